"""Blender lights to emitters, in Blender's radiometry (as Cycles renders it): a point or
spot light of power P has intensity P/(4 pi) W/sr (with a Radius r, a sphere of radiance
P/(4 pi^2 r^2)), a sun's strength is its irradiance in W/m², an area light of power P and
area A has radiance P/(pi A)."""

import math

import numpy as np

from . import convert, materials

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


def followed(light):
    """Whether a lamp is one an animation follows frame by frame: one exported as an emitter
    (a sun, a point or spot lamp without a radius), which a loaded scene replaces cheaply
    (volpath's Scene.update), so that every frame has the lamp as Blender evaluates it."""
    return light.type == "SUN" or (light.type in ("POINT", "SPOT") and light.shadow_soft_size == 0)


def power(light, report, name):
    """The lamp's colour times its power, as Cycles reads them: Color, times the colour of
    its Temperature where that is on, times Power (W; the sun's Strength in W/m²) times 2 to
    the Exposure, times what its node tree's Emission gives (colour x strength)."""
    color = np.array(light.color, dtype=np.float64)
    if getattr(light, "use_temperature", False):
        color = color * np.array(light.temperature_color, dtype=np.float64)
    return color * light.energy * 2.0 ** getattr(light, "exposure", 0.0) * _emission(light, report, name)


def _emission(light, report, name):
    """The colour x strength of the Emission node on a lamp's Light Output (1 without one).
    Its Color may come from a Blackbody node; other nodes driving it are reported and their
    socket's value used."""
    out = materials.output(light.node_tree if getattr(light, "use_nodes", False) else None, "ShaderNodeOutputLight")
    node = materials.linked(out, "Surface") if out is not None else None
    if node is None:
        return np.ones(3)
    if node.bl_idname != "ShaderNodeEmission":
        report.warn(f"light '{name}': '{node.name}' on its Light Output is not supported (expected Emission)")
        return np.ones(3)
    from volpath.blackbody import blackbody_colour

    def value(socket):
        if not socket.is_linked:
            return np.array(socket.default_value, dtype=np.float64).ravel()[:3]
        source = socket.links[0].from_node
        if source.bl_idname == "ShaderNodeBlackbody" and not source.inputs["Temperature"].is_linked:
            return blackbody_colour(source.inputs["Temperature"].default_value)
        report.warn(f"light '{name}': '{source.name}' drives {socket.name}; using the socket's value")
        return np.array(socket.default_value, dtype=np.float64).ravel()[:3]

    return value(node.inputs["Color"]) * value(node.inputs["Strength"])[0]


def export(obj, matrix_world, report):
    """The emitter (or emitting shape) of one light instance, or None; unsupported lights
    are reported, never dropped silently."""
    light = obj.data
    name = obj.name
    color = power(light, report, name)
    off = hidden_kinds(obj)
    # Diffuse, Glossy, Transmission off: it lights surfaces through their other lobes only.
    # Volume Scatter off: it lights no medium. Cast Shadow off: it casts none (Cycles reads
    # the light's own switch, not the object's Shadow visibility).
    kinds = [k for k in off if k in ("diffuse", "glossy", "transmission", "scatter")]
    kinds += [] if light.use_shadow else ["shadow"]
    hidden = {"hidden_from": ", ".join(kinds)} if kinds else {}
    if light.type in ("POINT", "SPOT"):
        return _point(light, obj, matrix_world, color, report, hidden)
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


def _point(light, obj, matrix_world, power, report, hidden):
    """A point or spot lamp: of intensity power / (4 pi) W/sr (a spot's cone cuts it, it
    does not concentrate it, as in Cycles); with a Radius, a sphere of that radius whose
    radiance gives the same power, seen by the camera where its visibility says so."""
    m = convert.matrix(matrix_world)
    position = m[:3, 3]
    intensity = power / (4 * math.pi)
    spot = {}
    if light.type == "SPOT":
        scales = np.linalg.norm(np.array(matrix_world)[:3, :3], axis=0)
        if not np.allclose(scales, scales[0], rtol=1e-4):
            report.note(f"light '{obj.name}': a spot's non-uniform scale is ignored (its cone stays round)")
        spot = {
            "direction": -m[:3, 2] / np.linalg.norm(m[:3, 2]),  # the lamp shines along its -Z
            "cutoff_angle": min(math.degrees(light.spot_size) / 2, 90.0),
            "blend": float(light.spot_blend),
        }
    radius = light.shadow_soft_size
    if radius <= 0:
        return {
            "type": light.type.lower(),
            "position": position,
            "intensity": convert.rgb(intensity),
            **spot,
            **hidden,
        }
    return {
        "type": "sphere",
        "center": position,
        "radius": float(radius),
        "bsdf": {"type": "null"},
        "emitter": {
            "type": "area",
            "radiance": convert.rgb(intensity / (math.pi * radius**2)),
            "soft_falloff": bool(getattr(light, "use_soft_falloff", True)),
            **spot,
            **hidden,
        },
        **({} if obj.visible_camera else {"hidden_from": "camera"}),
    }


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
            # Normalize off: Power is per square metre, the light grows with its size.
            "radiance": convert.rgb(power / (math.pi * (area if getattr(light, "normalize", True) else 1.0))),
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
