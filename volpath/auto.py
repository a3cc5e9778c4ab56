"""tracer="auto": simulate only what the scene calls for.

Before rendering, the scene's contents (media, their albedo and optical thickness,
scattering surfaces, delta lights) decide the cheapest tracer whose omitted effects stay
below `tolerance` (a fraction of the image). The choice and its reasons are reported.
"""

import math


def choose_tracer(scene, tolerance=0.01, max_depth=-1):
    """Return (tracer, reasons, bound): bound is an upper estimate of what the choice
    leaves out, relative to what it renders (0 when it is exact)."""
    s = scene.summary
    media = s["media"]
    surfaces = [sh for sh in s["shapes"] if sh.get("bsdf") != "null" and not sh["emitter"]]
    delta_lights = [e for e in s["emitters"] if e["type"] in ("point", "directional")]
    if not media:
        return "nee_mis", ["no participating media: surface path tracing, NEE combined with BSDF sampling"], 0.0
    kinds = sorted({m["type"] for m in media})
    grey = all(len(set(m.get("sigma_t", [0]))) == 1 for m in media)
    spectral = (
        "grey media: one channel's distances serve all three (spectral MIS is a no-op)"
        if grey
        else "chromatic media: distances sampled in one channel, pdfs averaged over RGB (spectral MIS)"
    )
    albedo_max = max(max(m["albedo"]) for m in media) if "atmosphere" not in kinds else 1.0
    if albedo_max == 0 and not surfaces and not delta_lights:
        emissive = " (emission included)" if any(m.get("emissive") for m in media) else ""
        return (
            "absorption",
            [
                f"media only absorb{emissive} and no surface or delta light can scatter light "
                "towards the camera: exact transmittance (ratio tracking in grids), no scattering",
                spectral,
            ],
            0.0,
        )
    if any(k != "homogeneous" for k in kinds):
        return (
            "null_scattering",
            [
                f"{', '.join(k for k in kinds if k != 'homogeneous')} medium: delta tracking "
                "against majorants, ratio tracking on shadow rays",
                spectral,
            ],
            0.0,
        )
    if max_depth in (1, 2):
        # The depth limit already restricts the physics; the lighter tracer is exact for it.
        tracer = "absorption" if max_depth == 1 else "single"
        return tracer, [f"max_depth {max_depth}: {tracer} computes exactly the paths it allows", spectral], 0.0
    if albedo_max == 0:
        return (
            "nee_mis",
            [
                "media only absorb: closed-form transmittance on every ray, no distance sampling",
                "scattering surfaces or delta lights: NEE + MIS",
            ],
            0.0,
        )
    tau = max((m.get("optical_thickness") or [math.inf, math.inf])[1] for m in media)
    # Once-scattered light scatters again with probability at most albedo (1 - e^-tau)
    # before leaving the media; the series of further orders sums to q / (1 - q).
    q = albedo_max * (1 - math.exp(-tau)) if math.isfinite(tau) else albedo_max
    bound = q / (1 - q) if q < 1 else math.inf
    if not surfaces and bound < tolerance:
        return (
            "single",
            [
                f"optically thin media (optical thickness <= {tau:.3g}, albedo <= {albedo_max:.3g}): "
                f"multiple scattering adds at most {bound:.2%} of single scattering "
                f"(tolerance {tolerance:.2%})",
                spectral,
            ],
            bound,
        )
    reason = "homogeneous media only: closed-form free flight and shadow transmittance, no majorant structures"
    return "nee_mis", [reason, spectral], 0.0
