"""The atmosphere against closed-form oracles: transmittance along exponential profiles,
the sphere quadratic at planet scale, white furnaces, and single scattering by quadrature."""

import math

import numpy as np
import pytest

import scenes as S
import volpath
from volpath import _core, _probes
from volpath.plugins.media import ATMOSPHERE_PRESETS, rayleigh_coefficient
from volpath.spectral import pass_wavelengths, white
from volpath.testing import MIN_BATCHES, chi2_directions, max_z, render_batches

R = 6360e3
B = ATMOSPHERE_PRESETS["bruneton"]


def air_scene(
    medium_params="",
    camera_origin="0, 1, 0",
    target="0, 1, -1",
    res=4,
    fov=30,
    spp=16,
    lights="",
    max_depth=-1,
    up="0, 1, 0",
):
    cam = S.camera(
        res=res,
        fov=fov,
        origin=camera_origin,
        target=target,
        spp=spp,
        up=up,
        extra='<float name="far_clip" value="1e9"/>',
    )
    return volpath.load_string(
        S.scene(cam, f'<medium type="atmosphere" id="air">{medium_params}</medium>', lights, max_depth=max_depth)
    )


# -- phase functions (oracle 4) --------------------------------------------------------------


def test_phase_values_and_normalisation():
    from scipy.integrate import quad

    assert abs(_probes.rayleigh_eval(1.0) - 0.119366) < 1e-6
    assert abs(_probes.cornette_shanks_eval(0.76, 1.0) - 2.8300) < 1e-4
    assert abs(_probes.cornette_shanks_eval(0.76, -1.0) - 0.00718) < 1e-5
    mean_cos = quad(lambda mu: 2 * math.pi * mu * _probes.cornette_shanks_eval(0.76, mu), -1, 1, epsabs=1e-12)[0]
    assert abs(mean_cos - 0.8098) < 1e-4
    for f in (
        lambda mu: _probes.rayleigh_eval(mu),
        lambda mu: _probes.cornette_shanks_eval(0.76, mu),
        lambda mu: _probes.cornette_shanks_eval(0.8, mu),
    ):
        assert abs(quad(lambda mu: 2 * math.pi * f(mu), -1, 1, epsabs=1e-12)[0] - 1) < 1e-9


@pytest.mark.parametrize("channel", [0, 2])
def test_air_phase_sampling_chi2(channel):
    """The Rayleigh + Mie mixture is sampled per channel; chi-square against its pdf
    (200 000 samples, rejection below p = 1e-4 as in tests/stats)."""
    fraction = (0.7, 0.5, 0.9)
    n = 200_000
    u = np.random.default_rng(4).random((n, 3))
    dirs, pdfs = _probes.air_phase_sample(fraction, 0.76, channel, u)
    marginal = lambda z: 2 * math.pi * _probes.air_phase_pdf(fraction, 0.76, channel, z)
    assert chi2_directions(dirs, None, n, z_marginal=marginal) > 1e-4


# -- planet intersection (oracle 5) -----------------------------------------------------------


@pytest.mark.parametrize("elevation,expected", [(-1.0, 57.3135), (-0.1, 588.561)])
def test_planet_intersection_from_one_metre(elevation, expected):
    e = math.radians(elevation)
    roots = _probes.sphere_roots((0, -R, 0), R, (0, 1, 0), (math.cos(e), math.sin(e), 0))
    assert roots is not None
    t = min(r for r in roots if r > 0)
    assert abs(t - expected) / expected < 1e-6


