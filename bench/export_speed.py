"""Exporter speed: a 1M-triangle Blender scene to a Volpath scene, in memory (F12) and
as a scene directory (XML + PLY). Target (issue #6): under 5 s. Prints a section of
bench/RESULTS.md (`make bench` appends it: --append FILE)."""

import os
import sys
import tempfile
import time

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests"))
from blender_scenes import add_camera, blank_scene  # noqa: E402
from publish import publish  # noqa: E402  (bench/)

from addon.export import export_scene, write_directory  # noqa: E402

scene = blank_scene()
# 708 x 708 quads, smooth shaded: 1,002,528 triangles; a second, flat-shaded instance.
bpy.ops.mesh.primitive_grid_add(x_subdivisions=709, y_subdivisions=709, size=10)
bpy.ops.object.shade_smooth()
bpy.ops.object.duplicate_move_linked(TRANSFORM_OT_translate={"value": (12, 0, 0)})
add_camera(scene)
depsgraph = bpy.context.evaluated_depsgraph_get()
start = time.perf_counter()
exported = export_scene(depsgraph)
memory = time.perf_counter() - start
triangles = sum(len(v["indices"]) for v in exported.scene.values() if isinstance(v, dict) and v.get("type") == "mesh")
with tempfile.TemporaryDirectory() as out:
    start = time.perf_counter()
    write_directory(exported, out)
    written = time.perf_counter() - start
section = f"""
## Blender exporter (issue #6; `bench/export_speed.py`)

| scene | export in memory (F12) | + scene directory (XML + PLY) | target |
|---|---|---|---|
| {triangles / 1e6:.2f} M triangles: a 1 M-triangle smooth grid and a linked duplicate | {memory:.2f} s | {written:.2f} s | < 5 s |\n"""
publish(section, sys.argv[2] if len(sys.argv) > 2 and sys.argv[1] == "--append" else None, key="export_speed")
