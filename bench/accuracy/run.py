"""What accuracy costs in time: error against a high-spp reference versus wall time, for
each estimator and option, on the bench scenes, a sparse VDB cloud and a sunrise sky (RGB
and spectral); Mitsuba 3 and Cycles 5.0 in the same run where they can render the scene.
Writes docs/accuracy.md and its PNG plots. References are cached in bench/cache/ so reruns
are quick, and so are the measurements: `--only` re-measures some scenes and reuses the
others', `--report-only` rewrites the report from them.

Per scene and variant: renders at a ladder of sample counts (2 threads), RMSE against the
reference, a log-log fit of RMSE against seconds, the bias that does not shrink with
samples (from two independent high-spp renders), and the time to reach a common target
error (the reference estimator's error at the middle of the ladder). Mitsuba 3 and Cycles
5.0 render the same scenes where they can (Mitsuba reads the bench files, Cycles renders
their equivalents built through the bpy module).
"""

import argparse
import datetime
import json
import os
import subprocess
import sys
import time
from typing import NamedTuple

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.dirname(HERE))
import compare_mitsuba as cm  # noqa: E402  (sets up Mitsuba's LLVM path)
from accuracy.denoise import kept_section  # noqa: E402

import volpath  # noqa: E402

CACHE = os.path.join(ROOT, "bench", "cache")
DOCS = os.path.join(ROOT, "docs")

TRACERS = ["auto", "absorption", "single", "multiple", "nee_mis", "null_scattering"]
NULL = {"tracer": "null_scattering"}


class Study(NamedTuple):
    """One scene of the study. Variants are (label, render keywords, scene options); scene
    options are the bench file's parameters, plus `majorants` for the hetero cube (a
    Volpath-only option kept out of the file that Mitsuba also reads). `peers` are (label,
    make(path, res)) pairs of other renderers; `reference` is the reference's scene options
    (its tracer is null_scattering)."""

    name: str
    desc: str
    path: str
    variants: list
    peers: tuple = ()
    options: dict = {}
    reference: dict = {}


def peers(key, mitsuba, cycles):
    """Mitsuba 3's variants (where it can read the scene file) and Cycles (bench/cycles_scenes.py)."""
    out = [(f"Mitsuba {v}", lambda p, res, v=v: cm.Mitsuba(v, p, res)) for v in mitsuba]
    if cycles:
        from cycles_scenes import Cycles

        out.append(("Cycles", lambda p, res: Cycles(key, res, cm.THREADS)))
    return tuple(out)


