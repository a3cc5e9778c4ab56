"""Small Blender scenes, one exported feature each, for comparing Volpath with Cycles
(issue #38's parity suite: tests/addon/test_parity.py quickly, bench/parity.py in full).

Each builder takes the blank scene (tests/blender_scenes.py) and adds a camera, a floor and
what it tests. `render_both` renders the scene with Volpath and Cycles under matched
settings: no denoising, no clamping, no adaptive sampling, Filter Glossy 0 (Cycles blurs
caustics otherwise), enough bounces, a one-pixel box filter."""

import math

import bpy
import numpy as np
from blender_scenes import add_camera, material, render_f12, set_background, volume_material, write_vdb


def _floor(size=12, colour=(0.6, 0.6, 0.6)):
    bpy.ops.mesh.primitive_plane_add(size=size)
    bpy.context.object.data.materials.append(material("floor", Base_Color=(*colour, 1), Specular_IOR_Level=0.0))


def _view(scene):
    add_camera(scene, location=(0, -6, 4), rotation=(math.radians(58), 0, 0))


def _light(kind, energy, location=(0, 0, 3), rotation=(0, 0, 0), **data):
    bpy.ops.object.light_add(type=kind, location=location, rotation=rotation)
    light = bpy.context.object
    light.data.energy = energy
    for k, v in data.items():
        setattr(light.data, k, v)
    return light


def point_light(scene):
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_cube_add(size=1, location=(0, 0, 0.5))
    _light("POINT", 300, location=(1, -1, 3), shadow_soft_size=0)
    set_background(scene, (0.05, 0.05, 0.05))


def sun_with_angle(scene):
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_cube_add(size=1, location=(0, 0, 0.5))
    _light("SUN", 3, rotation=(0.5, 0.3, 0), angle=math.radians(10))
    set_background(scene, (0.1, 0.12, 0.15))


def area_lights(scene):
    """A square, a rectangle and a disk, seen in the floor's light (not by the camera)."""
    _floor(), _view(scene)
    _light("AREA", 80, location=(-2, 0, 2), shape="SQUARE", size=0.8)
    _light("AREA", 80, location=(0, 0, 2), shape="RECTANGLE", size=1.2, size_y=0.4)
    _light("AREA", 80, location=(2, 0, 2), shape="DISK", size=0.8)


def area_light_spread(scene):
    """Spread: a square light narrowed to 60 degrees, a tilted disk to 100, over the floor."""
    _floor(), _view(scene)
    _light("AREA", 150, location=(-1.5, 0, 2), shape="SQUARE", size=0.8, spread=math.radians(60))
    _light("AREA", 150, location=(1.5, 0, 2), rotation=(0.4, 0, 0), shape="DISK", size=0.8, spread=math.radians(100))


def spot_lights(scene):
    """A spot with a hard edge and one with a soft one (Blend), tilted, beside a cube."""
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_cube_add(size=1, location=(0, 0.5, 0.5))
    _light("SPOT", 400, location=(-1.5, 0, 3), rotation=(0.3, 0, 0), spot_size=math.radians(50), spot_blend=0)
    _light("SPOT", 600, location=(1.5, -1, 3), rotation=(-0.2, 0.3, 0), spot_size=math.radians(70), spot_blend=0.6)
    set_background(scene, (0.03, 0.03, 0.03))


def sphere_lights(scene):
    """A point lamp and a spot with a Radius: soft shadows, the lamps seen as discs; one
    with Soft Falloff, one without."""
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_cube_add(size=1, location=(-0.5, 0, 0.5))
    _light("POINT", 300, location=(0.8, -0.5, 1.8), shadow_soft_size=0.35)
    spot = _light("SPOT", 500, location=(-1.8, -1, 2.2), rotation=(0.5, -0.4, 0), spot_size=math.radians(80))
    spot.data.shadow_soft_size, spot.data.use_soft_falloff = 0.25, False
    set_background(scene, (0.03, 0.03, 0.03))


