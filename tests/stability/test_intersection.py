"""Property-based tests of ray intersection (hypothesis)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import scenes as S
import volpath
from volpath import _probes
from volpath.meshes import write_ply

coord = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
unit = st.floats(0.0, 1.0)


def mesh_scene(tmp_path, positions, triangles):
    write_ply(tmp_path / "m.ply", positions, triangles)
    return volpath.load_string(
        S.scene(
            S.camera(res=2),
            '<shape type="ply"><string name="filename" value="m.ply"/>'
            '<boolean name="face_normals" value="true"/></shape>',
        ),
        base_dir=str(tmp_path),
    )


@settings(max_examples=300, deadline=None)
@given(
    centre=st.tuples(coord, coord, coord),
    radius=st.floats(1e-2, 1e3),
    angles=st.lists(unit, min_size=4, max_size=4, unique=True),
    tilt=st.tuples(unit, unit),
    s=st.floats(0.02, 0.98),
    lift=st.floats(0.5, 100),
)
def test_shared_edges_are_watertight(tmp_path_factory, centre, radius, angles, tilt, s, lift):
    """Rays aimed at points on the diagonal shared by the two triangles of a convex
    planar quad never slip through, from any side and distance."""
    a = np.sort(np.array(angles)) * 2 * np.pi
    if np.min(np.diff(np.r_[a, a[0] + 2 * np.pi])) < 0.2 or np.max(np.diff(np.r_[a, a[0] + 2 * np.pi])) > np.pi - 0.2:
        return  # too thin a quad (or a triangle in disguise)
    z = 1 - 2 * tilt[0]
    normal = np.array(
        [np.sqrt(1 - z * z) * np.cos(2 * np.pi * tilt[1]), np.sqrt(1 - z * z) * np.sin(2 * np.pi * tilt[1]), z]
    )
    u = np.cross(normal, [1.0, 0, 0] if abs(normal[0]) < 0.9 else [0, 1.0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    p = np.array(centre) + radius * (np.cos(a)[:, None] * u + np.sin(a)[:, None] * v)
    p = p.astype(np.float32).astype(np.float64)  # what the PLY file stores
    scene = mesh_scene(tmp_path_factory.mktemp("w"), p, [[0, 1, 2], [0, 2, 3]])
    target = p[0] + s * (p[2] - p[0])  # on the shared edge
    rng = np.random.default_rng(int(s * 1e6))
    side = rng.choice([-1.0, 1.0], size=(16, 1))
    origins = target + lift * radius * (side * normal + 0.5 * rng.normal(size=(16, 3)))
    dirs = target - origins
    t, shape, _ = _probes.intersect(scene.native, origins, dirs)
    expected = np.linalg.norm(dirs, axis=1)
    assert np.all(shape == 0), "a ray slipped between the two triangles"
    assert np.all(np.abs(t - expected) <= 1e-9 * (1 + np.abs(origins).max() + expected))


@settings(max_examples=200, deadline=None)
@given(
    cx=st.floats(-1e7, 1e7),
    cy=st.floats(-1e7, 1e7),
    cz=st.floats(-1e7, 1e7),
    r=st.floats(0.01, 1e6),
    dist=st.floats(1.001, 100.0),
    theta=unit,
    phi=unit,
)
def test_spheres_far_from_the_origin(cx, cy, cz, r, dist, theta, phi):
    """A ray aimed at the centre of a sphere anywhere within 1e7 hits at dist - r, to
    1e-9 of the scene's scale (double precision throughout)."""
    c = np.array([cx, cy, cz])
    z = 1 - 2 * theta
    d = np.array([np.sqrt(1 - z * z) * np.cos(2 * np.pi * phi), np.sqrt(1 - z * z) * np.sin(2 * np.pi * phi), z])
    o = c + d * dist * r
    scene = volpath.load_string(
        S.scene(
            S.camera(res=2),
            f'<shape type="sphere"><point name="center" '
            f'value="{cx!r}, {cy!r}, {cz!r}"/><float name="radius" value="{r!r}"/></shape>',
        )
    )
    t, shape, _ = _probes.intersect(scene.native, o[None], -d[None])
    assert shape[0] == 0
    scale = np.abs(o).max() + r
    assert abs(t[0] - (dist - 1) * r) <= 1e-9 * scale


def _matrix_text(m):
    return f'<matrix value="{" ".join(repr(float(v)) for v in m.ravel())}"/>'