def scene_list(mitsuba, cycles):
    bench = os.path.join(ROOT, "bench", "scenes")
    sky = os.path.join(ROOT, "scenes", "test", "sky.xml")
    sunrise = {"elevation": 2, "azimuth": 60}
    out = []
    for key, (stem, desc) in cm.SCENES.items():
        heterogeneous = key == "d"  # only the null-scattering tracer handles grids
        variants = [
            (t, {"tracer": t}, {})
            for t in TRACERS
            if not (heterogeneous and t in ("absorption", "single", "multiple", "nee_mis"))
        ]
        variants.append(("null_scattering, independent sampler", {**NULL, "sampler": "independent"}, {}))
        if key == "d":
            variants += [
                (f"majorant grid {r}³" if r > 1 else "one global majorant", NULL, {"majorants": r}) for r in (1, 8, 16)
            ]
        if key in ("b", "e"):  # a point light; the sun
            variants.append(("null_scattering, no light distances", {**NULL, "light_distances": False}, {}))
        if key == "c":
            variants += [
                (f"nee_mis max_depth {d}", {"tracer": "nee_mis", "max_depth": d}, {}) for d in (1, 2, 4, 8, 16, 32)
            ]
            variants += [("nee_mis no Russian roulette", {"tracer": "nee_mis", "rr_depth": 10**6}, {})]
        out.append(
            Study(f"({key}) {stem}", desc, os.path.join(bench, f"{stem}.xml"), variants, peers(key, mitsuba, cycles))
        )
    out.append(
        Study(
            "sparse cloud",
            "128³ cumulus puffs read from a .vdb (about 4 % of the voxels active, σt up to 150), "
            "albedo 0.98, g = 0.6, sun and sky, all orders of scattering",
            os.path.join(bench, "cloud.xml"),
            [
                ("auto", {"tracer": "auto"}, {}),
                ("null_scattering (automatic majorant grid)", NULL, {}),
                ("one global majorant", NULL, {"majorants": 1}),
                ("majorant grid 8³", NULL, {"majorants": 8}),
                ("majorant grid 32³", NULL, {"majorants": 32}),
                ("independent sampler", {**NULL, "sampler": "independent"}, {}),
            ],
            peers("cloud", (), cycles),
        )
    )  # Mitsuba 3 reads no .vdb
    out.append(
        Study(
            "sunrise sky",
            "Bruneton atmosphere, camera 2 m up, looking 60° away from the sun at 2° "
            "elevation (the sun's disc, a sub-pixel emitter, would dominate any error measure), "
            "multiple scattering",
            sky,
            [
                ("null_scattering (guided free flight, tabulated transmittances, sky map)", NULL, {}),
                ("guided free flight without the sky map (no control variates)", NULL, {"skymap": "false"}),
                ("delta tracking, 4 majorant pieces", NULL, {"flight": "tracking"}),
                ("delta tracking, one majorant per ray", NULL, {"flight": "tracking", "pieces": 1}),
                ("delta tracking, 16 majorant pieces", NULL, {"flight": "tracking", "pieces": 16}),
                ("guided, sun transmittance by quadrature on each ray", NULL, {"sun": "quadrature"}),
                ("unbiased: delta tracking, sun ratio-tracked", NULL, {"sun": "tracking", "flight": "tracking"}),
                ("single scattering (max_depth 2)", {**NULL, "max_depth": 2}, {}),
                ("max_depth 4", {**NULL, "max_depth": 4}, {}),
                ("auto", {"tracer": "auto"}, {}),
                ("independent sampler", {**NULL, "sampler": "independent"}, {}),
            ],
            options=sunrise,
        )
    )
    out.append(
        Study(
            "sunrise sky, spectral reference",
            "the same sky against a spectral-mode reference (4 passes of "
            "3 wavelengths): RGB mode's colour bias against spectral mode's cost",
            sky,
            [
                ("rgb", NULL, {}),
                ("spectral, 1 pass", NULL, {"mode": "spectral", "passes": 1}),
                ("spectral, 4 passes", NULL, {"mode": "spectral"}),
            ],
            options=sunrise,
            reference={"mode": "spectral"},
        )
    )
    return out


def load(study, res, options):
    options = {**study.options, **options}
    if "majorants" in options and study.name.startswith("(d)"):
        text = (
            open(study.path)
            .read()
            .replace(
                '<float name="scale" value="1.0"/>',
                f'<float name="scale" value="1.0"/><integer name="majorant_resolution" value="{options.pop("majorants")}"/>',
            )
        )
        return volpath.load_string(text, base_dir=os.path.dirname(study.path), res=res, **options)
    return volpath.load_file(study.path, res=res, **options)


def render(study, res, options, kwargs, spp, seed):
    """The image and its wall time; short renders are timed twice (the same seed, the same
    image) and the faster time kept, since a busy moment of the machine weighs most there."""
    scene = load(study, res, options)
    kw = dict(kwargs)
    if "rr_depth" in kw:
        scene.rr_depth = kw.pop("rr_depth")
    seconds = []
    while not seconds or (len(seconds) < 2 and sum(seconds) < 2.0):
        start = time.perf_counter()
        img = volpath.render(scene, spp=spp, seed=seed, threads=cm.THREADS, **kw)
        seconds.append(time.perf_counter() - start)
    return img.astype(np.float64), min(seconds)


def _stem(study):
    return study.name.replace(" ", "_").replace(",", "").replace("(", "").replace(")", "")


