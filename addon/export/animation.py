"""A Blender animation as an animation directory: the scene once, and per frame what moves,
evaluated by Blender itself (``frame_set``), so that fcurves, drivers and constraints
count: the camera, the lamps and VDB sequences as updates of the first frame's scene, and
whole scenes for the frames where anything else animated differs from the first. The
pipeline renders such a directory frame by frame without Blender (``pipeline.frames``,
where the directory's format is described).
"""

import json
import os

import numpy as np

from pipeline.frames import ANIMATION_FILE

from . import ExportError, camera, export_scene, export_volume, lights, write_directory


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
    of them, and scene_NNNN.xml for each frame where more changes than the frame-by-frame
    updates follow (see _per_frame) into ``directory``; returns the export's warnings."""
    import bpy

    current = scene.frame_current
    scene.frame_set(frames[0])
    try:
        exported = export_scene(bpy.context.evaluated_depsgraph_get())
    finally:
        scene.frame_set(current)
    write_directory(exported, directory, by_content=True)
    per_frame, animated, whole = _per_frame(scene, frames, exported)
    animation = {"suns": exported.suns, "lamps": exported.lamps, "frames": per_frame, "animated": animated}
    warnings = list(exported.warnings)
    if animated:
        warnings.append(
            f"{len(whole)} of {len(frames)} frames exported whole, for what the pipeline does not yet update "
            "frame by frame (slower: an export and a scene load each): "
            + "; ".join(f"{a['what']} ({a['changes']}, from frame {a['from_frame']})" for a in animated)
        )
        warnings += _whole_frames(scene, [e for e in per_frame if e["frame"] in whole], directory, warnings)
    if exported.sequences:
        _volume_sequences(scene, exported.sequences, [e for e in per_frame if "scene" not in e], directory)
    tmp = os.path.join(directory, ANIMATION_FILE + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(animation, f, indent=1)
    os.replace(tmp, os.path.join(directory, ANIMATION_FILE))
    return warnings


def _per_frame(scene, frames, exported):
    """Per frame, what the pipeline updates frame by frame: the direction of every Sun lamp,
    the point and sun lamps' emitters (Exported.lamps) and the camera's to_world. Then what
    else changes over `frames`, found by comparing what Blender evaluates at each frame with
    the first: [{"what", "changes", "from_frame"}], and the frames where anything of it
    differs from the first, which are exported whole (_whole_frames)."""
    import bpy

    from . import Report

    followed = {*exported.lamps.values(), *exported.sequences.values()}
    current = scene.frame_current
    out, first, changed, whole = [], None, {}, set()
    try:
        for f in frames:
            scene.frame_set(f)
            depsgraph = bpy.context.evaluated_depsgraph_get()
            suns = {
                o.name: lights.sun_direction(o.evaluated_get(depsgraph)).tolist()
                for o in scene.objects
                if o.type == "LIGHT" and o.data.type == "SUN"
            }
            cam = scene.camera.evaluated_get(depsgraph) if scene.camera else None
            lamps = {}
            for name in exported.lamps.values():
                lamp = bpy.data.objects[name].evaluated_get(depsgraph)
                lamps[name] = _jsonable(lights.export(lamp, lamp.matrix_world, Report()))
            out.append(
                {
                    "frame": f,
                    "suns": suns,
                    "lamps": lamps,
                    "camera": camera.to_world(cam).tolist() if cam is not None else None,
                }
            )
            state = _unfollowed_state(scene, depsgraph, followed)
            if first is None:
                first = state
                continue
            for key in first.keys() | state.keys():
                if key not in state or key not in first or not _same(first[key], state[key]):
                    changed.setdefault(key, f)
                    whole.add(f)
    finally:
        scene.frame_set(current)
    animated = [{"what": what, "changes": changes, "from_frame": f} for (what, changes), f in sorted(changed.items())]
    return out, animated, whole


def _whole_frames(scene, entries, directory, known):
    """Each entry's frame exported whole beside the first (scene_NNNN.xml, sharing the files
    that stay the same), named in its "scene"; returns the warnings not in `known`."""
    import bpy

    current = scene.frame_current
    warnings = []
    try:
        for entry in entries:
            scene.frame_set(entry["frame"])
            exported = export_scene(bpy.context.evaluated_depsgraph_get())
            entry["scene"] = f"scene_{entry['frame']:04d}.xml"
            write_directory(exported, directory, entry["scene"], by_content=True)
            warnings += [w for w in exported.warnings if w not in known and w not in warnings]
    finally:
        scene.frame_set(current)
    return warnings


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


LIGHT_SETTINGS = ("energy", "color", "shadow_soft_size", "spot_size", "spot_blend", "angle", "size", "size_y", "spread")
CAMERA_SETTINGS = ("lens", "sensor_width", "sensor_height", "shift_x", "shift_y", "clip_start", "clip_end")


def _unfollowed_state(scene, depsgraph, followed):
    """{(what, changes): values} at the current frame for everything the pipeline exports once:
    objects' placements (all but the camera's, the followed lamps' and VDB sequences'; a sun's
    has no effect), other lamps' and the camera's settings, deformed meshes, instances'
    placements, material and world node values."""
    state = {}
    for obj in scene.objects:
        ob = obj.evaluated_get(depsgraph)
        what = f"{obj.type.lower()} '{obj.name}'"
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
        elif obj.type == "MESH" and _may_deform(obj):
            mesh = ob.to_mesh()  # evaluated: modifiers and shape keys applied
            co = np.empty(3 * len(mesh.vertices))
            mesh.vertices.foreach_get("co", co)
            ob.to_mesh_clear()
            state[(what, "shape")] = co
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


def _may_deform(obj):
    """Whether an object's mesh can change from frame to frame: modifiers (an armature's
    among them), shape keys, or an armature parent."""
    return bool(obj.modifiers) or obj.data.shape_keys is not None or (obj.parent and obj.parent.type == "ARMATURE")


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
