"""Shader node trees to BSDFs, area emitters and media.

What maps (in Blender's radiometry, as Cycles renders it; lights.py gives the lights'):
  Principled BSDF   -> principled (base colour, metallic, roughness; IOR and Specular IOR
                       Level give the coat's F0), diffuse when F0 and metallic are 0, or,
                       with transmission, glass; emission colour x strength -> area emitter
  Diffuse / Glass / Emission -> diffuse / dielectric / area emitter on a black diffuse
  Principled Volume -> sigma_s = density colour, sigma_a = density (1 - colour)(1 - sqrt(absorption
                       colour)) (the square root as Cycles' images show it: bench/parity.py);
                       emission E (per unit length) -> Le = E / sigma_a; blackbody -> Le = intensity x
                       Planck radiance at the temperature (times the temperature grid, for volumes)
  Volume Scatter    -> sigma_s = density colour;  Volume Absorption -> sigma_a = density (1 - colour)
  Mix Shader       -> blendbsdf (Fac a number or texture); Transparent BSDF -> null
  Principled Alpha -> mask; Metallic (a number or texture) -> principled's mixture of
                       plastic and a metal of F0 = base colour (volpath/plugins/bsdfs.py)
  Glass and Transmission -> dielectric, roughdielectric where rough
  Normal Map (tangent) and Bump -> normalmap and bumpmap around the BSDF
Textures (textures.py): Image Texture nodes, through UV Map and Mapping nodes, on the Base
Color, Roughness, Metallic and Alpha (an image's Alpha output) of a Principled BSDF, the
Color of a Diffuse BSDF, a Mix Shader's Fac, a Normal Map's Color and a Bump's Height.
Everything else (other nodes plugged into inputs, other shaders) is reported as a warning
and replaced by the input's default value, never ignored silently.
"""

import math
from typing import NamedTuple

import numpy as np

from . import convert, textures

DEFAULT_SURFACE = {"type": "diffuse", "reflectance": convert.rgb((0.8, 0.8, 0.8))}


class EmissionMap(NamedTuple):
    """Emission whose colour is an image: the bitmap times `scale` (rgb)."""

    bitmap: dict
    scale: np.ndarray


def emitter(radiance):
    """The area emitter of a material's radiance (an rgb or an EmissionMap)."""
    if isinstance(radiance, EmissionMap):
        return {"type": "area", "radiance": radiance.bitmap, "scale": convert.rgb(radiance.scale)}
    return {"type": "area", "radiance": convert.rgb(radiance)}


class Material(NamedTuple):
    bsdf: dict
    radiance: object  # emitted radiance (rgb, or an EmissionMap) or None
    medium: dict | None  # the volume's description (sigma_a, sigma_s, g, ...)
    uv_map: str | None  # the UV map its textures read ("" for the render one), None if none


class _Inputs:
    """A node's input values, reporting inputs driven by links that are not supported."""

    def __init__(self, node, owner, report, images=None):
        self.node, self.owner, self.report = node, owner, report
        self.images = images

    def texture(self, name):
        """The bitmap an input is linked to (a scene dictionary), or its value."""
        socket = self.node.inputs[name]
        if self.images is not None and socket.is_linked:
            bitmap = self.images.bitmap(socket.links[0], f"'{name}' of '{self.node.name}'")
            if bitmap is not None:
                return bitmap
        return self(name)

    def __call__(self, name):
        socket = self.node.inputs[name]
        if socket.is_linked:
            self.report.warn(
                f"{self.owner}: '{name}' of '{self.node.name}' is driven by nodes; "
                f"using its value {_show(socket.default_value)}"
            )
        v = socket.default_value
        return np.array(v[:3], dtype=np.float64) if hasattr(v, "__len__") else float(v)


def _show(v):
    return f"({', '.join(f'{c:.3g}' for c in v[:3])})" if hasattr(v, "__len__") else f"{v:.3g}"


def output(tree, kind="ShaderNodeOutputMaterial"):
    """A node tree's active output node of `kind` (a material's, a world's or a lamp's; the
    first where none is marked active), or None."""
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.bl_idname == kind]
    active = [n for n in outputs if n.is_active_output] or outputs
    return active[0] if active else None