def reference(study, res, seconds):
    """The reference image and its own variance (compare_mitsuba.reference: two independent
    halves), cached."""
    file = os.path.join(CACHE, f"{_stem(study)}_{res}.npz")
    if os.path.exists(file):
        cached = np.load(file)
        if "var" in cached:  # older caches lack the variance: render again
            return cached["image"], float(cached["var"])
    _, t16 = render(study, res, study.reference, NULL, 16, 1)
    spp = int(2 ** np.clip(np.round(np.log2(16 * seconds / max(t16, 1e-3))), 8, 16))
    print(f"  reference: {spp} spp", flush=True)

    class Halves:
        def render(self, spp, seed):
            return render(study, res, study.reference, NULL, spp, seed)

    img, var, _ = cm.reference(Halves(), spp)
    np.savez_compressed(file, image=img, var=var, spp=spp)
    return img, var


def measure(study, res, options, kwargs, ladder, ref, ref_var):
    """(spp, seconds, RMSE net of the reference's noise or None where it is below it) per
    rung, and the estimator's bias."""
    pts = []
    for spp in ladder:
        img, sec = render(study, res, options, kwargs, spp, spp)
        pts.append((spp, sec, cm.rmse_net(cm.mse(img, ref), ref_var)))
    # Bias: two independent renders at the top of the ladder; what their mean's squared error
    # has beyond its own noise (from their difference) and the reference's does not shrink
    # with samples.
    a, _ = render(study, res, options, kwargs, ladder[-1], 7001)
    b, _ = render(study, res, options, kwargs, ladder[-1], 7002)
    noise2 = cm.mse(a, b) / 4
    bias = float(np.sqrt(max(0.0, cm.mse((a + b) / 2, ref) - noise2 - ref_var)))
    return pts, bias


def measured(pts):
    """The points whose error could be told from the reference's noise."""
    return [p for p in pts if p[2] is not None]


def biased(bias, target):
    """Whether the estimator's bias keeps it from ever reaching the target error."""
    return bias is not None and bias > 0.7 * target


def time_to(pts, target, bias):
    """Seconds to reach `target` from the fit; None when the estimator is biased(), or fewer
    than two of its errors stand out of the reference's noise."""
    if biased(bias, target):
        return None
    pts = measured(pts)
    if len(pts) < 2:
        return None
    t, _, _ = cm.time_for([(s, e) for _, s, e in pts], target)
    return t


def plot(name, curves, target, file):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=110)
    colours = plt.get_cmap("tab20")
    for i, (label, pts) in enumerate(curves.items()):
        # Twenty distinct colours, and dashes for the peers, so no two curves look alike.
        peer = label.startswith(("Mitsuba", "Cycles"))
        pts = measured(pts)
        ax.loglog(
            [s for _, s, _ in pts],
            [e for _, _, e in pts],
            "o--" if peer else "o-",
            ms=3,
            color=colours(i % 20),
            label=label,
        )
    ax.axhline(target, color="grey", lw=0.8, ls="--", label="target error")
    ax.set_xlabel("seconds (2 threads)")
    ax.set_ylabel("RMSE against the reference")
    ax.set_title(name)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(file)
    plt.close(fig)


