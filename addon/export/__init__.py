"""Blender scene -> Volpath scene dictionary (the vocabulary of volpath.load_dict).

    exported = export_scene(depsgraph)          # in memory, for F12
    volpath.load_dict(exported.scene)
    write_directory(exported, "out/scene")      # scene.xml + meshes/*.ply + volumes/*.vol
    animation(scene, frames)                    # per-frame sun directions and camera

Everything that cannot be exported faithfully is listed in ``exported.warnings`` (the
engine shows them in Blender's report); what cannot be exported at all raises ExportError.
"""

import numpy as np

from . import camera, convert, lights, materials, meshes, volumes, world


class ExportError(Exception):
    """The scene cannot be rendered (no camera, a missing VDB file, ...)."""


class Report:
    def __init__(self):
        self.warnings, self.notes = [], []

    def warn(self, message):
        if message not in self.warnings:
            self.warnings.append(message)

    def note(self, message):
        if message not in self.notes:
            self.notes.append(message)

    @staticmethod
    def error(message):
        return ExportError(message)


class Exported:
    """``scene``: the dictionary; ``warnings``/``notes``: what the report shows;
    ``suns``: keys of the sun emitters, with the Blender objects they came from."""

    def __init__(self, scene, report, suns):
        self.scene, self.warnings, self.notes, self.suns = scene, report.warnings, report.notes, suns


_CONVERTIBLE = {"MESH", "CURVE", "SURFACE", "FONT", "META"}


def export_scene(depsgraph):
    """The evaluated depsgraph (modifiers, instances, the current frame) as a scene."""
    scene = depsgraph.scene
    settings = scene.volpath
    report = Report()
    d = {"type": "scene",
         "integrator": {"type": "volpath", "max_depth": int(settings.max_depth), "rr_depth": int(settings.rr_depth),
                        "max_null_collisions": int(settings.max_null_collisions)},
         "camera": camera.export(scene, report)}
    suns = {}
    sun_lamps = [inst for inst in depsgraph.object_instances
                 if inst.object.type == "LIGHT" and inst.object.data.type == "SUN"]
    sky = world.export(scene, report, has_sun_lamp=bool(sun_lamps))
    d.update(sky)
    if "air" in sky:
        # The atmosphere needs rays hundreds of kilometres long; Blender's clip end does
        # not apply to the world either.
        d["camera"]["far_clip"] = max(d["camera"]["far_clip"], 1e9)
    exterior = {"type": "ref", "id": "air"} if "air" in sky else None
    mesh_cache = {}
    names = set()

    def key(name):
        k, i = name, 1
        while k in names or k in d:
            k, i = f"{name}.{i}", i + 1
        names.add(k)
        return k

    for inst in depsgraph.object_instances:
        obj = inst.object
        if obj.type == "LIGHT":
            entry = lights.export(obj, inst.matrix_world, report)
            if entry is not None:
                k = key(obj.name)
                d[k] = entry
                if entry["type"] == "sun":
                    suns[k] = obj.original.name
        elif obj.type in _CONVERTIBLE:
            data = obj.data.original if obj.data is not None else obj.original
            cache_key = (data.name, data.library.name if getattr(data, "library", None) else None,
                         obj.original.name if obj.modifiers else "")
            if cache_key not in mesh_cache:
                mesh_cache[cache_key] = meshes.triangles(obj)
            slots = [s.material for s in obj.material_slots]
            to_world = np.array(inst.matrix_world, dtype=np.float64)
            to_world = convert.matrix(to_world)
            for index, (positions, indices, normals) in mesh_cache[cache_key].items():
                material = slots[index] if index < len(slots) else None
                bsdf, radiance, medium = materials.export(material, report)
                shape = {"type": "mesh", "positions": positions, "indices": indices, "to_world": to_world, "bsdf": bsdf}
                if normals is not None:
                    shape["normals"] = normals
                if radiance is not None:
                    shape["emitter"] = {"type": "area", "radiance": convert.rgb(radiance)}
                if medium is not None:
                    shape["interior"] = materials.homogeneous(medium)
                    if exterior is not None:
                        shape["exterior"] = exterior
                d[key(obj.name if len(mesh_cache[cache_key]) == 1 else f"{obj.name}.{material.name if material else index}")] = shape
        elif obj.type == "VOLUME":
            material = obj.material_slots[0].material if obj.material_slots else None
            _, _, medium = materials.export(material, report)
            if material is None or medium is None:
                medium = {"sigma_a": np.full(3, 0.5), "sigma_s": np.full(3, 0.5), "g": 0.0, "attribute": "density"}
            entry = volumes.export(obj, inst.matrix_world, medium, report, exterior)
            if entry is not None:
                entry["interior"]["majorant_resolution"] = int(settings.majorant_resolution)
                d[key(obj.name)] = entry
        elif obj.type not in ("CAMERA", "EMPTY", "ARMATURE", "LIGHT_PROBE", "SPEAKER", "LATTICE"):
            report.warn(f"object '{obj.name}': {obj.type.lower()} objects are not supported (skipped)")
    return Exported(d, report, suns)


def animation(scene, frames):
    """Per frame: the scene-space direction of every Sun lamp and the camera's to_world,
    evaluated by Blender itself (``frame_set``), so fcurves, drivers and constraints count."""
    import bpy

    current = scene.frame_current
    out = []
    try:
        for f in frames:
            scene.frame_set(f)
            depsgraph = bpy.context.evaluated_depsgraph_get()
            suns = {o.name: lights.sun_direction(o.evaluated_get(depsgraph)).tolist()
                    for o in scene.objects if o.type == "LIGHT" and o.data.type == "SUN"}
            cam = scene.camera.evaluated_get(depsgraph) if scene.camera else None
            out.append({"frame": f, "suns": suns,
                        "camera": camera.to_world(cam).tolist() if cam is not None else None})
    finally:
        scene.frame_set(current)
    return out


def write_directory(exported, directory):
    """scene.xml with meshes/ and volumes/ beside it; returns the XML's path."""
    from volpath.xml_writer import write_scene

    return write_scene(exported.scene, directory)
