"""Chi-square goodness of fit: every direction sampler against its own pdf.

Each test draws 200 000 samples into 800 equal-area bins and pools bins expecting fewer
than 5. The null hypothesis (sampler and pdf agree) is rejected below p = 1e-4, so a
correct sampler fails one run in ten thousand, while a pdf off by a few percent in
any region fails every time.
"""

import numpy as np
import pytest

import scenes as S
import volpath
from volpath import _probes
from volpath.testing import chi2_directions, chi2_pooled

N = 200_000
P_MIN = 1e-4


def uniforms(n, dims, seed=1):
    return np.random.default_rng(seed).random((n, dims))


@pytest.mark.parametrize("g", [-0.999, -0.9, -0.3, 0.0, 0.5, 0.95, 0.999])
def test_phase_hg(g):
    dirs, pdfs = _probes.phase_sample(g, uniforms(N, 2))
    # The sampled pdf equals the phase function (exact sampling).
    mu = dirs[:, 2]
    assert np.allclose(pdfs, [_probes.phase_eval(g, m) for m in mu[:1000]] + list(pdfs[1000:]))
    # Symmetric about the incident direction: the marginal of mu is 2 pi p(mu).
    assert chi2_directions(dirs, None, N, z_marginal=lambda z: 2 * np.pi * _probes.phase_eval(g, z)) > P_MIN


def _light_scene(emitter_xml, extra=""):
    return volpath.load_string(S.scene(S.camera(res=4), emitter_xml, extra))


LIGHTS = {
    "sphere_outside": (
        '<shape type="sphere"><point name="center" value="0.5, 1, 3"/><float name="radius" value="1.2"/>'
        '<emitter type="area"><rgb name="radiance" value="1,1,1"/></emitter></shape>',
        (0, 0, 0),
    ),
    "sphere_inside": (
        '<shape type="sphere"><float name="radius" value="2"/><boolean name="flip_normals" value="true"/>'
        '<emitter type="area"><rgb name="radiance" value="1,1,1"/></emitter></shape>',
        (0.3, -0.5, 0.2),
    ),
    "rectangle": (
        '<shape type="rectangle"><transform name="to_world"><scale x="2" y="1"/><rotate x="1" angle="30"/>'
        '<translate z="1.5"/></transform><emitter type="area"><rgb name="radiance" value="1,1,1"/></emitter></shape>',
        (0.2, 0.1, 3.0),
    ),
    "sun": (
        '<emitter type="sun"><float name="elevation" value="40"/><float name="angular_radius" value="0.05"/></emitter>',
        (0, 0, 0),
    ),
    "constant": ('<emitter type="constant"><rgb name="radiance" value="1,1,1"/></emitter>', (0, 0, 0)),
}


@pytest.mark.parametrize("name", sorted(LIGHTS))
def test_light_sampling(name):
    xml, ref = LIGHTS[name]
    scene = _light_scene(xml)
    dirs, pdfs = _probes.light_sample(scene.native, 0, ref, uniforms(N, 2))
    ok = pdfs > 0
    assert ok.mean() > 0.99
    pdf = lambda d: _probes.light_pdf(scene.native, 0, ref, d)
    # The pdf the sampler reports equals the pdf of the same direction found by tracing.
    assert np.allclose(pdfs[ok][:200], pdf(dirs[ok][:200]), rtol=1e-6)
    # 64 x 64 quadrature points per bin resolve the light's silhouette.
    axis = np.mean(dirs[ok], axis=0)
    assert chi2_directions(dirs[ok], pdf, N, sub=64, axis=axis) > P_MIN


def test_envmap_sampling(tmp_path):
    rng = np.random.default_rng(3)
    img = rng.uniform(0, 1, (16, 32, 3)).astype(np.float32) ** 4
    img[4:6, 10:14] = 50  # a bright "sun"
    volpath.write_exr(tmp_path / "env.exr", img)
    scene = volpath.load_string(
        S.scene(
            S.camera(res=4),
            '<emitter type="envmap"><string name="filename" value="env.exr"/>'
            '<transform name="to_world"><rotate y="1" angle="40"/></transform></emitter>',
        ),
        base_dir=str(tmp_path),
    )
    dirs, pdfs = _probes.light_sample(scene.native, 0, (0, 0, 0), uniforms(N, 2))
    ok = pdfs > 0
    pdf = lambda d: _probes.light_pdf(scene.native, 0, (0, 0, 0), d)
    assert np.allclose(pdfs[ok][:200], pdf(dirs[ok][:200]), rtol=1e-6)
    assert chi2_directions(dirs[ok], pdf, N, sub=64) > P_MIN


