"""Blackbody emission as linear sRGB radiance: Planck's law integrated against the CIE
1931 colour-matching functions (the multi-lobe Gaussian fit of Wyman, Sloan and Shirley
2013), then XYZ -> linear sRGB (D65). Units: W / (m^2 sr) weighted by the CMFs, without
the 683 lm/W luminous efficacy, so that a temperature's Y is its CMF-weighted radiance."""

import numpy as np

_H, _C, _K = 6.62607015e-34, 2.99792458e8, 1.380649e-23
_LAMBDA = np.arange(380.0, 781.0, 5.0)  # nm
_XYZ_TO_SRGB = np.array([[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]])


def _lobe(lam, mu, s1, s2):
    s = np.where(lam < mu, s1, s2)
    return np.exp(-0.5 * ((lam - mu) / s) ** 2)


def cie_xyz(lam):
    """The CIE 1931 2-degree colour-matching functions at wavelengths `lam` (nm)."""
    x = (
        1.056 * _lobe(lam, 599.8, 37.9, 31.0)
        + 0.362 * _lobe(lam, 442.0, 16.0, 26.7)
        - 0.065 * _lobe(lam, 501.1, 20.4, 26.2)
    )
    y = 0.821 * _lobe(lam, 568.8, 46.9, 40.5) + 0.286 * _lobe(lam, 530.9, 16.3, 31.1)
    z = 1.217 * _lobe(lam, 437.0, 11.8, 36.0) + 0.681 * _lobe(lam, 459.0, 26.0, 13.8)
    return np.stack([x, y, z], axis=-1)


def planck(lam_nm, temperature):
    """Spectral radiance B(lambda, T) in W / (m^2 sr nm)."""
    lam = np.asarray(lam_nm, dtype=np.float64) * 1e-9
    t = np.maximum(np.asarray(temperature, dtype=np.float64), 1e-6)
    with np.errstate(over="ignore"):
        return 2 * _H * _C**2 / lam**5 / np.expm1(_H * _C / (lam * _K * t)) * 1e-9


_SRGB_CMF = cie_xyz(_LAMBDA) @ _XYZ_TO_SRGB.T * 5.0  # per 5 nm bin, rows: wavelengths


def blackbody_rgb(temperature):
    """Linear sRGB radiance of a blackbody at `temperature` (K); any array shape -> shape + (3,).
    Negative sRGB components (deep reds are outside the gamut) are clipped to 0."""
    t = np.asarray(temperature, dtype=np.float64)
    radiance = planck(_LAMBDA, t[..., None])  # (..., wavelengths)
    return np.maximum(radiance @ _SRGB_CMF, 0.0)


def blackbody_colour(temperature):
    """The colour of a blackbody at `temperature` (K) scaled to luminance 1 (Rec. 709
    weights), as Blender's Blackbody node and a lamp's Temperature give it: within 1 % of
    Blender's from 2,000 K up; below, where the deep red leaves the gamut, the two clip
    differently."""
    c = blackbody_rgb(temperature)
    return c / np.maximum(c @ np.array([0.2126, 0.7152, 0.0722]), 1e-300)[..., None]
