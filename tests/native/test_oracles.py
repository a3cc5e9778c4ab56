"""Closed-form oracles: analytic transmittance and white furnaces."""

import math

import numpy as np
import pytest

import scenes as S
import volpath
from volpath import _probes
from volpath.testing import render_batches

SCATTERING_TRACERS = ["multiple", "nee_mis", "null_scattering"]


def expected_absorption(res, fov, sigma_t, cam_z=5.0, radius=1.0, sub=24):
    """exp(-sigma_t * chord) averaged over each pixel (sub x sub midpoint rule), with
    the per-pixel spread of the integrand (what one uniformly jittered sample varies by)."""
    t = math.tan(math.radians(fov) / 2)
    u = (np.arange(res * sub) + 0.5) / (res * sub)
    # Mitsuba's camera: +x of the camera is the image's left; lookat from +z towards 0.
    x = (1 - 2 * u) * t
    X, Y = np.meshgrid(x, x[::-1][::-1], indexing="xy")
    d = np.stack([-X, Y, -np.ones_like(X)], axis=-1)  # world directions (camera looks down -z)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    o = np.array([0, 0, cam_z])
    b = d @ o
    disc = b**2 - (o @ o - radius**2)
    chord = 2 * np.sqrt(np.maximum(disc, 0))
    T = np.exp(-sigma_t * chord)
    T = T.reshape(res, sub, res, sub)
    return T.mean(axis=(1, 3)), T.std(axis=(1, 3))


