"""Where the physics coincides, the tracers agree (z-tests on 4x4 pixel blocks).

Each image is rendered as 16 independent batches (volpath.testing.render_batches); the
standard error of every block mean is estimated from the spread between batches, so each
z follows Student's t with 15 degrees of freedom. With 4x4 blocks of a 16x16 image there
are 16 blocks x 3 channels = 48 comparisons per test; a threshold of 5 standard errors
(P(|t| > 5) = 1.6e-4 each) keeps the family-wise false-alarm rate below 1 % while a bias
of a few percent is caught.
"""

import numpy as np
import pytest

import scenes as S
import volpath
from volpath.testing import max_z, render_batches

Z_MAX = 5.0


def compare(scene, tracer_a, tracer_b, batches=6, **kwargs):
    a = render_batches(volpath.render, scene, batches, block=4, tracer=tracer_a, **kwargs)
    b = render_batches(volpath.render, scene, batches, block=4, tracer=tracer_b, **kwargs)
    return max_z(a[0], a[1], b[0], b[1])


def test_single_equals_nee_mis_at_depth_two():
    xml = S.scene(
        S.camera(res=16, spp=32),
        S.homogeneous("m", "1.5, 1, 0.5", "0.8, 0.6, 0.9", g=0.4),
        S.medium_sphere("m"),
        S.floor(),
        S.area_light_above(),
        S.point_light(),
        S.constant_env("0.2, 0.2, 0.3"),
    )
    scene = volpath.load_string(xml)
    assert compare(scene, "single", "nee_mis", max_depth=2) < Z_MAX


@pytest.mark.parametrize("pair", [("multiple", "nee_mis"), ("nee_mis", "null_scattering")])
def test_grey_homogeneous_scene_agrees(pair):
    # No delta lights: phase sampling alone (multiple) must find all the light too.
    xml = S.scene(
        S.camera(res=16, spp=48),
        S.homogeneous("m", "2", "0.9", g=0.5),
        S.medium_sphere("m"),
        S.floor(),
        S.area_light_above(size=1.0, radiance="5, 5, 5"),
        S.constant_env("0.3, 0.3, 0.3"),
    )
    scene = volpath.load_string(xml)
    assert compare(scene, *pair) < Z_MAX


def test_shadow_ray_roulette_agrees():
    """Every shadow ray toward the light leaves an absorbing slab (transmittance e^-4)
    below kShadowRouletteT and goes on by Russian roulette; phase sampling alone
    (multiple) must find the same light through the slab."""
    slab = """<shape type="cube"><transform name="to_world"><scale x="2" y="0.1" z="2"/><translate y="1.5"/></transform>
        <bsdf type="null"/><ref name="interior" id="ink"/></shape>"""
    xml = S.scene(
        S.camera(res=16, spp=256),
        S.homogeneous("m", "0.5", "0.9"),
        S.homogeneous("ink", "20", "0"),
        S.medium_sphere("m"),
        slab,
        S.area_light_above(y=2.5, size=1.5, radiance="60, 60, 60"),
    )
    scene = volpath.load_string(xml)
    assert compare(scene, "multiple", "nee_mis") < Z_MAX


