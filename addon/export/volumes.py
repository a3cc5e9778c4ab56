"""Volume objects: their OpenVDB grids, read with the ``openvdb`` module that ships with
Blender, become dense grids over the active voxels (shared/README.md §4).

A VDB voxel i sits at i * voxel_size (Blender's ``matrix_object`` maps index to object
space); a Volpath grid voxel at (i + 0.5) / res of the unit box. The box therefore starts
half a voxel before the first active voxel.
"""

import os
import sys

import numpy as np

from . import convert


def _openvdb():
    import bpy

    site = os.path.join(bpy.utils.resource_path("LOCAL"), "python", "lib",
                        f"python{sys.version_info.major}.{sys.version_info.minor}", "site-packages")
    if os.path.isdir(site) and site not in sys.path:
        sys.path.append(site)
    import openvdb

    return openvdb


def read_grid(path, name, box=None):
    """(dense (z, y, x, 1) float32 array, index of its first voxel) of one float grid, over
    its active voxels or over `box` = (first index, (nx, ny, nz))."""
    vdb = _openvdb()
    grid = vdb.read(path, name)
    if box is None:
        (i0, j0, k0), (i1, j1, k1) = grid.evalActiveVoxelBoundingBox()
        box = ((i0, j0, k0), (i1 - i0 + 1, j1 - j0 + 1, k1 - k0 + 1))
    first, shape = tuple(int(i) for i in box[0]), tuple(int(n) for n in box[1])
    if min(shape) < 1:
        return None, None
    dense = np.zeros(shape, np.float32)
    grid.copyToArray(dense, ijk=first)
    return np.ascontiguousarray(dense.transpose(2, 1, 0)[..., None]), np.array(first, np.float64)


def export(obj, matrix_world, medium, report, exterior):
    """A cube shape holding the heterogeneous medium of one volume object, or None."""
    import bpy

    volume = obj.data
    owner = f"volume '{obj.name}'"
    path = bpy.path.abspath(volume.grids.frame_filepath or volume.filepath)
    if not path or not os.path.isfile(path):
        raise report.error(f"{owner}: VDB file '{path or volume.filepath}' not found")
    if not volume.grids.load():
        raise report.error(f"{owner}: Blender could not read '{path}' ({volume.grids.error_message})")
    attribute = medium["attribute"]
    grid = volume.grids.get(attribute)
    if grid is None:
        names = ", ".join(g.name for g in volume.grids)
        raise report.error(f"{owner}: no grid named '{attribute}' in '{path}' (it has: {names})")
    if grid.data_type != "FLOAT":
        raise report.error(f"{owner}: grid '{attribute}' is {grid.data_type}, expected a FLOAT density")
    try:
        data, first = read_grid(path, attribute)
    except (RuntimeError, KeyError, ValueError) as e:
        raise report.error(f"{owner}: cannot read grid '{attribute}' from '{path}' ({e})") from None
    if data is None:
        report.warn(f"{owner}: grid '{attribute}' has no active voxels (skipped)")
        return None
    if data.min() < 0:
        report.warn(f"{owner}: negative densities clamped to 0")
        data = np.maximum(data, 0)
    sigma_t = medium["sigma_a"] + medium["sigma_s"]
    scale = float(sigma_t.mean())
    if scale <= 0:
        return None
    if np.ptp(sigma_t) > 1e-6 * scale:
        report.warn(f"{owner}: coloured extinction is not supported for grids; using its mean")
    albedo = np.clip(medium["sigma_s"] / scale, 0, 1)
    interior = {"type": "heterogeneous", "scale": scale,
                "density": {"type": "gridvolume", "data": data},
                "albedo": {"type": "rgb", "value": albedo.tolist()},
                "phase": {"type": "hg", "g": float(np.clip(medium["g"], -0.99, 0.99))}}
    radiance = _emission(volume, path, medium, data, first, scale, albedo, report, owner)
    if radiance is not None:
        interior["radiance"] = {"type": "gridvolume", "data": radiance}
    res = np.array(data.shape[2::-1], np.float64)
    box = np.eye(4)
    box[:3, :3] = np.diag(res)
    box[:3, 3] = first - 0.5
    grid_to_world = convert.matrix(matrix_world) @ np.array(grid.matrix_object, dtype=np.float64) @ box
    cube = np.eye(4)
    cube[:3, :3] = np.diag([0.5, 0.5, 0.5])
    cube[:3, 3] = 0.5
    for grid_entry in ("density", "radiance"):
        if grid_entry in interior:
            interior[grid_entry]["to_world"] = grid_to_world
    shape = {"type": "cube", "to_world": grid_to_world @ cube, "bsdf": {"type": "null"}, "interior": interior}
    if exterior is not None:
        shape["exterior"] = exterior
    return shape


def _emission(volume, path, medium, density, first, scale, albedo, report, owner):
    """The radiance grid (z, y, x, 3) of an emitting volume, or None: Blender's emission
    coefficient over sigma_a, plus blackbody radiance at Temperature x the temperature grid
    (read over the density's box)."""
    from .materials import emitted_radiance

    if not (np.any(np.asarray(medium.get("emission", 0)) > 0) or medium.get("blackbody", 0) > 0):
        return None
    temperature = np.full(density.shape[:3], medium.get("temperature", 0.0))
    if medium.get("blackbody", 0) > 0:
        name = medium["temperature_attribute"]
        if volume.grids.get(name) is not None:
            grid, _ = read_grid(path, name, (first, density.shape[2::-1]))
            temperature = temperature * grid[..., 0]
        else:
            report.warn(f"{owner}: no '{name}' grid: blackbody at the constant Temperature")
    sigma_a = scale * density * (1 - albedo)  # (z, y, x, 3)
    Le = emitted_radiance(medium, sigma_a, temperature, report, owner)
    if not np.any(Le > 0):
        return None
    return np.ascontiguousarray(Le, dtype=np.float32)