def linked(node, socket):
    """The node plugged into `node`'s input `socket`, or None."""
    s = node.inputs[socket]
    return s.links[0].from_node if s.is_linked else None


def export(material, report):
    """The Material of a material slot."""
    if material is None:
        return Material(DEFAULT_SURFACE, None, None, None)
    owner = f"material '{material.name}'"
    out = output(material.node_tree)
    if out is None:
        return Material({"type": "diffuse", "reflectance": convert.rgb(material.diffuse_color[:3])}, None, None, None)
    surface = linked(out, "Surface")
    volume = linked(out, "Volume")
    medium = _volume(volume, owner, report) if volume is not None else None
    images = textures.Images(owner, report)
    if surface is None:
        bsdf, radiance = (
            ({"type": "null"} if medium is not None else {"type": "diffuse", "reflectance": convert.rgb((0, 0, 0))}),
            None,
        )
    else:
        bsdf, radiance = _surface(surface, owner, report, images)
    return Material(bsdf, radiance, medium, images.uv_map)


def _colour(v):
    """A colour input's value for the scene: a bitmap as it is, an RGB clamped to [0, 1]."""
    return v if isinstance(v, dict) else convert.rgb(np.clip(v, 0, 1))


def _surface(node, owner, report, images):
    """(bsdf dict, emitted radiance or None) of the shader node plugged into Surface."""
    kind = node.bl_idname
    if kind == "ShaderNodeMixShader":
        return _mix(node, owner, report, images)
    if kind == "ShaderNodeBsdfTransparent":
        if np.ptp(node.inputs["Color"].default_value[:3]) > 1e-6 or node.inputs["Color"].default_value[0] < 1:
            report.warn(f"{owner}: a tinted Transparent BSDF is not supported; it lets all light through")
        return {"type": "null"}, None
    get = _Inputs(node, owner, report, images)
    radiance = None
    if kind == "ShaderNodeBsdfPrincipled":
        bsdf, radiance = _principled(get, owner, report)
    elif kind == "ShaderNodeBsdfDiffuse":
        bsdf = {"type": "diffuse", "reflectance": _colour(get.texture("Color"))}
    elif kind == "ShaderNodeBsdfGlass":
        colour = get("Color")  # Cycles' glass colour tints both lobes
        bsdf = _glass(get("IOR"), get("Roughness"), reflectance=colour, transmittance=colour)
    elif kind == "ShaderNodeEmission":
        return {"type": "diffuse", "reflectance": convert.rgb((0, 0, 0))}, _emission(get, "Color", "Strength")
    else:
        report.warn(f"{owner}: surface node '{node.name}' ({node.bl_label}) is not supported; using a grey diffuse")
        return DEFAULT_SURFACE, None
    bsdf = _perturbed(node, bsdf, owner, report, images)
    if kind == "ShaderNodeBsdfPrincipled":
        alpha = get.texture("Alpha")
        if isinstance(alpha, dict) or alpha < 1:
            opacity = alpha if isinstance(alpha, dict) else float(np.clip(alpha, 0, 1))
            bsdf = {"type": "mask", "opacity": opacity, "surface": bsdf}
    return bsdf, radiance


def _emission(get, colour, strength):
    """Colour x strength: an rgb, or an EmissionMap where an image gives the colour; None
    where nothing is emitted."""
    c, k = get.texture(colour), get(strength)
    if isinstance(c, dict):
        return EmissionMap(c, np.full(3, float(k))) if k > 0 else None
    return c * k if np.any(c * k > 0) else None


