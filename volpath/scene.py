"""The scene model: a Mitsuba-style scene dictionary turned into the native scene.

``load_file``/``load_string`` read XML into the dictionary (xml_reader.py); ``load_dict``
builds from a dictionary directly (the Blender exporter's path) through the plugins, one
module per kind (plugins/). Every unknown plugin or parameter is an error that names where
it came from.
"""

import contextlib
import gc
import os
from typing import Any

from . import _core, spectral
from .errors import SceneError
from .plugins.builder import Builder
from .xml_reader import read_xml


class Scene:
    """A loaded scene: the native scene plus the file's render settings.

    Attributes: ``spp``, ``max_depth``, ``rr_depth``, ``max_null_collisions``, ``light_distances``,
    ``tracer`` (the integrator's tracer), ``width``, ``height``, ``summary`` (what the
    scene contains, for ``volpath info``), ``passes`` (in spectral mode, the scene at each
    pass's wavelengths; see volpath/spectral.py) and, after a render, ``last_render``
    (seconds, non-finite sample count, ...).
    """

    def __init__(self, native: _core.Scene, settings: dict, summary: dict, source: str | None):
        self.native = native
        self.spp = settings["spp"]
        self.max_depth = settings["max_depth"]
        self.rr_depth = settings["rr_depth"]
        self.max_null_collisions = settings["max_null_collisions"]
        self.light_distances = settings["light_distances"]
        self.tracer = settings["tracer"]
        self.summary = summary
        self.source = source
        self.last_render: dict[str, Any] | None = None
        self.passes: list[_core.Scene] = []  # spectral mode: one native scene per wavelength pass
        self._builder: Builder | None = None  # what update() rebuilds with

    @property
    def width(self) -> int:
        return self.native.width

    def update(self, d: dict) -> bool:
        """Move the scene to ``d``: the dictionary it was loaded from with some of its
        top-level entries replaced (an animation's next frame, a lamp edited in the
        viewport). What can change in place does: the sensor; an emitter, by one of its type;
        an instance's ``to_world`` and ``motion`` (the BVH is refit, not rebuilt); a shape group's meshes
        (that group's BVH alone is rebuilt); a shape's BSDF, by a leaf without textures.
        Meshes, media, the BVH, and the sky map's levels while the sun stays within their
        elevations, are kept, and rays find what ``load_dict(d)``'s would. Entries not
        replaced must be the same objects or equal. Returns False, changing nothing, where
        ``d`` differs in anything else or the scene has spectral passes."""
        if self.passes or self._builder is None:
            return False
        spp = self._builder.update(d)
        if spp is None:
            return False
        self.spp = spp
        return True

    @property
    def height(self) -> int:
        return self.native.height

    @property
    def memory(self) -> dict[str, int]:
        """Bytes the native scene holds, by part ("shapes", "bvh", "media", "lights"; a
        spectral mode's passes summed in) and in all ("total")."""
        parts = dict(self.native.memory)
        for native in self.passes:
            for part, n in native.memory.items():
                parts[part] += n
        return {**parts, "total": sum(parts.values())}

    def __repr__(self) -> str:
        return (
            f"<volpath.Scene {self.source or ''} {self.width}x{self.height}, spp={self.spp}, "
            f"tracer={self.tracer}, max_depth={self.max_depth}>"
        )


@contextlib.contextmanager
def _no_cycle_collection():
    """Loading makes a small dict or list for every element of the scene, and none of them
    is cyclic garbage: the collector's passes over them would cost a third of the load."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


@_no_cycle_collection()
def load_file(path: str | os.PathLike, **params: Any) -> Scene:
    """Load a Mitsuba 3 (or 0.5/0.6 / lajolla) XML scene. Keyword arguments override the
    file's ``<default>`` parameters, as ``mi.load_file`` does."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise SceneError(f"{path}: scene file not found")
    with open(path, encoding="utf-8") as f:
        text = f.read()
    d = read_xml(text, path, params)
    return load_dict(d, base_dir=os.path.dirname(os.path.abspath(path)), source=path)


@_no_cycle_collection()
def load_string(xml: str, base_dir: str | os.PathLike = ".", **params: Any) -> Scene:
    """Load a scene from XML text; relative file names are resolved against base_dir."""
    d = read_xml(xml, "<string>", params)
    return load_dict(d, base_dir=base_dir, source="<string>")


@_no_cycle_collection()
def load_dict(d: dict, base_dir: str | os.PathLike = ".", source: str | None = None) -> Scene:
    """Build a scene from a Mitsuba-style dictionary ({'type': 'scene', ...})."""
    if not isinstance(d, dict) or d.get("type") != "scene":
        raise SceneError("expected a scene dictionary with 'type': 'scene'")
    builder = Builder(d, base_dir, source)
    scene = Scene(builder.native, builder.build(), builder.summary, source)
    scene._builder = builder
    if builder.spectral_passes:  # the scene again at each pass's wavelengths
        scene.passes = []
        for wavelengths in spectral.pass_wavelengths(builder.spectral_passes):
            at = Builder(d, base_dir, source, wavelengths)
            at.build()
            scene.passes.append(at.native)
    return scene
