"""Parameter access with bookkeeping, and the colour conversions every plugin kind uses."""

import math
import warnings

import numpy as np

from .. import spectral
from ..errors import SceneError, SceneWarning, where

# Wavelengths (nm) at which sampled spectra are read for the R, G and B channels.
RGB_WAVELENGTHS = (680.0, 550.0, 440.0)


class Params:
    """A plugin's parameters, read with checks; whatever the plugin does not read is an
    error (check()), named with the file and line it came from."""

    def __init__(self, d, kind, wavelengths=None):
        self.d, self.kind = d, kind
        self.wavelengths = wavelengths  # a spectral pass's three wavelengths (nm), or None: RGB
        self.loc = d.get("__loc__")
        self.type = d.get("type")
        self.read = {"type", "__loc__", "__id__", "__kind__", "__old__"}

    def error(self, msg):
        return SceneError(f"{where(self.loc)}{self.kind} '{self.type}': {msg}")

    def has(self, name):
        return name in self.d

    def raw(self, name, default=None):
        self.read.add(name)
        return self.d.get(name, default)

    def float(self, name, default=None, positive=False, minimum=None, maximum=None):
        v = self.raw(name, default)
        if v is None:
            raise self.error(f"missing float '{name}'")
        if isinstance(v, dict) and v.get("type") == "spectrum" and not isinstance(v["value"], list):
            v = v["value"]
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
            raise self.error(f"'{name}' must be a float, got {describe(v)}")
        v = float(v)
        if not math.isfinite(v):
            raise self.error(f"'{name}' must be finite, got {v}")
        if positive and v <= 0:
            raise self.error(f"'{name}' must be positive, got {v}")
        if minimum is not None and v < minimum:
            raise self.error(f"'{name}' must be at least {minimum}, got {v}")
        if maximum is not None and v > maximum:
            raise self.error(f"'{name}' must be at most {maximum}, got {v}")
        return v

    def int(self, name, default=None):
        v = self.raw(name, default)
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise self.error(f"'{name}' must be an integer, got {describe(v)}")
        return int(v)

    def bool(self, name, default=None):
        v = self.raw(name, default)
        if not isinstance(v, (bool, np.bool_)):
            raise self.error(f"'{name}' must be a boolean, got {describe(v)}")
        return bool(v)

    def str(self, name, default=None, choices=None):
        v = self.raw(name, default)
        if not isinstance(v, str):
            raise self.error(f"'{name}' must be a string, got {describe(v)}")
        if choices and v not in choices:
            raise self.error(f"'{name}' is '{v}', expected one of: {', '.join(choices)}")
        return v

    def rgb(self, name, default=None, nonnegative=True, emitted=False, spectral=True):
        """A colour; in a spectral pass, its values at the pass's wavelengths (times the
        white illuminant when `emitted`; as given when not `spectral`)."""
        v = self.raw(name, default)
        rgb = to_rgb(v)
        if rgb is None:
            raise self.error(f"'{name}' must be a float, rgb or spectrum, got {describe(v)}")
        if not np.all(np.isfinite(rgb)) or (nonnegative and np.any(rgb < 0)):
            raise self.error(f"'{name}' must be finite and non-negative, got {list(rgb)}")
        if self.wavelengths is not None and spectral:
            rgb = spectral_colour(rgb, self.wavelengths, emitted)
        return rgb

    def vec3(self, name, default=None):
        v = self.raw(name, default)
        arr = np.asarray(v, dtype=np.float64) if isinstance(v, (list, tuple, np.ndarray)) else None
        if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)):
            raise self.error(f"'{name}' must be a 3-vector, got {describe(v)}")
        return arr

    def transform(self, name="to_world"):
        v = self.raw(name)
        if v is None:
            return np.eye(4)
        m = np.asarray(v, dtype=np.float64) if isinstance(v, (list, tuple, np.ndarray)) else None
        if m is None or m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise self.error(f"'{name}' must be a 4x4 transform")
        (a, b, c), (d, e, f), (g, h, i) = m[:3, :3].tolist()
        if abs(a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)) < 1e-300:
            raise self.error(f"'{name}' is singular")
        return m

    def motion(self, name="motion"):
        """Motion keys (K >= 2, 4, 4): the map at evenly spaced times over the shutter, or None."""
        v = self.raw(name)
        if v is None:
            return None
        m = np.asarray(v, dtype=np.float64) if isinstance(v, (list, tuple, np.ndarray)) else None
        if m is None or m.ndim != 3 or m.shape[0] < 2 or m.shape[1:] != (4, 4) or not np.all(np.isfinite(m)):
            raise self.error(f"'{name}' must be two or more 4x4 transforms (K, 4, 4)")
        if (np.abs(np.linalg.det(m[:, :3, :3])) < 1e-300).any():
            raise self.error(f"'{name}' holds a singular transform")
        return m

    def ignored(self, name, why):
        """A parameter that an older spelling defines and that changes nothing in Volpath's
        image: read, with a SceneWarning naming where it is."""
        if name in self.d:
            self.read.add(name)
            warnings.warn(
                SceneWarning(f"{where(self.loc)}{self.kind} '{self.type}': '{name}' ignored ({why})"), stacklevel=2
            )

    def check(self):
        unknown = [k for k in self.d if k not in self.read]
        if unknown:
            raise self.error(f"unexpected parameter(s) {', '.join(repr(k) for k in unknown)}")


def describe(v):
    if isinstance(v, dict):
        return f"a {v.get('type', 'dictionary')}"
    return repr(v)


def spectral_colour(rgb, wavelengths, emitted):
    """An RGB colour (..., 3) at a spectral pass's three wavelengths; emitters carry the
    white illuminant."""
    values = spectral.uplift(rgb, wavelengths)
    return values * spectral.white(wavelengths) if emitted else values


def to_rgb(v):
    if isinstance(v, bool):
        return None
    if isinstance(v, (int, float, np.integer, np.floating)):
        return np.full(3, float(v))
    if isinstance(v, dict):
        if v.get("type") == "rgb":
            return np.asarray(v["value"], dtype=np.float64).reshape(3)
        if v.get("type") == "spectrum":
            s = v["value"]
            if not isinstance(s, list):
                return np.full(3, float(s))
            wl = np.array([p[0] for p in s])
            val = np.array([p[1] for p in s])
            return np.interp(RGB_WAVELENGTHS, wl, val)
    if isinstance(v, (list, tuple, np.ndarray)) and np.asarray(v).shape == (3,):
        return np.asarray(v, dtype=np.float64)
    return None
