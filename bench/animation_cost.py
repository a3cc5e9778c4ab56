"""What following an animation costs a frame (issue #57, part 4): a 1 M-triangle terrain
with a small cube, exported and rendered by the pipeline once with the cube keyframed
across it and once with nothing moving; per frame, the export's time and a worker's time
besides its samples (applying the frame's changes: the cube's instance moved and the BVH
refit), side by side in one run: the first update after the worker's load apart (the first
refit links the BVH's nodes to their parents, once per worker). The moving run's frames
after the first must be updated in place (checked).

    python bench/animation_cost.py [--frames 24] [--triangles 1000000] [--append bench/RESULTS.md]
"""

import argparse
import math
import os
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "tests"))
from publish import publish  # noqa: E402  (bench/)


def build(bpy, blender_scenes, triangles, moving, frames):
    scene = blender_scenes.blank_scene()
    scene.render.resolution_x, scene.render.resolution_y = 32, 18
    blender_scenes.add_camera(scene)
    bpy.ops.object.light_add(type="SUN")
    side = int(math.sqrt(triangles / 2)) + 1
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=side, y_subdivisions=side, size=40)
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(-3, 0, 0.5))
    cube = bpy.context.object
    if moving:
        for frame, x in ((frames[0], -3.0), (frames[-1], 3.0)):
            cube.location.x = x
            cube.keyframe_insert("location", frame=frame)
    return scene


def export_per_frame(scene, frames, directory):
    """The export's time per frame but the first frame's export: the pass over the frames
    (animation.py's _scan) and the changed frames' entries, the meshes' triangles cached."""
    from addon.export import animation as A

    start = time.perf_counter()
    scan = A._scan(scene, frames)
    seconds = time.perf_counter() - start
    moving, caches = scan.objects("placement", "shape"), {"meshes": {}, "digests": {}}
    first, _ = A._frame_entries(scene, frames[0], directory, moving, caches, [])
    start = time.perf_counter()
    A._changed_frames(scene, scan, first, directory, moving, caches, [])
    return (seconds + time.perf_counter() - start) / len(frames)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--triangles", type=int, default=1_000_000)
    ap.add_argument("--append")
    args = ap.parse_args()
    import blender_scenes
    import bpy

    from addon.export.animation import export_animation
    from pipeline import frames as F

    frames = list(range(1, args.frames + 1))
    rows, fixed = [], {}
    for moving in (False, True):
        scene = build(bpy, blender_scenes, args.triangles, moving, frames)
        with tempfile.TemporaryDirectory() as tmp:
            export = export_per_frame(scene, frames, os.path.join(tmp, "timed"))
            export_animation(scene, frames, tmp)
            F.render_frame(tmp, frames[0], 1, threads=2)  # the worker's first load
            besides = []
            for frame in frames[1:]:
                _, metadata = F.render_frame(tmp, frame, 1, threads=2)
                if metadata["scene_built"]:
                    raise SystemExit(f"frame {frame}: the worker built the scene anew")
                besides.append(metadata["seconds"] - metadata["render_seconds"])
            F._scenes.clear()
        fixed[moving] = export, float(np.mean(besides[1:])), besides[0]
        label = "the cube moving" if moving else "nothing moving"
        export, worker, first = fixed[moving]
        rows.append(
            f"| {label} | {export * 1e3:.1f} ms | {worker * 1e3:.1f} ms | {(export + worker) * 1e3:.1f} ms | "
            f"{first * 1e3:.1f} ms |"
        )
    ratio = [fixed[True][i] / fixed[False][i] for i in (0, 1, 2)]
    both = sum(fixed[True][:2]) / sum(fixed[False][:2])
    rows.append(f"| ratio | {ratio[0]:.2f}x | {ratio[1]:.2f}x | {both:.2f}x | {ratio[2]:.2f}x |")
    publish(
        "\n## What following an animation costs a frame (issue #57 part 4; `bench/animation_cost.py`)\n\n"
        f"A {args.triangles:,}-triangle terrain and a 12-triangle cube, {len(frames)} frames at 32x18, 1 spp, "
        "2 threads, one run on this machine: per frame, the export but the first frame's scene (the pass "
        "over the frames and the changed frames' entries) "
        "and a worker's time besides its samples for the frames after the second, and for the second (the "
        "first update after the load) apart; all updated in place (checked). Before in-place updates, a frame "
        "where an object moved was exported and loaded whole: the first frame's export (mostly the terrain's "
        "triangles) and a scene load again.\n\n"
        "| per frame | export | worker, besides samples | both | first update after the load |\n"
        "|---|---|---|---|---|\n" + "\n".join(rows) + "\n",
        args.append,
        key="animation_cost",
    )


if __name__ == "__main__":
    main()
