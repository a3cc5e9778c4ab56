"""BSDF plugins: null, diffuse, (rough, thin) dielectric, (rough) conductor, (rough)
plastic, principled, twosided, and the layers: blendbsdf, mask, normalmap, bumpmap."""

import warnings

import numpy as np

from .. import metals
from ..errors import SceneError, SceneWarning, where
from . import kind_of, textures
from .params import RGB_WAVELENGTHS
from .textures import Textured, value

# Stand-ins for textured colours in the native BSDF as created (every hit replaces them).
GREY, WHITE = (0.5, 0.5, 0.5), (1.0, 1.0, 1.0)

# Named indices of refraction (Mitsuba's table, the common entries).
IOR = {
    "vacuum": 1.0,
    "air": 1.000277,
    "water": 1.3330,
    "water ice": 1.31,
    "fused quartz": 1.458,
    "pyrex": 1.470,
    "acrylic glass": 1.49,
    "polypropylene": 1.49,
    "bk7": 1.5046,
    "sodium chloride": 1.544,
    "amber": 1.55,
    "pet": 1.575,
    "diamond": 2.419,
}


def build(b, d, twosided=False):
    d = b.resolve(d)
    key = (id(d), twosided)
    if key in b.bsdfs:
        return b.bsdfs[key]
    if id(d) in b.building:
        raise SceneError(f"{where(d.get('__loc__'))}cyclic bsdf definition")
    b.building.add(id(d))
    p = b.params(d, "bsdf")
    n = b.native
    if p.type == "twosided":
        inner = [k for k, v in d.items() if isinstance(v, dict) and kind_of(b.resolve(v)) == "bsdf"]
        if len(inner) != 1:
            raise p.error("expected exactly one nested bsdf")
        p.read.add(inner[0])
        index = build(b, d[inner[0]], twosided=True)
    elif p.type in LAYERS:
        index = _layer(b, d, p, twosided)
    elif p.type == "null":
        index = n.add_bsdf_null()
    elif p.type == "diffuse":
        r = textures.param(b, p, "reflectance", 0.5)
        index = n.add_bsdf_diffuse(value(r, GREY), twosided)
        textures.bind(b, index, reflectance=r)
    elif p.type in ("dielectric", "thindielectric"):
        eta = ior(p, "int_ior", 1.5046) / ior(p, "ext_ior", 1.000277)
        if p.type == "dielectric":
            index = n.add_bsdf_dielectric(eta, *_glass_tints(p))
        else:
            p.raw("specular_reflectance"), p.raw("specular_transmittance")
            index = n.add_bsdf_thindielectric(eta)
    elif p.type == "roughdielectric":
        alpha = ggx_alpha(b, p)
        eta = ior(p, "int_ior", 1.5046) / ior(p, "ext_ior", 1.000277)
        index = n.add_bsdf_roughdielectric(eta, value(alpha, 0.1), *_glass_tints(p))
        textures.bind(b, index, alpha=alpha)
    elif p.type in ("conductor", "roughconductor"):
        eta, k = _conductor_index(b, p)
        ext = ior(p, "ext_eta", 1.000277) if p.has("ext_eta") else 1.000277
        alpha = ggx_alpha(b, p) if p.type == "roughconductor" else 0.0
        specular = textures.param(b, p, "specular_reflectance", 1.0)
        index = n.add_bsdf_conductor(eta / ext, k / ext, value(specular, WHITE), value(alpha, 0.1), twosided)
        textures.bind(b, index, specular=specular, alpha=alpha)
    elif p.type in ("roughplastic", "plastic"):
        dist = p.str("distribution", "ggx", ("ggx", "beckmann"))
        if dist != "ggx":
            raise p.error("only the 'ggx' distribution is supported")
        alpha = roughness(b, p, "alpha", 0.1 if p.type == "roughplastic" else 0.001)
        eta = ior(p, "int_ior", 1.49) / ior(p, "ext_ior", 1.000277)
        p.raw("nonlinear"), p.raw("sample_visible")
        diffuse = textures.param(b, p, "diffuse_reflectance", 0.5)
        specular = textures.param(b, p, "specular_reflectance", 1.0)
        index = n.add_bsdf_roughplastic(value(diffuse, GREY), value(specular, WHITE), value(alpha, 0.1), eta, twosided)
        textures.bind(b, index, reflectance=diffuse, specular=specular, alpha=alpha)
    elif p.type == "principled":
        index = _principled(b, p, twosided)
    else:
        raise p.error(
            "unknown bsdf (expected one of: null, diffuse, dielectric, thindielectric, roughdielectric, conductor, "
            "roughconductor, plastic, roughplastic, principled, twosided, blendbsdf, mask, normalmap, bumpmap)"
        )
    p.check()
    b.building.discard(id(d))
    b.bsdfs[key] = index
    if p.type != "twosided":  # the sided one it wraps is listed
        b.summary["bsdfs"].append({"type": p.type, "twosided": twosided, "id": d.get("__id__"), "loc": p.loc})
    return index


