"""Volpath's settings, stored in the .blend as ``scene.volpath`` and, per view layer, its
passes as ``view_layer.volpath``."""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from volpath import TracerConfig

DEFAULTS = TracerConfig()  # the core's defaults, the one source of them

TRACER_ITEMS = [
    ("auto", "Auto", "The cheapest tracer whose omissions stay below the tolerance (reasons in the report)"),
    ("absorption", "Absorption", "Emission and absorption only (tracer 1)"),
    ("single", "Single Scattering", "One scattering event in media (tracer 2)"),
    ("multiple", "Multiple Scattering", "Any number of scattering events, Russian roulette (tracer 3)"),
    ("nee_mis", "NEE + MIS", "Next-event estimation and multiple importance sampling, surfaces (tracer 4)"),
    ("null_scattering", "Null Scattering", "Heterogeneous and chromatic media by null scattering (tracer 5)"),
]


class VolpathSettings(bpy.types.PropertyGroup):
    # Sampling
    spp: IntProperty(
        name="Samples",
        description="Samples per pixel (the cap per pixel with a noise threshold)",
        default=16,
        min=1,
        soft_max=4096,
    )
    use_adaptive_sampling: BoolProperty(
        name="Noise Threshold",
        description="Render until the image's noise is below the threshold: the noisiest regions take the most samples",
        default=False,
    )
    adaptive_threshold: FloatProperty(
        name="Noise Threshold",
        description="RMS error of the displayed image, in "
        "display units 0..1, at the image's own auto exposure (0.02: 2 % of the "
        "display's range)",
        default=0.02,
        min=0.001,
        max=0.5,
        precision=3,
        step=0.1,
    )
    use_denoising: BoolProperty(
        name="Denoise",
        description="Pass the render through Intel Open Image Denoise "
        "with the albedo and normal of the first surfaces: far less noise, some bias",
        default=False,
    )
    seed: IntProperty(
        name="Seed", description="The same seed gives the same image on any number of threads", default=0, min=0
    )
    threads: IntProperty(name="Threads", description="Render threads (0: all cores)", default=0, min=0, soft_max=256)
    tracer: EnumProperty(name="Tracer", items=TRACER_ITEMS, default="auto")
    tolerance: FloatProperty(
        name="Tolerance",
        description="Relative error the automatic tracer may leave out",
        default=0.01,
        min=0.0,
        max=1.0,
    )
    # Light paths
    max_depth: IntProperty(
        name="Max Depth",
        description="Path segments as Mitsuba counts them (-1: unlimited)",
        default=DEFAULTS.max_depth,
        min=-1,
        soft_max=1024,
    )
    rr_depth: IntProperty(
        name="Russian Roulette Depth",
        description="Depth from which paths may be ended at random",
        default=DEFAULTS.rr_depth,
        min=1,
        soft_max=64,
    )
    # Volumes
    majorant_resolution: IntProperty(
        name="Majorant Grid",
        description="Cells per axis of the local majorant grid "
        "(0: automatic, about one per 10 voxels; 1: one global majorant)",
        default=0,
        min=0,
        max=64,
    )
    max_null_collisions: IntProperty(
        name="Max Null Collisions",
        description="Safety cap on null collisions per segment",
        default=DEFAULTS.max_null_collisions,
        min=1,
        soft_max=100000,
    )
    # Atmosphere (a world with a Sky Texture)
    use_atmosphere: BoolProperty(
        name="Atmosphere", description="Render a Sky Texture world as the physical atmosphere", default=True
    )
    atmosphere_preset: EnumProperty(
        name="Preset",
        default="bruneton",
        items=[
            (
                "bruneton",
                "Bruneton 2017",
                "Measured Rayleigh, Mie and ozone coefficients (Bruneton 2017, Hillaire 2020)",
            ),
            ("report", "Course Report", "The original report's physics: lambda^-4 Rayleigh, no ozone, R = 6378 km"),
        ],
    )
    atmosphere_mode: EnumProperty(
        name="Colour",
        default="rgb",
        items=[
            ("rgb", "RGB", "Three wavelengths, 680 / 550 / 440 nm: one pass"),
            (
                "spectral",
                "Spectral",
                "Twelve wavelengths over 360-830 nm in four passes, integrated against the CIE "
                "matching functions: truer sunrise colours for four times the time",
            ),
        ],
    )
    atmosphere_free_flight: EnumProperty(
        name="Free Flight",
        default="guided",
        items=[
            (
                "guided",
                "Guided",
                "Collisions drawn toward where the sun's light scatters, transmittances from a table: "
                "far less noise at sunrise",
            ),
            (
                "tracking",
                "Delta Tracking",
                "Collisions by delta tracking against per-ray majorants (unbiased with the "
                "sun's transmittance tracked too)",
            ),
        ],
    )
    atmosphere_pieces: IntProperty(
        name="Majorant Pieces",
        description="Pieces of each ray's per-altitude majorant (delta tracking)",
        default=4,
        min=1,
        max=16,
    )
    sun_irradiance: FloatProperty(
        name="Sky Sun Irradiance",
        description="W/m² of the Sky Texture's own sun (used only without a Sun lamp), times its Sun Intensity",
        default=10.0,
        min=0.0,
    )
    # Animation to video (the sunrise pipeline)
    video_directory: StringProperty(name="Output Folder", subtype="DIR_PATH", default="//volpath_video/")
    video_fps: IntProperty(name="FPS", default=24, min=1, max=240)
    video_step: IntProperty(name="Frame Step", default=1, min=1)
    video_workers: IntProperty(
        name="Workers", description="Frames rendered at once (0: one per core)", default=0, min=0
    )
    video_resume: BoolProperty(name="Resume", description="Keep frames already rendered", default=True)
    video_scheduler: StringProperty(
        name="Dask Scheduler",
        description="Address of a Dask distributed scheduler (empty: render on this machine)",
        default="",
    )


class VolpathViewLayerSettings(bpy.types.PropertyGroup):
    denoising_data: BoolProperty(
        name="Denoising Data",
        description="Denoising Albedo and Denoising Normal passes, for the compositor's Denoise node",
        default=False,
    )


def register():
    bpy.utils.register_class(VolpathSettings)
    bpy.types.Scene.volpath = PointerProperty(type=VolpathSettings)
    bpy.utils.register_class(VolpathViewLayerSettings)
    bpy.types.ViewLayer.volpath = PointerProperty(type=VolpathViewLayerSettings)


def unregister():
    del bpy.types.ViewLayer.volpath
    bpy.utils.unregister_class(VolpathViewLayerSettings)
    del bpy.types.Scene.volpath
    bpy.utils.unregister_class(VolpathSettings)
