"""Command line: ``python -m volpath render|info ...``."""

import argparse
import json
import os
import sys
import time
import warnings

from . import __version__
from .adaptive import describe
from .errors import SceneError, SceneWarning
from .exr import write_exr
from .plugins.integrators import TRACERS
from .render import render
from .scene import load_file


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """A scene's warnings as the CLI's own lines ("volpath: warning: file:line: ..."), not
    Python's (which name Volpath's source)."""
    if issubclass(category, SceneWarning):
        print(f"volpath: warning: {message}", file=sys.stderr)
    else:
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


def _params(defines, parser):
    params = {}
    for d in defines or []:
        if "=" not in d:
            parser.error(f"-D expects name=value, got '{d}'")
        k, v = d.split("=", 1)
        params[k.strip()] = v.strip()
    return params


def _render(args, parser):
    from tqdm import tqdm

    scene = load_file(args.scene, **_params(args.define, parser))
    out = args.output
    if os.path.dirname(out) and not os.path.isdir(os.path.dirname(out)):
        parser.error(f"output directory '{os.path.dirname(out)}' does not exist")
    target = args.target_error
    spp = args.spp or (None if target else scene.spp)
    tracer = args.tracer or scene.tracer
    what = f"up to {spp or 'the cap of'} spp, target error {100 * target:g} %" if target else f"{spp} spp"
    bar = tqdm(
        total=100,
        unit="%",
        desc=f"{scene.width}x{scene.height} {what} {tracer}",
        disable=args.quiet,
        bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}{postfix}",
    )

    def progress(fraction):
        bar.n = round(100 * fraction, 1)
        bar.refresh()
        return True

    def status(s):
        bar.set_postfix_str(describe(s), refresh=False)

    start = time.perf_counter()
    try:
        image = render(
            scene,
            spp=spp,
            seed=args.seed,
            threads=args.threads,
            tracer=tracer,
            progress=progress,
            max_depth=args.max_depth,
            target_error=target,
            status=status,
            denoise=args.denoise,
        )
    finally:
        bar.close()
    seconds = time.perf_counter() - start
    stats = scene.last_render
    spp = stats["spp"]
    if stats.get("auto"):
        tracer = stats["tracer"]
        print(f"auto: {tracer}: " + "; ".join(stats["auto"]["reasons"]))
    metadata = {
        "volpath_version": __version__,
        "spp": spp,
        "tracer": tracer,
        "seed": args.seed,
        "seconds": seconds,
        "nonfinite_samples": stats["nonfinite_samples"],
        "negative_samples": stats["negative_samples"],
        "denoised": int(args.denoise),
    }
    samples = f"{spp} spp"
    if target:
        metadata.update(target_error=target, error=stats["error"], spp_mean=stats["spp_mean"])
        samples = (
            f"error {100 * stats['error']:.2g} % (target {100 * target:g} %), {stats['spp_min']}-{spp} spp "
            f"(mean {stats['spp_mean']:.0f})"
        )
    write_exr(out, image, metadata=metadata)
    samples += ", denoised" if args.denoise else ""
    print(
        f"{out}: {scene.width}x{scene.height}, {samples}, tracer {tracer}, {seconds:.2f} s, "
        f"{stats['nonfinite_samples']} non-finite samples discarded, {stats['negative_samples']} negative "
        f"samples clamped ({stats['clamped_share']:.1e} of the light)"
    )