def test_planet_intersection_against_exact_arithmetic():
    """Rays from 0.1 m to 1000 km above the ground, within 3 degrees of the horizontal: both
    roots within 1e-8 of the same roots computed with 50 significant digits (from the same
    double inputs). Measured: 5e-9 at worst over 1000 rays."""
    from decimal import Decimal, localcontext

    rng = np.random.default_rng(7)
    with localcontext() as ctx:
        ctx.prec = 50
        for _ in range(500):
            h, e = 10 ** rng.uniform(-1, 6), math.radians(rng.uniform(-3, 3))
            d = (math.cos(e), math.sin(e), 0.0)
            oc = [Decimal(0), Decimal(h) + Decimal(R), Decimal(0)]
            dd = [Decimal(x) for x in d]
            norm = sum(x * x for x in dd).sqrt()
            dd = [x / norm for x in dd]
            b = sum(x * y for x, y in zip(oc, dd))
            disc = b * b - (sum(x * x for x in oc) - Decimal(R) ** 2)
            roots = _probes.sphere_roots((0, -R, 0), R, (0, h, 0), d)
            assert (roots is None) == (disc < 0), (h, e)
            if roots is not None:
                for got, exact in zip(roots, (-b - disc.sqrt(), -b + disc.sqrt())):
                    assert abs((Decimal(got) - exact) / exact) < Decimal("1e-8"), (h, e, got, exact)


def test_horizon_distance():
    h = 1.0
    horizon = math.sqrt(h * (2 * R + h))
    assert abs(horizon - 3566.51) < 0.01
    # The tangent ray just grazes: distance to the tangent point along the horizontal
    # direction tilted down by the horizon dip angle.
    dip = math.acos(R / (R + h))
    roots = _probes.sphere_roots((0, -R, 0), R, (0, h, 0), (math.cos(dip), -math.sin(dip), 0))
    assert roots is not None and abs(roots[0] - horizon) / horizon < 1e-6


# -- transmittance (oracles 1, 2) --------------------------------------------------------------


def vertical_tau(beta, H, top=60e3):
    return beta * H * (1 - math.exp(-top / H))


def test_vertical_transmittance_oracle():
    scene = air_scene()
    tau = np.array(_probes.optical_depth(scene.native, 0, (0, 0, 0), (0, 1, 0), 60e3, 256))
    T = np.exp(-tau)
    # R, G, B = 680, 550, 440 nm
    assert np.allclose(T, [0.9404, 0.8677, 0.7624], atol=1e-3)
    # The closed form, component by component (ozone's tent integrates to 15 km of peak).
    closed = (
        vertical_tau(np.array(B["rayleigh_scattering"]), 8e3)
        + vertical_tau(4.44e-6, 1.2e3)
        + np.array(B["ozone_absorption"]) * 15e3
    )
    assert np.allclose(tau, closed, rtol=1e-6)


def test_ratio_tracking_is_unbiased_through_the_atmosphere():
    """Ratio tracking along vertical, slanted and horizontal rays agrees with quadrature
    within 5 standard errors of 20 000 estimates."""
    scene = air_scene()
    for d in [(0, 1, 0), (1, 0.2, 0), (1, 0.0, 0)]:
        d = np.array(d) / np.linalg.norm(d)
        roots = _probes.sphere_roots((0, -R, 0), R + 60e3, (0, 0.1, 0), tuple(d))
        t_max = roots[1]
        tau = np.array(_probes.optical_depth(scene.native, 0, (0, 0.1, 0), tuple(d), t_max, 4096))
        mean, se = _probes.ratio_tracking(scene.native, 0, (0, 0.1, 0), tuple(d), t_max, 20000, 9)
        assert np.all(np.abs(np.array(mean) - np.exp(-tau)) <= 5 * np.array(se) + 1e-9), (d, mean, np.exp(-tau), se)


def test_horizontal_air_mass():
    """Oracle 2: Chapman air masses at R = 6360 km, and the horizontal optical depth."""
    scene = air_scene(
        '<boolean name="ozone" value="false"/><rgb name="mie_extinction" value="0"/>'
        '<rgb name="mie_scattering" value="0"/><rgb name="rayleigh_scattering" value="1e-6"/>'
    )
    roots = _probes.sphere_roots((0, -R, 0), R + 60e3, (0, 0, 0), (1, 0, 0))
    tau = _probes.optical_depth(scene.native, 0, (0, 0, 0), (1, 0, 0), roots[1], 20000)[0]
    assert abs(tau / (1e-6 * 8e3) - 35.355) / 35.355 < 2e-3
    scene = air_scene(
        '<boolean name="ozone" value="false"/><float name="rayleigh_height" value="1200"/>'
        '<rgb name="mie_extinction" value="0"/><rgb name="mie_scattering" value="0"/>'
        '<rgb name="rayleigh_scattering" value="1e-6"/>'
    )
    tau = _probes.optical_depth(scene.native, 0, (0, 0, 0), (1, 0, 0), roots[1], 20000)[0]
    assert abs(tau / (1e-6 * 1.2e3) - 91.249) / 91.249 < 2e-3


