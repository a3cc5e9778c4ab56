"""Shape groups and instances (Mitsuba's shapegroup and instance): hits through a map with
rotation, non-uniform scale and mirroring are the flattened copy's; renders agree with it
within noise; instances share their group's memory; what a group may not hold is refused;
instances moved between frames (Scene.update, the BVH refit) and over the shutter (motion
blur)."""

import re

import numpy as np
import pytest

import scenes as S
import volpath
from volpath import _probes
from volpath.plugins.shapes import transform_normals, transform_points
from volpath.testing import MIN_BATCHES, max_z, render_batches


def rotation(axis, degrees):
    a = np.radians(degrees)
    c, s = np.cos(a), np.sin(a)
    i, j = [k for k in range(3) if k != axis]
    m = np.eye(4)
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def placed(scale, translate, rotations=()):
    m = np.diag([*scale, 1.0])
    for axis, degrees in rotations:
        m = rotation(axis, degrees) @ m
    m[:3, 3] = translate
    return m


# A rotated, non-uniformly scaled and moved map, and one that also mirrors.
STRETCHED = placed([1.0, 2.5, 0.6], [0.4, -0.3, 0.2], [(2, 30), (0, 50)])
MIRRORED = placed([-1.2, 0.8, 1.0], [-0.5, 0.1, 0.0], [(1, 20)])


def bump():
    """A smooth bumpy patch with normals and texture coordinates (local space)."""
    u, v = np.meshgrid(np.linspace(-1, 1, 17), np.linspace(-1, 1, 17))
    z = 0.3 * np.sin(3 * u) * np.cos(2 * v)
    positions = np.stack([u, v, z], axis=-1).reshape(-1, 3)
    dz_du, dz_dv = 0.9 * np.cos(3 * u) * np.cos(2 * v), -0.6 * np.sin(3 * u) * np.sin(2 * v)
    normals = np.stack([-dz_du, -dz_dv, np.ones_like(u)], axis=-1).reshape(-1, 3)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    k = np.arange(17 * 17).reshape(17, 17)[:-1, :-1].ravel()
    triangles = np.concatenate([np.stack([k, k + 1, k + 18], 1), np.stack([k, k + 18, k + 17], 1)]).astype(np.uint32)
    uvs = np.stack([(u + 1) / 2, (v + 1) / 2], axis=-1).reshape(-1, 2)
    return positions, triangles, normals, uvs


def mesh(positions, triangles, normals, uvs, bsdf):
    return {"type": "mesh", "positions": positions, "indices": triangles, "normals": normals, "uvs": uvs, "bsdf": bsdf}


def sensor(res, spp):
    """The tests' camera, looking down at the origin from -y."""
    return {
        "type": "perspective",
        "fov": 50.0,
        "to_world": S.lookat([0, -6, 4], [0, 0, 0], [0, 0, 1]),
        "film": {"type": "hdrfilm", "width": res, "height": res},
        "sampler": {"type": "independent", "sample_count": spp},
    }


def scene_pair(maps, res=24, spp=8):
    """The same objects as instances of one group, and flattened into world-space meshes."""
    positions, triangles, normals, uvs = bump()
    red = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.8, 0.3, 0.2]}}
    base = {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": 4},
        "sensor": sensor(res, spp),
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}},
        "floor": {"type": "rectangle", "to_world": placed([6.0, 6.0, 1.0], [0.0, 0.0, -1.5])},
    }
    instanced = dict(base, group={"type": "shapegroup", "bump": mesh(positions, triangles, normals, uvs, red)})
    flat = dict(base)
    for k, m in enumerate(maps):
        instanced[f"i{k}"] = {"type": "instance", "group": {"type": "ref", "id": "group"}, "to_world": m}
        flat[f"m{k}"] = mesh(transform_points(m, positions), triangles, transform_normals(m, normals), uvs, red)
    return volpath.load_dict(instanced), volpath.load_dict(flat)


def random_rays(n, seed):
    rng = np.random.default_rng(seed)
    origins = rng.normal(size=(n, 3)) * 0.5 + [0, -6, 3]
    targets = rng.uniform(-2.5, 2.5, size=(n, 3)) * [1, 1, 0.5]
    return origins, targets - origins


