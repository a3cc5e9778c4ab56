"""Interleaved A/B runs: two or more builds of Volpath on one scene, time to equal error.

For changes to the estimators that keep them unbiased, the error at a fixed spp is the
per-pixel standard deviation, and it falls as 1/sqrt(time): the time to an equal error is
proportional to variance x time. Each build renders the scene with the same seeds, in
turn (build A seed 0, build B seed 0, A seed 1, ...), so that the machine's drift spreads
over all of them; the variance is each pixel's variance across the seeds, averaged over
the image, and the time the median seconds per render. Prints each build's figures and
its ratio to the first (< 1: faster to equal error).

A build is a git revision (built from `git archive`, cached by commit in bench/cache/ab/)
or `WORKTREE`, the working tree as it is (uncommitted changes included), e.g.

    .venv/bin/python bench/ab.py HEAD WORKTREE --scene bench/scenes/hetero_cube.xml --param res=128 --spp 32

This measures changes one at a time, on this machine, with nothing else running: it is how
the README's and the commits' "interleaved A/B" figures were taken. `make bench` compares
Volpath with its peers.
"""

import argparse
import io
import os
import shutil
import subprocess
import sys
import sysconfig
import tarfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CACHE = os.path.join(ROOT, "bench", "cache", "ab")

CHILD = r"""
import sys, time, numpy as np, volpath
scene, spp, seed, threads, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
params = dict(p.split("=", 1) for p in sys.argv[6:])
s = volpath.load_file(scene, **params)
start = time.perf_counter()
image = volpath.render(s, spp=spp, seed=seed, threads=threads)
seconds = time.perf_counter() - start
if s.last_render["nonfinite_samples"]:
    sys.exit("non-finite samples")
np.save(out, image)
print(seconds)
"""


def time_to_equal_error(images, seconds, exposure=None):
    """Variance x time: the per-pixel variance across renders with different seeds (averaged
    over the image) times the median seconds per render. Proportional to the time an
    unbiased renderer needs to reach a given error. With `exposure` (stops), the variance of
    the displayed images (volpath.tonemap.display), as the video shows them."""
    stack = np.stack(images).astype(np.float64)
    if exposure is not None:
        from volpath.tonemap import display

        stack = display(stack, exposure)
    variance = float(stack.var(axis=0, ddof=1).mean())
    return variance, float(np.median(seconds)), variance * float(np.median(seconds))


def source_tree(rev):
    """A directory holding native/ and volpath/ of `rev` (WORKTREE: the repository itself),
    and a cache key."""
    if rev == "WORKTREE":
        return ROOT, "worktree"
    sha = subprocess.run(["git", "rev-parse", "--verify", rev + "^{commit}"], cwd=ROOT, capture_output=True, text=True)
    if sha.returncode:
        sys.exit(f"ab.py: {rev!r} is not a revision of this repository")
    sha = sha.stdout.strip()
    src = os.path.join(CACHE, sha, "src")
    if not os.path.isdir(src):
        archive = subprocess.run(
            ["git", "archive", sha, "native", "volpath"], cwd=ROOT, capture_output=True, check=True
        ).stdout
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            # Our own archive; the "data" filter where this Python has it (3.11.4 on).
            tar.extractall(src, **({"filter": "data"} if hasattr(tarfile, "data_filter") else {}))
    return src, sha


def build(rev):
    """The volpath package of `rev`, its native module built as `make setup` builds it
    (Release), in bench/cache/ab/<commit>/. Returns the directory to put on sys.path."""
    src, key = source_tree(rev)
    work = os.path.join(CACHE, key)
    build_dir, pkg = os.path.join(work, "build"), os.path.join(work, "pkg")
    if not os.path.exists(os.path.join(build_dir, "CMakeCache.txt")):  # later builds reconfigure as needed
        import pybind11

        subprocess.run(
            [
                "cmake",
                "-S",
                os.path.join(src, "native"),
                "-B",
                build_dir,
                "-DCMAKE_BUILD_TYPE=Release",
                f"-Dpybind11_DIR={pybind11.get_cmake_dir()}",
                f"-DPython_EXECUTABLE={sys.executable}",
            ],
            check=True,
            capture_output=True,
        )
    subprocess.run(
        ["cmake", "--build", build_dir, "--target", "_core", "-j", str(os.cpu_count() or 2)],
        check=True,
        capture_output=True,
    )
    shutil.rmtree(pkg, ignore_errors=True)
    shutil.copytree(
        os.path.join(src, "volpath"), os.path.join(pkg, "volpath"), ignore=shutil.ignore_patterns("*.so", "__pycache__")
    )
    for name in os.listdir(build_dir):
        if name.startswith("_core") and name.endswith(".so"):
            shutil.copy(os.path.join(build_dir, name), os.path.join(pkg, "volpath"))
    # The OpenVDB reader does not change with the core: the installed one serves all builds.
    import importlib.util

    vdb = importlib.util.find_spec("volpath._vdb")
    if vdb and vdb.origin:
        shutil.copy(vdb.origin, os.path.join(pkg, "volpath"))
    return pkg


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("revs", nargs="+", help="git revisions, or WORKTREE; the first is the baseline")
    ap.add_argument("--scene", default=os.path.join(ROOT, "bench", "scenes", "hetero_cube.xml"))
    ap.add_argument("--param", action="append", default=[], help="a scene parameter, name=value (repeatable)")
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--seeds", type=int, default=6, help="renders per build and round")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument(
        "--display",
        action="store_true",
        help="the variance of the displayed images, at the first build's auto exposure (for the sunrise)",
    )
    args = ap.parse_args()
    if len(args.revs) < 2:
        ap.error("give at least two builds")
    if args.seeds * args.rounds < 4:
        ap.error("at least 4 renders per build (seeds x rounds) to estimate a variance")
    subprocess.run([sys.executable, os.path.join(ROOT, "bench", "make_grids.py")], check=True, capture_output=True)
    packages = {}
    for rev in dict.fromkeys(args.revs):
        print(f"building {rev} ...", flush=True)
        packages[rev] = build(rev)
    site = sysconfig.get_paths()["purelib"]
    renders = {rev: ([], []) for rev in packages}
    out = os.path.join(CACHE, "image.npy")
    for r in range(args.rounds):
        for s in range(args.seeds):
            for rev, pkg in packages.items():
                # -S: no site hooks, so that the editable install's finder does not shadow `pkg`.
                env = dict(os.environ, PYTHONPATH=os.pathsep.join([pkg, site]))
                result = subprocess.run(
                    [
                        sys.executable,
                        "-S",
                        "-c",
                        CHILD,
                        os.path.abspath(args.scene),
                        str(args.spp),
                        str(1000 * r + s),
                        str(args.threads),
                        out,
                        *args.param,
                    ],
                    env=env,
                    cwd=CACHE,
                    capture_output=True,
                    text=True,
                )
                if result.returncode:
                    sys.exit(f"ab.py: {rev} failed:\n{result.stderr}")
                renders[rev][0].append(np.load(out))
                renders[rev][1].append(float(result.stdout.split()[-1]))
    base = exposure = None
    if args.display:
        from volpath.tonemap import auto_exposure

        exposure = auto_exposure(np.mean(next(iter(renders.values()))[0], axis=0))
    for rev, (images, seconds) in renders.items():
        variance, median, cost = time_to_equal_error(images, seconds, exposure)
        base = base or cost
        print(
            f"{rev:>12}: {median:.3f} s per render, variance {variance:.4e}, mean {np.mean(images):.5f}, "
            f"time to equal error {cost / base:.3f}x the first"
        )


if __name__ == "__main__":
    main()