@pytest.mark.parametrize("wi", [(0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (0.95, 0.1, 0.3)])
@pytest.mark.parametrize(
    "bsdf",
    [
        '<bsdf type="diffuse"/>',
        '<bsdf type="roughplastic"><float name="alpha" value="0.3"/></bsdf>',
        '<bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha" value="0.3"/>'
        '<rgb name="eta" value="0.2, 0.9, 1.1"/><rgb name="k" value="3.9, 2.4, 2.1"/></bsdf>',
    ],
)
def test_bsdf_sampling(bsdf, wi):
    scene = volpath.load_string(S.scene(S.camera(res=4), f'<shape type="sphere">{bsdf}</shape>'))
    dirs, pdfs = _probes.bsdf_sample(scene.native, 0, wi, uniforms(N, 3))
    ok = pdfs > 0
    pdf = lambda d: _probes.bsdf_pdf(scene.native, 0, wi, d)
    assert np.allclose(pdfs[ok][:200], pdf(dirs[ok][:200]), rtol=1e-6)
    assert chi2_directions(dirs[ok], pdf, N) > P_MIN


ROUGH_GLASS = (
    '<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" value="{}"/></bsdf>'
)


@pytest.mark.parametrize("alpha", [0.3, 0.5])
@pytest.mark.parametrize("wi", [(0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (0.3, 0.2, -0.93), (0.9, 0.0, -0.436)])
def test_rough_dielectric_sampling(alpha, wi):
    """Reflection and refraction together, from outside and from inside (the last beyond
    the critical angle at a flat facet, where most facets reflect totally). The bins put
    the transmitted lobe on their equator, finely integrated: it is narrower than the
    roughness (by 1 - 1/eta from outside)."""
    wi = tuple(np.asarray(wi) / np.linalg.norm(wi))
    scene = volpath.load_string(S.scene(S.camera(res=4), f'<shape type="sphere">{ROUGH_GLASS.format(alpha)}</shape>'))
    dirs, pdfs = _probes.bsdf_sample(scene.native, 0, wi, uniforms(N, 3))
    ok = pdfs > 0
    pdf = lambda d: _probes.bsdf_pdf(scene.native, 0, wi, d)
    assert np.allclose(pdfs[ok][:200], pdf(dirs[ok][:200]), rtol=1e-6)
    axis = np.median(dirs[ok][dirs[ok][:, 2] * wi[2] < 0], axis=0) if (dirs[ok][:, 2] * wi[2] < 0).any() else None
    assert chi2_directions(dirs[ok], pdf, N, sub=32, axis=axis) > P_MIN


@pytest.mark.parametrize("wi", [(0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (0.3, 0.0, -0.954)])
def test_rough_dielectric_conserves_energy_and_tends_to_fresnel(wi):
    """Sample weights with refraction's radiance compression undone (times etap^2) carry
    what the interface reflects and transmits: at most 1 (4 s.e.), a little less as
    masking grows with roughness. Nearly smooth, a sample reflects with the Fresnel
    reflectance of a flat interface (4 s.e.)."""
    wi = np.asarray(wi) / np.linalg.norm(wi)
    eta = 1.5046 / 1.000277
    for alpha in (0.001, 0.1, 0.4):
        scene = volpath.load_string(
            S.scene(S.camera(res=4), f'<shape type="sphere">{ROUGH_GLASS.format(alpha)}</shape>')
        )
        u = uniforms(N, 3, seed=5)
        dirs, pdfs = _probes.bsdf_sample(scene.native, 0, tuple(wi), u)
        ok = pdfs > 0
        f = _probes.bsdf_eval(scene.native, 0, tuple(wi), dirs[ok])[:, 0]
        reflected = dirs[ok][:, 2] * wi[2] > 0
        etap = np.where(reflected, 1.0, eta if wi[2] > 0 else 1 / eta)
        energy = np.zeros(N)
        energy[ok] = f / pdfs[ok] * etap**2
        mean, se = energy.mean(), energy.std() / np.sqrt(N)
        assert mean <= 1 + 4 * se, (alpha, mean)
        # Light that scatters between facets is lost to a microfacet model: more, rougher.
        assert mean > {0.001: 0.999, 0.1: 0.95, 0.4: 0.75}[alpha], (alpha, mean)
        if alpha == 0.001:
            cos_i = abs(wi[2])
            n = eta if wi[2] > 0 else 1 / eta  # interior over exterior, seen from wi's side
            sin_t2 = (1 - cos_i**2) / n**2
            if sin_t2 >= 1:
                fresnel = 1.0
            else:
                cos_t = np.sqrt(1 - sin_t2)
                rs = (cos_i - n * cos_t) / (cos_i + n * cos_t)
                rp = (n * cos_i - cos_t) / (n * cos_i + cos_t)
                fresnel = (rs**2 + rp**2) / 2
            p = reflected.sum() / N
            assert abs(p - fresnel) < 4 * np.sqrt(fresnel * (1 - fresnel) / N) + 1e-3, (p, fresnel)


@pytest.mark.parametrize(
    "c, o, d, t0, t1",
    [
        ((0.3, 1.0, 2.0), (0, 0, 0), (0, 0, 1), 0.0, 5.0),  # light beside the segment
        ((0.0, 0.01, -3.0), (0, 0, 0), (0, 0, 1), 0.0, 5.0),  # behind the start, nearly on the line
        ((1.0, -2.0, 40.0), (0, 0, 0), (0.6, 0, 0.8), 0.5, np.inf),
    ],
)  # an unbounded segment
def test_equiangular_distances(c, o, d, t0, t1):
    """Equiangular sampling toward a point light: the pdf is the sampler's density (dt/du
    = 1 / pdf by central differences, 0.1 %), proportional to 1 / distance^2 to the light,
    and t stays in [t0, t1], increasing with u."""
    u = np.linspace(0.001, 0.999, 999)
    h = 1e-6
    t, pdf = _probes.equiangular_sample(c, o, d, t0, t1, u)
    t_lo, _ = _probes.equiangular_sample(c, o, d, t0, t1, u - h)
    t_hi, _ = _probes.equiangular_sample(c, o, d, t0, t1, u + h)
    assert np.all(np.diff(t) > 0) and t[0] >= t0 and t[-1] <= t1
    assert np.allclose((t_hi - t_lo) / (2 * h) * pdf, 1, rtol=1e-3)
    d = np.asarray(d) / np.linalg.norm(d)
    r2 = np.sum((np.asarray(o) + t[:, None] * d - np.asarray(c)) ** 2, axis=1)
    assert np.allclose(pdf * r2, np.mean(pdf * r2), rtol=1e-9)
    with pytest.raises(ValueError):
        _probes.equiangular_sample(c, c, d, t0, t1, u)  # the line passes through the light


# Each light with where it is seen from: (xml, position or None, direction toward it or None).
POINT_NEAR = (S.point_light("0.05, 0, 1", "1, 1, 1"), (0.05, 0, 1), None)
POINT_FAR = (S.point_light("0, 3, 0", "1, 1, 1"), (0, 3, 0), None)
AREA = (S.area_light_above(y=3, size=1.0), (0, 3, 0), None)
SUN_OBLIQUE = (
    '<emitter type="directional"><vector name="direction" value="-0.6, 0, -0.8"/></emitter>',
    None,
    (0.6, 0, 0.8),
)


def _expected_light_distance_pdfs(light, o, d, t0, t1, sigma_t, t):
    """The densities the integrator describes: an exponential of rate sigma_t (1 - cos)
    toward the light (per channel), and where the light is near, an equiangular one."""
    _, position, toward = light
    o, d = np.asarray(o, float), np.asarray(d, float) / np.linalg.norm(d)
    if position is not None:
        toward = np.asarray(position) - (o + t0 * d)
    toward = np.asarray(toward, float) / np.linalg.norm(toward)
    rate = np.asarray(sigma_t, float) * max(1 - np.dot(d, toward), 1e-3)
    exponential = rate * np.exp(-rate * (t - t0)) / -np.expm1(-rate * (t1 - t0))
    if position is None:
        return exponential, 0.0
    c = np.asarray(position, float)
    t_closest = np.dot(c - o, d)
    D = np.linalg.norm(c - o - t_closest * d)
    if D == 0:  # the segment's line passes through the light: no equiangular density
        return exponential, 0.0
    theta = np.arctan2(np.array([t0, t1]) - t_closest, D)
    return exponential, D / ((theta[1] - theta[0]) * (D * D + (t - t_closest) ** 2))


@pytest.mark.parametrize(
    "light, o, d, t0, t1, sigma_t, channel, near",
    [
        (POINT_FAR, (0, 0, 0), (0.6, 0.8, 0), 0.0, 1.5, (2, 1, 0.5), 0, False),  # toward the light
        (POINT_FAR, (0, 0, 0), (0.6, 0.8, 0), 0.0, 1.5, (2, 1, 0.5), 2, False),
        (POINT_FAR, (0, 0.5, 0), (0, -1, 0), 0.1, 4.0, (3, 3, 3), 0, False),  # away from it
        (POINT_NEAR, (0, 0, 0), (0, 0, 1), 0.0, 3.0, (5, 5, 5), 0, True),  # past it: two distances
        (POINT_NEAR, (0, 0, 0), (0, 0, 1), 0.0, np.inf, (0.5, 1, 2), 1, True),  # unbounded
        (SUN_OBLIQUE, (0, 0, 0), (0, 0, 1), 0.0, np.inf, (1, 0.5, 0.25), 1, False),
        (AREA, (0, 0, 0), (0.3, 0.9, 0.3), 0.0, 2.0, (6, 6, 6), 0, False),
    ],
)
def test_light_distances(light, o, d, t0, t1, sigma_t, channel, near):
    """Distances drawn for a light along a medium segment: one exponential toward the light,
    and an equiangular one where the light is near. Each follows its density (chi-square
    over 40 bins of about equal count, the exponential drawn in `channel`); the density the
    integrator weighs them by is the sum of the two, checked per channel at the samples;
    and it integrates to the number of distances over the segment in every channel (the
    MIS over channels uses all three)."""
    from scipy.integrate import quad

    scene = _light_scene(light[0]).native
    count = _probes.light_distance_count(scene, 0, o, d, t0, t1, sigma_t)
    assert count == (2 if near else 1)
    peak = float(np.dot(np.asarray(light[1] or (0, 0, 0)) - o, np.asarray(d) / np.linalg.norm(d)))

    def integral(f, a, b):
        if near and a < peak < b:  # the equiangular peak as a break point
            return quad(f, a, peak, limit=200)[0] + quad(f, peak, b, limit=200)[0]
        return quad(f, a, b, limit=200)[0]

    for k in range(count):
        t, density = _probes.light_distance_sample(scene, 0, o, d, t0, t1, sigma_t, channel, k, uniforms(N, 1)[:, 0])
        assert np.all(np.isfinite(t)) and np.all((t >= t0) & (t <= t1))
        expected = [_expected_light_distance_pdfs(light, o, d, t0, t1, sigma_t, x) for x in t[:500]]
        assert np.allclose(density[:500], [e + (q if near else 0) for e, q in expected], rtol=1e-9)

        def own(x, k=k):  # the k-th distance's density: the exponential's in `channel`, or the equiangular
            exponential, equiangular = _expected_light_distance_pdfs(light, o, d, t0, t1, sigma_t, x)
            return exponential[channel] if k == 0 else equiangular

        t_ref, _ = _probes.light_distance_sample(
            scene, 0, o, d, t0, t1, sigma_t, channel, k, uniforms(N, 1, seed=2)[:, 0]
        )
        edges = np.concatenate([[t0], np.quantile(t_ref, np.linspace(0, 1, 41)[1:-1]), [t1]])
        expected_counts = np.array([integral(own, a, b) for a, b in zip(edges[:-1], edges[1:])]) * N
        assert chi2_pooled(np.histogram(t, edges)[0], expected_counts) > P_MIN
    for c in range(3):
        total = integral(lambda x: _probes.light_distance_density(scene, 0, o, d, t0, t1, sigma_t, x)[c], t0, t1)
        assert total == pytest.approx(count, abs=1e-4)
