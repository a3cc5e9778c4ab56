"""The active camera: Mitsuba's perspective sensor with Blender's sensor fit and shift."""

import math

import numpy as np

from . import convert

# Mitsuba's camera looks along +z with +x to the image's left; Blender's looks along -z
# with +x to the right: flip both.
_BLENDER_TO_MITSUBA_CAMERA = np.diag([-1.0, 1.0, -1.0, 1.0])


def resolution(render):
    scale = render.resolution_percentage / 100.0
    return max(1, int(render.resolution_x * scale)), max(1, int(render.resolution_y * scale))


def to_world(obj):
    return convert.matrix(obj.matrix_world) @ _BLENDER_TO_MITSUBA_CAMERA


def export(scene, report):
    """The sensor dictionary (film and sampler included) for scene.camera."""
    obj = scene.camera
    if obj is None:
        raise report.error("the scene has no active camera")
    cam = obj.data
    if cam.type != "PERSP":
        report.warn(f"camera '{obj.name}': {cam.type.lower()} projection is not supported, rendering as perspective")
    width, height = resolution(scene.render)
    aspect_x, aspect_y = scene.render.pixel_aspect_x, scene.render.pixel_aspect_y
    if abs(aspect_x - aspect_y) > 1e-6:
        report.warn("non-square pixel aspect is not supported; pixels are square")
    fit = cam.sensor_fit
    if fit == "AUTO":
        fov, axis = 2 * math.atan(cam.sensor_width / (2 * cam.lens)), "larger"
    elif fit == "HORIZONTAL":
        fov, axis = 2 * math.atan(cam.sensor_width / (2 * cam.lens)), "x"
    else:
        fov, axis = 2 * math.atan(cam.sensor_height / (2 * cam.lens)), "y"
    if cam.dof.use_dof:
        report.warn(f"camera '{obj.name}': depth of field is not supported (pinhole camera)")
    settings = scene.volpath
    sensor = {
        "type": "perspective",
        "fov": math.degrees(fov),
        "fov_axis": axis,
        "near_clip": float(cam.clip_start),
        "far_clip": float(cam.clip_end),
        "to_world": to_world(obj),
        "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"}},
        "sampler": {"type": "independent", "sample_count": int(settings.spp)},
    }
    if cam.shift_x or cam.shift_y:
        # Blender's shift is in fractions of the side the sensor fits (the larger one under
        # Auto), the scene's in fractions of the larger side.
        fitted = {"x": width, "y": height, "larger": max(width, height)}[axis] / max(width, height)
        sensor["shift_x"], sensor["shift_y"] = float(cam.shift_x) * fitted, float(cam.shift_y) * fitted
    return sensor


def from_view(view_matrix, window_matrix, width, height, clip_start, clip_end, spp=1):
    """The sensor dictionary for a 3D viewport: its view matrix (world to view) and its
    perspective projection (OpenGL's, possibly off-centre in camera view) at its size."""
    P = np.array(window_matrix, dtype=np.float64).reshape(4, 4)
    if P[3, 3] != 0:
        raise ValueError("orthographic views are not supported (perspective only)")
    tan_x, tan_y = 1.0 / P[0, 0], 1.0 / P[1, 1]
    span = 2 * max(tan_x, tan_y)  # Blender's shift is in fractions of the larger side
    world_to_view = np.array(view_matrix, dtype=np.float64).reshape(4, 4)
    sensor = {
        "type": "perspective",
        "fov": math.degrees(2 * math.atan(tan_x)),
        "fov_axis": "x",
        "near_clip": float(clip_start),
        "far_clip": float(clip_end),
        "to_world": convert.matrix(np.linalg.inv(world_to_view)) @ _BLENDER_TO_MITSUBA_CAMERA,
        "film": {"type": "hdrfilm", "width": int(width), "height": int(height), "rfilter": {"type": "box"}},
        "sampler": {"type": "independent", "sample_count": int(spp)},
    }
    shift_x, shift_y = P[0, 2] * tan_x / span, P[1, 2] * tan_y / span
    if shift_x or shift_y:
        sensor["shift_x"], sensor["shift_y"] = float(shift_x), float(shift_y)
    return sensor
