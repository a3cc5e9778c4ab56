"""The sky map and the air's control variates (native/include/volpath/sky_map.h, the
integrator's guided flight): the map's sampler against its pdf, the integrals the control
variates rely on against quadrature, and the sky they render against delta tracking."""

import numpy as np
import pytest

import scenes as S
import volpath
from volpath import _probes
from volpath.testing import chi2_directions, max_z, render_batches

R = 6360e3


def sky(
    elevation=2.0,
    origin="0, 2, 0",
    target="0.5, 2.3, -1",
    res=8,
    fov=40,
    spp=16,
    max_depth=-1,
    flight="guided",
    azimuth=120,
    extra="",
):
    """The Bruneton air alone (ground and top spheres), one sun, and `extra` shapes."""
    cam = S.camera(
        res=res, fov=fov, origin=origin, target=target, spp=spp, extra='<float name="far_clip" value="1e9"/>'
    )
    air = f'<medium type="atmosphere" id="air"><string name="free_flight" value="{flight}"/></medium>'
    sun = (
        f'<emitter type="sun"><float name="elevation" value="{elevation}"/>'
        f'<float name="azimuth" value="{azimuth}"/></emitter>'
    )
    return volpath.load_string(S.scene(cam, air, sun, extra, max_depth=max_depth))


# A hill beside the camera that shadows part of the low air, and a bank of fog in the air
# above it (a homogeneous medium in a box: its boundary and its shadow are local too).
HILL_AND_FOG = """
    <shape type="cube"><transform name="to_world"><scale x="300" y="60" z="300"/><translate x="150" y="0" z="-600"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.25, 0.1"/></bsdf></shape>
    <medium type="homogeneous" id="fog"><float name="sigma_t" value="0.01"/><float name="albedo" value="0.95"/></medium>
    <shape type="cube"><transform name="to_world"><scale x="200" y="40" z="200"/><translate x="0" y="120" z="-900"/></transform>
        <bsdf type="null"/><ref name="interior" id="fog"/><ref name="exterior" id="air"/></shape>"""


# The hill glossy (rough plastic: a diffuse and a specular lobe) and a tower on it that hides
# part of the sky from the hill's top: where the map's light is no model of the bounce's.
GLOSSY_HILL_AND_TOWER = """
    <shape type="cube"><transform name="to_world"><scale x="300" y="60" z="300"/><translate x="150" y="0" z="-600"/></transform>
        <bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.2, 0.25, 0.1"/><float name="alpha" value="0.3"/></bsdf></shape>
    <shape type="cube"><transform name="to_world"><scale x="20" y="80" z="20"/><translate x="60" y="140" z="-520"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.3"/></bsdf></shape>"""


def sky_map(scene, p, d_in=(0, 0, -1), dirs=None, us=None):
    dirs = np.zeros((0, 3)) if dirs is None else np.asarray(dirs, float)
    us = np.zeros((0, 3)) if us is None else np.asarray(us, float)
    return _probes.sky_map(scene.native, 0, tuple(map(float, p)), tuple(map(float, d_in)), dirs, us)


def sphere_grid(n_z, n_phi):
    """Midpoints of an equal-area grid over the sphere (z = cos theta along +y, the
    zenith of a point on the y axis) and the solid angle of each cell."""
    z = (np.arange(n_z) + 0.5) / n_z * 2 - 1
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2 * np.pi - np.pi
    Z, P = np.meshgrid(z, phi, indexing="ij")
    r = np.sqrt(1 - Z**2)
    dirs = np.stack([r * np.cos(P), Z, r * np.sin(P)], axis=-1).reshape(-1, 3)
    return dirs, (2 / n_z) * (2 * np.pi / n_phi)


# Points low and high in the sunrise air, on the y axis (their zenith is +y).
POINTS = [(0, 300, 0), (0, 4000, 0), (0, 25e3, 0)]


@pytest.mark.parametrize("p", POINTS)
def test_map_samples_have_the_density_pdf_gives_them(p):
    """sample() returns a direction and a density: pdf() of that direction must agree, and
    the directions must follow pdf (chi-square, rejection below p = 1e-4; 200 000 samples,
    the bins' axis the point's zenith, where the map's cells crowd at the horizon)."""
    scene = sky()
    u = np.random.default_rng(3).random((200_000, 3))
    out = sky_map(scene, p, us=u)
    dirs, pdf = out["samples"], out["sample_pdf"]
    assert np.all(pdf > 0) and np.all(np.isfinite(dirs))
    again = sky_map(scene, p, dirs=dirs)["pdf"]
    assert np.allclose(again, pdf, rtol=1e-9), np.max(np.abs(again / pdf - 1))
    # chi2_directions bins over cos theta about +z: swap y and z (y is the zenith here).
    swap = [0, 2, 1]
    density = lambda d: sky_map(scene, p, dirs=d[:, swap])["pdf"]
    assert chi2_directions(dirs[:, swap], density, len(dirs), n_theta=40, n_phi=40, sub=24) > 1e-4