# -- rendering ----------------------------------------------------------------------------------


@pytest.mark.parametrize("flight", ["tracking", "guided"])
def test_single_scattering_at_the_zenith(flight):
    """Oracle 3: sun at the zenith, camera on the ground looking up. Every scattered path
    has the same transmittance, so L = E exp(-tau_t) (tau_R p_R(1) + tau_Ms p_CS(1)).
    The sun is a directional light here (a disc of 0.27 degrees changes L by < 0.1 %)."""
    from volpath.testing import render_batches

    scene = air_scene(
        f'<string name="free_flight" value="{flight}"/>',
        camera_origin="0, 0.1, 0",
        target="0, 1, 0",
        up="0, 0, -1",
        fov=0.01,
        spp=16384 if flight == "tracking" else 64,
        max_depth=2,
        lights='<emitter type="directional"><vector name="direction" value="0, -1, 0"/>'
        '<rgb name="irradiance" value="1"/></emitter>',
    )
    mean, se = render_batches(volpath.render, scene, 8, block=4)
    tau_r = vertical_tau(np.array(B["rayleigh_scattering"]), 8e3)
    tau_ms = vertical_tau(3.996e-6, 1.2e3)
    tau_t = tau_r + vertical_tau(4.44e-6, 1.2e3) + np.array(B["ozone_absorption"]) * 15e3
    expected = np.exp(-tau_t) * (tau_r * _probes.rayleigh_eval(1.0) + tau_ms * _probes.cornette_shanks_eval(0.8, 1.0))
    mean, se = mean.reshape(3), se.reshape(3)
    if flight == "tracking":
        # Free flight finds a real collision in only ~5-15 % of the samples, so the noise is
        # estimated from 16 independent batches of 16 x 8192 samples: 5 standard errors
        # (about 1.5 %) for each channel.
        assert np.all(np.abs(mean - expected) < 5 * se), (mean, expected, se)
        assert np.all(se / expected < 0.006)
    else:
        # The guided flight samples collisions in proportion to the integrand (up to its
        # fit by exponentials between nodes): 8 x 16 x 64 samples leave a standard error
        # below 1e-3 of the value (tracking: 6e-3 from 256 times as many), and the
        # transmittances from the table err by at most 3e-4 of the value here.
        assert np.all(np.abs(mean - expected) < 5 * se + 3e-4 * expected), (mean, expected, se)
        assert np.all(se / expected < 1e-3), se / expected


def test_energy_is_conserved_in_a_furnace():
    """Oracle 6: ground albedo 1, no absorption, uniform unit sky: radiance 1 everywhere."""
    scene = air_scene(
        '<boolean name="ozone" value="false"/><float name="mie_extinction" value="3.996e-6"/>'
        '<rgb name="ground_albedo" value="1"/>',
        camera_origin="0, 10, 0",
        target="0, 9.9, -1",
        res=6,
        fov=60,
        spp=64,
        lights=S.constant_env("1, 1, 1"),
    )
    image = volpath.render(scene, seed=1).astype(np.float64)
    assert np.all(np.isfinite(image))
    # Paths bounce between air and ground; 36 pixels x 64 spp. The spread per sample is
    # below 1 (Russian roulette weights up to 1/0.95), so 5 standard errors is 0.02.
    assert abs(image.mean() - 1) < 0.02, image.mean()


