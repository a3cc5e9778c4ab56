"""Denoising: the albedo and normal passes the native renderer gives the denoiser, and what
Intel Open Image Denoise makes of a noisy render."""

import subprocess
import sys

import numpy as np
import pytest

import scenes as S
import volpath
from volpath import _core
from volpath.adaptive import SLACK
from volpath.denoise import surface_passes
from volpath.tonemap import auto_exposure, display

WALL = """<shape type="rectangle"><transform name="to_world"><scale x="1" y="3"/><translate x="-1" z="-1"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.4, 0.6"/></bsdf></shape>"""


def features(scene, spp=4):
    f = np.zeros((scene.height, scene.width, 8))
    settings = _core.RenderSettings(spp=spp, threads=1, tracer=_core.TracerConfig(tracer=_core.Tracer.nee_mis))
    _core.render(scene.native, settings, features=f)
    return surface_passes(f, spp)


def test_passes_hold_the_first_surface_through_boundaries_and_fog():
    # A wall on the left half seen through a sphere of fog (an index-matched boundary), the
    # right half empty: the wall's reflectance and its normal toward the camera on the left,
    # white and no normal on the right.
    scene = volpath.load_string(
        S.scene(
            S.camera(res=16, fov=30),
            S.homogeneous("fog", "0.5", "0.9"),
            S.medium_sphere("fog", radius=0.5),
            WALL,
            S.point_light(),
        )
    )
    f = features(scene)
    albedo, normal = f["albedo"], f["normal"]
    left, right = np.s_[:, :6], np.s_[:, 10:]  # Mitsuba's camera: +x is the image's left
    assert np.allclose(albedo[left], [0.2, 0.4, 0.6]) and np.allclose(normal[left], [0, 0, 1])
    assert np.allclose(albedo[right], 1) and np.allclose(normal[right], 0)
    # Depth along the view axis: the wall (z = -1) 6 units from the camera (z = 5), whatever
    # the pixel's angle; nothing on the right.
    assert np.allclose(f["depth"][left], 6) and np.all(np.isinf(f["depth"][right]))


def test_render_returns_the_passes_it_was_asked_for_with_the_same_image():
    scene = volpath.load_string(S.scene(S.camera(res=8, spp=4), WALL, S.point_light()))
    image, aovs = volpath.render(scene, seed=3, aovs=True)
    assert np.array_equal(image, volpath.render(scene, seed=3))  # the passes change no sample
    assert set(aovs) == {"albedo", "normal", "depth"} and aovs["depth"].shape == (8, 8)
    assert aovs["albedo"].dtype == np.float32 and aovs["albedo"].shape == (8, 8, 3)


def test_denoised_render_is_closer_to_the_reference_and_keeps_the_means():
    # At 4 spp the denoised image must be much closer to a 1024-spp reference on the display
    # than the noisy one (measured: 3x), and its 8x8 block means within 10 % of the
    # reference's (the bias a denoiser may leave: it smooths, it does not relight).
    scene = volpath.load_string(
        S.scene(
            S.camera(res=32, spp=4),
            S.homogeneous("m", "3, 2, 1", "0.9", g=0.3),
            S.medium_sphere("m"),
            S.floor(),
            S.area_light_above(size=0.4),
            S.constant_env("0.05, 0.05, 0.08"),
        )
    )
    reference = volpath.render(scene, spp=1024, seed=99)
    noisy = volpath.render(scene, spp=4, seed=1)
    denoised = volpath.render(scene, spp=4, seed=1, denoise=True)
    assert scene.last_render["denoised"] and np.isfinite(denoised).all() and denoised.min() >= 0
    e = auto_exposure(reference)
    error = lambda im: np.sqrt(np.mean((display(im, e) - display(reference, e)) ** 2))
    assert error(denoised) < error(noisy) / 2, (error(denoised), error(noisy))
    blocks = lambda im: im.reshape(4, 8, 4, 8, 3).mean(axis=(1, 3, 4))
    assert np.allclose(blocks(denoised), blocks(reference), rtol=0.1, atol=0.01 * reference.mean())


def test_denoise_with_a_target_error():
    scene = volpath.load_string(
        S.scene(
            S.camera(res=16),
            S.homogeneous("m", "2", "0.9"),
            S.medium_sphere("m"),
            S.floor(),
            S.area_light_above(size=0.4),
        )
    )
    image = volpath.render(scene, target_error=0.03, spp=64, denoise=True, seed=2)
    assert scene.last_render["denoised"] and np.isfinite(image).all() and scene.last_render["error"] <= 0.03 * SLACK


def test_missing_denoiser_is_a_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyoidn", None)  # as if not installed
    scene = volpath.load_string(S.scene(S.camera(res=8), S.floor(), S.point_light()))
    with pytest.raises(RuntimeError, match="pip install pyoidn"):
        volpath.render(scene, spp=1, denoise=True)


def test_cli_denoise(tmp_path, root):
    (tmp_path / "s.xml").write_text(S.scene(S.camera(res=8), S.floor(), S.point_light()))
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "volpath",
            "render",
            str(tmp_path / "s.xml"),
            "-o",
            str(tmp_path / "o.exr"),
            "--spp",
            "2",
            "--denoise",
            "-q",
        ],
        capture_output=True,
        text=True,
        cwd=root,
    )
    assert r.returncode == 0, r.stderr
    assert "denoised" in r.stdout and volpath.read_exr(tmp_path / "o.exr", metadata=True)[1]["denoised"] == 1