@pytest.mark.parametrize("p", POINTS)
def test_map_pdf_integrates_to_one(p):
    dirs, cell = sphere_grid(6000, 720)
    total = sky_map(sky(), p, dirs=dirs)["pdf"].sum() * cell
    # Midpoints across the cells' edges: ~1e-3 quadrature error.
    assert abs(total - 1) < 3e-3, total


@pytest.mark.parametrize("p", POINTS)
@pytest.mark.parametrize("d_in", [(0, 0, -1), (0, -1, 0), (0.6, 0.8, 0)])
def test_rayleigh_integral_is_the_maps_integral(p, d_in):
    """The control variate's integral, 3/(16 pi) (total + d^T M d) from the map's moments,
    equals the integral of p_R(d_in . w) times the map's radiance over the sphere."""
    scene = sky()
    dirs, cell = sphere_grid(6000, 720)
    out = sky_map(scene, p, d_in=d_in, dirs=dirs)
    mu = dirs @ (np.asarray(d_in, float) / np.linalg.norm(d_in))
    p_rayleigh = 3 / (16 * np.pi) * (1 + mu**2)
    numeric = (out["radiance"] * p_rayleigh[:, None]).sum(axis=0) * cell
    assert np.allclose(out["rayleigh_integral"], numeric, rtol=3e-3), (out["rayleigh_integral"], numeric)


@pytest.mark.parametrize("with_map", [False, True])
@pytest.mark.parametrize("elevation", [-2.0, 2.0, 30.0])
def test_segment_light_integral_is_the_models_integral(with_map, elevation):
    """The segment's control variate adds light_integral(): the exact integral of
    light_model(t), exponential (or linear) between nodes, here by trapezoids; on rays up,
    down, and one that stays level (500 m falling 10 m: modelled by its two ends)."""
    scene = sky(elevation=elevation)
    rays = (
        ((0, 2, 0), (0.3, 0.05, -1), 2e6),
        ((0, 1500, 0), (0, -0.2, -1), 2e6),
        ((0, 8000, 0), (0.2, 1, 0.1), 2e6),
        ((0, 30, 0), (1, -0.02, 0), 500.0),
    )
    for o, d, t_max in rays:
        t = np.linspace(0, t_max, 400_001)
        values, integral = _probes.air_light_model(scene.native, 0, o, d, t_max, t, with_map)
        numeric = np.trapz(values, t, axis=0)
        assert np.all(values >= 0) and np.all(np.isfinite(values))
        assert np.allclose(integral, numeric, rtol=1e-4, atol=1e-12 * np.max(integral)), (o, d, integral, numeric)


def test_sky_map_can_be_turned_off():
    """sky_map="false" (for the accuracy study) builds no map: the air is guided as before."""
    cam = S.camera(
        res=4, fov=40, origin="0, 2, 0", target="0, 2.3, -1", spp=4, extra='<float name="far_clip" value="1e9"/>'
    )
    scene = volpath.load_string(
        S.scene(
            cam,
            '<medium type="atmosphere" id="air"><boolean name="sky_map" value="false"/></medium>',
            '<emitter type="sun"><float name="elevation" value="5"/></emitter>',
        )
    )
    with pytest.raises(ValueError, match="no sky map"):
        sky_map(scene, (0, 2, 0))
    assert np.all(np.isfinite(volpath.render(scene)))


def test_map_models_light_only_where_it_is_faithful():
    """The control variates run only where the map stands for the light well: from inside
    the air with the sun above the horizon; not in twilight nor from space."""
    assert sky_map(sky(), (0, 2, 0))["models_light"]
    assert not sky_map(sky(elevation=-2), (0, 2, 0))["models_light"]
    assert not sky_map(sky(origin="0, 400e3, 0", target="0, 399.9e3, -1"), (0, 2, 0))["models_light"]