def sky_scene(elevation, target, fov=5, spp=256, res=4, mode="rgb"):
    return air_scene(
        f'<string name="mode" value="{mode}"/>',
        camera_origin="0, 2, 0",
        target=target,
        fov=fov,
        spp=spp,
        res=res,
        lights=f'<emitter type="sun"><float name="elevation" value="{elevation}"/>'
        f'<float name="azimuth" value="180"/><rgb name="irradiance" value="1"/></emitter>',
    )


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_noon_zenith_is_bluer_than_the_horizon(mode):
    zenith = volpath.render(sky_scene(70, "0.001, 3, 0", mode=mode)).reshape(-1, 3).mean(axis=0)
    horizon = volpath.render(sky_scene(70, "0, 2.05, -1", mode=mode)).reshape(-1, 3).mean(axis=0)
    # Blue over red: the zenith sky is far bluer than the whitish horizon.
    assert zenith[2] / zenith[0] > 1.3 * horizon[2] / horizon[0], (zenith, horizon)


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_sun_disc_is_redder_at_sunrise(mode):
    """Seen through the whole air mass, the sun's disc loses blue first."""

    def disc(elevation):
        e = math.radians(elevation)
        target = f"{0}, {2 + math.sin(e)}, {math.cos(e)}"
        scene = sky_scene(elevation, target, fov=0.2, spp=16, mode=mode)
        return volpath.render(scene, max_depth=1).reshape(-1, 3).mean(axis=0)

    low, high = disc(0.5), disc(30)
    # Red over blue five times higher (spectral: the low disc's blue may be out of the sRGB
    # gamut, clipped to 0).
    assert low[0] * high[2] > 5 * high[0] * low[2], (low, high)


@pytest.mark.parametrize("elevation", [-20, -2, 0, 5, 90])
@pytest.mark.parametrize("altitude", [0.1, 1e4, 1e6])
def test_no_nan_or_negative_anywhere(elevation, altitude):
    scene = air_scene(
        camera_origin=f"0, {altitude}, 0",
        target=f"0, {altitude - 0.2}, -1",
        res=6,
        fov=120,
        spp=4,
        lights=f'<emitter type="sun"><float name="elevation" value="{elevation}"/>'
        '<rgb name="irradiance" value="1"/></emitter>',
    )
    image = volpath.render(scene, seed=3)
    assert np.all(np.isfinite(image)) and image.min() >= 0
    assert scene.last_render["nonfinite_samples"] == 0


def test_report_preset():
    assert np.allclose(rayleigh_coefficient([680, 550, 440]), [5.197e-6, 1.214e-5, 2.965e-5], rtol=1e-3)
    scene = air_scene('<string name="preset" value="report"/>')
    m = scene.summary["media"][0]
    assert m["planet_radius"] == 6378e3 and m["g"] == 0.76


# The sun out of view: camera rays that land on its 0.27-degree disc are too rare for a
# z-test over a few batches.
SUN_5_DEGREES_ASIDE = (
    '<emitter type="sun"><float name="elevation" value="5"/><float name="azimuth" value="90"/></emitter>'
)


def test_one_majorant_or_many_agree():
    """Under delta tracking the majorant pieces change the sampling, not the answer (z-test,
    5 s.e.)."""
    from volpath.testing import render_batches

    res = []
    for pieces in (1, 16):
        scene = air_scene(
            f'<integer name="majorant_pieces" value="{pieces}"/><string name="free_flight" value="tracking"/>',
            camera_origin="0, 2, 0",
            target="0, 2.2, -1",
            res=4,
            fov=40,
            spp=64,
            lights=SUN_5_DEGREES_ASIDE,
        )
        res.append(render_batches(volpath.render, scene, 6, block=2))
    (a, sa), (b, sb) = res
    assert np.max(np.abs(a - b) / np.sqrt(sa**2 + sb**2 + 1e-12)) < 5


