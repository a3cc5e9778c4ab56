"""Instancing at scale (issue #37): one bumpy sphere of 100 k triangles alone, and 1 000 and
100 000 instances of it (a field, each turned and scaled) on a floor, 256x256 pixels, Volpath
beside Mitsuba 3 (scalar_rgb, shapegroup + instance), one run. Each measurement runs in a
fresh process: "load" is load_file to a built scene, "per sample" a 4-spp render's time over
its samples, "peak" the process's peak resident memory less what it held after importing the
renderer. Both renderers use all the machine's cores for the render.

    .venv/bin/python bench/instance_scaling.py [--counts 1000 100000] [--append bench/RESULTS.md]
"""

import argparse
import os
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from mesh_loading import bumpy_sphere, measure  # noqa: E402  (bench/)
from publish import publish  # noqa: E402

SPP = 4
HEAD = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="3"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, {h:g}, {d:g}" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>
    <film type="hdrfilm"><integer name="width" value="256"/><integer name="height" value="256"/></film>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="{floor:g}"/><translate y="-1"/></transform>
    <bsdf type="diffuse"/>
  </shape>
"""

# Run in a child: argv = renderer, scene path. Prints RESULT {"load", "render", "peak"}.
CHILD = r"""
import json, resource, sys, time
renderer, path = sys.argv[1:]
if renderer == "volpath":
    import volpath
    load, render = volpath.load_file, volpath.render
else:
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    load, render = mi.load_file, mi.render
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
start = time.perf_counter()
scene = load(path)
if renderer == "volpath":
    scene.native.build()
loaded = time.perf_counter()
render(scene)
done = time.perf_counter()
peak = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base) * 1024
print("RESULT", json.dumps({"load": loaded - start, "render": done - loaded, "peak": peak}))
"""


def field(count, rng):
    """`count` maps on a square grid: each sphere turned about y, scaled 0.3-0.45 of the
    spacing, resting on the floor."""
    k = int(np.ceil(np.sqrt(count)))
    cells = np.stack(np.meshgrid(np.arange(k), np.arange(k), indexing="ij"), -1).reshape(-1, 2)[:count]
    maps = []
    for x, z in cells - (k - 1) / 2:
        s = rng.uniform(0.3, 0.45)
        a = rng.uniform(0, 2 * np.pi)
        m = np.diag([s, s, s, 1.0])
        m[[0, 0, 2, 2], [0, 2, 0, 2]] = s * np.array([np.cos(a), np.sin(a), -np.sin(a), np.cos(a)])
        m[:3, 3] = [x, s - 1, z]
        maps.append(m)
    return k, maps


def write_scene(path, count):
    rng = np.random.default_rng(1)
    if count == 0:  # the mesh alone
        body = '  <shape type="ply"><string name="filename" value="mesh.ply"/><bsdf type="diffuse"/></shape>\n'
        head = HEAD.format(h=1.5, d=3.5, spp=SPP, floor=4)
    else:
        k, maps = field(count, rng)
        body = (
            '  <shape type="shapegroup" id="sphere">\n'
            '    <shape type="ply"><string name="filename" value="mesh.ply"/><bsdf type="diffuse"/></shape>\n'
            "  </shape>\n"
        )
        body += "".join(
            '  <shape type="instance"><ref id="sphere"/><transform name="to_world">'
            f'<matrix value="{" ".join(f"{v:.9g}" for v in m.ravel())}"/></transform></shape>\n'
            for m in maps
        )
        head = HEAD.format(h=0.8 * k, d=0.9 * k, spp=SPP, floor=k)
    with open(path, "w", encoding="utf-8") as f:
        f.write(head + body + "</scene>\n")


def main():
    from volpath.meshes import write_ply

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--counts", type=int, nargs="+", default=[1000, 100_000])
    ap.add_argument("--append")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="volpath-instances-") as d:
        positions, triangles = bumpy_sphere(100_000)
        write_ply(os.path.join(d, "mesh.ply"), positions, triangles)
        single = None
        for count in [0, *args.counts]:
            scene = os.path.join(d, f"field{count}.xml")
            write_scene(scene, count)
            v, m = (measure(r, scene, CHILD) for r in ("volpath", "mitsuba"))
            v_sample, m_sample = v["render"] / SPP, m["render"] / SPP
            single = single or v_sample
            rows.append(
                f"| {count or 'the mesh alone'} | {count * len(triangles) or len(triangles):.3g} | "
                f"{v['load']:.2f} s | {m['load']:.2f} s | {v_sample:.3f} s | {m_sample:.3f} s | "
                f"**{v_sample / single:.2f}x** | {v['peak'] / 2**20:.0f} MB | {m['peak'] / 2**20:.0f} MB |"
            )
            print(rows[-1], flush=True)
    section = (
        "\n## Instancing at scale (issue #37; `bench/instance_scaling.py`)\n\n"
        "A bumpy sphere of 0.1 M triangles alone, and instanced in a field (each turned and scaled) on a "
        "floor; 256x256, path tracing to depth 3, 4 spp; each measurement in a fresh process. Mitsuba 3.9.1 "
        'scalar_rgb with shapegroup + instance, same run. "vs alone": Volpath\'s time per sample over its '
        "time with the mesh alone (target: at most 3x at 100 000 instances, within 2 GB).\n\n"
        "| instances | triangles | Volpath load | Mitsuba load | Volpath per sample | Mitsuba per sample "
        "| vs alone | Volpath peak | Mitsuba peak |\n"
        "|---|---|---|---|---|---|---|---|---|\n" + "\n".join(rows) + "\n"
    )
    publish(section, args.append)


if __name__ == "__main__":
    main()