@pytest.mark.parametrize("elevation,max_depth", [(2, -1), (2, 3), (2, 4), (25, -1)])
def test_control_variates_leave_the_sky_unbiased(elevation, max_depth):
    """The guided flight with the sky map and its control variates against delta tracking
    (the air as a generic heterogeneous medium, none of those): z-tests on 2x2-pixel
    blocks (48 values, 5 s.e.) and on the image mean per channel (4 s.e.), 8 independent
    renders each (tracking at 4x the samples: its noise sets the tests' power, enough to
    see Russian roulette add 0.8 of its prediction instead of all of it); max_depth 3 and
    4 check where the models stop. And the control variates must pay: the guided s.e.
    well below tracking's at equal samples."""
    assert sky_map(sky(elevation=elevation), (0, 2, 0))["models_light"]
    sa, sb = guided_agrees_with_tracking(elevation=elevation, max_depth=max_depth)
    assert np.mean(sb) < 0.25 * np.mean(sa), (np.mean(sb), np.mean(sa))  # 0.5x at equal spp


def guided_agrees_with_tracking(**scene):
    """Delta tracking at 2048 spp and the guided flight at 512, 8 independent renders each:
    z-tests on 2x2-pixel blocks (5 s.e.) and on the image mean per channel (4 s.e.).
    Returns the two standard errors per block."""
    res = {}
    for flight, spp in (("tracking", 2048), ("guided", 512)):
        res[flight] = render_batches(volpath.render, sky(flight=flight, spp=spp, **scene), 8, block=2)
    (a, sa), (b, sb) = res["tracking"], res["guided"]
    assert max_z(a, sa, b, sb) < 5
    mean_a, mean_b = a.mean(axis=(0, 1)), b.mean(axis=(0, 1))
    se_a = np.sqrt((sa**2).sum(axis=(0, 1))) / sa[..., 0].size
    se_b = np.sqrt((sb**2).sum(axis=(0, 1))) / sb[..., 0].size
    assert np.all(np.abs(mean_a - mean_b) < 4 * np.sqrt(se_a**2 + se_b**2)), (mean_a, mean_b, se_a, se_b)
    return sa, sb


def test_local_sun_shadow_is_where_rays_toward_the_sun_meet_the_local_bounds():
    """Scene::local_sun_shadow against brute force: along random rays, the distances whose
    rays toward the sun enter the bounds of the hill and the fog (a slab test at 4001
    points) are those of the interval, to the spacing of the points."""
    rng = np.random.default_rng(11)
    for elevation, azimuth in ((2, 120), (-3, 40), (35, 200), (0, 90)):
        scene = sky(elevation=elevation, azimuth=azimuth, extra=HILL_AND_FOG)
        s = np.asarray(scene.summary["emitters"][0]["to_sun"])
        for _ in range(25):
            o = rng.uniform([-1500, -50, -2000], [1500, 400, 500])
            d = rng.normal(size=3)
            d /= np.linalg.norm(d)
            t = np.linspace(0, 3000, 4001)
            a, b, lo, hi = _probes.local_sun_shadow(scene.native, tuple(o), tuple(d), 0.0, 3000.0)
            assert lo == pytest.approx((-200, -60, -1100)) and hi == pytest.approx((450, 160, -300))  # hill and fog
            p = o + t[:, None] * d
            with np.errstate(divide="ignore", invalid="ignore"):
                t_lo, t_hi = (np.array(lo) - p) / s, (np.array(hi) - p) / s
            near = np.max(np.minimum(t_lo, t_hi), axis=1)
            far = np.min(np.maximum(t_lo, t_hi), axis=1)
            meets = (near <= far) & (far >= 0)
            inside = (t >= a - 1) & (t <= b + 1)
            assert np.all(inside[meets]), (elevation, o, d, a, b)
            assert not np.any(meets[(t < a - 1) | (t > b + 1)])


@pytest.mark.parametrize("elevation", [2, 25])
def test_control_variates_past_local_shapes_leave_the_sky_unbiased(elevation):
    """With a hill and a fog bank in the air, the models serve only where the sun's rays
    miss them (the guided flight cuts its segments there): the sky against delta tracking,
    as above, the camera looking over the hill, through the fog's shadow, at the sky."""
    guided_agrees_with_tracking(elevation=elevation, target="0.3, 2.1, -1", extra=HILL_AND_FOG)