def light_colour(scene):
    """A point lamp coloured by its Temperature, with an Exposure; an area lamp whose power
    is not normalized by its size; a spot whose node tree's Emission takes its colour from a
    Blackbody node and doubles its strength."""
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_cube_add(size=1, location=(0, 0, 0.5))
    warm = _light("POINT", 100, location=(-1, -1, 2.5), shadow_soft_size=0, exposure=1.5)
    warm.data.use_temperature, warm.data.temperature = True, 2700
    _light("AREA", 40, location=(1.5, 0, 2), size=1.5, normalize=False)
    spot = _light("SPOT", 300, location=(0, 1.5, 3), rotation=(-0.4, 0, 0), shadow_soft_size=0)
    spot.data.use_nodes = True
    tree = spot.data.node_tree
    emission = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 2.0
    blackbody = tree.nodes.new("ShaderNodeBlackbody")
    blackbody.inputs["Temperature"].default_value = 9000
    tree.links.new(blackbody.outputs[0], emission.inputs["Color"])


def light_visibility(scene):
    """A point light that casts no shadow (Cast Shadow off) beside a cube and a box of smoke,
    and an area light that lights no medium (Volume Scatter off) above the smoke."""
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_cube_add(size=1, location=(-1.2, 0, 0.5))
    bpy.ops.mesh.primitive_cube_add(size=1.4, location=(1.2, 0, 0.75))
    bpy.context.object.data.materials.append(volume_material("smoke", density=1.5, color=(0.8, 0.8, 0.8)))
    _light("POINT", 400, location=(-2, -1, 3), shadow_soft_size=0, use_shadow=False)
    _light("AREA", 120, location=(1.2, 0, 2.5), size=1.0).visible_volume_scatter = False
    set_background(scene, (0.05, 0.05, 0.05))


def light_lobes(scene):
    """An area light hidden from glossy rays (it lights the diffuse floor and the chalk
    sphere, and puts no highlight on the gold one) and a point light hidden from diffuse
    rays (it puts a highlight on the gold sphere and lights nothing else)."""
    _floor(), _view(scene)
    for x, m in (
        (-1, material("gold", Base_Color=(0.9, 0.6, 0.2, 1), Metallic=1.0, Roughness=0.3)),
        (1, material("chalk", Base_Color=(0.8, 0.8, 0.8, 1), Specular_IOR_Level=0.0)),
    ):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(x, 0, 0.7), segments=64, ring_count=32)
        bpy.ops.object.shade_smooth()
        bpy.context.object.data.materials.append(m)
    _light("AREA", 200, location=(0, -1, 3), size=1.0).visible_glossy = False
    _light("POINT", 300, location=(-2.5, -2, 2.5), shadow_soft_size=0).visible_diffuse = False
    set_background(scene, (0.05, 0.05, 0.05))


def emission_shader(scene):
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_plane_add(size=1.5, location=(0, 0.5, 1.5), rotation=(math.pi, 0, 0))
    m = bpy.data.materials.new("glow")
    tree = m.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    emit = tree.nodes.new("ShaderNodeEmission")
    emit.inputs["Color"].default_value, emit.inputs["Strength"].default_value = (1.0, 0.8, 0.5, 1), 6.0
    tree.links.new(emit.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    bpy.context.object.data.materials.append(m)


def emission_map(scene):
    """A panel whose Emission colour is an image (warm and cool squares), lighting the floor
    and a cube and seen by the camera."""
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(0.8, -0.5, 0.4))
    bpy.context.object.data.materials.append(material("chalk", Base_Color=(0.8, 0.8, 0.8, 1), Specular_IOR_Level=0.0))
    bpy.ops.mesh.primitive_plane_add(size=2, location=(0, 1, 1.2), rotation=(math.radians(70), 0, 0))
    image = bpy.data.images.new("panel", 4, 4)
    u, v = np.meshgrid(np.arange(4), np.arange(4))
    texels = np.where(((u + v) % 2 == 0)[..., None], [1.0, 0.6, 0.2, 1.0], [0.2, 0.5, 1.0, 1.0])
    image.pixels.foreach_set(texels.astype(np.float32).ravel())
    image.pack()
    m = bpy.data.materials.new("panel")
    tree = m.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    emit, tex = tree.nodes.new("ShaderNodeEmission"), tree.nodes.new("ShaderNodeTexImage")
    tex.image, tex.interpolation = image, "Closest"
    emit.inputs["Strength"].default_value = 8.0
    tree.links.new(tex.outputs["Color"], emit.inputs["Color"])
    tree.links.new(emit.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    bpy.context.object.data.materials.append(m)
    set_background(scene, (0.02, 0.02, 0.02))


def glass_and_metal(scene):
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(-1, 0, 0.7), segments=64, ring_count=32)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(material("glass", Transmission_Weight=1.0, IOR=1.45, Roughness=0.0))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(1, 0, 0.7), segments=64, ring_count=32)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(
        material("gold", Base_Color=(0.9, 0.6, 0.2, 1), Metallic=1.0, Roughness=0.25)
    )
    _light("AREA", 200, location=(0, -1, 3), size=1.0)
    set_background(scene, (0.2, 0.2, 0.2))