def test_chromatic_homogeneous_agrees_with_grid_of_same_density(tmp_path):
    """Null scattering through a constant grid equals closed-form tracking of the same
    homogeneous medium: tests delta tracking, ratio tracking and the spectral MIS."""
    from volpath.grids import write_vol

    sigma_t, albedo = (3.0, 1.0, 0.4), (0.9, 0.5, 0.99)
    write_vol(tmp_path / "c.vol", np.tile(np.array(sigma_t, np.float32), (4, 4, 4, 1)))
    common = [
        S.camera(res=16, spp=32),
        S.floor(),
        S.area_light_above(size=1.0, radiance="5, 5, 5"),
        S.point_light("1.5, 1.5, 2", "4, 4, 4"),
    ]
    homog = volpath.load_string(
        S.scene(
            *common,
            S.homogeneous("m", ", ".join(map(str, sigma_t)), ", ".join(map(str, albedo)), g=0.3),
            S.medium_cube("m", 0.8),
        )
    )
    grid = volpath.load_string(
        S.scene(
            *common,
            f"""
        <medium type="heterogeneous" id="m">
            <volume type="gridvolume" name="sigma_t"><string name="filename" value="c.vol"/>
                <transform name="to_world"><translate value="-0.5"/><scale value="1.6"/></transform></volume>
            <rgb name="albedo" value="{", ".join(map(str, albedo))}"/>
            <phase type="hg"><float name="g" value="0.3"/></phase>
        </medium>""",
            S.medium_cube("m", 0.8),
        ),
        base_dir=str(tmp_path),
    )
    a = render_batches(volpath.render, homog, 6, block=4, tracer="nee_mis")
    b = render_batches(volpath.render, grid, 6, block=4, tracer="null_scattering")
    assert max_z(a[0], a[1], b[0], b[1]) < Z_MAX


def _lit_grid(tmp_path, grid, majorant_res, g=0.3, extra=""):
    """A grid medium in a cube over a floor, under an area light, a sky and a sun."""
    return volpath.load_string(
        S.scene(
            S.camera(res=16, spp=32),
            S.floor(),
            S.area_light_above(size=1.0, radiance="5, 5, 5"),
            S.constant_env("0.3, 0.3, 0.4"),
            SUN,
            f"""
        <medium type="heterogeneous" id="m">
            <volume type="gridvolume" name="sigma_t"><string name="filename" value="{grid}"/>
                <transform name="to_world"><translate value="-0.5"/><scale value="1.6"/></transform></volume>
            <rgb name="albedo" value="0.9, 0.6, 0.95"/>{extra}
            <integer name="majorant_resolution" value="{majorant_res}"/>
            <phase type="hg"><float name="g" value="{g}"/></phase>
        </medium>""",
            S.medium_cube("m", 0.8),
        ),
        base_dir=str(tmp_path),
    )


def test_delta_tracking_agrees_whatever_the_majorant(tmp_path):
    """Real-or-null choices along a segment share one remapped uniform (ChoiceChain): under
    one global majorant, set by a single hot voxel, each real collision follows a run of
    about ten null ones at varying probabilities, against a few under local majorants. A
    wrong remap biases the long runs (one that keeps u unchanged makes the cube's centre
    6 % brighter under the global majorant: z = 20). The sun's shadow rays take residual
    ratio tracking against the local minorants, and plain ratio tracking under the global
    bounds (an empty corner voxel makes the global minorant 0)."""
    from volpath.grids import write_vol

    rng = np.random.default_rng(3)
    data = rng.uniform(0.5, 3.0, (6, 6, 6, 3)).astype(np.float32)
    data[1, 4, 2] = (40.0, 30.0, 35.0)
    data[0, 0, 0] = 0.0
    write_vol(tmp_path / "g.vol", data)

    def scene(majorant_res):
        return _lit_grid(tmp_path, "g.vol", majorant_res)

    a = render_batches(volpath.render, scene(1), 6, block=4, tracer="null_scattering")
    b = render_batches(volpath.render, scene(12), 6, block=4, tracer="null_scattering")
    assert max_z(a[0], a[1], b[0], b[1]) < Z_MAX


