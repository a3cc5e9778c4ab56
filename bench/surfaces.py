"""Surfaces beside Cycles 5.0 (issue #62 part 4): scenes without media, rendered by both
through Blender's F12 (export or sync included) on the same machine and threads in one
run, no denoising on either side. Each renderer is measured against its own reference
(REF_SPP, same settings) by the display RMSE (volpath.tonemap.display, at the exposure
that suits Cycles' reference); the figure is the time to TARGET, interpolated in log-log
over the ladder (cycles_sunrise.time_to). A second table takes the first scene apart:
the display error at 64 spp with each of its three lights alone and together.

    python bench/surfaces.py [--res 96x72] [--only NAME] [--append bench/RESULTS.md]
"""

import argparse
import math
import os
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "tests"))
import cycles_sunrise  # noqa: E402  (bench/)
from cycles_sunrise import THREADS  # noqa: E402
from publish import publish  # noqa: E402

REF_SPP = 1024
LADDER = (16, 64, 256)
TARGET = 0.01  # display RMSE, 0..1
LIGHTS = ("area", "sun", "world")


def _object(bpy, add, material, smooth=False, **kwargs):
    add(**kwargs)
    if smooth:
        bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(material)
    return bpy.context.object


def lit_floor(bpy, scene, directory, lights=LIGHTS):
    """The issue's scene: an image-textured floor, a gold sphere, a bump-mapped cube and a
    Mix of Diffuse and Glossy, lit by an area lamp, a sun and a grey world."""
    from blender_scenes import add_camera, material, set_background

    ops = bpy.ops.mesh
    floor = material("tiles")
    image = bpy.data.images.new("tiles", 16, 16)
    u, v = np.meshgrid(np.arange(16), np.arange(16))
    texels = np.where(((u // 2 + v // 2) % 2 == 0)[..., None], [0.7, 0.65, 0.6, 1.0], [0.25, 0.3, 0.35, 1.0])
    image.pixels.foreach_set(texels.astype(np.float32).ravel())
    image.pack()
    tex = floor.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    floor.node_tree.links.new(tex.outputs["Color"], floor.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    _object(bpy, ops.primitive_plane_add, floor, size=12)
    gold = material("gold", Base_Color=(0.9, 0.6, 0.2, 1), Metallic=1.0, Roughness=0.3)
    _object(bpy, ops.primitive_uv_sphere_add, gold, True, radius=0.7, location=(-1.5, 0.5, 0.7), segments=48)
    bumpy = material("bumpy", Base_Color=(0.3, 0.5, 0.8, 1), Roughness=0.5)
    bump = bumpy.node_tree.nodes.new("ShaderNodeBump")
    heights = bumpy.node_tree.nodes.new("ShaderNodeTexImage")
    heights.image = bpy.data.images.load(os.path.join(ROOT, "tests", "scenes", "ripples.png"))
    heights.image.colorspace_settings.name = "Non-Color"
    bumpy.node_tree.links.new(heights.outputs["Color"], bump.inputs["Height"])
    bumpy.node_tree.links.new(bump.outputs["Normal"], bumpy.node_tree.nodes["Principled BSDF"].inputs["Normal"])
    _object(bpy, ops.primitive_cube_add, bumpy, size=1.2, location=(0.3, 0.8, 0.6), rotation=(0, 0, 0.5))
    mix = bpy.data.materials.new("mix")
    tree = mix.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    diffuse, glossy = tree.nodes.new("ShaderNodeBsdfDiffuse"), tree.nodes.new("ShaderNodeBsdfGlossy")
    diffuse.inputs["Color"].default_value = (0.8, 0.2, 0.2, 1)
    glossy.inputs["Roughness"].default_value = 0.2
    node = tree.nodes.new("ShaderNodeMixShader")
    node.inputs["Fac"].default_value = 0.3
    tree.links.new(diffuse.outputs[0], node.inputs[1]), tree.links.new(glossy.outputs[0], node.inputs[2])
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    _object(bpy, ops.primitive_uv_sphere_add, mix, True, radius=0.6, location=(1.6, -0.2, 0.6), segments=48)
    add_camera(scene, location=(0, -6, 3.2), rotation=(math.radians(62), 0, 0))
    if "area" in lights:
        bpy.ops.object.light_add(type="AREA", location=(1.5, -1, 3.5), rotation=(0.3, 0.3, 0))
        bpy.context.object.data.energy, bpy.context.object.data.size = 300, 1.0
    if "sun" in lights:
        bpy.ops.object.light_add(type="SUN", rotation=(0.7, -0.3, 0.4))
        bpy.context.object.data.energy = 2.5
    set_background(scene, (0.3, 0.3, 0.3) if "world" in lights else (0, 0, 0))


def _room(bpy, size, colours, skip=()):
    """A box room from planes facing inward: floor, ceiling, back, left, right, front."""
    from blender_scenes import material

    half = size / 2
    walls = {
        "floor": ((0, 0, 0), (0, 0, 0)),
        "ceiling": ((0, 0, size), (math.pi, 0, 0)),
        "back": ((0, half, half), (math.pi / 2, 0, 0)),
        "left": ((-half, 0, half), (0, math.pi / 2, 0)),
        "right": ((half, 0, half), (0, -math.pi / 2, 0)),
        "front": ((0, -half, half), (-math.pi / 2, 0, 0)),
    }
    for name, (location, rotation) in walls.items():
        if name in skip:
            continue
        bpy.ops.mesh.primitive_plane_add(size=size, location=location, rotation=rotation)
        colour = colours.get(name, (0.7, 0.7, 0.7))
        bpy.context.object.data.materials.append(material(name, Base_Color=(*colour, 1), Specular_IOR_Level=0.0))


def cornell(bpy, scene, directory):
    """A Cornell-box-like room lit by one small area lamp under its ceiling."""
    from blender_scenes import add_camera, material, set_background

    _room(bpy, 4, {"left": (0.65, 0.1, 0.1), "right": (0.1, 0.55, 0.15)}, skip=("front",))
    white = material("box", Base_Color=(0.75, 0.75, 0.75, 1), Specular_IOR_Level=0.0)
    _object(bpy, bpy.ops.mesh.primitive_cube_add, white, size=1.2, location=(-0.6, 0.6, 1.2), scale=(1, 1, 2))
    _object(bpy, bpy.ops.mesh.primitive_cube_add, white, size=1.1, location=(0.7, -0.4, 0.55), rotation=(0, 0, 0.3))
    bpy.ops.object.light_add(type="AREA", location=(0, 0, 3.98))
    bpy.context.object.data.energy, bpy.context.object.data.size = 60, 0.5
    add_camera(scene, location=(0, -7.5, 2), rotation=(math.pi / 2, 0, 0))
    scene.camera.data.lens = 35
    set_background(scene, (0, 0, 0))


def window(bpy, scene, directory):
    """An interior lit through a window by a sun and a blue sky (a constant world): a room
    whose right wall has an opening."""
    from blender_scenes import add_camera, material, set_background

    _room(bpy, 4, {"floor": (0.5, 0.4, 0.3)}, skip=("right", "front"))
    wall = material("wall", Base_Color=(0.7, 0.7, 0.7, 1), Specular_IOR_Level=0.0)
    for z, height in ((0.5, 1.0), (3.5, 1.0)):  # below and above the window
        _object(bpy, bpy.ops.mesh.primitive_cube_add, wall, size=1, location=(2.05, 0, z), scale=(0.1, 4, height))
    for y in (-1.5, 1.5):  # beside it
        _object(bpy, bpy.ops.mesh.primitive_cube_add, wall, size=1, location=(2.05, y, 2), scale=(0.1, 1, 2))
    chair = material("chair", Base_Color=(0.6, 0.3, 0.1, 1), Roughness=0.4)
    _object(bpy, bpy.ops.mesh.primitive_cube_add, chair, size=0.8, location=(-0.5, 0.5, 0.4))
    bpy.ops.object.light_add(type="SUN", rotation=(0, math.radians(-55), math.radians(10)))
    bpy.context.object.data.energy = 4
    add_camera(scene, location=(-0.5, -3.8, 1.8), rotation=(math.radians(85), 0, math.radians(-20)))
    scene.camera.data.lens = 20
    set_background(scene, (0.35, 0.5, 0.9))


def hdri(bpy, scene, directory):
    """An HDRI-lit set of glossy and diffuse objects (tests/parity_scenes.py's)."""
    from parity_scenes import environment_texture

    environment_texture(scene, directory)


SCENES = {"lit floor": lit_floor, "Cornell box": cornell, "window": window, "HDRI": hdri}


def render(bpy, volpath, scene, engine, spp, seed, tmp):
    """One F12 at `spp`: (linear image, seconds of the render call)."""
    if engine == "CYCLES":
        c = scene.cycles
        c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 8
        c.sample_clamp_direct = c.sample_clamp_indirect = 0
        c.blur_glossy = 0.0
        c.pixel_filter_type, c.filter_width = "BOX", 1.0
        return cycles_sunrise.render_cycles(bpy, volpath, scene, scene.frame_current, tmp, spp, seed)
    scene.render.engine = "VOLPATH"
    scene.volpath.spp, scene.volpath.seed, scene.volpath.threads, scene.volpath.max_depth = spp, seed, THREADS, 10
    return cycles_sunrise.f12(bpy, volpath, scene, os.path.join(tmp, "volpath.exr"))


def measure(bpy, volpath, scene, tmp, ladder=LADDER):
    """{engine: (seconds to TARGET, [(seconds, display RMSE, spp)])}, at the exposure that
    suits Cycles' reference."""
    from volpath.tonemap import auto_exposure, display

    references = {e: render(bpy, volpath, scene, e, REF_SPP, 1, tmp)[0] for e in ("CYCLES", "VOLPATH")}
    exposure = auto_exposure(references["CYCLES"])
    out = {}
    for engine, reference in references.items():
        shown = display(reference, exposure)
        points = []
        for spp in ladder:
            image, seconds = render(bpy, volpath, scene, engine, spp, 2, tmp)
            points.append((seconds, float(np.sqrt(np.mean((display(image, exposure) - shown) ** 2))), spp))
        out[engine] = (cycles_sunrise.time_to(points)[0] if len(points) > 1 else None, points)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", default="96x72")
    ap.add_argument("--only")
    ap.add_argument("--append")
    args = ap.parse_args()
    import bpy
    from blender_scenes import blank_scene

    import volpath

    cycles_sunrise.TARGET = TARGET

    def fresh():
        scene = blank_scene()
        scene.render.resolution_x, scene.render.resolution_y = map(int, args.res.split("x"))
        return scene

    rows, ratios = [], []
    for name, build in SCENES.items():
        if args.only and name != args.only:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            scene = fresh()
            build(bpy, scene, tmp)
            m = measure(bpy, volpath, scene, tmp)
        (tv, pv), (tc, pc) = m["VOLPATH"], m["CYCLES"]
        ratio = tv / tc if tv and tc else float("nan")
        ratios.append(ratio)
        ladder = "; ".join(
            f"{spp} spp {ev:.4f} in {sv:.2f} s / {ec:.4f} in {sc:.2f} s" for (sv, ev, spp), (sc, ec, _) in zip(pv, pc)
        )
        rows.append(
            f"| {name} | {tv or float('nan'):.2f} s | {tc or float('nan'):.2f} s | **{ratio:.2f}x** | {ladder} |"
        )
        print(rows[-1], flush=True)
    parts = []
    if not args.only or args.only == "lights":
        for lights in [(k,) for k in LIGHTS] + [LIGHTS]:
            with tempfile.TemporaryDirectory() as tmp:
                scene = fresh()
                lit_floor(bpy, scene, tmp, lights)
                m = measure(bpy, volpath, scene, tmp, ladder=(64,))
            ev, ec = m["VOLPATH"][1][0][1], m["CYCLES"][1][0][1]
            parts.append(f"| {' + '.join(lights)} | {ev:.4f} | {ec:.4f} | **{ev / ec:.2f}x** |")
            print(parts[-1], flush=True)
    publish(
        "\n## Surfaces beside Cycles (issue #62 part 4; `bench/surfaces.py`)\n\n"
        f"Scenes without media at {args.res}, both through F12 at {THREADS} threads, one run on this machine, "
        f"no denoising; each renderer against its own {REF_SPP}-spp reference; time to a display RMSE of "
        f"{TARGET} (tone-mapped at the exposure of Cycles' reference; log-log over the ladder). Volpath at "
        "max depth 10, Cycles at 8 bounces, clamping and Filter Glossy off.\n\n"
        "| scene | Volpath | Cycles 5.0 | Volpath / Cycles | ladder: Volpath / Cycles (display RMSE, time) |\n"
        "|---|---|---|---|---|\n"
        + "\n".join(rows)
        + "\n\nThe lit floor taken apart: display RMSE at 64 spp with each light alone and together.\n\n"
        "| lights | Volpath | Cycles 5.0 | Volpath / Cycles |\n|---|---|---|---|\n" + "\n".join(parts) + "\n",
        args.append,
        key="surfaces",
    )


if __name__ == "__main__":
    main()