def _info(args, parser):
    scene = load_file(args.scene, **_params(args.define, parser))
    s = scene.summary
    if args.json:
        print(
            json.dumps(
                {
                    "settings": {
                        "spp": scene.spp,
                        "tracer": scene.tracer,
                        "max_depth": scene.max_depth,
                        "rr_depth": scene.rr_depth,
                    },
                    **s,
                    "memory": scene.memory,
                },
                indent=2,
            )
        )
        return
    cam = s["camera"]
    print(f"{args.scene}")
    print(
        f"  film      {cam['width']}x{cam['height']}, fov {cam['fov']:.2f} ({cam['fov_axis']}), "
        f"camera at {', '.join(f'{v:g}' for v in cam['origin'])}"
        + (f", inside medium {cam['medium']}" if cam["medium"] >= 0 else "")
    )
    print(f"  settings  {scene.spp} spp, tracer {scene.tracer}, max_depth {scene.max_depth}, rr_depth {scene.rr_depth}")
    grouped = sum("group" in sh for sh in s["shapes"])
    print(
        f"  shapes    {len(s['shapes'])}"
        + (f" ({grouped} in shape groups), {s['instances']} instances" if grouped or s["instances"] else "")
    )
    for sh in s["shapes"]:
        extra = (
            f"{sh['triangles']} triangles"
            if "triangles" in sh
            else "analytic box"
            if sh.get("box")
            else f"radius {sh['radius']:g}"
        )
        group = f", in group {sh['group']}" if "group" in sh else ""
        print(f"    {sh['type']:<10} {extra}{', emitter' if sh['emitter'] else ''}{group}")
    print(f"  media     {len(s['media'])}")
    for m in s["media"]:
        tau = m.get("optical_thickness")
        tau_text = f", optical thickness {tau[0]:.3g}..{tau[1]:.3g}" if tau else ""
        if m["type"] == "atmosphere":
            print(
                f"    [{m['index']}] atmosphere: planet radius {m['planet_radius']:.6g}, height {m['height']:.6g}, "
                f"sea-level sigma_t {[float(f'{v:.4g}') for v in m['sigma_t']]}, g {m['g']}, {m['mode']} mode"
            )
        elif m["type"] == "homogeneous":
            print(
                f"    [{m['index']}] homogeneous sigma_t {[round(v, 6) for v in m['sigma_t']]}, "
                f"albedo {[round(v, 4) for v in m['albedo']]}, g {m['g']}{tau_text}"
            )
        else:
            lo, hi = m["sigma_t_range"]
            print(
                f"    [{m['index']}] heterogeneous {'x'.join(map(str, m['resolution']))} grid "
                f"({m['memory'] / 2**20:.1f} MiB resident), sigma_t {lo:.3g}..{hi:.3g}, g {m['g']}{tau_text}"
            )
    print(f"  emitters  {len(s['emitters'])}")
    for e in s["emitters"]:
        print(f"    {e['type']}")
    print(f"  bsdfs     {len(s['bsdfs'])}")
    for b in s["bsdfs"]:
        named = f" {b['id']!r}" if b["id"] else ""
        print(f"    {b['type']}{' (two-sided)' if b['twosided'] else ''}{named}")
    print(f"  textures  {len(s['textures'])}")
    for t in s["textures"]:
        named = f" {t['id']!r}" if t["id"] else ""
        if t["type"] == "bitmap":
            source = t["filename"] or "texels in the dictionary"
            w, h = t["size"]
            encoding = "sRGB" if t["srgb"] else "linear"
            print(f"    bitmap{named} {source}: {w}x{h}, {t['channels']} channel(s), {t['texel']} {encoding}")
        else:
            print(f"    {t['type']}{named}")
    memory = scene.memory
    print(
        f"  memory    {memory['total'] / 2**20:.1f} MiB: "
        + ", ".join(f"{part} {n / 2**20:.1f}" for part, n in memory.items() if part != "total")
    )
    print(f"  warnings  {len(s['warnings'])}")
    for w in s["warnings"]:
        print(f"    {w}")


def main(argv=None):
    parser = argparse.ArgumentParser(prog="volpath", description="Volpath volumetric path tracer")
    parser.add_argument("--version", action="version", version=f"volpath {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render", help="render a scene to an EXR file")
    r.add_argument("scene")
    r.add_argument("-o", "--output", required=True, help="output .exr file")
    r.add_argument(
        "--spp", type=int, help="samples per pixel (default: the scene's; with --target-error the cap, default 1024)"
    )
    r.add_argument(
        "--target-error",
        type=float,
        metavar="E",
        help="render until the displayed image's RMS error is E, in display units 0..1 "
        "(e.g. 0.01; volpath/adaptive.py defines it)",
    )
    r.add_argument(
        "--denoise",
        action="store_true",
        help="denoise with Intel Open Image Denoise (less noise, some bias: off by default)",
    )
    r.add_argument("--tracer", choices=("auto",) + TRACERS, help="default: the scene's (usually auto)")
    r.add_argument("--threads", type=int, help="default: all cores")
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--max-depth", type=int, help="path segments (default: the scene's)")
    r.add_argument("-D", "--define", action="append", metavar="NAME=VALUE", help="override a <default> parameter")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    i = sub.add_parser("info", help="print what a scene contains")
    i.add_argument("scene")
    i.add_argument("-D", "--define", action="append", metavar="NAME=VALUE")
    i.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    warnings.showwarning = _show_warning
    try:
        if args.command == "render":
            if args.spp is not None and args.spp < 1:
                parser.error("--spp must be at least 1")
            if args.target_error is not None and not 0 < args.target_error < 1:
                parser.error("--target-error must be a display error in (0, 1), e.g. 0.01")
            if args.threads is not None and args.threads < 1:
                parser.error("--threads must be at least 1")
            _render(args, parser)
        else:
            _info(args, parser)
    except (SceneError, ValueError) as e:
        print(f"volpath: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("volpath: interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
