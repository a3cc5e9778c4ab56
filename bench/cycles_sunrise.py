"""Volpath against Cycles 5.0 on the default sunrise (issue #7): frames per hour at equal
error, on the same .blend, same machine, same threads, one run.

The two do not model the same sky (Cycles' Sky Texture is a precomputed radiance map and
its sun lamp is not dimmed by the air; Volpath traces the atmosphere), so each is measured
against its own reference (the same renderer at REF_SPP). The error is what the video
shows: the RMSE of the tone-mapped frame (the pipeline's exposure, filmic curve and sRGB,
in display units 0..1, before 8-bit rounding) against the tone-mapped reference, so that
the few pixels of a visible sun disc do not decide it. The figure is the time per frame
to reach TARGET, interpolated in log-log between the ladder's points that bracket it.

With --sky (issue #4), the scene is the sky alone: a Sky Texture (Cycles' multiple
scattering model) with its sun 2 degrees up, the camera 2 m above the ground looking 60
degrees away from the sun, 320x180. Volpath renders it with both free flights (guided and
delta tracking). The error is estimated from pairs of independent renders (seeds differ):
each renderer is unbiased (Volpath up to its tables' stated error), so half the mean
squared difference of a pair is the mean squared error of one render, with no reference
whose own noise would set a floor. Reported: the time to the display RMSE TARGET and to a
linear RMSE of 1 % of the frame's mean (the issue's target), extrapolated from the 64-spp
pair as error ~ time^-1/2 (the measured exponent between 16 and 64 spp is printed); the
two 64-spp images are saved side by side in docs/sky_cycles_volpath.png.

    python bench/cycles_sunrise.py [--frame 34] [--res 160x90] [--sky] [--append bench/RESULTS.md]
"""

import argparse
import os
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from publish import publish  # noqa: E402  (bench/)

TARGET = 0.02
REF_SPP = 1024
LADDER = (16, 64, 256)
THREADS = 2


def time_to(points):
    """Seconds to reach TARGET from (seconds, error, setting) points in the ladder's order
    (ever more work): log-log interpolation between the pair whose errors bracket it, or
    the cheaper of the two where the more accurate one took no longer (a fixed cost hides
    the samples' cost); extrapolation from the last two; None where the error stops
    falling short of the target (a denoiser's bias). Returns (seconds, error-vs-time slope)."""
    t0, e0, _ = points[0]
    if e0 <= TARGET:
        return t0, float("nan")
    for (t0, e0, _), (t1, e1, _) in zip(points, points[1:]):
        if e1 <= TARGET or (t1, e1) == points[-1][:2]:
            if t1 <= t0:
                return (t1, float("nan")) if e1 <= TARGET else (None, float("nan"))
            slope = np.log(e1 / e0) / np.log(t1 / t0)
            if not slope < -0.05:
                return None, float(slope)
            return float(t0 * (TARGET / e0) ** (1 / slope)), float(slope)
    raise ValueError("need at least two points")


def render_cycles(bpy, volpath, scene, frame, tmp, spp, seed, denoise=False):
    """Cycles on the CPU at THREADS threads, no adaptive sampling; with ``denoise``, Open
    Image Denoise with albedo and normal: (image, seconds of the render call)."""
    c = scene.cycles
    scene.render.engine = "CYCLES"
    c.device, c.samples, c.seed = "CPU", spp, seed
    c.use_denoising, c.use_adaptive_sampling = denoise, False
    if denoise:
        c.denoiser, c.denoising_input_passes, c.denoising_prefilter = (
            "OPENIMAGEDENOISE",
            "RGB_ALBEDO_NORMAL",
            "ACCURATE",
        )
    c.volume_bounces = 16  # Volpath's paths are unlimited; Cycles' default is single scattering
    scene.render.threads_mode, scene.render.threads = "FIXED", THREADS
    scene.frame_set(frame)
    return f12(bpy, volpath, scene, os.path.join(tmp, "cycles.exr"))


def f12(bpy, volpath, scene, path):
    """F12 with the scene's engine, saved as a 32-bit EXR at `path`: (image, seconds of the
    render call)."""
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = path
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - start
    return volpath.read_exr(path)[..., :3], seconds


