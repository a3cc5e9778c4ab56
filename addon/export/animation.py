"""A Blender animation as an animation directory: the scene once, and per frame what moves,
evaluated by Blender itself (``frame_set``), so that fcurves, drivers and constraints
count. The pipeline renders such a directory frame by frame without Blender
(``pipeline.frames``, where the directory's format is described).
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
    """Write scene.xml (+ meshes, volumes) at the first of ``frames`` and animation.json for
    all of them into ``directory``; returns the export's warnings."""
    import bpy

    current = scene.frame_current
    scene.frame_set(frames[0])
    try:
        exported = export_scene(bpy.context.evaluated_depsgraph_get())
    finally:
        scene.frame_set(current)
    write_directory(exported, directory)
    animation = {"suns": exported.suns, "frames": _suns_and_camera(scene, frames)}
    if exported.sequences:
        _volume_sequences(scene, exported.sequences, animation["frames"], directory)
    tmp = os.path.join(directory, ANIMATION_FILE + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(animation, f, indent=1)
    os.replace(tmp, os.path.join(directory, ANIMATION_FILE))
    return exported.warnings


def _suns_and_camera(scene, frames):
    """Per frame: the direction of every Sun lamp and the camera's to_world."""
    import bpy

    current = scene.frame_current
    out = []
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
            out.append({"frame": f, "suns": suns, "camera": camera.to_world(cam).tolist() if cam is not None else None})
    finally:
        scene.frame_set(current)
    return out


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
