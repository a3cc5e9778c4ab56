"""Blender side of the pipeline: the scene once, and per frame what moves (the suns'
directions and the camera), as an animation directory that volpath.frames renders."""

import json
import os

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
    if len(frames) > 1:
        for name in exported.sequences:
            exported.warnings.append(f"volume '{name}' is a VDB sequence: the pipeline renders every frame with "
                                     f"its grid at frame {frames[0]} (F12 and animation renders follow the sequence)")
    export.write_directory(exported, directory)
    animation = {"suns": exported.suns, "frames": export.animation(scene, frames)}
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
