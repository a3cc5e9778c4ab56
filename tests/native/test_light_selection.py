"""Light selection by importance (native/include/volpath/light_sampler.h) against
superposition: light adds up, so a scene lit by several lights renders as the sum of the
scene lit by each alone. Alone, a light is NEE's only choice; together, NEE chooses among
them by their importance at each point, and an emitter found by a BSDF's sample is weighted
with the probability NEE would have had at the path's vertex. A wrong probability on either
side (a pdf that does not match the choice, a light given no chance where it does light)
biases the sum, which the z-test finds."""

import numpy as np
import pytest

import scenes as S
import volpath
from volpath.testing import max_z, render_batches

QUAD = """<shape type="rectangle">
    <transform name="to_world"><scale value="1.2"/><rotate x="1" angle="90"/><translate y="1.8"/></transform>%s</shape>"""
SPHERE = """<shape type="sphere"><point name="center" value="-1.2, 0.6, 0.5"/><float name="radius" value="0.5"/>
    <bsdf type="null"/>%s</shape>"""
# Each light, as (its shape without emission, or "", the light): a light's shape stays in
# every render, lit or not, so that the shadows it casts are the same in all of them.
LIGHTS = {
    # A one-sided quad facing down (the floor sees its front, the sun its back).
    "quad": (QUAD % "", QUAD % '<emitter type="area"><rgb name="radiance" value="8, 8, 8"/></emitter>'),
    "sphere": (
        SPHERE % "",
        SPHERE
        % '<emitter type="area"><rgb name="radiance" value="6, 5, 4"/><boolean name="soft_falloff" value="true"/></emitter>',
    ),
    "point": ("", S.point_light(position="1.5, 1.5, 1.5", intensity="3, 3, 5")),
    "spot": (
        "",
        '<emitter type="spot"><point name="position" value="0, 3, -1"/><vector name="direction" value="0, -1, 0.5"/>'
        '<float name="cutoff_angle" value="30"/><float name="blend" value="0.5"/>'
        '<rgb name="intensity" value="20, 20, 20"/></emitter>',
    ),
    "sun": (
        "",
        '<emitter type="sun"><vector name="direction" value="-0.3, -1, -0.2"/><rgb name="irradiance" value="1, 1, 1"/>'
        '<float name="angular_radius" value="0.05"/></emitter>',
    ),
}


# A ring of small lamps: with the lights above, more local lights than the sampler weighs one
# by one (LightSampler::kLinearLights): they are chosen through its tree.
RING = {
    f"lamp {k}": (
        "",
        S.point_light(
            position=f"{2 * np.cos(k / 2.5):.3f}, {0.3 + 0.1 * k:.2f}, {2 * np.sin(k / 2.5):.3f}",
            intensity=f"{0.2 + 0.1 * k:.2f}, 0.5, 0.4",
        ),
    )
    for k in range(16)
}
LIGHTS.update(RING)


def _scene(lit):
    """The scene with every light's shape, the lights in `lit` emitting."""
    glossy = """<shape type="sphere"><point name="center" value="0.3, 0, 0"/><float name="radius" value="0.5"/>
        <bsdf type="roughconductor"><float name="alpha" value="0.3"/></bsdf></shape>"""
    lights = [LIGHTS[n][1] if n in lit else LIGHTS[n][0] for n in LIGHTS]
    return S.scene(
        S.camera(res=24, fov=60, origin="0, 2, 4", target="0, -0.5, 0", spp=16),
        S.floor(y=-0.5, size=4),
        glossy,
        *lights,
        max_depth=4,
    )


def _render(xml):
    return render_batches(volpath.render, volpath.load_string(xml), 32, tracer="nee_mis")


@pytest.mark.parametrize(
    "names",
    [("quad", "sphere", "point", "spot", "sun"), ("quad", "point", "sun"), tuple(LIGHTS)],
    ids=["five lights", "three lights", "a tree of twenty lights"],
)
def test_several_lights_render_as_the_sum_of_each_alone(names):
    mean, se = _render(_scene(names))
    alone = [_render(_scene([n])) for n in names]
    total = sum(m for m, _ in alone)
    total_se = np.sqrt(sum(s**2 for _, s in alone))
    assert total.mean() > 0.05
    # 5 sigma over 24 x 24 x 3 values: a false alarm ~1e-3 at most.
    assert max_z(mean, se, total, total_se) < 5
