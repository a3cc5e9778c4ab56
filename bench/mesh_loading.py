"""Loading a large mesh (issue #37): load time and peak memory of one bumpy sphere of N
triangles on its own, as binary PLY and as OBJ, Volpath beside Mitsuba 3 (scalar_rgb) and
Cycles 5.0 (the bpy module: Blender's importer, then Cycles' own scene and BVH), all on the
machine's cores, one run. Each measurement runs in a fresh process: "load" is loading the
file up to a built scene (plus a 1-spp 8x8 render, so nothing is left to build lazily),
"peak" the process's peak resident memory less what it held after importing the renderer.
With --plot, the load times and peaks against the triangle count, log-log, as a PNG.

    .venv/bin/python bench/mesh_loading.py [--sizes 100000 1000000] [--append bench/RESULTS.md]
        [--plot docs/mesh_loading.png]
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from publish import publish, table  # noqa: E402  (bench/)

SCENE = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="2"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
  <shape type="{kind}"><string name="filename" value="{file}"/><bsdf type="diffuse"/></shape>
</scene>
"""

# A child's peak resident memory, in bytes: VmHWM, not ru_maxrss, which Linux carries over
# exec from the parent (a large benchmark process would hide the child's own peak).
PEAK_MEMORY = r"""
def peak_memory():
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmHWM:"))
"""

# Run in a child: argv = renderer, scene path. Prints RESULT {"load": s, "peak": bytes}.
CHILD = (
    PEAK_MEMORY
    + r"""
import json, sys, time
renderer, path = sys.argv[1:]
if renderer == "volpath":
    import volpath
    load = lambda: volpath.load_file(path)
    render = lambda s: volpath.render(s, spp=1)
elif renderer == "cycles":
    import os, bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine, scene.cycles.device, scene.cycles.samples = "CYCLES", "CPU", 1
    scene.render.resolution_x = scene.render.resolution_y = 8
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(camera)
    camera.location = (0, -4, 0)
    camera.rotation_euler = (1.5708, 0, 0)
    scene.camera = camera
    mesh = os.path.join(os.path.dirname(path), "mesh." + os.path.basename(path).split(".")[0])
    importer = bpy.ops.wm.ply_import if mesh.endswith(".ply") else bpy.ops.wm.obj_import
    load = lambda: importer(filepath=mesh)
    render = lambda s: bpy.ops.render.render()
else:
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    load = lambda: mi.load_file(path)
    render = lambda s: mi.render(s, spp=1)
base = peak_memory()
start = time.perf_counter()
render(load())
seconds = time.perf_counter() - start
print("RESULT", json.dumps({"load": seconds, "peak": peak_memory() - base}))
"""
)


def bumpy_sphere(triangles):
    """Positions and triangles of a sphere with ripples, about `triangles` faces."""
    n = int(np.sqrt(triangles / 2))
    theta, phi = np.meshgrid(np.linspace(0, np.pi, n + 1), np.linspace(0, 2 * np.pi, n + 1), indexing="ij")
    r = 1 + 0.03 * np.sin(12 * theta) * np.sin(12 * phi)
    p = np.stack([r * np.sin(theta) * np.cos(phi), r * np.cos(theta), r * np.sin(theta) * np.sin(phi)], axis=-1)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a, b = i * (n + 1) + j, i * (n + 1) + j + 1
    c, d = a + n + 1, b + n + 1
    tris = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([b, d, c], -1).reshape(-1, 3)])  # outward
    return p.reshape(-1, 3), tris


def write_obj(path, positions, triangles):
    with open(path, "w", encoding="ascii") as f:
        np.savetxt(f, positions, fmt="v %.7g %.7g %.7g")
        np.savetxt(f, triangles + 1, fmt="f %d %d %d")


def measure(renderer, scene, child=CHILD):
    """The dictionary a fresh process running `child` prints after RESULT."""
    run = subprocess.run([sys.executable, "-c", child, renderer, scene], capture_output=True, text=True, cwd=ROOT)
    results = [line.split("RESULT ", 1)[1] for line in run.stdout.splitlines() if "RESULT " in line]
    if not results:  # (Mitsuba may crash at exit, after its result)
        sys.exit(f"{renderer} failed on {scene}:\n{run.stdout[-2000:]}{run.stderr[-2000:]}")
    return json.loads(results[0])


