"""Instancing at scale (issue #37): one bumpy sphere of 100 k triangles alone, and 1 000 and
100 000 instances of it (a field, each turned and scaled) on a floor, 256x256 pixels, Volpath
beside Mitsuba 3 (scalar_rgb, shapegroup + instance) and Cycles 5.0 (the bpy module: the
field as geometry-node instances on points), one run. Each measurement runs in a fresh
process, the best of --runs (3) kept: "load" is load_file to a built scene (Cycles: building the Blender scene and a 1-spp
render, which builds its BVH), "per sample" a 16-spp render's time over its samples (Cycles:
the 16-spp render less the 1-spp one, over 15), "peak" the process's own peak resident memory (VmHWM) less
what it held after importing the renderer. All use all the machine's cores for the render.

    .venv/bin/python bench/instance_scaling.py [--counts 1000 100000] [--runs 3] [--append bench/RESULTS.md]
        [--plot docs/instance_scaling.png]
"""

import argparse
import os
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from mesh_loading import LOAD, PEAK, PEAK_MEMORY, PER_SAMPLE, RENDERERS, bumpy_sphere, measure, plot  # noqa: E402  (bench/)
from publish import publish, table  # noqa: E402

SPP = 16
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

# Run in a child: argv = renderer, scene path. Prints RESULT {"load", "per_sample", "peak"}.
CHILD = (
    PEAK_MEMORY
    + r"""
import json, sys, time
renderer, path = sys.argv[1:]
SPP = 16
if renderer == "volpath":
    import volpath
    load, render = volpath.load_file, lambda scene: volpath.render(scene, spp=SPP)
elif renderer == "cycles":
    sys.path.insert(0, "bench")
    import bpy
    from instance_scaling import cycles_scene
    load = cycles_scene
    def render(scene, spp=SPP):
        scene.cycles.samples = spp
        bpy.ops.render.render()
else:
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    load, render = mi.load_file, lambda scene: mi.render(scene, spp=SPP)
base = peak_memory()
start = time.perf_counter()
scene = load(path)
if renderer == "volpath":
    scene.native.build()
if renderer == "cycles":  # Cycles builds its BVH in a render: a 1-spp render counts as loading
    built = time.perf_counter()
    render(scene, 1)
loaded = time.perf_counter()
render(scene)
done = time.perf_counter()
if renderer == "cycles":  # each render synchronises the scene again: the samples past the first
    per_sample = ((done - loaded) - (loaded - built)) / (SPP - 1)
else:
    per_sample = (done - loaded) / SPP
peak = peak_memory() - base
print("RESULT", json.dumps({"load": loaded - start, "per_sample": per_sample, "peak": peak}))
"""
)


