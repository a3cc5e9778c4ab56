"""Scene loading: both spellings, parameters, meshes, and an error for every bad input."""

import re

import numpy as np
import pytest

import scenes as S
import volpath
from volpath.meshes import load_mesh, write_ply

LAJOLLA = """<?xml version="1.0"?>
<scene version="0.5.0">
    <integrator type="volpath">
        <integer name="maxDepth" value="6"/>
        <integer name="rrDepth" value="3"/>
        <integer name="version" value="4"/>
        <integer name="maxNullCollisions" value="500"/>
        <boolean name="light_distances" value="false"/>
    </integrator>
    <medium type="homogeneous" id="medium">
        <rgb name="sigmaA" value="0.5 0.5 0.5"/>
        <rgb name="sigmaS" value="1 1 1"/>
        <float name="scale" value="2"/>
        <phase type="hg"><float name="g" value="0.3"/></phase>
    </medium>
    <shape type="sphere">
        <point name="center" x="0" y="0" z="0"/>
        <float name="radius" value="1"/>
        <ref name="interior" id="medium"/>
        <bsdf type="null"/>
    </shape>
    <shape type="sphere">
        <point name="center" x="1" y="3" z="1"/>
        <float name="radius" value="0.3"/>
        <emitter type="area"><srgb name="radiance" value="1, 1, 1"/></emitter>
    </shape>
    <sensor type="perspective">
        <string name="fovAxis" value="y"/>
        <transform name="toWorld"><lookAt origin="0, 0, -4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <float name="fov" value="45"/>
        <sampler type="independent"><integer name="sampleCount" value="8"/></sampler>
        <film type="hdrfilm"><integer name="width" value="12"/><integer name="height" value="10"/>
            <rfilter type="box"/></film>
    </sensor>
</scene>"""

MITSUBA3 = S.scene(
    S.camera(res=12, spp=8),
    '<default name="sigma" value="2"/>',
    '<medium type="homogeneous" id="m"><float name="sigma_t" value="$sigma"/>'
    '<float name="albedo" value="0.5"/></medium>',
    S.medium_sphere("m"),
    S.point_light(),
)


def test_lajolla_spellings():
    scene = volpath.load_string(LAJOLLA)
    assert (scene.width, scene.height, scene.spp) == (12, 10, 8)
    assert scene.tracer == "nee_mis" and scene.max_depth == 6 and scene.rr_depth == 3
    assert scene.max_null_collisions == 500 and not scene.light_distances
    assert volpath.load_string(MITSUBA3).light_distances  # on by default
    m = scene.summary["media"][0]
    assert np.allclose(m["sigma_t"], 3.0) and np.allclose(m["albedo"], 2 / 3) and m["g"] == 0.3
    image = volpath.render(scene)
    assert image.shape == (10, 12, 3) and np.isfinite(image).all() and image.max() > 0


def test_mitsuba3_defaults_and_overrides():
    scene = volpath.load_string(MITSUBA3)
    assert scene.summary["media"][0]["sigma_t"] == [2.0] * 3
    scene = volpath.load_string(MITSUBA3, sigma=5)
    assert scene.summary["media"][0]["sigma_t"] == [5.0] * 3
    assert scene.tracer == "auto"


def test_load_file_and_meshes(tmp_path):
    p = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
    write_ply(tmp_path / "quad.ply", p, [[0, 1, 2], [0, 2, 3]])
    (tmp_path / "quad.obj").write_text("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n")
    xml = S.scene(
        S.camera(res=8),
        '<default name="spp" value="4"/>',
        '<shape type="ply"><string name="filename" value="quad.ply"/>'
        '<emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>',
        '<shape type="obj"><string name="filename" value="quad.obj"/>'
        '<transform name="to_world"><translate z="-1"/></transform></shape>',
    )
    (tmp_path / "s.xml").write_text(xml)
    scene = volpath.load_file(tmp_path / "s.xml")
    assert [s["triangles"] for s in scene.summary["shapes"]] == [2, 2]
    image = volpath.render(scene, spp=4)
    # The emitting quad fills the view: radiance 1 where it is seen.
    assert abs(image[4, 4, 0] - 1) < 1e-6


def _ply(path, order, faces, extra_face_prop=False):
    """A binary PLY of four vertices whose faces are the given index lists."""
    o = "<" if order == "little" else ">"
    head = [
        "ply",
        f"format binary_{order}_endian 1.0",
        "element vertex 4",
        "property float x",
        "property float y",
        "property float z",
        f"element face {len(faces)}",
        "property list uchar int vertex_indices",
    ] + (["property uchar flags"] if extra_face_prop else [])
    body = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], o + "f4").tobytes()
    for f in faces:
        body += np.array([len(f)], "u1").tobytes() + np.array(f, o + "i4").tobytes()
        body += b"\x07" if extra_face_prop else b""
    path.write_bytes(("\n".join(head + ["end_header"]) + "\n").encode() + body)
    return path


