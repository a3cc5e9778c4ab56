"""Image Texture nodes exported as bitmaps: files and pixels, UV maps, Mapping nodes; F12
beside Cycles on a textured plane."""

import bpy
import numpy as np
import pytest
from blender_scenes import add_camera, depsgraph, render_f12, set_background

import volpath
from addon.export import export_scene, write_directory


def quadrants(path, n=64):
    """An n x n PNG: red top-left, green top-right, blue bottom-left, white bottom-right.
    (Large enough that a texel is smaller than a pixel: Cycles interpolates 8-bit sRGB
    texels before decoding them, Volpath, as Mitsuba, after.)"""
    from PIL import Image

    img = np.zeros((n, n, 3), np.uint8)
    h = n // 2
    img[:h, :h], img[:h, h:], img[h:, :h], img[h:, h:] = (220, 40, 30), (30, 200, 40), (40, 30, 210), (230, 230, 230)
    Image.fromarray(img).save(path)
    return str(path)


def textured_material(name, image, socket="Base Color", shader="ShaderNodeBsdfPrincipled"):
    m = bpy.data.materials.new(name)
    tree = m.node_tree
    out = tree.nodes["Material Output"]
    for n in [n for n in tree.nodes if n != out]:
        tree.nodes.remove(n)
    bsdf = tree.nodes.new(shader)
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tree.links.new(tex.outputs["Color"], bsdf.inputs[socket])
    return m, tex