def test_tabulated_and_ratio_tracked_sun_agree():
    """sun_transmittance="tracking" (unbiased: delta tracking and ratio tracking throughout),
    "quadrature" and the default "table" (both with the guided free flight) render the same
    sky (z-tests, 5 s.e.: the table's and the quadrature's errors, T within 1e-3, are far
    below the noise of these renders); tracking is the noisiest at 5 degrees."""
    from volpath.testing import render_batches

    res = {}
    for method in ("tracking", "quadrature", "table"):
        scene = air_scene(
            f'<string name="sun_transmittance" value="{method}"/>',
            camera_origin="0, 2, 0",
            target="0, 2.2, -1",
            res=4,
            fov=40,
            spp=64,
            lights=SUN_5_DEGREES_ASIDE,
        )
        res[method] = render_batches(volpath.render, scene, 6, block=2)
    (a, sa) = res["tracking"]
    for method in ("quadrature", "table"):
        b, sb = res[method]
        assert np.max(np.abs(a - b) / np.sqrt(sa**2 + sb**2 + 1e-12)) < 5, method
        assert np.mean(sb) < np.mean(sa), method


# -- spectral mode ---------------------------------------------------------------------------


def test_spectral_mode_changes_only_what_depends_on_wavelength():
    """Air without coefficients, a grey sphere under the sun and a grey sky: every spectral
    pass sees the scene scaled by the white illuminant, which the white balance maps back to
    1, so spectral and RGB agree (z-tests on 4x4 blocks over 16 batches). The passes share
    the samples out: pass k renders samples 2k, 2k + 1 of 8, and with those alone it equals
    RGB's render of the same samples to rounding."""

    def render(mode, spp):
        scene = air_scene(
            f'<string name="mode" value="{mode}"/><rgb name="rayleigh_scattering" value="0"/>'
            '<float name="mie_scattering" value="0"/><float name="mie_extinction" value="0"/>'
            '<boolean name="ozone" value="false"/><boolean name="ground" value="false"/>',
            camera_origin="0, 1, 5",
            target="0, 1, 0",
            res=8,
            fov=30,
            spp=8,
            lights='<shape type="sphere"><point name="center" value="0, 1, 0"/><bsdf type="diffuse">'
            '<rgb name="reflectance" value="0.5"/></bsdf></shape>'
            '<emitter type="sun"><float name="elevation" value="40"/><rgb name="irradiance" value="3"/>'
            "</emitter>" + S.constant_env("0.2, 0.2, 0.2"),
        )
        return scene

    rgb_scene, spectral_scene = render("rgb", 8), render("spectral", 8)
    assert len(rgb_scene.passes) == 0 and len(spectral_scene.passes) == 4
    rgb, spectral = (render_batches(volpath.render, s, 6, block=4, spp=64) for s in (rgb_scene, spectral_scene))
    assert rgb[0].mean() > 0 and max_z(*rgb, *spectral) < 5
    assert spectral_scene.last_render["spp"] == 6 * 64 // MIN_BATCHES  # each batch's, all passes together

    def samples(native, first):  # two samples of every pixel, from sample index `first` on
        return _core.render(native, _core.RenderSettings(spp=2, seed=5, first_sample=first))[0]

    assert not np.allclose(samples(rgb_scene.native, 0), samples(rgb_scene.native, 2))
    for k, (native, lam) in enumerate(zip(spectral_scene.passes, pass_wavelengths(4))):
        assert np.allclose(samples(native, 2 * k) / white(lam), samples(rgb_scene.native, 2 * k), rtol=1e-5, atol=1e-7)


def test_spectral_uplift_round_trips_rgb_colours():
    """A colour lit by the white illuminant comes back within 0.05 (partition-of-unity
    spectra are smooth: saturated colours shift a little), and white exactly."""
    from volpath import spectral

    for passes in (4, 8):
        film = spectral.Film(passes)
        for rgb in ([1, 1, 1], [0.8, 0.1, 0.1], [0.1, 0.8, 0.1], [0.1, 0.1, 0.8], [0.5, 0.3, 0.1]):
            film.rgb = None
            for k, lam in enumerate(film.wavelengths):
                film.add(k, (spectral.uplift(rgb, lam) * spectral.white(lam))[None, None])
            assert np.allclose(film.image()[0, 0], rgb, atol=0.05 if rgb != [1, 1, 1] else 1e-6), (passes, rgb)


