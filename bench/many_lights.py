"""Many lights beside Cycles 5.0 (issue #58 part 2): a floor with a few boxes lit by N small
sphere lamps (Radius 5 cm, hidden from the camera) scattered 2.5-3.5 m above it, the same
total power for every N (so that the converged images are alike in detail), rendered by
both through F12 at 96x72 (export or sync included), each against its own reference;
time to a display RMSE of 0.01 (bench/surfaces.py's measure). Volpath chooses among the
lamps through its light tree past 16 local lights (native/include/volpath/light_sampler.h),
Cycles through its own.

    python bench/many_lights.py [--counts 10 1000] [--append bench/RESULTS.md]
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
import surfaces  # noqa: E402  (bench/)
from publish import publish  # noqa: E402

TOTAL_POWER = 3000.0  # W, shared by the lamps


def build(bpy, scene, count):
    from blender_scenes import add_camera, material, set_background

    bpy.ops.mesh.primitive_plane_add(size=16)
    bpy.context.object.data.materials.append(material("floor", Base_Color=(0.6, 0.6, 0.6, 1)))
    box = material("box", Base_Color=(0.7, 0.4, 0.2, 1), Roughness=0.4)
    rng = np.random.default_rng(7)
    for x, y in rng.uniform(-5, 5, size=(6, 2)):
        bpy.ops.mesh.primitive_cube_add(size=1, location=(x, y, 0.5))
        bpy.context.object.data.materials.append(box)
    lamp = bpy.data.lights.new("lamp", "POINT")
    lamp.energy, lamp.shadow_soft_size = TOTAL_POWER / count, 0.05
    for k, (x, y, z) in enumerate(np.column_stack([rng.uniform(-7, 7, (count, 2)), rng.uniform(2.5, 3.5, count)])):
        obj = bpy.data.objects.new(f"lamp {k}", lamp)
        obj.location, obj.visible_camera = (x, y, z), False
        scene.collection.objects.link(obj)
    add_camera(scene, location=(0, -11, 7), rotation=(math.radians(58), 0, 0))
    set_background(scene, (0, 0, 0))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--counts", type=int, nargs="+", default=[10, 1000])
    ap.add_argument("--res", default="96x72")
    ap.add_argument("--append")
    args = ap.parse_args()
    import bpy
    from blender_scenes import blank_scene

    import volpath

    surfaces.cycles_sunrise.TARGET = surfaces.TARGET
    rows, times = [], {}
    for count in args.counts:
        with tempfile.TemporaryDirectory() as tmp:
            scene = blank_scene()
            scene.render.resolution_x, scene.render.resolution_y = map(int, args.res.split("x"))
            build(bpy, scene, count)
            m = surfaces.measure(bpy, volpath, scene, tmp)
        times[count] = {e: t for e, (t, _) in m.items()}
        ladder = "; ".join(
            f"{spp} spp {ev:.4f} in {sv:.2f} s / {ec:.4f} in {sc:.2f} s"
            for (sv, ev, spp), (sc, ec, _) in zip(m["VOLPATH"][1], m["CYCLES"][1])
        )
        tv, tc = times[count]["VOLPATH"], times[count]["CYCLES"]
        rows.append(f"| {count} | {tv:.2f} s | {tc:.2f} s | **{tv / tc:.2f}x** | {ladder} |")
        print(rows[-1], flush=True)
    few, many = min(args.counts), max(args.counts)
    scaling = {e: times[many][e] / times[few][e] for e in ("VOLPATH", "CYCLES")}
    publish(
        "\n## Many lights beside Cycles (issue #58 part 2; `bench/many_lights.py`)\n\n"
        f"A floor with six boxes lit by N sphere lamps 2.5-3.5 m above it (Radius 5 cm, hidden from the camera, "
        f"{TOTAL_POWER:g} W shared), {args.res}, both "
        f"through F12 at {surfaces.THREADS} threads, one run on this machine, each renderer against its own "
        f"{surfaces.REF_SPP}-spp reference; time to a display RMSE of {surfaces.TARGET}.\n\n"
        "| lamps | Volpath | Cycles 5.0 | Volpath / Cycles | ladder: Volpath / Cycles (display RMSE, time) |\n"
        "|---|---|---|---|---|\n"
        + "\n".join(rows)
        + f"\n\n{many} lamps take {scaling['VOLPATH']:.2f}x the time of {few} in Volpath, "
        f"{scaling['CYCLES']:.2f}x in Cycles.\n",
        args.append,
        key="many_lights",
    )


if __name__ == "__main__":
    main()
