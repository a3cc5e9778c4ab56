"""Denoising with Intel Open Image Denoise, through its ``pyoidn`` binding: the rendered
image with the albedo and normal of the first surface each pixel sees (the native renderer's
``first_surface``, averaged over the pixel's samples) as auxiliary images.

A denoised image trades noise for bias (detail smoothed away, fog and sky taken as noise
where they hide a surface), which is why ``render`` leaves it off unless asked:
docs/accuracy.md measures both against time."""

import numpy as np


def denoise(image, features, samples):
    """OIDN's ray-tracing filter on linear HDR ``image`` (h, w, 3) with the albedo and normal
    of ``surface_passes(features, samples)``."""
    try:
        import pyoidn
    except ImportError:
        raise RuntimeError("denoising needs Intel Open Image Denoise's Python binding: pip install pyoidn") from None
    passes = surface_passes(features, samples)
    albedo = np.ascontiguousarray(np.clip(passes["albedo"], 0, 1))
    normal = np.ascontiguousarray(np.clip(passes["normal"], -1, 1))
    color = np.ascontiguousarray(image, np.float32)
    return pyoidn.denoise(color, albedo=albedo, normal=normal, hdr=True, clean_aux=False)


def surface_passes(features, samples):
    """The native renderer's ``features`` (h, w, 8: sums over ``samples`` per pixel, an array
    or a number) as the first surface's passes, each the mean over the pixel's samples:
    ``albedo`` and ``normal`` (h, w, 3) and ``depth`` (h, w; distance along the camera's
    view axis, over the samples that hit a surface; inf where none did), float32."""
    n = np.maximum(np.asarray(samples, np.float64), 1)
    n = n[..., None] if np.ndim(n) else n
    hits = features[..., 7]
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = np.where(hits > 0, features[..., 6] / hits, np.inf)
    return {
        "albedo": (features[..., 0:3] / n).astype(np.float32),
        "normal": (features[..., 3:6] / n).astype(np.float32),
        "depth": depth.astype(np.float32),
    }
