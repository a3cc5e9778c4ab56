"""What denoising buys and what it costs: error on screen against time, noisy and denoised
(Intel Open Image Denoise, `render(..., denoise=True)`), on the bench scenes and on
frames of the default sunrise, each against its own high-spp reference. Writes the
"Denoising" section of docs/accuracy.md (between its markers; bench/accuracy/run.py
keeps it) and docs/accuracy/denoising.png. References are cached in bench/cache/denoise/.

The error is the display RMSE (the pipeline's tone curve at the reference's auto
exposure, 0..1) net of the reference's own noise: the reference is two independent
halves, a quarter of whose squared displayed difference is its noise on screen, taken off
every squared error. A denoiser's bias is where its curve flattens: the table gives the
error at the ladder's top, and the shift of the displayed image's mean brightness.

    .venv/bin/python bench/accuracy/denoise.py [--ladder 2 8 32 128] [--ref-spp 1024]
"""

import argparse
import datetime
import json
import os
import re
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.dirname(HERE))
import volpath  # noqa: E402
from volpath.tonemap import auto_exposure, display  # noqa: E402

CACHE = os.path.join(ROOT, "bench", "cache", "denoise")
DOCS = os.path.join(ROOT, "docs")
THREADS = 2
BENCH = ("absorbing_sphere", "single_scattering", "dense_multiple", "hetero_cube", "thin_fog")
SUNRISE_FRAMES = (1, 34, 72)
MARKERS = ("<!-- denoising -->", "<!-- /denoising -->")


def bench_renderer(stem, res):
    path = os.path.join(ROOT, "bench", "scenes", f"{stem}.xml")
    if stem == "hetero_cube" and not os.path.exists(os.path.join(ROOT, "bench", "scenes", "hetero_cube.vol")):
        import subprocess

        subprocess.run([sys.executable, os.path.join(ROOT, "bench", "make_grids.py")], check=True)
    scene = volpath.load_file(path, res=res)
    return lambda spp, seed, denoise: volpath.render(scene, spp=spp, seed=seed, threads=THREADS, denoise=denoise)


def sunrise_renderers(frames, res):
    """Frames of the default sunrise, exported once (the bpy module), rendered as the pipeline does."""
    import bpy

    import addon
    from addon.export.animation import export_animation
    from pipeline.frames import render_frame

    addon.register()
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "scenes", "sunrise", "sunrise.blend"))
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = res
    scene.render.resolution_percentage = 100
    directory = os.path.join(tempfile.mkdtemp(prefix="volpath-denoise-"), "scene")
    export_animation(scene, list(frames), directory)
    return {
        f"sunrise frame {f}": (
            lambda spp, seed, denoise, f=f: render_frame(
                directory, f, spp, tracer="null_scattering", seed=seed, threads=THREADS, denoise=denoise
            )[0]
        )
        for f in frames
    }


