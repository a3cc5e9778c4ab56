"""The world: a Background colour x strength is a constant environment; an Environment
Texture (through Mapping nodes) an environment map; a Sky Texture is Volpath's atmosphere
medium (planet, air, aerosols, ozone) lit by the scene's Sun lamps, or by the node's own
sun when there is none."""

import math

import numpy as np

from . import convert, materials


def _background(world):
    """The shader on the world's output (None without one)."""
    out = materials.output(world.node_tree, "ShaderNodeOutputWorld")
    return materials.linked(out, "Surface") if out is not None else None


def export(scene, report, has_sun_lamp):
    """{key: dict} entries for the scene's world: emitters and media."""
    world = scene.world
    if world is None:
        return {}
    node = _background(world)
    if node is None:
        color = np.array(world.color[:3])
        return {"world": {"type": "constant", "radiance": convert.rgb(color)}} if np.any(color > 0) else {}
    if node.bl_idname == "ShaderNodeMixShader" and _is_camera_ray(node.inputs["Fac"]):
        return _shown_and_lit(node, world.name, report)
    if node.bl_idname != "ShaderNodeBackground":
        report.warn(f"world '{world.name}': '{node.name}' is not supported (expected Background); no world light")
        return {}
    color_in = node.inputs["Color"]
    if color_in.is_linked and color_in.links[0].from_node.bl_idname == "ShaderNodeTexSky":
        return _sky(color_in.links[0].from_node, scene, node.inputs["Strength"].default_value, report, has_sun_lamp)
    light = _light(node, world.name, report)
    return {"world": light} if light is not None else {}


def _light(node, owner, report):
    """The environment of a Background node: an envmap of its Environment Texture, else a
    constant of its colour x strength (None where black)."""
    strength = node.inputs["Strength"].default_value
    color_in = node.inputs["Color"]
    if color_in.is_linked:
        source = color_in.links[0].from_node
        if source.bl_idname == "ShaderNodeTexEnvironment" and source.image is not None:
            return _environment(source, strength, owner, report)
        report.warn(
            f"world '{owner}': '{source.name}' ({source.bl_label}) drives the background colour; "
            f"only the Environment and Sky Textures are supported, using the socket's colour"
        )
    radiance = np.array(color_in.default_value[:3]) * strength
    return {"type": "constant", "radiance": convert.rgb(radiance)} if np.any(radiance > 0) else None


def _is_camera_ray(socket):
    link = socket.links[0] if socket.is_linked else None
    return (
        link is not None
        and link.from_node.bl_idname == "ShaderNodeLightPath"
        and link.from_socket.name == "Is Camera Ray"
    )


def _shown_and_lit(mix, owner, report):
    """A Mix Shader whose factor is the Light Path's Is Camera Ray: its first Background
    lights the scene unseen, its second is what the camera sees and lights nothing."""
    entries = {}
    for key, socket, hidden in (
        ("world", mix.inputs[1], "camera"),
        ("world_shown", mix.inputs[2], "diffuse, glossy, transmission, scatter"),
    ):
        node = socket.links[0].from_node if socket.is_linked else None
        if node is None or node.bl_idname != "ShaderNodeBackground":
            report.warn(f"world '{owner}': '{mix.name}' mixes a shader that is not a Background; it is left out")
            continue
        light = _light(node, owner, report)
        if light is not None:
            entries[key] = {**light, "hidden_from": hidden}
    return entries


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


# Blender's equirectangular image seen from the scene: the direction b (Blender's axes,
# after its Mapping nodes) is found at u = 1/2 - atan2(b_y, b_x) / 2 pi, its zenith at the
# top; the scene's envmap (Mitsuba's mapping) looks up u = atan2(l_x, -l_z) / 2 pi in its
# local frame l, y up. The two agree where l = (b_y, b_z, b_x).
_BLENDER_TO_ENVMAP = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])