def _principled(b, p, twosided):
    """Mitsuba's principled as a mixture, by metallic, of a rough plastic (the base colour
    under a GGX coat of index eta) and a metal whose normal-incidence reflectance is the
    base colour (a conductor of eta 1 and k = 2 sqrt(F0 / (1 - F0)), its Fresnel rising to
    white at grazing angles; a textured base colour tints a mirror instead). Both take
    alpha = roughness^2."""
    base = textures.param(b, p, "base_color", 0.5)
    metallic = _unit_param(b, p, "metallic", 0.0)
    rough = textures.param(b, p, "roughness", 0.5)
    eta = p.float("eta", 1.5, positive=True)
    for ignored in (
        "specular",
        "spec_tint",
        "anisotropic",
        "sheen",
        "sheen_tint",
        "clearcoat",
        "clearcoat_gloss",
        "spec_trans",
        "flatness",
    ):
        p.raw(ignored)
    alpha = rough._replace(squared=True) if isinstance(rough, Textured) else max(float(rough[0]) ** 2, 1e-3)
    n = b.native

    def plastic():
        index = n.add_bsdf_roughplastic(value(base, GREY), WHITE, value(alpha, 0.1), eta, twosided)
        textures.bind(b, index, reflectance=base, alpha=alpha)
        return index

    def metal():
        if isinstance(base, Textured):
            index = n.add_bsdf_conductor(np.zeros(3), np.zeros(3), WHITE, value(alpha, 0.1), twosided)
            textures.bind(b, index, specular=base, alpha=alpha)
            return index
        f0 = np.clip(base, 0.0, 0.999)
        index = n.add_bsdf_conductor(np.ones_like(f0), 2 * np.sqrt(f0 / (1 - f0)), WHITE, value(alpha, 0.1), twosided)
        textures.bind(b, index, alpha=alpha)
        return index

    if metallic == 0:
        return plastic()
    if metallic == 1:
        return metal()
    index = n.add_bsdf_blend(plastic(), metal(), value(metallic, 0.5))
    textures.bind(b, index, weight=metallic)
    return index


LAYERS = ("blendbsdf", "mask", "normalmap", "bumpmap")


def _layer(b, d, p, twosided):
    """A BSDF made of nested ones (built first, with the same sidedness): blendbsdf (two,
    weight 0 gives the first), mask (one, an opacity), normalmap and bumpmap (one, and a
    texture: `normalmap`'s tangent-space normals, raw; bumpmap's heights times `scale`)."""
    nested = [k for k, v in d.items() if isinstance(v, dict) and kind_of(b.resolve(v)) == "bsdf"]
    expected = 2 if p.type == "blendbsdf" else 1
    if len(nested) != expected:
        raise p.error(f"expected exactly {expected} nested bsdf{'s' if expected > 1 else ''}, found {len(nested)}")
    for k in nested:
        p.read.add(k)
    inner = [build(b, d[k], twosided) for k in nested]
    n = b.native
    if p.type == "blendbsdf":
        weight = _unit_param(b, p, "weight", 0.5)
        index = n.add_bsdf_blend(inner[0], inner[1], value(weight, 0.5))
        textures.bind(b, index, weight=weight)
    elif p.type == "mask":
        opacity = _unit_param(b, p, "opacity", 0.5)
        index = n.add_bsdf_mask(inner[0], value(opacity, 0.5))
        textures.bind(b, index, opacity=opacity)
    else:
        name = "normalmap" if p.type == "normalmap" else None
        found = [k for k, v in d.items() if isinstance(v, dict) and kind_of(b.resolve(v)) == "texture"]
        if name is not None and name not in found:
            raise p.error("expected a texture named 'normalmap'")
        if name is None and len(found) != 1:
            raise p.error(f"expected exactly one nested texture (the heights), found {len(found)}")
        key = name or found[0]
        p.read.add(key)
        texture = textures.build(b, d[key])
        if p.type == "normalmap":
            index = n.add_bsdf_normalmap(inner[0], texture, p.float("strength", 1.0, minimum=0.0))
        else:
            index = n.add_bsdf_bumpmap(inner[0], texture, p.float("scale", 1.0), p.float("strength", 1.0, minimum=0.0))
    return index