def textured_principled(scene):
    _floor(), _view(scene)
    image = bpy.data.images.new("checks", 8, 8)
    u, v = np.meshgrid(np.arange(8), np.arange(8))
    colour = np.where(((u + v) % 2 == 0)[..., None], [0.8, 0.2, 0.1, 1.0], [0.1, 0.3, 0.8, 1.0])
    image.pixels.foreach_set(colour.astype(np.float32).ravel())
    image.pack()
    bpy.ops.mesh.primitive_cube_add(size=1.6, location=(0, 0, 0.8))
    m = bpy.data.materials.new("checks")
    tex = m.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image, tex.interpolation = image, "Closest"
    m.node_tree.links.new(tex.outputs["Color"], m.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    bpy.context.object.data.materials.append(m)
    _light("SUN", 3, rotation=(0.6, 0.4, 0))
    set_background(scene, (0.2, 0.25, 0.3))


def coloured_volume(scene):
    """A box of Principled Volume with a coloured absorption, lit by the sun; lifted off the
    floor, since Cycles darkens the floor under a box that rests on it (9 % here) where a
    gap of any width would not (Volpath renders both alike: tests/stability/test_coplanar.py)."""
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_cube_add(size=2, location=(0, 0, 1.05))
    m = volume_material("smoke", density=1.5, color=(0.8, 0.8, 0.8), anisotropy=0.3)
    m.node_tree.nodes["Principled Volume"].inputs["Absorption Color"].default_value = (0.2, 0.5, 0.9, 1)
    bpy.context.object.data.materials.append(m)
    _light("SUN", 4, rotation=(0.5, 0.2, 0))
    set_background(scene, (0.1, 0.1, 0.1))


def vdb_volume(scene, directory):
    _floor(), _view(scene)
    x, y, z = np.meshgrid(*(np.linspace(-1, 1, 24),) * 3, indexing="ij")
    density = np.clip(1 - np.sqrt(x**2 + y**2 + z**2), 0, None) * 4
    path = write_vdb(f"{directory}/blob.vdb", density, voxel_size=0.08)
    bpy.ops.object.volume_import(filepath=str(path), location=(-1, -1, 0))
    bpy.context.object.data.materials.append(volume_material("blob", density=1.0, color=(0.9, 0.9, 0.9)))
    _light("SUN", 4, rotation=(0.5, 0.2, 0))
    set_background(scene, (0.1, 0.1, 0.1))


def world_colour(scene):
    _floor(colour=(0.8, 0.8, 0.8)), _view(scene)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(0, 0, 0.8), segments=64, ring_count=32)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(material("red", Base_Color=(0.8, 0.1, 0.1, 1), Roughness=0.5))
    set_background(scene, (0.3, 0.5, 0.9), strength=1.5)