def test_forced_collisions_nee_agrees_with_delta_tracking(tmp_path):
    """The camera's forced branches in a grid of grey density take NEE at each tentative
    collision whatever the real-or-null choice (weighted by sigma_s / sigma_maj); a density
    that is not quite grey (the third channel 1e-7 denser) keeps the NEE with the choice. Same medium, same image:
    emission, an absorbing albedo, a sun, an area light and a sky behind, under one global
    majorant (most collisions null) and under local ones."""
    from volpath.grids import write_vol

    rng = np.random.default_rng(5)
    density = rng.uniform(0.0, 3.0, (6, 6, 6)).astype(np.float32)
    density[2, 3, 1] = 20.0
    write_vol(tmp_path / "grey.vol", density[..., None])
    write_vol(tmp_path / "rgb.vol", np.stack([density, density, density * np.float32(1 + 1e-7)], axis=-1))

    def scene(grid, majorant_res):
        return _lit_grid(
            tmp_path, grid, majorant_res, 0.5, '\n            <rgb name="radiance" value="0.5, 0.2, 0.1"/>'
        )

    for majorant_res in (1, 0):
        a = render_batches(volpath.render, scene("grey.vol", majorant_res), 6, block=4, tracer="null_scattering")
        b = render_batches(volpath.render, scene("rgb.vol", majorant_res), 6, block=4, tracer="null_scattering")
        assert max_z(a[0], a[1], b[0], b[1]) < Z_MAX, majorant_res


def test_dielectric_sphere_with_medium_inside():
    """Refraction into a medium: nee_mis and multiple agree through a specular interface."""
    xml = S.scene(
        S.camera(res=16, spp=64),
        S.homogeneous("m", "1", "0.9"),
        """<shape type="sphere"><float name="radius" value="1"/>
                     <bsdf type="dielectric"><float name="int_ior" value="1.33"/></bsdf>
                     <ref name="interior" id="m"/></shape>""",
        S.floor(),
        S.area_light_above(size=1.5, radiance="3, 3, 3"),
        S.constant_env("0.5, 0.5, 0.5"),
    )
    scene = volpath.load_string(xml)
    assert compare(scene, "multiple", "nee_mis", max_depth=12) < Z_MAX


def test_heterogeneous_media_need_null_scattering(tmp_path):
    from volpath.grids import write_vol

    write_vol(tmp_path / "g.vol", np.ones((2, 2, 2)))
    xml = S.scene(
        S.camera(res=8, spp=4),
        """<medium type="heterogeneous" id="m">
        <volume type="gridvolume" name="sigma_t"><string name="filename" value="g.vol"/></volume></medium>""",
        S.medium_cube("m"),
        S.constant_env(),
    )
    scene = volpath.load_string(xml, base_dir=str(tmp_path))
    with pytest.raises(ValueError, match="null_scattering"):
        volpath.render(scene, tracer="nee_mis")
    assert np.isfinite(volpath.render(scene, tracer="null_scattering")).all()


def test_camera_inside_a_scattering_medium_agrees():
    """The split camera segment with MIS (nee_mis) against phase sampling alone."""
    xml = S.scene(
        S.camera(res=16, spp=64, origin="0, 0, 2.5", medium="fog"),
        S.homogeneous("fog", "0.3, 0.5, 0.8", "0.9", g=0.4),
        S.medium_sphere("fog", radius=4),
        S.floor(),
        S.area_light_above(size=1.0, radiance="5, 5, 5"),
    )
    scene = volpath.load_string(xml)
    assert compare(scene, "multiple", "nee_mis") < Z_MAX


def _light_distances(on):
    return lambda scene, **kwargs: volpath.render(scene, light_distances=on, **kwargs)


SUN = '<emitter type="directional"><vector name="direction" value="-0.3, -1, -0.4"/><rgb name="irradiance" value="2, 2, 2"/></emitter>'

