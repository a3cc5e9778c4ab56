"""The exporter: what a Blender scene becomes, and that both ways of rendering it agree."""

import json
import math
import os

import numpy as np
import pytest
from blender_scenes import add_camera, bpy, depsgraph, material, render_f12, set_background, small_scene

import volpath
from addon.export import ExportError, convert, export_scene, write_directory
from addon.export.animation import export_animation
from addon.export.convert import BLENDER_TO_SCENE
from volpath.adaptive import SLACK
from volpath.testing import MIN_BATCHES, max_z, render_batches
from volpath.xml_reader import read_xml


def test_round_trip_camera_lights_meshes(blank, tmp_path):
    small_scene(blank)
    plane = bpy.data.objects["Plane"]
    plane.location = (1.0, 2.0, 0.5)
    plane.rotation_euler = (0, 0, math.pi / 2)
    ex = export_scene(depsgraph())
    d = ex.scene
    meshes = {k: v for k, v in d.items() if isinstance(v, dict) and v.get("type") == "mesh"}
    # Plane, Sphere, Cube and the area light's quad
    assert set(meshes) == {"Plane", "Sphere", "Cube", "Area"}
    assert len(meshes["Sphere"]["indices"]) == 960 and "normals" in meshes["Sphere"]  # smooth
    assert "normals" not in meshes["Plane"]  # flat
    assert meshes["Cube"]["bsdf"]["type"] == "null" and meshes["Cube"]["interior"]["type"] == "homogeneous"
    # A known vertex: the plane's corner (5, 5, 0) after rotation by 90 degrees about z and the
    # move, then Blender's z-up -> the scene's y-up.
    m = meshes["Plane"]
    p = m["to_world"] @ np.append(m["positions"][np.argmax(m["positions"].sum(axis=1))], 1.0)
    assert np.allclose(p[:3], [1 - 5, 0.5, -(2 + 5)], atol=1e-5)
    cam = d["camera"]
    obj = bpy.data.objects["Camera"]
    assert np.allclose(cam["to_world"][:3, 3], BLENDER_TO_SCENE[:3, :3] @ np.array(obj.location))
    # The camera looks along its local +z (Mitsuba) = Blender's -z.
    forward = BLENDER_TO_SCENE[:3, :3] @ (np.array(obj.matrix_world.to_3x3()) @ [0, 0, -1])
    assert np.allclose(cam["to_world"][:3, 2], forward)
    assert cam["fov"] == pytest.approx(math.degrees(2 * math.atan(36 / 100)))
    assert cam["film"]["width"] == 48 and cam["film"]["height"] == 32
    sun = d["Sun"]
    assert sun["type"] == "sun" and sun["irradiance"]["value"] == pytest.approx([3, 3, 3])
    area = d["Area"]
    size = bpy.data.objects["Area"].data.size
    assert size > 0
    # P / (pi A): 200 W on a square of side `size`
    assert area["emitter"]["radiance"]["value"] == pytest.approx([200 / (math.pi * size**2)] * 3, rel=1e-6)
    assert d["world"]["radiance"]["value"] == pytest.approx([0.1, 0.2, 0.4])
    # The written directory loads and describes the same scene.
    scene = volpath.load_file(write_directory(ex, tmp_path / "scene"))
    assert scene.summary["camera"]["width"] == 48
    assert sorted(s["type"] for s in scene.summary["shapes"]) == ["ply"] * 4


def test_f12_equals_rendering_the_exported_directory(blank, tmp_path):
    small_scene(blank)
    blank.volpath.seed = 7
    blank.volpath.tracer = "nee_mis"
    f12 = render_f12(blank, tmp_path / "f12.exr")
    path = write_directory(export_scene(depsgraph()), tmp_path / "scene")
    cli = volpath.render(volpath.load_file(path), seed=7, tracer="nee_mis", threads=1)
    assert f12.shape == cli.shape == (32, 48, 3)
    assert np.array_equal(f12, cli)  # same seed, same bits, whatever the thread count
    assert cli.mean() > 0.05


def test_an_hdri_world_is_an_environment_map_written_losslessly(blank, tmp_path):
    """An Environment Texture (a .hdr file turned by a Mapping node) exports as an envmap of
    the image's linear pixels, written to the directory as an EXR: F12 and the directory
    render alike, bit for bit. (Its orientation against Cycles: test_parity.py's
    "environment texture".)"""
    from parity_scenes import environment_texture

    environment_texture(blank, tmp_path)
    blank.volpath.seed, blank.volpath.tracer = 5, "nee_mis"
    world = export_scene(depsgraph()).scene["world"]
    assert world["type"] == "envmap" and world["data"].shape == (32, 64, 3) and world["scale"] == pytest.approx(1.2)
    image = bpy.data.images["sky.hdr"]
    pixels = np.empty(64 * 32 * 4, np.float32)
    image.pixels.foreach_get(pixels)
    assert np.array_equal(world["data"], pixels.reshape(32, 64, 4)[::-1, :, :3])  # linear, rows top first
    f12 = render_f12(blank, tmp_path / "f12.exr")
    cli = volpath.render(volpath.load_file(write_directory(export_scene(depsgraph()), tmp_path / "scene")), seed=5)
    assert np.array_equal(f12, cli)
    # A non-uniform Scale would bend the map's solid angles (its importance sampling assumes
    # a rotation): reported, and the rotation alone kept.
    blank.world.node_tree.nodes["Mapping"].inputs["Scale"].default_value = (1, 2, 1)
    ex = export_scene(depsgraph())
    assert any("non-uniform Scale" in w for w in ex.warnings)
    m = ex.scene["world"]["to_world"][:3, :3]
    np.testing.assert_allclose(m @ m.T, np.eye(3), atol=1e-12)