def summary_plot(rows, file):
    """Seconds to each scene's target error: auto, the best fixed tracer, and each peer's best."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    series = [("auto", "o"), ("best fixed tracer", "s"), ("Mitsuba 3 (faster variant)", "^"), ("Cycles 5.0", "D")]
    fig, ax = plt.subplots(figsize=(8.4, 0.45 * len(rows) + 1.4), dpi=110)
    for j, (label, marker) in enumerate(series):
        # A dot per scene and series (bars would mislead on a log axis).
        xs = [row[1][j] or np.nan for row in rows]
        ax.plot(
            xs,
            np.arange(len(rows)) + 0.12 * (j - 1.5),
            marker,
            ls="none",
            ms=6,
            label=label,
            color=plt.get_cmap("tab10")(j),
        )
    ax.set_yticks(range(len(rows)), [row[0] for row in rows], fontsize=8)
    ax.set_ylim(len(rows) - 0.5, -0.5)
    ax.set_xscale("log")
    ax.set_xlabel("seconds to the scene's target error (2 threads; shorter is better)")
    ax.grid(True, axis="x", which="both", lw=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1))
    fig.tight_layout()
    fig.savefig(file)
    plt.close(fig)


def measure_study(study, args):
    """Curves and biases of every variant and peer, and the target error; saved as JSON."""
    ref, ref_var = reference(study, args.res, args.ref_seconds)
    curves, biases = {}, {}
    for label, kwargs, options in study.variants:
        curves[label], biases[label] = measure(study, args.res, options, kwargs, args.ladder, ref, ref_var)
    for label, make in study.peers:
        renderer = make(study.path, args.res)
        curves[label] = [
            (spp, sec, cm.rmse_net(cm.mse(img, ref), ref_var))
            for spp in args.ladder
            for img, sec in [renderer.render(spp, spp)]
        ]
        biases[label] = None
    # The common target: the reference estimator's error at the middle of the ladder.
    mid = args.ladder[len(args.ladder) // 2]
    plain = next(l for l, kw, o in study.variants if kw == NULL and o == study.reference)
    target = next(e for s, _, e in curves[plain] if s == mid)
    if target is None:
        raise SystemExit(f"{study.name}: the reference is too noisy to measure the target error; raise --ref-seconds")
    return {
        "curves": curves,
        "biases": biases,
        "target": target,
        "mean": float(ref.mean()),
        "ref_rmse": float(np.sqrt(ref_var)),
    }


def report(study, result):
    """The study's Markdown section (and its plot), and its (auto, best fixed, Mitsuba,
    Cycles) seconds to target for the summary."""
    curves, biases, target = result["curves"], result["biases"], result["target"]
    png = f"accuracy/{study.name.split(' ', 1)[-1].replace(' ', '_').replace(',', '')}.png"
    plot(study.name, curves, target, os.path.join(DOCS, png))
    times = {label: time_to(pts, target, biases[label]) for label, pts in curves.items()}
    rows = []
    for label, pts in curves.items():
        t, bias = times[label], biases[label]
        fitted = measured(pts)
        slope = f"{cm.fit([(s, e) for _, s, e in fitted])[1]:.2f}" if len(fitted) >= 2 else "—"
        reach = f"{t:.3g}" if t else "never (bias)" if biased(bias, target) else "— (too few points)"
        rows.append(
            f"| {label} | {reach} | {slope} | {'—' if bias is None else f'{bias:.3g}'} | "
            + " · ".join(
                f"{s}: {f'{e:.3g}' if e is not None else 'within the reference noise'} in {sec:.2f} s"
                for s, sec, e in pts
            )
            + " |"
        )
    mean = result["mean"]
    section = (
        f"### {study.name}\n\n{study.desc}. Reference mean {mean:.4g}; target RMSE {target:.4g} "
        f"({target / mean:.1%} of the mean); the reference's own RMSE {result['ref_rmse']:.2g}."
        f"\n\n![{study.name}]({png})\n\n"
        "| estimator | seconds to target | slope | bias | spp: RMSE in time |\n|---|---|---|---|---|\n"
        + "\n".join(rows)
        + "\n"
    )
    fixed = [l for l, kw, o in study.variants if list(kw) == ["tracer"] and kw["tracer"] != "auto" and not o]
    best = min((l for l in fixed if times.get(l)), key=lambda l: times[l], default=None)
    mitsuba = min((t for l, t in times.items() if l.startswith("Mitsuba") and t), default=None)
    summary = None
    if "auto" in times and best:
        summary = (times["auto"], times[best], mitsuba, times.get("Cycles"), best)
    return section, summary


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--ladder", type=int, nargs="+", default=[4, 16, 64, 256])
    ap.add_argument("--ref-seconds", type=float, default=40)
    ap.add_argument(
        "--only", help="substring of the scene names to measure (the others' saved measurements are reused)"
    )
    ap.add_argument("--report-only", action="store_true", help="write docs/accuracy.md from the saved measurements")
    ap.add_argument("--no-cycles", dest="cycles", action="store_false", help="leave Cycles out")
    args = ap.parse_args()
    if args.cycles and not args.report_only:
        try:
            import bpy  # noqa: F401
        except ImportError:
            print("  (Cycles unavailable: no bpy module)")
            args.cycles = False
    if not args.report_only:
        subprocess.run([sys.executable, os.path.join(ROOT, "bench", "make_grids.py")], check=True)
    os.makedirs(os.path.join(DOCS, "accuracy"), exist_ok=True)
    os.makedirs(CACHE, exist_ok=True)
    sections, summary = [], []
    for study in scene_list([] if args.report_only else cm.mitsuba_variants(), args.cycles and not args.report_only):
        saved = os.path.join(CACHE, f"accuracy_{_stem(study)}_{args.res}.json")
        if not args.report_only and (not args.only or args.only in study.name):
            print(study.name, flush=True)
            result = dict(
                measure_study(study, args),
                ladder=args.ladder,
                date=datetime.date.today().isoformat(),
                machine=cm.machine(),
            )
            with open(saved, "w") as f:
                json.dump(result, f)
        elif os.path.exists(saved):
            with open(saved) as f:
                result = json.load(f)
        else:
            print(f"{study.name}: no saved measurement at {args.res}², left out")
            continue
        section, times = report(study, result)
        sections.append(section)
        if times:
            summary.append((study.name, times))
    summary_plot(summary, os.path.join(DOCS, "accuracy", "summary.png"))
    fmt = lambda t: f"{t:.3g}" if t else "—"
    table = "\n".join(
        f"| {name} | {fmt(a)} | {fmt(b)} ({best}) | {'%.2f' % (a / b) if a else '—'} | {fmt(m)} | {fmt(c)} |"
        for name, (a, b, m, c, best) in summary
    )
    date = datetime.date.today().isoformat()
    text = (
        f"# What accuracy costs in time\n\nProduced by `make accuracy` (bench/accuracy/run.py) on {date}, "
        f"{cm.machine()}; {args.res}×{args.res} pixels, {cm.THREADS} threads, spp ladder "
        f"{', '.join(map(str, args.ladder))}. Each curve is RMSE against a high-spp null-scattering "
        "reference versus wall time on log–log axes: unbiased estimators fall with slope about −0.5 "
        "with independent samples, and more steeply with the default low-discrepancy (Sobol) sampler "
        "where the integrand is smooth; "
        "an estimator that leaves physics out (absorption only, single scattering, a depth limit) "
        "flattens at its bias, listed in the tables. The reference is rendered as two independent "
        "halves, whose difference measures its own variance; that variance is taken off every "
        "squared error and off the bias estimate (an image's squared error against an independent "
        "reference is its own plus the reference's), so the curves are errors against the true "
        "image, and a point whose error the reference's noise hides is left out of the fit. "
        "'Seconds to target' comes from the "
        "fit and is 'never' where the bias exceeds the target. Renders under 2 s are timed twice "
        "and the faster kept. Mitsuba 3 renders the bench files themselves; Cycles 5.0 renders "
        "each scene rebuilt through the `bpy` module (bench/cycles_scenes.py; its per-render scene "
        "synchronisation is not counted), so its curve also shows how far its scene and conventions "
        "differ from Volpath's (a floor at the difference).\n\n"
        "## Seconds to each scene's target error\n\n![summary](accuracy/summary.png)\n\n"
        "| scene | auto s | best fixed tracer s | auto / best | Mitsuba 3 s | Cycles s |\n"
        "|---|---|---|---|---|---|\n" + table + "\n\n## Scenes\n\n" + "\n".join(sections)
    )
    path = os.path.join(DOCS, "accuracy.md")
    kept = kept_section(path)  # bench/accuracy/denoise.py's section
    with open(path, "w") as f:
        f.write(text + ("\n\n" + kept + "\n" if kept else ""))
    print(text)


if __name__ == "__main__":
    main()
