"""Time to equal error: Volpath against Mitsuba 3 and Cycles 5.0 on the bench scenes, in one run.

For each scene: a high-spp Volpath reference (two independent halves, so that its own
variance can be taken off every squared error); then the renderers render at a ladder of
sample counts, each rung by all of them in turn (2 threads; Mitsuba's second of two
renders timed, so its LLVM kernels are compiled beforehand; Cycles' per-render scene
synchronisation subtracted) and each one's RMSE against the reference is fitted as RMSE = a * t^b on log-log axes. The target error is what the fastest Mitsuba
variant reaches at --target-spp; the table gives the time each renderer needs for it, and
Volpath's ratio to the better peer. Cycles renders each scene's equivalent built through
the bpy module (bench/cycles_scenes.py). Each peer's highest-spp image also checks that
it agrees with Volpath's reference (difference of the means).
"""

import argparse
import datetime
import os
import platform
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
if os.path.exists(LLVM):
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)

from publish import publish  # noqa: E402  (bench/)

import volpath  # noqa: E402

SCENES = {
    "a": ("absorbing_sphere", "σt=1 sphere absorbing in front of a back-light"),
    "b": ("single_scattering", "albedo-0.8 sphere, point light, max_depth 2"),
    "c": ("dense_multiple", "σt=5, albedo 0.99, g=0.6 sphere over a floor, area light, max_depth 64"),
    "d": ("hetero_cube", "64³ heterogeneous cube (τ up to ~20), chromatic albedo, sun + sky"),
    "e": ("thin_fog", "1000 m box of fog σt=1e-3, sun, camera in the fog"),
}
THREADS = 2


def mse(img, ref):
    return float(np.mean((np.asarray(img, np.float64) - ref) ** 2))