def sky_scene():
    """The sky alone: Sky Texture (multiple scattering), its sun 2 degrees up, the camera
    2 m above the ground looking 10 degrees up and 60 degrees away from the sun."""
    import math

    sys.path.insert(0, os.path.join(ROOT, "tests"))
    from blender_scenes import add_camera, blank_scene, set_background

    scene = blank_scene()
    add_camera(scene, location=(0, 0, 2), rotation=(math.radians(100), 0, math.radians(60)))
    tree = set_background(scene, (0, 0, 0)).node_tree
    sky = tree.nodes.new("ShaderNodeTexSky")
    sky.sky_type, sky.sun_elevation, sky.sun_rotation = "MULTIPLE_SCATTERING", math.radians(2), 0.0
    tree.links.new(sky.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    scene.frame_start = scene.frame_end = 1
    return scene


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--frame", type=int, default=34)
    ap.add_argument("--res", default="160x90")
    ap.add_argument("--sky", action="store_true", help="the sky alone (see above)")
    ap.add_argument("--append")
    args = ap.parse_args()
    if args.sky:
        args.frame, args.res = 1, "320x180" if args.res == "160x90" else args.res
    import bpy

    import addon
    import volpath
    from addon.export.animation import export_animation
    from pipeline import video
    from pipeline.frames import render_frame

    if args.sky:
        return sky_main(args, sky_scene(), video, volpath, export_animation, render_frame, bpy)
    else:
        addon.register()
        bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "scenes", "sunrise", "sunrise.blend"))
        scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = map(int, args.res.split("x"))
    scene.render.resolution_percentage = 100
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        animation = os.path.join(tmp, "scene")
        export_animation(scene, [args.frame], animation)

        def volpath_render(setting, seed, target_error=False, denoise=False):
            spp, target = (REF_SPP, setting) if target_error else (setting, None)
            start = time.perf_counter()
            image, _ = render_frame(
                animation,
                args.frame,
                spp,
                tracer="null_scattering",
                seed=seed,
                threads=THREADS,
                target_error=target,
                denoise=denoise,
            )
            return image, time.perf_counter() - start

        def cycles_render(spp, seed, denoise=False):
            return render_cycles(bpy, volpath, scene, args.frame, tmp, spp, seed, denoise)

        for name, renderer, fn, ladder, kw in VARIANTS(volpath_render, cycles_render):
            if renderer not in results:
                fn(4, 99)  # warm-up: kernels, BVH, caches
                reference, ref_seconds = fn(REF_SPP, 12345)
                exposure = video.auto_exposure([reference], [0])[0]
                results[renderer] = (exposure, video.display(reference, exposure), {})
            exposure, shown, rows = results[renderer]
            points = []
            for setting in ladder:
                image, seconds = fn(setting, 7, **kw)
                points.append(
                    (seconds, float(np.sqrt(np.mean((video.display(image, exposure) - shown) ** 2))), setting)
                )
            rows[name] = (time_to(points), points, kw)
    table, best = [], {}
    cycles = results["Cycles 5.0"][2]
    for renderer, (_, _, rows) in results.items():
        for name, ((t, slope), points, kw) in rows.items():
            pair = "Cycles 5.0, OIDN" if kw.get("denoise") else "Cycles 5.0"
            ratio = t / cycles[pair][0][0] if t and cycles[pair][0][0] else None
            if renderer == "Volpath" and ratio is not None:
                key = "denoised" if kw.get("denoise") else "plain"
                best[key] = min(best.get(key, np.inf), ratio)
            unit = (lambda x: f"target {x}") if "target_error" in kw else (lambda x: f"{x} spp")
            ladder = "; ".join(f"{unit(x)}: {s:.2f} s, {e:.4f}" for s, e, x in points)
            table.append(
                f"| {name} | {'not reached' if t is None else f'{t:.2f} s'} | "
                f"{'–' if ratio is None else f'{ratio:.2f}x'} ({pair}) | {'–' if np.isnan(slope) else f't^{slope:.2f}'} | {ladder} |"
            )
    section = (
        f"\n## Sunrise frame: Volpath against Cycles (issues #7, #33; `bench/cycles_sunrise.py`)\n\n"
        f"Frame {args.frame} of the default sunrise at {args.res}, {THREADS} threads, each renderer "
        f"against its own {REF_SPP}-spp reference (their skies differ: Cycles' Sky Texture is a "
        "precomputed map with an undimmed sun lamp, Volpath traces the atmosphere). Time per frame "
        "(Volpath's is a pipeline worker's, which keeps its scene from frame to frame: "
        f"`bench/frame_reuse.py` measures what that leaves besides the samples) to an RMSE of {TARGET} "
        "in display units (tone-mapped as "
        "the video is), interpolated in log-log over each row's ladder; denoised rows against the other "
        "renderer's denoised row, the others against plain Cycles.\n\n"
        "| renderer | seconds per frame | time / Cycles | error vs time | ladder (setting: seconds, RMSE) |\n"
        "|---|---|---|---|---|\n" + "\n".join(table) + "\n"
    )
    section += (
        f"\nReading: without denoising on either side Volpath's best needs {best.get('plain', np.nan):.2f}x "
        f"Cycles' time per frame (issue #33's target: 0.5x); with denoising on both sides "
        f"{best.get('denoised', np.nan):.2f}x. Cycles' sky is a radiance map precomputed once, so only "
        "the fog and the surfaces are path traced, while Volpath traces every sky path through the "
        "atmosphere; Cycles' time at low spp is mostly its fixed cost (scene sync).\n"
    )
    publish(
        section, args.append, key=f"cycles_sunrise {args.res}" + (f" frame {args.frame}" if args.frame != 34 else "")
    )


