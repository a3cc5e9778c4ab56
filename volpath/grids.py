"""Mitsuba's binary ``.vol`` voxel grids.

Layout: b"VOL", uint8 version 3, int32 encoding (1 = float32), int32 xres, yres, zres,
int32 channels, 6 float32 bounding box (min xyz, max xyz), then float32 data with x
fastest: index ((z * yres + y) * xres + x) * channels + c.
"""

import os
import struct
import warnings

import numpy as np

from .errors import SceneError, SceneWarning

# A grid larger than this many values is refused before anything is allocated.
MAX_VOXEL_VALUES = 1 << 31


def read_vol(path):
    """Return (data float32 (z, y, x, c), bbox (2, 3) float64)."""
    if not os.path.exists(path):
        raise SceneError(f"{path}: grid file not found")
    with open(path, "rb") as f:
        head = f.read(48)
        if len(head) < 48 or head[:3] != b"VOL":
            raise SceneError(f"{path}: not a .vol grid (expected the bytes 'VOL' and a 48-byte header)")
        version = head[3]
        encoding, xres, yres, zres, channels = struct.unpack("<5i", head[4:24])
        bbox = np.array(struct.unpack("<6f", head[24:48]), dtype=np.float64).reshape(2, 3)
        if version != 3:
            raise SceneError(f"{path}: .vol version {version} is not supported (expected 3)")
        if encoding != 1:
            raise SceneError(f"{path}: .vol encoding {encoding} is not supported (expected 1, float32)")
        if min(xres, yres, zres) < 1 or channels not in (1, 3):
            raise SceneError(
                f"{path}: bad grid size {xres}x{yres}x{zres} with {channels} channels "
                "(expected positive sizes and 1 or 3 channels)"
            )
        count = xres * yres * zres * channels
        if count > MAX_VOXEL_VALUES:
            raise SceneError(f"{path}: grid of {count} values is larger than the limit of {MAX_VOXEL_VALUES}")
        size = os.path.getsize(path)
        if size < 48 + 4 * count:
            raise SceneError(f"{path}: truncated grid: {size - 48} data bytes, expected {4 * count}")
        data = np.fromfile(f, dtype="<f4", count=count)
    if not np.all(np.isfinite(data)):
        raise SceneError(f"{path}: the grid contains NaN or infinite values")
    clamp_negative(data, path)
    return data.reshape(zres, yres, xres, channels).astype(np.float32), bbox


def clamp_negative(values, what):
    """Negative voxels (filtering leaves a few) set to 0 in place, with a SceneWarning that
    counts them: densities, albedos and temperatures are >= 0."""
    negative = values < 0
    count = int(np.count_nonzero(negative))
    if count:
        values[negative] = 0
        warnings.warn(
            SceneWarning(f"{what}: {count} negative voxel{'s' if count > 1 else ''} clamped to 0"), stacklevel=3
        )


def write_vol(path, data, bbox=((0, 0, 0), (1, 1, 1))):
    """Write a (z, y, x) or (z, y, x, c) float array as a .vol grid."""
    data = np.asarray(data, dtype=np.float32)
    if data.ndim == 3:
        data = data[..., None]
    z, y, x, c = data.shape
    with open(path, "wb") as f:
        f.write(b"VOL" + bytes([3]) + struct.pack("<5i", 1, x, y, z, c))
        f.write(struct.pack("<6f", *np.asarray(bbox, dtype=np.float64).ravel()))
        f.write(np.ascontiguousarray(data, dtype="<f4").tobytes())
