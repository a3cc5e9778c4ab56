"""Blender's lamps against closed forms: a spot's cone with its smoothstep Blend, a sphere
lamp (a point lamp with a Radius) and its Soft Falloff, on a diffuse floor seen from
straight above (direct light only); and an emission map, found alike by NEE and by the
path.

Each pixel's expectation is the closed-form radiance averaged over the pixel (16x16
points: the box filter's jitter), so the renders are held to it by a z-test over
independent batches."""

import numpy as np
import pytest

import scenes as S
import volpath
from volpath.testing import max_z, render_batches

RES, HEIGHT, FOV = 24, 10.0, 40.0  # the camera above the floor's centre
ALBEDO, INTENSITY, LAMP = 0.5, 8.0, 2.0  # the lamp LAMP above the floor, over its centre
CUTOFF, BLEND, RADIUS = 40.0, 1.0, 0.5


def _scene(lamp):
    return S.scene(
        S.camera(res=RES, fov=FOV, origin=f"0, {HEIGHT}, 0", target="0, 0, 0", up="0, 0, -1", spp=16),
        S.floor(y=0, size=10, reflectance=f"{ALBEDO}, {ALBEDO}, {ALBEDO}"),
        lamp,
        max_depth=2,
    )


def _expected(falloff):
    """Per pixel, the floor's radiance under a lamp of intensity INTENSITY at height LAMP
    times falloff(cos_theta, d), averaged over the pixel."""
    half = HEIGHT * np.tan(np.radians(FOV / 2))
    sub = 16
    t = (np.arange(RES * sub) + 0.5) / (RES * sub) * 2 - 1
    x, z = np.meshgrid(t * half, t * half)
    d = np.sqrt(x**2 + z**2 + LAMP**2)
    cos_theta = LAMP / d
    L = ALBEDO / np.pi * INTENSITY * cos_theta / d**2 * falloff(cos_theta, d)
    return L.reshape(RES, sub, RES, sub).mean(axis=(1, 3))


def _z(xml, expected):
    scene = volpath.load_string(xml)
    mean, se = render_batches(volpath.render, scene, 32)
    return max_z(mean.mean(axis=2), se.mean(axis=2), expected, np.zeros_like(expected), floor=1e-4)


def test_a_spot_lights_its_cone_and_fades_over_its_blend():
    cos_half = np.cos(np.radians(CUTOFF))

    def smoothstep(cos_theta, d):
        s = np.clip((cos_theta - cos_half) / ((1 - cos_half) * BLEND), 0, 1)
        return s * s * (3 - 2 * s)

    lamp = (
        f'<emitter type="spot"><point name="position" value="0, {LAMP}, 0"/><vector name="direction" value="0, -1, 0"/>'
        f'<float name="cutoff_angle" value="{CUTOFF}"/><float name="blend" value="{BLEND}"/>'
        f'<rgb name="intensity" value="{INTENSITY}, {INTENSITY}, {INTENSITY}"/></emitter>'
    )
    expected = _expected(smoothstep)
    assert expected.min() == 0 and expected.max() > 0  # the cone's edge is in view
    assert _z(_scene(lamp), expected) < 5  # 5 sigma over 576 pixels: a false alarm ~1e-4


@pytest.mark.parametrize("soft", [False, True])
def test_a_sphere_lamp_lights_as_its_point_lamp_or_a_facing_disc(soft):
    """Without Soft Falloff, a sphere above the horizon gives the irradiance of a point of
    the same power; with it, that of a disc of its radius facing the receiver: times
    d^2 / (d^2 + r^2) (Cycles' rule, tests/parity_scenes.py's sphere lights)."""
    radiance = INTENSITY / (np.pi * RADIUS**2)
    lamp = (
        f'<shape type="sphere"><point name="center" value="0, {LAMP}, 0"/><float name="radius" value="{RADIUS}"/>'
        f'<string name="hidden_from" value="camera"/><bsdf type="null"/>'
        f'<emitter type="area"><rgb name="radiance" value="{radiance}, {radiance}, {radiance}"/>'
        f'<boolean name="soft_falloff" value="{str(soft).lower()}"/></emitter></shape>'
    )
    expected = _expected(lambda c, d: d**2 / (d**2 + RADIUS**2) if soft else 1.0)
    assert _z(_scene(lamp), expected) < 5


def test_bad_spots_are_errors_naming_the_parameter():
    for bad, message in (("cutoff_angle", "at most 90"), ("blend", "at most 1")):
        lamp = (
            f'<emitter type="spot"><point name="position" value="0, 2, 0"/><float name="{bad}" value="120"/></emitter>'
        )
        with pytest.raises(volpath.SceneError, match=f"'{bad}' must be {message}"):
            volpath.load_string(_scene(lamp))


OBLIQUE = S.camera(res=16, fov=70, origin="0, 0.5, 3", target="0, -0.2, 0", spp=16)


def _emission_map_scene(camera=OBLIQUE):
    """A floor lit by a quad facing down whose radiance is a checkerboard (an emission map)."""
    quad = """<shape type="rectangle">
        <transform name="to_world"><scale value="1.0"/><rotate x="1" angle="90"/><translate y="1.5"/></transform>
        <emitter type="area"><texture type="checkerboard" name="radiance">
            <rgb name="color0" value="4, 1, 0.5"/><rgb name="color1" value="0.5, 2, 6"/>
            <transform name="to_uv"><scale value="2"/></transform></texture>
            <rgb name="scale" value="1.5, 1.5, 1.5"/></emitter></shape>"""
    return S.scene(camera, S.floor(y=-0.5, size=4), quad, max_depth=3)


def test_an_emission_map_lights_alike_whichever_strategy_finds_it():
    """NEE draws the map at the point it samples on the quad, a BSDF's sample looks it up
    where it hits: the tracer that combines both (nee_mis) and the one that only follows
    the path (multiple) agree, block by block."""
    scene = volpath.load_string(_emission_map_scene())
    a = render_batches(volpath.render, scene, 8, block=4, tracer="nee_mis")
    b = render_batches(volpath.render, scene, 8, block=4, tracer="multiple")
    assert a[0].mean() > 0.05
    assert max_z(*a, *b) < 5


def test_an_emission_map_is_seen_as_its_texture_times_its_scale():
    looking_up = S.camera(res=32, fov=30, origin="0, 0, 0", target="0, 1, 0", up="0, 0, -1", spp=4)
    image = volpath.render(volpath.load_string(_emission_map_scene(looking_up)), tracer="absorption", seed=1)
    colours = {tuple(np.round(c, 3)) for c in image.reshape(-1, 3) if c.max() > 0}
    assert {(6.0, 1.5, 0.75), (0.75, 3.0, 9.0)} <= colours
