"""Coplanar medium boundaries and surfaces (issue #38): a box of smoke resting on the floor,
an area light on its top face, a camera on the floor's plane, each rendered as it would
be across a gap of zero width. The floor under a resting box once rendered 11 % darker: a
ray that crossed the box's bottom face first was pushed past the floor."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "native"))
from test_layers import CAMERA, lookat, placed  # noqa: E402

import volpath  # noqa: E402

SMOKE = {"type": "homogeneous", "sigma_t": 1.0, "albedo": 0.8}
GAP = 1e-4  # wide against ray epsilons (~1e-9 here), narrow against the image


def scene(box_gap=0.0, light_gap=None, eye=(0, -5, 4)):
    box = np.eye(4)
    box[2, 3] = 1 + box_gap  # the cube [-1, 1]^3, its bottom face box_gap above the floor
    d = {
        "type": "scene",
        "camera": {
            **CAMERA,
            "fov": 40,
            "film": {"type": "hdrfilm", "width": 24, "height": 24},
            "to_world": lookat(eye, (0, 0, 0.5)),
        },
        "floor": {"type": "rectangle", "to_world": placed(4), "bsdf": {"type": "diffuse", "reflectance": 0.7}},
        "cube": {"type": "cube", "to_world": box, "bsdf": {"type": "null"}, "interior": SMOKE},
        "sun": {"type": "directional", "direction": [0.3, 0.2, -1], "irradiance": 3.0},
        "env": {"type": "constant", "radiance": 0.3},
    }
    if light_gap is not None:  # a black quad lit on its underside, on the box's top face
        d["light"] = {
            "type": "rectangle",
            "to_world": placed(0.5, flip=True, z=2 + box_gap + light_gap),
            "bsdf": {"type": "diffuse", "reflectance": 0.0},
            "emitter": {"type": "area", "radiance": 4.0},
        }
    return volpath.load_dict(d)


def means(s, first_seed, seeds=8, spp=32):
    return np.array([volpath.render(s, spp=spp, seed=first_seed + k, threads=2).mean() for k in range(seeds)])


@pytest.mark.parametrize(
    "touching, apart",
    [
        (dict(), dict(box_gap=GAP)),
        (dict(light_gap=0.0), dict(light_gap=GAP)),
        (dict(eye=(0, -5, 0.0)), dict(eye=(0, -5, GAP))),
    ],
    ids=["box on the floor", "light on the box", "camera on the floor's plane"],
)
def test_a_shared_plane_renders_as_a_zero_gap(touching, apart):
    """Image means over 8 seeds each agree within 5 standard errors of their difference
    (different seeds: independent estimates)."""
    a, b = means(scene(**touching), 0), means(scene(**apart), 100)
    assert np.all(np.isfinite(a)) and np.all(np.isfinite(b))
    se = math.sqrt(a.var(ddof=1) / len(a) + b.var(ddof=1) / len(b))
    assert abs(a.mean() - b.mean()) < 5 * se + 1e-4 * b.mean(), (a.mean(), b.mean(), se)


def test_only_boundaries_a_surface_may_lie_on_look_around():
    """The look costs a ray query per crossing: only flat null boundaries that a flat
    surface may touch pay it (none of the bench scenes' do)."""
    from volpath import _probes

    assert _probes.boundary_with_contact(scene().native) == [False, True]  # the floor, the box
    assert _probes.boundary_with_contact(scene(box_gap=GAP).native) == [False, False]
