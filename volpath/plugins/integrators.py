"""Integrator plugins: Mitsuba's volpath / volpathmis / path and lajolla's versioned tracers,
all to Volpath's render settings."""

from .. import _core

TRACERS = tuple(t.name for t in _core.Tracer)  # absorption, single, multiple, nee_mis, null_scattering
DEFAULTS = _core.TracerConfig()  # the core's defaults, the one source of them
# lajolla's integrator `version` numbering of its staged tracers.
LAJOLLA_VERSIONS = {1: "absorption", 2: "single", 3: "multiple", 4: "nee_mis", 5: "nee_mis", 6: "null_scattering"}
# Mitsuba's integrators leave the choice to the scene analysis (tracer="auto"); a lajolla
# `version` names one tracer explicitly.
INTEGRATORS = {"volpath": "auto", "volpathmis": "auto", "path": "auto"}


def build(b, d):
    settings = {
        "max_depth": DEFAULTS.max_depth,
        "rr_depth": DEFAULTS.rr_depth,
        "max_null_collisions": DEFAULTS.max_null_collisions,
        "light_distances": DEFAULTS.light_distances,
        "tracer": "auto",
    }
    if d is None:
        return settings
    p = b.params(d, "integrator")
    if p.type not in INTEGRATORS:
        raise p.error(f"unknown integrator (expected one of: {', '.join(INTEGRATORS)})")
    settings["tracer"] = INTEGRATORS[p.type]
    if p.has("version"):
        version = p.int("version")
        if version not in LAJOLLA_VERSIONS:
            raise p.error(f"'version' must be 1..6 (lajolla's tracers), got {version}")
        settings["tracer"] = LAJOLLA_VERSIONS[version]
    settings["max_depth"] = p.int("max_depth", DEFAULTS.max_depth)
    if settings["max_depth"] < -1 or settings["max_depth"] == 0:
        raise p.error("'max_depth' must be -1 (unlimited) or at least 1")
    settings["rr_depth"] = p.int("rr_depth", DEFAULTS.rr_depth)
    if settings["rr_depth"] < 1:
        raise p.error("'rr_depth' must be at least 1")
    settings["max_null_collisions"] = p.int("max_null_collisions", DEFAULTS.max_null_collisions)
    settings["light_distances"] = p.bool("light_distances", DEFAULTS.light_distances)
    if p.bool("hide_emitters", False):
        raise p.error("'hide_emitters' is not supported")
    p.check()
    return settings
