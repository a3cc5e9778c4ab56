"""Procedural grids for the bench scenes (deterministic: fixed seed): the hetero cube's .vol
and the accuracy study's cloud, a .vdb written by Blender's OpenVDB (the bpy module)."""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from volpath.grids import write_vol  # noqa: E402


def hetero_cube(res=64, seed=1):
    """Smooth blobs of density: sigma_t up to 10 per unit, so a 2-unit cube reaches an
    optical thickness of about 20 along its densest lines."""
    rng = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*[(np.arange(res) + 0.5) / res] * 3, indexing="ij")
    d = np.zeros((res, res, res))
    for _ in range(24):
        c = rng.uniform(0.15, 0.85, 3)
        r = rng.uniform(0.06, 0.2)
        d += np.exp(-((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) / (2 * r * r))
    return (10.0 * d / d.max()).astype(np.float32)


def cumulus_field(res, seed=7):
    """Round puffs in a layer (a fifth of the box's height): mostly empty, ~4 % active.
    Indexed (z, y, x), the unit cube."""
    rng = np.random.default_rng(seed)
    d = np.zeros((res, res, res), np.float32)
    axis = (np.arange(res, dtype=np.float32) + 0.5) / res
    for _ in range(60):
        c = rng.uniform([0.1, 0.35, 0.1], [0.9, 0.5, 0.9])  # x, y (up), z
        r = rng.uniform(0.03, 0.08)
        lo = np.maximum(((c - r) * res).astype(int), 0)
        hi = np.minimum(((c + r) * res).astype(int) + 1, res)
        x, y, z = axis[lo[0] : hi[0]], axis[lo[1] : hi[1]], axis[lo[2] : hi[2]]
        q = ((x[None, None, :] - c[0]) ** 2 + (y[None, :, None] - c[1]) ** 2 + (z[:, None, None] - c[2]) ** 2) / r**2
        puff = np.clip(1 - q, 0, None) * 150.0  # sigma_t up to 150 per unit at a puff's centre
        view = d[lo[2] : hi[2], lo[1] : hi[1], lo[0] : hi[0]]
        np.maximum(view, puff, out=view)
    return d


def write_vdb(path, density, voxel_size):
    """A float grid 'density' (indexed z, y, x) written by Blender's openvdb module."""
    from addon.export.volumes import _openvdb

    openvdb = _openvdb()
    grid = openvdb.FloatGrid()
    grid.name = "density"
    grid.copyFromArray(np.ascontiguousarray(density.transpose(2, 1, 0)))
    grid.transform = openvdb.createLinearTransform(voxelSize=voxel_size)
    openvdb.write(path, grids=[grid])
    return path


if __name__ == "__main__":
    scenes = os.path.join(os.path.dirname(os.path.abspath(__file__)), "scenes")
    write_vol(os.path.join(scenes, "hetero_cube.vol"), hetero_cube())
    write_vdb(os.path.join(scenes, "cloud.vdb"), cumulus_field(128), voxel_size=1 / 128)
