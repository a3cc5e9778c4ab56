"""Rendering to an error instead of a sample count (``render(..., target_error=...)``).

The error is the one the picture shows: the RMS difference between the displayed image and
the displayed converged image, in display units 0..1 (volpath/tonemap.py: exposure, the
filmic curve, sRGB; the exposure is the image's own auto exposure unless one is given), so
target_error=0.01 asks for 1 % of the display's range, and dark and overexposed regions
count as little as they show.

The estimate. Every pixel's samples are split by index parity into two half-buffers drawn
from two independent sequences (the native renderer's ``halves``), A and B, each the mean
of half the samples, the pixel I = (A + B) / 2. A and B are displayed, and a quarter of
their squared difference estimates the displayed pixel's squared error: were the display
linear, without bias (Var(A - B) = 4 Var(I)); as it is, the curve compresses a firefly in
one half as much as it compresses it on screen, where the curve's slope at I would count
it at full strength (on the sunrise's sparkling fog bank that asked for far more samples
than the screen needed). Each BLOCK x BLOCK block's mean squared display error is
its pixels' and channels' mean; the image's error is the pixel-weighted RMS over the
blocks. tests/stats/test_adaptive.py checks that the spread of independent renders, on
screen, is the target to within 20 %.

The rounds. The whole image first takes PILOT_SPP samples a pixel, and while its error is
above the target it grows evenly by what the error predicts it needs (error ~ 1 / sqrt(n)),
up to ``min_spp``: a loose target stops where it is met instead of at ``min_spp``, whose
error may be half the target, and no block is judged on fewer samples. After each round
from then on, water-filling finds the level E* to which the blocks above it must be brought so that the image's error
is the target (blocks below it, or stopped at the sample cap, keep theirs); each such block
takes the samples that its error predicts it needs (error ~ 1 / sqrt(n)), at least a
quarter more and at most as many again as it has. Blocks within SLACK of E* take no round of a
few samples: the image may end up to SLACK - 1 above the target. A block's decision depends
on its own samples only through its error estimate, pooled over up to 3 BLOCK^2 values: the
bias this leaves is of second order, below the z-tests' resolution, where per-pixel
decisions are caught (tests/stats/test_adaptive.py).
"""

import time

import numpy as np

from . import _core
from .tonemap import auto_exposure, display

BLOCK = 8
PILOT_SPP, MIN_SPP = 2, 8
SLACK, AIM = 1.05, 0.95


