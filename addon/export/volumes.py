"""Volume objects: their OpenVDB grids become heterogeneous media.

Grids are read by volpath's own sparse reader (``VolumeGrid.from_file``: memory follows
the active voxels), placed by the file's transform and the object's. An emitting volume's
radiance is Blender's emission divided by the absorption, voxel by voxel, plus blackbody
radiance from its temperature grid: it is computed on the density's stored bricks, with
the temperature read at the same voxel indices (``read_vdb_aligned``), so it is sparse too.
Blender's ``openvdb`` module (bundled with the bpy module) is only used to write test and
scene files.
"""

import os
import sys

import numpy as np

from . import convert


def _openvdb():
    import bpy

    site = os.path.join(
        bpy.utils.resource_path("LOCAL"),
        "python",
        "lib",
        f"python{sys.version_info.major}.{sys.version_info.minor}",
        "site-packages",
    )
    if os.path.isdir(site) and site not in sys.path:
        sys.path.append(site)
    import openvdb

    return openvdb


def export(obj, matrix_world, medium, report, exterior):
    """A cube shape holding the heterogeneous medium of one volume object, or None."""
    import bpy

    from volpath import SceneError, VolumeGrid

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
    interior = {
        "type": "heterogeneous",
        "scale": scale,
        "albedo": {"type": "rgb", "value": albedo.tolist()},
        "phase": {"type": "hg", "g": float(np.clip(medium["g"], -0.99, 0.99))},
    }
    try:
        if _emits(medium):
            density = _with_emission(
                volume, path, attribute, matrix_world, medium, scale, albedo, interior, report, owner
            )
        else:
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


def _with_emission(volume, path, attribute, matrix_world, medium, scale, albedo, interior, report, owner):
    """An emitting volume's density as a VolumeGrid, and its radiance grid in `interior` on
    the same bricks: Blender's emission over sigma_a, plus blackbody radiance at Temperature
    x the temperature grid, voxel by voxel (Le divides by the density, so the two grids
    share voxels)."""
    from volpath.volume import read_vdb_aligned

    from .materials import emitted_radiance

    names = [attribute]
    if medium.get("blackbody", 0) > 0:
        if volume.grids.get(medium["temperature_attribute"]) is not None:
            names.append(medium["temperature_attribute"])
        else:
            report.warn(f"{owner}: no '{medium['temperature_attribute']}' grid: blackbody at the constant Temperature")
    density, others = read_vdb_aligned(path, names, to_world=convert.matrix(matrix_world))
    bricks = density.bricks  # (n, 8, 8, 8, 1)
    temperature = np.full(bricks.shape[:4], medium.get("temperature", 0.0))
    if others:
        temperature = temperature * others[0][..., 0]
    Le = emitted_radiance(medium, scale * bricks * (1 - albedo), temperature, report, owner)
    if np.any(Le > 0):
        interior["radiance"] = density.with_bricks(Le)
    return density
