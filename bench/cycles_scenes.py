"""Cycles 5.0 (the bpy module) rendering the bench scenes' equivalents, for
compare_mitsuba.py. The scenes are rebuilt in Blender in the bench files' own (Y-up)
coordinates with Blender's radiometry as Cycles renders it: an Emission strength is the
radiance, an area light of power P and area A has radiance P / (pi A), a point light of
power P has intensity P / (4 pi), a Sun's strength is its irradiance; Principled Volume
density x colour = sigma_s, density x (1 - colour) = sigma_a (absorption colour black);
max_bounces = max_depth - 2 and volume_bounces likewise. Box pixel filter, no denoising,
adaptive sampling, clamping. Each render synchronises the scene again (with persistent
data, the bpy module returned the previous image without rendering again): tens of
milliseconds for surfaces, about 3 s with a VDB volume. That is not rendering, so the times
reported exclude it: the time of a 1-spp render is subtracted (which favours Cycles by one
sample's cost).
"""

import math
import os
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def _camera(bpy, origin, target, fov, far=1000.0):
    from mathutils import Matrix, Vector

    o, t = Vector(origin), Vector(target)
    forward = (t - o).normalized()
    right = forward.cross(Vector((0, 1, 0))).normalized()
    up = right.cross(forward)
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    bpy.context.collection.objects.link(cam)
    # Blender's camera looks along -Z with +Y up and +X to the right.
    cam.matrix_world = Matrix(
        (
            (right.x, up.x, -forward.x, o.x),
            (right.y, up.y, -forward.y, o.y),
            (right.z, up.z, -forward.z, o.z),
            (0, 0, 0, 1),
        )
    )
    cam.data.sensor_fit = "HORIZONTAL"
    cam.data.angle = math.radians(fov)
    cam.data.clip_start, cam.data.clip_end = 0.01, far
    bpy.context.scene.camera = cam


def _material(bpy, name, volume=None, diffuse=None, emission=None):
    m = bpy.data.materials.new(name)
    if m.node_tree is None:
        m.use_nodes = True
    tree = m.node_tree
    for n in list(tree.nodes):
        if n.bl_idname != "ShaderNodeOutputMaterial":
            tree.nodes.remove(n)
    out = tree.nodes["Material Output"]
    if volume is not None:
        density, colour, g = volume
        pv = tree.nodes.new("ShaderNodeVolumePrincipled")
        pv.inputs["Density"].default_value = density
        pv.inputs["Color"].default_value = (*colour, 1)
        pv.inputs["Absorption Color"].default_value = (0, 0, 0, 1)
        pv.inputs["Anisotropy"].default_value = g
        tree.links.new(pv.outputs[0], out.inputs["Volume"])
    if diffuse is not None:
        d = tree.nodes.new("ShaderNodeBsdfDiffuse")
        d.inputs["Color"].default_value = (*diffuse, 1)
        tree.links.new(d.outputs[0], out.inputs["Surface"])
    if emission is not None:
        e = tree.nodes.new("ShaderNodeEmission")
        e.inputs["Color"].default_value = (1, 1, 1, 1)
        e.inputs["Strength"].default_value = emission
        tree.links.new(e.outputs[0], out.inputs["Surface"])
    return m


def _sphere(bpy, center, radius, material):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=256, ring_count=128, radius=radius, location=center)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(material)


def _rectangle(bpy, size, location, normal, material):
    """A square of side `size` facing `normal` (Mitsuba's rectangle, scaled)."""
    from mathutils import Vector

    bpy.ops.mesh.primitive_plane_add(size=size, location=location)
    obj = bpy.context.object
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = Vector(normal).to_track_quat("Z", "Y")
    obj.data.materials.append(material)


def _light(bpy, kind, **kw):
    from mathutils import Vector

    light = bpy.data.lights.new(kind, kind)
    obj = bpy.data.objects.new(kind, light)
    bpy.context.collection.objects.link(obj)
    obj.location = kw.get("location", (0, 0, 0))
    if "direction" in kw:  # lights shine along their -Z
        obj.rotation_mode = "QUATERNION"
        obj.rotation_quaternion = Vector(kw["direction"]).to_track_quat("-Z", "Y")
    light.energy = kw["energy"]
    if kind == "POINT":
        light.shadow_soft_size = 0.0
        if hasattr(light, "use_soft_falloff"):
            light.use_soft_falloff = False
    if kind == "SUN":
        light.angle = 0.0
    if kind == "AREA":
        light.shape, light.size = "SQUARE", kw["size"]
    return obj


def _world(bpy, rgb):
    world = bpy.data.worlds.new("world")
    if world.node_tree is None:
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*rgb, 1)
    bpy.context.scene.world = world


def _volume(bpy, vdb, location, albedo, g):
    """A Volume object from a .vdb, its 'density' the Principled Volume's density."""
    bpy.ops.object.volume_import(filepath=vdb, location=location)
    obj = bpy.context.object
    obj.data.render.precision = "FULL"
    obj.data.render.clipping = 0.0
    obj.data.materials.append(_material(bpy, "smoke", volume=(1.0, albedo, g)))


