"""Motion blur as Blender's render settings ask for it (Motion Blur: Shutter and Position;
the shutter curve aside): the camera's and moving objects' maps at KEYS evenly spaced times
over the shutter, as the scene's ``motion`` keys, between which the core interpolates
linearly and each camera ray draws its time. Objects moving in the shutter are exported
as instances (export_scene's ``instanced``): the keys move the instance. Deformation
within the shutter is not blurred (the mesh is the frame's)."""

import math

import numpy as np

from . import camera, convert

# The shutter's opening, middle and closing (Cycles' default motion steps for objects).
KEYS = 3

_BLURRED = {"MESH", "CURVE", "SURFACE", "FONT", "META"}


class Motion:
    """``objects``: {Blender object: [matrix_world per key]} for the objects that move in
    the shutter; ``camera``: the camera's scene to_world per key, or None where it holds
    still."""

    def __init__(self, objects, camera):
        self.objects, self.camera = objects, camera

    def moves(self):
        return bool(self.objects) or self.camera is not None


def shutter_times(render, frame):
    """The frame times of the keys (the shutter centred on, starting or ending at `frame`),
    or None where motion blur is off."""
    if not render.use_motion_blur:
        return None
    s = float(render.motion_blur_shutter)
    opening = frame + {"START": 0.0, "CENTER": -0.5 * s, "END": -s}[render.motion_blur_position]
    return [opening + s * k / (KEYS - 1) for k in range(KEYS)]


def sample(scene, depsgraph_at, frame):
    """The Motion over the shutter of `frame`, or None where motion blur is off.
    ``depsgraph_at(frame, subframe)`` evaluates the scene there and returns the depsgraph (a
    render engine's frame_set, or the scene's); the scene is left evaluated at `frame`."""
    times = shutter_times(scene.render, frame)
    if times is None:
        return None
    blurred = [
        o for o in scene.objects if o.type in _BLURRED and getattr(getattr(o, "cycles", None), "use_motion_blur", True)
    ]
    maps, cams = {o.name: [] for o in blurred}, []
    try:
        for t in times:
            whole = math.floor(t)
            depsgraph = depsgraph_at(whole, t - whole)
            for o in blurred:
                maps[o.name].append(np.array(o.evaluated_get(depsgraph).matrix_world))
            if scene.camera is not None:
                cams.append(camera.to_world(scene.camera.evaluated_get(depsgraph)))
    finally:
        depsgraph_at(frame, 0.0)
    objects = {name: keys for name, keys in maps.items() if not _still(keys)}
    return Motion(objects, np.array(cams) if cams and not _still(cams) else None)


def attach(exported, motion):
    """The motion keys on the exported scene: its camera's, and those of the instances that
    objects in motion.objects became."""
    if motion is None:
        return
    d = exported.scene
    if motion.camera is not None:
        d["camera"] = dict(d["camera"], motion=motion.camera)
    for key, name in exported.placed.items():
        if name in motion.objects:
            d[key] = dict(d[key], motion=np.array([convert.matrix(m) for m in motion.objects[name]]))


def _still(keys):
    return all(np.array_equal(keys[0], k) for k in keys[1:])
