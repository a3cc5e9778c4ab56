"""A Blender animation as an animation directory: the scene once, and per frame what
changes, evaluated by Blender itself (``frame_set``), so that fcurves, drivers and
constraints count. The camera, the point, spot and sun lamps and VDB sequences are updated from
animation.json; anything else animated (objects moving or deforming, materials, the world,
lamp and camera settings, instances) is found by comparing each frame with the first, and
the scene entries it changes are written per frame (updates_NNNN.xml), which a worker
applies to its loaded scene in place where it can (volpath's Scene.update). Objects that
move or deform are exported as instances of a group of their own, so that their motion
refits the BVH instead of rebuilding it. The pipeline renders such a directory frame by
frame without Blender (``pipeline.frames``, where the directory's format is described).
"""

import json
import os

import numpy as np

from pipeline.frames import ANIMATION_FILE, SCENE_FILE

from . import ExportError, camera, drop_meshes, export_scene, export_volume, lights, motion, shown_in_render


def frame_list(scene, frames=None, step=None):
    """The frames to render: ``frames`` (first, last) or the scene's range, every ``step``-th
    (default: the scene's frame step)."""
    first, last = frames or (scene.frame_start, scene.frame_end)
    step = scene.frame_step if step is None else step
    if step < 1:
        raise ValueError(f"the frame step must be at least 1, got {step}")
    return list(range(first, last + 1, step))