def add_mapping(material, tex, location=(0, 0, 0), rotation=(0, 0, 0), scale=(1, 1, 1), uv_map=None):
    tree = material.node_tree
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Location"].default_value = location
    mapping.inputs["Rotation"].default_value = rotation
    mapping.inputs["Scale"].default_value = scale
    source = tree.nodes.new("ShaderNodeUVMap")
    if uv_map is not None:
        source.uv_map = uv_map
    tree.links.new(source.outputs["UV"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    return mapping


def plane_under_white_sky(scene, material, size=4):
    """A plane filling the view of a camera looking straight down, lit by a white world
    (its radiance is its albedo wherever nothing else matters)."""
    bpy.ops.mesh.primitive_plane_add(size=size)
    plane = bpy.context.object
    plane.data.materials.append(material)
    add_camera(scene, location=(0, 0, 5), rotation=(0, 0, 0))
    set_background(scene, (1, 1, 1))
    return plane


def block_means(img, block=8):
    h, w = img.shape[0] // block, img.shape[1] // block
    return img[: h * block, : w * block].reshape(h, block, w, block, 3).mean(axis=(1, 3))


def test_a_textured_plane_matches_cycles_block_by_block(blank, tmp_path):
    """F12 against Cycles, both 64 spp: every 8x8 block's mean within 5 % (+0.01). Under a
    white world a diffuse-coated plane's pixels hardly vary between samples, so what could
    fail is the texture's orientation, tiling, mapping, colour decoding or filtering."""
    image = bpy.data.images.load(quadrants(tmp_path / "q.png"))
    m, tex = textured_material("quads", image)
    add_mapping(m, tex, location=(0.25, 0.1, 0), rotation=(0, 0, 0.4), scale=(1.5, 1.0, 1))
    plane_under_white_sky(blank, m)
    blank.volpath.spp = 64
    ours = render_f12(blank, tmp_path / "volpath.exr")
    blank.render.engine = "CYCLES"
    blank.cycles.samples, blank.cycles.use_denoising, blank.cycles.device = 64, False, "CPU"
    cycles = render_f12(blank, tmp_path / "cycles.exr")
    a, c = block_means(ours), block_means(cycles)
    assert np.ptp(c) > 0.3  # the texture is in view, with its four colours
    np.testing.assert_allclose(a, c, rtol=0.05, atol=0.01)


def test_pixels_without_a_file_and_non_colour_data(blank, tmp_path):
    """A generated (byte) image goes out as its pixels, rows top first; a Non-Color image
    stays raw; the scene written to a directory renders to the same bits as in memory."""
    image = bpy.data.images.new("painted", 2, 2)
    px = np.array([[1, 0, 0, 1], [0, 1, 0, 1], [0, 0, 1, 1], [1, 1, 1, 1]], np.float32)  # bottom row first
    image.pixels.foreach_set(px.ravel())
    m, _ = textured_material("painted", image, socket="Color", shader="ShaderNodeBsdfDiffuse")
    rough = bpy.data.images.load(quadrants(tmp_path / "r.png"))
    rough.colorspace_settings.name = "Non-Color"
    m2, _ = textured_material("rough", rough, socket="Roughness")
    plane_under_white_sky(blank, m)
    bpy.ops.mesh.primitive_cube_add(location=(0, 0, 1))
    bpy.context.object.data.materials.append(m2)
    exported = export_scene(depsgraph())
    bitmap = exported.scene["Plane"]["bsdf"]["reflectance"]
    assert bitmap["data"].dtype == np.uint8
    np.testing.assert_array_equal(bitmap["data"][0], [[0, 0, 255], [255, 255, 255]])  # Blender's top row
    roughness = exported.scene["Cube"]["bsdf"]["roughness"]
    assert roughness["raw"] is True and roughness["filename"].endswith("r.png")
    assert exported.scene["Cube"]["uvs"].shape == (len(exported.scene["Cube"]["positions"]), 2)
    memory = volpath.render(volpath.load_dict(exported.scene), spp=2, seed=1, threads=1)
    written = volpath.render(volpath.load_file(write_directory(exported, tmp_path / "out")), spp=2, seed=1, threads=1)
    np.testing.assert_array_equal(memory, written)
    assert np.all(np.isfinite(memory))


def test_sampling_settings_and_uv_maps(blank, tmp_path):
    image = bpy.data.images.load(quadrants(tmp_path / "q.png"))
    m, tex = textured_material("closest", image)
    tex.interpolation, tex.extension = "Closest", "EXTEND"
    add_mapping(m, tex, scale=(2, 2, 1), uv_map="second")
    plane = plane_under_white_sky(blank, m)
    plane.data.uv_layers.new(name="second")
    uv = np.array([0.5, 0.5] * len(plane.data.loops), np.float32)
    plane.data.uv_layers["second"].uv.foreach_set("vector", uv)
    exported = export_scene(depsgraph())
    bitmap = exported.scene["Plane"]["bsdf"]["base_color"]
    assert bitmap["filter_type"] == "nearest" and bitmap["wrap_mode"] == "clamp"
    # u' = 2u; v' = 1 - 2(1 - v) in the scene's flipped frame.
    np.testing.assert_allclose(bitmap["to_uv"], [[2, 0, 0], [0, 2, -1], [0, 0, 1]], atol=1e-12)
    np.testing.assert_allclose(exported.scene["Plane"]["uvs"], 0.5)  # the named map, not the render one
    tex.projection = "BOX"
    exported = export_scene(depsgraph())
    assert any("BOX projection" in w for w in exported.warnings)


def test_unsupported_texture_inputs_warn(blank, tmp_path):
    image = bpy.data.images.load(quadrants(tmp_path / "q.png"))
    m, tex = textured_material("alpha", image, socket="Metallic")
    plane_under_white_sky(blank, m)
    warnings = export_scene(depsgraph()).warnings
    assert any("'Metallic'" in w and "driven by nodes" in w for w in warnings)


def test_a_missing_image_file_is_an_error_naming_it(blank, tmp_path):
    from addon.export import ExportError

    path = quadrants(tmp_path / "gone.png")
    image = bpy.data.images.load(path)
    m, _ = textured_material("gone", image)
    plane_under_white_sky(blank, m)
    image.filepath = str(tmp_path / "elsewhere.png")
    with pytest.raises(ExportError, match="image 'gone.png' has no pixels"):
        export_scene(depsgraph())