def _hdri(directory, name, size=(64, 32), projection="EQUIRECTANGULAR"):
    """A small HDR environment written to `directory` and loaded as Blender loads a user's:
    a blue sky over a brown ground, a bright warm patch (a low sun) and a green one, so
    that a turn of the map shows."""
    w, h = size
    v, u = np.meshgrid((np.arange(h) + 0.5) / h, (np.arange(w) + 0.5) / w, indexing="ij")  # rows bottom first
    sky = np.where((v > 0.5)[..., None], [0.3, 0.5, 1.0], [0.25, 0.18, 0.1]) * 1.0
    sky = sky + 40.0 * (np.hypot(u - 0.3, v - 0.62) < 0.05)[..., None] * np.array([1.0, 0.85, 0.6])
    sky = sky + 3.0 * (np.hypot(u - 0.75, v - 0.55) < 0.1)[..., None] * np.array([0.1, 1.0, 0.2])
    image = bpy.data.images.new(name, w, h, float_buffer=True)
    image.pixels.foreach_set(np.concatenate([sky, np.ones((h, w, 1))], axis=2).astype(np.float32).ravel())
    suffix = ".hdr" if projection == "EQUIRECTANGULAR" else ".exr"
    image.filepath_raw = f"{directory}/{name}{suffix}"
    image.file_format = "HDR" if suffix == ".hdr" else "OPEN_EXR"
    image.save()
    bpy.data.images.remove(image)
    return bpy.data.images.load(f"{directory}/{name}{suffix}")


def environment_texture(scene, directory, projection="EQUIRECTANGULAR", turn=60):
    """An HDRI world (a .hdr file) turned by a Mapping node, lighting a diffuse and a glossy
    sphere on the floor and seen behind them."""
    _floor(), _view(scene)
    for x, m in (
        (-1, material("chalk", Base_Color=(0.8, 0.8, 0.8, 1), Specular_IOR_Level=0.0)),
        (1, material("steel", Base_Color=(0.9, 0.9, 0.9, 1), Metallic=1.0, Roughness=0.2)),
    ):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(x, 0, 0.7), segments=64, ring_count=32)
        bpy.ops.object.shade_smooth()
        bpy.context.object.data.materials.append(m)
    world = set_background(scene, (0, 0, 0), strength=1.2)
    tree = world.node_tree
    env = tree.nodes.new("ShaderNodeTexEnvironment")
    env.image, env.projection = _hdri(directory, "sky", projection=projection), projection
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0, 0, math.radians(turn))
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs[0], env.inputs["Vector"])
    tree.links.new(env.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    scene.camera.location, scene.camera.rotation_euler = (0, -6, 2), (math.radians(80), 0, 0)


def shown_and_lit(scene, directory):
    """The Light Path's Is Camera Ray mixing two Backgrounds: the HDRI lights the spheres
    unseen, the camera sees a plain dark blue."""
    environment_texture(scene, directory)
    tree = scene.world.node_tree
    shown = tree.nodes.new("ShaderNodeBackground")
    shown.inputs["Color"].default_value = (0.05, 0.1, 0.3, 1)
    mix = tree.nodes.new("ShaderNodeMixShader")
    tree.links.new(tree.nodes.new("ShaderNodeLightPath").outputs["Is Camera Ray"], mix.inputs["Fac"])
    tree.links.new(tree.nodes["Background"].outputs[0], mix.inputs[1])
    tree.links.new(shown.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], tree.nodes["World Output"].inputs["Surface"])


def mirror_ball(scene, directory):
    """The same world from a mirror ball image (an .exr), turned so that the direction the
    ball cannot show (where its whole rim converges) lies behind the camera, as users
    place it."""
    environment_texture(scene, directory, projection="MIRROR_BALL", turn=170)


