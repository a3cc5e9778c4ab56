"""Volume objects: their OpenVDB grids become heterogeneous media.

The density grid is read by volpath's own sparse reader (``VolumeGrid.from_file``: memory
follows the active voxels), placed by the file's transform and the object's. An emitting
volume is read with the ``openvdb`` module that ships with Blender (shared/README.md §4)
into dense grids over the density's active voxels, because its radiance is Blender's
emission divided by the absorption, voxel by voxel. There a VDB voxel i sits at
i * voxel_size (Blender's ``matrix_object`` maps index to object space) and a Volpath voxel
at (i + 0.5) / res of the unit box, so the box starts half a voxel before the first active
voxel.
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
    sigma_t = medium["sigma_a"] + medium["sigma_s"]
    scale = float(sigma_t.mean())
    if scale <= 0:
        return None
    if np.ptp(sigma_t) > 1e-6 * scale:
        report.warn(f"{owner}: coloured extinction is not supported for grids; using its mean")
    albedo = np.clip(medium["sigma_s"] / scale, 0, 1)
    interior = {"type": "heterogeneous", "scale": scale,
                "albedo": {"type": "rgb", "value": albedo.tolist()},
                "phase": {"type": "hg", "g": float(np.clip(medium["g"], -0.99, 0.99))}}
    if _emits(medium):
        density = _dense_with_emission(volume, path, attribute, grid, matrix_world, medium, scale, albedo,
                                       interior, report, owner)
    else:  # read sparse by volpath's own reader: memory follows the active voxels
        from volpath import SceneError, VolumeGrid

        try:
            density = VolumeGrid.from_file(path, attribute, to_world=convert.matrix(matrix_world))
        except SceneError as e:
            if "no active voxels" not in str(e):
                raise report.error(f"{owner}: {e}") from None
            density = None
    if density is None:
        report.warn(f"{owner}: grid '{attribute}' has no active voxels (skipped)")
        return None
    interior["density"] = density
    cube = np.eye(4)
    cube[:3, :3] = np.diag([0.5, 0.5, 0.5])
    cube[:3, 3] = 0.5
    shape = {"type": "cube", "to_world": density.to_world @ cube, "bsdf": {"type": "null"}, "interior": interior}
    if exterior is not None:
        shape["exterior"] = exterior
    return shape


def _emits(medium):
    return bool(np.any(np.asarray(medium.get("emission", 0)) > 0) or medium.get("blackbody", 0) > 0)


def _dense_with_emission(volume, path, attribute, grid, matrix_world, medium, scale, albedo, interior, report,
                         owner):
    """An emitting volume's density as a VolumeGrid, and its radiance grid in `interior`:
    Blender's emission over sigma_a, plus blackbody radiance at Temperature x the
    temperature grid, voxel by voxel over the density's active box (read with Blender's
    own openvdb: Le divides by the density, so both grids must share voxels)."""
    from volpath import VolumeGrid

    from .materials import emitted_radiance

    try:
        data, first = read_grid(path, attribute)
    except (RuntimeError, KeyError, ValueError) as e:
        raise report.error(f"{owner}: cannot read grid '{attribute}' from '{path}' ({e})") from None
    if data is None:
        return None
    if data.min() < 0:
        report.warn(f"{owner}: negative densities clamped to 0")
        data = np.maximum(data, 0)
    box = np.eye(4)
    box[:3, :3] = np.diag(np.array(data.shape[2::-1], np.float64))
    box[:3, 3] = first - 0.5
    grid_to_world = convert.matrix(matrix_world) @ np.array(grid.matrix_object, dtype=np.float64) @ box
    temperature = np.full(data.shape[:3], medium.get("temperature", 0.0))
    if medium.get("blackbody", 0) > 0:
        name = medium["temperature_attribute"]
        if volume.grids.get(name) is not None:
            t_grid, _ = read_grid(path, name, (first, data.shape[2::-1]))
            temperature = temperature * t_grid[..., 0]
        else:
            report.warn(f"{owner}: no '{name}' grid: blackbody at the constant Temperature")
    sigma_a = scale * data * (1 - albedo)  # (z, y, x, 3)
    Le = emitted_radiance(medium, sigma_a, temperature, report, owner)
    if np.any(Le > 0):
        interior["radiance"] = VolumeGrid.from_numpy(np.ascontiguousarray(Le, dtype=np.float32), grid_to_world)
    return VolumeGrid.from_numpy(data, grid_to_world)