def _unit_param(b, p, name, default):
    """A weight or opacity: a float in [0, 1], or a Textured (its channels' mean)."""
    v = p.raw(name, default)
    if isinstance(v, dict) and kind_of(b.resolve(v)) == "texture":
        return Textured(textures.build(b, v))
    return p.float(name, default, minimum=0.0, maximum=1.0)


def ggx_alpha(b, p):
    """A microfacet BSDF's GGX alpha (a float or a Textured): isotropic `alpha`, or equal
    `alpha_u` and `alpha_v`. Mitsuba's default distribution is Beckmann's; GGX stands in
    for it (close at small roughness, with longer tails), with a warning."""
    if p.str("distribution", "beckmann", ("ggx", "beckmann")) == "beckmann":
        warnings.warn(
            SceneWarning(f"{where(p.loc)}bsdf '{p.type}': the GGX distribution stands in for Beckmann's"),
            stacklevel=3,
        )
    p.raw("sample_visible")
    if p.has("alpha_u") or p.has("alpha_v"):
        if p.float("alpha_u", 0.1) != p.float("alpha_v", 0.1):
            raise p.error("anisotropic roughness (alpha_u != alpha_v) is not supported")
        return roughness(b, p, "alpha_u", 0.1)
    return roughness(b, p, "alpha", 0.1)


def roughness(b, p, name, default):
    """A GGX alpha: a float, at least 1e-3, or a Textured."""
    v = p.raw(name, default)
    if isinstance(v, dict) and kind_of(b.resolve(v)) == "texture":
        return Textured(textures.build(b, v))
    return max(p.float(name, default, minimum=0.0), 1e-3)


def _glass_tints(p):
    """A dielectric's specular_reflectance and specular_transmittance (1: none)."""
    return tuple(p.rgb("specular_reflectance", 1.0)), tuple(p.rgb("specular_transmittance", 1.0))


def _conductor_index(b, p):
    """A conductor's (eta, k): a named metal's, measured, at the pass's wavelengths (in RGB,
    at the wavelengths RGB values stand for), or given as `eta` and `k`; "none" is a
    perfect mirror."""
    material = p.str("material", "none")
    if material == "none":
        return p.rgb("eta", 0.0), p.rgb("k", 0.0)
    if p.has("eta") or p.has("k"):
        raise p.error("give either 'material' or 'eta' and 'k', not both")
    index = metals.eta_k(material, RGB_WAVELENGTHS if b.wavelengths is None else b.wavelengths)
    if index is None:
        raise p.error(f"unknown conductor material '{material}' (expected none or one of: {', '.join(metals.names())})")
    return index


def ior(p, name, default):
    v = p.raw(name, default)
    if isinstance(v, str):
        if v.lower() not in IOR:
            raise p.error(f"unknown material '{v}' for '{name}' (expected a number or one of: {', '.join(IOR)})")
        return IOR[v.lower()]
    return p.float(name, default, positive=True)


def default(b):
    key = ("default", False)
    if key not in b.bsdfs:
        b.bsdfs[key] = b.native.add_bsdf_diffuse((0.5, 0.5, 0.5), False)
    return b.bsdfs[key]