def cycles_scene(path):
    """The field of `path` (its maps in the .npy beside it) in Blender, Z-up: the mesh, and
    geometry-node instances of it on points carrying each one's turn and scale."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine, scene.cycles.device = "CYCLES", "CPU"
    scene.cycles.use_adaptive_sampling = scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 2  # path depth 3
    scene.render.resolution_x = scene.render.resolution_y = 256
    world = bpy.data.worlds.new("sky")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (1, 1, 1, 1)
    scene.world = world
    directory = os.path.dirname(path)
    bpy.ops.wm.ply_import(filepath=os.path.join(directory, "mesh.ply"))
    sphere = bpy.context.selected_objects[0]
    maps = np.load(path[:-4] + ".npy")
    k = int(np.ceil(np.sqrt(len(maps)))) if len(maps) else 0
    h, d, floor = (0.8 * k, 0.9 * k, k) if k else (1.5, 3.5, 4)
    bpy.ops.mesh.primitive_plane_add(size=2 * floor, location=(0, 0, -1))
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(camera)
    camera.location = (0, -d, h)  # the scene's (x, y, z) is Blender's (x, -z, y)
    camera.rotation_euler = (-camera.location).to_track_quat("-Z", "Y").to_euler()
    camera.data.sensor_fit, camera.data.angle = "HORIZONTAL", np.radians(40)
    scene.camera = camera
    if len(maps):
        for c in list(sphere.users_collection):
            c.objects.unlink(sphere)  # seen through its instances only
        scale = np.linalg.norm(maps[:, :3, 0], axis=1)
        points = bpy.data.meshes.new("points")
        points.vertices.add(len(maps))
        points.vertices.foreach_set("co", np.stack([maps[:, 0, 3], -maps[:, 2, 3], maps[:, 1, 3]], 1).ravel())
        turn = np.zeros((len(maps), 3))
        turn[:, 2] = np.arctan2(maps[:, 0, 2], maps[:, 0, 0])  # about the scene's y: Blender's z
        points.attributes.new("turn", "FLOAT_VECTOR", "POINT").data.foreach_set("vector", turn.ravel())
        points.attributes.new("size", "FLOAT", "POINT").data.foreach_set("value", scale)
        field = bpy.data.objects.new("field", points)
        scene.collection.objects.link(field)
        tree = bpy.data.node_groups.new("field", "GeometryNodeTree")
        tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
        on_points, info = tree.nodes.new("GeometryNodeInstanceOnPoints"), tree.nodes.new("GeometryNodeObjectInfo")
        info.inputs["Object"].default_value = sphere
        turn_in, size_in = (tree.nodes.new("GeometryNodeInputNamedAttribute") for _ in range(2))
        turn_in.data_type, turn_in.inputs["Name"].default_value = "FLOAT_VECTOR", "turn"
        size_in.data_type, size_in.inputs["Name"].default_value = "FLOAT", "size"
        tree.links.new(tree.nodes.new("NodeGroupInput").outputs[0], on_points.inputs["Points"])
        tree.links.new(info.outputs["Geometry"], on_points.inputs["Instance"])
        tree.links.new(turn_in.outputs["Attribute"], on_points.inputs["Rotation"])
        tree.links.new(size_in.outputs["Attribute"], on_points.inputs["Scale"])
        tree.links.new(on_points.outputs["Instances"], tree.nodes.new("NodeGroupOutput").inputs[0])
        field.modifiers.new("field", "NODES").node_group = tree
    return scene


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
    np.save(path[:-4] + ".npy", field(count, np.random.default_rng(1))[1] if count else np.zeros((0, 4, 4)))


PEERS = ("Volpath", "Mitsuba", "Cycles")
COLUMNS = ("instances", "triangles", *(f"{r} load" for r in PEERS), *(f"{r} a sample" for r in PEERS), "vs alone")
COLUMNS += tuple(f"{r} peak" for r in PEERS)


def best_of(jobs, runs):
    """Each (renderer, scene) job's figures, each the least over `runs` fresh processes, the
    jobs taken in turn: the machine's noise only adds time, and it drifts over minutes, so a
    ratio is taken between jobs run side by side."""
    results = {job: [] for job in jobs}
    for _ in range(runs):
        for renderer, scene in jobs:
            results[renderer, scene].append(measure(renderer, scene, CHILD))
    return [{k: min(x[k] for x in results[job]) for k in results[job][0]} for job in jobs]


def main():
    from volpath.meshes import write_ply

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--counts", type=int, nargs="+", default=[1000, 100_000])
    ap.add_argument("--runs", type=int, default=3, help="fresh processes per measurement (the best is kept)")
    ap.add_argument("--append")
    ap.add_argument("--plot", help="a PNG of load, time a sample and peak against the triangles instanced")
    args = ap.parse_args()
    rows, results = [], {}
    with tempfile.TemporaryDirectory(prefix="volpath-instances-") as d:
        positions, triangles = bumpy_sphere(100_000)
        write_ply(os.path.join(d, "mesh.ply"), positions, triangles)
        alone = os.path.join(d, "field0.xml")
        for count in [0, *args.counts]:
            scene = os.path.join(d, f"field{count}.xml")
            write_scene(scene, count)
            # Volpath's mesh alone again beside each field, for the ratio of their times.
            jobs = [(r, scene) for r in RENDERERS] + ([("volpath", alone)] if count else [])
            v, m, c, *beside = best_of(jobs, args.runs)
            for r, result in zip(RENDERERS, (v, m, c)):
                results.setdefault((r, ""), []).append(((count or 1) * len(triangles), result))
            single = (beside or [v])[0]["per_sample"]
            rows.append(
                f"| {count or 'the mesh alone'} | {count * len(triangles) or len(triangles):.3g} | "
                + " | ".join(f"{r['load']:.2f} s" for r in (v, m, c))
                + " | "
                + " | ".join(f"{r['per_sample']:.3f} s" for r in (v, m, c))
                + f" | **{v['per_sample'] / single:.2f}x** | "
                + " | ".join(f"{r['peak'] / 2**20:.0f} MB" for r in (v, m, c))
                + " |"
            )
            print(rows[-1], flush=True)
    if args.plot:
        plot(results, args.plot, "triangles (instanced)", (LOAD, PER_SAMPLE, PEAK))
    section = (
        "\n## Instancing at scale (issue #37; `bench/instance_scaling.py`)\n\n"
        "A bumpy sphere of 0.1 M triangles alone, and instanced in a field (each turned and scaled) on a "
        "floor; 256x256, path tracing to depth 3, 16 spp; each figure the best of three fresh processes, the "
        "renderers in turn, same run. Mitsuba "
        "3.9.1 scalar_rgb with shapegroup + instance; Cycles 5.0 with geometry-node instances on points (its "
        "load includes a 1-spp render, which builds its BVH; its time a sample is the 16-spp render's less the "
        "1-spp one's). \"vs alone\": Volpath's time a sample over its time with the mesh alone, measured again "
        "in turn with the field's (target: at most "
        "3x at 100 000 instances, within 2 GB).\n\n" + table(COLUMNS, rows)
    )
    publish(section, args.append, key="instance_scaling")


if __name__ == "__main__":
    main()
