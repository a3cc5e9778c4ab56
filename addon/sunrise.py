"""Render a Blender animation (by default the sunrise) to EXR frames and an H.264 video:
the pipeline from the command line, with the bpy module or inside Blender.

    python -m addon.sunrise [--blend scenes/sunrise/sunrise.blend] [options]
    blender -b scenes/sunrise/sunrise.blend --python addon/sunrise.py -- [options]

Exit status: 0 when every frame rendered, 1 when some failed (the video holds the rest),
2 for bad options or a scene that cannot be exported.
"""

import argparse
import os
import re
import sys
import time

if __name__ == "__main__" and not __package__:  # run as a file by `blender --python`
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    from addon.sunrise import main

    sys.exit(main())

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_BLEND = os.path.join(ROOT, "scenes", "sunrise", "sunrise.blend")


def _frames(text):
    m = re.fullmatch(r"\s*(-?\d+)\s*(?:[-:]\s*(-?\d+)\s*)?", text)
    if not m:
        raise argparse.ArgumentTypeError(f"'{text}': expected a frame or a range such as 1-72")
    first = int(m.group(1))
    last = int(m.group(2)) if m.group(2) is not None else first
    if last < first:
        raise argparse.ArgumentTypeError(f"'{text}': the range ends before it starts")
    return first, last


def _resolution(text):
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m or not (1 <= int(m.group(1)) <= 16384 and 1 <= int(m.group(2)) <= 16384):
        raise argparse.ArgumentTypeError(f"'{text}': expected WIDTHxHEIGHT, e.g. 320x180")
    return int(m.group(1)), int(m.group(2))


def _exposure(text):
    if text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}': expected a number of stops or 'auto'") from None


def _display_error(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}': expected a number such as 0.02") from None
    if not 0 <= value < 1:
        raise argparse.ArgumentTypeError(f"{value}: a display error is in [0, 1) (0: off)")
    return value


def _tracer(text):
    import volpath

    if text != "auto" and text not in volpath.TRACERS:
        raise argparse.ArgumentTypeError(
            f"unknown tracer '{text}' (expected auto or one of: {', '.join(volpath.TRACERS)})"
        )
    return text


def _count(minimum):
    def parse(text):
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{text}': expected an integer") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"{value}: must be at least {minimum}")
        return value

    return parse


def parser():
    p = argparse.ArgumentParser(prog="python -m addon.sunrise", description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--blend", help=f"the .blend to render (default: the open file inside Blender, else {DEFAULT_BLEND})"
    )
    p.add_argument("--frames", type=_frames, help="frame or range, e.g. 1-72 (default: the scene's range)")
    p.add_argument("--step", type=_count(1), help="render every STEP-th frame (default: the scene's frame step)")
    p.add_argument("--res", type=_resolution, help="WIDTHxHEIGHT (default: the scene's output size)")
    p.add_argument(
        "--spp",
        type=_count(1),
        help="samples per pixel, or the cap with --target-error (default: the scene's Volpath samples)",
    )
    p.add_argument(
        "--target-error",
        type=_display_error,
        metavar="E",
        help="render each frame to this RMS error of the displayed frame, in display units 0..1 "
        "(e.g. 0.02; default: the scene's Noise Threshold, 0 = off: fixed spp)",
    )
    p.add_argument(
        "--denoise",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="denoise each frame with Intel Open Image Denoise (default: the scene's Denoise setting)",
    )
    p.add_argument(
        "--tracer",
        type=_tracer,
        help="auto or absorption, single, multiple, nee_mis, null_scattering (default: the scene's)",
    )
    p.add_argument("--out", default=os.path.join("out", "sunrise"), help="output directory (default: out/sunrise)")
    p.add_argument("--fps", type=_count(1), default=24, help="video frame rate (default: 24)")
    p.add_argument(
        "--exposure",
        type=_exposure,
        default="auto",
        help="stops for the PNGs and video, or 'auto' (middle grey, smoothed over frames; the default)",
    )
    p.add_argument("--workers", type=_count(0), default=0, help="local worker processes (default: one per core)")
    p.add_argument(
        "--threads", type=_count(0), default=0, help="threads per frame (default: cores / workers; 1 on Dask)"
    )
    p.add_argument("--scheduler", default="", help="Dask distributed scheduler address, e.g. tcp://host:8786")
    p.add_argument("--resume", action="store_true", help="keep frames whose EXR exists and reads back valid")
    return p


def _user_args(argv):
    """Inside Blender the script's options follow `--`."""
    if argv is not None:
        return argv
    return sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]


def main(argv=None):
    args = parser().parse_args(_user_args(argv))
    import bpy

    from pipeline.run import Options

    from . import register
    from .export.animation import frame_list

    if not hasattr(bpy.types.Scene, "volpath"):  # plain Python, or Blender without the extension
        register()
    if args.blend:
        if not os.path.isfile(args.blend):
            print(f"error: {args.blend}: no such .blend file", file=sys.stderr)
            return 2
        bpy.ops.wm.open_mainfile(filepath=os.path.abspath(args.blend))
    elif not bpy.data.filepath:
        if not os.path.isfile(DEFAULT_BLEND):
            print(
                f"error: {DEFAULT_BLEND} does not exist: build it with `make sunrise` (scenes/sunrise/build.py)",
                file=sys.stderr,
            )
            return 2
        bpy.ops.wm.open_mainfile(filepath=DEFAULT_BLEND)
    scene = bpy.context.scene
    try:
        frames = frame_list(scene, args.frames, args.step)
        s = scene.volpath
        target = (
            args.target_error
            if args.target_error is not None
            else (s.adaptive_threshold if s.use_adaptive_sampling else 0.0)
        )
        denoise = s.use_denoising if args.denoise is None else args.denoise
        options = Options(
            spp=args.spp or s.spp,
            target_error=target,
            denoise=denoise,
            tracer=args.tracer or s.tracer,
            workers=args.workers,
            threads=args.threads,
            scheduler=args.scheduler,
            resume=args.resume,
            fps=args.fps,
            exposure=args.exposure,
        )
        options.check()
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if args.res:
        scene.render.resolution_x, scene.render.resolution_y = args.res
        scene.render.resolution_percentage = 100
    return render_animation(scene, frames, args.out, options)


def render_animation(scene, frames, out, options):
    """Export, render, make the video; returns the exit status."""
    from pipeline.run import Run

    from .export import ExportError
    from .export.animation import export_animation

    start = time.monotonic()
    animation_dir = os.path.join(out, "scene")
    try:
        warnings = export_animation(scene, frames, animation_dir)
    except ExportError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    run = Run(animation_dir, out, frames, options)
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)
    summary = run.execute()
    failed = run.failed()
    print(
        f"{len(frames) - len(failed)}/{len(frames)} frames in {time.monotonic() - start:.0f} s; "
        f"video: {summary.get('video')}; summary: {run.summary_path}"
    )
    for f in failed:
        print(f"frame {f} failed: {run.status[f]['error']}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
