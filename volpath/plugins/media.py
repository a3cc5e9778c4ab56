"""Medium plugins: homogeneous, heterogeneous (grids, emission, blackbody) and the
atmosphere (a planet's air with its ground and top), with their phase functions."""

import math

import numpy as np

from .. import spectral
from . import kind_of, volumes
from .params import RGB_WAVELENGTHS, spectral_colour


def rayleigh_coefficient(wavelength_nm, n=1.00029, N=2.504e25):
    """Rayleigh scattering at sea level, 8 pi^3 (n^2 - 1)^2 / (3 N lambda^4), per metre."""
    lam = np.asarray(wavelength_nm, dtype=np.float64) * 1e-9
    return 8 * math.pi**3 * (n * n - 1) ** 2 / (3 * N * lam**4)


# Atmosphere presets, in metres. Bruneton 2017 / Hillaire 2020 is the physically sound
# default; "report" reproduces the physics of the original course report.
ATMOSPHERE_PRESETS = {
    "bruneton": dict(
        planet_radius=6360e3,
        atmosphere_height=60e3,
        rayleigh_scattering=(5.802e-6, 13.558e-6, 33.1e-6),
        rayleigh_height=8e3,
        mie_scattering=3.996e-6,
        mie_extinction=4.440e-6,
        mie_height=1.2e3,
        g=0.8,
        ozone=True,
        ozone_absorption=(0.650e-6, 1.881e-6, 0.085e-6),
        ground_albedo=0.1,
    ),
    "report": dict(
        planet_radius=6378e3,
        atmosphere_height=60e3,
        rayleigh_scattering=tuple(rayleigh_coefficient(RGB_WAVELENGTHS)),
        rayleigh_height=8.5e3,
        mie_scattering=3.996e-6,
        mie_extinction=3.996e-6 / 0.9,
        mie_height=1.2e3,
        g=0.76,
        ozone=False,
        ozone_absorption=(0.0, 0.0, 0.0),
        ground_albedo=(0.25, 0.25, 0.35),
    ),
}


def build(b, d):
    d = b.resolve(d)
    if id(d) in b.media:
        return b.media[id(d)]
    p = b.params(d, "medium")
    g = phase(b, p, d)
    p.raw("sample_emitters"), p.raw("has_spectral_extinction")
    p.ignored("method", "Mitsuba 0.5's integration method: Volpath tracks every medium by null scattering")
    p.ignored("step_size", "Mitsuba 0.5's ray-marching step: Volpath's trackers take no steps")
    scale = p.float("scale", 1.0, minimum=0.0)
    if p.type == "homogeneous":
        if p.has("sigma_a") or p.has("sigma_s"):  # Mitsuba 0.5 / lajolla
            sigma_a, sigma_s = p.rgb("sigma_a", 0.0) * scale, p.rgb("sigma_s", 0.0) * scale
        else:
            sigma_t = p.rgb("sigma_t", 1.0) * scale
            albedo = p.rgb("albedo", 0.75)
            if np.any(albedo > 1):
                raise p.error(f"'albedo' must be at most 1, got {list(albedo)}")
            sigma_s = sigma_t * albedo
            sigma_a = sigma_t - sigma_s
        Le = p.rgb("radiance", 0.0, emitted=True)
        if np.any(Le > 0) and not np.any(sigma_a > 0):
            raise p.error("'radiance' needs absorption: the medium emits sigma_a * radiance")
        index = b.native.add_medium_homogeneous(tuple(sigma_a), tuple(sigma_s), g, tuple(Le))
        b.summary["media"].append(
            {
                "index": index,
                "type": "homogeneous",
                "sigma_t": (sigma_a + sigma_s).tolist(),
                "emissive": bool(np.any(Le > 0)),
                "albedo": np.divide(
                    sigma_s, sigma_a + sigma_s, out=np.zeros(3), where=(sigma_a + sigma_s) > 0
                ).tolist(),
                "g": g,
                "loc": p.loc,
            }
        )
    elif p.type == "heterogeneous":
        density = spectral_grid(b, volumes.build(b, p, "density" if p.has("density") else "sigma_t", 1.0))
        albedo_grid = spectral_grid(b, volumes.build(b, p, "albedo", 0.75))
        albedo = np.ones(3)
        if volumes.is_constant(albedo_grid):
            albedo, albedo_grid = volumes.constant_rgb(albedo_grid), None
        if max(albedo.max(), albedo_grid.max() if albedo_grid else 0) > 1:
            raise p.error("'albedo' must be at most 1")
        Le_grid, Le_scale = grid_emission(b, p)
        majorant_res = p.int("majorant_resolution", 0)
        if not 0 <= majorant_res <= 64:
            raise p.error("'majorant_resolution' must be in 0..64 (0: automatic, 1: one global majorant)")
        index = b.native.add_medium_grid(
            density.native,
            density.world_to_grid,
            albedo_grid=albedo_grid and albedo_grid.native,
            albedo_world_to_grid=albedo_grid and albedo_grid.world_to_grid,
            albedo=tuple(albedo),
            scale=scale,
            g=g,
            majorant_res=majorant_res,
            Le_grid=Le_grid and Le_grid.native,
            Le_world_to_grid=Le_grid and Le_grid.world_to_grid,
            Le_scale=tuple(Le_scale),
        )
        b.summary["media"].append(
            {
                "index": index,
                "type": "heterogeneous",
                "sigma_t_range": [density.min() * scale, density.max() * scale],
                "resolution": list(density.shape[2::-1]),
                "g": g,
                "loc": p.loc,
                "memory": density.nbytes,
                "emissive": bool(np.any(Le_scale > 0)),
                "albedo": [albedo_grid.max()] * 3 if albedo_grid else albedo.tolist(),
            }
        )
    elif p.type == "atmosphere":
        index = atmosphere(b, p, scale)
    else:
        raise p.error("unknown medium (expected 'homogeneous', 'heterogeneous' or 'atmosphere')")
    p.check()
    b.media[id(d)] = index
    return index