@pytest.mark.parametrize("m", [STRETCHED, MIRRORED], ids=["stretched", "mirrored"])
def test_hits_are_the_flattened_copys(m):
    """Distances, normals and texture coordinates through an instance match a world-space
    copy of the mesh to rounding (1e-9): the map is exact, not an approximation."""
    instanced, flat = scene_pair([m])
    o, d = random_rays(4000, 1)
    t_i, shape_i, n_i = _probes.intersect(instanced.native, o, d)
    t_f, shape_f, n_f = _probes.intersect(flat.native, o, d)
    hit = np.isfinite(t_f)
    assert hit.sum() > 500 and (shape_f[hit] == 1).sum() > 300  # the bump is hit, not only the floor
    np.testing.assert_array_equal(np.isfinite(t_i), hit)
    np.testing.assert_allclose(t_i[hit], t_f[hit], rtol=1e-9)
    np.testing.assert_allclose(n_i[hit], n_f[hit], atol=1e-9)  # mirrored: faces turn as the copy's
    uv_i, uv_f = _probes.surface_uv(instanced.native, o, d), _probes.surface_uv(flat.native, o, d)
    np.testing.assert_allclose(uv_i[hit], uv_f[hit], atol=1e-9)


def test_renders_agree_with_the_flattened_copy():
    """Three instances (one mirrored) against three world-space copies: 4x4-pixel block
    means within 4.5 standard errors (of 36 blocks, a false alarm has probability ~2e-4);
    the paths differ only by rounding, which changes their random choices."""
    maps = [STRETCHED, MIRRORED, placed([0.5, 0.5, 0.5], [1.5, 1.0, 0.5])]
    instanced, flat = scene_pair(maps)
    a = render_batches(volpath.render, instanced, MIN_BATCHES, block=4)
    b = render_batches(volpath.render, flat, MIN_BATCHES, block=4)
    assert max_z(*a, *b) < 4.5


def test_instanced_render_is_reproducible_across_thread_counts():
    instanced, _ = scene_pair([STRETCHED, MIRRORED])
    np.testing.assert_array_equal(
        volpath.render(instanced, seed=3, threads=1), volpath.render(instanced, seed=3, threads=2)
    )


def test_instances_share_their_groups_memory():
    """200 instances hold their maps and a top-level BVH; the group's triangles once."""
    maps = [placed([0.2] * 3, [x, y, 0.0]) for x in np.linspace(-2, 2, 20) for y in np.linspace(-2, 2, 10)]
    instanced, flat = scene_pair(maps)
    mi, mf = instanced.memory, flat.memory
    assert mi["shapes"] + mi["bvh"] < 0.1 * (mf["shapes"] + mf["bvh"])
    assert "200 instances" in repr(instanced.native)


GROUP = '<shape type="shapegroup" id="g">{}</shape>'
INSTANCE = '<shape type="instance">{}</shape>'
CUBE = '<shape type="cube"/>'


@pytest.mark.parametrize(
    "body, message",
    [
        (GROUP.format('<shape type="sphere"/>') + INSTANCE.format('<ref id="g"/>'), "meshes only"),
        (
            GROUP.format('<shape type="cube"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>'),
            "neither emit nor bound a medium",
        ),
        (GROUP.format(GROUP.replace('id="g"', 'id="h"').format(CUBE)), "do not nest"),
        (GROUP.format(CUBE) + INSTANCE.format(""), "exactly one shapegroup"),
        ('<shape type="cube" id="c"/>' + INSTANCE.format('<ref id="c"/>'), "names a shapegroup"),
        (
            GROUP.format(CUBE) + INSTANCE.format('<ref id="g"/><transform name="to_world"><scale z="0"/></transform>'),
            "singular",
        ),
    ],
    ids=["sphere", "emitter", "nested", "no-group", "not-a-group", "singular"],
)
def test_what_a_group_may_not_hold_is_refused_with_its_line(body, message):
    with pytest.raises(volpath.SceneError, match=message) as e:
        volpath.load_string(S.scene(S.camera(res=4), body))
    assert re.match(r"<string>:\d+: ", str(e.value)), "the message names the line"


def test_a_field_of_instances_names_the_one_whose_transform_fails():
    """Instances reach the core in one call after their transforms are checked together:
    the error still names the line of the one that fails."""
    good = INSTANCE.format('<ref id="g"/><transform name="to_world"><translate x="1"/></transform>')
    bad = INSTANCE.format('<ref id="g"/><transform name="to_world"><scale y="0"/></transform>')
    xml = S.scene(S.camera(res=4), GROUP.format(CUBE) + "\n" + good + "\n" + bad + "\n" + good)
    line = next(i for i, text in enumerate(xml.splitlines(), 1) if 'scale y="0"' in text)
    with pytest.raises(volpath.SceneError, match=f"^<string>:{line}: .*singular"):
        volpath.load_string(xml)


