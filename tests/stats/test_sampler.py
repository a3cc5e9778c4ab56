"""The pixel sampler: Owen-scrambled Sobol points are uniform, stratified, and
independent between dimensions; the independent sampler stays available."""

import numpy as np
import pytest
from scipy import stats

from volpath import _core


@pytest.mark.parametrize("dimension", [0, 1, 5, 23])
def test_2d_dimensions_are_0_2_nets(dimension):
    """64 samples of one pixel: every elementary interval of area 1/64 (all 7 shapes, from
    1 x 1/64 to 1/64 x 1) holds exactly one point. A deterministic property of a scrambled
    (0, 2)-sequence, for every dimension that is low-discrepancy (the first 24)."""
    for pixel in range(20):
        pts = _core.sampler_values(3, pixel, 64, dimension + 1, True, True)[:, dimension]
        for k in range(7):
            cells = np.floor(pts[:, 0] * 2 ** k).astype(int) * 2 ** (6 - k) + np.floor(pts[:, 1] * 2 ** (6 - k)).astype(int)
            assert np.array_equal(np.sort(cells), np.arange(64)), (pixel, k)


def test_1d_dimensions_are_stratified():
    for pixel in range(20):
        v = _core.sampler_values(5, pixel, 64, 24, True, False)
        assert np.array_equal(np.sort(np.floor(v * 64).astype(int), axis=0), np.tile(np.arange(64)[:, None], (1, 24)))


@pytest.mark.parametrize("low_discrepancy", [True, False])
def test_uniform_and_independent_across_pixels(low_discrepancy):
    """Over 4000 pixels x 4 samples, every dimension (low-discrepancy ones and those after)
    is uniform (Kolmogorov-Smirnov, p > 1e-4 for each of 30: a false alarm about once in
    300 runs) and pairs of dimensions are uncorrelated (|r| < 5 / sqrt(n): 5 sigma)."""
    v = np.concatenate([_core.sampler_values(11, p, 4, 30, low_discrepancy, False) for p in range(4000)])
    for d in range(v.shape[1]):
        assert stats.kstest(v[:, d], "uniform").pvalue > 1e-4, d
    r = np.corrcoef(v.T)
    n = len(v)
    assert np.all(np.abs(r[np.triu_indices(30, 1)]) < 5 / np.sqrt(n))
    assert v.min() >= 0 and v.max() < 1


def test_seeds_give_independent_scrambles():
    a = _core.sampler_values(1, 0, 16, 4, True, True)
    b = _core.sampler_values(2, 0, 16, 4, True, True)
    assert not np.allclose(a, b)