def test_spectral_coefficients_follow_their_laws():
    from volpath import spectral

    assert np.allclose(spectral.rayleigh(13.558e-6, [680, 550, 440]), [5.80e-6, 13.558e-6, 33.1e-6], rtol=0.01)
    # Ozone's band reproduces Bruneton's RGB ratios (0.345 : 1 : 0.045) to 10 %.
    assert np.allclose(spectral.ozone(1.881e-6, [680, 550, 440]), [0.650e-6, 1.881e-6, 0.085e-6], rtol=0.1)
    lam = spectral.pass_wavelengths(4)
    assert lam.shape == (4, 3) and np.allclose(np.sort(lam.ravel()), 360 + (np.arange(12) + 0.5) * 470 / 12)


def test_sun_transmittance_table_error():
    """Shadow rays to the sun through the air take their optical depth from a table over
    (altitude, direction) (AtmosphereMedium::tau_to_top, 256 x 256 entries) instead of
    ratio tracking. Against a 4000-interval Simpson reference, from the ground to the top
    of the atmosphere and for the sun from the zenith down to the horizon's dip (below it,
    the ground blocks the shadow ray): T within 6e-4 everywhere (the largest errors sit at
    the kinks of ozone's tent profile), and below 10 km, where nearly all the scattering
    happens, tau within 5e-4 tau + 2e-4 (T within 0.05 % per unit of tau) wherever T is
    above 1e-4."""
    scene = air_scene()
    for altitude in np.concatenate([[0.1, 2.0, 100.0], np.linspace(1e3, 59e3, 30)]):
        dip = math.degrees(math.acos(6360e3 / (6360e3 + altitude)))
        for elevation in np.concatenate([[90, 30, 10, 5, 2, 1, 0.5, 0], -np.linspace(0, 0.999 * dip, 6)]):
            e = math.radians(elevation)
            d = (0.0, math.sin(e), math.cos(e))
            tau = np.array(_probes.sun_optical_depth(scene.native, 0, (0.0, altitude, 0.0), d, 1e9))
            ref = np.array(_probes.optical_depth(scene.native, 0, (0.0, altitude, 0.0), d, 1e9, 4000))
            assert np.all(np.abs(np.exp(-tau) - np.exp(-ref)) < 6e-4), (altitude, elevation, tau, ref)
            if altitude <= 1e4:
                visible = ref < -math.log(1e-4)
                assert np.all((np.abs(tau - ref) < 5e-4 * ref + 2e-4)[visible]), (altitude, elevation, tau, ref)


def test_sun_transmittance_short_of_the_top_takes_the_quadrature():
    """A shadow-ray segment that stops inside the air (at an object) is not what the table
    holds: it takes Simpson's rule on its own span, with fewer intervals on short spans
    (each at most a fifth of Mie's scale height), from the ground and from 3 km up."""
    scene = air_scene()
    for elevation in (0.5, 5, 30, 90):
        d = (0.0, math.sin(math.radians(elevation)), math.cos(math.radians(elevation)))
        for o in ((0.0, 2.0, 0.0), (0.0, 3e3, 0.0)):
            for t_max in (10.0, 300.0, 1e3, 2e3, 5e3, 2e4):
                tau = np.array(_probes.sun_optical_depth(scene.native, 0, o, d, t_max))
                ref = np.array(_probes.optical_depth(scene.native, 0, o, d, t_max, 4000))
                assert np.allclose(tau, ref, rtol=1e-4, atol=1e-9), (elevation, o, t_max, tau, ref)


def test_bad_atmosphere_options_name_file_line_and_choices():
    """A wrong `sun_transmittance` or `spectral_passes` (checked in RGB mode too) is a
    SceneError naming the file position and what was expected."""
    import pytest

    with pytest.raises(
        volpath.SceneError,
        match=r":\d+: .*'sun_transmittance' is 'exact', expected one of: "
        r"table, quadrature, tracking",
    ):
        air_scene('<string name="sun_transmittance" value="exact"/>')
    with pytest.raises(volpath.SceneError, match=r":\d+: .*'spectral_passes' must be in 1..32"):
        air_scene('<integer name="spectral_passes" value="0"/>')