def test_occlusion_queries_agree_with_the_closest_hit():
    """Geometry::occluded, the shadow rays' any-hit query, stops at the first hit it finds
    (in the scene's BVH or an instance's): it reports a hit before t_max exactly where the
    closest hit lies before t_max, for t_max just short of and just past that hit."""
    instanced, flat = scene_pair([STRETCHED, MIRRORED, placed([0.5, 0.5, 0.5], [1.5, 1.0, 0.5])])
    o, d = random_rays(4000, 2)
    for scene in (instanced, flat):
        t, _, _ = _probes.intersect(scene.native, o, d)
        hit = np.isfinite(t)
        assert hit.sum() > 500 and (~hit).sum() > 100  # both kinds of ray
        far = np.where(hit, t, 1e3)
        assert np.array_equal(_probes.occluded(scene.native, o, d, np.full(len(t), np.inf)), hit)
        assert np.array_equal(_probes.occluded(scene.native, o, d, far * (1 + 1e-9)), hit)
        assert not _probes.occluded(scene.native, o, d, far * (1 - 1e-9)).any()


def test_shadow_rays_decide_alike_by_any_hit_and_closest_hit():
    """Where every shape stops shadow rays, they stop at the first hit found; one shape that
    lets them through (out of every ray's way) sends them back to the closest hit. The
    image is the same bit for bit: both decide each shadow ray alike."""
    maps = [STRETCHED, MIRRORED, placed([0.5, 0.5, 0.5], [1.5, 1.0, 0.5])]
    d = scene_pair(maps, res=16)[0]._builder.d
    aside = {"type": "rectangle", "to_world": placed([0.1, 0.1, 1.0], [0.0, 0.0, -50.0]), "hidden_from": "shadow"}
    any_hit, closest = volpath.load_dict(d), volpath.load_dict(dict(d, aside=aside))
    assert _probes.shadows_stop_at_any_hit(any_hit.native) and not _probes.shadows_stop_at_any_hit(closest.native)
    np.testing.assert_array_equal(volpath.render(any_hit, seed=4), volpath.render(closest, seed=4))


def field(maps, group):
    """A floor and a field of instances of `group` (a shapegroup dictionary), one per map."""
    d = {
        "type": "scene",
        "sensor": {"type": "perspective", "to_world": S.lookat([0, -6, 4], [0, 0, 0], [0, 0, 1])},
        "floor": {"type": "rectangle", "to_world": placed([6.0, 6.0, 1.0], [0.0, 0.0, -1.5])},
        "group": group,
    }
    for k, m in enumerate(maps):
        d[f"i{k}"] = {"type": "instance", "group": {"type": "ref", "id": "group"}, "to_world": m}
    return d


def assert_same_hits(a, b, seed):
    o, d = random_rays(4000, seed)
    hits_a, hits_b = _probes.intersect(a.native, o, d), _probes.intersect(b.native, o, d)
    for x, y in zip(hits_a, hits_b):
        np.testing.assert_array_equal(x, y)
    return hits_a


def test_moved_instances_find_the_hits_of_a_fresh_build():
    """Scene.update moves instances by refitting the BVH (the tree kept, the bounds made
    to fit): frame after frame, as the instances cross the scene (one of them mirrored, one
    leaving the others' region), rays find exactly what a scene loaded afresh finds."""
    positions, triangles, normals, uvs = bump()
    group = {"type": "shapegroup", "bump": mesh(positions, triangles, normals, uvs, {"type": "diffuse"})}
    rng = np.random.default_rng(4)
    maps = [placed([0.3, 0.3, 0.3], [x, y, 0.0]) for x, y in rng.uniform(-2, 2, (40, 2))]
    d = field(maps, group)
    scene = volpath.load_dict(d)
    bvh = scene.memory["bvh"]
    for frame in range(4):
        d = dict(d)
        d["i0"] = dict(d["i0"], to_world=placed([0.3, 0.3, 0.3], [-2 + 1.3 * frame, 0.5, 0.2 * frame]))
        d["i1"] = dict(d["i1"], to_world=MIRRORED @ placed([0.5, 0.5, 0.5], [0, 0, 0.3 * frame]))
        d["i2"] = dict(d["i2"], to_world=placed([0.4, 0.4, 0.4], [0, 0, 3.0 * frame]))  # rises away
        assert scene.update(d)
        t, shape, _ = assert_same_hits(scene, volpath.load_dict(d), seed=frame)
        assert (shape == 1).sum() > 300  # the instances are hit, not only the floor
    assert scene.memory["bvh"] == bvh  # refit in place: not a node more


