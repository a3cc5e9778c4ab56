"""Shape plugins: spheres, analytic boxes (cube), and meshes (rectangle, cube, OBJ, PLY,
numpy arrays in a dictionary), with their BSDF, area emitter and medium interface; shape
groups of meshes and their instances (Mitsuba's shapegroup and instance)."""

import math

import numpy as np

from ..meshes import Mesh, load_mesh
from . import bsdfs, kind_of


def build(b, d, group=-1):
    """One shape, in the scene or (group >= 0) in a shape group."""
    if d.get("type") == "shapegroup":
        return shape_group(b, d)
    if d.get("type") == "instance":
        return instance(b, d)
    p = b.params(d, "shape")
    to_world = p.transform()
    bsdf_index, radiance, interior, exterior, bsdf_type = None, None, -1, -1, "diffuse"
    emitter_twosided, emitter_spread, emitter_hidden_from, emitter_texture = False, math.pi, 0, -1
    sphere_emission = {}
    for key, v in d.items():
        if not isinstance(v, dict) or key == "to_world":
            continue
        r = b.resolve(v)
        kind = kind_of(r)
        if kind == "bsdf":
            if bsdf_index is not None:
                raise p.error("more than one bsdf")
            bsdf_index = b.bsdf(r)
            bsdf_type = r.get("type")
        elif kind == "emitter":
            ep = b.params(r, "emitter")
            if ep.type != "area":
                raise ep.error("only 'area' emitters can be attached to shapes")
            radiance, emitter_texture = _radiance(b, ep, p.type)
            emitter_twosided = ep.bool("twosided", False)  # Volpath's: both faces emit (Blender's)
            # Volpath's: Blender's Spread, the full angle in degrees around the normal.
            spread = ep.float("spread", 180.0)
            if not 0 < spread <= 180:
                raise ep.error(f"'spread' must be in (0, 180] degrees, got {spread:g}")
            emitter_spread = math.radians(spread)
            emitter_hidden_from = light_hidden_from(ep)
            if p.type == "sphere":  # Blender's lamps with a radius: a spot cone, Soft Falloff
                from .emitters import spot_cone

                spot = spot_cone(ep, None) if ep.has("cutoff_angle") else None
                sphere_emission = dict(emitter_spot=spot, emitter_soft_falloff=ep.bool("soft_falloff", False))
            ep.check()
        elif kind == "medium":
            if key not in ("interior", "exterior"):
                raise p.error(f"medium '{key}' must be named 'interior' or 'exterior'")
            if key == "interior":
                interior = b.medium(r)
            else:
                exterior = b.medium(r)
        else:
            continue
        p.read.add(key)
    if bsdf_index is None:
        bsdf_index = bsdfs.default(b)
    medium_interface = p.has("interior") or p.has("exterior")
    if group >= 0 and (radiance is not None or medium_interface):
        raise p.error("a shape in a shapegroup can neither emit nor bound a medium")
    if group >= 0 and p.type == "sphere":
        raise p.error("a shapegroup holds meshes only (rectangle, cube, obj, ply, mesh), not spheres")
    mesh_emission = {} if emitter_texture < 0 else {"emitter_texture": emitter_texture}
    common = dict(
        bsdf=bsdf_index,
        interior=interior,
        exterior=exterior,
        medium_interface=medium_interface,
        radiance=None if radiance is None else tuple(radiance),
        hidden_from=_hidden_from(p),
        emitter_twosided=emitter_twosided,
        emitter_spread=emitter_spread,
        emitter_hidden_from=emitter_hidden_from,
    )
    flip = p.bool("flip_normals", False)
    if p.type == "sphere":
        center = transform_points(to_world, p.vec3("center", [0, 0, 0])[None])[0]
        radius = p.float("radius", 1.0, positive=True)
        if p.has("to_world"):  # (without one, as Blender's lamps are written: nothing to check)
            lin = to_world[:3, :3]
            scales = np.linalg.norm(lin, axis=0)
            if not np.allclose(scales, scales[0], rtol=1e-6) or not np.allclose(
                lin.T @ lin, np.diag(scales**2), atol=1e-9 * scales.max() ** 2
            ):
                raise p.error("sphere to_world must be a similarity (uniform scale, rotation, translation)")
            radius *= scales[0]
        index = b.native.add_sphere(tuple(center), radius, flip, **common, **sphere_emission)
        bounds = np.array([center - radius, center + radius])
        b.summary["shapes"].append(
            {
                "type": "sphere",
                "center": center.tolist(),
                "radius": radius,
                "emitter": radiance is not None,
                "bsdf": bsdf_type,
                "loc": p.loc,
            }
        )
    elif p.type == "cube" and radiance is None and group < 0 and np.linalg.cond(to_world[:3, :3]) < 1e12:
        # An analytic box (one primitive); emitting or flattened cubes stay meshes.
        # Under a mirroring map the mesh's faces turn inward; the box's do too.
        box_info = {k: v for k, v in common.items() if not k.startswith("emitter_") and k != "radiance"}
        mirrored = np.linalg.det(to_world[:3, :3]) < 0
        index = b.native.add_box(to_world, np.linalg.inv(to_world), flip != mirrored, **box_info)
        corners = transform_points(to_world, cube()[0])
        bounds = np.array([corners.min(axis=0), corners.max(axis=0)])
        b.summary["shapes"].append({"type": "cube", "box": True, "emitter": False, "bsdf": bsdf_type, "loc": p.loc})
    else:
        positions, triangles, normals, uvs, motion = mesh_data(b, p, to_world, flip)
        if motion is not None and group < 0:
            raise p.error("only a shapegroup's meshes deform in the shutter ('motion'): place it by an instance")
        index = b.native.add_mesh(
            positions, triangles, normals, uvs=uvs, group=group, motion=motion, **common, **mesh_emission
        )
        bounds = np.array([positions.min(axis=0), positions.max(axis=0)])
        b.summary["shapes"].append(
            {
                "type": p.type,
                "triangles": int(len(triangles)),
                "emitter": radiance is not None,
                "bsdf": bsdf_type,
                "loc": p.loc,
                **({"group": group} if group >= 0 else {}),
            }
        )
    if interior >= 0:
        b.medium_bounds.setdefault(interior, []).append(bounds)
    if radiance is not None:
        b.summary["emitters"].append({"type": "area", "radiance": radiance.tolist(), "loc": p.loc})
    p.check()
    b.built_shapes[id(d)] = (index, bsdf_index)


