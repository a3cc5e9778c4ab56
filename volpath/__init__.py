"""Volpath: a physically based volumetric path tracer.

import volpath
scene = volpath.load_file("scene.xml", spp=16)
image = volpath.render(scene, seed=1)          # float32 (height, width, 3)
volpath.write_exr("out.exr", image)
"""

from ._core import RenderSettings, Tracer, TracerConfig
from .errors import RenderCancelled, SceneError, SceneWarning
from .exr import read_exr, write_exr
from .plugins.integrators import TRACERS
from .plugins.media import ATMOSPHERE_PRESETS
from .render import render
from .scene import Scene, load_dict, load_file, load_string
from .volume import VolumeGrid

__version__ = "0.1.0"
__all__ = [
    "ATMOSPHERE_PRESETS",
    "RenderCancelled",
    "RenderSettings",
    "Scene",
    "SceneError",
    "SceneWarning",
    "TRACERS",
    "Tracer",
    "TracerConfig",
    "VolumeGrid",
    "load_dict",
    "load_file",
    "load_string",
    "read_exr",
    "render",
    "write_exr",
    "__version__",
]