# A chromatic medium lit by two point lights, a directional light, an area light and an
# environment (which has no distance strategy: NEE chooses among more lights than the
# distances do), the camera outside or inside the medium.
# The point lights stay out of the medium: next to a point light in a medium, free flight's
# NEE has infinite variance (1/r^2 at collisions near it), and even equiangular sampling's
# diverges (1/D for paths passing at distance D), which would void the z-tests' errors.
LIGHT_DISTANCE_SCENES = {
    "camera_outside": lambda: S.scene(
        S.camera(res=16, spp=16),
        S.homogeneous("m", "1.5, 1, 0.5", "0.8, 0.6, 0.9", g=0.4),
        S.medium_sphere("m", 1.2),
        S.floor(),
        S.point_light("1.3, -0.5, 0.8", "2, 1.5, 1"),
        S.point_light(),
        SUN,
        S.area_light_above(size=1.0, radiance="5, 5, 5"),
        S.constant_env("0.2, 0.2, 0.3"),
        max_depth=6,
    ),
    "camera_inside": lambda: S.scene(
        S.camera(res=16, spp=16, medium="m", origin="0, 0, 2.5"),
        S.homogeneous("m", "0.6, 0.4, 0.2", "0.9, 0.8, 0.7", g=0.6),
        S.medium_cube("m", 3),
        S.floor(),
        S.point_light("4, 4, 0", "20, 15, 10"),
        S.point_light("-4, 1, 1", "10, 10, 10"),
        SUN,
        S.area_light_above(y=2.5, size=1.0, radiance="5, 5, 5"),
        max_depth=6,
    ),
}


@pytest.mark.parametrize(
    "case, tracer",
    [
        ("camera_outside", "single"),
        ("camera_outside", "nee_mis"),
        ("camera_inside", "single"),
        ("camera_inside", "nee_mis"),
    ],
)
def test_light_distances_and_free_flight_agree(case, tracer):
    """Light estimated from distances drawn for the lights (LightDistances; NEE at free
    flight's collisions toward the environment alone) equals NEE at every collision."""
    scene = volpath.load_string(LIGHT_DISTANCE_SCENES[case]())
    a = render_batches(_light_distances(True), scene, 8, block=4, tracer=tracer)
    b = render_batches(_light_distances(False), scene, 8, block=4, tracer=tracer)
    assert max_z(a[0], a[1], b[0], b[1]) < Z_MAX


def test_light_distances_leave_an_environment_map_to_collisions(tmp_path):
    """Under MIS a textured environment is a light NEE chooses, but it has no distances:
    with light distances on, free flight's collisions take NEE toward it alone (chosen with
    probability 1 there, against 1/2 where the sun is chosen too), and its light found by
    phase sampling is weighed against that. The image equals the one with NEE at every
    collision among both lights. Weighing the phase-sampled light with the choice of 1/2
    shifts the image by 3 % (z about 7: measured by mutation)."""
    rng = np.random.default_rng(5)
    sky = (rng.uniform(0.2, 1, (8, 16, 3)) ** 2).astype(np.float32)
    sky[1:3, 4:7] = 20  # a bright patch
    volpath.write_exr(tmp_path / "sky.exr", sky)
    envmap = '<emitter type="envmap"><string name="filename" value="sky.exr"/></emitter>'
    scene = volpath.load_string(
        S.scene(
            S.camera(res=16, spp=128),
            S.homogeneous("m", "1.5, 1.2, 1.0", "0.95, 0.9, 0.85", g=0.3),
            S.medium_sphere("m", 1.2),
            SUN,
            envmap,
            max_depth=5,
        ),
        base_dir=str(tmp_path),
    )
    on = render_batches(_light_distances(True), scene, 8, block=8, tracer="nee_mis")
    off = render_batches(_light_distances(False), scene, 8, block=8, tracer="nee_mis")
    assert max_z(on[0], on[1], off[0], off[1]) < Z_MAX


