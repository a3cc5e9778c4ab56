"""Blender scenes built by scripts (the `bpy` module, no .blend fixtures), shared by the
add-on and pipeline tests."""

import math
import os
import sys

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
import addon  # noqa: E402  (the repository root holds the add-on package)

_registered = False


def blank_scene():
    """An empty scene rendered by Volpath at 48x32, 4 spp, linear output."""
    global _registered
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not _registered:
        addon.register()
        _registered = True
    scene = bpy.context.scene
    scene.render.engine = "VOLPATH"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 48, 32, 100
    scene.view_settings.view_transform = "Standard"
    scene.render.dither_intensity = 0
    scene.volpath.spp = 4
    return scene


def add_camera(scene, location=(0, -8, 3), rotation=(1.3, 0, 0)):
    bpy.ops.object.camera_add(location=location, rotation=rotation)
    scene.camera = bpy.context.object
    return scene.camera


def set_background(scene, rgb, strength=1.0):
    scene.world = bpy.data.worlds.new("world")
    tree = scene.world.node_tree if scene.world.node_tree else None
    if tree is None:
        scene.world.use_nodes = True
        tree = scene.world.node_tree
    bg = tree.nodes["Background"]
    bg.inputs["Color"].default_value = (*rgb, 1.0)
    bg.inputs["Strength"].default_value = strength
    return scene.world


def material(name, **inputs):
    """A Principled BSDF material with the given inputs (names with spaces as underscores)."""
    m = bpy.data.materials.new(name)
    if m.node_tree is None:
        m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    for k, v in inputs.items():
        bsdf.inputs[k.replace("_", " ")].default_value = v
    return m


def volume_material(name, density=1.0, color=(0.5, 0.5, 0.5), anisotropy=0.0):
    m = bpy.data.materials.new(name)
    if m.node_tree is None:
        m.use_nodes = True
    tree = m.node_tree
    out = tree.nodes["Material Output"]
    for link in list(out.inputs["Surface"].links):
        tree.links.remove(link)
    pv = tree.nodes.new("ShaderNodeVolumePrincipled")
    pv.inputs["Density"].default_value = density
    pv.inputs["Color"].default_value = (*color, 1.0)
    pv.inputs["Anisotropy"].default_value = anisotropy
    tree.links.new(pv.outputs[0], out.inputs["Volume"])
    return m


def small_scene(scene):
    """Floor, smooth sphere, a fog cube, sun + area light, camera, blue world."""
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1, location=(0, 0, 1))
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(material("red", Base_Color=(0.8, 0.1, 0.1, 1), Roughness=0.4))
    bpy.ops.mesh.primitive_cube_add(size=1, location=(2, 0, 0.5))
    bpy.context.object.data.materials.append(volume_material("fog", density=2.0))
    bpy.ops.object.light_add(type="SUN", rotation=(0.6, 0.2, 0))
    bpy.context.object.data.energy = 3
    bpy.ops.object.light_add(type="AREA", location=(0, 0, 4))
    bpy.context.object.data.energy = 200
    add_camera(scene)
    set_background(scene, (0.1, 0.2, 0.4))
    return scene


def render_f12(scene, path):
    """F12 through Blender, saved as a 32-bit float EXR; returns its RGB."""
    import volpath

    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return volpath.read_exr(str(path))[..., :3]


def depsgraph():
    return bpy.context.evaluated_depsgraph_get()


def write_vdb(path, density, voxel_size=0.1, origin_index=(0, 0, 0)):
    """A float grid named 'density' written by Blender's bundled openvdb module; `density`
    is indexed [x, y, z]."""
    from addon.export.volumes import _openvdb

    vdb = _openvdb()
    grid = vdb.FloatGrid()
    grid.name = "density"
    grid.copyFromArray(np.ascontiguousarray(density, dtype=np.float32), ijk=origin_index)
    grid.transform = vdb.createLinearTransform(voxelSize=voxel_size)
    vdb.write(str(path), grids=[grid])
    return path


def add_volume(path, material=None, location=(0, 0, 0)):
    bpy.ops.object.volume_import(filepath=str(path), location=location)
    obj = bpy.context.object
    if material is not None:
        obj.data.materials.append(material)
    return obj


def tiny_animation(path=None, frames=4, spp=4, sky=False):
    """A floor, a box, a keyframed sun (and optionally the atmosphere), 64x36; saved to
    `path` when given."""
    scene = blank_scene()
    scene.render.resolution_x, scene.render.resolution_y = 64, 36
    scene.frame_start, scene.frame_end = 1, frames
    scene.volpath.spp = spp
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.ops.mesh.primitive_cube_add(size=2, location=(0, 0, 1))
    bpy.context.object.data.materials.append(material("box", Base_Color=(0.8, 0.3, 0.1, 1)))
    bpy.ops.object.light_add(type="SUN")
    sun = bpy.context.object
    sun.data.energy = 5
    for f, angle in ((1, 80), (frames, 30)):
        sun.rotation_euler = (0, math.radians(angle), 0)
        sun.keyframe_insert("rotation_euler", frame=f)
    add_camera(scene, location=(0, -9, 3), rotation=(math.radians(75), 0, 0))
    world = bpy.data.worlds.new("w")
    scene.world = world
    if world.node_tree is None:
        world.use_nodes = True
    if sky:
        node = world.node_tree.nodes.new("ShaderNodeTexSky")
        world.node_tree.links.new(node.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"])
    else:
        world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.2, 0.3, 0.5, 1)
    if path is not None:
        bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path