@pytest.mark.parametrize("order", ["little", "big"])
@pytest.mark.parametrize(
    "faces",
    [[[0, 1, 2], [0, 2, 3]], [[0, 1, 2, 3]], [[0, 1, 2, 3], [0, 1, 2]], [[3, 2, 1, 0], [0, 1, 2, 3], [1, 2, 3]]],
)
@pytest.mark.parametrize("extra", [False, True])
def test_binary_ply_faces_fan_triangulated(tmp_path, order, faces, extra):
    # One structured read when every face has one size, a row-by-row walk otherwise:
    # both fan-triangulate each polygon in order and skip the face's other properties.
    triangles = load_mesh(str(_ply(tmp_path / "m.ply", order, faces, extra))).triangles
    expected = [[f[0], f[i], f[i + 1]] for f in faces for i in range(1, len(f) - 1)]
    assert triangles.tolist() == expected


def test_transforms_compose_in_order():
    # scale then translate: the rectangle ends up 10 wide centred at z=-3.
    xml = S.scene(S.camera(res=8, fov=10), S.back_light(z=-3, size=10, radiance="2, 2, 2"))
    image = volpath.render(volpath.load_string(xml), spp=1)
    assert np.allclose(image, 2.0)


BAD = {
    "unknown plugin": (S.scene(S.camera(), '<shape type="teapot"/>'), r"<string>:\d+: .*unknown shape"),
    "unknown parameter": (
        S.scene(S.camera(), '<shape type="sphere"><float name="radios" value="1"/></shape>'),
        r"<string>:\d+: .*unexpected parameter.*radios",
    ),
    "malformed number": (
        S.scene(S.camera(), '<shape type="sphere"><float name="radius" value="1.x"/></shape>'),
        r"<string>:\d+: malformed number '1.x'",
    ),
    "dangling ref": (
        S.scene(S.camera(), '<shape type="sphere"><ref name="interior" id="fog"/></shape>'),
        r"<string>:\d+: reference to unknown id 'fog'",
    ),
    "missing file": (
        S.scene(S.camera(), '<shape type="obj"><string name="filename" value="nope.obj"/></shape>'),
        r"<string>:\d+: .*'nope.obj' not found",
    ),
    "malformed xml": ("<scene version='3.0.0'><shape type='sphere'></scene>", r"<string>:1: malformed XML"),
    "undefined parameter": (
        S.scene(S.camera(), '<shape type="sphere"><float name="radius" value="$r"/></shape>'),
        r"<string>:\d+: undefined parameter \$r",
    ),
    "wrong type": (
        S.scene(S.camera(), '<shape type="sphere"><string name="radius" value="big"/></shape>'),
        r"<string>:\d+: .*'radius' must be a float",
    ),
    "no sensor": (S.scene('<shape type="sphere"/>'), r"no sensor"),
    "bad rgb": (
        S.scene(
            S.camera(),
            '<shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="1, 2"/></bsdf></shape>',
        ),
        r"<string>:\d+: rgb '1, 2': expected 3 numbers",
    ),
    "negative radius": (
        S.scene(S.camera(), '<shape type="sphere"><float name="radius" value="-1"/></shape>'),
        r"<string>:\d+: .*'radius' must be positive",
    ),
    "bad film": (S.scene(S.camera(res=0)), r"<string>:\d+: .*film size"),
    "area emitter alone": (S.scene(S.camera(), '<emitter type="area"/>'), r"<string>:\d+: .*nested inside a shape"),
    "stretched sphere": (
        S.scene(S.camera(), '<shape type="sphere"><transform name="to_world"><scale x="2"/></transform></shape>'),
        r"<string>:\d+: .*must be a similarity",
    ),
    "emission map on a sphere": (
        S.scene(
            S.camera(),
            '<shape type="sphere"><emitter type="area"><texture type="checkerboard" name="radiance"/></emitter>'
            "</shape>",
        ),
        r"<string>:\d+: .*emission map needs a mesh",
    ),
    "unknown element": (
        S.scene(S.camera(), '<shape type="sphere"><colour name="x" value="1"/></shape>'),
        r"<string>:\d+: unknown element <colour>",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_raises_scene_error(case):
    xml, pattern = BAD[case]
    with pytest.raises(volpath.SceneError, match=pattern):
        volpath.load_string(xml)


def test_error_names_the_file_and_line(tmp_path):
    path = tmp_path / "bad.xml"
    path.write_text(
        '<scene version="3.0.0">\n\n  <shape type="sphere">\n    <float name="radius" value="abc"/>\n  </shape>\n</scene>\n'
    )
    with pytest.raises(volpath.SceneError) as e:
        volpath.load_file(path)
    assert str(e.value).startswith(f"{path}:4: malformed number 'abc'")


def test_unused_override_is_an_error():
    with pytest.raises(volpath.SceneError, match="neither declares nor uses"):
        volpath.load_string(MITSUBA3, sigmaa=3)


def test_bad_grid_files(tmp_path):
    from volpath.grids import write_vol

    write_vol(tmp_path / "ok.vol", np.ones((2, 2, 2)))
    data = (tmp_path / "ok.vol").read_bytes()
    (tmp_path / "short.vol").write_bytes(data[:-8])
    write_vol(tmp_path / "nan.vol", np.full((2, 2, 2), np.nan))
    huge = bytearray(data[:48])
    huge[8:12] = (1 << 30).to_bytes(4, "little")
    (tmp_path / "huge.vol").write_bytes(bytes(huge))
    for name, msg in [("short", "truncated"), ("nan", "NaN"), ("huge", "larger than the limit")]:
        xml = S.scene(
            S.camera(),
            f'<medium type="heterogeneous" id="m"><volume type="gridvolume" name="sigma_t">'
            f'<string name="filename" value="{name}.vol"/></volume></medium>',
            S.medium_cube("m"),
        )
        with pytest.raises(volpath.SceneError, match=msg):
            volpath.load_string(xml, base_dir=str(tmp_path))


def test_load_dict_in_mitsubas_dictionary_form():
    to_world = np.diag([-1.0, 1.0, -1.0, 1.0])
    to_world[2, 3] = 5  # at z = 5 looking down -z
    scene = volpath.load_dict(
        {
            "type": "scene",
            "sensor": {
                "type": "perspective",
                "fov": 40.0,
                "to_world": to_world,
                "film": {"type": "hdrfilm", "width": 8, "height": 8, "rfilter": {"type": "box"}},
                "sampler": {"type": "independent", "sample_count": 4},
            },
            "fog": {"type": "homogeneous", "sigma_t": 1.0, "albedo": 0.0},
            "ball": {
                "type": "sphere",
                "radius": 1.0,
                "bsdf": {"type": "null"},
                "interior": {"type": "ref", "id": "fog"},
            },
            "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [1, 1, 1]}},
        }
    )
    image = volpath.render(scene)
    assert scene.spp == 4 and image.shape == (8, 8, 3)
    assert np.allclose(image[0, 0], 1) and image[4, 4, 0] < 0.2  # through the sphere: about exp(-2)
    with pytest.raises(volpath.SceneError, match="'radius' must be a float"):
        volpath.load_dict({"type": "scene", "s": {"type": "sphere", "radius": "big"}})


def test_old_spellings_that_change_nothing_load_with_a_warning_naming_file_and_line(tmp_path):
    """Mitsuba 0.5's heterogeneous `method` and `step_size`, and a pinhole's
    `focus_distance`: a SceneWarning each, with file:line, in the summary too; a misspelt
    parameter stays an error."""
    from volpath.grids import write_vol

    write_vol(tmp_path / "d.vol", np.ones((2, 2, 2)))
    xml = S.scene(
        S.camera(extra='<float name="focus_distance" value="3"/>'),
        '<medium type="heterogeneous" id="m"><string name="method" value="woodcock"/>'
        '<float name="step_size" value="0.1"/>'
        '<volume type="gridvolume" name="density"><string name="filename" value="d.vol"/></volume></medium>',
        S.medium_cube("m"),
    )
    with pytest.warns(volpath.SceneWarning) as caught:
        scene = volpath.load_string(xml, base_dir=str(tmp_path))
    messages = [str(w.message) for w in caught]
    assert len(messages) == 3 and scene.summary["warnings"] == messages
    assert all(re.match(r"<string>:\d+: ", m) for m in messages), messages
    assert any("'focus_distance' ignored" in m for m in messages) and any("'step_size' ignored" in m for m in messages)
    with pytest.raises(volpath.SceneError, match="unexpected parameter.*'step_sise'"):
        volpath.load_string(xml.replace("step_size", "step_sise"), base_dir=str(tmp_path))


def test_negative_voxels_are_clamped_and_counted(tmp_path):
    from volpath.grids import write_vol

    data = np.ones((2, 2, 2))
    data[0, 0, :] = -0.01  # what filtering leaves
    write_vol(tmp_path / "neg.vol", data)
    xml = S.scene(
        S.camera(res=8, spp=4),
        '<medium type="heterogeneous" id="m"><volume type="gridvolume" name="sigma_t">'
        '<string name="filename" value="neg.vol"/></volume></medium>',
        S.medium_cube("m"),
    )
    with pytest.warns(volpath.SceneWarning, match="neg.vol: 2 negative voxels clamped to 0"):
        scene = volpath.load_string(xml, base_dir=str(tmp_path))
    assert scene.summary["media"][0]["sigma_t_range"][0] == 0
    assert np.all(np.isfinite(volpath.render(scene)))
    array = -np.ones((2, 2, 2), np.float32)
    with pytest.warns(volpath.SceneWarning, match="8 negative voxels"):
        grid = volpath.VolumeGrid.from_numpy(array)
    assert grid.min() == 0 and np.all(array == -1)  # the caller's array is left as it was


def test_roughdielectric_loads_as_mitsuba_and_lajolla_write_it():
    """Mitsuba's default distribution (Beckmann) renders as GGX, with a warning; named
    IORs; anisotropic roughness is refused."""
    glass = '<shape type="sphere"><bsdf type="roughdielectric"><string name="int_ior" value="water"/>{}</bsdf></shape>'
    with pytest.warns(volpath.SceneWarning, match="GGX distribution stands in for Beckmann"):
        scene = volpath.load_string(S.scene(S.camera(res=4), glass.format('<float name="alpha" value="0.2"/>')))
    assert np.all(np.isfinite(volpath.render(scene, spp=4)))
    assert [b["type"] for b in scene.summary["bsdfs"]] == ["roughdielectric"]  # what volpath info lists
    ggx = '<string name="distribution" value="ggx"/><float name="alpha_u" value="0.2"/><float name="alpha_v" value="0.2"/>'
    assert volpath.load_string(S.scene(S.camera(res=4), glass.format(ggx))).summary["warnings"] == []
    aniso = '<string name="distribution" value="ggx"/><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/>'
    with pytest.raises(volpath.SceneError, match=r"<string>:\d+: .*anisotropic"):
        volpath.load_string(S.scene(S.camera(res=4), glass.format(aniso)))


def test_named_conductors_reflect_their_measured_index():
    """Mitsuba's named metals from measured eta and k (volpath/data/metals.json): a smooth
    conductor's sample weight head-on is the Fresnel reflectance of the table's index at
    the wavelengths RGB stands for; gold reflects red most and blue least. Unknown names,
    and a name with an explicit index, are errors naming the place."""
    from volpath import _probes, metals
    from volpath.plugins.params import RGB_WAVELENGTHS

    metal = '<shape type="sphere"><bsdf type="conductor"><string name="material" value="{}"/>{}</bsdf></shape>'
    u = np.random.default_rng(1).random((8, 3))
    for name in ("Au", "Ag", "Cu_palik"):
        scene = volpath.load_string(S.scene(S.camera(res=4), metal.format(name, "")))
        weight = _probes.bsdf_sample_weight(scene.native, 0, (0.0, 0.0, 1.0), u).mean(axis=0)
        eta, k = metals.eta_k(name, RGB_WAVELENGTHS)
        eta, k = eta / 1.000277, k / 1.000277
        np.testing.assert_allclose(weight, ((eta - 1) ** 2 + k**2) / ((eta + 1) ** 2 + k**2), rtol=1e-6)
        if name == "Au":
            assert weight[0] > weight[1] > weight[2] and weight[0] > 0.9 and weight[2] < 0.5
    with pytest.raises(volpath.SceneError, match=r"<string>:\d+: .*unknown conductor material 'Unobtainium'.*Au"):
        volpath.load_string(S.scene(S.camera(res=4), metal.format("Unobtainium", "")))
    with pytest.raises(volpath.SceneError, match="either 'material' or 'eta' and 'k'"):
        volpath.load_string(S.scene(S.camera(res=4), metal.format("Au", '<rgb name="k" value="1, 1, 1"/>')))


def test_loading_gives_the_cycle_collector_back_as_it_found_it():
    """The collector is paused while a scene loads; after a load that fails it runs again,
    and a caller who had paused it finds it paused still."""
    import gc

    with pytest.raises(volpath.SceneError):
        volpath.load_string('<scene version="3.0.0"><shape type="nonsense"/></scene>')
    assert gc.isenabled()
    gc.disable()
    try:
        volpath.load_string(S.scene(S.camera(res=4)))
        assert not gc.isenabled()
    finally:
        gc.enable()