def _environment(node, strength, owner, report):
    """An Environment Texture as an `envmap`: the image's pixels (any file Blender loads,
    linear), equirectangular or resampled from a mirror ball, turned as the Mapping nodes
    in front of it turn the direction it looks up."""
    from volpath.tonemap import srgb_to_linear

    from .textures import _LINEAR, _pixels

    image = node.image
    texels = _pixels(image, f"world '{owner}'")[:, :, :3].astype(np.float64)
    if not image.is_float and image.colorspace_settings.name not in _LINEAR:
        texels = srgb_to_linear(texels)
    if node.projection == "MIRROR_BALL":
        texels = _mirror_ball_to_equirectangular(texels)
    rotation = _direction_map(node, owner, report)
    # to_local maps scene directions to the envmap's frame: back to Blender's axes, through
    # the Mapping nodes, into the envmap's.
    to_local = np.eye(4)
    to_local[:3, :3] = _BLENDER_TO_ENVMAP @ rotation @ convert.BLENDER_TO_SCENE[:3, :3].T
    return {
        "type": "envmap",
        "data": np.ascontiguousarray(np.clip(texels, 0, None), dtype=np.float32),
        "scale": float(strength),
        "to_world": np.linalg.inv(to_local),
    }


def _direction_map(node, owner, report):
    """The rotation that Mapping nodes (and a Texture Coordinate's Generated output, the
    world's direction) apply to the direction an Environment Texture looks up. Their
    Location moves no direction and a uniform Scale changes none; a non-uniform one would
    bend the map's solid angles, which its importance sampling assumes unbent: it is
    reported and left out."""
    from .textures import _mapping_matrix

    m, socket = np.eye(3), node.inputs["Vector"]
    while socket.is_linked:
        link = socket.links[0]
        source = link.from_node
        if source.bl_idname == "ShaderNodeMapping":
            m = m @ _mapping_matrix(source, f"world '{owner}'", report)[:3, :3]
            socket = source.inputs["Vector"]
        elif source.bl_idname == "ShaderNodeTexCoord" and link.from_socket.name in ("Generated", "Object"):
            break
        else:
            report.warn(
                f"world '{owner}': '{node.name}' reads its direction from '{source.name}' ({source.bl_label}); "
                "using the view direction"
            )
            break
    u, scales, vt = np.linalg.svd(m)
    if not np.allclose(scales, scales[0], rtol=1e-6):
        report.warn(f"world '{owner}': a non-uniform Scale of the Environment Texture's mapping is ignored")
    return u @ vt  # the nearest orthogonal map: the rotation alone


def _mirror_ball_to_equirectangular(ball):
    """A mirror ball image (a chrome sphere seen along +Y) resampled to an equirectangular
    one: for each direction, the point of the ball that reflects it toward the viewer, read
    bilinearly. The ball's rim spreads over much of the sphere, so the map has eight times
    the ball's height (at most 2048 rows), each texel the mean of up to 3 x 3 directions
    (about 8 million in all)."""
    h = min(8 * ball.shape[0], 2048)
    w = 2 * h
    n = int(np.clip(np.sqrt(8e6 / (h * w)), 1, 3))
    v, u = np.meshgrid((np.arange(h * n) + 0.5) / (h * n), (np.arange(w * n) + 0.5) / (w * n), indexing="ij")
    phi, theta = (0.5 - u) * 2 * np.pi, v * np.pi  # rows top first: theta from the zenith
    d = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=-1)
    # The ball's normal halves the angle between d and the direction back to the viewer (-Y).
    normal = d - np.array([0.0, 1.0, 0.0])
    normal /= np.maximum(np.linalg.norm(normal, axis=-1, keepdims=True), 1e-12)
    x = (normal[..., 0] + 1) / 2 * ball.shape[1] - 0.5
    y = (1 - normal[..., 2]) / 2 * ball.shape[0] - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]

    def at(yi, xi):
        return ball[np.clip(yi, 0, ball.shape[0] - 1), np.clip(xi, 0, ball.shape[1] - 1)]

    texels = (at(y0, x0) * (1 - fx) + at(y0, x0 + 1) * fx) * (1 - fy) + (
        at(y0 + 1, x0) * (1 - fx) + at(y0 + 1, x0 + 1) * fx
    ) * fy
    return texels.reshape(h, n, w, n, 3).mean(axis=(1, 3))
