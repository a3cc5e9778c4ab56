"""bench/compare_mitsuba.py's errors are net of its reference's noise: checked with a fake
renderer whose noise is known, so that no render is needed."""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "bench"))
import compare_mitsuba  # noqa: E402

TRUE = np.linspace(0.1, 2.0, 64 * 64 * 3).reshape(64, 64, 3)


class NoisyRenderer:
    """The true image plus independent Gaussian noise of variance 1 / spp per pixel."""

    def render(self, spp, seed):
        rng = np.random.default_rng(seed)
        return TRUE + rng.normal(0.0, 1.0 / np.sqrt(spp), TRUE.shape), 0.0


def test_the_reference_variance_is_measured_and_taken_off():
    # Reference at 16 spp: variance 1/16, a quarter of the 4-spp image's 1/4, so an error
    # left uncorrected would be sqrt(1.25) = 1.12x the true one. 12288 pixel values give
    # each mean square a relative standard deviation of sqrt(2 / 12288) = 1.3 %: 5 % is
    # about 4 standard deviations for the sums and differences involved.
    ref, ref_var, _ = compare_mitsuba.reference(NoisyRenderer(), 16)
    assert abs(ref_var / (1 / 16) - 1) < 0.05
    img, _ = NoisyRenderer().render(4, 7)
    net = compare_mitsuba.rmse_net(compare_mitsuba.mse(img, ref), ref_var)
    assert abs(net / np.sqrt(1 / 4) - 1) < 0.05
    # An image as good as the reference cannot be told apart from it.
    assert compare_mitsuba.rmse_net(0.5 * ref_var, ref_var) is None
