"""Volume plugins: grids of a medium's density, albedo or emission (gridvolume, vdbvolume,
constvolume, or a VolumeGrid in a dictionary), constants as 1x1x1 grids."""

import os

import numpy as np

from ..errors import SceneError
from ..volume import VolumeGrid
from . import kind_of
from .params import to_rgb


def build(b, p, name, default):
    """A volume parameter as a VolumeGrid (constants as a 1x1x1 grid)."""
    v = b.resolve(p.raw(name, default))
    if isinstance(v, VolumeGrid):  # dictionaries only: a grid built in Python
        return v
    if not isinstance(v, dict) or kind_of(v) != "volume":
        rgb = to_rgb(v)
        if rgb is None:
            raise p.error(f"'{name}' must be a volume, float or rgb")
        return constant_grid(rgb)
    vp = b.params(v, "volume")
    if vp.type == "constvolume":
        rgb = vp.rgb("value", 1.0)
        vp.check()
        return constant_grid(rgb)
    if vp.type not in ("gridvolume", "vdbvolume"):
        raise vp.error("unknown volume (expected 'gridvolume', 'vdbvolume' or 'constvolume')")
    to_world = vp.transform()
    if vp.type == "gridvolume" and vp.has("data"):  # dictionaries only: a (z, y, x, c) array
        data = vp.raw("data")
        vp.check()
        try:
            return VolumeGrid.from_numpy(data, to_world)
        except SceneError as e:
            raise vp.error(f"'data': {e}") from None
    filter_type = vp.str("filter_type", "trilinear", ("trilinear", "nearest"))
    if filter_type != "trilinear":
        raise vp.error("only 'trilinear' filtering is supported")
    if vp.type == "vdbvolume":
        grid = vp.str("grid", "density")
        frame = vp.int("frame", 0) if vp.has("frame") else None
        filename = vp.str("filename")
        vp.check()
        try:  # the file is looked for once the frame is in its name
            return VolumeGrid.from_file(os.path.join(b.base_dir, filename), grid, to_world, frame)
        except SceneError as e:
            raise vp.error(str(e)) from None
    path = b.path(vp, "filename")
    use_bbox = vp.bool("use_grid_bbox", b.old)
    vp.raw("raw"), vp.raw("accel")
    vp.check()
    grid = VolumeGrid.from_file(path, to_world=to_world)
    if not use_bbox:  # Mitsuba 3 places the grid's unit cube, not the file's box
        grid.to_world = to_world
    return grid


def constant_grid(rgb):
    """A 1x1x1 grid of one value (one channel when grey)."""
    value = rgb[:1] if np.all(rgb == rgb[0]) else rgb
    return VolumeGrid.from_numpy(np.asarray(value, np.float32).reshape(1, 1, 1, -1))


def is_constant(grid):
    return grid.shape[:3] == (1, 1, 1)


def constant_rgb(grid):
    return np.broadcast_to(grid.numpy().reshape(-1), (3,)).astype(np.float64)
