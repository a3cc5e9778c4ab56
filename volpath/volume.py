"""Voxel grids placed in the world: ``volpath.VolumeGrid``.

A grid fills the unit cube of its own space, voxel ``i`` centred at ``(i + 0.5) / res``,
and ``to_world`` (4x4) maps that cube into the scene. The voxels live in native memory as
8^3 bricks, only the non-zero ones stored, so a sparse cloud costs what its active voxels
cost. Grids come from numpy arrays, Mitsuba ``.vol`` files and OpenVDB ``.vdb`` files.

    grid = volpath.VolumeGrid.from_file("cloud.vdb", grid="density")
    grid = volpath.VolumeGrid.from_numpy(array_zyx, to_world)
    scene = volpath.load_dict({..., "density": grid, ...})
"""

import os
import re
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from . import _core, vdb
from .errors import SceneError
from .grids import clamp_negative, read_vol


class VolumeGrid:
    """A sparse voxel grid (1 or 3 channels, float32) and its placement ``to_world``."""

    def __init__(
        self,
        native: _core.VoxelGrid,
        to_world: npt.ArrayLike | None = None,
        source: str = "",
        vdb: tuple[str, str, np.ndarray] | None = None,
    ):
        self.native = native
        self.to_world = np.eye(4) if to_world is None else np.array(to_world, dtype=np.float64).reshape(4, 4)
        self.source = source  # "file, grid 'name'" for messages
        self.vdb = vdb  # (path, grid, to_world given) when read from a .vdb: how to read it again

    @classmethod
    def from_numpy(cls, data: npt.ArrayLike, to_world: npt.ArrayLike | None = None) -> "VolumeGrid":
        """From a (z, y, x) or (z, y, x, 1 or 3) array; x is the fastest axis."""
        data = np.asarray(data, dtype=np.float32)
        if data.ndim == 3:
            data = data[..., None]
        if data.ndim != 4 or data.shape[3] not in (1, 3) or data.size == 0:
            raise SceneError(f"a grid must have shape (z, y, x) or (z, y, x, 1 or 3), got {data.shape}")
        if np.any(data < 0):
            data = data.copy()  # the caller's array stays as it is
        _check_values(data, "the array")
        return cls(_core.VoxelGrid.from_dense(np.ascontiguousarray(data)), to_world)

    @classmethod
    def from_file(
        cls,
        path: str | os.PathLike,
        grid: str = "density",
        to_world: npt.ArrayLike | None = None,
        frame: int | None = None,
    ) -> "VolumeGrid":
        """From a ``.vdb`` file (the grid named `grid`, placed by the file's transform, then
        by `to_world`) or a Mitsuba ``.vol`` file (its bounding box, then `to_world`). A run
        of ``#`` in the file name is replaced by `frame`, zero-padded (Blender's sequences)."""
        path = sequence_path(str(path), frame)
        user = np.eye(4) if to_world is None else np.asarray(to_world, dtype=np.float64)
        if not os.path.exists(path):
            raise SceneError(f"{path}: volume file not found")
        if path.lower().endswith(".vdb"):
            return _read_vdb(path, grid, user)
        data, (lo, hi) = read_vol(path)
        if np.any(hi <= lo):
            raise SceneError(f"{path}: empty bounding box in the grid file")
        box = np.eye(4)
        box[:3, :3], box[:3, 3] = np.diag(hi - lo), lo
        return cls(_core.VoxelGrid.from_dense(data), user @ box, path)

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """(z, y, x, channels), as ``numpy()`` returns."""
        x, y, z = self.native.res
        return (z, y, x, self.native.channels)

    @property
    def channels(self) -> int:
        return self.native.channels

    @property
    def nbytes(self) -> int:
        """Resident bytes of the voxels (stored bricks and the brick index)."""
        return self.native.nbytes

    @property
    def dense_nbytes(self) -> int:
        """Bytes the same grid would take as a dense float32 array."""
        return int(np.prod(self.shape)) * 4

    def numpy(self) -> np.ndarray:
        """The grid as a dense float32 array (z, y, x, channels)."""
        return self.native.dense()

    def save(self, path: str | os.PathLike, grid: str = "density") -> None:
        """Write the grid as a sparse ``.vdb`` file holding one fog-volume grid named `grid`
        (its non-zero voxels active), placed by ``to_world``: ``from_file(path, grid)``
        reads back the same values at the same places. Needs the OpenVDB module."""
        res = np.asarray(self.native.res, dtype=np.float64)
        unit_to_index = np.eye(4)  # as _grid_from_vdb: voxel i centred at index i
        unit_to_index[:3, :3], unit_to_index[:3, 3] = np.diag(res), -0.5
        vdb.write(
            str(path),
            grid,
            {
                "res": self.native.res,
                "origin": (0, 0, 0),
                "index_to_world": self.to_world @ np.linalg.inv(unit_to_index),
                "brick_index": self.native.brick_index,
                "bricks": self.native.bricks,
            },
        )

    def max(self) -> float:
        bricks = self.native.bricks
        return float(bricks.max()) if bricks.size else 0.0

    def min(self) -> float:
        """The smallest value (0 where bricks are empty, or pad a side that is not a multiple of 8)."""
        bricks = self.native.bricks
        empty = bool(np.any(self.native.brick_index < 0))
        return min(float(bricks.min()) if bricks.size else 0.0, 0.0 if empty else np.inf)

    @property
    def bricks(self) -> np.ndarray:
        """The stored bricks' voxels, read-only: (n, 8, 8, 8, channels), (z, y, x) inside."""
        return self.native.bricks

    def with_bricks(self, values: npt.ArrayLike) -> "VolumeGrid":
        """A grid on the same bricks and placement holding `values` (n, 8, 8, 8, 1 or 3)
        instead: a quantity derived voxel by voxel (unstored voxels stay 0)."""
        values = np.ascontiguousarray(values, dtype=np.float32)
        native = _core.VoxelGrid.from_bricks(self.native.res, self.native.brick_index, values)
        return VolumeGrid(native, self.to_world, self.source)

    def map(self, f: Callable[[np.ndarray], npt.ArrayLike]) -> "VolumeGrid":
        """A grid of f(values) with the same placement; f maps a (..., channels) array to
        (..., 1 or 3) and must map 0 to 0 (unstored voxels stay 0)."""
        if np.any(np.asarray(f(np.zeros((1, self.channels), np.float32))) != 0):
            raise ValueError("map: f(0) must be 0")
        return self.with_bricks(f(self.bricks))

    @property
    def world_to_grid(self) -> np.ndarray:
        return np.linalg.inv(self.to_world)

    def __repr__(self) -> str:
        z, y, x, c = self.shape
        return (
            f"VolumeGrid({x}x{y}x{z}, {c} channel{'s' * (c > 1)}, {self.nbytes / 2**20:.1f} MiB "
            f"of {self.dense_nbytes / 2**20:.1f} MiB dense{', ' + self.source if self.source else ''})"
        )