def export_animation(scene, frames, directory):
    """Write scene.xml (+ meshes, volumes) at the first of ``frames``, animation.json for all
    of them, and for each frame where more changes than animation.json follows, the scene
    entries that change (updates_NNNN.xml), or where objects appear or vanish the whole
    scene (scene_NNNN.xml), into ``directory``; returns the export's warnings."""
    from volpath.xml_writer import write_entries

    scan = _scan(scene, frames)
    moving = scan.objects("placement", "shape") | {name for m in scan.blur.values() if m for name in m.instanced()}
    caches, warnings = {"meshes": {}, "digests": {}}, []
    current = scene.frame_current
    try:
        first, exported = _frame_entries(scene, frames[0], directory, moving, caches, warnings, scan.blur[frames[0]])
        whole = _changed_frames(scene, scan, first, directory, moving, caches, warnings)
    finally:
        scene.frame_set(current)
    write_entries(first, directory, SCENE_FILE)
    animation = {
        "suns": exported.suns,
        "lamps": exported.lamps,
        "frames": scan.frames,
        "animated": scan.animated,
        "instanced": sorted(moving),
    }
    if scan.changed:
        warnings.append(
            "animated besides the camera, point, spot and sun lamps and VDB sequences: "
            + "; ".join(f"{a['what']} ({a['changes']}, from frame {a['from_frame']})" for a in scan.animated)
            + f"; {len(scan.changed_frames) - len(whole)} frames are updates of the first"
            + (f", {len(whole)} exported whole (objects appear or vanish)" if whole else "")
        )
    if exported.sequences:
        _volume_sequences(scene, exported.sequences, [e for e in scan.frames if "scene" not in e], directory)
    tmp = os.path.join(directory, ANIMATION_FILE + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(animation, f, indent=1)
    os.replace(tmp, os.path.join(directory, ANIMATION_FILE))
    return warnings


class _Scan:
    """One pass over the frames (_scan): ``frames``, animation.json's per-frame entries (sun
    directions, followed lamps, the camera); ``changed``, {(what, changes): the first frame
    where it differs from the first}, for what animation.json does not follow; ``names``,
    {what: Blender object}; ``changed_frames``, those where anything of it differs, or
    where something moves in the shutter; ``blur``, per frame its motion.Motion (None:
    motion blur is off)."""

    def __init__(self):
        self.frames, self.changed, self.names, self.changed_frames, self.blur = [], {}, {}, set(), {}

    @property
    def animated(self):
        """animation.json's "animated": what changes, how, from which frame."""
        return [{"what": w, "changes": c, "from_frame": f} for (w, c), f in sorted(self.changed.items())]

    def objects(self, *changes):
        """The Blender objects whose `changes` (placement, shape) animate."""
        return {self.names[w] for (w, c) in self.changed if c in changes and w in self.names}


def _followed(scene):
    """The objects animation.json follows frame by frame: sun, point and spot lamps without a
    radius, VDB sequences."""
    return {
        o.name
        for o in scene.objects
        if (o.type == "LIGHT" and lights.followed(o.data)) or (o.type == "VOLUME" and o.data.is_sequence)
    }


def _scan(scene, frames):
    """Per frame, the direction of every Sun lamp, the point, spot and sun lamps' emitters and the
    camera's to_world; what else changes over `frames`, found by comparing what Blender
    evaluates at each frame with the first (_unfollowed_state); and with Motion Blur on,
    what moves in each frame's shutter (motion.sample)."""
    import bpy

    from . import Report

    depsgraph_at = motion.scene_depsgraph(scene)
    followed, scan, first = _followed(scene), _Scan(), None
    current = scene.frame_current
    try:
        for f in frames:
            scene.frame_set(f)
            depsgraph = bpy.context.evaluated_depsgraph_get()
            suns, lamps = {}, {}
            for o in scene.objects:
                if o.type == "LIGHT" and o.name in followed:
                    ob = o.evaluated_get(depsgraph)
                    if o.data.type == "SUN":
                        suns[o.name] = lights.sun_direction(ob).tolist()
                    lamp = lights.export(ob, ob.matrix_world, Report())
                    if lamp is not None:
                        lamps[o.name] = _jsonable(lamp)
            cam = scene.camera.evaluated_get(depsgraph) if scene.camera else None
            scan.frames.append(
                {
                    "frame": f,
                    "suns": suns,
                    "lamps": lamps,
                    "camera": camera.to_world(cam).tolist() if cam is not None else None,
                }
            )
            state = _unfollowed_state(scene, depsgraph, followed, scan.names)
            scan.blur[f] = blur = motion.sample(scene, depsgraph_at, f)  # (back at f after)
            if blur is not None and blur.moves() and f != frames[0]:
                scan.changed_frames.add(f)  # its motion keys are its own
            if first is None:
                first = state
                continue
            for key in first.keys() | state.keys():
                if key not in state or key not in first or not _same(first[key], state[key]):
                    scan.changed.setdefault(key, f)
                    scan.changed_frames.add(f)
    finally:
        scene.frame_set(current)
    return scan


def _frame_entries(scene, frame, directory, moving, caches, warnings, blur):
    """The scene at `frame` as XML entries ({key: text}, xml_writer.scene_entries), its
    files written into `directory` by content; objects in `moving` as instances, with the
    motion keys of `blur` (motion.Motion). `caches`:
    the meshes' triangles and the arrays' digests, kept from frame to frame. Returns the
    entries and the Exported; its warnings not yet in `warnings` are added."""
    import bpy

    from volpath.xml_writer import scene_entries

    scene.frame_set(frame)  # (export_animation sets the current frame back once)
    exported = export_scene(bpy.context.evaluated_depsgraph_get(), caches["meshes"], instanced=moving, final=True)
    motion.attach(exported, blur)
    warnings += [w for w in exported.warnings if w not in warnings]
    return scene_entries(exported.scene, directory, by_content=True, digests=caches["digests"]), exported


def _changed_frames(scene, scan, first, directory, moving, caches, warnings):
    """Each changed frame's entries that differ from the `first` frame's, as updates_NNNN.xml
    named in its animation.json entry ("updates"); a frame whose entries are not the first's
    (objects appear or vanish) whole, as scene_NNNN.xml ("scene"). Returns the whole frames."""
    import bpy

    from volpath.xml_writer import write_entries

    deforming = [bpy.data.objects[name] for name in scan.objects("shape")]
    whole = []
    for entry in scan.frames:
        f = entry["frame"]
        if f not in scan.changed_frames:
            continue
        drop_meshes(caches["meshes"], deforming)
        entries, _ = _frame_entries(scene, f, directory, moving, caches, warnings, scan.blur[f])
        if entries.keys() != first.keys():
            entry["scene"] = f"scene_{f:04d}.xml"
            write_entries(entries, directory, entry["scene"])
            whole.append(f)
        else:
            entry["updates"] = f"updates_{f:04d}.xml"
            write_entries({k: v for k, v in entries.items() if v != first[k]}, directory, entry["updates"])
    return whole


def _jsonable(entry):
    """A plugin dictionary with its arrays as lists."""
    return {k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in entry.items()}


def _same(a, b):
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and np.allclose(a, b, rtol=1e-6, atol=1e-9)


def _node_values(tree):
    """The unlinked inputs' values of a node tree (what keyframes on a node change)."""
    values = []
    for node in tree.nodes if tree else ():
        for socket in node.inputs:
            value = getattr(socket, "default_value", None)
            if value is not None and not socket.is_linked and not isinstance(value, str):
                values.extend(np.ravel(np.asarray(value, dtype=np.float64)).tolist())
    return values


LIGHT_SETTINGS = (
    "energy",
    "color",
    "exposure",
    "use_temperature",
    "temperature",
    "normalize",
    "shadow_soft_size",
    "use_soft_falloff",
    "spot_size",
    "spot_blend",
    "angle",
    "size",
    "size_y",
    "spread",
)
CAMERA_SETTINGS = ("lens", "sensor_width", "sensor_height", "shift_x", "shift_y", "clip_start", "clip_end")


def _unfollowed_state(scene, depsgraph, followed, names):
    """{(what, changes): values} at the current frame for everything animation.json does not
    follow: objects' placements (all but the camera's, the followed lamps' and VDB
    sequences'; a sun's has no effect), other lamps' and the camera's settings, deformed
    meshes, instances' placements, material and world node values, which objects render.
    ``names``: {what:
    Blender object}, filled in."""
    state = {}
    for obj in scene.objects:
        ob = obj.evaluated_get(depsgraph)
        what = f"{obj.type.lower()} '{obj.name}'"
        names[what] = obj.name
        sun = obj.type == "LIGHT" and obj.data.type == "SUN"
        if obj != scene.camera and not sun and obj.name not in followed:
            state[(what, "placement")] = np.array(ob.matrix_world)
        if obj.type == "LIGHT" and obj.name not in followed:  # followed lamps are exported at every frame
            state[(what, "settings")] = np.concatenate(
                [np.ravel(getattr(ob.data, a)) for a in LIGHT_SETTINGS if hasattr(ob.data, a)]
            )
            state[(what, "node values")] = _node_values(
                ob.data.node_tree if getattr(ob.data, "use_nodes", False) else None
            )
        elif obj.type == "CAMERA":
            state[(what, "settings")] = [getattr(ob.data, a) for a in CAMERA_SETTINGS]
        elif motion.may_deform(obj):
            mesh = ob.to_mesh()  # evaluated: modifiers and shape keys applied
            co = np.empty(3 * len(mesh.vertices))
            mesh.vertices.foreach_get("co", co)
            ob.to_mesh_clear()
            state[(what, "shape")] = co
    state[(f"scene '{scene.name}'", "objects shown")] = [i for i, o in enumerate(scene.objects) if shown_in_render(o)]
    placements = {}
    for inst in depsgraph.object_instances:
        if inst.is_instance:
            placements.setdefault(f"instances of '{inst.object.name}'", []).append(np.array(inst.matrix_world))
    for what, matrices in placements.items():
        state[(what, "placements")] = np.array(matrices)
    for material in _materials(scene):
        state[(f"material '{material.name}'", "node values")] = _node_values(material.node_tree)
    if scene.world is not None:
        state[(f"world '{scene.world.name}'", "node values")] = _node_values(scene.world.node_tree)
    return state


def _materials(scene):
    """The materials the scene's objects use."""
    seen = {}
    for obj in scene.objects:
        for slot in getattr(obj, "material_slots", ()):
            if slot.material is not None:
                seen[slot.material.name] = slot.material
    return seen.values()


def _volume_sequences(scene, sequences, frames, directory):
    """Per frame, the grids of every VDB sequence beside the scene: a copy of the frame's
    .vdb, or for an emitting volume's radiance (computed voxel by voxel in Blender) a
    sparse .vdb of its own (volpath.xml_writer.write_volume)."""
    import bpy

    from volpath.xml_writer import write_volume

    os.makedirs(os.path.join(directory, "volumes"), exist_ok=True)
    current = scene.frame_current
    try:
        for entry in frames:
            scene.frame_set(entry["frame"])
            depsgraph = bpy.context.evaluated_depsgraph_get()
            entry["volumes"] = {}
            for key, name in sequences.items():
                shape = export_volume(depsgraph, name)
                if shape is None:
                    raise ExportError(f"volume '{name}': no active voxels at frame {entry['frame']}")
                grids = {"to_world": shape["to_world"].tolist()}
                for grid in ("density", "radiance"):
                    if grid not in shape["interior"]:
                        continue
                    stem = f"volumes/{key}_{grid}_{entry['frame']:04d}"
                    plugin = write_volume(shape["interior"][grid], directory, lambda ext: f"{stem}.{ext}", grid)
                    grids[grid] = dict(plugin, to_world=np.asarray(plugin["to_world"]).tolist())
                entry["volumes"][key] = grids
    finally:
        scene.frame_set(current)