def sky_texture(scene):
    """The Sky Texture with a Sun lamp: Volpath traces the physical atmosphere, Cycles looks
    its sky up in a table it precomputes; a documented difference, not held to the others'
    tolerance (KNOWN_DIFFERENCES)."""
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_cube_add(size=1, location=(0, 0, 0.5))
    world = set_background(scene, (0, 0, 0))
    sky = world.node_tree.nodes.new("ShaderNodeTexSky")
    world.node_tree.links.new(sky.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"])
    _light("SUN", 3, rotation=(math.radians(40), 0, 0.5))


def camera_fit_and_shift(scene):
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_cube_add(size=1, location=(1, 1, 0.5))
    cam = scene.camera.data
    cam.sensor_fit, cam.shift_x, cam.shift_y, cam.lens = "VERTICAL", 0.15, -0.1, 40
    _light("SUN", 3, rotation=(0.5, 0.3, 0))
    set_background(scene, (0.2, 0.2, 0.2))


def modifiers_and_instances(scene):
    _floor(), _view(scene)
    bpy.ops.mesh.primitive_cube_add(size=0.6, location=(-2, 0, 0.3))
    cube = bpy.context.object
    cube.data.materials.append(material("orange", Base_Color=(0.9, 0.4, 0.1, 1)))
    array = cube.modifiers.new("array", "ARRAY")
    array.count, array.relative_offset_displace = 4, (1.8, 0, 0)
    bevel = cube.modifiers.new("bevel", "BEVEL")
    bevel.width = 0.1
    for x in (-3.5, 1):  # apart: overlapping copies would make coplanar faces
        copy = cube.copy()  # a linked duplicate: shares the mesh
        copy.location = (x, 2, 0.3)
        bpy.context.collection.objects.link(copy)
    _light("SUN", 3, rotation=(0.5, 0.3, 0))
    set_background(scene, (0.2, 0.2, 0.2))


SCENES = {
    "point light": point_light,
    "sun with an angle": sun_with_angle,
    "area lights": area_lights,
    "area light spread": area_light_spread,
    "spot lights": spot_lights,
    "sphere lights": sphere_lights,
    "light colour": light_colour,
    "light visibility": light_visibility,
    "light lobes": light_lobes,
    "emission shader": emission_shader,
    "emission map": emission_map,
    "glass and metal": glass_and_metal,
    "textured principled": textured_principled,
    "coloured volume": coloured_volume,
    "VDB volume": vdb_volume,
    "world colour": world_colour,
    "environment texture": environment_texture,
    "mirror ball": mirror_ball,
    "shown and lit worlds": shown_and_lit,
    "sky texture": sky_texture,
    "camera fit and shift": camera_fit_and_shift,
    "modifiers and instances": modifiers_and_instances,
}


# Scenes where the two renderers are known to differ, and why.
KNOWN_DIFFERENCES = {
    "mirror ball": "the geometry agrees (the same image, the horizon where Cycles has it), but where a "
    "small bright patch of the ball lights the scene Volpath is 5 % brighter (1.010 without the patches); "
    "the cause is not found yet",
    "sky texture": "Cycles' sky is a precomputed table lit by the Sky Texture's own sun (the physical "
    "solar irradiance times Sun Intensity), with the Sun lamp added on top; Volpath traces the "
    "atmosphere lit by the Sun lamp (3 W/m2 here), so its sky is far dimmer",
}


def build(name, scene, directory):
    builder = SCENES[name]
    builder(scene, directory) if builder in (vdb_volume, environment_texture, mirror_ball, shown_and_lit) else builder(
        scene
    )


def render_both(scene, directory, spp, size=(64, 48)):
    """(Volpath's image, Cycles' image) of the scene at `spp`, matched settings."""
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.engine = "VOLPATH"
    scene.volpath.spp, scene.volpath.max_depth = spp, 34
    ours = render_f12(scene, f"{directory}/volpath.exr")
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.samples, c.use_denoising, c.device, c.use_adaptive_sampling = spp, False, "CPU", False
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = c.volume_bounces = 32
    c.transparent_max_bounces = 64
    c.sample_clamp_direct = c.sample_clamp_indirect = 0
    c.blur_glossy = 0.0
    c.caustics_reflective = c.caustics_refractive = True
    c.pixel_filter_type, c.filter_width = "BOX", 1.0  # Volpath's pixel filter
    theirs = render_f12(scene, f"{directory}/cycles.exr")
    return ours, theirs


def agreement(ours, theirs, block=8):
    """(image mean ratio, the largest relative difference of 8x8 block means among blocks
    brighter than a tenth of the image mean)."""
    ratio = float(ours.mean() / theirs.mean())
    h, w = ours.shape[0] // block, ours.shape[1] // block

    def blocks(img):
        return img[: h * block, : w * block].mean(axis=2).reshape(h, block, w, block).mean(axis=(1, 3))

    a, b = blocks(ours), blocks(theirs)
    lit = b > 0.1 * theirs.mean()
    return ratio, float(np.max(np.abs(a[lit] / b[lit] - 1))) if lit.any() else 0.0