def test_roulette_by_the_map_leaves_lit_terrain_unbiased():
    """The camera above the hill looks down at its sunlit top and its shadowed side: the
    forced collisions in the few hundred metres of air before the hill (roulette by the
    map's predicted share) and the hill's bounces that escape to the sky (roulette with the
    map's prediction as a control variate) against delta tracking, as above. Checked by
    mutation: the surface's roulette adding 0.8 of its prediction fails (z = 11.7). The
    share roulette cuts only walks predicted to bring under a tenth of the sample, so a
    bias of its own hides in this noise (survivors weighted 1/sqrt(q) pass): it rests on
    being plain Russian roulette."""
    guided_agrees_with_tracking(elevation=10, origin="-100, 150, 0", target="150, 40, -600", extra=HILL_AND_FOG)


def test_roulette_by_the_map_leaves_a_fog_bank_unbiased():
    """The camera looks into the fog bank: its scattered paths that leave it for the open sky
    take the roulette with the map's prediction as a control variate there, as a surface's
    bounces do, against delta tracking as above. Checked by mutation: that roulette adding
    0.8 of its prediction fails (z = 8.7 on the image's mean)."""
    guided_agrees_with_tracking(elevation=10, origin="0, 130, -500", target="0, 125, -900", extra=HILL_AND_FOG)


def test_the_maps_light_as_a_surfaces_control_variate_leaves_terrain_unbiased():
    """A bounce off a surface into the air takes the map's light integrated against the
    BSDF (from stratified BSDF directions) less its value in the bounce's direction: on a
    glossy hill half in a tower's shadow, whose top the tower hides part of the sky from,
    against delta tracking as above. Checked by mutation: the integral taken at 0.9 fails
    the diffuse hill's test above (z = 11.8); added only where the path's own direction
    is drawn (a glossy lobe's may fall below the horizon) fails this one (z = 15.7)."""
    guided_agrees_with_tracking(elevation=10, origin="-100, 150, 0", target="60, 60, -520", extra=GLOSSY_HILL_AND_TOWER)


def test_negative_samples_are_rare_and_clamped():
    """A control variate can take a single sample below zero where its model overestimates;
    the render counts such samples as 0 (a bias) and reports them. In a sunrise sky at 4 spp
    they are a few in 10^5 samples and add less than 1e-4 of the light; no pixel is negative."""
    scene = sky(res=64, spp=4)
    image = volpath.render(scene, seed=5)
    stats = scene.last_render
    assert image.min() >= 0
    assert stats["negative_samples"] <= 1e-3 * 64 * 64 * 4, stats
    assert stats["clamped_share"] < 1e-4, stats


def test_an_animated_sun_and_camera_give_the_bits_of_a_fresh_load():
    """Scene.update (a worker's next frame) moves the sun and the camera and keeps the rest:
    the sky map's levels while the sun stays within their elevations, a new map beyond. Each
    frame renders the same bits as the frame loaded afresh; a change to anything else is
    refused and leaves the scene as it was."""
    from volpath.plugins import kind_of
    from volpath.xml_reader import read_xml

    cam = S.camera(
        res=8, fov=40, origin="0, 2, 0", target="0.3, 2.1, -1", spp=2, extra='<float name="far_clip" value="1e9"/>'
    )
    air = '<medium type="atmosphere" id="air"/>'
    d = read_xml(
        S.scene(cam, air, '<emitter type="sun"><float name="elevation" value="2"/></emitter>', HILL_AND_FOG), "<test>"
    )
    scene = volpath.load_dict(d)
    levels = sky_map(scene, (0, 2, 0))["levels"]
    turned = np.array(d["sensor"]["to_world"])
    turned[:3, 3] += (40, 5, 0)
    for elevation, to_world, same_levels in (
        (2.4, d["sensor"]["to_world"], True),
        (2.6, turned, True),
        (12, turned, False),
    ):
        frame = dict(d, emitter=dict(d["emitter"], elevation=elevation), sensor=dict(d["sensor"], to_world=to_world))
        assert scene.update(frame)
        assert scene.summary["emitters"][0]["to_sun"][1] == pytest.approx(np.sin(np.radians(elevation)))
        assert (sky_map(scene, (0, 2, 0))["levels"] == levels) == same_levels
        fresh = volpath.load_dict(frame)
        assert np.array_equal(volpath.render(scene, seed=3), volpath.render(fresh, seed=3)), elevation
    before = volpath.render(scene, seed=4)
    lifted = np.eye(4)
    lifted[1, 3] = 0.5
    moved_hill = {
        k: dict(v, to_world=lifted @ v.get("to_world", np.eye(4)))
        if isinstance(v, dict) and kind_of(v) == "shape"
        else v
        for k, v in frame.items()
    }
    assert not scene.update(moved_hill)
    assert np.array_equal(volpath.render(scene, seed=4), before)