def VARIANTS(volpath_render, cycles_render):
    """(row, renderer, render(setting, seed, **kw), ladder, kw): fixed spp, rendering to a
    target error, and denoising, for both renderers where they have it."""
    return (
        ("Volpath", "Volpath", volpath_render, (2, 4, 16, 64), {}),
        ("Volpath, target error", "Volpath", volpath_render, (0.04, 0.02, 0.01), {"target_error": True}),
        ("Volpath, denoised", "Volpath", volpath_render, (1, 4, 16), {"denoise": True}),
        (
            "Volpath, target error, denoised",
            "Volpath",
            volpath_render,
            (0.08, 0.04, 0.02),
            {"target_error": True, "denoise": True},
        ),
        ("Cycles 5.0", "Cycles 5.0", cycles_render, LADDER, {}),
        ("Cycles 5.0, OIDN", "Cycles 5.0", cycles_render, (1, 4, 16), {"denoise": True}),
    )


def sky_main(args, scene, video, volpath, export_animation, render_frame, bpy):
    """The sky alone (--sky): errors from pairs of independent renders (see the top)."""
    scene.render.resolution_x, scene.render.resolution_y = map(int, args.res.split("x"))
    scene.render.resolution_percentage = 100
    results = {}
    with tempfile.TemporaryDirectory() as tmp:

        def volpath_render(flight):
            scene.volpath.atmosphere_free_flight = flight  # the World panel's Free Flight
            animation = os.path.join(tmp, flight)
            export_animation(scene, [args.frame], animation)

            def render(spp, seed):
                start = time.perf_counter()
                image, meta = render_frame(
                    animation, args.frame, spp, tracer="null_scattering", seed=seed, threads=THREADS
                )
                total = time.perf_counter() - start
                return image, total, total - meta["render_seconds"]  # the scene's load, once per frame

            return render

        def cycles_render(spp, seed):
            return (*render_cycles(bpy, volpath, scene, args.frame, tmp, spp, seed), 0.0)

        renderers = (
            ("Volpath, guided free flight", volpath_render("guided")),
            ("Volpath, delta tracking", volpath_render("tracking")),
            ("Cycles 5.0", cycles_render),
        )
        for name, fn in renderers:
            fn(4, 99)  # warm-up: kernels, BVH, caches
            points = []
            for spp in (16, 64):
                (a, ta, la), (b, tb, lb) = fn(spp, spp), fn(spp, spp + 1000)
                a, b = a.astype(np.float64), b.astype(np.float64)
                exposure = video.auto_exposure([a], [0])[0]
                display = float(np.sqrt(np.mean((video.display(a, exposure) - video.display(b, exposure)) ** 2) / 2))
                linear = float(np.sqrt(np.mean((a - b) ** 2) / 2) / np.mean((a + b) / 2))
                points.append(
                    (spp, (ta + tb) / 2, display, linear, video.display((a + b) / 2, exposure), (la + lb) / 2)
                )
            results[name] = points

    def time_to(t16, e16, t64, e64, target, load):
        """(seconds, exact): a render already at the target bounds the time from above; else
        the 64-spp render's time scaled as error ~ time^-1/2, the scene's load counted once."""
        if e16 <= target:
            return t16, False
        if e64 <= target:
            return t64, False
        return load + (t64 - load) * (e64 / target) ** 2, True

    def shown(t):
        return f"{t[0]:.3g} s" if t[1] else f"≤ {t[0]:.2f} s"

    rows = []
    for name, points in results.items():
        (_, t16, d16, l16, _, _), (_, t64, d64, l64, _, load) = points
        slope = np.log(l64 / l16) / np.log(t64 / t16)
        rows.append(
            (
                name,
                t16,
                d16,
                l16,
                t64,
                d64,
                l64,
                slope,
                time_to(t16, d16, t64, d64, TARGET, load),
                time_to(t16, l16, t64, l64, 0.01, load),
            )
        )
    cycles_t = rows[-1][8][0]
    table = "\n".join(
        f"| {n} | {t16:.2f} s: {d16:.4f}, {100 * l16:.2f} % | {t64:.2f} s: {d64:.4f}, {100 * l64:.2f} % | "
        f"t^{s:.2f} | {shown(td)} ({td[0] / cycles_t:.0f}x) | {shown(tl)} |"
        for n, t16, d16, l16, t64, d64, l64, s, td, tl in rows
    )
    side_by_side = np.concatenate([results["Cycles 5.0"][1][4], results["Volpath, guided free flight"][1][4]], axis=1)
    video.write_png(
        os.path.join(ROOT, "docs", "sky_cycles_volpath.png"),
        np.round(np.clip(side_by_side, 0, 1) * 255).astype(np.uint8),
    )
    guided, tracking = rows[0], rows[1]
    section = f"""
## Sunrise sky: Volpath against Cycles' Sky Texture (issue #4; `bench/cycles_sunrise.py --sky`)

The sky alone: Sky Texture (multiple scattering), sun 2° up, camera 2 m up looking 60° away from
the sun, {args.res}, {THREADS} threads. Errors from pairs of independent renders (half the mean
squared difference of two renders with different seeds is one render's mean squared error; no
reference, so no reference noise): the display RMSE (tone-mapped as the video is, 0..1) and the
linear RMSE relative to the frame's mean. Times to the display target {TARGET} and to 1 % of the
mean extrapolated from 64 spp as error ~ time^-1/2 (the measured exponent is shown), the scene's load
(0.4 s: the tables and the sky map) counted once.

| renderer | 16 spp: time, display RMSE, relative RMSE | 64 spp | error vs time | to display RMSE {TARGET} (vs Cycles) | to 1 % of the mean |
|---|---|---|---|---|---|
{table}

Reading: the guided free flight with the sky map and its control variates (README, "The
atmosphere") reaches 1 % of the mean in {guided[9][0]:.0f} s per frame against delta
tracking's {tracking[9][0]:.0f} s ({tracking[9][0] / guided[9][0]:.1f}x faster); the issue's target, 60 s, is
{"met" if guided[9][0] <= 60 else f"not met ({guided[9][0] / 60:.1f}x over)"}. Cycles' times are upper bounds: its 16-spp render already
meets both targets, so the ratios against it are lower bounds. What noise remains is the
models' error (the map's cells and levels, Mie's share estimated from two directions) and
the light the models leave out. Cycles looks its sky up in a table it
precomputes from its own multiple-scattering model: no path crosses the air, its error is the
pixel filter's alone, and no path tracer of the air reaches its time. The skies also differ
in model (docs/sky_cycles_volpath.png: Cycles left, Volpath right at 64 spp, each at its own
exposure).
"""
    publish(section, args.append, key="cycles_sunrise sky")


if __name__ == "__main__":
    main()
