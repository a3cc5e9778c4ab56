"""Cycles parity (issue #38): the scenes of tests/parity_scenes.py, one exported feature
each, rendered by Volpath (F12) and Cycles 5.0 with matched settings; prints each scene's
image mean ratio and the largest relative difference among 8x8 block means, as a markdown
table for bench/RESULTS.md.

    .venv/bin/python bench/parity.py [--spp 1024] [--size 96x72]
"""

import argparse
import os
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path[:0] = [ROOT, os.path.join(ROOT, "tests")]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--size", default="96x72")
    ap.add_argument("--only", help="one scene's name")
    args = ap.parse_args()
    size = tuple(int(v) for v in args.size.split("x"))
    from blender_scenes import blank_scene
    from parity_scenes import KNOWN_DIFFERENCES, SCENES, agreement, build, render_both

    print(f"| scene ({args.spp} spp, {size[0]}x{size[1]}) | image mean, Volpath / Cycles | largest block difference |")
    print("|---|---|---|")
    for name in [args.only] if args.only else SCENES:
        with tempfile.TemporaryDirectory() as directory:
            scene = blank_scene()
            build(name, scene, directory)
            ratio, block = agreement(*render_both(scene, directory, args.spp, size))
        note = f" ({KNOWN_DIFFERENCES[name]})" if name in KNOWN_DIFFERENCES else ""
        print(f"| {name}{note} | {ratio:.3f} | {100 * block:.1f} % |", flush=True)


if __name__ == "__main__":
    main()
