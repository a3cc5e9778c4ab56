"""Procedural grids for the bench scenes (deterministic: fixed seed)."""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from volpath.grids import write_vol  # noqa: E402


def hetero_cube(res=64, seed=1):
    """Smooth blobs of density: sigma_t up to 10 per unit, so a 2-unit cube reaches an
    optical thickness of about 20 along its densest lines."""
    rng = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*[(np.arange(res) + 0.5) / res] * 3, indexing="ij")
    d = np.zeros((res, res, res))
    for _ in range(24):
        c = rng.uniform(0.15, 0.85, 3)
        r = rng.uniform(0.06, 0.2)
        d += np.exp(-((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) / (2 * r * r))
    return (10.0 * d / d.max()).astype(np.float32)


if __name__ == "__main__":
    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "scenes", "hetero_cube.vol")
    write_vol(out, hetero_cube())
    print(out)
