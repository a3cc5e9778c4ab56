"""Named conductors (Mitsuba's `material` of `conductor` and `roughconductor`): eta and k
measured over the visible range, from volpath/data/metals.json (written from the
refractiveindex.info database by volpath/data/make_metals.py)."""

import functools
import json
import os

import numpy as np


@functools.cache
def _table():
    with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "metals.json")) as f:
        return json.load(f)


def names():
    t = _table()
    return sorted(t["metals"]) + sorted(t["aliases"])


def eta_k(name, wavelengths):
    """(eta, k) of the named metal at the wavelengths (nm), relative to vacuum; None if the
    name is unknown."""
    t = _table()
    entry = t["metals"].get(t["aliases"].get(name, name))
    if entry is None:
        return None
    wl = np.asarray(t["wavelengths_nm"])
    return np.interp(wavelengths, wl, entry["eta"]), np.interp(wavelengths, wl, entry["k"])
