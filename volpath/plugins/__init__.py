"""The scene language's plugins, one module per kind as Mitsuba keeps them: integrators,
sensors, BSDFs, media (with their phase functions), volumes, shapes and emitters. Each
module's ``build(b, d, ...)`` turns one plugin dictionary into the native scene through
the builder ``b`` (builder.py), which holds what they share: the native scene, the ids,
what is built already, the summary."""

KINDS = {
    "integrator": {"volpath", "volpathmis", "path"},
    "sensor": {"perspective", "thinlens"},
    "film": {"hdrfilm"},
    "sampler": {"independent", "stratified", "multijitter", "ldsampler", "orthogonal"},
    "rfilter": {"box", "gaussian", "tent"},
    "shape": {
        *("sphere", "rectangle", "cube", "obj", "ply", "mesh", "shapegroup", "instance"),
        *("disk", "cylinder", "serialized"),
    },
    "bsdf": {
        "null",
        "diffuse",
        "dielectric",
        "thindielectric",
        "roughplastic",
        "plastic",
        "principled",
        "twosided",
        "conductor",
        "roughconductor",
        "roughdielectric",
        "blendbsdf",
        "mask",
        "normalmap",
        "bumpmap",
    },
    "emitter": {"point", "directional", "sun", "constant", "envmap", "area", "spot"},
    "medium": {"homogeneous", "heterogeneous", "atmosphere"},
    "phase": {"isotropic", "hg"},
    "volume": {"gridvolume", "vdbvolume", "constvolume"},
    "texture": {"bitmap", "checkerboard"},
}


def kind_of(d):
    """The plugin kind of an object dict: from the XML tag if known, else from its type."""
    if "__kind__" in d:
        return d["__kind__"]
    t = d.get("type")
    for kind, types in KINDS.items():
        if t in types:
            return kind
    return None