def mesh_data(b, p, to_world, flip):
    """(positions, triangles, normals, uvs, motion) of a mesh shape, in the world (or its
    group); motion: its positions at the shutter's keys (K, n, 3), or None."""
    motion = None
    if p.type == "rectangle":
        positions, triangles, normals, uvs = rectangle()
    elif p.type == "cube":
        positions, triangles, normals, uvs = cube()
    elif p.type in ("obj", "ply"):
        path = b.path(p, "filename")
        positions, triangles, normals, uvs = load_mesh(path)
        if p.bool("face_normals", False):
            normals = None
        if p.has("motion"):  # a file a key, each the same mesh deformed
            keys = [load_mesh(b.path(p, "motion", name.strip())) for name in p.str("motion").split(",")]
            if len(keys) < 2 or any(k[0].shape != positions.shape or not np.array_equal(k[1], triangles) for k in keys):
                raise p.error("'motion' names two or more files of the mesh deformed (its vertices and triangles)")
            motion = np.array([k[0] for k in keys])
    elif p.type == "mesh":  # dictionaries only: numpy arrays in memory (the exporter)
        positions, triangles, normals, uvs = mesh_arrays(p)
        if p.has("motion"):
            motion = np.asarray(p.raw("motion"), dtype=np.float64)
            shaped = motion.ndim == 3 and len(motion) >= 2 and motion.shape[1:] == positions.shape
            if not shaped or not np.isfinite(motion).all():
                raise p.error("'motion' must be the positions at two or more keys (K, n, 3)")
    else:
        raise p.error("unknown shape (expected one of: sphere, rectangle, cube, obj, ply, mesh, shapegroup, instance)")
    positions = transform_points(to_world, positions)
    if motion is not None:
        motion = np.array([transform_points(to_world, key) for key in motion])
    if normals is not None:
        normals = transform_normals(to_world, normals)
    if flip:
        triangles = triangles[:, ::-1].copy()
        if normals is not None:
            normals = -normals
    return positions, triangles, normals, uvs, motion


