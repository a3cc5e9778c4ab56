"""Images for textures: PNG, JPEG and the other formats Pillow reads, kept 8-bit, and
OpenEXR, as float."""

import os

import numpy as np

from .errors import SceneError
from .exr import read_exr, write_exr


def read_image(path):
    """(texels (h, w, 1 or 3), sRGB-encoded?): uint8 for 8-bit images, float32 otherwise
    (16-bit images scaled to [0, 1], still encoded; EXR linear). Alpha is dropped."""
    if os.path.splitext(path)[1].lower() == ".exr":
        try:
            return read_exr(path), False
        except (OSError, ValueError) as e:
            raise SceneError(str(e)) from None
    from PIL import Image, UnidentifiedImageError  # only where an 8-bit texture is read

    try:
        with Image.open(path) as im:
            im.load()
            mode = im.mode
            if mode in ("I;16", "I;16B", "I;16L", "I"):
                texels = np.asarray(im, dtype=np.float32)[..., None] / (65535.0 if mode != "I" else 4294967295.0)
                return texels, True
            if mode not in ("L", "RGB"):
                im = im.convert("L" if mode in ("1", "LA", "La") else "RGB")
            texels = np.asarray(im, dtype=np.uint8)
    except (OSError, UnidentifiedImageError) as e:
        raise SceneError(f"{path}: not a readable image ({e})") from None
    return (texels[..., None] if texels.ndim == 2 else texels), True


def write_image(path, texels):
    """Writes texels (h, w, c): uint8 as PNG (sRGB-encoded as given), float as EXR (linear)."""
    texels = np.asarray(texels)
    if texels.dtype == np.uint8:
        from PIL import Image

        Image.fromarray(texels[..., 0] if texels.shape[2] == 1 else texels).save(path)
    else:
        write_exr(path, texels)
