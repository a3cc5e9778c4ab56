"""Spectral rendering by wavelength passes.

The native core carries three channels per path. In RGB mode they are red, green and blue
(the atmosphere's coefficients at 680 / 550 / 440 nm). In spectral mode the range
360-830 nm is cut into 3K equal strata and the scene is rendered in K passes, each with
three wavelengths (stratum midpoints, one from each third of the range) as its channels:
every coefficient of the scene is evaluated at those wavelengths, and the passes, which
share each pixel's samples out (a path carries its pass's three wavelengths, as in
hero-wavelength sampling), are integrated against the CIE 1931 matching functions into
XYZ, then linear sRGB.

Spectra of RGB inputs: reflectances, albedos and extinction colours become smooth spectra
by a partition of unity over the spectrum (blue below 470 nm, green 510-570 nm, red above
610 nm, linear ramps between), so grey stays flat and values stay within [min, max] of
the RGB; emitters are the same times the white illuminant, the sun's spectrum (a 5772 K
blackbody). The white balance maps the white illuminant to RGB (1, 1, 1), so a grey
world under the sun renders as in RGB mode, and only what depends on wavelength (the
atmosphere: Rayleigh's lambda^-4, ozone's Chappuis band) changes colour.
"""

import numpy as np

from .blackbody import _XYZ_TO_SRGB, cie_xyz, planck

LAMBDA_MIN, LAMBDA_MAX = 360.0, 830.0
SUN_TEMPERATURE = 5772.0  # K, the Sun's effective temperature

# Ozone's absorption cross-section relative to 550 nm: a smooth approximation of the
# Chappuis band (peak near 600 nm, falling to almost nothing at 400 nm), fitted to the
# ratios of Bruneton's RGB values, 0.35 : 1 : 0.045 at 680 / 550 / 440 nm. Not a measured
# table: good to about 20 % between those wavelengths.
_OZONE_NM = np.array(
    [360, 400, 420, 440, 460, 480, 500, 520, 540, 560, 580, 600, 620, 640, 660, 680, 700, 740, 780, 830],
    dtype=np.float64,
)
_OZONE_REL = np.array(
    [
        0.0,
        0.004,
        0.015,
        0.045,
        0.10,
        0.20,
        0.34,
        0.58,
        0.88,
        1.12,
        1.38,
        1.52,
        1.30,
        0.95,
        0.62,
        0.36,
        0.24,
        0.12,
        0.06,
        0.03,
    ]
)


def pass_wavelengths(passes):
    """(passes, 3) wavelengths in nm: pass k takes strata k, k + K, k + 2K of 3K."""
    strata = 3 * passes
    mid = LAMBDA_MIN + (np.arange(strata) + 0.5) * (LAMBDA_MAX - LAMBDA_MIN) / strata
    return np.stack([mid[k::passes] for k in range(passes)])[:, ::-1]  # red, green, blue-ish order


def _ramp(lam, a, b):
    return np.clip((lam - a) / (b - a), 0.0, 1.0)


def basis(lam):
    """(len(lam), 3): the weights of R, G, B at each wavelength (they sum to 1)."""
    lam = np.asarray(lam, dtype=np.float64)
    red = _ramp(lam, 570.0, 610.0)
    blue = 1.0 - _ramp(lam, 470.0, 510.0)
    return np.stack([red, 1.0 - red - blue, blue], axis=-1)


def uplift(rgb, lam):
    """An RGB value (..., 3) as a spectrum sampled at the three wavelengths `lam` (..., 3)."""
    return np.asarray(rgb, dtype=np.float64) @ basis(lam).T


def white(lam):
    """The white illuminant (the sun's spectrum) at `lam`, 1 at 560 nm."""
    return planck(lam, SUN_TEMPERATURE) / planck(560.0, SUN_TEMPERATURE)


def rayleigh(sigma_550, lam):
    """Rayleigh scattering at `lam` from its value at 550 nm (lambda^-4)."""
    return sigma_550 * (550.0 / np.asarray(lam, dtype=np.float64)) ** 4


def ozone(sigma_550, lam):
    """Ozone absorption at `lam` from its value at 550 nm."""
    return sigma_550 * np.interp(lam, _OZONE_NM, _OZONE_REL) / np.interp(550.0, _OZONE_NM, _OZONE_REL)


class Film:
    """Accumulates the passes of a spectral render into linear sRGB."""

    def __init__(self, passes):
        self.wavelengths = pass_wavelengths(passes)
        width = (LAMBDA_MAX - LAMBDA_MIN) / (3 * passes)
        self.to_rgb = [(_XYZ_TO_SRGB @ cie_xyz(lam).T) * width for lam in self.wavelengths]  # (3 rgb, 3 channels)
        # White balance: the white illuminant, through the same quadrature, is (1, 1, 1).
        self.balance = sum(m @ white(lam) for m, lam in zip(self.to_rgb, self.wavelengths))
        self.rgb = None

    def add(self, k, image):
        """Adds pass k's image (h, w, 3: radiance at its three wavelengths)."""
        rgb = image.astype(np.float64) @ self.to_rgb[k].T
        self.rgb = rgb if self.rgb is None else self.rgb + rgb

    def image(self):
        """Linear sRGB; colours outside the sRGB gamut (negative components) are clipped to 0."""
        return np.maximum(self.rgb / self.balance, 0.0).astype(np.float32)
