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


def read_grid(path, name):
    """(dense (z, y, x, 1) float32 array, index of its first voxel) of one float grid."""
    vdb = _openvdb()
    grid = vdb.read(path, name)
    (i0, j0, k0), (i1, j1, k1) = grid.evalActiveVoxelBoundingBox()
    shape = (i1 - i0 + 1, j1 - j0 + 1, k1 - k0 + 1)
    if min(shape) < 1:
        return None, None
    dense = np.zeros(shape, np.float32)
    grid.copyToArray(dense, ijk=(i0, j0, k0))
    return np.ascontiguousarray(dense.transpose(2, 1, 0)[..., None]), np.array([i0, j0, k0], np.float64)


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
    res = np.array(data.shape[2::-1], np.float64)
    box = np.eye(4)
    box[:3, :3] = np.diag(res)
    box[:3, 3] = first - 0.5
    grid_to_world = convert.matrix(matrix_world) @ np.array(grid.matrix_object, dtype=np.float64) @ box
    cube = np.eye(4)
    cube[:3, :3] = np.diag([0.5, 0.5, 0.5])
    cube[:3, 3] = 0.5
    shape = {"type": "cube", "to_world": grid_to_world @ cube, "bsdf": {"type": "null"},
             "interior": {"type": "heterogeneous", "scale": scale,
                          "density": {"type": "gridvolume", "data": data, "to_world": grid_to_world},
                          "albedo": {"type": "rgb", "value": albedo.tolist()},
                          "phase": {"type": "hg", "g": float(np.clip(medium["g"], -0.99, 0.99))}}}
    if exterior is not None:
        shape["exterior"] = exterior
    return shape