def test_f12_noise_threshold_renders_to_the_target_error(blank, tmp_path):
    small_scene(blank)
    blank.volpath.seed, blank.volpath.tracer, blank.volpath.spp = 3, "nee_mis", 256
    blank.volpath.use_adaptive_sampling, blank.volpath.adaptive_threshold = True, 0.02
    f12 = render_f12(blank, tmp_path / "f12.exr")
    scene = volpath.load_file(write_directory(export_scene(depsgraph()), tmp_path / "scene"))
    cli = volpath.render(scene, seed=3, tracer="nee_mis", spp=256, target_error=0.02, threads=1)
    assert np.array_equal(f12, cli)
    assert scene.last_render["error"] <= 0.02 * SLACK and scene.last_render["spp_min"] < 256


def test_linked_duplicates_are_instances_and_modifiers_apply(blank, tmp_path):
    bpy.ops.mesh.primitive_cube_add(size=2)
    bpy.ops.object.duplicate_move_linked(TRANSFORM_OT_translate={"value": (3, 0, 0)})
    bpy.ops.mesh.primitive_cube_add(size=2, location=(0, 4, 0))
    bpy.context.object.modifiers.new("sub", "SUBSURF").levels = 1
    add_camera(blank)
    ex = export_scene(depsgraph())
    d = ex.scene
    a, b, smooth = d["Cube"], d["Cube.001"], d["Cube.002"]
    assert a["type"] == b["type"] == "instance" and a["group"] == b["group"] == {"type": "ref", "id": "Cube.group"}
    (member,) = [v for v in d["Cube.group"].values() if isinstance(v, dict)]
    assert len(member["indices"]) == 12 and "to_world" not in member  # once, in object space
    assert np.allclose(b["to_world"][:3, 3] - a["to_world"][:3, 3], [3, 0, 0])
    assert smooth["type"] == "mesh" and len(smooth["indices"]) == 6 * 4 * 2  # subdivided once
    # The written directory keeps them instances.
    assert volpath.load_file(write_directory(ex, tmp_path / "scene")).summary["instances"] == 2


def test_instances_reach_the_pipeline_and_the_viewport(blank, tmp_path):
    """Linked duplicates stay instances in export_animation's directory, which a pipeline
    worker renders (pipeline.frames.render_frame), and in the viewport's exports, whose mesh
    cache hands the second export the same arrays."""
    from blender_scenes import tiny_animation

    from pipeline.frames import render_frame

    tiny_animation(frames=2)
    for obj in bpy.context.scene.objects:
        obj.select_set(obj.name == "Cube")
    bpy.context.view_layer.objects.active = bpy.data.objects["Cube"]
    bpy.ops.object.duplicate_move_linked(TRANSFORM_OT_translate={"value": (3, 0, 0)})
    export_animation(bpy.context.scene, [1, 2], tmp_path / "anim")
    xml = (tmp_path / "anim" / "scene.xml").read_text()
    assert xml.count('type="shapegroup"') == 1 and xml.count('type="instance"') == 2
    image, _ = render_frame(str(tmp_path / "anim"), 2, 4)
    assert np.all(np.isfinite(image)) and image.mean() > 0
    cache = {}
    first, second = (export_scene(depsgraph(), cache).scene for _ in range(2))
    members = [[v for v in d["Cube.group"].values() if isinstance(v, dict)] for d in (first, second)]
    assert members[0][0]["positions"] is members[1][0]["positions"]