def _principled(get, owner, report):
    radiance = _emission(get, "Emission Color", "Emission Strength")
    for name in ("Coat Weight", "Sheen Weight", "Subsurface Weight"):
        if get(name) > 0:
            report.warn(f"{owner}: '{name}' is not supported (ignored)")
    if get("Transmission Weight") >= 0.5:
        # Cycles tints the transmitted light by the base colour.
        return _glass(get("IOR"), get("Roughness"), transmittance=get("Base Color")), radiance
    base, metallic, rough = get.texture("Base Color"), get.texture("Metallic"), get.texture("Roughness")
    if not isinstance(metallic, dict):
        metallic = float(np.clip(metallic, 0, 1))
    # Specular IOR Level scales the coat's normal-incidence reflectance F0 (0.5: as the IOR says).
    ior = max(get("IOR"), 1.0)
    f0 = ((ior - 1) / (ior + 1)) ** 2 * 2 * max(get("Specular IOR Level"), 0.0)
    if f0 < 1e-4 and metallic == 0:
        return {"type": "diffuse", "reflectance": _colour(base)}, radiance
    eta = (1 + math.sqrt(min(f0, 0.9))) / (1 - math.sqrt(min(f0, 0.9)))
    return {
        "type": "principled",
        "base_color": _colour(base),
        "metallic": metallic,
        "roughness": rough if isinstance(rough, dict) else float(np.clip(rough, 0, 1)),
        "eta": max(eta, 1.0001),
    }, radiance


def _glass(ior, roughness, reflectance=None, transmittance=None):
    """Glass (or full transmission): smooth, or GGX with alpha = roughness^2; tinted."""
    d = {"type": "dielectric", "int_ior": max(ior, 1.0001), "ext_ior": 1.0}
    if reflectance is not None and np.any(np.abs(reflectance - 1) > 1e-6):
        d["specular_reflectance"] = convert.rgb(np.clip(reflectance, 0, 1))
    if transmittance is not None and np.any(np.abs(transmittance - 1) > 1e-6):
        # The square root per interface, so that light through a body (in and out) takes
        # the colour once, as Cycles' images show (bench/parity.py).
        d["specular_transmittance"] = convert.rgb(np.sqrt(np.clip(transmittance, 0, 1)))
    if roughness**2 >= 1e-3:
        d.update(type="roughdielectric", distribution="ggx", alpha=float(roughness) ** 2)
    return d


def _mix(node, owner, report, images):
    """Mix Shader: (1 - Fac) x the first + Fac x the second, as a blendbsdf."""
    get = _Inputs(node, owner, report, images)
    parts = []
    for socket in (node.inputs[1], node.inputs[2]):
        if socket.is_linked:
            parts.append(_surface(socket.links[0].from_node, owner, report, images))
        else:
            report.warn(f"{owner}: an empty shader input of '{node.name}' is read as a grey diffuse")
            parts.append((DEFAULT_SURFACE, None))
    fac = get.texture("Fac")
    (a, ra), (b, rb) = parts
    radiance = None
    if ra is not None or rb is not None:
        maps = [r for r in (ra, rb) if isinstance(r, EmissionMap)]
        if isinstance(fac, dict):
            report.warn(f"{owner}: emission mixed by a texture is not supported (none emitted)")
        elif maps and (ra is not None and rb is not None):
            report.warn(f"{owner}: an emission map mixed with other emission is not supported (the map alone)")
            radiance = maps[0]
        elif maps:
            radiance = maps[0]._replace(scale=maps[0].scale * (1 - fac if ra is not None else fac))
        else:
            zero = np.zeros(3)
            radiance = (1 - fac) * (zero if ra is None else ra) + fac * (zero if rb is None else rb)
    weight = fac if isinstance(fac, dict) else float(np.clip(fac, 0, 1))
    return {"type": "blendbsdf", "weight": weight, "first": a, "second": b}, radiance


def _perturbed(node, bsdf, owner, report, images):
    """The BSDF under a Normal Map or Bump node plugged into the shader's Normal input
    (a Bump's own Normal input may take a Normal Map in turn)."""
    socket = node.inputs.get("Normal")
    if socket is None or not socket.is_linked:
        return bsdf
    source = socket.links[0].from_node
    if source.bl_idname == "ShaderNodeBump":
        get = _Inputs(source, owner, report, images)
        height = source.inputs["Height"]
        heights = images.bitmap(height.links[0], f"'Height' of '{source.name}'") if height.is_linked else None
        inner = _perturbed(source, bsdf, owner, report, images)
        if heights is None:
            report.warn(f"{owner}: bump '{source.name}' needs an Image Texture as its Height; ignored")
            return inner
        scale = get("Distance") * (-1 if source.invert else 1)
        return {"type": "bumpmap", "heights": heights, "scale": scale, "strength": get("Strength"), "surface": inner}
    if source.bl_idname == "ShaderNodeNormalMap":
        get = _Inputs(source, owner, report, images)
        color = source.inputs["Color"]
        normals = images.bitmap(color.links[0], f"'Color' of '{source.name}'") if color.is_linked else None
        if source.space != "TANGENT" or normals is None:
            report.warn(f"{owner}: normal map '{source.name}' needs tangent space and an Image Texture; ignored")
            return bsdf
        return {"type": "normalmap", "normalmap": normals, "strength": get("Strength"), "surface": bsdf}
    report.warn(f"{owner}: the Normal input of '{node.name}' is driven by '{source.name}'; ignored")
    return bsdf