def reference(vp, spp):
    """Volpath at spp, as the mean of two independent halves, and the variance that mean
    still has, E|A - B|^2 / 4 (pixel mean). An image's squared error against the reference is
    its own plus the reference's (independent seeds): without taking the latter off, a noisy
    reference flattens every error curve and favours the noisier renderer."""
    a, t_a = vp.render(spp // 2, 12345)
    b, t_b = vp.render(spp // 2, 54321)
    a, b = a.astype(np.float64), b.astype(np.float64)
    return (a + b) / 2, mse(a, b) / 4, t_a + t_b


def rmse_net(e, ref_var):
    """RMSE against the true image, from the squared error e against the reference: None
    where the reference's variance is not small enough to tell (the render is as good)."""
    return float(np.sqrt(e - ref_var)) if e > ref_var else None


class Volpath:
    name = "volpath"

    def __init__(self, path, res):
        self.scene = volpath.load_file(path, res=res)

    def render(self, spp, seed):
        start = time.perf_counter()
        img = volpath.render(self.scene, spp=spp, seed=seed, threads=THREADS)
        return img, time.perf_counter() - start


class Mitsuba:
    def __init__(self, variant, path, res):
        import drjit as dr
        import mitsuba as mi

        mi.set_variant(variant)
        dr.set_thread_count(THREADS)
        self.mi, self.variant, self.name = mi, variant, f"mitsuba {variant}"
        self.scene = mi.load_file(path, res=res)

    def render(self, spp, seed):
        mi = self.mi
        mi.set_variant(self.variant)  # scenes belong to the variant that loaded them
        np.asarray(mi.render(self.scene, spp=spp, seed=seed + 7919))  # compile / warm up
        start = time.perf_counter()
        img = np.asarray(mi.render(self.scene, spp=spp, seed=seed))
        return img[..., :3], time.perf_counter() - start


def mitsuba_variants():
    try:
        import mitsuba as mi
    except ImportError:
        return []
    found = []
    for v in ("scalar_rgb", "llvm_ad_rgb"):
        try:
            mi.set_variant(v)
            found.append(v)
        except Exception as e:  # missing LLVM: reported, not fatal
            print(f"  (mitsuba {v} unavailable: {e})")
    return found


def fit(points):
    """Least-squares fit of log(rmse) = a + b log(t); returns (a, b)."""
    t = np.log([p[0] for p in points])
    e = np.log([p[1] for p in points])
    b, a = np.polyfit(t, e, 1)
    return a, b


def time_for(points, target):
    """(seconds to reach target, fitted slope, bound): no extrapolation below the cheapest
    render, which is the time (an upper bound, bound=True) when it already meets the target."""
    a, b = fit(points)
    cheapest = min(points)
    if cheapest[1] <= target:
        return float(cheapest[0]), b, True
    return float(np.exp((np.log(target) - a) / b)), b, False


def run_scene(key, args, variants):
    stem, _ = SCENES[key]
    path = os.path.join(HERE, "scenes", f"{stem}.xml")
    vp = Volpath(path, args.res)
    _, t16 = vp.render(16, 1)
    ref_spp = int(2 ** np.clip(np.round(np.log2(16 * args.ref_seconds / max(t16, 1e-3))), 8, 16))
    ref, ref_var, ref_time = reference(vp, ref_spp)
    renderers = [vp] + [Mitsuba(v, path, args.res) for v in variants]
    if args.cycles:
        from cycles_scenes import Cycles

        renderers.append(Cycles(key, args.res, THREADS))
    # Rung by rung, every renderer in turn: the machine's speed drifts over minutes (shared
    # hosts), and interleaving spreads the drift over all renderers instead of one.
    rows = {r.name: [] for r in renderers}
    for spp in args.ladder:
        for r in renderers:
            if spp < getattr(r, "min_spp", 1):
                continue
            img, sec = r.render(spp, 1 + spp)
            # Repeats keep the fastest time: the machine only ever slows a render down.
            for _ in range(args.repeats - 1):
                sec = min(sec, r.render(spp, 1 + spp)[1])
            e = mse(img, ref)
            rows[r.name].append((sec, rmse_net(e, ref_var), spp, img, np.sqrt(e)))
    # Target: the fastest Mitsuba variant's error at target_spp (or Volpath's own if no peer).
    peers = [n for n in rows if n.startswith("mitsuba")]
    target = None
    if peers:
        at = {n: next(p for p in rows[n] if p[2] == args.target_spp) for n in peers}
        best = min(peers, key=lambda n: at[n][0])
        target = at[best][1]
    else:
        target = next(p for p in rows["volpath"] if p[2] == args.target_spp)[1]
    if target is None:
        raise SystemExit(f"({key}): the target render is as good as the reference; raise --ref-seconds")
    result = {
        "ref_spp": ref_spp,
        "ref_rmse": float(np.sqrt(ref_var)),
        "ref_time": ref_time,
        "target": target,
        "mean": float(ref.mean()),
        "renderers": {},
    }
    for n, pts in rows.items():
        t, slope, bound = time_for([(p[0], p[1]) for p in pts if p[1] is not None], target)
        result["renderers"][n] = {
            "time": t,
            "slope": slope,
            "bound": bound,
            "points": [(p[2], p[0], p[1], p[4]) for p in pts],
        }
        if n != "volpath":
            # Agreement: the highest-spp peer image against the reference, by the mean.
            img_hi = pts[-1][3]
            result["renderers"][n]["agreement"] = {
                "mean_diff_rel": float(np.mean(img_hi) - ref.mean()) / max(float(ref.mean()), 1e-12)
            }
    return result


def machine():
    cpu = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}"


def markdown(results, args, variants):
    date = datetime.date.today().isoformat()
    peers = [f"mitsuba {v}" for v in variants] + (["cycles"] if args.cycles else [])
    lines = [
        f"## Volpath vs Mitsuba 3 and Cycles 5.0 — {date}",
        "",
        f"Machine: {machine()}. {THREADS} threads each, {args.res}×{args.res}, reference: Volpath at the "
        "spp shown, as two independent halves, whose difference measures the reference's own variance (its "
        "RMSE shown): it is taken off every squared error, so that RMSEs are against the true image. "
        f"Target error: the fastest Mitsuba variant's RMSE at {args.target_spp} spp. Times to reach it "
        "come from a log–log fit of RMSE against seconds over spp "
        + ", ".join(map(str, args.ladder))
        + " (Cycles from 4: its times are net of a 1-spp render, the scene's synchronisation)"
        + (f"; each the fastest of {args.repeats} renders" if args.repeats > 1 else "")
        + "; a time "
        "marked ≤ is the cheapest render's, which already meets the target (no extrapolation below it).",
        f"Peers: {', '.join(peers) or 'none available'}. Target (issue #12): Volpath ≤ 0.5× the better peer.",
        "",
        "| scene | ref spp (RMSE) | target RMSE (rel.) | Volpath s | "
        + " | ".join(f"{v} s" for v in peers)
        + " | Volpath / best peer | slopes (V; peers) | mean diff vs peers |",
        "|---|---|---|---|" + "---|" * len(peers) + "---|---|---|",
    ]
    for key, r in results.items():
        rv = r["renderers"]["volpath"]
        mts = [r["renderers"].get(v) for v in peers]
        best = min((m["time"] for m in mts if m), default=None)
        ratio = f"**{rv['time'] / best:.2f}×**" if best else "—"
        slopes = f"{rv['slope']:.2f}; " + ", ".join(f"{m['slope']:.2f}" for m in mts if m)
        agree = ", ".join(f"{100 * m['agreement']['mean_diff_rel']:+.2f} %" for m in mts if m)
        shown = lambda m: f"{'≤' if m['bound'] else ''}{m['time']:.3f}"  # noqa: E731
        lines.append(
            f"| ({key}) {SCENES[key][0]} | {r['ref_spp']} ({r['ref_rmse']:.2g}) | {r['target']:.4g} ({r['target'] / max(r['mean'], 1e-12):.2%}) | "
            f"{shown(rv)} | " + " | ".join(shown(m) if m else "—" for m in mts) + f" | {ratio} | {slopes} | {agree} |"
        )
    lines += ["", "Raw points (spp, seconds, RMSE net of the reference's variance, RMSE against the reference):", ""]
    net = lambda e: "—" if e is None else f"{e:.4g}"  # noqa: E731
    for key, r in results.items():
        for n, rr in r["renderers"].items():
            pts = "; ".join(f"{s}: {t:.3f} s, {net(e)}, {raw:.4g}" for s, t, e, raw in rr["points"])
            lines.append(f"- ({key}) {n}: {pts}")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", default="abcde")
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--ladder", type=int, nargs="+", default=[1, 4, 16, 64, 256])
    ap.add_argument("--target-spp", type=int, default=64)
    ap.add_argument("--ref-seconds", type=float, default=60.0, help="time budget of each reference")
    ap.add_argument("--append", help="put this table in that Markdown file, in place of its earlier one")
    ap.add_argument(
        "--repeats",
        type=int,
        default=1,
        help="render each rung this many times and keep the fastest (for noisy machines)",
    )
    ap.add_argument("--no-cycles", dest="cycles", action="store_false", help="leave Cycles out")
    args = ap.parse_args()
    if args.cycles:
        try:
            import bpy  # noqa: F401
        except ImportError:
            print("  (Cycles unavailable: no bpy module)")
            args.cycles = False
    if args.target_spp not in args.ladder:
        ap.error("--target-spp must be one of the --ladder values")
    subprocess.run([sys.executable, os.path.join(HERE, "make_grids.py")], check=True, capture_output=True)
    variants = mitsuba_variants()
    results = {}
    for key in args.scenes:
        print(f"({key}) {SCENES[key][0]} ...", flush=True)
        results[key] = run_scene(key, args, variants)
    publish(markdown(results, args, variants), args.append, key="peers")


if __name__ == "__main__":
    main()
