"""Emissive media against closed forms.

Deep inside a large homogeneous medium that emits sigma_a Le per unit length, radiance
reaches equilibrium: L = Le once every scattering order is simulated (the source balances
absorption), and L = Le sigma_a / sigma_t when scattering only removes light (the
absorption tracer). The slab case checks the exact segment integral
Le (1 - exp(-sigma_a d)) + T L_background.
"""

import numpy as np
import pytest

import scenes as S
import volpath
from volpath.grids import write_vol
from volpath.testing import max_z, render_batches

LE = np.array([2.0, 1.0, 0.5])
SIGMA_A = np.array([0.5, 0.3, 0.2])
SIGMA_S = np.array([0.5, 0.7, 0.3])


def _rgb(v):
    return ", ".join(map(str, v))


def _deep_medium(medium_xml):
    # The camera at the centre of a cube of half-size 40: at least 40 mean free paths (sigma_t >= 0.5)
    # to the boundary, where e^-20 of the background could leak in: negligible.
    return S.scene(
        S.camera(res=4, fov=30, origin="0, 0, 0", target="0, 0, -1", spp=16, medium="m"),
        medium_xml,
        S.medium_cube("m", half=40.0),
    )


def _homogeneous():
    return (
        f'<medium type="homogeneous" id="m"><rgb name="sigma_a" value="{_rgb(SIGMA_A)}"/>'
        f'<rgb name="sigma_s" value="{_rgb(SIGMA_S)}"/><rgb name="radiance" value="{_rgb(LE)}"/></medium>'
    )


def _grid(tmp_path):
    # A constant 3^3 grid: the grid code path (majorant grid, trilinear lookups, Le grid) with
    # the homogeneous answer. sigma_t is grey here (the grid has one density).
    write_vol(tmp_path / "d.vol", np.ones((3, 3, 3), np.float32))
    write_vol(tmp_path / "le.vol", np.broadcast_to(LE.astype(np.float32), (3, 3, 3, 3)))
    return (
        f'<medium type="heterogeneous" id="m"><float name="scale" value="1.0"/>'
        f'<volume type="gridvolume" name="density"><string name="filename" value="{tmp_path / "d.vol"}"/>'
        f'<transform name="to_world"><translate value="-0.5, -0.5, -0.5"/><scale value="80"/></transform></volume>'
        f'<rgb name="albedo" value="0.5, 0.7, 0.3"/>'
        f'<volume type="gridvolume" name="radiance"><string name="filename" value="{tmp_path / "le.vol"}"/>'
        f'<transform name="to_world"><translate value="-0.5, -0.5, -0.5"/><scale value="80"/></transform></volume>'
        f"</medium>"
    )


@pytest.mark.parametrize("tracer", ["multiple", "nee_mis", "null_scattering"])
def test_equilibrium_radiance_is_le(tracer):
    scene = volpath.load_string(_deep_medium(_homogeneous()))
    mean, se = render_batches(volpath.render, scene, 4, block=4, tracer=tracer)
    # 4 x 256 paths as 16 independent batches: 5 standard errors (of their spread) plus 1 % of
    # Le for the Russian roulette and depth tails, which are unbiased but heavy.
    assert np.all(np.abs(mean[0, 0] - LE) < 5 * se[0, 0] + 0.01 * LE), (mean, se)
    assert np.all(np.isfinite(mean))


def test_absorption_tracer_counts_only_unscattered_emission():
    scene = volpath.load_string(_deep_medium(_homogeneous()))
    image = volpath.render(scene, spp=4, tracer="absorption")
    # Closed form on every ray: exact up to float rounding.
    assert np.allclose(image, LE * SIGMA_A / (SIGMA_A + SIGMA_S), rtol=1e-5)


def test_grid_emission_matches_the_homogeneous_answer(tmp_path):
    scene = volpath.load_string(_deep_medium(_grid(tmp_path)))
    mean, se = render_batches(volpath.render, scene, 4, block=4, tracer="null_scattering")
    assert np.all(np.abs(mean[0, 0] - LE) < 5 * se[0, 0] + 0.01 * LE), (mean, se)
    # The absorption tracer by ratio tracking: sigma_a / sigma_t of Le (albedo 0.5, 0.7, 0.3).
    mean, se = render_batches(volpath.render, scene, 4, block=4, tracer="absorption")
    expected = LE * (1 - np.array([0.5, 0.7, 0.3]))
    assert np.all(np.abs(mean[0, 0] - expected) < 5 * se[0, 0] + 1e-3), (mean, se)


