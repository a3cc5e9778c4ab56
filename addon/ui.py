"""Panels of the Volpath engine (render, world) and Blender's own panels that apply to it."""

import bpy


class _VolpathPanel:
    """A panel of scene.volpath settings: `props` are drawn in order, then `extra()`."""

    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    COMPAT_ENGINES = {"VOLPATH"}
    props = ()

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        s = context.scene.volpath
        self.layout.use_property_split = True
        for name in self.props:
            self.layout.prop(s, name)
        self.extra(self.layout, s)

    def extra(self, layout, s):
        pass


class VOLPATH_PT_sampling(_VolpathPanel, bpy.types.Panel):
    bl_label = "Sampling"
    bl_context = "render"
    head = ("use_adaptive_sampling", "adaptive_threshold", "spp")  # drawn first, as Cycles draws them
    props = ("use_denoising", "seed", "threads", "tracer")

    def draw(self, context):
        s = context.scene.volpath
        self.layout.use_property_split = True
        row = self.layout.row(heading="Noise Threshold")
        row.prop(s, "use_adaptive_sampling", text="")
        sub = row.row()
        sub.active = s.use_adaptive_sampling
        sub.prop(s, "adaptive_threshold", text="")
        self.layout.prop(s, "spp", text="Max Samples" if s.use_adaptive_sampling else "Samples")
        super().draw(context)

    def extra(self, layout, s):
        row = layout.row()
        row.active = s.tracer == "auto"
        row.prop(s, "tolerance")


class VOLPATH_PT_light_paths(_VolpathPanel, bpy.types.Panel):
    bl_label = "Light Paths"
    bl_context = "render"
    props = ("max_depth", "rr_depth")


class VOLPATH_PT_volumes(_VolpathPanel, bpy.types.Panel):
    bl_label = "Volumes"
    bl_context = "render"
    props = ("majorant_resolution", "max_null_collisions")


class VOLPATH_PT_video(_VolpathPanel, bpy.types.Panel):
    bl_label = "Animation to Video"
    bl_context = "render"
    props = ("video_directory", "video_step", "video_fps", "video_workers", "video_resume", "video_scheduler")

    def extra(self, layout, s):
        layout.operator("volpath.render_video", icon="RENDER_ANIMATION")
        layout.operator("volpath.open_output", icon="FILE_FOLDER")
        layout.operator("volpath.export_scene", icon="EXPORT")


class VOLPATH_PT_atmosphere(_VolpathPanel, bpy.types.Panel):
    bl_label = "Atmosphere"
    bl_context = "world"

    def draw_header(self, context):
        self.layout.prop(context.scene.volpath, "use_atmosphere", text="")

    props = ("atmosphere_preset", "atmosphere_mode", "atmosphere_free_flight", "atmosphere_pieces", "sun_irradiance")

    def draw(self, context):
        self.layout.active = context.scene.volpath.use_atmosphere
        self.layout.label(text="A Sky Texture world renders as a planet's atmosphere", icon="INFO")
        super().draw(context)


class VOLPATH_PT_passes(bpy.types.Panel):
    """The view layer's passes besides Combined (the engine's update_render_passes)."""

    bl_label = "Passes"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "view_layer"
    COMPAT_ENGINES = {"VOLPATH"}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        layer = context.view_layer
        self.layout.use_property_split = True
        self.layout.prop(layer, "use_pass_z")
        self.layout.prop(layer.volpath, "denoising_data")


CLASSES = (
    VOLPATH_PT_sampling,
    VOLPATH_PT_light_paths,
    VOLPATH_PT_volumes,
    VOLPATH_PT_video,
    VOLPATH_PT_passes,
    VOLPATH_PT_atmosphere,
)

# Blender's panels for what the exporter reads: camera, lights, materials, world, volumes.
_BLENDER_PANELS = (
    "DATA_PT_lens",
    "DATA_PT_camera",
    "DATA_PT_camera_dof",
    "DATA_PT_context_light",
    "DATA_PT_light",
    "DATA_PT_EEVEE_light",
    "EEVEE_MATERIAL_PT_context_material",
    "EEVEE_MATERIAL_PT_surface",
    "EEVEE_MATERIAL_PT_volume",
    "EEVEE_WORLD_PT_surface",
    "DATA_PT_volume_file",
    "DATA_PT_volume_grids",
    "DATA_PT_volume_render",
)


def _blender_panels():
    for name in _BLENDER_PANELS:
        panel = getattr(bpy.types, name, None)
        if panel is not None and hasattr(panel, "COMPAT_ENGINES"):
            yield panel
    for panel in bpy.types.Panel.__subclasses__():  # the panels every engine shares
        if "BLENDER_RENDER" in getattr(panel, "COMPAT_ENGINES", ()):
            yield panel


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    for panel in _blender_panels():
        panel.COMPAT_ENGINES.add("VOLPATH")


def unregister():
    for panel in _blender_panels():
        panel.COMPAT_ENGINES.discard("VOLPATH")
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
