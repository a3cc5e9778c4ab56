"""A sparse cloud from 64^3 to 1024^3 voxels (issue #37): load time, peak memory and time a
sample, Volpath beside Mitsuba 3 (scalar_rgb) and Cycles 5.0 (the bpy module), one run.

The cloud is the accuracy study's (bench/make_grids.py's cumulus field: puffs in a layer,
about 4 % of the voxels active, sigma_t up to 150 per unit, albedo 0.98, g = 0.6) at each
resolution, in the unit cube, under a sun and a sky; 128x128 pixels, all orders of
scattering. Volpath and Cycles read it as OpenVDB (written by Blender's openvdb); Mitsuba,
which reads no OpenVDB, as a dense .vol grid. Each measurement runs in a fresh process:
"load" is loading the scene and a 1-spp render (so nothing is left to build lazily),
"a sample" a SPP-spp render's time over its samples (Cycles: less a second 1-spp render's,
its per-render scene synchronisation, over SPP - 1), "peak" the process's own peak resident memory
(VmHWM) above what it held after its imports. Volpath reads a .vdb in a short-lived child
process (docs/scene-format.md); its peak is reported beside, as "reader" (an upper bound:
its ru_maxrss counts what it inherits from its parent).

    .venv/bin/python bench/cloud_scaling.py [--sizes 64 128 256 512 1024] [--append bench/RESULTS.md]
        [--plot docs/cloud_scaling.png]
"""

import argparse
import os
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from make_grids import cumulus_field, write_vdb  # noqa: E402  (bench/)
from mesh_loading import LOAD, PEAK, PEAK_MEMORY, PER_SAMPLE, RENDERERS, measure, plot  # noqa: E402
from publish import publish, table  # noqa: E402

SPP = 16
RES = 128
SCENE = """<scene version="3.0.0">
  <integrator type="volpath"><integer name="max_depth" value="-1"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="0.5, 0.75, 1.6" target="0.5, 0.42, 0.5" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="{res}"/><integer name="height" value="{res}"/>
      <rfilter type="box"/></film>
  </sensor>
  <medium type="heterogeneous" id="cloud">
    {volume}
    <float name="albedo" value="0.98"/>
    <phase type="hg"><float name="g" value="0.6"/></phase>
  </medium>
  <shape type="cube">
    <transform name="to_world"><scale value="0.5"/><translate value="0.5, 0.5, 0.5"/></transform>
    <bsdf type="null"/>
    <ref name="interior" id="cloud"/>
  </shape>
  <emitter type="directional">
    <vector name="direction" value="-0.4, -1, -0.3"/>
    <rgb name="irradiance" value="3, 3, 3"/>
  </emitter>
  <emitter type="constant"><rgb name="radiance" value="0.3, 0.4, 0.6"/></emitter>
</scene>
"""
VDB = '<volume type="vdbvolume" name="sigma_t"><string name="filename" value="cloud.vdb"/></volume>'
VOL = '<volume type="gridvolume" name="sigma_t"><string name="filename" value="cloud.vol"/></volume>'

# Run in a child: argv = renderer, scene path. Prints RESULT {"load", "per_sample", "peak", "reader"}.
CHILD = (
    PEAK_MEMORY
    + r"""
import json, resource, sys, time
renderer, path = sys.argv[1:]
SPP = {SPP}
if renderer == "volpath":
    import volpath
    load, render = volpath.load_file, lambda scene, spp: volpath.render(scene, spp=spp)
elif renderer == "cycles":
    sys.path.insert(0, "bench")
    import bpy
    from cloud_scaling import cycles_scene
    load = cycles_scene
    def render(scene, spp):
        scene.cycles.samples = spp
        bpy.ops.render.render()
else:
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    load, render = mi.load_file, lambda scene, spp: mi.render(scene, spp=spp)
base = peak_memory()
start = time.perf_counter()
scene = load(path)
render(scene, 1)
loaded = time.perf_counter()
if renderer == "cycles":  # each render synchronises the scene again: the samples past the first
    render(scene, 1)  # (a second time, its caches warm)
    synced = time.perf_counter()
    render(scene, SPP)
    per_sample = ((time.perf_counter() - synced) - (synced - loaded)) / (SPP - 1)
else:
    render(scene, SPP)
    per_sample = (time.perf_counter() - loaded) / SPP
reader = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
print("RESULT", json.dumps({"load": loaded - start, "per_sample": per_sample, "peak": peak_memory() - base,
                            "reader": reader}))
""".replace("{SPP}", str(SPP))
)


