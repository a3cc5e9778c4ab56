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
    m, tex = textured_material("refracting", image, socket="IOR")
    plane_under_white_sky(blank, m)
    warnings = export_scene(depsgraph()).warnings
    assert any("'IOR'" in w and "driven by nodes" in w for w in warnings)


def test_an_image_on_emission_color_is_an_emission_map(blank, tmp_path):
    """Emission Color from an image: the plane's area emitter takes the bitmap as its
    radiance, times Emission Strength, and the mesh keeps its UVs (tests/parity_scenes.py's
    "emission map" renders it beside Cycles)."""
    image = bpy.data.images.load(quadrants(tmp_path / "q.png"))
    m, tex = textured_material("glowing", image, socket="Emission Color")
    m.node_tree.nodes["Principled BSDF"].inputs["Emission Strength"].default_value = 3.0
    plane_under_white_sky(blank, m)
    shape = export_scene(depsgraph()).scene["Plane"]
    assert shape["emitter"]["radiance"]["type"] == "bitmap"
    assert shape["emitter"]["scale"]["value"] == pytest.approx([3.0] * 3)
    assert shape["uvs"].shape == (len(shape["positions"]), 2)


def test_an_images_alpha_output_makes_a_mask(blank):
    """Alpha from the image's Alpha output: a one-channel raw bitmap of the alpha, rows top
    first, as the mask's opacity."""
    image = bpy.data.images.new("leaf", 2, 2, alpha=True)
    image.pixels.foreach_set(np.array([1, 1, 1, 0.0] * 2 + [1, 1, 1, 1.0] * 2, np.float32))  # bottom row clear
    m, bsdf = principled("leaf")
    tex = m.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    m.node_tree.links.new(tex.outputs["Alpha"], bsdf.inputs["Alpha"])
    plane_under_white_sky(blank, m)
    mask = export_scene(depsgraph()).scene["Plane"]["bsdf"]
    assert mask["type"] == "mask" and mask["surface"]["type"] == "principled"
    opacity = mask["opacity"]
    assert opacity["raw"] and opacity["data"].shape == (2, 2, 1)
    np.testing.assert_array_equal(opacity["data"][:, :, 0], [[255, 255], [0, 0]])


def test_a_missing_image_file_is_an_error_naming_it(blank, tmp_path):
    from addon.export import ExportError

    path = quadrants(tmp_path / "gone.png")
    image = bpy.data.images.load(path)
    m, _ = textured_material("gone", image)
    plane_under_white_sky(blank, m)
    image.filepath = str(tmp_path / "elsewhere.png")
    with pytest.raises(ExportError, match="image 'gone.png' has no pixels"):
        export_scene(depsgraph())


def generated_image(name, rgb, size=4, non_colour=True):
    """A size x size image of one colour made in Blender (no file), Non-Color by default."""
    image = bpy.data.images.new(name, size, size)
    if non_colour:  # before the pixels: a new colour space regenerates them
        image.colorspace_settings.name = "Non-Color"
    image.pixels.foreach_set(np.tile([*rgb, 1.0], size * size).astype(np.float32))
    image.pack()  # Cycles reads a generated image's pixels once they are packed
    return image


def principled(name, **inputs):
    m = bpy.data.materials.new(name)
    bsdf = m.node_tree.nodes["Principled BSDF"]
    for k, v in inputs.items():
        bsdf.inputs[k.replace("_", " ")].default_value = v
    return m, bsdf


def four_panels(scene):
    """Four planes seen from above under a sun and a dim white world: a metal, a Mix Shader,
    a normal-mapped diffuse (tilted 30 degrees toward +x) and a half-transparent white."""
    metal, _ = principled("metal", Base_Color=(0.9, 0.6, 0.2, 1), Metallic=1.0, Roughness=0.3)
    mix = bpy.data.materials.new("mix")
    tree = mix.node_tree
    out = tree.nodes["Material Output"]
    red, blue = tree.nodes.new("ShaderNodeBsdfDiffuse"), tree.nodes["Principled BSDF"]
    red.inputs["Color"].default_value = (0.8, 0.1, 0.1, 1)
    blue.inputs["Base Color"].default_value = (0.1, 0.2, 0.8, 1)
    node = tree.nodes.new("ShaderNodeMixShader")
    node.inputs["Fac"].default_value = 0.3
    tree.links.new(red.outputs[0], node.inputs[1])
    tree.links.new(blue.outputs[0], node.inputs[2])
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    tilted = (0.5 + 0.5 * np.sin(np.pi / 6), 0.5, 0.5 + 0.5 * np.cos(np.pi / 6))
    bumpy, tex = textured_material("normals", generated_image("n", tilted), "Color", "ShaderNodeBsdfDiffuse")
    tree = bumpy.node_tree
    diffuse = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    normal_map = tree.nodes.new("ShaderNodeNormalMap")
    for link in list(tex.outputs["Color"].links):
        tree.links.remove(link)
    diffuse.inputs["Color"].default_value = (0.7, 0.7, 0.7, 1)
    tree.links.new(tex.outputs["Color"], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs["Normal"], diffuse.inputs["Normal"])
    glassy, _ = principled("half", Base_Color=(1, 1, 1, 1), Alpha=0.5)
    for material, (x, y) in zip((metal, mix, bumpy, glassy), ((-1, 1), (1, 1), (-1, -1), (1, -1))):
        bpy.ops.mesh.primitive_plane_add(size=1.8, location=(x, y, 0))
        bpy.context.object.data.materials.append(material)
    add_camera(scene, location=(0, 0, 8), rotation=(0, 0, 0))
    set_background(scene, (1, 1, 1), strength=0.3)
    bpy.ops.object.light_add(type="SUN", rotation=(0, np.radians(40), 0))
    bpy.context.object.data.energy = 3
    bpy.context.object.data.angle = 0