def build(key, res, tmp):
    """The Blender scene of bench scene `key` ("a".."e", "cloud"); returns the max_depth used."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.render.resolution_x = scene.render.resolution_y = res
    scene.render.resolution_percentage = 100
    _world(bpy, (0, 0, 0))
    if key == "a":
        _camera(bpy, (0, 0, 5), (0, 0, 0), 35)
        _sphere(bpy, (0, 0, 0), 1, _material(bpy, "absorber", volume=(1.0, (0, 0, 0), 0.0)))
        _rectangle(bpy, 20, (0, 0, -3), (0, 0, 1), _material(bpy, "backlight", emission=1.0))
        return -1
    if key == "b":
        _camera(bpy, (0, 0, 5), (0, 0, 0), 35)
        _sphere(bpy, (0, 0, 0), 1, _material(bpy, "smoke", volume=(1.0, (0.8, 0.8, 0.8), 0.0)))
        _light(bpy, "POINT", location=(2, 2, 2), energy=4 * math.pi * 20)
        return 2
    if key == "c":
        _camera(bpy, (0, 1, 5), (0, -0.2, 0), 40)
        _sphere(bpy, (0, 0, 0), 1, _material(bpy, "cloud", volume=(5.0, (0.99, 0.99, 0.99), 0.6)))
        _rectangle(bpy, 10, (0, -1, 0), (0, 1, 0), _material(bpy, "floor", diffuse=(0.5, 0.5, 0.5)))
        _light(bpy, "AREA", location=(0, 3, 0), direction=(0, -1, 0), size=1.5, energy=15 * math.pi * 1.5**2)
        return 64
    if key == "d":
        _camera(bpy, (2.5, 2, 4), (0, 0, 0), 40)
        from make_grids import write_vdb

        from volpath.grids import read_vol

        data, _ = read_vol(os.path.join(HERE, "scenes", "hetero_cube.vol"))
        vdb = write_vdb(os.path.join(tmp, "hetero_cube.vdb"), data[..., 0], voxel_size=2.0 / data.shape[0])
        offset = -1 + 0.5 * 2.0 / data.shape[0]  # a VDB voxel i sits at i * size; the .vol's at (i + 0.5) / res
        _volume(bpy, vdb, (offset,) * 3, (0.9, 0.7, 0.5), 0.0)
        _light(bpy, "SUN", direction=(-1, -2, -0.5), energy=3.0)
        _world(bpy, (0.3, 0.4, 0.6))
        return 64
    if key == "e":
        _camera(bpy, (0, -490, 400), (0, -440, -300), 60, far=1e5)
        bpy.ops.mesh.primitive_cube_add(size=1000)
        bpy.context.object.data.materials.append(_material(bpy, "fog", volume=(0.001, (0.9, 0.9, 0.9), 0.7)))
        _rectangle(bpy, 998, (0, -499, 0), (0, 1, 0), _material(bpy, "ground", diffuse=(0.3, 0.3, 0.3)))
        _sphere(bpy, (0, -440, -200), 60, _material(bpy, "ball", diffuse=(0.6, 0.6, 0.6)))
        _light(bpy, "SUN", direction=(0.3, -0.5, 1), energy=5.0)
        return 16
    if key == "cloud":  # the accuracy study's cloud: the same .vdb as bench/scenes/cloud.xml
        _camera(bpy, (0.5, 0.75, 1.6), (0.5, 0.42, 0.5), 45)
        _volume(bpy, os.path.join(HERE, "scenes", "cloud.vdb"), (0, 0, 0), (0.98, 0.98, 0.98), 0.6)
        _light(bpy, "SUN", direction=(-0.4, -1, -0.3), energy=3.0)
        _world(bpy, (0.3, 0.4, 0.6))
        return -1
    raise KeyError(key)


class Cycles:
    name = "cycles"
    sync_seconds = None  # per-render synchronisation, measured by the first render
    min_spp = 4  # a 1-spp render is what sync_seconds measures: its net time would be 0

    def __init__(self, key, res, threads):
        import bpy

        self.bpy = bpy
        self.tmp = tempfile.mkdtemp(prefix="volpath-cycles-")
        max_depth = build(key, res, self.tmp)
        scene = bpy.context.scene
        c = scene.cycles
        c.device = "CPU"
        c.use_denoising = c.use_adaptive_sampling = False
        c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
        c.pixel_filter_type, c.filter_width = "BOX", 1.0
        bounces = 1024 if max_depth < 0 else max(max_depth - 2, 0)
        c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = bounces
        c.volume_bounces = bounces
        c.transparent_max_bounces = 64
        c.volume_max_steps = 100000
        scene.render.threads_mode, scene.render.threads = "FIXED", threads
        scene.render.image_settings.file_format = "OPEN_EXR"
        scene.render.image_settings.color_depth = "32"
        scene.render.filepath = os.path.join(self.tmp, "frame.exr")

    def _render(self, spp, seed):
        import volpath

        scene = self.bpy.context.scene
        scene.cycles.samples, scene.cycles.seed = spp, seed
        start = time.perf_counter()
        self.bpy.ops.render.render(write_still=True)
        seconds = time.perf_counter() - start
        return volpath.read_exr(scene.render.filepath)[..., :3], seconds

    def render(self, spp, seed):
        if self.sync_seconds is None:
            self.sync_seconds = min(self._render(1, seed)[1] for _ in range(2))
        self._render(spp, seed + 7919)  # warm up: kernels, image and VDB caches
        image, seconds = self._render(spp, seed)
        return image, max(seconds - self.sync_seconds, 1e-3)
