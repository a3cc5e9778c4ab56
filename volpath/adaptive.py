"""Rendering to an error instead of a sample count (``render(..., target_error=...)``).

The error is the one the picture shows: the RMS difference between the displayed image and
the displayed converged image, in display units 0..1 (volpath/tonemap.py: exposure, the
filmic curve, sRGB; the exposure is the image's own auto exposure unless one is given), so
target_error=0.01 asks for 1 % of the display's range, and dark and overexposed regions
count as little as they show.

The estimate. Every pixel's samples are split by index parity into two half-buffers drawn
from two independent sequences (the native renderer's ``halves``), A and B, the means of
n_a = ceil(n / 2) and n_b = floor(n / 2) samples, the pixel I their samples' mean. A and B
are displayed, and their squared difference over 1/n_a + 1/n_b estimates the displayed
pixel's variance per sample: were the display linear, without bias (Var(A - B) =
sigma^2 (1/n_a + 1/n_b)); as it is, the curve compresses a firefly in one half as much as
it compresses it on screen, where the curve's slope at I would count it at full strength
(on the sunrise's sparkling fog bank that asked for far more samples than the screen
needed). A BLOCK x BLOCK block's variance sigma_b^2 is its pixels' and channels' mean; the
image's squared error is the pixels' mean of sigma^2 / n. tests/stats/test_adaptive.py
checks that the spread of independent renders, on screen, is the target to within 20 %.

The rounds. The whole image first takes PILOT_SPP samples a pixel. While its error is above
the target, each block is given the samples that reach the target with the fewest in all:
in proportion to sigma_b (Neyman's allocation; bringing every block to one error would
give them in proportion to sigma_b^2, and at the sunrise's 5-spp targets cost as much as
sampling evenly), never fewer than it has nor more than the cap. Each block then takes at
least a quarter more and at most as many again as it has, aiming at AIM of the target; a
block that the share-out gives less than SLACK^2 its samples takes none, and the image
stops within SLACK of the target. A block's mean count may be fractional: its pixels
share it out by a fixed ordered dither, so counts need not be even nor whole per block. A
block's decision depends on its own samples only through its variance, pooled over up to
3 BLOCK^2 values: the bias this leaves is of second order, below the z-tests' resolution,
where per-pixel decisions are caught (tests/stats/test_adaptive.py).
"""

import time

import numpy as np

from . import _core
from .tonemap import auto_exposure, display

BLOCK = 8
PILOT_SPP = 2
SLACK, AIM = 1.05, 0.95
# Thresholds of the 8x8 ordered dither (Bayer) by which a block's pixels share out a
# fractional count: fixed, so they tell nothing about any pixel's samples.
_BAYER = np.zeros((1, 1))
for _ in range(3):
    _BAYER = np.block([[4 * _BAYER, 4 * _BAYER + 2], [4 * _BAYER + 3, 4 * _BAYER + 1]])
DITHER = (_BAYER + 0.5) / 64


