"""Blender scene -> Volpath scene dictionary (the vocabulary of volpath.load_dict).

    exported = export_scene(depsgraph)          # in memory, for F12
    volpath.load_dict(exported.scene)
    write_directory(exported, "out/scene")      # scene.xml + meshes/*.ply + volumes/*.vdb

An animation (the scene plus what moves per frame) is animation.py's.

Everything that cannot be exported faithfully is listed in ``exported.warnings`` (the
engine shows them in Blender's report); what cannot be exported at all raises ExportError.
"""

from collections import Counter

import numpy as np

from . import camera, convert, lights, materials, meshes, motion, volumes, world


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
    ``suns``: keys of the sun emitters, with the Blender objects they came from;
    ``lamps``: the same for every point, spot and sun emitter of a lamp that is no instance (an
    animation follows their settings frame by frame);
    ``sequences``: {key: volume object} for the VDB sequences (files change with the frame);
    ``placed``: {key: motion.source} for the instances: what places each (an object, or a
    particle or collection instance of its instancer), which motion keys move (motion.attach)."""

    def __init__(self, scene, report, suns, lamps, sequences, placed):
        self.scene, self.warnings, self.notes = scene, report.warnings, report.notes
        self.suns, self.lamps, self.sequences, self.placed = suns, lamps, sequences, placed


_CONVERTIBLE = {"MESH", "CURVE", "SURFACE", "FONT", "META"}


def export_scene(depsgraph, mesh_cache=None, instanced=(), final=False):
    """The evaluated depsgraph (modifiers, instances, the current frame) as a scene.
    ``mesh_cache``: a dictionary kept between exports (the viewport's, an animation's) whose
    meshes' triangles are reused; drop_meshes() forgets those whose geometry changed.
    ``instanced``: names of objects placed as an instance of a group of their own even
    where nothing shares their mesh (an animation's moving and deforming objects: a frame
    moves the instance, or replaces the group's mesh, without rebuilding the rest).
    ``final``: objects disabled in renders are left out even where the depsgraph is the
    viewport's (an animation exported outside F12 renders what F12 would)."""
    scene = depsgraph.scene
    settings = scene.volpath
    report = Report()
    d = {
        "type": "scene",
        "integrator": {
            "type": "volpath",
            "max_depth": int(settings.max_depth),
            "rr_depth": int(settings.rr_depth),
            "max_null_collisions": int(settings.max_null_collisions),
        },
        "camera": camera.export(scene, report),
    }
    suns, lamps, sequences = {}, {}, {}
    sun_lamps = [
        inst for inst in depsgraph.object_instances if inst.object.type == "LIGHT" and inst.object.data.type == "SUN"
    ]
    sky = world.export(scene, report, has_sun_lamp=bool(sun_lamps))
    d.update(sky)
    if "air" in sky:
        # The atmosphere needs rays hundreds of kilometres long; Blender's clip end does
        # not apply to the world either.
        d["camera"]["far_clip"] = max(d["camera"]["far_clip"], 1e9)
    exterior = {"type": "ref", "id": "air"} if "air" in sky else None
    meshes_by_data, materials_by_name = {} if mesh_cache is None else mesh_cache, {}

    def material(m):
        """(Material, the medium inside) of a material slot, exported once."""
        name = m.name if m is not None else None
        if name not in materials_by_name:
            mat = materials.export(m, report)
            medium = mat.medium
            interior = materials.homogeneous(medium, report, f"material '{name}'") if medium is not None else None
            materials_by_name[name] = mat, interior
        return materials_by_name[name]

    def add(name, entry):
        k = _unique(name, d)
        d[k] = entry
        return k

    for inst in depsgraph.object_instances:
        obj = inst.object
        if final and not shown_in_render(inst.parent if inst.is_instance else obj):
            continue
        if obj.type == "LIGHT":
            entry = lights.export(obj, inst.matrix_world, report)
            if entry is not None:
                k = add(obj.name, entry)
                if entry["type"] == "sun":
                    suns[k] = obj.original.name
                if lights.followed(obj.data) and not inst.is_instance:
                    lamps[k] = obj.original.name
        elif obj.type in _CONVERTIBLE:
            placed = _mesh_shapes(obj, inst, meshes_by_data, material, exterior, report)
            if placed.parts:
                add(obj.name, placed)
        elif obj.type == "VOLUME":
            slot = obj.material_slots[0].material if obj.material_slots else None
            entry = _volume_shape(obj, inst.matrix_world, material(slot)[0].medium, settings, report, exterior)
            if entry is not None:
                k = add(obj.name, entry)
                if obj.data.is_sequence:
                    sequences[k] = obj.original.name
        elif obj.type not in ("CAMERA", "EMPTY", "ARMATURE", "LIGHT_PROBE", "SPEAKER", "LATTICE"):
            report.warn(f"object '{obj.name}': {obj.type.lower()} objects are not supported (skipped)")
    placed, placed_objects = _place_meshes(d, set(instanced))
    return Exported(placed, report, suns, lamps, sequences, placed_objects)


def shown_in_render(obj):
    """Whether an object renders: neither it nor a collection it is in is disabled in renders
    (the render depsgraph leaves those out; a viewport's keeps them)."""
    obj = obj.original
    return not obj.hide_render and not any(c.hide_render for c in obj.users_collection)


def _unique(name, taken):
    k, i = name, 1
    while k in taken:
        k, i = f"{name}.{i}", i + 1
    return k


class _Placed:
    """One object instance's mesh shapes (object space), its map, the Blender object's
    name, and what it shares with other instances of the same mesh: ``key`` (the mesh
    datablock, its materials and ray visibility), or None where it cannot be instanced (it
    emits or holds a medium)."""

    def __init__(self, key, parts, to_world, name, source):
        self.key, self.parts, self.to_world, self.name = key, parts, to_world, name
        self.source = source  # motion.source: what places it (the object, or its instancer)


def _place_meshes(d, instanced):
    """The scene with each mesh object in place: meshes that several object instances share
    (linked duplicates, collection, particle and geometry-node instances), and the objects
    named in ``instanced``, as one shapegroup and an instance per object; the others as
    world-placed shapes, one per material. Returns it and {instance key: motion.source}."""
    counts = Counter(v.key for v in d.values() if isinstance(v, _Placed) and v.key is not None)
    out, groups, objects = {}, {}, {}
    for k, v in d.items():
        if not isinstance(v, _Placed):
            out[k] = v
        elif counts[v.key] > 1 or (v.key is not None and v.name in instanced):
            if v.key not in groups:
                groups[v.key] = _unique(f"{v.key[0][0]}.group", d.keys() | out.keys())
                group = out[groups[v.key]] = {"type": "shapegroup"}
                for name, shape in v.parts:  # (two slots may hold one material)
                    group[_unique(name, group)] = shape
            out[k] = {"type": "instance", "group": {"type": "ref", "id": groups[v.key]}, "to_world": v.to_world}
            objects[k] = v.source
        else:
            for name, shape in v.parts:
                part = k if len(v.parts) == 1 else _unique(f"{k}.{name}", d.keys() | out.keys())
                out[part] = dict(shape, to_world=v.to_world)
    return out, objects


def _volume_shape(obj, matrix_world, medium, settings, report, exterior):
    if medium is None:  # Blender's default volume
        medium = {"sigma_a": np.full(3, 0.5), "sigma_s": np.full(3, 0.5), "g": 0.0, "attribute": "density"}
    entry = volumes.export(obj, matrix_world, medium, report, exterior)
    if entry is not None:
        entry["interior"]["majorant_resolution"] = int(settings.majorant_resolution)
    return entry


def export_volume(depsgraph, name):
    """The shape of one volume object at the depsgraph's frame (a VDB sequence's frame)."""
    obj = depsgraph.scene.objects[name].evaluated_get(depsgraph)
    slot = obj.material_slots[0].material if obj.material_slots else None
    report = Report()
    return _volume_shape(
        obj, obj.matrix_world, materials.export(slot, report).medium, depsgraph.scene.volpath, report, None
    )


def uv_map_of(obj, material, report):
    """The UV map an object's triangles carry: the one its materials' textures read (the
    first by name where they differ, reported); None where none reads one."""
    uv_maps = {material(s.material).uv_map for s in obj.material_slots} - {None}
    uv_map = min(uv_maps) if uv_maps else None
    if len(uv_maps) > 1:
        shown = uv_map or "the render one"
        report.warn(f"object '{obj.name}': its materials read different UV maps; all read '{shown}'")
    return uv_map


def drop_meshes(mesh_cache, objects):
    """Forget the cached triangles of these Blender objects (their geometry changed)."""
    names = {o.name for o in objects} | {o.data.name for o in objects if getattr(o, "data", None) is not None}
    for key in [k for k in mesh_cache if k[0] in names or k[2] in names]:
        del mesh_cache[key]


def _mesh_shapes(obj, inst, meshes_by_data, material, exterior, report):
    """One mesh instance's shapes (a _Placed): one per material slot, named by the slot's
    material; the triangle arrays of a mesh datablock are computed once and shared by its
    instances (unless modifiers differ)."""
    slots = [s.material for s in obj.material_slots]
    uv_map = uv_map_of(obj, lambda m: material(m)[0], report)
    data = obj.data.original if obj.data is not None else obj.original
    key = (
        data.name,
        data.library.name if getattr(data, "library", None) else None,
        obj.original.name if obj.modifiers else "",
        uv_map,
        data.as_pointer(),  # meshes that geometry nodes make share names ("Mesh"), not addresses
    )
    if key not in meshes_by_data:
        meshes_by_data[key] = meshes.triangles(obj, uv_map)
    parts = meshes_by_data[key]
    shapes, names, shared = [], [], True
    hidden = lights.hidden_from(obj)
    for index, (positions, indices, normals, uvs) in parts.items():
        m = slots[index] if index < len(slots) else None
        mat, interior = material(m)
        if mat.uv_map is not None and uvs is None:
            report.warn(f"object '{obj.name}': no UV map '{mat.uv_map}' for its textures; they read (0, 0)")
        shape = {"type": "mesh", "positions": positions, "indices": indices, "bsdf": mat.bsdf}
        if normals is not None:
            shape["normals"] = normals
        if hidden:
            shape["hidden_from"] = hidden
        if uvs is not None:
            shape["uvs"] = uvs
        if mat.radiance is not None:
            # Cycles' emission shaders light both faces of a mesh.
            shape["emitter"] = {**materials.emitter(mat.radiance), "twosided": True}
        if interior is not None:
            shape["interior"] = interior
            if exterior is not None:
                shape["exterior"] = exterior
        shared &= mat.radiance is None and interior is None
        shapes.append((m.name if m else str(index), shape))
        names.append(m.name if m else None)
    return _Placed(
        (key, tuple(names), hidden) if shared else None,
        shapes,
        convert.matrix(inst.matrix_world),
        obj.original.name,
        motion.source(inst),
    )


def write_directory(exported, directory, filename="scene.xml", by_content=False):
    """scene.xml with meshes/ and volumes/ beside it; returns the XML's path. ``by_content``:
    see volpath.xml_writer.write_scene (an animation's frames share their files)."""
    from volpath.xml_writer import write_scene

    return write_scene(exported.scene, directory, filename, by_content)