class Adaptive:
    """The state of one adaptive render: the half-buffers, each pixel's sample count, and
    the error estimates after the last round."""

    def __init__(self, height, width, target, max_spp, exposure=None, min_spp=MIN_SPP):
        if not (isinstance(target, (int, float)) and 0 < target < 1):
            raise ValueError(f"target_error must be a display error in (0, 1), e.g. 0.01, got {target!r}")
        if max_spp < 2:
            raise ValueError(f"spp (the cap with target_error) must be at least 2, got {max_spp}")
        self.target, self.max_spp, self.exposure = float(target), _even(max_spp, down=True), exposure
        self.min_spp = min(_even(min_spp), self.max_spp)
        self.halves = np.zeros((height, width, 2, 3))
        self.taken = np.zeros((height, width), np.uint32)
        self.blocks_y, self.blocks_x = -(-height // BLOCK), -(-width // BLOCK)
        self.block_pixels = self._per_block(np.ones((height, width)))
        self.error = np.inf
        self.block_error = np.full((self.blocks_y, self.blocks_x), np.inf)

    def image(self):
        n = np.maximum(self.taken, 1)[..., None]
        return (self.halves.sum(axis=2) / n).astype(np.float32)

    def _per_block(self, a):
        """Sum of a per-pixel array over each block: (blocks_y, blocks_x)."""
        h, w = a.shape
        padded = np.zeros((self.blocks_y * BLOCK, self.blocks_x * BLOCK))
        padded[:h, :w] = a
        return padded.reshape(self.blocks_y, BLOCK, self.blocks_x, BLOCK).sum(axis=(1, 3))

    def estimate(self):
        """Update the blocks' and the image's display errors from the half-buffers."""
        half_n = np.maximum(self.taken, 2)[..., None] / 2
        a, b = self.halves[:, :, 0] / half_n, self.halves[:, :, 1] / half_n
        image = (a + b) / 2
        exposure = auto_exposure(image) if self.exposure is None else self.exposure
        squared = np.mean((display(a, exposure) - display(b, exposure)) ** 2, axis=2) / 4
        self.block_error = np.sqrt(self._per_block(squared) / self.block_pixels)
        self.error = self._rms(self.block_error)
        return self.error

    def _rms(self, block_error):
        """The image's error from its blocks' (pixel-weighted)."""
        return float(np.sqrt(np.sum(self.block_pixels * block_error**2) / np.sum(self.block_pixels)))

    def level(self, n):
        """The error E* that the unfinished blocks are sampled to: the image's RMS error is
        the target when every block ends at min(E_b, E*), or at the error it has at the
        sample cap when that is higher (water-filling, by bisection)."""
        cap_error = self.block_error * np.sqrt(n / self.max_spp)

        def rms(level):
            return self._rms(np.maximum(np.minimum(self.block_error, level), cap_error))

        lo, hi = 0.0, float(self.block_error.max())
        if rms(hi) <= self.target:
            return hi
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if rms(mid) <= self.target else (lo, mid)
        return lo

    def next_counts(self):
        """Samples each pixel takes in the next round (uint32, even), and the samples every
        unfinished block is predicted to need beyond that."""
        if not self.taken.any():
            return self._evenly(min(PILOT_SPP, self.min_spp)), 0.0
        taken = int(self.taken.min())
        if taken < self.min_spp:  # still even: the image's error decides
            if self.error <= SLACK * self.target:
                return self._evenly(0), 0.0
            needed = min(taken * (self.error / (AIM * self.target)) ** 2, self.max_spp)
            step = min(max(_even(np.ceil(needed)), taken + 2), self.min_spp) - taken
            return self._evenly(step), max(needed - taken - step, 0.0) * self.taken.size
        n = self._block_view(self.taken).astype(np.float64)
        level = self.level(n)
        # SLACK keeps a block that the estimate's noise puts just above E* from taking a
        # round of a few samples; AIM lands the next round just below it.
        unfinished = (self.block_error > SLACK * level) & (n < self.max_spp)
        with np.errstate(divide="ignore", invalid="ignore"):  # E* = 0: every block to the cap
            needed = np.minimum(np.ceil(n * (self.block_error / (AIM * level)) ** 2), self.max_spp)
        step = np.clip(needed - n, n / 4, n)  # at least a quarter more, at most as many again
        step = np.minimum(2 * np.ceil(step / 2), self.max_spp - n)
        step = np.where(unfinished, step, 0)
        later = np.where(unfinished, np.maximum(needed - n - step, 0), 0)
        return self._pixels(step).astype(np.uint32), float(self._per_block(self._pixels(later)).sum())

    def _evenly(self, n):
        return np.full(self.taken.shape, n, np.uint32)

    def _block_view(self, per_pixel):
        """A per-pixel array that is constant over blocks, as (blocks_y, blocks_x)."""
        return per_pixel[::BLOCK, ::BLOCK]

    def _pixels(self, per_block):
        h, w = self.taken.shape
        return np.repeat(np.repeat(per_block, BLOCK, axis=0), BLOCK, axis=1)[:h, :w]


def _even(n, down=False):
    n = int(n)
    return n - n % 2 if down else n + n % 2


def render_adaptive(passes, args, target, max_spp, exposure, progress, status, out, sobol, features=None, film=None):
    """Rounds of native renders until the image's error is ``target`` or every block is at
    ``max_spp``; returns (image, stats, samples per pixel): the image and stats as
    _core.render gives them, with the achieved error and the spp taken. ``features`` (the
    denoiser's passes) are summed over all rounds. ``passes``: the native scenes; more than
    one in spectral mode, where each round renders the same pixels' samples in every pass
    (pass k's sample indices from k * max_spp on, disjoint) and ``film`` (spectral.Film)
    integrates their half-buffers into linear sRGB; the counts are then per pass, the
    stats' spp over all passes, as fixed-spp spectral renders count them."""
    _, seed, threads, *tracer_args = args  # the spp each pixel takes is the rounds' counts
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
            _, s = _core.render(
                native,
                2,
                seed,
                threads,
                *tracer_args,
                report if n_passes == 1 else (lambda f, k=k: report((k + f) / n_passes)),
                None,
                sobol,
                k * state.max_spp,
                state.taken,
                counts,
                halves[k],
                features if k == 0 else None,
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
