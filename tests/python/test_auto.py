"""tracer="auto" picks the cheapest sufficient tracer, says why, and keeps its bound."""

import numpy as np
import pytest

import scenes as S
import volpath
from volpath.grids import write_vol
from volpath.testing import render_batches


def auto_choice(scene, **kw):
    volpath.render(scene, spp=1, tracer="auto", **kw)
    return scene.last_render["auto"]


def test_no_media_uses_surface_path_tracing():
    scene = volpath.load_string(S.scene(S.camera(res=8), S.floor(), S.area_light_above()))
    a = auto_choice(scene)
    assert a["tracer"] == "nee_mis" and "no participating media" in a["reasons"][0]


def test_pure_absorber_uses_the_absorption_tracer():
    scene = volpath.load_string(
        S.scene(S.camera(res=8), S.homogeneous("m", "2", "0"), S.medium_sphere("m"), S.back_light())
    )
    assert auto_choice(scene)["tracer"] == "absorption"
    # ... and its image equals the full null-scattering estimate (both are exact here).
    full = volpath.render(scene, spp=4, tracer="null_scattering", seed=1)
    auto = volpath.render(scene, spp=4, seed=1)
    assert np.allclose(full, auto, atol=1e-6)


def test_absorber_with_surfaces_keeps_scattering():
    scene = volpath.load_string(
        S.scene(S.camera(res=8), S.homogeneous("m", "2", "0"), S.medium_sphere("m"), S.floor(), S.point_light())
    )
    assert auto_choice(scene)["tracer"] == "nee_mis"


def test_heterogeneous_needs_null_scattering(tmp_path):
    write_vol(tmp_path / "g.vol", np.ones((2, 2, 2)))
    scene = volpath.load_string(
        S.scene(
            S.camera(res=8),
            '<medium type="heterogeneous" id="m"><volume '
            'type="gridvolume" name="sigma_t"><string name="filename" value="g.vol"/>'
            "</volume></medium>",
            S.medium_cube("m"),
            S.constant_env(),
        ),
        base_dir=str(tmp_path),
    )
    assert auto_choice(scene)["tracer"] == "null_scattering"


def test_absorbing_emitting_grid_uses_the_absorption_tracer(tmp_path):
    """Fire without smoke: an absorbing, emitting grid and nothing that scatters. Ratio
    tracking is exact in expectation: the same image as null scattering, within noise."""
    write_vol(tmp_path / "g.vol", np.random.default_rng(1).random((4, 4, 4)))
    scene = volpath.load_string(
        S.scene(
            S.camera(res=8),
            '<medium type="heterogeneous" id="m"><volume '
            'type="gridvolume" name="sigma_t"><string name="filename" value="g.vol"/>'
            '</volume><float name="albedo" value="0"/><rgb name="radiance" value="1, 0.5, 0.2"/>'
            "</medium>",
            S.medium_cube("m"),
            S.constant_env("0.2, 0.2, 0.2"),
        ),
        base_dir=str(tmp_path),
    )
    a = auto_choice(scene)
    assert a["tracer"] == "absorption" and "(emission included)" in a["reasons"][0]
    fast, se_fast = render_batches(volpath.render, scene, 4, block=4, tracer="absorption", spp=64)
    full, se_full = render_batches(volpath.render, scene, 4, block=4, tracer="null_scattering", spp=64)
    # 5 standard errors of the difference (render_batches: the 4 x 64 spp as 16 batches, so
    # t with 15 degrees of freedom): a false alarm about once in 6000 block-channels.
    assert np.all(np.abs(fast - full) < 5 * np.sqrt(se_fast**2 + se_full**2) + 1e-4)


def test_thick_homogeneous_uses_nee_mis():
    scene = volpath.load_string(
        S.scene(S.camera(res=8), S.homogeneous("m", "5", "0.9"), S.medium_sphere("m"), S.point_light())
    )
    a = auto_choice(scene)
    assert a["tracer"] == "nee_mis" and "grey media" in a["reasons"][1]


@pytest.mark.parametrize("sigma_t,tolerance", [(0.001, 0.01), (0.004, 0.05)])
def test_thin_media_use_single_scattering_within_the_stated_bound(sigma_t, tolerance):
    """A thin fog: auto drops multiple scattering. Its image must agree with the full
    null-scattering image within the stated bound (of the image) plus 5 standard errors."""
    xml = S.scene(
        S.camera(res=8, fov=35, spp=1024),
        S.homogeneous("m", f"{sigma_t}, {2 * sigma_t}, {3 * sigma_t}", "0.95"),
        S.medium_sphere("m"),
        S.point_light("1.5, 1.5, 1.5", "50, 50, 50"),
    )
    scene = volpath.load_string(xml)
    a = auto_choice(scene, tolerance=tolerance)
    assert a["tracer"] == "single" and 0 < a["bound"] < tolerance
    full, full_se = render_batches(volpath.render, scene, 4, block=8, tracer="null_scattering")
    auto, auto_se = render_batches(volpath.render, scene, 4, block=8, tracer="auto", tolerance=tolerance)
    diff = np.abs(full - auto).ravel()
    allowed = a["bound"] * full.ravel() + 5 * np.sqrt(full_se**2 + auto_se**2).ravel()
    assert np.all(diff <= allowed), (full, auto, allowed)


def test_cli_reports_the_choice(tmp_path):
    import subprocess
    import sys

    (tmp_path / "s.xml").write_text(
        S.scene(S.camera(res=4), S.homogeneous("m", "2", "0"), S.medium_sphere("m"), S.back_light())
    )
    r = subprocess.run(
        [sys.executable, "-m", "volpath", "render", str(tmp_path / "s.xml"), "-o", str(tmp_path / "o.exr"), "-q"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0 and "auto: absorption: media only absorb" in r.stdout


def test_depth_limit_selects_the_exact_lighter_tracer():
    scene = volpath.load_string(
        S.scene(S.camera(res=8), S.homogeneous("m", "1", "0.8"), S.medium_sphere("m"), S.point_light(), max_depth=2)
    )
    assert auto_choice(scene)["tracer"] == "single"
    assert auto_choice(scene, max_depth=1)["tracer"] == "absorption"