def test_a_deformed_group_mesh_finds_the_hits_of_a_fresh_build():
    """A shape group's mesh replaced (a deformed mesh's next frame): that group's BVH is
    built again and the scene's refit around its instances' new bounds."""
    positions, triangles, normals, uvs = bump()
    maps = [placed([0.5, 0.5, 0.5], [x, 0.0, 0.0]) for x in (-1.5, 0.0, 1.5)]
    d = field(maps, {"type": "shapegroup", "bump": mesh(positions, triangles, normals, uvs, {"type": "diffuse"})})
    scene = volpath.load_dict(d)
    for frame in range(1, 3):
        stretched = positions * [1.0, 1.0 + frame, 2.0 * frame]
        d = dict(d, group={"type": "shapegroup", "bump": mesh(stretched, triangles, normals, uvs, {"type": "diffuse"})})
        assert scene.update(d)
        assert_same_hits(scene, volpath.load_dict(d), seed=frame)


# Motion blur: instances and the camera moved over the shutter by motion keys (a map at
# evenly spaced times, interpolated linearly between them), each camera ray drawing its
# time and every ray of its path keeping it.


def moving(d, key, keys):
    """The scene dictionary with entry `key` given motion keys (and placed at the first)."""
    return dict(d, **{key: dict(d[key], to_world=keys[0], motion=np.array(keys))})


def group_scene(keys, res=24, spp=8, sky=1.0):
    """A bumpy mesh on a floor of its own (the floor's bounce and shadow rays meet the mesh)
    as an instance under a white sky and a sun, moved by `keys`, or still where there is one
    key."""
    positions, triangles, normals, uvs = bump()
    d = {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": 4},
        "sensor": sensor(res, spp),
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [sky, sky, sky]}},
        "sun": {
            "type": "directional",
            "direction": [0.4, 0.3, -1.0],
            "irradiance": {"type": "rgb", "value": [3, 3, 3]},
        },
        "group": {
            "type": "shapegroup",
            "bump": mesh(positions, triangles, normals, uvs, {"type": "diffuse"}),
            "floor": {"type": "rectangle", "to_world": placed([2.5, 2.5, 1.0], [0.0, 0.0, -0.4])},
        },
        "bump": {"type": "instance", "group": {"type": "ref", "id": "group"}, "to_world": keys[0]},
    }
    return moving(d, "bump", keys) if len(keys) > 1 else d


@pytest.mark.parametrize("time", [0.0, 0.3, 0.5, 0.9])
def test_a_moving_instance_is_hit_where_its_keys_put_it_at_the_ray_s_time(time):
    """Rays at time t meet a moving instance (stretched, then mirrored: its faces turn) where
    a still instance placed by the keys interpolated at t is met, to rounding."""
    keys = [STRETCHED, placed([1.0, 1.0, 1.0], [0.5, 0.2, 0.1]), MIRRORED]
    x = time * 2
    i = min(int(x), 1)
    still = (1 - (x - i)) * keys[i] + (x - i) * keys[i + 1]
    a, b = volpath.load_dict(group_scene(keys)), volpath.load_dict(group_scene([still]))
    o, d = random_rays(4000, 3)
    t_a, shape_a, n_a = _probes.intersect(a.native, o, d, time=time)
    t_b, shape_b, n_b = _probes.intersect(b.native, o, d)
    hit = np.isfinite(t_b)
    assert hit.sum() > 200  # (of 4000 rays, the mesh alone in the scene)
    np.testing.assert_array_equal(np.isfinite(t_a), hit)
    np.testing.assert_allclose(t_a[hit], t_b[hit], rtol=1e-9)
    np.testing.assert_allclose(n_a[hit], n_b[hit], atol=1e-9)


def test_a_camera_moving_with_its_subject_sees_it_still():
    """The camera and the mesh carried by the same motion under a uniform sky: the blurred
    image is the still one's (4x4-block means within 4.5 standard errors, of 36 blocks a false
    alarm ~2e-4). Shadow and bounce rays that took another time than their camera ray would
    put its shadows and hollows where the mesh is not."""
    shift = [placed([1.0, 1.0, 1.0], [x, 0.0, 0.6 * x]) for x in (0.0, 0.8, 2.0)]
    still = group_scene([np.eye(4)])
    d = group_scene(shift)
    d["sensor"] = dict(d["sensor"], motion=np.array([m @ d["sensor"]["to_world"] for m in shift]))
    d["sensor"]["to_world"] = d["sensor"]["motion"][0]
    a = render_batches(volpath.render, volpath.load_dict(d), MIN_BATCHES, block=4)
    b = render_batches(volpath.render, volpath.load_dict(still), MIN_BATCHES, block=4)
    assert max_z(*a, *b) < 4.5


