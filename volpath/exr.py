"""OpenEXR image I/O through the ``OpenEXR`` package (numpy in, numpy out)."""

import os
from collections.abc import Mapping
from typing import Any, Literal, overload

import numpy as np
import numpy.typing as npt
import OpenEXR

# Header attributes that OpenEXR itself manages; everything else is user metadata.
_STANDARD = {
    "channels",
    "compression",
    "dataWindow",
    "displayWindow",
    "lineOrder",
    "pixelAspectRatio",
    "screenWindowCenter",
    "screenWindowWidth",
    "type",
}


def _metadata_value(key, value):
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, str):
        return value
    arr = np.asarray(value)
    if arr.shape in ((2,), (3,)) and np.issubdtype(arr.dtype, np.number):
        return arr.astype(np.float32)
    raise TypeError(f"metadata {key!r}: expected a number, a string or a 2/3-vector, got {value!r}")


def write_exr(
    path: str | os.PathLike, image: npt.ArrayLike, metadata: Mapping[str, Any] | None = None, half: bool = False
) -> None:
    """Write a linear image of shape (h, w), (h, w, 3) or (h, w, 4) to ``path``.

    The file is written to a temporary name and renamed into place, so a reader never
    sees half a file. ``metadata`` maps names to numbers, strings or 2/3-vectors and is
    stored in the EXR header. ``half=True`` stores 16-bit floats.
    """
    img = np.asarray(image)
    if img.ndim == 2:
        img = img[..., None]
    if img.ndim != 3 or img.shape[2] not in (1, 3, 4):
        raise ValueError(f"expected an image of shape (h, w), (h, w, 3) or (h, w, 4), got {img.shape}")
    img = np.ascontiguousarray(img, dtype=np.float16 if half else np.float32)
    names = {1: "Y", 3: "RGB", 4: "RGBA"}[img.shape[2]]
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    for key, value in (metadata or {}).items():
        if key in _STANDARD:
            raise ValueError(f"metadata name {key!r} is reserved by OpenEXR")
        header[key] = _metadata_value(key, value)
    channels = {names: img[..., 0] if names == "Y" else img}
    path = os.fspath(path)
    tmp = f"{path}.tmp{os.getpid()}.exr"
    try:
        with OpenEXR.File(header, channels) as f:
            f.write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


@overload
def read_exr(path: str | os.PathLike, metadata: Literal[False] = False) -> np.ndarray: ...
@overload
def read_exr(path: str | os.PathLike, metadata: Literal[True]) -> tuple[np.ndarray, dict[str, Any]]: ...
def read_exr(path: str | os.PathLike, metadata: bool = False) -> np.ndarray | tuple[np.ndarray, dict[str, Any]]:
    """Read an EXR as float32 (h, w, 3) RGB (grey images are repeated, alpha dropped).

    With ``metadata=True`` returns ``(image, dict)`` with the non-standard header entries.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"{path}: no such EXR file")
    try:
        # Copy everything out inside the block: closing the file empties its channel dict.
        with OpenEXR.File(path) as f:
            channels = {name: np.array(c.pixels) for name, c in f.channels().items()}
            header = dict(f.header())
    except Exception as e:  # the binding raises plain RuntimeErrors for bad files
        raise ValueError(f"{path}: not a readable EXR file ({e})") from e
    if "RGB" in channels or "RGBA" in channels:
        img = channels["RGB" if "RGB" in channels else "RGBA"][..., :3]
    elif all(c in channels for c in "RGB"):
        img = np.stack([channels[c] for c in "RGB"], axis=-1)
    elif channels:
        grey = next(iter(channels.values()))
        img = np.repeat(grey[..., None], 3, axis=-1) if grey.ndim == 2 else grey[..., :3]
    else:
        raise ValueError(f"{path}: EXR file has no channels")
    img = np.ascontiguousarray(img, dtype=np.float32)
    if not metadata:
        return img
    meta = {k: v for k, v in header.items() if k not in _STANDARD}
    return img, meta
