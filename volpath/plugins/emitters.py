"""Emitter plugins: point, spot, directional, sun, constant and envmap (area emitters belong
to their shapes)."""

import math

import numpy as np

from .params import spectral_colour
from .shapes import light_hidden_from


def build(b, d, key=None):
    """Adds the emitter, or replaces the light that was built under the same top-level
    ``key`` (Scene.update)."""
    p = b.params(d, "emitter")
    n = b.native
    info = {"type": p.type, "loc": p.loc}
    replace, position = b.lights.get(key, (-1, len(b.summary["emitters"])))
    index = None
    if p.type == "point":
        if p.has("position"):
            pos = p.vec3("position")
        else:
            pos = p.transform()[:3, 3]
        intensity = p.rgb("intensity", 1.0, emitted=True)
        index = n.add_point_light(tuple(pos), tuple(intensity), replace, light_hidden_from(p))
        info.update(position=pos.tolist(), intensity=intensity.tolist())
    elif p.type == "spot":
        to_world = p.transform()
        pos = p.vec3("position") if p.has("position") else to_world[:3, 3]
        direction, half_angle, blend = spot_cone(p, to_world[:3, :3] @ np.array([0.0, 0.0, 1.0]))
        intensity = p.rgb("intensity", 1.0, emitted=True)
        index = n.add_spot_light(
            tuple(pos), tuple(direction), half_angle, blend, tuple(intensity), replace, light_hidden_from(p)
        )
        info.update(position=pos.tolist(), direction=direction.tolist(), intensity=intensity.tolist())
    elif p.type == "directional":
        if p.has("direction"):
            direction = p.vec3("direction")
        else:
            direction = p.transform()[:3, :3] @ np.array([0.0, 0.0, 1.0])
        if np.linalg.norm(direction) == 0:
            raise p.error("'direction' must not be zero")
        irradiance = p.rgb("irradiance", 1.0, emitted=True)
        index = n.add_directional_light(tuple(direction), tuple(irradiance), replace, light_hidden_from(p))
        info.update(direction=(direction / np.linalg.norm(direction)).tolist(), irradiance=irradiance.tolist())
    elif p.type == "constant":
        radiance = p.rgb("radiance", 1.0, emitted=True)
        index = n.add_environment(tuple(radiance), None, np.eye(4), np.eye(4), replace, light_hidden_from(p))
        info.update(radiance=radiance.tolist())
    elif p.type == "envmap":
        path, image = _envmap_image(b, p)
        if not np.all(np.isfinite(image)) or image.min() < 0:
            raise p.error(f"{path}: the environment map has negative or non-finite pixels")
        scale = p.float("scale", 1.0, minimum=0.0)
        to_world = p.transform()
        if b.wavelengths is not None:
            image = spectral_colour(image, b.wavelengths, emitted=True).astype(np.float32)
        index = n.add_environment(
            (scale, scale, scale), image, to_world, np.linalg.inv(to_world), replace, light_hidden_from(p)
        )
        info.update(filename=path, resolution=list(image.shape[1::-1]))
    elif p.type == "sun":
        if p.has("direction"):
            direction = p.vec3("direction")
            if np.linalg.norm(direction) == 0:
                raise p.error("'direction' must not be zero")
            to_sun = -direction / np.linalg.norm(direction)
        else:
            # Y is up; azimuth turns from -z towards +x.
            elevation = math.radians(p.float("elevation", 30.0))
            a = math.radians(p.float("azimuth", 0.0))
            to_sun = np.array(
                [math.cos(elevation) * math.sin(a), math.sin(elevation), -math.cos(elevation) * math.cos(a)]
            )
        radius = p.float("angular_radius", 0.004675, positive=True)
        if radius >= 0.5:
            raise p.error("'angular_radius' must be below 0.5 rad")
        irradiance = p.rgb("irradiance", 1.0, emitted=True)
        index = n.add_sun(tuple(to_sun), radius, tuple(irradiance), replace, light_hidden_from(p))
        info.update(to_sun=to_sun.tolist(), angular_radius=radius, irradiance=irradiance.tolist())
    elif p.type == "area":
        raise p.error("an area emitter must be nested inside a shape")
    else:
        raise p.error("unknown emitter (expected one of: point, spot, directional, sun, constant, envmap, area)")
    p.raw("sampling_weight")
    p.check()
    b.summary["emitters"][position : position + 1] = [info]
    if key is not None and index is not None:
        b.lights[key] = (index, position)


def spot_cone(p, axis):
    """(direction, half-angle in radians, blend) of a spot: Mitsuba's `cutoff_angle` (the
    half-angle in degrees, default 20) about `direction` (else `axis`, if given), and
    Volpath's `blend`, Blender's Spot Blend (the cone's outer share that fades, default 0)."""
    direction = p.vec3("direction", axis)
    if np.linalg.norm(direction) == 0:
        raise p.error("'direction' must not be zero")
    cutoff = p.float("cutoff_angle", 20.0, positive=True, maximum=90.0)
    blend = p.float("blend", 0.0, minimum=0.0, maximum=1.0)
    return direction / np.linalg.norm(direction), math.radians(cutoff), blend


def _envmap_image(b, p):
    """(where it came from, (h, w, 3) float32 linear RGB) of an envmap: its OpenEXR file, or
    Volpath's `data`, the texels of a dictionary (the Blender exporter's worlds)."""
    if p.has("data"):
        image = np.asarray(p.raw("data"), dtype=np.float32)
        if image.ndim != 3 or image.shape[2] != 3 or min(image.shape[:2]) < 1:
            raise p.error(f"'data' must be an (h, w, 3) array, got shape {image.shape}")
        return "<data>", image
    from ..exr import read_exr

    path = b.path(p, "filename")
    if not path.lower().endswith(".exr"):
        raise p.error("environment maps must be OpenEXR files")
    try:
        return path, read_exr(path)
    except ValueError as e:
        raise p.error(str(e)) from None
