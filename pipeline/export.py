"""Blender side of the pipeline: the scene once, and per frame what moves (the suns'
directions and the camera), as an animation directory that volpath.frames renders."""

import json
import os

from volpath.frames import ANIMATION_FILE

from . import sibling


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
    tmp = os.path.join(directory, ANIMATION_FILE + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(animation, f, indent=1)
    os.replace(tmp, os.path.join(directory, ANIMATION_FILE))
    return exported.warnings
