"""RGB against spectral over the default sunrise (issue #4): which colour mode reaches a
given error sooner on the frames the pipeline renders.

Frames of scenes/sunrise/sunrise.blend from the sun below the horizon to well above it,
RES, 2 threads, the null-scattering tracer. Reference per frame: spectral mode at REF_SPP.
Each mode at the LADDER's samples per pixel (in spectral mode the samples are shared out
over the wavelength passes, so equal spp costs about equal time): seconds, and the error
the video shows (RMSE of the tone-mapped frame, display units 0..1, at the reference's
exposure) and the linear RMSE relative to the reference's RMS. RGB's error stops falling
at its colour bias; the mean chromaticity of the converged RGB frame against the
reference is listed too. Prints a section of bench/RESULTS.md (--append FILE).

    python bench/spectral_sunrise.py [--frames 1,36,72] [--res 96x54] [--append bench/RESULTS.md]
"""

import argparse
import copy
import os
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from publish import publish  # noqa: E402  (bench/)

REF_SPP = 512
LADDER = (8, 32, 128)
THREADS = 2


def chroma(colour):
    """r, g, b shares of a colour."""
    return colour / colour.sum()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", default="1,36,72")
    ap.add_argument("--res", default="96x54")
    ap.add_argument("--append")
    args = ap.parse_args()
    frames = [int(f) for f in args.frames.split(",")]
    import bpy

    import addon
    import volpath
    from addon.export.animation import export_animation
    from pipeline import video
    from pipeline.frames import _load, frame_dictionary

    addon.register()
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "scenes", "sunrise", "sunrise.blend"))
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = map(int, args.res.split("x"))
    scene.render.resolution_percentage = 100
    rows, colours = [], []
    with tempfile.TemporaryDirectory() as tmp:
        animation = os.path.join(tmp, "scene")
        export_animation(scene, frames, animation)
        d, directory, anim = _load(animation)

        def render(frame, mode, spp, seed):
            entry = next(e for e in anim["frames"] if e["frame"] == frame)
            frame_dict = copy.deepcopy(frame_dictionary(d, anim, entry))

            def set_mode(node):
                if isinstance(node, dict):
                    if node.get("type") == "atmosphere":
                        node["mode"] = mode
                    for value in node.values():
                        set_mode(value)

            set_mode(frame_dict)
            s = volpath.load_dict(frame_dict, base_dir=directory)
            start = time.perf_counter()
            image = volpath.render(s, spp=spp, seed=seed, threads=THREADS, tracer="null_scattering")
            return image.astype(np.float64), time.perf_counter() - start

        for frame in frames:
            ref, ref_seconds = render(frame, "spectral", REF_SPP, 12345)
            exposure = video.auto_exposure([ref], [0])[0]
            shown, norm = video.display(ref, exposure), np.sqrt(np.mean(ref**2))
            for mode in ("rgb", "spectral"):
                for spp in LADDER:
                    image, seconds = render(frame, mode, spp, spp)
                    rows.append(
                        (
                            frame,
                            mode,
                            spp,
                            seconds,
                            np.sqrt(np.mean((video.display(image, exposure) - shown) ** 2)),
                            np.sqrt(np.mean((image - ref) ** 2)) / norm,
                        )
                    )
                    print(*rows[-1], flush=True)
                    if mode == "rgb" and spp == LADDER[-1]:
                        colours.append(
                            (frame, ref_seconds, chroma(ref.mean(axis=(0, 1))), chroma(image.mean(axis=(0, 1))))
                        )

    lines = [
        "## RGB and spectral over the sunrise (issue #4; `bench/spectral_sunrise.py`)",
        "",
        f"Frames {', '.join(map(str, frames))} of the default sunrise at {args.res}, {THREADS} threads, null-scattering "
        f"tracer; reference per frame: spectral mode at {REF_SPP} spp. In spectral mode the samples are shared out over "
        "the four wavelength passes, so equal spp costs about equal time. Display RMSE: the tone-mapped frame as the "
        "video shows it (0..1); relative RMSE: linear, over the reference's RMS.",
        "",
        "| frame | mode | spp | seconds | display RMSE | relative RMSE |",
        "|---|---|---|---|---|---|",
    ]
    for frame, mode, spp, seconds, shown_err, rel in rows:
        lines.append(f"| {frame} | {mode} | {spp} | {seconds:.2f} s | {shown_err:.4f} | {100 * rel:.1f} % |")
    lines += ["", f"Mean chromaticity (r, g, b shares) of the reference against RGB mode at {LADDER[-1]} spp:", ""]
    for frame, ref_seconds, ref_c, rgb_c in colours:
        lines.append(
            f"- frame {frame} (reference {ref_seconds:.0f} s): spectral {', '.join(f'{c:.3f}' for c in ref_c)}; "
            f"RGB {', '.join(f'{c:.3f}' for c in rgb_c)}"
        )
    publish("\n".join(lines) + "\n", args.append, key="spectral_sunrise")


if __name__ == "__main__":
    main()