def _volume(node, owner, report):
    """A medium description: sigma_a, sigma_s (per scene unit, before any density grid), g,
    and the name of the density attribute (volume objects)."""
    get = _Inputs(node, owner, report)
    kind = node.bl_idname
    if kind == "ShaderNodeVolumePrincipled":
        density, color = get("Density"), np.clip(get("Color"), 0, 1)
        sigma_s = density * color
        sigma_a = density * (1 - color) * np.clip(1 - np.sqrt(np.clip(get("Absorption Color"), 0, None)), 0, 1)
        tint = get("Blackbody Tint")
        if np.ptp(tint) > 1e-6:
            report.warn(f"{owner}: a coloured Blackbody Tint is not supported; using its mean")
        return {
            "sigma_a": sigma_a,
            "sigma_s": sigma_s,
            "g": get("Anisotropy"),
            "attribute": node.inputs["Density Attribute"].default_value or "density",
            "emission": get("Emission Color") * get("Emission Strength"),
            "blackbody": get("Blackbody Intensity") * float(np.mean(tint)),
            "temperature": get("Temperature"),
            "temperature_attribute": node.inputs["Temperature Attribute"].default_value or "temperature",
        }
    if kind == "ShaderNodeVolumeScatter":
        return {
            "sigma_a": np.zeros(3),
            "sigma_s": get("Density") * np.clip(get("Color"), 0, 1),
            "g": get("Anisotropy"),
            "attribute": "density",
        }
    if kind == "ShaderNodeVolumeAbsorption":
        return {
            "sigma_a": get("Density") * (1 - np.clip(get("Color"), 0, 1)),
            "sigma_s": np.zeros(3),
            "g": 0.0,
            "attribute": "density",
        }
    report.warn(f"{owner}: volume node '{node.name}' ({node.bl_label}) is not supported (no medium)")
    return None


def emitted_radiance(medium, sigma_a, temperature, report, owner):
    """Volpath's Le (the medium emits sigma_a Le) for Blender's emission coefficient
    E = Emission Colour x Strength (emitted per unit length: Le = E / sigma_a) plus
    blackbody emission at `temperature` (Le = Blackbody Intensity x the Planck radiance,
    Kirchhoff's law). Broadcasts over grids; 0 where nothing absorbs, reported."""
    from volpath.blackbody import blackbody_rgb

    E = np.asarray(medium.get("emission", np.zeros(3)), dtype=np.float64)
    sigma_a = np.asarray(sigma_a, dtype=np.float64)
    Le = np.divide(E, sigma_a, out=np.zeros(np.broadcast(E, sigma_a).shape), where=sigma_a > 0)
    if np.any(E > 0) and np.any((sigma_a <= 0) & (E > 0)):
        report.warn(f"{owner}: emission where nothing absorbs is not rendered (Volpath media emit sigma_a x Le)")
    if medium.get("blackbody", 0) > 0:
        Le = Le + medium["blackbody"] * blackbody_rgb(temperature)
    return Le


def homogeneous(medium, report, owner):
    """The homogeneous medium of a mesh's volume material (coefficients per Blender unit,
    which is the scene unit)."""
    d = {
        "type": "homogeneous",
        "sigma_a": convert.rgb(medium["sigma_a"]),
        "sigma_s": convert.rgb(medium["sigma_s"]),
        "phase": {"type": "hg", "g": float(np.clip(medium["g"], -0.99, 0.99))},
    }
    Le = emitted_radiance(medium, medium["sigma_a"], medium.get("temperature", 0.0), report, owner)
    if np.any(Le > 0):
        d["radiance"] = convert.rgb(Le)
    return d
