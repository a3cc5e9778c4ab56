"""Volpath against Cycles 5.0 on the default sunrise (issue #7): frames per hour at equal
error, on the same .blend, same machine, same threads, one run.

The two do not model the same sky (Cycles' Sky Texture is a precomputed radiance map and
its sun lamp is not dimmed by the air; Volpath traces the atmosphere), so each is measured
against its own reference (the same renderer at REF_SPP): the figure is the time a frame
needs to reach a relative RMSE of TARGET, read off a log-log fit of error against time.

    python bench/cycles_sunrise.py [--frame 34] [--res 160x90] [--append bench/RESULTS.md]
"""

import argparse
import os
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
TARGET = 0.05
REF_SPP = 1024
LADDER = (4, 16, 64)
THREADS = 2


def rel_rmse(img, ref):
    return float(np.sqrt(np.mean((img - ref) ** 2)) / np.mean(ref))


def time_to(points):
    """Seconds to reach TARGET from (seconds, error) points, by a log-log fit."""
    t, e = np.log([p[0] for p in points]), np.log([p[1] for p in points])
    slope, intercept = np.polyfit(t, e, 1)
    return float(np.exp((np.log(TARGET) - intercept) / slope)), float(slope)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--frame", type=int, default=34)
    ap.add_argument("--res", default="160x90")
    ap.add_argument("--append")
    args = ap.parse_args()
    import bpy

    import addon
    import volpath
    from pipeline.export import export_animation
    from volpath.frames import render_frame

    addon.register()
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "scenes", "sunrise", "sunrise.blend"))
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = map(int, args.res.split("x"))
    scene.render.resolution_percentage = 100
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        animation = os.path.join(tmp, "scene")
        export_animation(scene, [args.frame], animation)

        def volpath_render(spp, seed):
            start = time.perf_counter()
            image, _ = render_frame(animation, args.frame, spp, tracer="null_scattering", seed=seed, threads=THREADS)
            return image, time.perf_counter() - start

        def cycles_render(spp, seed):
            scene.render.engine = "CYCLES"
            c = scene.cycles
            c.device, c.samples, c.seed = "CPU", spp, seed
            c.use_denoising, c.use_adaptive_sampling = False, False
            c.volume_bounces = 16  # Volpath's paths are unlimited; Cycles' default is single scattering
            scene.render.threads_mode, scene.render.threads = "FIXED", THREADS
            scene.frame_set(args.frame)
            scene.render.image_settings.file_format = "OPEN_EXR"
            scene.render.image_settings.color_depth = "32"
            scene.render.filepath = os.path.join(tmp, "cycles.exr")
            start = time.perf_counter()
            bpy.ops.render.render(write_still=True)
            seconds = time.perf_counter() - start
            return volpath.read_exr(scene.render.filepath)[..., :3], seconds

        for name, fn in (("Volpath", volpath_render), ("Cycles 5.0", cycles_render)):
            fn(4, 99)  # warm-up: kernels, BVH, caches
            reference, ref_seconds = fn(REF_SPP, 12345)
            points = []
            for spp in LADDER:
                image, seconds = fn(spp, spp)
                points.append((seconds, rel_rmse(image, reference), spp))
            results[name] = (time_to(points), points, ref_seconds)
    rows = []
    best_other = results["Cycles 5.0"][0][0]
    for name, ((t, slope), points, ref_seconds) in results.items():
        ladder = "; ".join(f"{spp} spp: {s:.2f} s, {e:.3f}" for s, e, spp in points)
        rows.append(f"| {name} | {t:.2f} s | {3600 / t:.0f} | t^{slope:.2f} | {t / best_other:.2f}x | {ladder} |")
    section = (f"\n## Sunrise frame: Volpath against Cycles (issue #7; `bench/cycles_sunrise.py`)\n\n"
               f"Frame {args.frame} of the default sunrise at {args.res}, {THREADS} threads, each renderer "
               f"against its own {REF_SPP}-spp reference (their skies differ: Cycles' Sky Texture is a "
               f"precomputed map with an undimmed sun lamp, Volpath traces the atmosphere). Time per frame "
               f"to a relative RMSE of {TARGET:.0%}, from a log-log fit over {', '.join(map(str, LADDER))} spp.\n\n"
               "| renderer | seconds per frame | frames per hour | error vs time | time / Cycles | ladder (spp: seconds, rel. RMSE) |\n"
               "|---|---|---|---|---|---|\n" + "\n".join(rows) + "\n")
    print(section)
    if args.append:
        with open(args.append, "a") as f:
            f.write(section)


if __name__ == "__main__":
    main()
