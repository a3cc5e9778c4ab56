"""Blender side of the pipeline: the scene once, and per frame what moves (the suns'
directions, the camera, the grids of VDB sequences: each frame's .vdb copied), as an animation directory that
volpath.frames renders."""

import json
import os

import numpy as np

from volpath.frames import ANIMATION_FILE

from . import sibling
from .run import Run


def export_animation(scene, frames, directory):
    """Write scene.xml (+ meshes, volumes) and animation.json for ``frames`` of ``scene``;
    returns the warnings of the export."""
    import bpy

    export = sibling("addon.export")
    current = scene.frame_current
    scene.frame_set(frames[0])
    try:
        exported = export.export_scene(bpy.context.evaluated_depsgraph_get())
    finally:
        scene.frame_set(current)
    export.write_directory(exported, directory)
    animation = {"suns": exported.suns, "frames": export.animation(scene, frames)}
    if exported.sequences:
        _volume_sequences(scene, exported.sequences, animation["frames"], directory)
    tmp = os.path.join(directory, ANIMATION_FILE + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(animation, f, indent=1)
    os.replace(tmp, os.path.join(directory, ANIMATION_FILE))
    return exported.warnings


def prepare_run(scene, frames, out_dir, options, progress=None, cancel=None):
    """Export ``frames`` of ``scene`` into ``out_dir``/scene and return (Run, warnings);
    the Run needs no Blender and may execute in any thread (``run.execute()``)."""
    animation_dir = os.path.join(out_dir, "scene")
    warnings = export_animation(scene, frames, animation_dir)
    return Run(animation_dir, out_dir, frames, options, progress=progress, cancel=cancel), warnings


def _volume_sequences(scene, sequences, frames, directory):
    """Per frame, the grids of every VDB sequence beside the scene: a copy of the frame's
    .vdb, or for an emitting volume's radiance (computed voxel by voxel in Blender) a
    sparse .vdb of its own (volpath.xml_writer.write_volume)."""
    import bpy
    from volpath.xml_writer import write_volume

    export = sibling("addon.export")
    os.makedirs(os.path.join(directory, "volumes"), exist_ok=True)
    current = scene.frame_current
    try:
        for entry in frames:
            scene.frame_set(entry["frame"])
            depsgraph = bpy.context.evaluated_depsgraph_get()
            entry["volumes"] = {}
            for key, name in sequences.items():
                shape = export.export_volume(depsgraph, name)
                if shape is None:
                    raise export.ExportError(f"volume '{name}': no active voxels at frame {entry['frame']}")
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
