"""Sunrise pipeline throughput (issue #7): frames per hour of the default sunrise, and
Dask distributed with 2 workers against 1 (target: at least 1.8x), measured in one run.

    python bench/pipeline_throughput.py [--frames 8] [--res 320x180] [--spp 8] [--append bench/RESULTS.md]
"""

import argparse
import os
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from publish import publish  # noqa: E402  (bench/)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--res", default="320x180")
    ap.add_argument("--spp", type=int, default=8)
    ap.add_argument("--append")
    args = ap.parse_args()
    import bpy
    from distributed import LocalCluster

    import addon
    from addon.export.animation import export_animation
    from pipeline.run import Options, Run

    addon.register()
    blend = os.path.join(ROOT, "scenes", "sunrise", "sunrise.blend")
    bpy.ops.wm.open_mainfile(filepath=blend)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = map(int, args.res.split("x"))
    frames = [round(1 + i * (scene.frame_end - 1) / max(args.frames - 1, 1)) for i in range(args.frames)]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        animation = os.path.join(tmp, "scene")
        export_animation(scene, frames, animation)
        times = {}
        for label, kw in (("local pool, 2 processes", dict(workers=2, threads=1)),):
            start = time.perf_counter()
            Run(
                animation, os.path.join(tmp, "local"), frames, Options(spp=args.spp, **kw), progress=lambda *a: None
            ).render()
            times[label] = time.perf_counter() - start
        for n in (1, 2):
            with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
                start = time.perf_counter()
                Run(
                    animation,
                    os.path.join(tmp, f"dask{n}"),
                    frames,
                    Options(spp=args.spp, scheduler=cluster.scheduler_address, threads=1),
                    progress=lambda *a: None,
                ).render()
                times[f"Dask, {n} worker{'s' if n > 1 else ''} x 1 thread"] = time.perf_counter() - start
    base = times["Dask, 1 worker x 1 thread"]
    for label, t in times.items():
        rows.append(f"| {label} | {len(frames)} | {t:.1f} s | {3600 * len(frames) / t:.0f} | {base / t:.2f}x |")
    section = (
        f"\n## Sunrise pipeline throughput (issue #7; `bench/pipeline_throughput.py`)\n\n"
        f"{len(frames)} frames of the default sunrise at {args.res}, {args.spp} spp, one run on this machine "
        f"({os.cpu_count()} cores). Target: 2 Dask workers at least 1.8x one.\n\n"
        "| how | frames | wall time | frames per hour | vs 1 Dask worker |\n|---|---|---|---|---|\n"
        + "\n".join(rows)
        + "\n"
    )
    publish(section, args.append, key="pipeline_throughput")


if __name__ == "__main__":
    main()