def test_light_distances_weigh_emitters_found_by_phase_sampling():
    """Thin chromatic smoke next to a large area light, under an environment, to depth 3:
    phase sampling often hits the light, so its MIS weight must count the light's distance
    strategy too (leaving that term out, or the phase strategy's density at a distance
    drawn for the light, shifts the image by 20-40 standard errors). Compared with light
    distances off and with phase sampling alone (the multiple tracer)."""
    scene = volpath.load_string(
        S.scene(
            S.camera(res=16, spp=16),
            S.homogeneous("m", "0.6, 0.4, 0.25", "0.95"),
            S.medium_sphere("m", 1.3),
            S.area_light_above(y=1.6, size=1.5, radiance="2, 2, 2"),
            S.constant_env("0.5, 0.5, 0.5"),
            max_depth=3,
        )
    )
    on = render_batches(_light_distances(True), scene, 8, block=4, tracer="nee_mis")
    off = render_batches(_light_distances(False), scene, 8, block=4, tracer="nee_mis")
    phase = render_batches(volpath.render, scene, 8, block=4, tracer="multiple")
    assert max_z(on[0], on[1], off[0], off[1]) < Z_MAX
    assert max_z(on[0], on[1], phase[0], phase[1]) < Z_MAX


@pytest.mark.parametrize("tracer", ["nee_mis", "null_scattering"])
def test_constant_sky_is_left_to_phase_sampling(tracer):
    """Under MIS, NEE never chooses a constant environment (Scene::mis_nee_lights): phase
    sampling finds the sky alone, and NEE chooses the sun with probability 1. In chromatic
    smoke under a sun and a sky (bench scene (d)'s lights), the image equals the sun alone
    plus the sky alone rendered by the multiple tracer, which has no NEE at all. A wrong
    selection pdf doubles the sun; an MIS weight that still counted NEE for the sky halves
    the sky's light found by phase sampling: both far beyond the threshold."""

    def smoke(*lights):
        return volpath.load_string(
            S.scene(
                S.camera(res=16, spp=16),
                S.floor(),
                S.homogeneous("m", "2, 1.5, 1", "0.9, 0.7, 0.5"),
                S.medium_cube("m", 0.8),
                *lights,
                max_depth=8,
            )
        )

    sky = S.constant_env("0.3, 0.4, 0.6")
    both = render_batches(volpath.render, smoke(SUN, sky), 8, block=4, tracer=tracer)
    sun = render_batches(volpath.render, smoke(SUN), 8, block=4, tracer=tracer)
    sky_alone = render_batches(volpath.render, smoke(sky), 8, block=4, tracer="multiple")
    assert max_z(both[0], both[1], sun[0] + sky_alone[0], np.hypot(sun[1], sky_alone[1])) < Z_MAX


SUN_DISC = """<emitter type="sun"><vector name="direction" value="-0.3, -1, -0.4"/>
    <float name="angular_radius" value="0.05"/><rgb name="irradiance" value="2, 2, 2"/></emitter>"""


@pytest.mark.parametrize(
    "light, sigma_t, least",
    [
        (S.point_light("0, 1.6, 0", "4, 4, 4"), "1", 2),
        (S.area_light_above(y=1.6, size=0.1, radiance="400, 400, 400"), "1", 2),
        (SUN, "0.2", 4),
        (SUN_DISC, "0.2", 4),
    ],
)
def test_light_distances_reduce_noise(light, sigma_t, least):
    """A sphere of smoke lit by a point light or a small area light above it, or thin smoke
    in the sun (directional, or a disc), single scattering: at equal spp the per-pixel
    standard deviation between renders is lower with distances drawn for the light, by at
    least 2x for the point and area lights (measured 6.6x and 5.1x at 8 spp) and 4x in the
    sun (measured 22x for both: free flight collides in the thin smoke only one time in
    three). The camera does not see the lights."""
    scene = volpath.load_string(
        S.scene(
            S.camera(res=16, spp=8, fov=28),
            S.homogeneous("m", sigma_t, "0.8"),
            S.medium_sphere("m"),
            light,
            max_depth=2,
        )
    )
    variance = {}
    for on in (True, False):
        images = [_light_distances(on)(scene, seed=100 + i) for i in range(6)]
        variance[on] = np.mean(np.var(images, axis=0, ddof=1))
    assert np.sqrt(variance[False] / variance[True]) > least