def reference(name, render, spp):
    """Two independent halves of a high-spp render, cached."""
    os.makedirs(CACHE, exist_ok=True)
    halves = []
    for k, seed in enumerate((424242, 515151)):
        path = os.path.join(CACHE, f"{re.sub(r'[^a-z0-9]+', '_', name)}_{spp}_{k}.exr")
        if not os.path.exists(path):
            volpath.write_exr(path, render(spp // 2, seed, False))
        halves.append(volpath.read_exr(path).astype(np.float64))
    return halves


def measure(name, render, ladder, ref_spp):
    a, b = reference(name, render, ref_spp)
    ref = (a + b) / 2
    exposure = auto_exposure(ref)
    shown = display(ref, exposure)
    ref_noise = np.mean((display(a, exposure) - display(b, exposure)) ** 2) / 4
    rows = {}
    render(2, 1, True)  # warm-up: OIDN's device, the scene's caches
    for denoise in (False, True):
        points = []
        for spp in ladder:
            start = time.perf_counter()
            image = render(spp, 7 + spp, denoise).astype(np.float64)
            seconds = time.perf_counter() - start
            squared = np.mean((display(image, exposure) - shown) ** 2) - ref_noise
            points.append(
                {
                    "spp": spp,
                    "seconds": seconds,
                    "error": float(np.sqrt(max(squared, 0.0))),
                    "mean_shift": float(display(image, exposure).mean() - shown.mean()),
                }
            )
        rows["denoised" if denoise else "noisy"] = points
    return {"ref_noise": float(np.sqrt(ref_noise)), **rows}


def plot(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(results)
    cols = 4
    fig, axes = plt.subplots(
        (len(names) + cols - 1) // cols,
        cols,
        figsize=(4 * cols, 3.2 * ((len(names) + cols - 1) // cols)),
        squeeze=False,
    )
    for ax, name in zip(axes.flat, names):
        for kind, style in (("noisy", "o-"), ("denoised", "s--")):
            pts = results[name][kind]
            ax.loglog([p["seconds"] for p in pts], [max(p["error"], 1e-5) for p in pts], style, label=kind)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("seconds")
        ax.set_ylabel("display RMSE")
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[len(names) :]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def section(results, args):
    lines = [
        MARKERS[0],
        "## Denoising",
        "",
        f"Produced by bench/accuracy/denoise.py on {datetime.date.today().isoformat()}: each scene "
        f"noisy and denoised (Intel Open Image Denoise through `pyoidn`, `render(..., denoise=True)`) "
        f"at {', '.join(map(str, args.ladder))} spp, {THREADS} threads, the bench scenes at "
        f"{args.res}² and sunrise frames at {args.sunrise_res[0]}×{args.sunrise_res[1]}, against "
        f"{args.ref_spp}-spp references. Error: display RMSE (the video's tone curve at the reference's "
        "auto exposure, 0..1), net of the reference's own noise. Denoising buys most where the noise "
        "is high (few samples) and flattens where its bias is reached: the error at the top of the "
        "ladder and the shift of the displayed image's mean show that bias (where the noisy render "
        "is nearly converged, the denoised one is the worse of the two); time includes the filter.",
        "",
        "![denoising](accuracy/denoising.png)",
        "",
        "| scene | error at the lowest spp: noisy → denoised | at the highest: noisy → denoised | "
        "shift of the displayed mean at the highest, denoised (noisy) | the filter's time |",
        "|---|---|---|---|---|",
    ]
    for name, r in results.items():
        n, d = r["noisy"], r["denoised"]
        lines.append(
            f"| {name} | {n[0]['error']:.4f} → {d[0]['error']:.4f} ({n[0]['spp']} spp) | "
            f"{n[-1]['error']:.4f} → {d[-1]['error']:.4f} ({n[-1]['spp']} spp) | "
            f"{d[-1]['mean_shift']:+.4f} ({n[-1]['mean_shift']:+.4f}) | "
            f"{d[0]['seconds'] - n[0]['seconds']:+.2f} s |"
        )
    lines += ["", MARKERS[1]]
    return "\n".join(lines)


def kept_section(path):
    """The denoising section of the report at `path`, for bench/accuracy/run.py to keep
    when it rewrites the rest ("" if there is none)."""
    if not os.path.exists(path):
        return ""
    with open(path, encoding="utf-8") as f:
        text = f.read()
    start, end = text.find(MARKERS[0]), text.find(MARKERS[1])
    return text[start : end + len(MARKERS[1])] if 0 <= start < end else ""


def replace_section(text, new):
    """docs/accuracy.md with its denoising section replaced (or appended)."""
    start, end = text.find(MARKERS[0]), text.find(MARKERS[1])
    if start >= 0 and end > start:
        return text[:start] + new + text[end + len(MARKERS[1]) :]
    return text.rstrip("\n") + "\n\n" + new + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ladder", type=int, nargs="+", default=[2, 8, 32, 128])
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--sunrise-res", type=lambda t: tuple(map(int, t.split("x"))), default=(160, 90))
    ap.add_argument("--report-only", action="store_true", help="rewrite the section from the saved measurements")
    args = ap.parse_args()
    saved = os.path.join(CACHE, "results.json")
    if args.report_only:
        with open(saved, encoding="utf-8") as f:
            results = json.load(f)
    else:
        results = {}
        for stem in BENCH:
            results[stem] = measure(stem, bench_renderer(stem, args.res), args.ladder, args.ref_spp)
            print(stem, json.dumps(results[stem]))
        for name, render in sunrise_renderers(SUNRISE_FRAMES, args.sunrise_res).items():
            results[name] = measure(name, render, args.ladder, args.ref_spp)
            print(name, json.dumps(results[name]))
        with open(saved, "w", encoding="utf-8") as f:
            json.dump(results, f, indent=1)
    plot(results, os.path.join(DOCS, "accuracy", "denoising.png"))
    path = os.path.join(DOCS, "accuracy.md")
    with open(path, encoding="utf-8") as f:
        text = f.read()
    with open(path, "w", encoding="utf-8") as f:
        f.write(replace_section(text, section(results, args)))
    print(section(results, args))


if __name__ == "__main__":
    main()
