"""Layered BSDFs: blendbsdf and mask (chosen per hit), normalmap and bumpmap (the shading
normal turned): their samplers against their mixtures, closed forms under a directional
light, and MIS through a mask."""

import math

import numpy as np
import pytest

import volpath
from scenes import lookat
from volpath import _probes
from volpath.testing import chi2_directions

N = 200_000
P_MIN = 1e-4  # as in tests/stats/test_chi2.py: a correct sampler fails one run in 10^4
ROUGH_METAL = {
    "type": "roughconductor",
    "distribution": "ggx",
    "alpha": 0.3,
    "eta": [0.2, 0.9, 1.1],
    "k": [3.9, 2.4, 2.1],
}
CAMERA = {"type": "perspective", "fov": 20, "film": {"type": "hdrfilm", "width": 8, "height": 8}}


def loaded(bsdf, **extra):
    """The BSDF on the rectangle z = 0, |x|, |y| <= 1 (uv = ((x + 1) / 2, (y + 1) / 2))."""
    return volpath.load_dict({"type": "scene", "camera": CAMERA, "shape": {"type": "rectangle", "bsdf": bsdf}, **extra})


def samples(scene, wi, u, uv=(0.5, 0.5)):
    """surface_sample where a ray from above meets the rectangle at uv."""
    origin = (2 * uv[0] - 1, 2 * uv[1] - 1, 1.0)
    return _probes.surface_sample(scene.native, top(scene), wi, u, origin, (0.0, 0.0, -1.0))


def top(scene):
    return len(scene.summary["bsdfs"]) - 1  # the layer is built after what it holds


def uniforms(n, dims=4, seed=1):
    return np.random.default_rng(seed).random((n, dims))


@pytest.mark.parametrize("wi", [(0.0, 0.0, 1.0), (0.6, 0.0, 0.8)])
def test_blend_samples_its_mixture(wi):
    """The directions a blend draws follow (1 - w) pdf_a + w pdf_b (chi-square)."""
    scene = loaded({"type": "blendbsdf", "weight": 0.3, "a": {"type": "diffuse"}, "b": ROUGH_METAL})
    dirs, weights, passed = samples(scene, wi, uniforms(N))
    assert not passed.any()
    ok = weights.max(axis=1) > 0

    def pdf(d):
        return 0.7 * _probes.bsdf_pdf(scene.native, 0, wi, d) + 0.3 * _probes.bsdf_pdf(scene.native, 1, wi, d)

    assert chi2_directions(dirs[ok], pdf, N) > P_MIN


def test_blend_weight_from_a_texture_chooses_per_point():
    """A checkerboard weight (0.9 / 0.1): the share of samples from b at points of each
    colour, within 5 standard errors."""
    checker = {"type": "checkerboard", "color0": 0.9, "color1": 0.1}
    mirror = {"type": "conductor"}
    scene = loaded({"type": "blendbsdf", "weight": checker, "a": {"type": "diffuse"}, "b": mirror})
    n, wi = 20_000, (0.0, 0.0, 1.0)
    for uv, w in (((0.25, 0.25), 0.9), ((0.75, 0.25), 0.1)):
        dirs, _, _ = samples(scene, wi, uniforms(n), uv)
        share = np.mean(dirs[:, 2] > 1 - 1e-9)  # the mirror's reflection of normal incidence
        assert abs(share - w) < 5 * math.sqrt(w * (1 - w) / n), (uv, share)


@pytest.mark.parametrize("opacity", [0.25, 0.8])
def test_mask_passes_one_minus_opacity_and_samples_the_rest(opacity):
    scene = loaded({"type": "mask", "opacity": opacity, "inner": {"type": "diffuse", "reflectance": 0.8}})
    wi = (0.3, 0.1, 0.9)
    dirs, weights, passed = samples(scene, wi, uniforms(N))
    assert abs(passed.mean() - (1 - opacity)) < 5 * math.sqrt(opacity * (1 - opacity) / N)
    np.testing.assert_allclose(weights[~passed], 0.8)
    pdf = lambda d: opacity * _probes.bsdf_pdf(scene.native, 0, wi, d)  # noqa: E731
    assert chi2_directions(dirs[~passed], pdf, N) > P_MIN


def test_layers_take_bsdfs_built_before_them():
    scene = volpath.load_dict({"type": "scene", "camera": CAMERA})
    with pytest.raises(ValueError, match="does not exist yet"):
        scene.native.add_bsdf_blend(0, 1, 0.5)


def test_mask_and_blend_spell_errors_with_their_place():
    with pytest.raises(volpath.SceneError, match="expected exactly 2 nested bsdfs, found 1"):
        loaded({"type": "blendbsdf", "a": {"type": "diffuse"}})
    with pytest.raises(volpath.SceneError, match="'opacity' must be at most 1"):
        loaded({"type": "mask", "opacity": 1.5, "a": {"type": "diffuse"}})


def lit_plane(bsdf, toward_light, irradiance=2.0):
    """A unit-square plane (normal +z, dp/du along +x) seen from above, lit by a
    directional light arriving from `toward_light`."""
    d = -np.asarray(toward_light, float) / np.linalg.norm(toward_light)
    return volpath.load_dict(
        {
            "type": "scene",
            "camera": {**CAMERA, "to_world": lookat((0, 0, 5), (0, 0, 0))},
            "plane": {"type": "rectangle", "bsdf": bsdf},
            "sun": {"type": "directional", "direction": d.tolist(), "irradiance": [irradiance] * 3},
        }
    )