@pytest.mark.parametrize("tracer", volpath.TRACERS)
def test_absorbing_sphere_matches_closed_form(tracer):
    res, fov, sigma_t, spp = 24, 30, 1.5, 64
    xml = S.scene(
        S.camera(res=res, fov=fov, spp=spp),
        S.homogeneous("m", f"{sigma_t}", "0"),
        S.medium_sphere("m"),
        S.back_light(z=-3, size=10),
    )
    scene = volpath.load_string(xml)
    image = volpath.render(scene, tracer=tracer, seed=3)
    mean, spread = expected_absorption(res, fov, sigma_t)
    # The only randomness is where in the pixel each sample lands: the standard error is
    # the within-pixel spread over sqrt(spp). 6 standard errors (plus float32 rounding)
    # over 576 pixels leaves a false-alarm rate below 1e-6.
    tol = 6 * spread / math.sqrt(spp) + 1e-5
    assert np.all(np.abs(image[..., 0] - mean) <= tol)
    assert np.allclose(image[..., 0], image[..., 1]) and np.allclose(image[..., 0], image[..., 2])
    # The centre pixel sees the full diameter: close to exp(-2 sigma_t).
    assert abs(mean[res // 2, res // 2] - math.exp(-2 * sigma_t)) < 0.02


@pytest.mark.parametrize("tracer", SCATTERING_TRACERS)
def test_white_furnace_homogeneous(tracer):
    """An albedo-1 medium under a uniform unit environment returns exactly 1 everywhere."""
    xml = S.scene(
        S.camera(res=8, fov=40, spp=32),
        S.homogeneous("m", "2, 0.5, 4", "1", g=0.6),
        S.medium_sphere("m"),
        S.constant_env("1, 1, 1"),
    )
    scene = volpath.load_string(xml)
    mean, se = render_batches(volpath.render, scene, 4, tracer=tracer)
    assert np.all(np.isfinite(mean))
    # Pixel means over 4 x 32 spp (as 16 batches); 5 standard errors of the whole-image mean.
    image_mean = mean.mean(axis=(0, 1))
    image_se = np.sqrt((se**2).mean(axis=(0, 1)) / (mean.shape[0] * mean.shape[1]))
    assert np.all(np.abs(image_mean - 1) <= 5 * image_se + 1e-6), (image_mean, image_se)


def test_white_furnace_heterogeneous_grid(tmp_path):
    """The same furnace with a random chromatic density grid, through null scattering."""
    rng = np.random.default_rng(7)
    density = rng.uniform(0, 1, size=(6, 5, 4, 3)).astype(np.float32)
    volpath_grid = tmp_path / "d.vol"
    from volpath.grids import write_vol

    write_vol(volpath_grid, density)
    xml = S.scene(
        S.camera(res=8, fov=40, spp=32),
        """
        <medium type="heterogeneous" id="m">
            <volume type="gridvolume" name="sigma_t"><string name="filename" value="d.vol"/>
                <transform name="to_world"><translate value="-0.5"/><scale value="2"/></transform></volume>
            <float name="albedo" value="1"/><float name="scale" value="3"/>
        </medium>""",
        S.medium_cube("m"),
        S.constant_env(),
    )
    scene = volpath.load_string(xml, base_dir=str(tmp_path))
    mean, se = render_batches(volpath.render, scene, 4, tracer="null_scattering")
    image_mean = mean.mean(axis=(0, 1))
    image_se = np.sqrt((se**2).mean(axis=(0, 1)) / (mean.shape[0] * mean.shape[1]))
    assert np.all(np.abs(image_mean - 1) <= 5 * image_se + 1e-6), (image_mean, image_se)


def test_energy_is_not_gained_with_absorption():
    """With albedo < 1 the furnace must return less than the environment."""
    xml = S.scene(
        S.camera(res=8, fov=40, spp=64), S.homogeneous("m", "3", "0.8"), S.medium_sphere("m"), S.constant_env()
    )
    scene = volpath.load_string(xml)
    for tracer in SCATTERING_TRACERS:
        image = volpath.render(scene, tracer=tracer)
        assert np.all(np.isfinite(image)) and image.min() >= 0
        assert image[2:6, 2:6].mean() < 0.95


@pytest.mark.parametrize("tracer", volpath.TRACERS)
def test_camera_inside_an_absorbing_medium(tracer):
    """The camera sits inside a large absorbing sphere and looks at an emitter 4 units
    away that is also inside: every pixel is exp(-sigma_t * distance), exactly. As in
    Mitsuba, rays start at the near clipping plane (0.01), so the medium before it is
    not traversed."""
    sigma_t = 0.3
    xml = S.scene(
        S.camera(res=8, fov=10, spp=4, medium="m"),
        S.homogeneous("m", f"{sigma_t}", "0"),
        S.medium_sphere("m", radius=50),
        S.back_light(z=1, size=20),
    )
    image = volpath.render(volpath.load_string(xml), tracer=tracer)
    # Rays at up to 7 degrees off-axis travel 4/cos(theta) to the plane z = 1.
    t = math.tan(math.radians(5)) * math.sqrt(2)
    lo, hi = math.exp(-sigma_t * 3.99 * math.sqrt(1 + t * t)), math.exp(-sigma_t * 3.99)
    assert np.all((image >= lo - 1e-6) & (image <= hi + 1e-6))


def test_nested_media_boundaries():
    """An absorbing sphere nested in another: transmittance multiplies along the ray."""
    xml = S.scene(
        S.camera(res=8, fov=2, spp=4),
        S.homogeneous("outer", "0.5", "0"),
        S.homogeneous("inner", "2", "0"),
        S.medium_sphere("outer", radius=2),
        '<shape type="sphere"><float name="radius" value="1"/><bsdf type="null"/>'
        '<ref name="interior" id="inner"/><ref name="exterior" id="outer"/></shape>',
        S.back_light(z=-3, size=10),
    )
    image = volpath.render(volpath.load_string(xml), tracer="absorption")
    expected = math.exp(-0.5 * 2 - 2 * 2)  # 2 units of outer, 2 of inner along the axis
    assert abs(image[4, 4, 0] - expected) / expected < 1e-3


@pytest.mark.parametrize("tracer", SCATTERING_TRACERS)
def test_white_furnace_with_the_camera_inside(tracer):
    """A camera inside a chromatic albedo-1 medium splits its first segment into a
    no-collision and a forced-collision branch; together they still return exactly 1."""
    xml = S.scene(
        S.camera(res=8, fov=60, spp=32, origin="0, 0, 0.5", medium="m"),
        S.homogeneous("m", "1, 2, 4", "1", g=0.5),
        S.medium_sphere("m", radius=2),
        S.constant_env(),
    )
    scene = volpath.load_string(xml)
    mean, se = render_batches(volpath.render, scene, 4, tracer=tracer)
    image_mean = mean.mean(axis=(0, 1))
    image_se = np.sqrt((se**2).mean(axis=(0, 1)) / (mean.shape[0] * mean.shape[1]))
    assert np.all(np.abs(image_mean - 1) <= 5 * image_se + 1e-6), (image_mean, image_se)


@pytest.mark.parametrize("alpha", ["0.05", "0.3"])
def test_rough_glass_in_a_furnace_loses_only_what_facets_shadow(alpha):
    """A rough glass sphere under a uniform unit environment: a lossless interface would
    return exactly 1 (radiance compressed on entering is expanded on leaving). A microfacet
    model loses the light that scatters between facets, so at most 1 (5 s.e.), and little
    of it: above 0.9 at these roughnesses."""
    xml = S.scene(
        S.camera(res=8, fov=40, spp=32),
        '<shape type="sphere"><bsdf type="roughdielectric"><string name="distribution" value="ggx"/>'
        f'<float name="alpha" value="{alpha}"/></bsdf></shape>',
        S.constant_env("1, 1, 1"),
    )
    scene = volpath.load_string(xml)
    mean, se = render_batches(volpath.render, scene, 4, tracer="nee_mis")
    assert np.all(np.isfinite(mean))
    image_mean = mean.mean(axis=(0, 1))
    image_se = np.sqrt((se**2).mean(axis=(0, 1)) / (mean.shape[0] * mean.shape[1]))
    assert np.all(image_mean <= 1 + 5 * image_se) and np.all(image_mean > 0.9), (image_mean, image_se)


@pytest.mark.parametrize("eta", [1.1, 1.49, 3.0])
def test_plastic_with_a_white_base_returns_what_it_receives(eta):
    """A smooth coating over a white Lambertian base: the coating reflects F(wi) and lets
    1 - F(wi) in; inter-reflected under the coating, all of it comes back out. The mean
    sample weight is 1 at any angle and index (4 s.e.); the diffuse Fresnel fits this
    once used gained 19 % at eta 3."""
    scene = volpath.load_string(S.scene(S.camera(res=4)))
    bsdf = scene.native.add_bsdf_roughplastic((1.0, 1.0, 1.0), (1.0, 1.0, 1.0), 1e-3, eta)
    u = np.random.default_rng(5).random((400_000, 3))
    for wi in ((0.0, 0.0, 1.0), (0.8, 0.0, 0.6), (0.99, 0.0, 0.141)):
        w = _probes.bsdf_sample_weight(scene.native, bsdf, wi, u)[:, 0]
        assert abs(w.mean() - 1) < 4 * w.std() / np.sqrt(len(w)), (eta, wi, w.mean())


def test_a_metallic_principled_reflects_its_base_colour_head_on_and_white_at_grazing():
    """metallic 1 is a conductor whose Fresnel reflectance is the base colour at normal
    incidence (k^2 / (4 + k^2) with eta 1) and rises toward 1 at grazing angles; near-zero
    roughness makes the sample weight that reflectance."""
    base = (0.9, 0.6, 0.2)
    scene = volpath.load_dict(
        {
            "type": "scene",
            "camera": {"type": "perspective"},
            "s": {"type": "sphere", "b": {"type": "principled", "base_color": base, "metallic": 1.0, "roughness": 0.0}},
        }
    )
    u = np.random.default_rng(3).random((1000, 3))
    head_on = _probes.bsdf_sample_weight(scene.native, 0, (0.0, 0.0, 1.0), u)
    np.testing.assert_allclose(head_on.mean(axis=0), base, rtol=2e-3)
    grazing = _probes.bsdf_sample_weight(scene.native, 0, (0.9995, 0.0, 0.0316), u).mean(axis=0)
    assert np.all(grazing > 0.9), grazing


def test_thin_glass_reflects_twice_fresnels_share_and_loses_nothing():
    """A thin sheet reflects 2R / (1 + R) (both faces and the light bouncing between them,
    R the Fresnel reflectance of one face), from either side, and passes the rest straight
    through: in a white furnace, a pane returns exactly 1."""
    scene = volpath.load_string(
        S.scene(S.camera(res=4), '<shape type="rectangle"><bsdf type="thindielectric"/></shape>')
    )
    eta = 1.5046 / 1.000277
    u = np.random.default_rng(2).random((100_000, 3))
    for wi in ((0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (0.6, 0.0, -0.8)):
        dirs, pdfs = _probes.bsdf_sample(scene.native, 0, wi, u)
        cos_i = abs(wi[2])
        cos_t = np.sqrt(1 - (1 - cos_i**2) / eta**2)
        R = (
            (cos_i - eta * cos_t) ** 2 / (cos_i + eta * cos_t) ** 2
            + (eta * cos_i - cos_t) ** 2 / (eta * cos_i + cos_t) ** 2
        ) / 2
        reflected = dirs[:, 2] * wi[2] > 0
        p = 2 * R / (1 + R)
        assert abs(reflected.mean() - p) < 4 * np.sqrt(p * (1 - p) / len(u)), (wi, reflected.mean(), p)
        assert np.allclose(dirs[~reflected], -np.asarray(wi))  # straight through
    furnace = volpath.load_string(
        S.scene(
            S.camera(res=8, fov=40, spp=8),
            '<shape type="rectangle"><bsdf type="thindielectric"/><transform name="to_world"><rotate x="1" angle="30"/>'
            "</transform></shape>",
            S.constant_env("1, 1, 1"),
        )
    )
    assert np.allclose(volpath.render(furnace, tracer="nee_mis"), 1, atol=1e-5)


def test_conductors_reflect_their_fresnel_reflectance():
    """A smooth conductor's one sample weighs its Fresnel reflectance: at normal incidence
    ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2) per channel; with k = 0, a dielectric's at any
    angle; a perfect mirror (material "none") returns exactly 1 in a white furnace."""
    eta, k = np.array([0.2, 0.9, 1.5]), np.array([3.9, 2.4, 0.0])
    metal = (
        '<shape type="sphere"><bsdf type="conductor">'
        f'<rgb name="eta" value="{", ".join(map(str, eta))}"/><rgb name="k" value="{", ".join(map(str, k))}"/>'
        "</bsdf></shape>"
    )
    scene = volpath.load_string(S.scene(S.camera(res=4), metal))
    u = np.full((1, 3), 0.5)
    ext = 1.000277  # the surroundings' index, Mitsuba's default ext_eta
    n, kk = eta / ext, k / ext
    weight = _probes.bsdf_sample_weight(scene.native, 0, (0.0, 0.0, 1.0), u)[0]
    assert np.allclose(weight, ((n - 1) ** 2 + kk**2) / ((n + 1) ** 2 + kk**2), rtol=1e-9)
    cos_i = 0.6
    weight = _probes.bsdf_sample_weight(scene.native, 0, (0.8, 0.0, cos_i), u)[0]
    cos_t = np.sqrt(1 - (1 - cos_i**2) / n[2] ** 2)
    rs = (cos_i - n[2] * cos_t) / (cos_i + n[2] * cos_t)
    rp = (n[2] * cos_i - cos_t) / (n[2] * cos_i + cos_t)
    assert weight[2] == pytest.approx((rs**2 + rp**2) / 2, rel=1e-9)
    mirror = volpath.load_string(
        S.scene(
            S.camera(res=8, spp=4), '<shape type="sphere"><bsdf type="conductor"/></shape>', S.constant_env("1, 1, 1")
        )
    )
    assert np.allclose(volpath.render(mirror, tracer="nee_mis"), 1, atol=1e-5)