def shape_group(b, d):
    """The native index of a shapegroup, built once however many instances name it: its
    shapes in the group's own space."""
    if id(d) in b.groups:
        return b.groups[id(d)]
    p = b.params(d, "shape")
    index = b.groups[id(d)] = b.native.add_group()
    for key, v in d.items():
        if key.startswith("__") or not isinstance(v, dict):
            continue
        member = b.resolve(v)
        if kind_of(member) != "shape":
            raise p.error(f"a shapegroup holds shapes only ('{key}' is a {kind_of(member) or member.get('type')})")
        if member.get("type") in ("shapegroup", "instance"):
            raise p.error(f"shapegroups do not nest ('{key}' is a {member['type']})")
        build(b, member, group=index)
        p.read.add(key)
    p.check()
    return index


def instance(b, d):
    """An instance: a shapegroup, named by a reference, placed by ``to_world``. It waits in
    ``b.instances`` for add_instances, which hands a field of them to the core at once."""
    p = b.params(d, "shape")
    groups = []
    for key, v in d.items():
        if key.startswith("__") or key == "to_world" or not isinstance(v, dict):
            continue
        r = b.resolve(v)
        if r.get("type") != "shapegroup":
            raise p.error(f"an instance names a shapegroup ('{key}' is a {r.get('type')})")
        groups.append(r)
        p.read.add(key)
    if len(groups) != 1:
        raise p.error(f"an instance names exactly one shapegroup (found {len(groups)})")
    p.raw("to_world")  # checked with the other instances' in add_instances
    motion = p.motion()  # over the shutter: motion blur
    p.check()
    b.instances.append((shape_group(b, groups[0]), d))
    b.built_instances[id(d)] = b.summary["instances"]  # its index: add_instances adds them in this order
    if motion is not None:
        b.instance_motions[b.summary["instances"]] = motion
    b.summary["instances"] += 1


def add_instances(b):
    """The waiting instances to the core in one call, their transforms checked all at once
    (where one fails, Params.transform names it and words the error)."""
    if not b.instances:
        return
    groups, dicts = zip(*b.instances)
    b.instances = []
    try:
        identity = np.eye(4)
        m = np.array([d.get("to_world", identity) for d in dicts], dtype=np.float64)
        valid = m.shape == (len(groups), 4, 4) and np.isfinite(m).all()
        valid = valid and (np.abs(np.linalg.det(m[:, :3, :3])) >= 1e-300).all()
    except (TypeError, ValueError):
        valid = False
    if not valid:
        m = np.array([b.params(d, "shape").transform() for d in dicts])
    b.native.add_instances(np.array(groups, dtype=np.int32), m)
    for k, motion in b.instance_motions.items():
        b.native.set_instance_motion(k, motion)
    b.instance_motions = {}


def mesh_arrays(p):
    positions = np.asarray(p.raw("positions"), dtype=np.float64)
    triangles = np.asarray(p.raw("indices"), dtype=np.int64)
    normals, uvs = p.raw("normals"), p.raw("uvs")
    if positions.ndim != 2 or positions.shape[1] != 3 or not np.all(np.isfinite(positions)):
        raise p.error("'positions' must be a finite (n, 3) array")
    if (
        triangles.ndim != 2
        or triangles.shape[1] != 3
        or (triangles.size and (triangles.min() < 0 or triangles.max() >= len(positions)))
    ):
        raise p.error("'indices' must be an (m, 3) array of vertex indices")
    if normals is not None:
        normals = np.asarray(normals, dtype=np.float64)
        if normals.shape != positions.shape or not np.all(np.isfinite(normals)):
            raise p.error("'normals' must be a finite array shaped like 'positions'")
    if uvs is not None:
        uvs = np.asarray(uvs, dtype=np.float64)
        if uvs.shape != (len(positions), 2) or not np.all(np.isfinite(uvs)):
            raise p.error("'uvs' must be a finite (n, 2) array, one pair per position")
    return Mesh(positions, triangles.astype(np.uint32), normals, uvs)


