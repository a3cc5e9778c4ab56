"""A light hidden from diffuse, glossy or transmission rays (Blender's ray visibility of
lights) lights surfaces through their other lobes only: NEE evaluates those lobes, and a
bounce that finds the light counts the share of its BSDF value they hold. The lobes split
every BSDF value, so what a light gives with some lobes hidden and what it gives with the
others hidden add up to what it gives seen by all, on every kind of surface (a plastic's
diffuse base and coating at once, a rough metal, rough glass from both sides)."""

import numpy as np
import pytest

import scenes as S
import volpath
from volpath.testing import max_z, render_batches

SURFACES = """
<shape type="rectangle">
    <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/><translate y="-1"/></transform>
    <bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.6, 0.4, 0.3"/>
        <float name="alpha" value="0.2"/></bsdf></shape>
<shape type="sphere"><point name="center" value="-0.8, -0.4, 0"/><float name="radius" value="0.6"/>
    <bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha" value="0.15"/></bsdf></shape>
<shape type="sphere"><point name="center" value="0.8, -0.4, 0.3"/><float name="radius" value="0.6"/>
    <bsdf type="roughdielectric"><string name="distribution" value="ggx"/>
        <float name="alpha" value="0.2"/></bsdf></shape>
"""


def lamp(kind, hidden):
    """The scene's one light, which the camera does not see."""
    hidden_from = f'<string name="hidden_from" value="{hidden}"/>' if hidden else ""
    if kind == "point":
        return f"""<emitter type="point"><point name="position" value="1, 2.5, 2"/>
            <rgb name="intensity" value="20, 20, 20"/>{hidden_from}</emitter>"""
    return f"""<shape type="rectangle">
        <transform name="to_world"><scale value="1.5"/><rotate x="1" angle="60"/><translate y="2" z="1"/></transform>
        <string name="hidden_from" value="camera"/>
        <emitter type="area"><rgb name="radiance" value="3, 3, 3"/>{hidden_from}</emitter></shape>"""


def load(kind, hidden, spp=16):
    camera = S.camera(res=16, fov=45, origin="0, 1.5, 5", target="0, -0.5, 0", spp=spp)
    return volpath.load_string(S.scene(camera, SURFACES, lamp(kind, hidden), max_depth=4))


@pytest.mark.parametrize("kind", ["area", "point"])
def test_hidden_lobes_add_up_to_the_light_seen_by_all(kind):
    """Block means (4x4 pixels) of the light seen by all against the sum of two renders
    that each hide it from the lobes the other shows it to: within 5 standard errors
    (16 independent batches each, Student's t with 15 degrees of freedom: a false alarm
    among the 16 blocks has probability ~2e-3)."""
    full = render_batches(volpath.render, load(kind, ""), 16, block=4)
    diffuse_hidden = render_batches(volpath.render, load(kind, "diffuse"), 16, block=4)
    others_hidden = render_batches(volpath.render, load(kind, "glossy, transmission"), 16, block=4)
    both = (diffuse_hidden[0] + others_hidden[0], np.hypot(diffuse_hidden[1], others_hidden[1]))
    assert max_z(*full, *both) < 5
    # Each half holds a part of the image that matters: neither is black or the whole.
    for part in (diffuse_hidden[0], others_hidden[0]):
        assert 0.1 < part.sum() / full[0].sum() < 0.9


def test_a_light_hidden_from_every_lobe_lights_no_surface():
    """Seen by no lobe and not by the camera, the scene's only light leaves the image black:
    neither NEE nor a bounce that meets it counts it."""
    image = volpath.render(load("area", "diffuse, glossy, transmission"), seed=1)
    assert np.all(image == 0)


@pytest.mark.parametrize("hidden", ["diffuse", "glossy, transmission"])
def test_bounces_that_find_the_light_count_the_lobes_it_shows_to(hidden):
    """Direct light only: NEE alone (`single`, which evaluates the lobes the light shows to)
    against NEE and BSDF sampling under MIS (`nee_mis`, where a bounce that finds the light
    counts the share of its BSDF value from those lobes). 4x4-pixel block means within 5
    standard errors (16 batches each, as above)."""
    scene = load("area", hidden)
    nee = render_batches(volpath.render, scene, 16, block=4, tracer="single", max_depth=2)
    mis = render_batches(volpath.render, scene, 16, block=4, tracer="nee_mis", max_depth=2)
    assert max_z(*nee, *mis) < 5