RENDERERS = ("volpath", "mitsuba", "cycles")


# Figures to plot: a result's key, its axis label, a factor.
LOAD, PEAK = ("load", "load (s)", 1), ("peak", "peak (MB)", 2**-20)
PER_SAMPLE = ("per_sample", "time a sample (s)", 1)


def plot(results, path, xlabel, panels=(LOAD, PEAK)):
    """Each panel's figure against size, log-log: one line per renderer and variant, from
    {(renderer, variant): [(size, result), ...]}."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(panels), figsize=(4.5 * len(panels), 3.6))
    variants = sorted({variant for _, variant in results})
    for (renderer, variant), points in sorted(results.items()):
        sizes = [n for n, _ in points]
        dashed = variant != variants[0]
        style = {"color": f"C{RENDERERS.index(renderer)}", "linestyle": "--" if dashed else "-", "marker": "o"}
        for ax, (key, ylabel, factor) in zip(axes, panels):
            ax.loglog(sizes, [r[key] * factor for _, r in points], label=f"{renderer} {variant}".strip(), **style)
            ax.set(xlabel=xlabel, ylabel=ylabel)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


COLUMNS = ("triangles", "file", *(f"{r} load" for r in ("Volpath", "Mitsuba", "Cycles")), "ratio")
COLUMNS += (*(f"{r} peak" for r in ("Volpath", "Mitsuba", "Cycles")), "ratio")


def main():
    from volpath.meshes import write_ply

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    ap.add_argument("--append")
    ap.add_argument("--plot")
    args = ap.parse_args()
    rows, results = [], {}
    with tempfile.TemporaryDirectory(prefix="volpath-meshes-") as d:
        for size in args.sizes:
            positions, triangles = bumpy_sphere(size)
            write_ply(os.path.join(d, "mesh.ply"), positions, triangles)
            write_obj(os.path.join(d, "mesh.obj"), positions, triangles)
            for kind in ("ply", "obj"):
                scene = os.path.join(d, f"{kind}.xml")
                with open(scene, "w", encoding="utf-8") as f:
                    f.write(SCENE.format(kind=kind, file=f"mesh.{kind}"))
                v, m, c = (measure(r, scene) for r in RENDERERS)
                for r, result in zip(RENDERERS, (v, m, c)):
                    results.setdefault((r, kind.upper()), []).append((len(triangles), result))
                best_load, best_peak = min(m["load"], c["load"]), min(m["peak"], c["peak"])
                rows.append(
                    f"| {len(triangles) / 1e6:.2f} M | {kind.upper()} | {v['load']:.2f} s | {m['load']:.2f} s | "
                    f"{c['load']:.2f} s | **{v['load'] / best_load:.2f}x** | {v['peak'] / 2**20:.0f} MB | "
                    f"{m['peak'] / 2**20:.0f} MB | {c['peak'] / 2**20:.0f} MB | **{v['peak'] / best_peak:.2f}x** |"
                )
                print(rows[-1], flush=True)
    if args.plot:
        plot(results, args.plot, "triangles")
    section = (
        "\n## Loading a large mesh (issue #37; `bench/mesh_loading.py`)\n\n"
        "One bumpy sphere, 8x8 pixels, each measurement in a fresh process: loading the file to a "
        "built scene (and a 1-spp render), and the process's own peak resident memory (VmHWM) above what "
        "it held after its imports. Volpath, Mitsuba 3.9.1 scalar_rgb and Cycles 5.0 (Blender's PLY/OBJ importer, then its "
        "render's scene and BVH), all on the machine's cores, same run; the ratios are Volpath's over the "
        "better of the two peers."
        + (f" Plotted log-log in `{args.plot}`." if args.plot else "")
        + "\n\n"
        + table(COLUMNS, rows)
    )
    publish(section, args.append, key="mesh_loading")


if __name__ == "__main__":
    main()
