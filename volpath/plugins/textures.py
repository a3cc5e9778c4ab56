"""Texture plugins: bitmap (an image file, or texels in a dictionary) and checkerboard,
and BSDF parameters given by them.

A texture holds RGB (or grey); the BSDF parameter it drives is offset + scale x texture,
which in a spectral pass also takes the RGB to the pass's wavelengths (the uplift of
spectral.py is linear)."""

from typing import NamedTuple

import numpy as np

from ..errors import SceneError
from ..images import read_image
from ..tonemap import srgb_to_linear
from . import kind_of
from .params import spectral_colour

FILTERS = {"bilinear": True, "nearest": False, "ewa": True, "trilinear": True}
WRAPS = ("repeat", "mirror", "clamp")


class Textured(NamedTuple):
    """A BSDF parameter given by a texture: offset + scale x texture(uv), squared if asked."""

    texture: int
    scale: object = 1.0
    offset: object = 0.0
    squared: bool = False


def build(b, d):
    """The native index of texture ``d`` (built once however often it is referenced)."""
    d = b.resolve(d)
    if id(d) in b.textures:
        return b.textures[id(d)]
    p = b.params(d, "texture")
    entry = {"type": p.type, "id": d.get("__id__"), "loc": p.loc}
    if p.type == "bitmap":
        index = _bitmap(b, p, entry)
    elif p.type == "checkerboard":
        # RGB as given: the binding takes it to a spectral pass's wavelengths.
        c0, c1 = p.rgb("color0", 0.4, spectral=False), p.rgb("color1", 0.2, spectral=False)
        index = b.native.add_texture_checkerboard(tuple(c0), tuple(c1), to_uv(p))
    else:
        raise p.error("unknown texture (expected one of: bitmap, checkerboard)")
    p.check()
    b.textures[id(d)] = index
    b.summary["textures"].append(entry)
    return index


def _bitmap(b, p, entry):
    if p.has("data"):  # a dictionary's texels (the Blender exporter's packed images)
        texels = np.asarray(p.raw("data"))
        if texels.ndim == 2:
            texels = texels[..., None]
        if texels.ndim != 3 or texels.shape[2] not in (1, 3, 4) or texels.size == 0:
            raise p.error("'data' must be an (h, w, 1, 3 or 4) array")
        texels = texels[..., :3] if texels.shape[2] == 4 else texels
        encoded = texels.dtype == np.uint8
        if not encoded:
            texels = texels.astype(np.float32)
        entry["filename"] = None
    else:
        path = b.path(p, "filename")
        try:
            texels, encoded = read_image(path)
        except SceneError as e:
            raise p.error(str(e)) from None
        entry["filename"] = p.raw("filename")
    if texels.dtype != np.uint8 and not np.all(np.isfinite(texels)):
        raise p.error("the image holds NaN or infinite texels")
    raw = p.bool("raw", False)
    if p.has("gamma"):  # Mitsuba 0.5: -1 is sRGB, 1 linear
        gamma = p.float("gamma")
        if gamma not in (-1.0, 1.0):
            raise p.error(f"'gamma' is {gamma}: only -1 (sRGB) and 1 (linear) are supported")
        raw = raw or (gamma == 1.0 and encoded)
    srgb = encoded and not raw
    if srgb and texels.dtype != np.uint8:  # 16-bit: decoded once, kept as floats
        texels = srgb_to_linear(texels).astype(np.float32)
    filter_type = p.str("filter_type", "bilinear", tuple(FILTERS))
    if filter_type in ("ewa", "trilinear"):
        p.ignored("filter_type", f"'{filter_type}' filtering is bilinear in Volpath (no MIP maps)")
    wrap = p.str("wrap_mode", "repeat", WRAPS)
    wrap, wrap_v = p.str("wrap_mode_u", wrap, WRAPS), p.str("wrap_mode_v", wrap, WRAPS)  # Mitsuba 0.5
    if wrap != wrap_v:
        raise p.error("'wrap_mode_u' and 'wrap_mode_v' must agree (one wrap mode for both axes)")
    p.ignored("max_anisotropy", "no anisotropic filtering")
    p.ignored("cache", "images are always held in memory")
    entry.update(
        size=[int(texels.shape[1]), int(texels.shape[0])],
        channels=int(texels.shape[2]),
        texel=str(texels.dtype),
        srgb=bool(srgb),
    )
    return b.native.add_texture_bitmap(texels, srgb, FILTERS[filter_type], wrap, to_uv(p))


def to_uv(p):
    """The 3x3 affine map of (u, v): Mitsuba's to_uv (of a 4x4 transform, the rows and
    columns of x, y and the translation, as Mitsuba extracts them), then Mitsuba 0.5's
    uscale / vscale and uoffset / voffset."""
    m = np.eye(3)
    if p.has("to_uv"):
        t = np.asarray(p.raw("to_uv"), dtype=np.float64)
        if t.shape == (4, 4):
            t = t[np.ix_([0, 1, 3], [0, 1, 3])]
        if t.shape != (3, 3) or not np.all(np.isfinite(t)):
            raise p.error("'to_uv' must be a 3x3 or 4x4 transform")
        m = t
    scale = np.diag([p.float("uscale", 1.0), p.float("vscale", 1.0), 1.0])
    offset = np.eye(3)
    offset[:2, 2] = p.float("uoffset", 0.0), p.float("voffset", 0.0)
    return offset @ scale @ m


def param(b, p, name, default):
    """A BSDF parameter that a texture may give: Textured, or its RGB value."""
    v = p.raw(name, default)
    if isinstance(v, dict) and kind_of(b.resolve(v)) == "texture":
        return Textured(build(b, v))
    return p.rgb(name, default)


def value(v, default):
    """What the native BSDF is created with: the value, or for a texture a stand-in that
    every hit replaces."""
    return default if isinstance(v, Textured) else v


def bind(b, bsdf, **params):
    """Binds each Textured among the named native parameters (reflectance, specular,
    alpha, weight, opacity) of the native BSDF ``bsdf``."""
    for name, v in params.items():
        if not isinstance(v, Textured):
            continue
        scale = np.broadcast_to(np.asarray(v.scale, dtype=np.float64), (3,))
        offset = np.broadcast_to(np.asarray(v.offset, dtype=np.float64), (3,))
        if name in ("alpha", "weight", "opacity"):  # one number: the mean of the texture's channels
            m = np.tile(scale / 3, (3, 1))
        else:
            m = np.diag(scale)
            if b.wavelengths is not None:
                to_pass = spectral_colour(np.eye(3), b.wavelengths, False).T  # RGB -> the pass's channels
                m, offset = to_pass @ m, to_pass @ offset
        b.native.bind_texture(bsdf, name, v.texture, m, tuple(offset), v.squared)
