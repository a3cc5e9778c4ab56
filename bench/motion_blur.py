"""Motion blur's cost beside Cycles 5.0 (issue #57, part 4): a cube crossing a lit floor
(1.5 m in the frame's shutter) and a panning camera, Motion Blur on (shutter 1 frame,
centred), rendered by both through Blender's F12 (export or sync included) on the same
machine and threads in one run; and the same frame with Motion Blur off. Each renderer
is measured against its own reference (REF_SPP, same settings): the relative RMSE of the
linear image; the figure is the time to TARGET, interpolated in log-log over the ladder
(cycles_sunrise.time_to).

    python bench/motion_blur.py [--res 320x180] [--append bench/RESULTS.md]
"""

import argparse
import os
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "tests"))
import cycles_sunrise  # noqa: E402  (bench/)
from cycles_sunrise import THREADS, time_to  # noqa: E402
from publish import publish  # noqa: E402

REF_SPP = 2048
LADDER = (16, 64, 256)
FRAME = 3


def build(bpy, res):
    from blender_scenes import add_camera, blank_scene, material, set_background

    scene = blank_scene()
    scene.render.resolution_x, scene.render.resolution_y = map(int, res.split("x"))
    cam = add_camera(scene)
    bpy.ops.object.light_add(type="SUN", rotation=(0.6, 0.2, 0))
    bpy.context.object.data.energy = 3
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.context.object.data.materials.append(material("floor", Base_Color=(0.5, 0.5, 0.5, 1)))
    bpy.ops.mesh.primitive_cube_add(location=(-3, 0, 1))
    cube = bpy.context.object
    cube.data.materials.append(material("paint", Base_Color=(0.8, 0.1, 0.1, 1)))
    set_background(scene, (0.2, 0.3, 0.5))
    for frame, x in ((1, -3.0), (5, 3.0)):
        cube.location.x = x
        cube.keyframe_insert("location", frame=frame)
        cam.location.x = x / 6
        cam.keyframe_insert("location", frame=frame)
    scene.render.motion_blur_shutter, scene.render.motion_blur_position = 1.0, "CENTER"
    scene.frame_set(FRAME)
    return scene


def render(bpy, volpath, scene, engine, spp, seed, tmp):
    """One F12 at `spp`: (linear image, seconds of the render call)."""
    if engine == "CYCLES":
        return cycles_sunrise.render_cycles(bpy, volpath, scene, FRAME, tmp, spp, seed)
    scene.render.engine = "VOLPATH"
    scene.volpath.spp, scene.volpath.seed, scene.volpath.threads = spp, seed, THREADS
    return cycles_sunrise.f12(bpy, volpath, scene, os.path.join(tmp, "volpath.exr"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", default="320x180")
    ap.add_argument("--append")
    args = ap.parse_args()
    import bpy

    import volpath

    scene = build(bpy, args.res)
    rows, times = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for blur in (True, False):
            scene.render.use_motion_blur = blur
            for engine, label in (("VOLPATH", "Volpath"), ("CYCLES", "Cycles 5.0")):
                reference, _ = render(bpy, volpath, scene, engine, REF_SPP, 1, tmp)
                points = []
                for spp in LADDER:
                    image, seconds = render(bpy, volpath, scene, engine, spp, 2, tmp)
                    error = float(np.sqrt(np.mean((image - reference) ** 2)) / reference.mean())
                    points.append((seconds, error, spp))
                seconds, _ = time_to(points)
                times[blur, engine] = seconds
                ladder = ", ".join(f"{spp} spp {e:.4f} in {t:.2f} s" for t, e, spp in points)
                rows.append(f"| {label} | {'on' if blur else 'off'} | {seconds:.2f} s | {ladder} |")
    ratio = times[True, "VOLPATH"] / times[True, "CYCLES"]
    publish(
        "\n## Motion blur beside Cycles (issue #57 part 4; `bench/motion_blur.py`)\n\n"
        f"A cube crossing a lit floor and a panning camera, frame {FRAME} at {args.res}, Motion Blur on "
        f"(shutter 1 frame, centred) and off, both through F12 at {THREADS} threads, one run on this machine; "
        f"each renderer against its own {REF_SPP}-spp reference; time to a relative RMSE of "
        f"{cycles_sunrise.TARGET} of the linear image (log-log over the ladder).\n\n"
        "| renderer | motion blur | time to equal error | ladder (error, time) |\n|---|---|---|---|\n"
        + "\n".join(rows)
        + f"\n\nWith motion blur, Volpath takes {ratio:.2f}x Cycles' time to equal error.\n",
        args.append,
        key="motion_blur",
    )


if __name__ == "__main__":
    main()