def test_shaders_mixes_alpha_and_normal_maps_match_cycles(blank, tmp_path):
    """Each panel's mean within 5 % of Cycles' (both 64 spp, no denoising), away from the
    panels' edges. The sun shines from 40 degrees toward +x, so the normal map's tilt
    changes the diffuse panel's brightness by a quarter; alpha shows the world through."""
    four_panels(blank)
    exported = export_scene(depsgraph())
    kinds = {k: v["bsdf"]["type"] for k, v in exported.scene.items() if isinstance(v, dict) and "bsdf" in v}
    assert sorted(kinds.values()) == ["blendbsdf", "mask", "normalmap", "principled"], kinds
    normal_map = next(
        v["bsdf"] for v in exported.scene.values() if isinstance(v, dict) and "normalmap" in v.get("bsdf", {})
    )
    assert normal_map["normalmap"]["raw"] and normal_map["surface"]["type"] == "diffuse"
    memory = volpath.render(volpath.load_dict(exported.scene), spp=2, seed=1, threads=1)
    written = volpath.load_file(write_directory(exported, tmp_path / "out"))
    np.testing.assert_array_equal(volpath.render(written, spp=2, seed=1, threads=1), memory)
    blank.render.resolution_x = blank.render.resolution_y = 48
    blank.volpath.spp = 64
    ours = render_f12(blank, tmp_path / "volpath.exr")
    blank.render.engine = "CYCLES"
    blank.cycles.samples, blank.cycles.use_denoising, blank.cycles.device = 64, False, "CPU"
    cycles = render_f12(blank, tmp_path / "cycles.exr")
    for rows in (slice(8, 20), slice(28, 40)):
        for cols in (slice(8, 20), slice(28, 40)):
            a, c = ours[rows, cols].mean(axis=(0, 1)), cycles[rows, cols].mean(axis=(0, 1))
            np.testing.assert_allclose(a, c, rtol=0.05, err_msg=f"panel at rows {rows}, columns {cols}")


def test_bump_over_a_normal_map_nests_both(blank, tmp_path):
    """Bump (Height from an image, Distance 0.2, inverted) whose Normal input is a Normal
    Map: bumpmap(normalmap(principled)); the scene renders finite, and written as XML to
    the same bits."""
    m, _ = principled("bumpy")
    tree = m.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    heights, normals = tree.nodes.new("ShaderNodeTexImage"), tree.nodes.new("ShaderNodeTexImage")
    heights.image = generated_image("h", (0.2, 0.2, 0.2))
    normals.image = generated_image("nm", (0.5, 0.5, 1.0))
    bump, normal_map = tree.nodes.new("ShaderNodeBump"), tree.nodes.new("ShaderNodeNormalMap")
    bump.inputs["Distance"].default_value, bump.invert = 0.2, True
    tree.links.new(heights.outputs["Color"], bump.inputs["Height"])
    tree.links.new(normals.outputs["Color"], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs["Normal"], bump.inputs["Normal"])
    tree.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    plane_under_white_sky(blank, m)
    exported = export_scene(depsgraph())
    outer = exported.scene["Plane"]["bsdf"]
    assert outer["type"] == "bumpmap" and outer["scale"] == pytest.approx(-0.2)
    assert outer["surface"]["type"] == "normalmap" and outer["surface"]["surface"]["type"] == "principled"
    img = volpath.render(volpath.load_dict(exported.scene), spp=2, seed=1, threads=1)
    assert np.all(np.isfinite(img)) and img.mean() > 0
    written = volpath.load_file(write_directory(exported, tmp_path / "out"))
    np.testing.assert_array_equal(volpath.render(written, spp=2, seed=1, threads=1), img)