class Adaptive:
    """The state of one adaptive render: the half-buffers, each pixel's sample count, and
    the error estimates after the last round."""

    def __init__(self, height, width, target, max_spp, exposure=None):
        if not (isinstance(target, (int, float)) and 0 < target < 1):
            raise ValueError(f"target_error must be a display error in (0, 1), e.g. 0.01, got {target!r}")
        if max_spp < PILOT_SPP:
            raise ValueError(f"spp (the cap with target_error) must be at least {PILOT_SPP}, got {max_spp}")
        self.target, self.max_spp, self.exposure = float(target), int(max_spp), exposure
        self.halves = np.zeros((height, width, 2, 3))
        self.taken = np.zeros((height, width), np.uint32)
        self.blocks_y, self.blocks_x = -(-height // BLOCK), -(-width // BLOCK)
        self.block_pixels = self._per_block(np.ones((height, width)))
        self.dither = np.tile(DITHER, (self.blocks_y, self.blocks_x))[:height, :width]
        self.error = np.inf
        self.block_variance = np.full((self.blocks_y, self.blocks_x), np.inf)

    def image(self):
        return self._mean().astype(np.float32)

    def _mean(self):
        """Each pixel's mean over its samples (float64)."""
        return self.halves.sum(axis=2) / np.maximum(self.taken, 1)[..., None]

    def _per_block(self, a):
        """Sum of a per-pixel array over each block: (blocks_y, blocks_x)."""
        h, w = a.shape
        padded = np.zeros((self.blocks_y * BLOCK, self.blocks_x * BLOCK))
        padded[:h, :w] = a
        return padded.reshape(self.blocks_y, BLOCK, self.blocks_x, BLOCK).sum(axis=(1, 3))

    def estimate(self):
        """Update the blocks' variances per sample and the image's display error from the
        half-buffers: even sample indices in the first, odd ones in the second."""
        n = self.taken.astype(np.float64)
        n_a, n_b = np.maximum(np.ceil(n / 2), 1), np.maximum(np.floor(n / 2), 1)
        a, b = self.halves[:, :, 0] / n_a[..., None], self.halves[:, :, 1] / n_b[..., None]
        exposure = auto_exposure(self._mean()) if self.exposure is None else self.exposure
        difference = np.mean((display(a, exposure) - display(b, exposure)) ** 2, axis=2)
        per_sample = difference / (1 / n_a + 1 / n_b)  # Var(A - B) = sigma^2 (1/n_a + 1/n_b)
        self.block_variance = self._per_block(per_sample) / self.block_pixels
        self.error = float(np.sqrt(np.mean(per_sample / np.maximum(n, 1))))
        return self.error

    def share_out(self, n):
        """Samples per block (float, not below ``n`` nor above the cap) that bring the
        image's error to the target with the fewest samples: each block's in proportion to
        its standard deviation per sample (Neyman's allocation, which minimizes
        sum sigma_b^2 / n_b for a given sum n_b), the factor found by bisection. Noisy
        blocks end noisier than quiet ones, at fewer samples in all than bringing every
        block to one error would take."""
        sigma = np.sqrt(self.block_variance)
        weight = self.block_pixels / self.block_pixels.sum()

        def squared_error(counts):
            return np.sum(weight * self.block_variance / counts)

        def counts(k):
            return np.clip(k * sigma, n, self.max_spp)

        capped = np.where(sigma > 0, float(self.max_spp), n)  # a black block needs none
        if squared_error(capped) >= self.target**2:  # every noisy block to the cap
            return capped
        lo, hi = 0.0, 1.0
        while squared_error(counts(hi)) > self.target**2:
            lo, hi = hi, 2 * hi
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if squared_error(counts(mid)) > self.target**2 else (lo, mid)
        return counts(hi)

    def next_counts(self):
        """Samples each pixel takes in the next round (uint32), and the samples every
        unfinished block is predicted to need beyond that."""
        if not self.taken.any():
            return self._pixels(np.full(self.block_variance.shape, float(PILOT_SPP))), 0.0
        if self.error <= SLACK * self.target:
            return np.zeros_like(self.taken), 0.0
        n = self._per_block(self.taken) / self.block_pixels
        # AIM lands the next round just below the target; SLACK keeps a block from taking a
        # round of a few samples that the estimate's noise asked for.
        needed = np.minimum(self.share_out(n) / AIM**2, self.max_spp)
        unfinished = (needed > SLACK**2 * n) & (n < self.max_spp)
        step = np.clip(needed - n, n / 4, n)  # at least a quarter more, at most as many again
        goal = np.where(unfinished, np.minimum(n + step, self.max_spp), n)
        later = float(np.sum(self.block_pixels * np.where(unfinished, needed - goal, 0)))
        return self._pixels(goal) - self.taken, max(later, 0.0)

    def _pixels(self, per_block):
        """Per-pixel counts (uint32) whose block means are ``per_block`` (fractional),
        shared out by the ordered dither, never below what a pixel has taken."""
        h, w = self.taken.shape
        mean = np.repeat(np.repeat(per_block, BLOCK, axis=0), BLOCK, axis=1)[:h, :w]
        counts = np.floor(mean) + (mean - np.floor(mean) > self.dither)
        return np.maximum(counts, self.taken).astype(np.uint32)


def render_adaptive(passes, settings, target, exposure, progress, status, out, features=None, film=None):
    """Rounds of native renders until the image's error is ``target`` or every block is at
    ``max_spp``; returns (image, stats, samples per pixel): the image and stats as
    _core.render gives them, with the achieved error and the spp taken. ``features`` (the
    denoiser's passes) are summed over all rounds. ``passes``: the native scenes; more than
    one in spectral mode, where each round renders the same pixels' samples in every pass
    (pass k's sample indices from k * max_spp on, disjoint) and ``film`` (spectral.Film)
    integrates their half-buffers into linear sRGB; the counts are then per pass, the
    stats' spp over all passes, as fixed-spp spectral renders count them. ``settings``
    (_core.RenderSettings): its spp is the cap per pixel, and the rounds set its
    first_sample."""
    max_spp = settings.spp
    height, width = passes[0].height, passes[0].width
    state = Adaptive(height, width, target, max_spp, exposure)
    n_passes = len(passes)
    halves = [state.halves] if film is None else [np.zeros_like(state.halves) for _ in passes]
    stats = {"seconds": 0.0, "nonfinite_samples": 0, "negative_samples": 0, "clamped_share": 0.0, "cancelled": False}
    start, rounds = time.perf_counter(), 0
    counts, later = state.next_counts()
    while counts.any():
        round_samples, done_before = float(counts.sum()), float(state.taken.sum())
        total = done_before + round_samples + later
        per_sample = stats["seconds"] / done_before if done_before else None

        def report(fraction):
            done = done_before + fraction * round_samples
            if status is not None:
                left = None if per_sample is None else per_sample * (total - done)
                status(
                    {
                        "error": state.error,
                        "target": state.target,
                        "spp": n_passes * done / counts.size,
                        "seconds": time.perf_counter() - start,
                        "seconds_left": left,
                    }
                )
            return None if progress is None else progress(done / total)

        for k, native in enumerate(passes):
            settings.first_sample = k * state.max_spp
            _, s = _core.render(
                native,
                settings,
                progress=report if n_passes == 1 else (lambda f, k=k: report((k + f) / n_passes)),
                starts=state.taken,
                counts=counts,
                halves=halves[k],
                features=features if k == 0 else None,
            )
            stats["seconds"] += s["seconds"]
            for key in ("nonfinite_samples", "negative_samples"):
                stats[key] += s[key]
            stats["clamped_share"] += s["clamped_share"] * round_samples / n_passes
            if s["cancelled"]:
                break
        rounds += 1
        state.taken += counts
        if film is not None:
            state.halves[...] = sum(h @ m.T for h, m in zip(halves, film.to_rgb)) / film.balance
        if out is not None:
            out[...] = _clipped(state.image(), film)
        if s["cancelled"]:
            stats["cancelled"] = True
            break
        state.estimate()
        counts, later = state.next_counts()
    stats["clamped_share"] /= max(float(state.taken.sum()), 1.0)
    if progress is not None and not stats["cancelled"]:
        progress(1.0)
    spp = state.taken
    stats.update(
        error=state.error,
        target_error=state.target,
        rounds=rounds,
        spp_mean=n_passes * float(spp.mean()),
        spp_min=n_passes * int(spp.min()),
        spp_max=n_passes * int(spp.max()),
        spp_cap=n_passes * state.max_spp,
    )
    image = _clipped(state.image(), film)
    if out is not None:
        out[...] = image
        image = out
    return image, stats, spp


def _clipped(image, film):
    """A spectral film's colours outside the sRGB gamut clipped to 0, as Film.image does."""
    return image if film is None else np.maximum(image, 0.0)


def describe(status):
    """A status as people read it: "error 1.8 % → 1 %, ~12 s left" (percent of the display's range)."""
    text = f"error {_percent(status['error'])} → {_percent(status['target'])}"
    if status.get("seconds_left") is not None:
        text += f", ~{status['seconds_left']:.0f} s left"
    return text


def _percent(x):
    return "…" if not np.isfinite(x) else f"{100 * x:.2g} %"