def phase(b, p, d):
    phases = [k for k, v in d.items() if isinstance(v, dict) and kind_of(b.resolve(v)) == "phase"]
    if len(phases) > 1:
        raise p.error("more than one phase function")
    if not phases:
        return 0.0
    p.read.add(phases[0])
    pp = b.params(b.resolve(d[phases[0]]), "phase")
    if pp.type == "isotropic":
        g = 0.0
    elif pp.type == "hg":
        g = pp.float("g", 0.8)
        if not -1 < g < 1:
            raise pp.error(f"'g' must be in (-1, 1), got {g}")
    else:
        raise pp.error("unknown phase function (expected 'isotropic' or 'hg')")
    pp.check()
    return g


def grid_emission(b, p):
    """(Le grid or None, Le scale) of a heterogeneous medium: `radiance` (an rgb or a
    grid), or blackbody radiance from a `temperature` grid (kelvin) times
    `blackbody_scale`. Each grid has its own placement; the medium emits sigma_a * Le."""
    from ..blackbody import blackbody_rgb

    if p.has("radiance") and p.has("temperature"):
        raise p.error("give 'radiance' or 'temperature', not both")
    if p.has("temperature"):
        grid = volumes.build(b, p, "temperature", 0.0)
        if grid.channels != 1:
            raise p.error("'temperature' must be a one-channel grid (kelvin)")
        scale = p.float("blackbody_scale", 1.0, minimum=0.0)
        Le = spectral_grid(b, grid.map(lambda t: blackbody_rgb(t[..., 0])), emitted=True)
        if volumes.is_constant(Le):
            return None, volumes.constant_rgb(Le) * scale
        return Le, np.full(3, scale)
    grid = spectral_grid(b, volumes.build(b, p, "radiance", 0.0), emitted=True)
    if volumes.is_constant(grid):
        return None, volumes.constant_rgb(grid)
    return grid, np.ones(3)


def spectral_grid(b, grid, emitted=False):
    """A grid's values at a spectral pass's wavelengths (as given in RGB mode)."""
    if b.wavelengths is None or (grid.channels == 1 and not emitted):
        return grid  # grey is flat
    wavelengths = b.wavelengths
    return grid.map(lambda v: spectral_colour(np.broadcast_to(v, v.shape[:-1] + (3,)), wavelengths, emitted))


