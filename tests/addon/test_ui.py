"""The panels name only settings and operators that exist (panels cannot draw headless,
so a misspelt name would otherwise surface only in Blender's console)."""

from blender_scenes import bpy

import addon.ui as ui


def test_panel_properties_and_operators_exist(blank):
    settings = blank.volpath
    for cls in ui.CLASSES:
        if not issubclass(cls, ui._VolpathPanel):  # the view layer's passes
            assert hasattr(bpy.context.view_layer, "use_pass_z") and not bpy.context.view_layer.volpath.denoising_data
            continue
        assert cls.props or cls.extra is not ui._VolpathPanel.extra
        for name in getattr(cls, "head", ()) + cls.props:
            assert hasattr(settings, name), (cls.__name__, name)
    for op in ("render_video", "open_output", "export_scene"):
        assert hasattr(bpy.ops.volpath, op)
    assert all("VOLPATH" in p.COMPAT_ENGINES for p in ui._blender_panels())
