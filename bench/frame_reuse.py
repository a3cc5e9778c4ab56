"""What a sunrise frame costs besides its samples (issue #33, item 4): per frame, a worker
that keeps its scene (pipeline.frames: Scene.update moves the sun and the camera; the sky
map's levels serve while the sun stays within their elevations) against one that loads
every frame afresh, and Cycles 5.0 on the same frames; same machine, same threads, one run.
Each kept frame is checked to be the same bits as the fresh one.

    python bench/frame_reuse.py [--frames 24] [--res 160x90] [--spp 4] [--append bench/RESULTS.md]
"""

import argparse
import os
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from cycles_sunrise import THREADS, render_cycles  # noqa: E402  (bench/)
from publish import publish  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--res", default="160x90")
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--append")
    args = ap.parse_args()
    import bpy

    import addon
    import volpath
    from addon.export.animation import export_animation
    from pipeline import frames as F

    addon.register()
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "scenes", "sunrise", "sunrise.blend"))
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = map(int, args.res.split("x"))
    scene.render.resolution_percentage = 100
    first = scene.frame_start + (scene.frame_end - scene.frame_start + 1 - args.frames) // 2
    frames = list(range(first, first + args.frames))  # consecutive, around the middle
    seconds = {"kept": [], "fresh": [], "render": [], "cycles": []}
    with tempfile.TemporaryDirectory() as tmp:
        animation = os.path.join(tmp, "scene")
        export_animation(scene, frames, animation)
        F.render_frame(animation, frames[0], 1, threads=THREADS)  # the worker's first load
        for frame in frames:
            start = time.perf_counter()
            kept, metadata = F.render_frame(animation, frame, args.spp, threads=THREADS)
            seconds["kept"].append(time.perf_counter() - start)
            seconds["render"].append(metadata["render_seconds"])
            worker = F._scenes.pop(animation)
            start = time.perf_counter()
            fresh, _ = F.render_frame(animation, frame, args.spp, threads=THREADS)
            seconds["fresh"].append(time.perf_counter() - start)
            F._scenes[animation] = worker
            if not np.array_equal(kept, fresh):
                raise SystemExit(f"frame {frame}: the kept scene's image differs from a fresh load's")
            seconds["cycles"].append(render_cycles(bpy, volpath, scene, frame, tmp, args.spp, frame)[1])
    mean = {k: float(np.mean(v)) for k, v in seconds.items()}
    rows = [
        f"| Volpath, scene kept by the worker | {mean['kept']:.2f} s | {mean['kept'] - mean['render']:.2f} s | "
        f"{mean['kept'] / mean['cycles']:.2f}x |",
        f"| Volpath, scene loaded every frame | {mean['fresh']:.2f} s | {mean['fresh'] - mean['render']:.2f} s | "
        f"{mean['fresh'] / mean['cycles']:.2f}x |",
        f"| Cycles 5.0 (render call) | {mean['cycles']:.2f} s | | 1x |",
    ]
    publish(
        f"\n## Per-frame cost of the sunrise (issue #33 item 4; `bench/frame_reuse.py`)\n\n"
        f"{len(frames)} consecutive frames ({frames[0]}-{frames[-1]}) of the default sunrise at {args.res}, "
        f"{args.spp} spp, {THREADS} threads, one run on this machine. Kept and fresh frames are the same bits "
        "(checked). Besides the samples: loading, building and the sky map.\n\n"
        "| per frame | time | besides the samples | vs Cycles |\n|---|---|---|---|\n" + "\n".join(rows) + "\n",
        args.append,
        key="frame_reuse",
    )


if __name__ == "__main__":
    main()