def scatter_nodes():
    """A geometry-nodes tree that puts a cylinder on each of a 4 x 4 grid's points."""
    tree = bpy.data.node_groups.new("Scatter", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    grid, cylinder = tree.nodes.new("GeometryNodeMeshGrid"), tree.nodes.new("GeometryNodeMeshCylinder")
    grid.inputs["Vertices X"].default_value = grid.inputs["Vertices Y"].default_value = 4
    cylinder.inputs["Radius"].default_value, cylinder.inputs["Depth"].default_value = 0.1, 0.3
    on_points = tree.nodes.new("GeometryNodeInstanceOnPoints")
    tree.links.new(grid.outputs["Mesh"], on_points.inputs["Points"])
    tree.links.new(cylinder.outputs["Mesh"], on_points.inputs["Instance"])
    tree.links.new(on_points.outputs["Instances"], tree.nodes.new("NodeGroupOutput").inputs[0])
    return tree


def flattened(d):
    """The scene with every instance replaced by its group's meshes, placed."""
    out = {}
    for k, v in d.items():
        if isinstance(v, dict) and v.get("type") == "instance":
            group = d[v["group"]["id"]]
            for name, m in group.items():
                if isinstance(m, dict):
                    out[f"{k}.{name}"] = dict(m, to_world=v["to_world"])
        elif not (isinstance(v, dict) and v.get("type") == "shapegroup"):
            out[k] = v
    return out


def test_collection_particle_and_geometry_node_instances_are_instances(blank):
    """Each kind of Blender instance exports as instances of one shapegroup per mesh, and
    renders as its flattened copy does: 4x4-pixel block means within 4.5 standard errors
    (of 48 blocks, a false alarm has probability ~3e-4)."""
    add_camera(blank, location=(0, -12, 6), rotation=(1.1, 0, 0))
    set_background(blank, (1.0, 1.0, 1.0))
    bpy.ops.mesh.primitive_plane_add(size=30)
    bpy.ops.mesh.primitive_cone_add(radius1=0.5, depth=1.5)
    cone = bpy.context.object
    tree = bpy.data.collections.new("Tree")  # not in the scene: seen through its instances only
    for c in list(cone.users_collection):
        c.objects.unlink(cone)
    tree.objects.link(cone)
    for i in range(3):
        empty = bpy.data.objects.new(f"Tree.{i}", None)
        empty.instance_type, empty.instance_collection = "COLLECTION", tree
        empty.location, empty.rotation_euler, empty.scale = (3 * i - 3, 2, 0.75), (0.3 * i, 0, 0), (1, 1, 1 + i)
        blank.collection.objects.link(empty)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1)
    pebble = bpy.context.object
    for c in list(pebble.users_collection):
        c.objects.unlink(pebble)
    bpy.ops.mesh.primitive_plane_add(size=4, location=(-3, -2, 0))
    bpy.context.object.modifiers.new("hair", "PARTICLE_SYSTEM")
    hair = bpy.context.object.particle_systems[0].settings
    hair.type, hair.count, hair.render_type, hair.instance_object, hair.particle_size = (
        "HAIR",
        20,
        "OBJECT",
        pebble,
        0.3,
    )
    bpy.ops.mesh.primitive_plane_add(size=3, location=(3, -2, 0.2))
    bpy.context.object.modifiers.new("scatter", "NODES").node_group = scatter_nodes()
    blank.render.resolution_x, blank.render.resolution_y = 32, 24
    d = export_scene(depsgraph()).scene
    instances = [v["group"]["id"] for v in d.values() if isinstance(v, dict) and v.get("type") == "instance"]
    assert sorted(set(instances)) == ["Cone.group", "Icosphere.group", "Mesh.group"]
    assert [instances.count(g) for g in ("Cone.group", "Icosphere.group", "Mesh.group")] == [3, 20, 16]
    scene, flat = volpath.load_dict(d), volpath.load_dict(flattened(d))
    assert scene.summary["instances"] == 39 and flat.summary["instances"] == 0
    a = render_batches(volpath.render, scene, MIN_BATCHES, block=4, spp=8)
    b = render_batches(volpath.render, flat, MIN_BATCHES, block=4, spp=8)
    assert max_z(*a, *b) < 4.5


def test_materials_map_to_bsdfs_and_emitters(blank):
    add_camera(blank)
    specs = {
        "glass": dict(Transmission_Weight=1.0, IOR=1.33, Roughness=0.0),
        "frosted": dict(Transmission_Weight=1.0, IOR=1.33, Roughness=0.5),
        "metal": dict(Base_Color=(0.9, 0.6, 0.2, 1), Metallic=1.0, Roughness=0.2),
        "lamp": dict(Emission_Color=(1, 0.5, 0.25, 1), Emission_Strength=4.0),
        "plastic": dict(Base_Color=(0.2, 0.3, 0.4, 1)),
        "matte": dict(Base_Color=(0.2, 0.3, 0.4, 1), Specular_IOR_Level=0.0),
    }
    for i, (name, inputs) in enumerate(specs.items()):
        bpy.ops.mesh.primitive_cube_add(location=(3 * i, 0, 0))
        bpy.context.object.name = name
        bpy.context.object.data.materials.append(material(name, **inputs))
    d = export_scene(depsgraph()).scene
    glass = d["glass"]["bsdf"]
    assert glass["type"] == "dielectric" and glass["int_ior"] == pytest.approx(1.33)
    assert glass["specular_transmittance"]["value"] == pytest.approx([0.8**0.5] * 3)  # the base colour, per interface
    assert d["frosted"]["bsdf"]["type"] == "roughdielectric" and d["frosted"]["bsdf"]["alpha"] == pytest.approx(0.25)
    assert d["metal"]["bsdf"]["metallic"] == 1.0 and d["metal"]["bsdf"]["roughness"] == pytest.approx(0.2)
    assert d["lamp"]["emitter"]["radiance"]["value"] == pytest.approx([4, 2, 1])
    assert d["plastic"]["bsdf"]["eta"] == pytest.approx(1.5)  # IOR 1.5 at the default level 0.5
    assert d["matte"]["bsdf"] == {
        "type": "diffuse",
        "reflectance": {"type": "rgb", "value": pytest.approx([0.2, 0.3, 0.4])},
    }


