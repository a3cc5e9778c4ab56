"""The scene corpus (tests/scenes/): files in the Mitsuba 0.5 / lajolla and Mitsuba 3
spellings, written for these tests (tests/scenes/make_assets.py writes their images and
grid), load with only the warnings their old spellings call for and render finite."""

import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

import volpath

CORPUS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "scenes")
# Each file's expected warnings (substrings, in any order): nothing else may be reported.
EXPECTED = {
    "mitsuba05_smoke.xml": [
        "'method' ignored",
        "'step_size' ignored",
        "208 negative voxels clamped to 0",
        "'filter_type' ignored",
        "'focus_distance' ignored",
    ],
    "mitsuba3_materials.xml": [],
    "lajolla_fog.xml": [],
}


def test_the_corpus_is_what_the_test_expects():
    assert sorted(f for f in os.listdir(CORPUS) if f.endswith(".xml")) == sorted(EXPECTED)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_a_corpus_scene_loads_with_its_warnings_and_renders_finite(name):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = volpath.load_file(os.path.join(CORPUS, name))
    messages = [str(w.message) for w in caught if issubclass(w.category, volpath.SceneWarning)]
    assert len(messages) == len(EXPECTED[name]), messages
    for expected in EXPECTED[name]:
        assert any(expected in m for m in messages), (expected, messages)
    image = volpath.render(scene, seed=1, threads=2)
    assert np.all(np.isfinite(image)) and image.min() >= 0 and image.mean() > 0.01


def test_volpath_info_lists_the_textures_and_bsdfs():
    out = subprocess.run(
        [sys.executable, "-m", "volpath", "info", os.path.join(CORPUS, "mitsuba3_materials.xml")],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    for expected in (
        "bsdfs     10",
        "blendbsdf",
        "mask (two-sided)",
        "normalmap",
        "bumpmap",
        "textures  5",
        "checkerboard 'checks'",
        "bitmap ripples.png: 32x32, 3 channel(s), uint8 linear",
        "bitmap colours.png: 32x32, 3 channel(s), uint8 sRGB",
    ):
        assert expected in out, (expected, out)
