"""How close `make sunrise`'s frames are to converged ones (issue #33): frames of a pipeline
run's output against references of the same frames, on screen.

Each reference is two independent halves (REF_SPP / 2 samples each, cached in
bench/cache/sunrise_quality/), rendered from the same .blend at the run's resolution; the
error is the display RMSE (the video's tone curve at the reference's auto exposure, 0..1),
shown raw and net of the reference's own noise (a quarter of the halves' squared displayed
difference). The frames' seconds, mean spp and estimated error come from summary.json.

    .venv/bin/python bench/sunrise_quality.py [--out out/sunrise] [--frames 1 36 71] [--ref-spp 512] [--append bench/RESULTS.md]

(--ref-spp below 512 for a quicker run: the net error subtracts the reference's larger noise.)
"""

import argparse
import json
import os
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from publish import publish, table  # noqa: E402  (bench/)

CACHE = os.path.join(ROOT, "bench", "cache", "sunrise_quality")
REF_SPP = 512
THREADS = 2


def references(frames, shape, ref_spp):
    """{frame: (half a, half b)} at the run's resolution, rendered once and cached."""
    import volpath

    height, width = shape
    paths = {
        f: [os.path.join(CACHE, f"{width}x{height}_{ref_spp}_{f}_{seed}.exr") for seed in (1001, 2002)] for f in frames
    }
    missing = [f for f in frames if not all(os.path.exists(p) for p in paths[f])]
    if missing:
        import bpy

        import addon
        from addon.export.animation import export_animation
        from pipeline.frames import render_frame

        addon.register()
        bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "scenes", "sunrise", "sunrise.blend"))
        scene = bpy.context.scene
        scene.render.resolution_x, scene.render.resolution_y = width, height
        scene.render.resolution_percentage = 100
        directory = os.path.join(tempfile.mkdtemp(prefix="volpath-quality-"), "scene")
        export_animation(scene, missing, directory)
        os.makedirs(CACHE, exist_ok=True)
        for f in missing:
            for path, seed in zip(paths[f], (1001, 2002)):
                image, _ = render_frame(
                    directory, f, ref_spp // 2, tracer="null_scattering", seed=seed, threads=THREADS
                )
                volpath.write_exr(path, image)
    return {f: [volpath.read_exr(p).astype(np.float64) for p in paths[f]] for f in frames}


COLUMNS = (
    *("frame", "display RMSE", "net of the reference's noise", "reference's noise"),
    *("estimated (noisy)", "mean spp", "seconds"),
)


def main():
    import volpath
    from pipeline import video

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "sunrise"))
    ap.add_argument("--frames", type=int, nargs="+", default=[1, 36, 71])
    ap.add_argument("--ref-spp", type=int, default=REF_SPP, help="the references' samples (two halves)")
    ap.add_argument("--append")
    args = ap.parse_args()
    with open(os.path.join(args.out, "summary.json"), encoding="utf-8") as f:
        summary = json.load(f)
    images = {
        f: volpath.read_exr(os.path.join(args.out, "frames", f"frame_{f:04d}.exr")).astype(np.float64)
        for f in args.frames
    }
    refs = references(args.frames, next(iter(images.values())).shape[:2], args.ref_spp)
    rows = []
    for f in args.frames:
        a, b = refs[f]
        ref = (a + b) / 2
        exposure = video.auto_exposure([ref], [0])[0]
        shown = video.display(ref, exposure)
        noise = np.mean((video.display(a, exposure) - video.display(b, exposure)) ** 2) / 4
        raw = np.mean((video.display(images[f], exposure) - shown) ** 2)
        s = summary["frames"][str(f)]
        estimate = f"{s['error']:.4f}" if "error" in s else "–"
        rows.append(
            f"| {f} | {np.sqrt(raw):.4f} | {np.sqrt(max(raw - noise, 0)):.4f} | {np.sqrt(noise):.4f} | "
            f"{estimate} | {s.get('spp_mean', s['spp'])} | {s['seconds']:.1f} s |"
        )
    o = summary["options"]
    how = (
        f"to a display error of {o['target_error']} (at most {o['spp']} spp)"
        if o.get("target_error")
        else f"at {o['spp']} spp"
    ) + (", denoised" if o.get("denoise") else "")
    h, w = next(iter(images.values())).shape[:2]
    section = (
        f"\n## `make sunrise`'s frames against converged ones (issue #33; `bench/sunrise_quality.py`)\n\n"
        f"The run in {os.path.relpath(args.out, ROOT)}: {w}x{h}, each frame {how}. References: "
        f"{args.ref_spp} spp as two independent halves; display RMSE raw and net of the reference's noise "
        "(target: 0.02); the estimate is the renderer's own, before denoising; seconds per frame on "
        "one worker thread (the pool runs two).\n\n" + table(COLUMNS, rows)
    )
    publish(section, args.append, key="sunrise_quality")


if __name__ == "__main__":
    main()
