"""Motion blur as Blender's render settings ask for it (Motion Blur: Shutter and Position;
the shutter curve aside): the camera's and moving objects' maps at KEYS evenly spaced times
over the shutter (particle and collection instances' too), as the scene's ``motion`` keys,
between which the core interpolates linearly and each camera ray draws its time; and for
meshes deformed in the shutter
(modifiers, shape keys, an armature), their positions at the keys. Objects moving or
deforming in the shutter are exported as instances of a group of their own (export_scene's
``instanced``): the keys move the instance, or deform the group's meshes."""

import math

import numpy as np

from . import camera, convert, materials, meshes

# The shutter's opening, middle and closing (Cycles' default motion steps for objects).
KEYS = 3

_BLURRED = {"MESH", "CURVE", "SURFACE", "FONT", "META"}


def source(inst):
    """What places an object instance of the depsgraph, the same at every sub-frame: the
    object's name, or for a particle or collection instance its instancer's name and its
    persistent id."""
    if not inst.is_instance:
        return inst.object.original.name
    return inst.parent.original.name, tuple(inst.persistent_id)


class Motion:
    """``objects``: {source(instance): [matrix_world per key]} for the objects and
    instances that move in the shutter; ``camera``: the camera's scene to_world per key, or None where it holds
    still; ``deformed``: {Blender object: [positions (K, n, 3) per material part, in the
    exporter's order]} for the meshes deformed in the shutter."""

    def __init__(self, objects, camera, deformed):
        self.objects, self.camera, self.deformed = objects, camera, deformed

    def moves(self):
        return bool(self.objects or self.deformed) or self.camera is not None

    def instanced(self):
        """The objects to export as instances of a group of their own."""
        return {name for name in self.objects if isinstance(name, str)} | set(self.deformed)


def may_deform(obj):
    """Whether an object's mesh can change with time: modifiers (an armature's among them),
    shape keys, or an armature parent."""
    data = getattr(obj, "data", None)
    return obj.type == "MESH" and (
        bool(obj.modifiers) or data.shape_keys is not None or (obj.parent and obj.parent.type == "ARMATURE")
    )


def shutter_times(render, frame):
    """The frame times of the keys (the shutter centred on, starting or ending at `frame`),
    or None where motion blur is off."""
    if not render.use_motion_blur:
        return None
    s = float(render.motion_blur_shutter)
    opening = frame + {"START": 0.0, "CENTER": -0.5 * s, "END": -s}[render.motion_blur_position]
    return [opening + s * k / (KEYS - 1) for k in range(KEYS)]


def scene_depsgraph(scene):
    """depsgraph_at for `sample` outside a render engine: the scene's own frame_set."""
    import bpy

    def depsgraph_at(frame, subframe):
        scene.frame_set(frame, subframe=subframe)
        return bpy.context.evaluated_depsgraph_get()

    return depsgraph_at


def sample(scene, depsgraph_at, frame):
    """The Motion over the shutter of `frame`, or None where motion blur is off.
    ``depsgraph_at(frame, subframe)`` evaluates the scene there and returns the depsgraph (a
    render engine's frame_set, or the scene's); the scene is left evaluated at `frame`."""
    times = shutter_times(scene.render, frame)
    if times is None:
        return None
    blurred = [o for o in scene.objects if o.type in _BLURRED and _switch(o, "use_motion_blur")]
    deformable = [o for o in blurred if may_deform(o) and _switch(o, "use_deform_motion")]
    uv_maps = {o.name: _uv_map(o) for o in deformable}
    maps, cams, parts = {o.name: [] for o in blurred}, [], {o.name: [] for o in deformable}
    try:
        for t in times:
            whole = math.floor(t)
            depsgraph = depsgraph_at(whole, t - whole)
            for o in blurred:
                maps[o.name].append(np.array(o.evaluated_get(depsgraph).matrix_world))
            for inst in depsgraph.object_instances:
                if inst.is_instance and inst.object.type in _BLURRED:
                    maps.setdefault(source(inst), []).append(np.array(inst.matrix_world))
            for o in deformable:
                parts[o.name].append(
                    [p[0] for p in meshes.triangles(o.evaluated_get(depsgraph), uv_maps[o.name]).values()]
                )
            if scene.camera is not None:
                cams.append(camera.to_world(scene.camera.evaluated_get(depsgraph)))
    finally:
        depsgraph_at(frame, 0.0)
    # (An instance that is not there at every key, a particle born in the shutter, holds still.)
    objects = {name: keys for name, keys in maps.items() if len(keys) == len(times) and not _still(keys)}
    deformed = {}
    for name, keys in parts.items():
        shapes = {tuple(p.shape for p in key) for key in keys}
        if len(shapes) == 1 and any(not _still([key[j] for key in keys]) for j in range(len(keys[0]))):
            deformed[name] = [np.array([key[j] for key in keys]) for j in range(len(keys[0]))]
    return Motion(objects, np.array(cams) if cams and not _still(cams) else None, deformed)


def _uv_map(obj):
    """The UV map the export gives the object's triangles (export_scene's choice)."""
    from . import Report, uv_map_of

    return uv_map_of(obj, lambda m: materials.export(m, Report()), Report())


def attach(exported, motion):
    """The motion keys on the exported scene: its camera's, those of the instances that
    objects in motion.objects became, and the positions of the deformed objects' groups'
    meshes (a group's members in the order of the object's material parts)."""
    if motion is None:
        return
    d = exported.scene
    if motion.camera is not None:
        d["camera"] = dict(d["camera"], motion=motion.camera)
    for key, name in exported.placed.items():
        if name in motion.objects:
            d[key] = dict(d[key], motion=np.array([convert.matrix(m) for m in motion.objects[name]]))
        if name in motion.deformed:
            group_key = d[key]["group"]["id"]
            members = [m for m in d[group_key] if m != "type"]
            keys = motion.deformed[name]
            if len(members) == len(keys) and all(
                d[group_key][m]["positions"].shape == k.shape[1:] for m, k in zip(members, keys)
            ):
                d[group_key] = dict(d[group_key], **{m: dict(d[group_key][m], motion=k) for m, k in zip(members, keys)})


def _switch(obj, name):
    """An object's Motion Blur switch (Object > Motion Blur, Cycles' settings): on unless off."""
    return getattr(getattr(obj, "cycles", None), name, True)


def _still(keys):
    return all(np.array_equal(keys[0], k) for k in keys[1:])
