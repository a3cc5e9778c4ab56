"""The caustic under a glass sphere (issue #38, item 3): Volpath, Cycles 5.0 and Mitsuba 3
on one scene built in Blender and exported by the add-on.

A diffuse floor, a smooth glass sphere (IOR 1.45) resting on it, an area light of 300 W
above, a black world; the camera looks down at the floor. Each renderer renders the exported
scene (Mitsuba reads the exported scene.xml, with Volpath's own `hidden_from` and null
BSDF on the light and its null-collision cap dropped: there the light quad is an
occluder, which changes nothing the floor sees). Cycles renders twice: with its default Filter Glossy (1.0, which blurs
caustics) and with 0. Prints the mean of the caustic's brightest 8x8 block and of the ring
of blocks around it, each renderer's ratio to Mitsuba's.

    .venv/bin/python bench/caustic.py [--spp 4096] [--out bench/cache/caustic]
"""

import argparse
import os
import re
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path[:0] = [ROOT, os.path.join(ROOT, "tests")]


def build_scene():
    import bpy
    from blender_scenes import add_camera, blank_scene, set_background

    scene = blank_scene()
    scene.render.resolution_x, scene.render.resolution_y = 96, 72
    bpy.ops.mesh.primitive_plane_add(size=8)
    floor = bpy.data.materials.new("floor")
    floor.node_tree.nodes["Principled BSDF"].inputs["Specular IOR Level"].default_value = 0.0
    bpy.context.object.data.materials.append(floor)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(0, 0, 0.5), segments=128, ring_count=64)
    bpy.ops.object.shade_smooth()
    glass = bpy.data.materials.new("glass")
    tree = glass.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    node = tree.nodes.new("ShaderNodeBsdfGlass")
    node.inputs["IOR"].default_value, node.inputs["Roughness"].default_value = 1.45, 0.0
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    bpy.context.object.data.materials.append(glass)
    bpy.ops.object.light_add(type="AREA", location=(0.6, 0, 3))
    bpy.context.object.data.energy, bpy.context.object.data.size = 300, 0.5
    add_camera(scene, location=(0, -2.2, 3.2), rotation=(0.62, 0, 0))
    set_background(scene, (0, 0, 0), strength=0.0)
    return scene


def blocks(img, block=8):
    h, w = img.shape[0] // block, img.shape[1] // block
    return img[: h * block, : w * block].mean(axis=2).reshape(h, block, w, block).mean(axis=(1, 3))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--out", default=os.path.join(ROOT, "bench", "cache", "caustic"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    import bpy

    import volpath
    from addon.export import export_scene, write_directory

    scene = build_scene()
    exported = export_scene(bpy.context.evaluated_depsgraph_get())
    xml = write_directory(exported, os.path.join(args.out, "scene"))
    images, times = {}, {}

    start = time.perf_counter()
    images["volpath"] = volpath.render(volpath.load_file(xml), spp=args.spp, seed=1, tracer="nee_mis")
    times["volpath"] = time.perf_counter() - start

    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.samples, c.use_denoising, c.device, c.use_adaptive_sampling = args.spp, False, "CPU", False
    c.max_bounces = c.transmission_bounces = c.glossy_bounces = c.diffuse_bounces = 32
    c.caustics_reflective = c.caustics_refractive = True
    c.sample_clamp_direct = c.sample_clamp_indirect = 0
    scene.render.image_settings.file_format, scene.render.image_settings.color_depth = "OPEN_EXR", "32"
    for blur in (1.0, 0.0):
        c.blur_glossy = blur
        scene.render.filepath = os.path.join(args.out, f"cycles_{blur:g}.exr")
        start = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        times[f"cycles (filter glossy {blur:g})"] = time.perf_counter() - start
        images[f"cycles (filter glossy {blur:g})"] = volpath.read_exr(scene.render.filepath)[..., :3]

    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    with open(xml) as f:
        text = f.read()
    text = re.sub(r'\s*<string name="hidden_from" value="[^"]*"\s*/>', "", text)
    text = re.sub(r'\s*<bsdf type="null"\s*/>', "", text)
    text = re.sub(r'\s*<integer name="max_null_collisions" value="[^"]*"\s*/>', "", text)
    mitsuba_xml = os.path.join(os.path.dirname(xml), "scene_mitsuba.xml")
    with open(mitsuba_xml, "w") as f:
        f.write(text)
    start = time.perf_counter()
    images["mitsuba"] = np.asarray(mi.render(mi.load_file(mitsuba_xml), spp=args.spp, seed=1))[..., :3]
    times["mitsuba"] = time.perf_counter() - start

    reference = blocks(images["mitsuba"])
    i, j = np.unravel_index(np.argmax(reference), reference.shape)
    ring = [(a, b) for a in (i - 1, i, i + 1) for b in (j - 1, j, j + 1) if (a, b) != (i, j)]
    ring = [(a, b) for a, b in ring if 0 <= a < reference.shape[0] and 0 <= b < reference.shape[1]]
    print(f"{args.spp} spp at 96x72; the caustic's block ({i}, {j}) and the {len(ring)} around it")
    print(f"{'renderer':28s} {'peak':>9s} {'ratio':>6s} {'ring':>9s} {'ratio':>6s} {'image':>9s} {'time':>7s}")
    ring_ref = np.mean([reference[a, b] for a, b in ring])
    for name, img in images.items():
        b = blocks(img)
        ring_mean = np.mean([b[a, c] for a, c in ring])
        print(
            f"{name:28s} {b[i, j]:9.4f} {b[i, j] / reference[i, j]:6.3f} {ring_mean:9.4f} {ring_mean / ring_ref:6.3f}"
            f" {img.mean():9.4f} {times[name]:6.1f}s"
        )
        np.save(os.path.join(args.out, f"{name.split()[0]}_{len(name)}.npy"), img)


if __name__ == "__main__":
    main()