# -- the guided free flight ------------------------------------------------------------------


def ray_to_ground_or_top(o, d):
    """Distance from o along d to the ground if d meets it, else to the top of the air."""
    c = np.array([0.0, -R, 0.0])
    oc = np.asarray(o) - c
    b = oc @ d
    for radius, first in ((R, True), (R + 60e3, False)):
        disc = b * b - (oc @ oc - radius * radius)
        if disc >= 0 and (not first or -b - math.sqrt(disc) > 0):
            return -b - math.sqrt(disc) if first else -b + math.sqrt(disc)


def guided_rays():
    for altitude in (0.1, 2.0, 100.0, 1e3, 5e3, 2e4, 5e4, 59e3):
        for elevation in (90, 30, 10, 5, 2, 1, 0.5, 0, -0.5, -1, -2, -5, -30, -90):
            e = math.radians(elevation)
            yield np.array([0.0, altitude, 0.0]), np.array([0.0, math.sin(e), math.cos(e)])


def test_guided_transmittance_error():
    """The guided free flight weighs collisions and crossings with T from the table of
    depths to the top (the difference of two lookups, along -d for rays that meet the
    ground). Against a 20000-interval Simpson reference, from 0.1 m to 59 km up, looking
    from straight up to straight down, at fractions of the way to the ground or the top:
    T within 1e-3 (the largest errors are where the two lookups nearly cancel, on slightly
    downward rays in the low air)."""
    scene = air_scene(lights='<emitter type="sun"><float name="elevation" value="2"/></emitter>')
    worst = 0.0
    for o, d in guided_rays():
        t_max = ray_to_ground_or_top(o, d)
        ts = t_max * np.array([0.001, 0.01, 0.1, 0.3, 0.7, 1.0])
        tau, _, _ = _probes.air_segment(scene.native, 0, tuple(o), tuple(d), t_max, ts, np.array([0.5]))
        for t, tau_t in zip(ts, tau):
            ref = np.array(_probes.optical_depth(scene.native, 0, tuple(o), tuple(d), t, 20000))
            worst = max(worst, float(np.max(np.abs(np.exp(-tau_t) - np.exp(-ref)))))
    assert worst < 1e-3, worst


def test_guided_collision_density_matches_its_samples():
    """Sampler/pdf consistency: t(u) is the inverse of the density's integral, so its
    derivative is 1 / pdf (central differences, 0.5 %), t grows with u and stays on the
    segment; checked on rays up, along the horizon, down to the ground, from space through
    the limb, and 500 m of level air (modelled by its two ends)."""
    scene = air_scene(lights='<emitter type="sun"><float name="elevation" value="2"/></emitter>')
    cases = [
        ((0.0, 2.0, 0.0), 10, 1e9),
        ((0.0, 2.0, 0.0), 0, 1e9),
        ((0.0, 5e3, 0.0), -20, 1e9),
        ((0.0, 1e3, 0.0), -1, 1e9),
        ((0.0, 70e3, -2000e3), -1.5, 1e9),
        ((0.0, 30.0, 0.0), -1, 500.0),
    ]
    u = np.linspace(0.001, 0.999, 999)
    h = 1e-5
    for o, elevation, t_max in cases:
        e = math.radians(elevation)
        d = (0.0, math.sin(e), math.cos(e))
        _, t, pdf = _probes.air_segment(scene.native, 0, o, d, t_max, np.array([0.0]), u)
        _, t_lo, _ = _probes.air_segment(scene.native, 0, o, d, t_max, np.array([0.0]), u - h)
        _, t_hi, _ = _probes.air_segment(scene.native, 0, o, d, t_max, np.array([0.0]), u + h)
        assert np.all(np.isfinite(t)) and np.all(pdf > 0) and np.all(np.diff(t) > 0), (o, elevation)
        assert np.all(t <= t_max), (o, elevation)
        assert np.allclose((t_hi - t_lo) / (2 * h) * pdf, 1, rtol=5e-3), (o, elevation)