def test_emitting_slab_closed_form():
    sa = np.array([0.3, 0.6, 1.2])
    xml = S.scene(
        S.camera(res=4, fov=1, spp=4),
        f'<medium type="homogeneous" id="m"><rgb name="sigma_a" value="{_rgb(sa)}"/>'
        f'<rgb name="sigma_s" value="0, 0, 0"/><rgb name="radiance" value="{_rgb(LE)}"/></medium>',
        S.medium_cube("m"),
        S.constant_env("0.1, 0.1, 0.1"),
    )
    scene = volpath.load_string(xml)
    expected = LE * (1 - np.exp(-2 * sa)) + 0.1 * np.exp(-2 * sa)
    for tracer in volpath.TRACERS:
        # Exact on every ray; the 1-degree field makes paths up to 1/cos(0.5 deg) = 1 + 4e-5 longer.
        assert np.allclose(volpath.render(scene, tracer=tracer), expected, rtol=2e-4), tracer


def test_blackbody_temperature_grid(tmp_path):
    from volpath.blackbody import blackbody_rgb

    write_vol(tmp_path / "d.vol", np.ones((2, 2, 2), np.float32))
    write_vol(tmp_path / "t.vol", np.full((2, 2, 2), 1500.0, np.float32))
    xml = S.scene(
        S.camera(res=4, fov=1, spp=4),
        f'<medium type="heterogeneous" id="m"><float name="scale" value="1.0"/>'
        f'<volume type="gridvolume" name="density"><string name="filename" value="{tmp_path / "d.vol"}"/>'
        f'<transform name="to_world"><scale value="2"/><translate value="-1, -1, -1"/></transform></volume>'
        f'<float name="albedo" value="0"/>'
        f'<volume type="gridvolume" name="temperature"><string name="filename" value="{tmp_path / "t.vol"}"/>'
        f'<transform name="to_world"><scale value="2"/><translate value="-1, -1, -1"/></transform></volume>'
        f'<float name="blackbody_scale" value="0.01"/></medium>',
        S.medium_cube("m"),
    )
    scene = volpath.load_string(xml)
    # A blackbody slab of optical thickness 2, nothing behind it: B(T) (1 - e^-2), by ratio tracking.
    expected = 0.01 * blackbody_rgb(1500.0) * (1 - np.exp(-2.0))
    mean, se = render_batches(volpath.render, scene, 4, block=4, tracer="absorption")
    assert expected[0] > 0.1 and expected[0] > 5 * expected[1] and expected[2] == 0  # red-hot
    assert np.all(np.abs(mean[0, 0] - expected) < 5 * se[0, 0] + 1e-6), (mean, se, expected)


def test_radiance_without_absorption_is_an_error():
    xml = S.scene(
        S.camera(),
        '<medium type="homogeneous" id="m"><rgb name="sigma_a" value="0, 0, 0"/>'
        '<rgb name="sigma_s" value="1, 1, 1"/><rgb name="radiance" value="1, 1, 1"/></medium>',
        S.medium_cube("m"),
    )
    with pytest.raises(volpath.SceneError, match="'radiance' needs absorption"):
        volpath.load_string(xml)


@pytest.mark.parametrize("twosided", [False, True])
def test_a_twosided_area_emitter_lights_both_faces(twosided):
    """A unit-radiance quad facing +z over a white floor, seen and lit from below: its back
    emits only when twosided (Blender's emission shaders). Seen directly: exactly its
    radiance or nothing. The floor's light by NEE with MIS and by BSDF sampling alone agree
    (5 s.e.), so the light's sampling and pdf count the back face as the path does."""
    quad = (
        '<shape type="rectangle"><transform name="to_world"><translate z="1"/></transform>'
        '<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>'
        f'<emitter type="area"><rgb name="radiance" value="1"/><boolean name="twosided" value="{str(twosided).lower()}"/>'
        "</emitter></shape>"
    )
    up = volpath.load_string(S.scene(S.camera(res=4, origin="0, 0, -3", target="0, 0, 1", fov=10), quad))
    np.testing.assert_allclose(volpath.render(up, spp=4), 1.0 if twosided else 0.0)
    floor = '<shape type="rectangle"><transform name="to_world"><scale value="4"/></transform></shape>'
    lit = S.scene(S.camera(res=8, origin="0, -3, 0.8", target="0, 0, 0", fov=40), quad, floor)  # under the quad
    scene = volpath.load_string(lit)
    means = {
        tracer: np.array([volpath.render(scene, spp=16, seed=s, tracer=tracer).mean() for s in range(6)])
        for tracer in ("nee_mis", "multiple")
    }
    a, b = means["nee_mis"], means["multiple"]
    se = np.sqrt(a.var(ddof=1) / len(a) + b.var(ddof=1) / len(b))
    assert abs(a.mean() - b.mean()) < 5 * se + 1e-6, (a.mean(), b.mean(), se)
    assert (a.mean() > 0.05) == twosided  # the floor below sees the back face only when it emits


