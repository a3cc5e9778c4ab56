"""Property-based tests of ray intersection (hypothesis)."""

import numpy as np
import volpath
from hypothesis import given, settings
from hypothesis import strategies as st
from volpath import _core
from volpath.meshes import write_ply

import scenes as S

coord = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
unit = st.floats(0.0, 1.0)


def mesh_scene(tmp_path, positions, triangles):
    write_ply(tmp_path / "m.ply", positions, triangles)
    return volpath.load_string(S.scene(S.camera(res=2), '<shape type="ply"><string name="filename" value="m.ply"/>'
                                       '<boolean name="face_normals" value="true"/></shape>'), base_dir=str(tmp_path))


@settings(max_examples=300, deadline=None)
@given(centre=st.tuples(coord, coord, coord), radius=st.floats(1e-2, 1e3), angles=st.lists(unit, min_size=4, max_size=4,
       unique=True), tilt=st.tuples(unit, unit), s=st.floats(0.02, 0.98), lift=st.floats(0.5, 100))
def test_shared_edges_are_watertight(tmp_path_factory, centre, radius, angles, tilt, s, lift):
    """Rays aimed at points on the diagonal shared by the two triangles of a convex
    planar quad never slip through, from any side and distance."""
    a = np.sort(np.array(angles)) * 2 * np.pi
    if np.min(np.diff(np.r_[a, a[0] + 2 * np.pi])) < 0.2 or np.max(np.diff(np.r_[a, a[0] + 2 * np.pi])) > np.pi - 0.2:
        return  # too thin a quad (or a triangle in disguise)
    z = 1 - 2 * tilt[0]
    normal = np.array([np.sqrt(1 - z * z) * np.cos(2 * np.pi * tilt[1]), np.sqrt(1 - z * z) * np.sin(2 * np.pi * tilt[1]), z])
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
    t, shape = _core.intersect(scene.native, origins, dirs)
    expected = np.linalg.norm(dirs, axis=1)
    assert np.all(shape == 0), "a ray slipped between the two triangles"
    assert np.all(np.abs(t - expected) <= 1e-9 * (1 + np.abs(origins).max() + expected))


@settings(max_examples=200, deadline=None)
@given(cx=st.floats(-1e7, 1e7), cy=st.floats(-1e7, 1e7), cz=st.floats(-1e7, 1e7), r=st.floats(0.01, 1e6),
       dist=st.floats(1.001, 100.0), theta=unit, phi=unit)
def test_spheres_far_from_the_origin(cx, cy, cz, r, dist, theta, phi):
    """A ray aimed at the centre of a sphere anywhere within 1e7 hits at dist - r, to
    1e-9 of the scene's scale (double precision throughout)."""
    c = np.array([cx, cy, cz])
    z = 1 - 2 * theta
    d = np.array([np.sqrt(1 - z * z) * np.cos(2 * np.pi * phi), np.sqrt(1 - z * z) * np.sin(2 * np.pi * phi), z])
    o = c + d * dist * r
    scene = volpath.load_string(S.scene(S.camera(res=2), f'<shape type="sphere"><point name="center" '
                                        f'value="{cx!r}, {cy!r}, {cz!r}"/><float name="radius" value="{r!r}"/></shape>'))
    t, shape = _core.intersect(scene.native, o[None], -d[None])
    assert shape[0] == 0
    scale = np.abs(o).max() + r
    assert abs(t[0] - (dist - 1) * r) <= 1e-9 * scale