def transform_points(m, p):
    return p @ m[:3, :3].T + m[:3, 3]


def transform_normals(m, n):
    out = n @ np.linalg.inv(m[:3, :3])  # (M^-T n) for row vectors
    norm = np.linalg.norm(out, axis=1, keepdims=True)
    return out / np.where(norm > 0, norm, 1)


# The ray kinds a shape can hide from (RayKind in native/include/volpath/scene.h).
RAY_KINDS = {"camera": 1, "diffuse": 2, "glossy": 4, "transmission": 8, "scatter": 16, "shadow": 32}


def _hidden_from(p, kinds=RAY_KINDS):
    """Volpath's `hidden_from`: the kinds of rays that pass through the shape (Blender's ray
    visibility; Mitsuba has none), comma-separated."""
    names = [n.strip() for n in p.str("hidden_from", "").split(",") if n.strip()]
    unknown = [n for n in names if n not in kinds]
    if unknown:
        raise p.error(f"unknown ray kind(s) {', '.join(unknown)} in 'hidden_from' (expected: {', '.join(kinds)})")
    return sum({RAY_KINDS[n] for n in names})


def _radiance(b, ep, shape_type):
    """(radiance, emission map's texture index or -1) of an area emitter: an RGB, or (Mitsuba)
    a texture, then times Volpath's `scale` (default 1: Blender's Emission Strength)."""
    v = ep.raw("radiance", 1.0)
    if not (isinstance(v, dict) and kind_of(b.resolve(v)) == "texture"):
        return ep.rgb("radiance", 1.0, emitted=True), -1
    if shape_type == "sphere":
        raise ep.error("an emission map needs a mesh, not a sphere")
    if b.wavelengths is not None:
        raise ep.error("an emission map is rendered in RGB only, not in a spectral pass")
    from . import textures

    return ep.rgb("scale", 1.0, emitted=True), textures.build(b, v)


def light_hidden_from(p):
    """An emitter's `hidden_from` (Blender's ray visibility of lights): `camera`, camera rays
    do not see it; `diffuse`, `glossy`, `transmission`, it lights surfaces through their
    other lobes only; `scatter`, it lights no medium; `shadow`, it casts no shadow
    (Scene::light_hidden_from in native/include/volpath/scene.h)."""
    return _hidden_from(p, tuple(RAY_KINDS))


def rectangle():
    p = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=np.float64)
    return Mesh(p, np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32), None, (p[:, :2] + 1) / 2)


# Texture coordinates on the cube's faces, as Mitsuba's cube mesh has them: per axis and
# side (+, -), u's and v's axis and sign (the analytic box's in geometry.cpp).
_CUBE_UV = {
    (0, 1): (1, 1, 2, -1),
    (0, -1): (1, 1, 2, 1),
    (1, 1): (0, -1, 2, -1),
    (1, -1): (2, 1, 0, 1),
    (2, 1): (1, 1, 0, 1),
    (2, -1): (1, -1, 0, 1),
}


def cube():
    positions, triangles, uvs = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            u, v = [(axis + 1) % 3, (axis + 2) % 3]
            base = len(positions)
            ua, us, va, vs = _CUBE_UV[axis, int(sign)]
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[u], p[v] = sign, a, b
                positions.append(p)
                uvs.append([(1 + us * p[ua]) / 2, (1 + vs * p[va]) / 2])
            # counter-clockwise seen from outside
            triangles += (
                [[base, base + 1, base + 2], [base, base + 2, base + 3]]
                if sign > 0
                else [[base, base + 2, base + 1], [base, base + 3, base + 2]]
            )
    return Mesh(np.array(positions), np.array(triangles, dtype=np.uint32), None, np.array(uvs))
