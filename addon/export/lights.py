"""Blender lights to emitters, in Blender's radiometry (as Cycles renders it): a point light
of power P has intensity P/(4 pi) W/sr, a sun's strength is its irradiance in W/m², an
area light of power P and area A has radiance P/(pi A)."""

import math

import numpy as np

from . import convert

_DISK_SEGMENTS = 64


def sun_direction(obj):
    """Where the sun's light travels, in scene coordinates (the lamp points along -Z)."""
    return convert.direction(-np.array(obj.matrix_world.to_3x3())[:, 2])


# Blender's ray visibility flags (Object properties) and the scene's ray kinds.
VISIBILITY = {
    "visible_camera": "camera",
    "visible_diffuse": "diffuse",
    "visible_glossy": "glossy",
    "visible_transmission": "transmission",
    "visible_volume_scatter": "scatter",
    "visible_shadow": "shadow",
}


def hidden_kinds(obj):
    """The ray kinds whose visibility flag is off on an object."""
    return [kind for flag, kind in VISIBILITY.items() if not getattr(obj, flag, True)]


def hidden_from(obj):
    """The scene's `hidden_from` of an object: its ray visibility flags that are off."""
    return ", ".join(hidden_kinds(obj))


# The emitters an animation follows frame by frame: a loaded scene replaces them cheaply
# (volpath's Scene.update), so every frame has the lamp as Blender evaluates it there.
FOLLOWED = ("point", "sun")


def export(obj, matrix_world, report):
    """The emitter (or emitting shape) of one light instance, or None; unsupported lights
    are reported, never dropped silently."""
    light = obj.data
    color = np.array(light.color, dtype=np.float64) * light.energy
    name = obj.name
    off = hidden_kinds(obj)
    # Diffuse, Glossy, Transmission off: it lights surfaces through their other lobes only.
    # Volume Scatter off: it lights no medium. Cast Shadow off: it casts none (Cycles reads
    # the light's own switch, not the object's Shadow visibility).
    kinds = [k for k in off if k in ("diffuse", "glossy", "transmission", "scatter")]
    kinds += [] if light.use_shadow else ["shadow"]
    hidden = {"hidden_from": ", ".join(kinds)} if kinds else {}
    if light.type == "POINT":
        if light.shadow_soft_size > 0:
            report.note(f"light '{name}': soft radius {light.shadow_soft_size:g} is rendered as a point light")
        return {
            "type": "point",
            "position": convert.matrix(matrix_world)[:3, 3],
            "intensity": convert.rgb(color / (4 * math.pi)),
            **hidden,
        }
    if light.type == "SUN":
        return {
            "type": "sun",
            "direction": sun_direction(obj),
            "angular_radius": max(light.angle / 2, 1e-4),
            "irradiance": convert.rgb(color),
            **hidden,
        }
    if light.type == "AREA":
        return _area(light, matrix_world, color, report, name, obj.visible_camera, hidden)
    report.warn(f"light '{name}': {light.type.lower()} lights are not supported (skipped)")
    return None


def _area(light, matrix_world, power, report, name, camera_visible, hidden):
    sx = light.size
    sy = light.size_y if light.shape in ("RECTANGLE", "ELLIPSE") else light.size
    if light.shape in ("SQUARE", "RECTANGLE"):
        positions = np.array([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]], np.float32)
        indices = np.array([[0, 2, 1], [0, 3, 2]], np.uint32)  # facing -z, where the lamp shines
    else:  # DISK, ELLIPSE: a fan whose area is the polygon's, so the power stays exact
        t = 2 * math.pi * np.arange(_DISK_SEGMENTS) / _DISK_SEGMENTS
        ring = np.stack([0.5 * np.cos(t), 0.5 * np.sin(t), np.zeros_like(t)], axis=1)
        positions = np.vstack([[0, 0, 0], ring]).astype(np.float32)
        i = np.arange(_DISK_SEGMENTS)
        indices = np.stack([np.zeros_like(i), (i + 1) % _DISK_SEGMENTS + 1, i + 1], axis=1).astype(np.uint32)
    scale = np.diag([sx, sy, 1.0, 1.0])
    to_world = convert.matrix(matrix_world) @ scale
    world = positions.astype(np.float64) @ to_world[:3, :3].T
    area = (
        0.5
        * np.linalg.norm(
            np.cross(world[indices[:, 1]] - world[indices[:, 0]], world[indices[:, 2]] - world[indices[:, 0]]), axis=1
        ).sum()
    )
    if area <= 0:
        report.warn(f"light '{name}': zero area (skipped)")
        return None
    # Lights are not geometry (as in Cycles): a null BSDF lets every ray through, shadow
    # rays included, and the camera sees the light only if the object says so.
    return {
        "type": "mesh",
        "positions": positions,
        "indices": indices,
        "to_world": to_world,
        "bsdf": {"type": "null"},
        "emitter": {
            "type": "area",
            "radiance": convert.rgb(power / (math.pi * area)),
            **_spread(light, report, name),
            **hidden,
        },
        **({} if camera_visible else {"hidden_from": "camera"}),
    }


# The narrowest spread rendered: a spread of 0 is a beam that only the camera could see.
MIN_SPREAD = 0.5


def _spread(light, report, name):
    """The emitter's `spread` in degrees, where it is below 180 (Blender's Spread)."""
    degrees = math.degrees(light.spread)
    if degrees >= 180 - 1e-4:
        return {}
    if degrees < MIN_SPREAD:
        report.note(f"light '{name}': a spread of {degrees:g} degrees is rendered as {MIN_SPREAD} degrees")
    return {"spread": max(degrees, MIN_SPREAD)}