def test_guided_and_tracked_free_flights_agree():
    """The specialised sampler and the generic null-scattering path (delta tracking against
    the majorant pieces, the air as a heterogeneous medium) render the same sky, with
    multiple scattering, at sunrise and from space through the limb (z-tests, 5 s.e.), and
    the guided one with less noise at sunrise."""
    from volpath.testing import max_z, render_batches

    views = {
        "sunrise": dict(camera_origin="0, 2, 0", target="0.5, 2.3, -1", elevation=2),
        "limb": dict(camera_origin="0, 400e3, 0", target="0, 399.94e3, -1", elevation=10),
    }
    for name, v in views.items():
        res = {}
        for flight in ("tracking", "guided"):
            scene = air_scene(
                f'<string name="free_flight" value="{flight}"/>',
                camera_origin=v["camera_origin"],
                target=v["target"],
                res=4,
                fov=40,
                spp=64,
                lights=f'<emitter type="sun"><float name="elevation" value="{v["elevation"]}"/>'
                '<float name="azimuth" value="120"/></emitter>',
            )
            res[flight] = render_batches(volpath.render, scene, 6, block=2)
        (a, sa), (b, sb) = res["tracking"], res["guided"]
        assert max_z(a, sa, b, sb) < 5, name
        if name == "sunrise":
            assert np.mean(sb) < np.mean(sa), (np.mean(sb), np.mean(sa))


def test_sun_disc_seen_through_a_medium_inside_the_air():
    """The camera sees the sun's disc through a thin fog sphere in the air: after leaving the
    fog the camera ray is back in guided air with no scattering behind it (so no NEE found
    the disc), and it must still fly through to the disc. The fog (optical depth 2e-3)
    changes the disc by well under 1 %; with and without it, and with delta tracking through
    the air, the means of 8 renders agree within 5 standard errors (estimated from their
    spread: per render, about 2.5 % for the guided flight and 12 % for delta tracking in
    the blue channel)."""
    fog = S.homogeneous("fog", "1e-3", "0.5") + (
        '<shape type="sphere"><point name="center" value="0, 2.1, -5"/><float name="radius" value="1"/>'
        '<bsdf type="null"/><ref name="interior" id="fog"/><ref name="exterior" id="air"/></shape>'
    )
    e = math.radians(5)

    def disc(flight, medium):
        scene = air_scene(
            f'<string name="free_flight" value="{flight}"/>',
            camera_origin="0, 2, 0",
            target=f"0, {2 + math.sin(e)}, {-math.cos(e)}",
            fov=1.0,
            res=8,
            spp=64,
            lights=medium + '<emitter type="sun"><float name="elevation" value="5"/>'
            '<rgb name="irradiance" value="1"/></emitter>',
        )
        renders = np.array([volpath.render(scene, seed=seed).reshape(-1, 3).mean(axis=0) for seed in range(8)])
        return renders.mean(axis=0), renders.std(axis=0, ddof=1) / np.sqrt(len(renders))

    def agree(a, b):
        return np.all(np.abs(a[0] - b[0]) < 5 * np.hypot(a[1], b[1]))

    clear, through_fog = disc("guided", ""), disc("guided", fog)
    assert clear[0][0] > 100, clear  # the disc is in view
    assert agree(through_fog, clear), (through_fog, clear)
    tracking = disc("tracking", fog)
    assert agree(tracking, through_fog), (tracking, through_fog)


def test_guided_free_flight_needs_a_deterministic_sun():
    with pytest.raises(
        volpath.SceneError,
        match=r":\d+: .*free_flight='guided'.*sun_transmittance 'table' or "
        r"'quadrature'",
    ):
        air_scene('<string name="free_flight" value="guided"/><string name="sun_transmittance" value="tracking"/>')
    with pytest.raises(volpath.SceneError, match=r"'free_flight' is 'exact', expected one of: guided, tracking"):
        air_scene('<string name="free_flight" value="exact"/>')