def placed(scale=1.0, flip=False, z=0.0):
    """A rectangle's to_world: scaled, turned upside down if asked, raised to z."""
    m = np.diag([scale, -scale if flip else scale, -scale if flip else scale, 1.0])
    m[2, 3] = z
    return m


def flat(value, size=1):
    return {"type": "bitmap", "data": np.full((size, size, 3), value, np.float32), "raw": True}


@pytest.mark.parametrize("toward_light", [(1, 0, 1), (-1, 0, 1), (0, 1, 1), (0.2, -0.5, 1)])
def test_a_normal_map_lights_the_plane_as_its_normal_says(toward_light):
    """Diffuse 0.5 under a directional light: radiance = 0.5 / pi x E x cos, with the
    cosine to the mapped normal (x along dp/du). Exact: NEE toward a delta light."""
    mapped = np.array([math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4)])
    texture = flat((mapped + 1) / 2)
    scene = lit_plane({"type": "normalmap", "normalmap": texture, "inner": {"type": "diffuse"}}, toward_light)
    img = volpath.render(scene, spp=1, seed=1, threads=1)
    L = np.asarray(toward_light, float) / np.linalg.norm(toward_light)
    expected = 0.5 / math.pi * 2.0 * max(float(mapped @ L), 0.0)
    np.testing.assert_allclose(img, expected, rtol=1e-5, atol=1e-7)


def test_a_bump_map_tilts_the_normal_by_its_slope():
    """Heights rising along u at slope 1 (a ramp across 64 texels), scale 2, on a plane
    whose dp/du is 2 x: the displaced surface's normal is (-1, 0, 1) / sqrt 2."""
    ramp = np.tile(((np.arange(64) + 0.5) / 64).astype(np.float32)[None, :, None], (4, 1, 3))
    heights = {"type": "bitmap", "data": ramp, "raw": True, "wrap_mode": "clamp"}
    for toward_light, cos in (((-1, 0, 1), 1.0), ((1, 0, 1), 0.0), ((0, 0, 1), math.sqrt(0.5))):
        scene = lit_plane(
            {"type": "bumpmap", "heights": heights, "scale": 2.0, "inner": {"type": "diffuse"}}, toward_light
        )
        img = volpath.render(scene, spp=1, seed=1, threads=1)
        centre = img[2:6, 2:6]  # away from the clamped edges, where the ramp's slope is 1
        np.testing.assert_allclose(centre, 0.5 / math.pi * 2.0 * cos, rtol=1e-4, atol=1e-6)


def test_strength_blends_toward_the_unperturbed_normal():
    texture = flat((np.array([1.0, 0.0, 0.0]) + 1) / 2)  # a normal in the plane: turned half-way
    bsdf = {"type": "normalmap", "normalmap": texture, "strength": 0.5, "inner": {"type": "diffuse"}}
    img = volpath.render(lit_plane(bsdf, (0, 0, 1)), spp=1, seed=1, threads=1)
    np.testing.assert_allclose(img, 0.5 / math.pi * 2.0 * math.sqrt(0.5), rtol=1e-5)


def render_mean(scene, spp, seed):
    return volpath.render(scene, spp=spp, seed=seed, tracer="nee_mis", threads=2).mean(axis=(0, 1))


BLACK = {"type": "diffuse", "reflectance": 0.0}
PANES = {
    "mask": {"type": "mask", "opacity": 0.4, "black": BLACK},
    "blend with null": {"type": "blendbsdf", "weight": 0.4, "a": {"type": "null"}, "b": BLACK},
}


@pytest.mark.parametrize("pane", PANES)
def test_a_pane_between_light_and_floor_passes_its_share_under_mis(pane):
    """An area light over a diffuse floor, with a pane of black diffuse masked to opacity
    0.4 (or blended 0.4 with a null BSDF) between them: the floor's light falls to 0.6 of what it was, and the camera sees
    the floor through the pane too: 0.36 in all. NEE's shadow rays and BSDF-sampled rays
    through the pane must agree on the pane's share, else the MIS weights no longer sum
    to one. 16 seeds each way; 5 standard errors."""

    def scene(with_pane):
        d = {
            "type": "scene",
            "camera": {
                **CAMERA,
                "film": {"type": "hdrfilm", "width": 16, "height": 16},
                "to_world": lookat((0, 4, 2.5), (0, 0, 0)),
            },
            "floor": {
                "type": "rectangle",
                "to_world": placed(3),
                "bsdf": {"type": "diffuse", "reflectance": 0.5},
            },
            "light": {
                "type": "rectangle",
                "to_world": placed(1.5, flip=True, z=2),
                "emitter": {"type": "area", "radiance": 5.0},
                "bsdf": BLACK,  # no light back to the floor
            },
        }
        if with_pane:
            d["pane"] = {
                "type": "rectangle",
                "to_world": placed(2.5, z=1),
                "bsdf": {"type": "twosided", "m": PANES[pane]},
            }
        return volpath.load_dict(d)

    with_pane = np.array([render_mean(scene(True), 16, s) for s in range(16)])
    without = np.array([render_mean(scene(False), 16, 100 + s) for s in range(16)])
    ratio = with_pane.mean(0) / without.mean(0)
    se = ratio * np.sqrt(
        (with_pane.std(0, ddof=1) / with_pane.mean(0)) ** 2 / 16 + (without.std(0, ddof=1) / without.mean(0)) ** 2 / 16
    )
    assert np.all(np.abs(ratio - 0.36) < 5 * se + 1e-3), (ratio, se)