def _spread_light(spread, size=0.005, extra=""):
    """A downward-facing square light at the origin (hidden from the camera), radiance 1000."""
    value = "" if spread is None else f'<float name="spread" value="{spread}"/>'
    return f"""<shape type="rectangle">{extra}
        <transform name="to_world"><scale value="{size}"/><rotate x="1" angle="90"/></transform>
        <emitter type="area"><rgb name="radiance" value="1000"/>{value}</emitter></shape>"""


def test_a_spread_narrows_an_area_light_and_keeps_its_power():
    """Blender's Spread (90 degrees): seen from the light, a floor 1 m below is lit in the
    ratio w(theta) = (tan h - tan theta) / (tan h - h), h = 45 degrees, to the same light
    without one, where theta is the angle of the pixel's ray from the normal: a camera at
    the light looks along it. The rendered ratio follows w within 3 % away from the cut-off
    (a pixel averages w over its footprint), and its integral with cos theta over the
    solid angle, the light's power relative to a full spread, is 1 within 3 % (the pixel
    grid's quadrature). A tiny light: NEE is nearly exact. Then a wider one with a 60-degree
    spread over the floor, lit by NEE with MIS and by BSDF sampling alone: they agree on 4x4
    blocks (z < 5, as in tests/native/test_tracer_agreement.py), so the light's sampling and
    the path's hits weigh the spread alike."""
    res, fov = 64, 100.0
    camera = S.camera(res=res, fov=fov, origin="0, 0.001, 0", target="0, -1, 0", up="0, 0, 1")
    hidden = '<string name="hidden_from" value="camera"/>'

    def floor_lit(spread):
        scene = volpath.load_string(S.scene(camera, S.floor(y=-1, size=20), _spread_light(spread, extra=hidden)))
        return volpath.render(scene, spp=16, tracer="nee_mis")[..., 0]

    ratio = floor_lit(90) / floor_lit(None)
    ndc = (2 * (np.arange(res) + 0.5) / res - 1) * np.tan(np.radians(fov / 2))
    tan_theta = np.hypot(*np.meshgrid(ndc, ndc))
    h = np.pi / 4
    w = np.clip(np.tan(h) - tan_theta, 0, None) / (np.tan(h) - h)
    pixel = 2 * np.tan(np.radians(fov / 2)) / res
    away = np.abs(tan_theta - np.tan(h)) > 2 * pixel
    np.testing.assert_allclose(ratio[away], w[away], rtol=0.03, atol=1e-3)
    cos = 1 / np.sqrt(1 + tan_theta**2)
    power = np.sum(ratio * cos * cos**3 * pixel**2)  # d(omega) = cos^3 dA on the image plane at 1
    assert abs(power / np.pi - 1) < 0.03, power / np.pi

    wide = S.scene(
        S.camera(res=16, origin="0, 2, 2", target="0, -1, 0", fov=60, spp=32), S.floor(y=-1), _spread_light(60, 0.5)
    )
    scene = volpath.load_string(wide)
    a = render_batches(volpath.render, scene, 6, block=4, tracer="nee_mis")
    b = render_batches(volpath.render, scene, 6, block=4, tracer="multiple")
    assert max_z(a[0], a[1], b[0], b[1]) < 5  # hits that miss the falloff: z = 14


@pytest.mark.parametrize("spread", [0, -5, 181])
def test_a_spread_out_of_range_is_an_error(spread):
    with pytest.raises(volpath.SceneError, match=r":\d+: .*'spread' must be in \(0, 180\]"):
        volpath.load_string(S.scene(S.camera(), _spread_light(spread)))


def test_a_shape_that_casts_no_shadow_lets_shadow_rays_through():
    """A black box between a point light and the floor, hidden from shadow rays: the floor
    under it is as bright as with no box (NEE toward a point light is the only strategy,
    so the images are equal to the last bit wherever the camera sees the floor)."""
    floor = '<shape type="rectangle"><transform name="to_world"><scale value="4"/></transform></shape>'
    light = '<emitter type="point"><point name="position" value="0, 0, 3"/><rgb name="intensity" value="5"/></emitter>'
    box = (
        '<shape type="cube"><transform name="to_world"><scale value="0.3"/><translate z="1.5"/></transform>'
        '<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>{}</shape>'
    )
    camera = S.camera(res=8, origin="0, -3, 1", target="0, 0, 0", fov=30)  # below the box: sees the floor
    without = volpath.render(volpath.load_string(S.scene(camera, floor, light)), spp=2, seed=1)
    shadowed = volpath.render(volpath.load_string(S.scene(camera, floor, light, box.format(""))), spp=2, seed=1)
    no_shadow = '<string name="hidden_from" value="shadow"/>'
    through = volpath.render(volpath.load_string(S.scene(camera, floor, light, box.format(no_shadow))), spp=2, seed=1)
    assert shadowed.mean() < 0.9 * without.mean()  # the box does shadow the floor
    np.testing.assert_array_equal(through, without)