def cycles_scene(path):
    """The cloud of `path`'s directory in Blender, as bench/cycles_scenes.py builds the
    accuracy study's: the same camera, sun and sky, the VDB a volume object."""
    import bpy
    from cycles_scenes import _camera, _light, _material, _world

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.render.resolution_x = scene.render.resolution_y = RES
    scene.render.resolution_percentage = 100
    c = scene.cycles
    c.device = "CPU"
    c.use_denoising = c.use_adaptive_sampling = False
    c.max_bounces = c.volume_bounces = 1024
    c.volume_max_steps = 100000
    _camera(bpy, (0.5, 0.75, 1.6), (0.5, 0.42, 0.5), 45)
    bpy.ops.object.volume_import(filepath=os.path.join(os.path.dirname(path), "cloud.vdb"))
    volume = bpy.context.object
    volume.data.render.precision = "FULL"
    volume.data.render.clipping = 0.0
    volume.data.materials.append(_material(bpy, "cloud", volume=(1.0, (0.98, 0.98, 0.98), 0.6)))
    _light(bpy, "SUN", direction=(-0.4, -1, -0.3), energy=3.0)
    _world(bpy, (0.3, 0.4, 0.6))
    return scene


PEERS = ("Volpath", "Mitsuba", "Cycles")
COLUMNS = ("cloud", *(f"{r} load" for r in PEERS), "ratio", *(f"{r} a sample" for r in PEERS), "ratio")
COLUMNS += (*(f"{r} peak" for r in PEERS), "ratio", "reader")


def main():
    from volpath.grids import write_vol

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[64, 128, 256, 512, 1024])
    ap.add_argument("--append")
    ap.add_argument("--plot", help="a PNG of load, time a sample and peak against the grid's resolution")
    args = ap.parse_args()
    rows, results = [], {}
    for size in args.sizes:
        with tempfile.TemporaryDirectory(prefix="volpath-clouds-") as d:
            density = cumulus_field(size)
            write_vdb(os.path.join(d, "cloud.vdb"), density, voxel_size=1 / size)
            write_vol(os.path.join(d, "cloud.vol"), density)
            del density
            for name, volume in (("vdb", VDB), ("vol", VOL)):
                with open(os.path.join(d, f"{name}.xml"), "w", encoding="utf-8") as f:
                    f.write(SCENE.format(res=RES, volume=volume))
            v = measure("volpath", os.path.join(d, "vdb.xml"), CHILD)
            m = measure("mitsuba", os.path.join(d, "vol.xml"), CHILD)
            c = measure("cycles", os.path.join(d, "vdb.xml"), CHILD)
        for r, result in zip(RENDERERS, (v, m, c)):
            results.setdefault((r, ""), []).append((size, result))
        best = {k: min(m[k], c[k]) for k in ("load", "per_sample", "peak")}
        rows.append(
            f"| {size}^3 | "
            + " | ".join(f"{r['load']:.2f} s" for r in (v, m, c))
            + f" | **{v['load'] / best['load']:.2f}x** | "
            + " | ".join(f"{r['per_sample']:.3f} s" for r in (v, m, c))
            + f" | **{v['per_sample'] / best['per_sample']:.2f}x** | "
            + " | ".join(f"{r['peak'] / 2**20:.0f} MB" for r in (v, m, c))
            + f" | **{v['peak'] / best['peak']:.2f}x** | {v['reader'] / 2**20:.0f} MB |"
        )
        print(rows[-1], flush=True)
    if args.plot:
        plot(results, args.plot, "voxels along each axis", (LOAD, PER_SAMPLE, PEAK))
    section = (
        "\n## A sparse cloud from 64^3 to 1024^3 (issue #37; `bench/cloud_scaling.py`)\n\n"
        f"The accuracy study's cumulus field (about 4 % of the voxels active) at each resolution, {RES}x{RES}, "
        f"all orders of scattering, {SPP} spp; each measurement in a fresh process, same run, all on the "
        "machine's cores. Volpath and Cycles 5.0 read the OpenVDB file, Mitsuba 3.9.1 scalar_rgb a dense .vol "
        "grid (it reads no OpenVDB). Load: the scene and a 1-spp render; a sample: the render's time over its "
        "samples (Cycles' less its per-render scene synchronisation); peak: the process's own resident memory "
        "above its imports (VmHWM); reader: the peak of Volpath's short-lived VDB-reading child. Ratios: "
        "Volpath's over the better peer's.\n\n" + table(COLUMNS, rows)
    )
    publish(section, args.append, key="cloud_scaling")


if __name__ == "__main__":
    main()