def test_unsupported_features_warn_in_the_render_report(blank, tmp_path, capfd):
    small_scene(blank)
    m = bpy.data.materials["red"]
    noise = m.node_tree.nodes.new("ShaderNodeTexNoise")
    m.node_tree.links.new(noise.outputs["Color"], m.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    bpy.ops.object.light_add(type="SPOT", location=(0, 0, 3))
    spot = bpy.context.object.data
    spot.use_nodes = True
    emission = next(n for n in spot.node_tree.nodes if n.bl_idname == "ShaderNodeEmission")
    spot.node_tree.links.new(spot.node_tree.nodes.new("ShaderNodeTexNoise").outputs["Color"], emission.inputs["Color"])
    warnings = export_scene(depsgraph()).warnings
    assert any("'Noise Texture' drives Color; using the socket's value" in w for w in warnings)
    assert any("'Base Color'" in w and "driven by nodes" in w for w in warnings)
    render_f12(blank, tmp_path / "f12.exr")
    out = capfd.readouterr()
    assert "Warning: Volpath: light 'Spot': 'Noise Texture' drives Color" in out.out + out.err


def test_no_camera_is_an_error_in_the_report(blank, capfd):
    bpy.ops.mesh.primitive_cube_add()
    with pytest.raises(ExportError, match="no active camera"):
        export_scene(depsgraph())


@pytest.mark.parametrize("fit", ["AUTO", "HORIZONTAL", "VERTICAL"])
@pytest.mark.parametrize("size", [(40, 30), (30, 40)], ids=["landscape", "portrait"])
def test_camera_fit_and_shift(blank, fit, size):
    """A small glowing ball lands on the pixel where Blender's own projection puts it
    (bpy_extras' world_to_camera_view), whatever the sensor fit, the shift and the aspect."""
    from bpy_extras.object_utils import world_to_camera_view
    from mathutils import Vector

    cam = add_camera(blank, location=(0, 0, 0), rotation=(math.pi / 2, 0, 0))
    cam.data.sensor_fit, cam.data.sensor_width, cam.data.sensor_height = fit, 36, 20
    cam.data.lens, cam.data.shift_x, cam.data.shift_y = 30, 0.15, -0.1
    blank.render.resolution_x, blank.render.resolution_y = size
    blank.render.resolution_percentage = 100
    ball = Vector((0.9, 8.0, 0.6))
    u, v, _ = world_to_camera_view(blank, cam, ball)
    d = export_scene(depsgraph()).scene
    d["ball"] = {"type": "sphere", "center": convert.point(ball), "radius": 0.2, "emitter": {"type": "area"}}
    image = volpath.render(volpath.load_dict(d), spp=16).mean(axis=2)
    rows, cols = np.indices(image.shape) + 0.5
    x, y = (cols * image).sum() / image.sum(), (rows * image).sum() / image.sum()  # the ball's centre
    assert 0.1 < u < 0.9 and 0.1 < v < 0.9, (u, v)  # in the frame
    assert abs(x - u * size[0]) < 0.3 and abs(y - (1 - v) * size[1]) < 0.3, (x, y, u * size[0], (1 - v) * size[1])


def test_keyframed_sun_directions_match_frame_set(blank, tmp_path):
    add_camera(blank)
    bpy.ops.object.light_add(type="SUN")
    sun = bpy.context.object
    sun.rotation_euler = (math.radians(95), 0, math.radians(10))
    sun.keyframe_insert("rotation_euler", frame=1)
    sun.rotation_euler = (math.radians(60), 0, math.radians(30))
    sun.keyframe_insert("rotation_euler", frame=9)
    # A constraint counts too: the camera tracks an animated empty.
    bpy.ops.object.empty_add(location=(0, 0, 0))
    target = bpy.context.object
    target.keyframe_insert("location", frame=1)
    target.location = (5, 5, 2)
    target.keyframe_insert("location", frame=9)
    track = blank.camera.constraints.new("TRACK_TO")
    track.target = target
    frames = list(range(1, 10))
    export_animation(blank, frames, str(tmp_path))
    anim = json.loads((tmp_path / "animation.json").read_text())["frames"]
    assert [a["frame"] for a in anim] == frames
    directions = []
    for a in anim:
        blank.frame_set(a["frame"])
        expected = np.array(sun.matrix_world.to_3x3()) @ [0, 0, -1]
        assert np.allclose(a["suns"]["Sun"], BLENDER_TO_SCENE[:3, :3] @ expected, atol=1e-6)
        cam = np.array(blank.camera.matrix_world)
        assert np.allclose(np.array(a["camera"])[:3, 3], BLENDER_TO_SCENE[:3, :3] @ cam[:3, 3], atol=1e-6)
        directions.append(a["suns"]["Sun"])
    assert not np.allclose(directions[0], directions[-1])  # it really moved
    cams = [np.array(a["camera"])[:3, 2] for a in anim]
    assert not np.allclose(cams[0], cams[-1])  # the constraint turned the camera


def test_sky_texture_becomes_the_atmosphere(blank):
    add_camera(blank, location=(0, 0, 2), rotation=(math.radians(90), 0, 0))
    world = set_background(blank, (0, 0, 0))
    tree = world.node_tree
    sky = tree.nodes.new("ShaderNodeTexSky")
    sky.air_density, sky.aerosol_density, sky.altitude = 2.0, 0.5, 0.0
    tree.links.new(sky.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    bpy.ops.object.light_add(type="SUN", rotation=(math.radians(30), 0, 0))  # 60 degrees up
    d = export_scene(depsgraph()).scene
    air = d["air"]
    from volpath.plugins.media import ATMOSPHERE_PRESETS

    preset = ATMOSPHERE_PRESETS["bruneton"]
    assert air["type"] == "atmosphere"
    assert air["rayleigh_scattering"]["value"] == pytest.approx(2 * np.array(preset["rayleigh_scattering"]))
    assert air["mie_scattering"] == pytest.approx(0.5 * preset["mie_scattering"])
    assert d["camera"]["far_clip"] >= 1e9
    scene = volpath.load_dict(d)
    img = volpath.render(scene, spp=2, seed=1)
    assert np.all(np.isfinite(img))
    # Daylight sky: blue above the horizon.
    assert img[:8].mean(axis=(0, 1))[2] > img[:8].mean(axis=(0, 1))[0]
    # The panel's Colour setting: spectral passes, a sky still blue above the horizon.
    blank.volpath.atmosphere_mode = "spectral"
    d = export_scene(depsgraph()).scene
    scene = volpath.load_dict(d)
    assert d["air"]["mode"] == "spectral" and len(scene.passes) == 4
    img = volpath.render(scene, spp=2, seed=1)
    assert np.all(np.isfinite(img)) and img[:8].mean(axis=(0, 1))[2] > img[:8].mean(axis=(0, 1))[0]
    # The panel's Free Flight setting reaches the scene (guided by default).
    assert d["air"]["free_flight"] == "guided"
    blank.volpath.atmosphere_free_flight = "tracking"
    assert export_scene(depsgraph()).scene["air"]["free_flight"] == "tracking"


def test_animation_render_writes_every_frame(blank, tmp_path):
    from blender_scenes import tiny_animation

    tiny_animation(frames=2)
    scene = bpy.context.scene
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.filepath = str(tmp_path / "anim_")
    bpy.ops.render.render(animation=True)
    first, second = (volpath.read_exr(tmp_path / f"anim_{f:04d}.exr") for f in (1, 2))
    assert first.mean() > 0 and not np.array_equal(first, second)  # the sun moved


@pytest.mark.parametrize("visible_camera", [False, True])
def test_area_lights_are_not_geometry(blank, visible_camera):
    """An area light between the sun and the floor casts no shadow, as in Cycles (its quad
    lets every ray through); the camera, looking up through it at a grey world, sees the
    light's emission only if its visible_camera says so."""
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.context.object.data.materials.append(material("floor", Base_Color=(0.8, 0.8, 0.8, 1)))
    bpy.ops.object.light_add(type="SUN")
    bpy.context.object.data.energy, bpy.context.object.data.angle = 3, 0
    add_camera(blank, location=(0, 0, 6), rotation=(0, 0, 0))
    set_background(blank, (0.2, 0.2, 0.2))

    def floor_image():
        return volpath.render(volpath.load_dict(export_scene(depsgraph()).scene), spp=4, seed=1, threads=1)

    unlit = floor_image()
    bpy.ops.object.light_add(type="AREA", location=(0, 0, 2))
    light = bpy.context.object
    light.data.size, light.data.energy = 3, 1e-6  # fills the view, adds nothing
    light.visible_camera = visible_camera
    entry = export_scene(depsgraph()).scene["Area"]
    assert entry["bsdf"] == {"type": "null"} and ("hidden_from" not in entry) is visible_camera
    # Black where it cast a shadow; NEE now chooses between the sun and it by their
    # importance, so pixels differ by the noise of that choice, not the mean.
    lit = floor_image()
    assert lit.min() > 0.7 * unlit.min() and lit.mean() == pytest.approx(unlit.mean(), rel=0.02)
    # From below, looking up at its face: the world behind it, plus its radiance if the
    # camera sees it (the ray goes on through the light, as Cycles' does).
    light.data.energy = 100
    blank.camera.location, blank.camera.rotation_euler = (0, 0, 0.5), (math.pi, 0, 0)
    up = floor_image()[12:20, 20:28].mean()
    radiance = 100 / (math.pi * 9)
    assert up == pytest.approx(0.2 + (radiance if visible_camera else 0), rel=1e-3)


def test_an_area_lights_spread_is_exported_in_degrees(blank):
    """Blender's Spread becomes the emitter's `spread` (none at 180 degrees); a spread of 0,
    a beam no path could reach, is rendered at the narrowest, with a note. How it renders
    beside Cycles: the "area light spread" parity scene."""
    add_camera(blank)
    bpy.ops.object.light_add(type="AREA")
    light = bpy.context.object.data

    def exported():
        result = export_scene(depsgraph())
        return result.scene["Area"]["emitter"].get("spread"), result.notes

    assert exported() == (None, [])
    light.spread = math.radians(60)
    assert exported()[0] == pytest.approx(60, rel=1e-5)
    light.spread = 0
    spread, notes = exported()
    assert spread == 0.5 and any("spread of 0 degrees is rendered as 0.5" in n for n in notes), notes


def test_ray_visibility_is_followed_for_meshes_and_for_lights_but_surface_kinds(blank):
    add_camera(blank)
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.object
    cube.visible_camera = cube.visible_shadow = cube.visible_diffuse = False
    bpy.ops.object.light_add(type="AREA")
    bpy.context.object.visible_glossy = False
    bpy.ops.object.light_add(type="POINT")
    bpy.context.object.visible_volume_scatter = bpy.context.object.visible_shadow = False
    bpy.context.object.data.use_shadow = False  # Cast Shadow: the object's Shadow flag is not it
    exported = export_scene(depsgraph())
    assert exported.scene["Cube"]["hidden_from"] == "camera, diffuse, shadow"
    assert exported.scene["Point"]["hidden_from"] == "scatter, shadow"
    assert exported.scene["Area"]["emitter"]["hidden_from"] == "glossy"
    assert not any("'Cube'" in w or "'Point'" in w or "'Area'" in w for w in exported.warnings), exported.warnings
    volpath.load_dict(exported.scene)  # the loader takes a light's lobe, scatter and shadow visibility


def keyframed(owner, attribute, first, last):
    """`owner.attribute` keyframed from `first` at frame 1 to `last` at frame 5."""
    for frame, value in ((1, first), (5, last)):
        setattr(owner, attribute, value)
        owner.keyframe_insert(attribute, frame=frame)


def bulging_plane(height):
    """A plane at (0, 3, 0.5) whose shape key, keyframed from 0 at frame 1 to 1 at frame 5,
    lifts a corner by `height`."""
    bpy.ops.mesh.primitive_plane_add(location=(0, 3, 0.5))
    bulge = bpy.context.object
    bulge.shape_key_add(name="Basis")
    key = bulge.shape_key_add(name="Bulge")
    key.data[0].co.z = height
    keyframed(key, "value", 0.0, 1.0)


def pipeline_frames_as_f12(scene, anim, frames, tmp_path):
    """Asserts that each pipeline frame of the exported animation `anim` is the bits of the
    scene exported afresh at that frame (what F12 renders; with the objects the animation
    instances because they move or deform as instances too: F12 places a mesh used once in
    the world, which changes rounding, not the image, tests/python/test_instances.py), and
    that the worker moved to each frame after the first in place. Returns the frames' means."""
    from pipeline.frames import render_frame

    instanced = json.loads((anim / "animation.json").read_text())["instanced"]
    means = []
    for f in frames:
        image, meta = render_frame(str(anim), f, 4, threads=1)
        scene.frame_set(f)
        fresh = write_directory(export_scene(depsgraph(), instanced=instanced), tmp_path / f"f{f}")
        expected = volpath.render(volpath.load_file(fresh), spp=4, seed=f, threads=2)
        assert np.array_equal(image, expected), f"frame {f}"
        assert meta["scene_built"] == (f == frames[0]), f"frame {f}"
        means.append(image.mean())
    return means


def test_every_animation_reaches_the_video_as_f12_renders_it(blank, tmp_path):
    """Issue #57's user: a cube keyframed across the floor, a point lamp from 300 W to 1500 W
    and a material from red to green; and a shape key, a focal length and a world's strength.
    The export names what it found animated besides the camera, the lamps and VDB sequences
    (animation.json, summary.json, the report), writes per frame the entries they change,
    which a worker applies in place, and every pipeline frame is the bits of the scene
    exported afresh at that frame (what F12 renders). The mesh that does not change is
    written once, and the updates hold only what changes."""
    add_camera(blank)
    bpy.ops.object.light_add(type="SUN")
    sun = bpy.context.object
    for f, angle in ((1, 80), (5, 30)):
        sun.rotation_euler = (0, math.radians(angle), 0)
        sun.keyframe_insert("rotation_euler", frame=f)
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.ops.mesh.primitive_cube_add(location=(-3, 0, 1))
    cube = bpy.context.object
    keyframed(cube, "location", (-3, 0, 1), (3, 0, 1))
    paint = material("paint", Base_Color=(0.8, 0.1, 0.1, 1))
    cube.data.materials.append(paint)
    colour = paint.node_tree.nodes["Principled BSDF"].inputs["Base Color"]
    keyframed(colour, "default_value", (0.8, 0.1, 0.1, 1), (0.1, 0.8, 0.1, 1))
    bpy.ops.object.light_add(type="POINT", location=(0, 0, 4))
    keyframed(bpy.context.object.data, "energy", 300, 1500)
    bulging_plane(1.0)
    keyframed(blank.camera.data, "lens", 50, 40)
    strength = set_background(blank, (0.1, 0.2, 0.4)).node_tree.nodes["Background"].inputs["Strength"]
    keyframed(strength, "default_value", 1.0, 3.0)
    anim = tmp_path / "anim"
    warnings = export_animation(blank, [1, 3, 5], str(anim))
    animation = json.loads((anim / "animation.json").read_text())
    named = {(a["what"], a["changes"]) for a in animation["animated"]}
    assert named == {
        ("mesh 'Cube'", "placement"),
        ("material 'paint'", "node values"),
        ("mesh 'Plane.001'", "shape"),
        ("camera 'Camera'", "settings"),
        ("world 'world'", "node values"),
    }
    assert all(a["from_frame"] == 3 for a in animation["animated"])
    assert [e.get("updates") for e in animation["frames"]] == [None, "updates_0003.xml", "updates_0005.xml"]
    assert not any("scene" in e for e in animation["frames"])
    assert animation["instanced"] == ["Cube", "Plane.001"]  # moving and deforming
    assert any("animated besides" in w and "mesh 'Cube'" in w and "2 frames are updates" in w for w in warnings)
    floors = [f for f in os.listdir(anim / "meshes") if f.startswith("Plane_")]
    assert len(floors) == 1  # the floor, the same at every frame, is one file
    updated = set(read_xml((anim / "updates_0005.xml").read_text()))
    assert "Plane" not in updated and {"Cube", "Plane.001.group", "camera", "world"} <= updated
    means = pipeline_frames_as_f12(blank, anim, (1, 3, 5), tmp_path)
    assert means[2] > 1.5 * means[0]  # brighter lamp, world and greener cube: it really changed


def test_a_sunrise_is_updated_frame_by_frame_not_exported_whole(tmp_path):
    """What the sunrise animates (its sun and camera) the pipeline updates frame by frame:
    nothing else is named, no frame is exported whole."""
    from blender_scenes import tiny_animation

    tiny_animation()
    warnings = export_animation(bpy.context.scene, [1, 2, 4], str(tmp_path))
    animation = json.loads((tmp_path / "animation.json").read_text())
    assert animation["animated"] == [] and animation["instanced"] == []
    assert not any("scene" in e or "updates" in e for e in animation["frames"])
    assert not any("animated besides" in w for w in warnings)


def test_keyframed_lamps_render_in_the_pipeline_as_in_f12(blank, tmp_path):
    """A point lamp from 300 W to 1500 W and a sun's strength and colour: each pipeline
    frame is the bits of the scene exported afresh at that frame (what F12 renders), the
    worker moving from frame to frame by Scene.update."""
    add_camera(blank)
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.ops.object.light_add(type="SUN")
    keyframed(bpy.context.object.data, "energy", 2.0, 5.0)
    keyframed(bpy.context.object.data, "color", (1.0, 1.0, 1.0), (1.0, 0.5, 0.2))
    bpy.ops.object.light_add(type="POINT", location=(0, 0, 2))
    keyframed(bpy.context.object.data, "energy", 300, 1500)
    anim = tmp_path / "anim"
    warnings = export_animation(blank, [1, 3, 5], str(anim))
    assert not any("animated besides" in w for w in warnings)  # animation.json follows them
    means = pipeline_frames_as_f12(blank, anim, (1, 3, 5), tmp_path)
    assert means[2] > 2 * means[0]  # the lamps really brightened


def test_a_keyframed_spot_renders_in_the_pipeline_as_in_f12(blank, tmp_path):
    """A spot lamp whose power, cone and blend are keyframed is followed frame by frame like
    a point lamp, updated in place, each frame the bits of a fresh export."""
    add_camera(blank)
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.ops.object.light_add(type="SPOT", location=(0, 0, 3))
    spot = bpy.context.object.data
    keyframed(spot, "energy", 300, 900)
    keyframed(spot, "spot_size", math.radians(30), math.radians(90))
    keyframed(spot, "spot_blend", 0.0, 0.8)
    anim = tmp_path / "anim"
    warnings = export_animation(blank, [1, 3, 5], str(anim))
    assert not any("animated besides" in w for w in warnings)  # animation.json follows it
    means = pipeline_frames_as_f12(blank, anim, (1, 3, 5), tmp_path)
    assert means[2] > 2 * means[0]  # a wider, brighter cone


def test_an_armature_and_moving_particle_instances_reach_the_video_as_f12_renders_them(blank, tmp_path):
    """A cylinder bent by a keyframed bone, and particles instancing a sphere from an emitter
    keyframed across the floor: named, updated in place (the cylinder's group mesh replaced,
    the instances moved), and each pipeline frame the bits of a fresh export at that frame."""
    add_camera(blank)
    bpy.ops.object.light_add(type="SUN")
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.ops.mesh.primitive_cylinder_add(depth=2, location=(0, 0, 1))
    cylinder = bpy.context.object
    bpy.ops.object.armature_add(location=(0, 0, 0))
    armature = bpy.context.object
    cylinder.modifiers.new("bend", "ARMATURE").object = armature
    cylinder.vertex_groups.new(name="Bone").add(list(range(len(cylinder.data.vertices))), 1.0, "REPLACE")
    bone = armature.pose.bones["Bone"]
    bone.rotation_mode = "XYZ"
    keyframed(bone, "rotation_euler", (0, 0, 0), (0.8, 0, 0))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.2, location=(0, 0, -50))
    ball = bpy.context.object
    bpy.ops.mesh.primitive_plane_add(size=2, location=(3, 0, 1))
    emitter = bpy.context.object
    particles = emitter.modifiers.new("scatter", "PARTICLE_SYSTEM").particle_system.settings
    particles.count, particles.frame_start, particles.frame_end, particles.lifetime = 20, 1, 1, 100
    particles.physics_type, particles.render_type, particles.instance_object = "NO", "OBJECT", ball
    keyframed(emitter, "location", (3, 0, 1), (3, 2, 1))
    anim = tmp_path / "anim"
    export_animation(blank, [1, 3, 5], str(anim))
    animation = json.loads((anim / "animation.json").read_text())
    named = {(a["what"], a["changes"]) for a in animation["animated"]}
    assert {("mesh 'Cylinder'", "shape"), ("instances of 'Sphere'", "placements")} <= named
    pipeline_frames_as_f12(blank, anim, (1, 3, 5), tmp_path)
    # As a Dask worker on another machine gets it: the directory as zip bytes.
    from pipeline.frames import pack, render_frame

    packed = pack(str(anim))
    for f in (3, 5):
        assert np.array_equal(render_frame(packed, f, 4, threads=1)[0], render_frame(str(anim), f, 4, threads=1)[0])


def test_an_object_shown_and_hidden_makes_its_frames_whole(blank, tmp_path):
    """Keyframed Disable in Renders: the frames where the cube is hidden have other scene
    entries than the first, so they are exported whole (scene_NNNN.xml), and still render
    as F12 does (whose depsgraph leaves the cube out: `final`)."""
    add_camera(blank)
    bpy.ops.object.light_add(type="SUN")
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.ops.mesh.primitive_cube_add(location=(0, 0, 1))
    cube = bpy.context.object
    for frame, hidden in ((1, False), (3, True), (5, False)):
        cube.hide_render = hidden
        cube.keyframe_insert("hide_render", frame=frame)
    anim = tmp_path / "anim"
    warnings = export_animation(blank, [1, 3, 5], str(anim))
    animation = json.loads((anim / "animation.json").read_text())
    assert [(a["what"], a["changes"]) for a in animation["animated"]] == [("scene 'Scene'", "objects shown")]
    assert [e.get("scene") for e in animation["frames"]] == [None, "scene_0003.xml", None]
    assert any("1 exported whole" in w for w in warnings)
    from pipeline.frames import render_frame

    for f in (1, 3, 5):
        image, _ = render_frame(str(anim), f, 4, threads=1)
        blank.frame_set(f)
        fresh = write_directory(export_scene(depsgraph(), final=True), tmp_path / f"f{f}")  # as F12's depsgraph
        assert np.array_equal(image, volpath.render(volpath.load_file(fresh), spp=4, seed=f, threads=2)), f


def blurred_export(scene, frame, instanced=None):
    """The scene at `frame` with its motion keys, as F12's engine exports it (the scene's
    frame_set standing in for the engine's); `instanced`: as an animation instanced them."""
    from addon.export import motion

    blur = motion.sample(scene, motion.scene_depsgraph(scene), frame)
    exported = export_scene(depsgraph(), instanced=blur.instanced() if instanced is None else instanced)
    motion.attach(exported, blur)
    return exported


def test_motion_blur_reaches_f12_and_the_pipeline_alike(blank, tmp_path):
    """Motion Blur on (shutter 1 frame, centred): a cube keyframed across the floor, a
    panning camera and a plane deformed by a shape key get motion keys at the shutter's
    opening, middle and closing (the plane its positions); F12's
    image is the bits of that scene rendered with F12's seed, blurred (it differs from the
    still frame), and each pipeline frame the bits of the same export at its frame, the
    worker updating the camera's, the cube's and the plane's keys in place."""
    cam = add_camera(blank)
    bpy.ops.object.light_add(type="SUN")
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.ops.mesh.primitive_cube_add(location=(-3, 0, 1))
    cube = bpy.context.object
    keyframed(cube, "location", (-3, 0, 1), (3, 0, 1))
    keyframed(cam, "location", (0, -8, 3), (1, -8, 3))
    bulging_plane(2.0)
    blank.render.use_motion_blur, blank.render.motion_blur_shutter = True, 1.0
    blank.volpath.seed = 5
    blank.frame_set(3)
    exported = blurred_export(blank, 3)
    assert exported.scene["Cube"]["motion"].shape == (3, 4, 4) and exported.scene["camera"]["motion"].shape == (3, 4, 4)
    member = next(v for k, v in exported.scene["Plane.001.group"].items() if k != "type")
    assert member["motion"].shape == (3, *member["positions"].shape)  # deformed in the shutter
    path = write_directory(exported, tmp_path / "blurred")
    f12 = render_f12(blank, tmp_path / "f12.exr")
    assert np.array_equal(f12, volpath.render(volpath.load_file(path), seed=5, threads=1))
    blank.render.use_motion_blur = False
    still = render_f12(blank, tmp_path / "still.exr")
    assert np.abs(f12 - still).max() > 0.1  # the streak
    blank.render.use_motion_blur = True
    anim = tmp_path / "anim"
    export_animation(blank, [1, 3, 5], str(anim))
    animation = json.loads((anim / "animation.json").read_text())
    assert animation["instanced"] == ["Cube", "Plane.001"]
    assert all("updates" in e for e in animation["frames"][1:])
    from pipeline.frames import render_frame

    for f in (1, 3, 5):
        image, meta = render_frame(str(anim), f, 4, threads=1)
        fresh = write_directory(blurred_export(blank, f, animation["instanced"]), tmp_path / f"f{f}")
        assert np.array_equal(image, volpath.render(volpath.load_file(fresh), spp=4, seed=f, threads=2)), f
        assert meta["scene_built"] == (f == 1)


def test_particle_instances_moving_in_the_shutter_blur(blank, tmp_path):
    """Particles instancing a sphere from an emitter keyframed across the floor, Motion Blur
    on: each particle's instance gets motion keys (matched across the shutter by its
    persistent id), and F12's image is the bits of that export rendered alike."""
    add_camera(blank)
    bpy.ops.object.light_add(type="SUN")
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.2, location=(0, 0, -50))
    ball = bpy.context.object
    bpy.ops.mesh.primitive_plane_add(size=2, location=(-2, 0, 1))
    emitter = bpy.context.object
    particles = emitter.modifiers.new("scatter", "PARTICLE_SYSTEM").particle_system.settings
    particles.count, particles.frame_start, particles.frame_end, particles.lifetime = 20, 1, 1, 100
    particles.physics_type, particles.render_type, particles.instance_object = "NO", "OBJECT", ball
    keyframed(emitter, "location", (-2, 0, 1), (2, 0, 1))
    blank.render.use_motion_blur, blank.volpath.seed = True, 3
    blank.frame_set(3)
    exported = blurred_export(blank, 3)
    spheres = [
        v for v in exported.scene.values() if isinstance(v, dict) and v.get("group", {}).get("id") == "Sphere.group"
    ]
    assert len(spheres) == 21  # the 20 particles' and the sphere's own, which holds still
    assert [v["motion"].shape for v in spheres if "motion" in v] == [(3, 4, 4)] * 20
    path = write_directory(exported, tmp_path / "blurred")
    f12 = render_f12(blank, tmp_path / "f12.exr")
    assert np.array_equal(f12, volpath.render(volpath.load_file(path), seed=3, threads=1))
