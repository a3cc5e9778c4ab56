"""Rendering: ``render(scene, ...)`` returns linear radiance as a float32 numpy array."""

import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from . import _core
from .adaptive import render_adaptive
from .auto import choose_tracer
from .denoise import denoise as oidn
from .denoise import surface_passes
from .errors import RenderCancelled
from .plugins.integrators import TRACERS
from .scene import Scene
from .spectral import Film

SAMPLERS = ("sobol", "independent")
MAX_SPP = 1024  # the cap of a render to a target error when no spp is given


def render(
    scene: Scene,
    spp: int | None = None,
    seed: int = 0,
    threads: int | None = None,
    tracer: str | None = None,
    progress: Callable[[float], bool | None] | None = None,
    max_depth: int | None = None,
    tolerance: float = 0.01,
    out: np.ndarray | None = None,
    sampler: str = "sobol",
    light_distances: bool | None = None,
    target_error: float | None = None,
    exposure: float | None = None,
    status: Callable[[dict[str, Any]], None] | None = None,
    denoise: bool = False,
    aovs: bool = False,
) -> Any:
    """Render ``scene`` and return a ``numpy.float32`` array of shape (height, width, 3).

    spp        samples per pixel (default: the scene's sampler ``sample_count``); in spectral
               mode shared out over the wavelength passes, each rendering ceil(spp / passes)
               of the pixel's samples with its three wavelengths (equal spp, equal cost)
    seed       the same seed gives a bit-identical image whatever the thread count
    threads    worker threads (default: all cores)
    tracer     "auto" or one of absorption, single, multiple, nee_mis, null_scattering
               (default: the scene's, which is "auto" unless a lajolla `version` names one);
               "auto" picks the cheapest tracer whose omissions stay below `tolerance`
               and says why in scene.last_render["auto"]
    progress   callable(fraction_done) called about 20 times a second from the calling
               thread; returning False cancels the render (raises RenderCancelled)
    max_depth  path segments, as Mitsuba counts them (default: the scene's)
    out        optional float32 array (height, width, 3) to render into; each 16x16 tile
               appears in it when finished, so a progress callback can display it
    sampler    "sobol": each random decision of a path is a dimension of an Owen-scrambled
               Sobol sequence over the pixel's samples (stratified, lower error where the
               integrand is smooth); "independent": PCG32 numbers. The scene file's
               sampler type is not used (its sample_count is).
    light_distances  NEE in homogeneous media also from distances drawn for the lights
               (all but environments), combined with free flight's by MIS (default: the
               scene's integrator setting, on unless the file turns it off)
    target_error  render to this error instead of a sample count: the RMS error of the
               displayed image in display units 0..1 (0.01: 1 % of the display's range;
               volpath/adaptive.py defines it and its estimate from two independent
               half-buffers). 8x8 blocks take samples in rounds, the noisier more;
               ``spp`` is then the cap per pixel (default 1024). scene.last_render holds
               the achieved estimate ("error") and the samples taken (spp_mean, spp_min,
               spp_max)
    exposure   with target_error: the exposure in stops at which the error is measured
               (default: the image's own auto exposure, as the pipeline's video sets it)
    status     with target_error: callable(dict) called with the progress, with "error" (the
               estimate after the last round), "target", "spp" (mean so far), "seconds" and
               "seconds_left" (None until a round has been timed)

    denoise    pass the image through Intel Open Image Denoise (``pip install pyoidn``) with
               the albedo and normal of the first surface each pixel sees: far less noise,
               some bias (off by default; docs/accuracy.md measures both). With
               target_error, the error is the noisy image's, which the denoiser lowers
    aovs       also return the first surface each pixel sees, as Blender's and a denoiser's
               passes: ``image, aovs = render(..., aovs=True)``, aovs["albedo"] and
               aovs["normal"] (h, w, 3; world space), aovs["depth"] (h, w; distance along the
               camera's view axis, inf where nothing is hit), each the mean over the pixel's
               samples (volpath.denoise.surface_passes)

    The GIL is released while rendering; Ctrl-C cancels within a fraction of a second.
    Statistics are left in ``scene.last_render``: seconds, non-finite samples discarded, and
    negative samples: only the air's control variates can give one (about one sample in
    10^4-10^5 in a sunrise sky), its negative channels count as 0, and ``clamped_share`` is
    the light that adds over the image's (a bias, ~1e-5 there).
    """
    tracer = tracer or scene.tracer
    max_depth = scene.max_depth if max_depth is None else int(max_depth)
    if max_depth == 0 or max_depth < -1:
        raise ValueError("max_depth must be -1 (unlimited) or at least 1")
    tracer, auto = resolve_tracer(scene, tracer, tolerance, max_depth)
    spp = (MAX_SPP if target_error is not None else scene.spp) if spp is None else int(spp)
    threads = 0 if threads is None else int(threads)
    if sampler not in SAMPLERS:
        raise ValueError(f"unknown sampler '{sampler}' (expected one of: {', '.join(SAMPLERS)})")
    if not 0 <= int(seed) < 2**64:
        raise ValueError("seed must be in [0, 2**64)")
    # Spectral: the samples are shared out over the wavelength passes.
    per_pass = -(-spp // len(scene.passes)) if scene.passes else spp
    spp = per_pass * max(len(scene.passes), 1)
    settings = _core.RenderSettings(
        spp=per_pass,
        seed=int(seed),
        threads=threads,
        low_discrepancy=sampler == "sobol",
        tracer=_core.TracerConfig(
            tracer=_core.Tracer[tracer],
            max_depth=max_depth,
            rr_depth=scene.rr_depth,
            max_null_collisions=scene.max_null_collisions,
            light_distances=scene.light_distances if light_distances is None else bool(light_distances),
        ),
    )
    features = np.zeros((scene.height, scene.width, 8)) if denoise or aovs else None
    samples = per_pass
    if target_error is not None:
        image, stats, samples = render_adaptive(
            scene.passes or [scene.native],
            settings,
            target_error,
            exposure,
            progress,
            status,
            out,
            features,
            Film(len(scene.passes)) if scene.passes else None,
        )
        spp = stats["spp_max"]
    elif scene.passes:
        image, stats = _render_spectral(scene.passes, settings, progress, out, features)
    else:
        image, stats = _core.render(scene.native, settings, progress=progress, out=out, features=features)
    if denoise and not stats["cancelled"]:
        start = time.perf_counter()
        image[...] = oidn(image, features, samples)
        stats["denoise_seconds"] = time.perf_counter() - start
    stats.update(
        spp=spp,
        seed=int(seed),
        tracer=tracer,
        max_depth=max_depth,
        sampler=sampler,
        threads=threads or os.cpu_count(),
        auto=auto,
        denoised=bool(denoise),
        memory=scene.memory,
    )
    scene.last_render = stats
    if stats["cancelled"]:
        raise RenderCancelled(image)
    return (image, surface_passes(features, samples)) if aovs else image


def _render_spectral(passes, settings, progress, out, features):
    """The passes of a spectral scene, integrated into linear sRGB (volpath/spectral.py).
    Pass k renders the pixel samples k n .. (k + 1) n - 1 (n = settings.spp): together the passes
    are the samples of one render at n * passes spp, each path carrying its pass's three
    wavelengths. The denoiser's ``features`` come from the first pass."""
    film = Film(len(passes))
    stats = {"seconds": 0.0, "nonfinite_samples": 0, "negative_samples": 0, "clamped_share": 0.0, "cancelled": False}
    for k, native in enumerate(passes):
        report = None if progress is None else (lambda f, k=k: progress((k + f) / len(passes)))
        settings.first_sample = k * settings.spp
        image, s = _core.render(native, settings, progress=report, features=None if k else features)
        stats["seconds"] += s["seconds"]
        for key in ("nonfinite_samples", "negative_samples"):
            stats[key] += s[key]
        stats["clamped_share"] += s["clamped_share"] / len(passes)  # the passes carry similar light
        if s["cancelled"]:
            stats["cancelled"] = True
            break
        film.add(k, image)
    image = film.image() if film.rgb is not None else np.zeros((*image.shape[:2], 3), np.float32)
    if out is not None:
        out[...] = image
        image = out
    return image, stats


def resolve_tracer(
    scene: Scene, tracer: str = "auto", tolerance: float = 0.01, max_depth: int = -1
) -> tuple[str, dict[str, Any] | None]:
    """(tracer, auto) for a render: "auto" becomes the cheapest sufficient tracer, with
    ``auto`` = its reasons and error bound (None when the tracer was given)."""
    if tracer != "auto":
        if tracer not in TRACERS:
            raise ValueError(f"unknown tracer '{tracer}' (expected auto or one of: {', '.join(TRACERS)})")
        return tracer, None
    chosen, reasons, bound = choose_tracer(scene, tolerance, max_depth)
    return chosen, {"tracer": chosen, "reasons": reasons, "bound": bound, "tolerance": tolerance}
