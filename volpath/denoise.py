"""Denoising with Intel Open Image Denoise, through its ``pyoidn`` binding: the rendered
image with the albedo and normal of the first surface each pixel sees (the native renderer's
``first_surface``, averaged over the pixel's samples) as auxiliary images.

A denoised image trades noise for bias (detail smoothed away, fog and sky taken as noise
where they hide a surface), which is why ``render`` leaves it off unless asked:
docs/accuracy.md measures both against time."""

import numpy as np


def denoise(image, features, samples):
    """OIDN's ray-tracing filter on linear HDR ``image`` (h, w, 3); ``features`` (h, w, 2, 3)
    holds the albedo and normal sums over ``samples`` per pixel (an array or a number)."""
    try:
        import pyoidn
    except ImportError:
        raise RuntimeError("denoising needs Intel Open Image Denoise's Python binding: pip install pyoidn") from None
    n = np.maximum(np.asarray(samples, np.float64), 1)
    n = n[..., None] if np.ndim(n) else n
    albedo = np.ascontiguousarray(np.clip(features[:, :, 0] / n, 0, 1), np.float32)
    normal = np.ascontiguousarray(np.clip(features[:, :, 1] / n, -1, 1), np.float32)
    color = np.ascontiguousarray(image, np.float32)
    return pyoidn.denoise(color, albedo=albedo, normal=normal, hdr=True, clean_aux=False)