def test_a_moving_instance_leaves_a_streak_whose_mean_is_its_still_mean():
    """A mesh crossing the view under a white sky and a sun (its radiance the same wherever it is):
    the blurred image's mean is the mean of the image at the shutter's middle within 4.5
    standard errors; the path between its ends is partly covered; it renders the same
    bits on one thread and on two."""
    keys = [placed([0.4, 0.4, 0.4], [x, 0.0, 0.0]) for x in (-1.5, 0.0, 1.5)]
    blurred, middle = volpath.load_dict(group_scene(keys)), volpath.load_dict(group_scene([keys[1]]))
    a = render_batches(volpath.render, blurred, MIN_BATCHES, block=24)
    b = render_batches(volpath.render, middle, MIN_BATCHES, block=24)
    assert max_z(*a, *b) < 4.5
    image = volpath.render(blurred, spp=64, seed=1)
    np.testing.assert_array_equal(image, volpath.render(blurred, spp=64, seed=1, threads=1))


def test_motion_keys_round_trip_through_xml_and_are_checked(tmp_path):
    """`motion` is written as Mitsuba 0.6's <animation> of evenly spaced <transform time=...>
    keys and read back; fewer than two keys, or uneven times, are refused with the line."""
    from volpath.xml_reader import read_xml
    from volpath.xml_writer import write_scene

    keys = [placed([0.4, 0.4, 0.4], [x, 0.0, 0.0]) for x in (-1.5, 0.0, 1.5)]
    d = group_scene(keys)
    path = write_scene(d, tmp_path)
    text = open(path).read()
    assert '<animation name="motion">' in text and 'time="0.5"' in text
    np.testing.assert_array_equal(read_xml(text, path)["bump"]["motion"], np.array(keys))
    np.testing.assert_array_equal(
        volpath.render(volpath.load_file(path), seed=2), volpath.render(volpath.load_dict(d), seed=2)
    )
    uneven = text.replace('time="0.5"', 'time="0.7"')
    with pytest.raises(volpath.SceneError, match=r"scene.xml:\d+: an <animation>'s keys must be evenly spaced"):
        read_xml(uneven, path)
    with pytest.raises(volpath.SceneError, match="'motion' must be two or more 4x4 transforms"):
        volpath.load_dict(dict(d, bump=dict(d["bump"], motion=np.array(keys[:1]))))


@pytest.mark.parametrize("time", [0.0, 0.4, 0.75])
def test_a_deforming_group_mesh_is_hit_where_its_keys_put_it_at_the_ray_s_time(time, tmp_path):
    """A group's mesh with motion keys (its positions at the shutter's opening, middle and
    closing): rays at time t meet the mesh whose positions are the keys interpolated at t,
    to rounding, through the dictionary and through XML (a PLY a key)."""
    from volpath.xml_writer import write_scene

    positions, triangles, normals, uvs = bump()
    keys = [positions * [1.0, 1.0, s] + [0.0, 0.2 * s, 0.0] for s in (1.0, -1.0, 2.5)]
    x = time * 2
    i = min(int(x), 1)
    at_t = (1 - (x - i)) * keys[i] + (x - i) * keys[i + 1]

    def scene(positions, motion=None):
        member = mesh(positions, triangles, normals, uvs, {"type": "diffuse"})
        if motion is not None:
            member["motion"] = np.array(motion, dtype=np.float32)
        return field([STRETCHED], {"type": "shapegroup", "bump": member})

    deforming = scene(np.float32(keys[0]), keys)
    loaded = volpath.load_file(write_scene(deforming, tmp_path))
    still = volpath.load_dict(scene(np.float32(at_t)))
    o, d = random_rays(4000, 5)
    t_s, _, n_s = _probes.intersect(still.native, o, d)
    hit = np.isfinite(t_s)
    assert hit.sum() > 1000
    for s in (volpath.load_dict(deforming), loaded):
        t, _, n = _probes.intersect(s.native, o, d, time=time)
        np.testing.assert_array_equal(np.isfinite(t), hit)
        np.testing.assert_allclose(t[hit], t_s[hit], rtol=1e-6)  # float32 keys, interpolated in double