@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    log_scale=st.floats(-3, 4),
    offset=st.floats(-1e4, 1e4),
    aligned=st.booleans(),
    flip=st.booleans(),
)
def test_boxes_hit_like_their_twelve_triangles(seed, log_scale, offset, aligned, flip):
    """A `cube` is an analytic box: from inside and outside, axis-aligned or under any
    invertible affine map (rotation, shear, unequal scales), its hits and normals are those
    of the same cube as a triangle mesh, to 1e-9 of the scene's scale (the normals to 1e-9,
    or to the rounding of the mesh's own where a tiny cube sits far from the origin)."""
    rng = np.random.default_rng(seed)
    scale = 10.0**log_scale * rng.uniform(0.2, 1.0, 3)
    lin = np.diag(scale) if aligned else rng.normal(size=(3, 3)) * 10.0**log_scale
    if abs(np.linalg.det(lin)) < 1e-3 * np.abs(lin).max() ** 3:
        return  # nearly flat: such cubes stay meshes
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = lin, offset * rng.normal(size=3)
    from volpath.plugins.shapes import cube

    corners, triangles = cube()[:2]
    positions = corners @ lin.T + m[:3, 3]
    if flip:
        triangles = triangles[:, ::-1]
    flip_text = '<boolean name="flip_normals" value="true"/>' if flip else ""
    box = volpath.load_string(
        S.scene(
            S.camera(res=2),
            f'<shape type="cube"><transform name="to_world">{_matrix_text(m)}</transform>{flip_text}</shape>',
        )
    )
    assert box.summary["shapes"][0].get("box")
    mesh = volpath.load_dict(
        {
            "type": "scene",
            "sensor": {"type": "perspective"},
            "cube": {"type": "mesh", "positions": positions, "indices": triangles.astype(np.int64)},
        }
    )
    centre, size = m[:3, 3], np.abs(lin).sum(axis=1)
    inside = centre + (rng.uniform(-0.9, 0.9, (32, 3)) @ lin.T)
    outside = centre + size * rng.uniform(1.5, 3.0, (32, 3)) * rng.choice([-1.0, 1.0], (32, 3))
    origins = np.vstack([inside, outside])
    dirs = np.vstack([rng.normal(size=(32, 3)), centre + (rng.uniform(-0.9, 0.9, (32, 3)) @ lin.T) - outside])
    t_box, hit_box, n_box = _probes.intersect(box.native, origins, dirs)
    t_mesh, hit_mesh, n_mesh = _probes.intersect(mesh.native, origins, dirs)
    assert np.array_equal(hit_box, hit_mesh) and np.all(hit_box == 0)
    tol = 1e-9 * (np.abs(origins).max() + size.max())
    assert np.all(np.abs(t_box - t_mesh) <= tol)
    # The mesh's normals come from edges of vertices as far out as the offset, each rounded
    # by ~eps |p|: relative to the shortest edge, that error bounds the reference itself.
    tol_n = 1e-9 + 4 * np.finfo(float).eps * np.abs(positions).max() / np.linalg.svd(lin, compute_uv=False).min()
    assert np.all(np.abs(n_box - n_mesh) <= tol_n)


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), box=st.booleans(), inner=st.integers(0, 3))
def test_rays_inside_an_empty_container_hit_it_first(seed, box, inner):
    """A medium held by a sphere or box with nothing inside it is crossed with no BVH
    traversal (Scene::medium_container): rays travelling in that medium, from inside and
    from outside the container, hit what the full traversal hits. Shapes placed inside or
    through the container (a sphere, a quad, a second box) take the shortcut away."""
    rng = np.random.default_rng(seed)
    lin = np.diag(rng.uniform(0.5, 2.0, 3)) @ np.linalg.qr(rng.normal(size=(3, 3)))[0]
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = lin, rng.uniform(-1, 1, 3)
    medium = S.homogeneous("fog", 1.0, 0.5)
    if box:
        container = (
            f'<shape type="cube"><transform name="to_world">{_matrix_text(m)}</transform>'
            '<bsdf type="null"/><ref name="interior" id="fog"/></shape>'
        )
    else:
        c = m[:3, 3]
        container = (
            f'<shape type="sphere"><point name="center" value="{c[0]!r}, {c[1]!r}, {c[2]!r}"/>'
            '<float name="radius" value="1.5"/><bsdf type="null"/><ref name="interior" id="fog"/></shape>'
        )
    # Other shapes: far outside, or (for inner > 0) one reaching into the container.
    others = ['<shape type="sphere"><point name="center" value="0, 0, 9"/><float name="radius" value="1"/></shape>']
    inside = m[:3, 3] + lin @ rng.uniform(-0.3, 0.3, 3)
    if inner == 1:
        others.append(
            f'<shape type="sphere"><point name="center" value="{inside[0]!r}, {inside[1]!r}, {inside[2]!r}"/>'
            '<float name="radius" value="0.2"/></shape>'
        )
    elif inner == 2:
        q = np.eye(4)
        q[:3, :3], q[:3, 3] = rng.normal(size=(3, 3)) * 0.5, inside
        others.append(f'<shape type="rectangle"><transform name="to_world">{_matrix_text(q)}</transform></shape>')
    elif inner == 3:
        q = np.eye(4)
        q[:3, :3], q[:3, 3] = np.diag(rng.uniform(0.1, 0.3, 3)), inside
        others.append(f'<shape type="cube"><transform name="to_world">{_matrix_text(q)}</transform></shape>')
    native = volpath.load_string(S.scene(S.camera(res=2), medium, container, *others)).native
    assert (_probes.medium_containers(native)[0] == 0) == (inner == 0)
    origins = np.vstack([m[:3, 3] + rng.uniform(-0.7, 0.7, (48, 3)) @ lin.T, rng.uniform(-6, 6, (16, 3))])
    dirs = rng.normal(size=(64, 3))
    t_fast, shape_fast, n_fast = _probes.intersect(native, origins, dirs, 0)
    t, shape, n = _probes.intersect(native, origins, dirs)
    assert np.array_equal(shape_fast, shape)
    assert np.array_equal(t_fast, t) and np.array_equal(n_fast, n)


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), box=st.booleans(), aligned=st.booleans(), poke_out=st.booleans())
def test_rays_leaving_the_enclosure_meet_nothing_the_traversal_would(seed, box, aligned, poke_out):
    """A sphere or box holding every other shape (a fog box around the scene) is the
    scene's enclosure (Geometry::enclosure): rays outside it that move away skip the BVH.
    They must hit exactly what the full traversal hits, from inside, from outside and from
    just past its surface (where rays leaving it start); a shape poking out of it, or a
    shape touching its face from inside, leaves no room for error either."""
    rng = np.random.default_rng(seed)
    lin = np.diag(rng.uniform(0.5, 2.0, 3))
    if not aligned:
        lin = lin @ np.linalg.qr(rng.normal(size=(3, 3)))[0]
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = lin, rng.uniform(-1, 1, 3)
    if box:
        enclosure = (
            f'<shape type="cube"><transform name="to_world">{_matrix_text(m)}</transform><bsdf type="null"/></shape>'
        )
    else:
        c = m[:3, 3]
        enclosure = (
            f'<shape type="sphere"><point name="center" value="{c[0]!r}, {c[1]!r}, {c[2]!r}"/>'
            '<float name="radius" value="1.5"/><bsdf type="null"/></shape>'
        )
    inside = [m[:3, 3] + lin @ rng.uniform(-0.25, 0.25, 3) * (1 if box else 0.5) for _ in range(2)]
    q = np.eye(4)
    q[:3, :3], q[:3, 3] = rng.normal(size=(3, 3)) * 0.1, inside[1]
    others = [
        f'<shape type="sphere"><point name="center" value="{inside[0][0]!r}, {inside[0][1]!r}, {inside[0][2]!r}"/>'
        '<float name="radius" value="0.1"/></shape>',
        f'<shape type="rectangle"><transform name="to_world">{_matrix_text(q)}</transform></shape>',
    ]
    if poke_out:  # reaches from inside to far outside
        others.append(
            f'<shape type="sphere"><point name="center" value="{inside[0][0]!r}, {inside[0][1]!r}, {inside[0][2] + 4!r}"/>'
            '<float name="radius" value="0.3"/></shape>'
        )
    native = volpath.load_string(S.scene(S.camera(res=2), enclosure, *others)).native
    assert _probes.enclosure(native) == (-1 if poke_out else 0)
    # Origins inside, outside, and just past the surface where rays from inside leave it.
    centre = m[:3, 3]
    o_in = centre + rng.uniform(-0.4, 0.4, (32, 3)) @ lin.T
    d_in = rng.normal(size=(32, 3))
    t, shape, n = _probes.intersect(native, o_in, d_in)
    exits = (shape == 0) & np.isfinite(t)
    d_unit = d_in / np.linalg.norm(d_in, axis=1, keepdims=True)
    p_exit = o_in[exits] + t[exits, None] * d_unit[exits]
    n_out = np.where((np.sum(n[exits] * d_unit[exits], axis=1) > 0)[:, None], n[exits], -n[exits])
    surface = p_exit + 1e-9 * np.maximum(1, np.abs(p_exit)) * n_out
    out_dirs = rng.normal(size=(len(surface), 3))
    out_dirs = np.where((np.sum(out_dirs * n_out, axis=1) < 0)[:, None], -out_dirs, out_dirs)
    origins = np.vstack([o_in, rng.uniform(-6, 6, (32, 3)), surface, surface])
    dirs = np.vstack([d_in, rng.normal(size=(32, 3)), out_dirs, d_unit[exits]])
    t_fast, shape_fast, n_fast = _probes.intersect(native, origins, dirs, -1)
    t, shape, n = _probes.intersect(native, origins, dirs)
    assert np.array_equal(shape_fast, shape)
    assert np.array_equal(t_fast, t) and np.array_equal(n_fast, n)
