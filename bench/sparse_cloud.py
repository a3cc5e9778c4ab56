"""Sparse clouds (issue #5): memory of the brick layout against a dense array, and local
majorants against one global majorant at equal error. Prints a section of
bench/RESULTS.md (`make bench` appends it: --append FILE).

1. Memory: a 512^3 cumulus field written as a .vdb by Blender's OpenVDB, then loaded by
   a fresh process through `vdbvolume`; its resident memory grows by the bricks, against
   the 512 MiB of a dense float32 array.
2. Time to equal RMSE: the same field at 256^3, rendered by the null-scattering tracer with
   majorant grids of 1 (global), 8, 16, 32 cells per axis and the automatic choice; each
   against one reference.
   Error falls as 1/sqrt(spp) and time grows as spp, so time to an equal RMSE is
   proportional to time * MSE at any fixed spp.
"""

import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from make_grids import cumulus_field, write_vdb  # noqa: E402  (bench/)
from publish import publish  # noqa: E402

import volpath  # noqa: E402

MEMORY_CHILD = """
import os, sys, volpath
def rss():
    return int(open("/proc/self/statm").read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
before = rss()
grid = volpath.VolumeGrid.from_file(sys.argv[1])
print(rss() - before, grid.nbytes, grid.dense_nbytes)
"""


def memory_section(tmp):
    cloud = cumulus_field(512)
    active = np.count_nonzero(cloud) / cloud.size
    write_vdb(os.path.join(tmp, "cloud.vdb"), cloud, voxel_size=1 / 512)
    del cloud
    out = subprocess.run(
        [sys.executable, "-c", MEMORY_CHILD, os.path.join(tmp, "cloud.vdb")], capture_output=True, text=True, check=True
    ).stdout.split()
    rss, nbytes, box = (int(v) for v in out)
    full = 512**3 * 4
    return (
        f"| 512³ cumulus field, {100 * active:.1f} % of voxels active | {rss / 2**20:.0f} MiB "
        f"(bricks: {nbytes / 2**20:.0f} MiB) | {full / 2**20:.0f} MiB: {rss / full:.1%} | "
        f"{box / 2**20:.0f} MiB: {rss / box:.1%} | ≤ 25 % |"
    )


def scene_xml(majorant_res, spp):
    return f"""<scene version="3.0.0">
    <integrator type="volpath"><integer name="max_depth" value="-1"/></integrator>
    <sensor type="perspective"><float name="fov" value="45"/>
        <transform name="to_world"><lookat origin="0.5, 0.75, 1.6" target="0.5, 0.42, 0.5" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>
        <film type="hdrfilm"><integer name="width" value="96"/><integer name="height" value="96"/></film></sensor>
    <medium type="heterogeneous" id="cloud">
        <volume type="gridvolume" name="density"><string name="filename" value="cloud.vol"/></volume>
        <float name="albedo" value="0.98"/><integer name="majorant_resolution" value="{majorant_res}"/>
        <phase type="hg"><float name="g" value="0.6"/></phase></medium>
    <shape type="cube"><transform name="to_world"><scale value="0.5"/><translate value="0.5, 0.5, 0.5"/></transform>
        <bsdf type="null"/><ref name="interior" id="cloud"/></shape>
    <emitter type="directional"><vector name="direction" value="-0.4, -1, -0.3"/><rgb name="irradiance" value="3"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.3, 0.4, 0.6"/></emitter>
</scene>"""


def render(tmp, majorant_res, spp, seed):
    scene = volpath.load_string(scene_xml(majorant_res, spp), base_dir=tmp)
    start = time.perf_counter()
    image = volpath.render(scene, seed=seed, threads=2, tracer="null_scattering")
    return image, time.perf_counter() - start


def majorant_section(tmp):
    from volpath.grids import write_vol

    write_vol(os.path.join(tmp, "cloud.vol"), cumulus_field(256))
    reference, ref_time = render(tmp, 8, 1024, seed=999)
    rows, results = [], {}
    for res in (1, 8, 16, 32, 0):
        image, seconds = render(tmp, res, 32, seed=1)
        mse = float(np.mean((image - reference) ** 2))
        results[res] = seconds * mse
        rows.append((res, seconds, np.sqrt(mse)))
    lines = []
    for res, seconds, rmse in rows:
        name = {1: "1 (global majorant)", 0: "automatic (26³ cells)"}.get(res, f"{res}³ cells")
        lines.append(f"| {name} | {seconds:.2f} s | {rmse:.4f} | {results[res] / results[1]:.2f}x |")
    return "\n".join(lines), ref_time


def main():
    with tempfile.TemporaryDirectory() as tmp:
        memory = memory_section(tmp)
        rows, ref_time = majorant_section(tmp)
    section = f"""
## Sparse clouds (issue #5; `bench/sparse_cloud.py`)

Resident memory of a cloud loaded from a .vdb file (OpenVDB leaves become 8³ bricks; empty
bricks are not stored), measured as the growth of a fresh process's resident set:

| cloud | resident | vs dense 512³ float32 | vs dense over the active bounding box | target |
|---|---|---|---|---|
{memory}

Local majorants against one global majorant: the same field at 256³, 96x96, 32 spp,
null-scattering tracer, 2 threads, one 1024-spp reference ({ref_time:.0f} s). Time to equal
RMSE relative to the global majorant (time x MSE; target ≤ 0.5x):

| majorant grid | time at 32 spp | RMSE | time to equal RMSE |
|---|---|---|---|
{rows}
"""
    publish(section, sys.argv[2] if len(sys.argv) > 2 and sys.argv[1] == "--append" else None, key="sparse_cloud")


if __name__ == "__main__":
    main()
