"""The pixel sampler: Owen-scrambled Sobol points are uniform, stratified, and
independent between dimensions; the independent sampler stays available."""

import numpy as np
import pytest
from scipy import stats

from volpath import _probes


@pytest.mark.parametrize("dimension", [0, 1, 5, 23])
def test_2d_dimensions_are_0_2_nets(dimension):
    """64 samples of one pixel: every elementary interval of area 1/64 (all 7 shapes, from
    1 x 1/64 to 1/64 x 1) holds exactly one point. A deterministic property of a scrambled
    (0, 2)-sequence, for every dimension that is low-discrepancy (the first 24)."""
    for pixel in range(20):
        pts = _probes.sampler_values(3, pixel, 64, dimension + 1, True, True)[:, dimension]
        for k in range(7):
            cells = np.floor(pts[:, 0] * 2**k).astype(int) * 2 ** (6 - k) + np.floor(pts[:, 1] * 2 ** (6 - k)).astype(
                int
            )
            assert np.array_equal(np.sort(cells), np.arange(64)), (pixel, k)


@pytest.mark.parametrize("split_after", [-1, 0, 3])
def test_1d_dimensions_are_stratified(split_after):
    """Over a pixel's 64 samples each dimension holds one value per 1/64 interval; so do the
    dimensions of a stream split off a sample (the camera's second branch in a medium),
    whose scrambles must depend on the pixel, not on the sample."""
    for pixel in range(20):
        v = _probes.sampler_values(5, pixel, 64, 24, True, False, split_after)
        assert np.array_equal(np.sort(np.floor(v * 64).astype(int), axis=0), np.tile(np.arange(64)[:, None], (1, 24)))
    parent, split = (_probes.sampler_values(5, 0, 64, 24, True, False, s) for s in (-1, 0))
    assert not np.allclose(parent, split)


@pytest.mark.parametrize("low_discrepancy", [True, False])
def test_uniform_and_independent_across_pixels(low_discrepancy):
    """Over 4000 pixels x 4 samples, every dimension (low-discrepancy ones and those after)
    is uniform (Kolmogorov-Smirnov, p > 1e-4 for each of 30: a false alarm about once in
    300 runs) and pairs of dimensions are uncorrelated (|r| < 5 / sqrt(n): 5 sigma)."""
    v = np.concatenate([_probes.sampler_values(11, p, 4, 30, low_discrepancy, False) for p in range(4000)])
    for d in range(v.shape[1]):
        assert stats.kstest(v[:, d], "uniform").pvalue > 1e-4, d
    r = np.corrcoef(v.T)
    n = len(v)
    assert np.all(np.abs(r[np.triu_indices(30, 1)]) < 5 / np.sqrt(n))
    assert v.min() >= 0 and v.max() < 1


@pytest.mark.parametrize("low_discrepancy", [True, False])
def test_a_chain_of_choices_from_one_uniform_keeps_their_probabilities(low_discrepancy):
    """ChoiceChain (delta tracking's real-or-null choices): the first choice made falls on
    the k-th of a run with probability p_k times the product of (1 - p_j) before it.
    A run of 60 takes the chain past a redraw (each remap coarsens u by 1 / (1 - p), and
    1 / P(no choice) > 2^10). Chi-square over 10^5 chains, p > 1e-4 (a false alarm about
    once in 10^4 runs); a remap that kept u unchanged fails at p ~ 0."""
    rng = np.random.default_rng(4)
    probabilities = np.concatenate([[0.3, 0.0, 0.5], rng.uniform(0.08, 0.12, 57)])
    counts = np.array(_probes.choice_chain_counts(list(probabilities), 7, 3125, 32, low_discrepancy))
    survive = np.concatenate([[1.0], np.cumprod(1 - probabilities)])
    assert 1 / survive[-1] > 2**10
    expected = np.append(probabilities * survive[:-1], survive[-1]) * counts.sum()
    assert counts[1] == 0  # never made with probability 0
    keep = expected > 0
    assert expected[keep].min() > 5  # chi-square's approximation holds in every bin
    assert stats.chisquare(counts[keep], expected[keep]).pvalue > 1e-4


def test_seeds_give_independent_scrambles():
    a = _probes.sampler_values(1, 0, 16, 4, True, True)
    b = _probes.sampler_values(2, 0, 16, 4, True, True)
    assert not np.allclose(a, b)


def test_error_of_a_smooth_integrand_falls_faster():
    """The integral of f(x, y) = sin(pi x) e^y over the unit square, estimated with N points
    of one dimension over 200 pixels (independent randomisations). Independent sampling's
    RMS error falls as N^-1/2 (x4 from 16 to 256 points); Owen-scrambled Sobol's as about
    N^-3/2 for smooth integrands (x64). Asserted: more than x16 against 2.5..6."""
    exact = 2 / np.pi * (np.e - 1)

    def rms_error(n, ld):
        errors = []
        for pixel in range(200):
            p = _probes.sampler_values(17, pixel, n, 1, ld, True)[:, 0]
            errors.append(np.mean(np.sin(np.pi * p[:, 0]) * np.exp(p[:, 1])) - exact)
        return np.sqrt(np.mean(np.square(errors)))

    sobol = rms_error(16, True) / rms_error(256, True)
    independent = rms_error(16, False) / rms_error(256, False)
    assert sobol > 16, sobol
    assert 2.5 < independent < 6, independent


def test_sobol_renders_converge_to_the_independent_answer():
    """Unbiased: the mean over seeds of low-discrepancy renders of a single-scattering scene
    agrees with independent-sampling renders, block by block, within 5 standard errors."""
    import scenes as S
    import volpath
    from volpath.testing import max_z, render_batches

    scene = volpath.load_string(
        S.scene(
            S.camera(res=16, spp=32),
            S.homogeneous("m", "1, 2, 3", "0.8"),
            S.medium_sphere("m"),
            S.point_light("2, 2, 2", "20, 20, 20"),
            max_depth=2,
        )
    )
    a, se_a = render_batches(volpath.render, scene, 6, block=4, sampler="sobol")
    b, se_b = render_batches(volpath.render, scene, 6, block=4, sampler="independent")
    assert max_z(a, se_a, b, se_b) < 5