def sequence_path(path: str, frame: int | None) -> str:
    """`path` with its run of '#' replaced by `frame` zero-padded to the run's length."""
    run = re.search(r"#+", os.path.basename(path))
    if run is None:
        if frame is not None:
            raise SceneError(f"{path}: a 'frame' needs a file name with '#' where the frame number goes")
        return path
    if frame is None:
        raise SceneError(f"{path}: the file name has '#' but no 'frame' was given")
    head = os.path.dirname(path)
    name = os.path.basename(path)
    return os.path.join(head, name[: run.start()] + f"{int(frame):0{len(run.group())}d}" + name[run.end() :])


def _check_values(values, what):
    if not np.all(np.isfinite(values)):
        raise SceneError(f"{what} contains NaN or infinite values")
    clamp_negative(values, what)


def _read_vdb(path, name, user_to_world):
    return _grid_from_vdb(vdb.read(path, name), path, name, user_to_world)


def _grid_from_vdb(d, path, name, user_to_world):
    what = f"{path}: grid '{name}'"
    _check_values(d["bricks"], what)
    # Unit cube -> VDB index space (voxel i centred at index i) -> the file's world -> the scene.
    unit_to_index = np.eye(4)
    unit_to_index[:3, :3], unit_to_index[:3, 3] = np.diag(d["res"].astype(np.float64)), d["origin"] - 0.5
    native = _core.VoxelGrid.from_bricks(tuple(int(r) for r in d["res"]), d["brick_index"], d["bricks"])
    return VolumeGrid(
        native,
        user_to_world @ d["index_to_world"] @ unit_to_index,
        what,
        vdb=(os.path.abspath(path), name, user_to_world),
    )


def read_vdb_aligned(
    path: str, names: list[str], to_world: npt.ArrayLike | None = None
) -> tuple[VolumeGrid, list[np.ndarray]]:
    """Grids of one ``.vdb`` file for combining voxel by voxel (an emitting volume's density
    and temperature): the first as ``VolumeGrid.from_file`` reads it, and for each other
    name the first's stored bricks (numpy (n, 8, 8, 8, channels)) filled with that grid's
    values at the same voxel indices, 0 where it has none. The grids of one file share an
    index space (Blender's smoke and fire grids do); memory follows the first's voxels."""
    user = np.eye(4) if to_world is None else np.asarray(to_world, dtype=np.float64)
    first = vdb.read(path, names[0])
    grid = _grid_from_vdb(first, path, names[0], user)
    # Each stored brick's voxels as global indices (x, y, z) of the file's index space.
    bz, by, bx = np.nonzero(first["brick_index"] >= 0)
    order = np.argsort(first["brick_index"][bz, by, bx])
    corner = np.stack([bx[order], by[order], bz[order]], axis=1) * 8 + first["origin"]  # (n, 3)
    z, y, x = np.meshgrid(np.arange(8), np.arange(8), np.arange(8), indexing="ij")
    voxels = corner[:, None, None, None, :] + np.stack([x, y, z], axis=-1)[None]  # (n, 8, 8, 8, 3)
    others = []
    for name in names[1:]:
        d = vdb.read(path, name)
        _check_values(d["bricks"], f"{path}: grid '{name}'")
        local = voxels - d["origin"]
        inside = np.all((local >= 0) & (local < d["res"]), axis=-1)
        local = np.where(inside[..., None], local, 0)
        slot = d["brick_index"][local[..., 2] // 8, local[..., 1] // 8, local[..., 0] // 8]
        values = d["bricks"][np.maximum(slot, 0), local[..., 2] % 8, local[..., 1] % 8, local[..., 0] % 8]
        others.append(np.where((inside & (slot >= 0))[..., None], values, 0).astype(np.float32))
    return grid, others
