"""The display transform the pipeline's video shows: exposure in stops,
the ACES filmic fit (Narkowicz 2015), the sRGB transfer curve. Rendering to a target error
(volpath/adaptive.py) measures the error in these display units."""

import numpy as np

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
MIDDLE = 0.25  # the display brightness that auto exposure gives a frame


def _film(u):
    return u * (2.51 * u + 0.03) / (u * (2.43 * u + 0.59) + 0.14)


def _srgb(y):
    return np.where(y <= 0.0031308, 12.92 * y, 1.055 * np.maximum(y, 0.0031308) ** (1 / 2.4) - 0.055)


def srgb_to_linear(c):
    """The sRGB transfer curve's inverse: encoded values in [0, 1] -> linear (float64)."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def display(image, exposure=0.0):
    """Linear radiance -> display values in [0, 1]: scale by 2^exposure, the filmic curve, sRGB."""
    x = np.maximum(np.asarray(image, dtype=np.float64) * 2.0**exposure, 0.0)
    return _srgb(np.clip(_film(x), 0.0, 1.0))


def log_brightness(image):
    """log2 of a frame's robust brightness: the mean luminance with the brightest 1 % of
    pixels (the sun's disc) clipped."""
    lum = np.asarray(image, dtype=np.float64) @ LUMINANCE
    return float(np.log2(max(np.minimum(lum, np.percentile(lum, 99)).mean(), 1e-8)))


def auto_exposure(image):
    """Stops that bring the frame's robust brightness to MIDDLE."""
    return float(np.clip(np.log2(MIDDLE) - log_brightness(image), -10.0, 12.0))