def atmosphere(b, p, scale):
    """The planet's air, its top-of-atmosphere boundary and (unless ground=false) the
    ground as a diffuse sphere. Lengths in metres times `unit` (metres per scene unit)."""
    preset = ATMOSPHERE_PRESETS[p.str("preset", "bruneton", tuple(ATMOSPHERE_PRESETS))]
    mode = p.str("mode", "rgb", ("rgb", "spectral"))
    passes = p.int("spectral_passes", 4)  # checked in RGB mode too: a scene may switch
    if not 1 <= passes <= 32:
        raise p.error("'spectral_passes' must be in 1..32 (three wavelengths each)")
    if mode == "spectral":
        b.spectral_passes = passes
    unit = p.float("unit", 1.0, positive=True)  # metres per scene unit
    R = p.float("planet_radius", preset["planet_radius"], positive=True) / unit
    H = p.float("atmosphere_height", preset["atmosphere_height"], positive=True) / unit
    center = p.vec3("center", [0.0, -R, 0.0])
    per_unit = unit * scale  # coefficients are per metre
    # Coefficients are given at 680 / 550 / 440 nm; a spectral pass takes Rayleigh's
    # lambda^-4 and ozone's band through the 550 nm value and Mie's mean (grey).
    raw = dict(spectral=False)
    rayleigh = (
        p.rgb("rayleigh_scattering", {"type": "rgb", "value": list(preset["rayleigh_scattering"])}, **raw) * per_unit
    )
    mie_s = p.rgb("mie_scattering", preset["mie_scattering"], **raw) * per_unit
    mie_t = p.rgb("mie_extinction", preset["mie_extinction"], **raw) * per_unit
    if np.any(mie_t < mie_s):
        raise p.error("'mie_extinction' must be at least 'mie_scattering'")
    ozone = p.bool("ozone", preset["ozone"])
    ozone_sigma = (
        p.rgb("ozone_absorption", {"type": "rgb", "value": list(preset["ozone_absorption"])}, **raw) * per_unit
    )
    if b.wavelengths is not None:
        rayleigh = spectral.rayleigh(rayleigh[1], b.wavelengths)
        mie_s, mie_t = np.full(3, mie_s.mean()), np.full(3, mie_t.mean())
        ozone_sigma = spectral.ozone(ozone_sigma[1], b.wavelengths)
    g = p.float("g", preset["g"])
    if not -1 < g < 1:
        raise p.error(f"'g' must be in (-1, 1), got {g}")
    h_r = p.float("rayleigh_height", preset["rayleigh_height"], positive=True) / unit
    h_m = p.float("mie_height", preset["mie_height"], positive=True) / unit
    pieces = p.int("majorant_pieces", 4)
    if not 1 <= pieces <= 16:
        raise p.error("'majorant_pieces' must be in 1..16")
    # Shadow rays to the sun: a table of optical depths, Simpson's rule, or ratio tracking.
    sun = p.str("sun_transmittance", "table", ("table", "quadrature", "tracking"))
    # Free flights: guided toward the sunlit air (transmittances by quadrature), or delta
    # tracking, which the fully unbiased sun_transmittance="tracking" implies.
    flight = p.str("free_flight", "tracking" if sun == "tracking" else "guided", ("guided", "tracking"))
    # The sky map (directions after scattering, control variates): off only to measure it.
    sky_map = p.bool("sky_map", True)
    albedo = p.rgb("ground_albedo", preset["ground_albedo"])
    if np.any(albedo > 1):
        raise p.error("'ground_albedo' must be at most 1")
    n = b.native
    index = n.add_medium_atmosphere(
        tuple(center),
        R,
        R + H,
        tuple(rayleigh),
        h_r,
        tuple(mie_s),
        tuple(mie_t - mie_s),
        h_m,
        g,
        tuple(ozone_sigma if ozone else np.zeros(3)),
        pieces,
        sun,
        flight,
        sky_map,
    )
    n.add_sphere(tuple(center), R + H, False, n.add_bsdf_null(), interior=index, exterior=-1, medium_interface=True)
    if p.bool("ground", True):
        n.add_sphere(
            tuple(center),
            R,
            False,
            n.add_bsdf_diffuse(tuple(albedo), False),
            interior=-1,
            exterior=index,
            medium_interface=True,
        )
    b.atmospheres.append((index, center, R + H))
    b.summary["media"].append(
        {
            "index": index,
            "type": "atmosphere",
            "mode": mode,
            "planet_radius": R,
            "height": H,
            "sigma_t": (rayleigh + mie_t + (ozone_sigma if ozone else 0)).tolist(),
            "albedo": [float("nan")] * 3,
            "g": g,
            "loc": p.loc,
        }
    )
    return index
