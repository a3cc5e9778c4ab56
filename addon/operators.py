"""Operators: export the scene as a Volpath scene directory."""

import os

import bpy
from bpy.props import StringProperty


class VOLPATH_OT_export_scene(bpy.types.Operator):
    """Write the scene as scene.xml with its meshes and volumes (renders with `python -m volpath render`)"""

    bl_idname = "volpath.export_scene"
    bl_label = "Export Volpath Scene"
    directory: StringProperty(subtype="DIR_PATH")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        from .export import ExportError, export_scene, write_directory

        if not self.directory:
            self.report({"ERROR"}, "no directory given")
            return {"CANCELLED"}
        try:
            exported = export_scene(context.evaluated_depsgraph_get())
            path = write_directory(exported, bpy.path.abspath(self.directory))
        except (ExportError, OSError) as e:
            self.report({"ERROR"}, f"Volpath: {e}")
            return {"CANCELLED"}
        for message in exported.warnings:
            self.report({"WARNING"}, f"Volpath: {message}")
        self.report({"INFO"}, f"Volpath scene written to {os.path.abspath(path)}")
        return {"FINISHED"}


CLASSES = (VOLPATH_OT_export_scene,)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
