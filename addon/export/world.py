"""The world: a Background colour x strength is a constant environment; a Sky Texture is
Volpath's atmosphere medium (planet, air, aerosols, ozone) lit by the scene's Sun lamps,
or by the node's own sun when there is none."""

import math

import numpy as np

from . import convert


def _background(world, report):
    tree = world.node_tree if world is not None else None
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"]
    active = [n for n in outputs if n.is_active_output] or outputs
    if not active or not active[0].inputs["Surface"].is_linked:
        return None
    return active[0].inputs["Surface"].links[0].from_node


def export(scene, report, has_sun_lamp):
    """{key: dict} entries for the scene's world: emitters and media."""
    world = scene.world
    if world is None:
        return {}
    node = _background(world, report)
    if node is None:
        color = np.array(world.color[:3])
        return {"world": {"type": "constant", "radiance": convert.rgb(color)}} if np.any(color > 0) else {}
    if node.bl_idname != "ShaderNodeBackground":
        report.warn(f"world '{world.name}': '{node.name}' is not supported (expected Background); no world light")
        return {}
    strength = node.inputs["Strength"]
    color_in = node.inputs["Color"]
    if color_in.is_linked:
        source = color_in.links[0].from_node
        if source.bl_idname == "ShaderNodeTexSky":
            return _sky(source, scene, strength.default_value, report, has_sun_lamp)
        report.warn(
            f"world '{world.name}': '{source.name}' ({source.bl_label}) drives the background colour; "
            f"only the Sky Texture is supported, using the socket's colour"
        )
    radiance = np.array(color_in.default_value[:3]) * strength.default_value
    return {"world": {"type": "constant", "radiance": convert.rgb(radiance)}} if np.any(radiance > 0) else {}


def _sky(node, scene, strength, report, has_sun_lamp):
    settings = scene.volpath
    if not settings.use_atmosphere:
        report.note("Sky Texture: the atmosphere is off in the Volpath world settings (black sky)")
        return {}
    if node.sky_type not in ("MULTIPLE_SCATTERING", "SINGLE_SCATTERING"):
        report.warn(
            f"Sky Texture: the {node.sky_type.replace('_', '-').title()} model is analytic; "
            "rendering the physical atmosphere instead"
        )
    unit = scene.unit_settings.scale_length or 1.0
    air = {
        "type": "atmosphere",
        "preset": settings.atmosphere_preset,
        "mode": settings.atmosphere_mode,
        "unit": float(unit),
        "free_flight": settings.atmosphere_free_flight,
        "majorant_pieces": int(settings.atmosphere_pieces),
    }
    from volpath import ATMOSPHERE_PRESETS

    preset = ATMOSPHERE_PRESETS[settings.atmosphere_preset]
    radius = preset["planet_radius"]
    # The Blender scene's origin sits `altitude` metres above sea level, as in Cycles.
    air["center"] = convert.point([0.0, 0.0, -(radius + float(node.altitude)) / unit])
    air["rayleigh_scattering"] = convert.rgb(np.asarray(preset["rayleigh_scattering"]) * node.air_density)
    air["mie_scattering"] = float(preset["mie_scattering"] * node.aerosol_density)
    air["mie_extinction"] = float(preset["mie_extinction"] * node.aerosol_density)
    air["ozone_absorption"] = convert.rgb(np.asarray(preset["ozone_absorption"]) * node.ozone_density)
    air["ozone"] = bool(node.ozone_density > 0 and np.any(np.asarray(preset["ozone_absorption"]) > 0))
    air["ground_albedo"] = float(node.ground_albedo) if hasattr(node, "ground_albedo") else 0.3
    entries = {"air": air}
    if not has_sun_lamp and node.sun_disc:
        # Blender's sky sun: elevation above the horizon, rotation about +Z from +Y towards -X
        # (the Sky Texture's sun_direction); strength scales the irradiance.
        e, r = node.sun_elevation, node.sun_rotation
        to_sun = np.array([-math.sin(r) * math.cos(e), math.cos(r) * math.cos(e), math.sin(e)])
        entries["sun"] = {
            "type": "sun",
            "direction": -convert.direction(to_sun),
            "angular_radius": max(node.sun_size / 2, 1e-4),
            "irradiance": convert.rgb(np.full(3, settings.sun_irradiance * node.sun_intensity * strength)),
        }
    return entries