@pytest.mark.parametrize("hidden, expected", [("", "box"), ("glossy", "sky"), ("camera, diffuse", "box")])
def test_a_mirror_shows_what_glossy_rays_may_see(hidden, expected):
    """A mirror reflects a red box against a blue sky: hidden from glossy rays, the box is
    gone from the reflection (a mirror's bounce is glossy); hidden from camera and diffuse
    rays only, it is still there."""
    mirror = '<shape type="rectangle"><bsdf type="conductor"/></shape>'
    box = (
        '<shape type="cube"><transform name="to_world"><scale value="2"/><translate z="5"/></transform>'
        '<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>'
        f'<emitter type="area"><rgb name="radiance" value="1, 0, 0"/></emitter><string name="hidden_from" value="{hidden}"/>'
        "</shape>"
    )
    sky = '<emitter type="constant"><rgb name="radiance" value="0, 0, 1"/></emitter>'
    camera = S.camera(res=4, origin="0.5, 0, 1", target="0, 0, 0", fov=5)  # beside the box, looking at the mirror
    img = volpath.render(volpath.load_string(S.scene(camera, mirror, box, sky)), spp=4, seed=1)
    red, blue = img[..., 0].mean(), img[..., 2].mean()
    assert (red > 0.9 and blue < 0.1) if expected == "box" else (blue > 0.9 and red < 0.1), (red, blue)


def _lights(hidden, size=0.4):
    """A point light and an area light facing down (out of the camera's sight), both hidden
    from the `hidden` rays."""
    tag = f'<string name="hidden_from" value="{hidden}"/>' if hidden else ""
    point = f'<emitter type="point"><point name="position" value="1, 3, 0"/><rgb name="intensity" value="8"/>{tag}</emitter>'
    area = f"""<shape type="rectangle"><string name="hidden_from" value="camera"/>
        <transform name="to_world"><scale value="{size}"/><rotate x="1" angle="90"/><translate x="-1" y="2"/></transform>
        <bsdf type="null"/><emitter type="area"><rgb name="radiance" value="10"/>{tag}</emitter></shape>"""
    return point + area


def test_lights_hidden_from_scatter_rays_light_no_medium():
    """Blender's Volume Scatter visibility off on both lights: a scattering cube in the dark
    between them is black to the last bit (NEE from the medium skips them, and scattered
    rays that meet the area light do not count it), while a floor without the medium is lit
    exactly as when they are visible (surfaces' NEE and BSDF rays are not scattered rays).
    Without NEE (`multiple`), scattered rays meeting the area light are all there is."""
    camera = S.camera(res=8, origin="0, 0.5, 5", target="0, 0.5, 0", fov=40)
    medium = S.homogeneous("m", "2, 2, 2", "0.9, 0.9, 0.9", g=0.3) + S.medium_cube("m", 0.8)
    for tracer in ("multiple", "nee_mis", "null_scattering"):
        lit = volpath.render(volpath.load_string(S.scene(camera, medium, _lights(""))), spp=8, tracer=tracer)
        dark = volpath.render(volpath.load_string(S.scene(camera, medium, _lights("scatter"))), spp=8, tracer=tracer)
        assert lit.mean() > 0.01 and not dark.any(), (tracer, lit.mean(), dark.max())
    floor = [camera, S.floor(y=-1)]
    np.testing.assert_array_equal(
        volpath.render(volpath.load_string(S.scene(*floor, _lights("scatter"))), spp=8, seed=2),
        volpath.render(volpath.load_string(S.scene(*floor, _lights(""))), spp=8, seed=2),
    )


def test_lights_that_cast_no_shadow_light_through_an_occluder():
    """Shadow visibility off on both lights: under a black board (hidden from the camera)
    the floor is lit as if the board were not there. With the area light NEE is then the
    only strategy, unweighted, where the open scene combines it with BSDF sampling: the two
    images agree within noise (z < 5 on 4x4 blocks, as tests/native/test_tracer_agreement.py
    argues), and the board's shadow is there when the lights cast one."""
    camera = S.camera(res=16, origin="0, 1, 5", target="0, -1, 0", fov=40)
    board = """<shape type="rectangle"><string name="hidden_from" value="camera"/>
        <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/><translate y="0.5"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf></shape>"""

    def batches(*parts):
        return render_batches(volpath.render, volpath.load_string(S.scene(camera, S.floor(y=-1), *parts)), 6, block=4)

    open_, through = batches(_lights("", 1.5)), batches(_lights("shadow", 1.5), board)
    shadowed = batches(_lights("", 1.5), board)
    assert max_z(open_[0], open_[1], through[0], through[1]) < 5  # hits counted on top of NEE: z = 11
    assert shadowed[0].mean() < 0.95 * open_[0].mean()
