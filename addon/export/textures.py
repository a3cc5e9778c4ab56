"""Image Texture nodes to bitmaps: the image (its file, or its pixels when it has none on
disk; its alpha channel, from the Alpha output), how it is sampled, and the UV Map and
Mapping nodes in front of it.

Blender's UVs have v = 0 at an image's bottom row, the scene format's at its top: meshes.py
flips the UVs, and a Mapping node's matrix is conjugated by that flip here."""

import os

import numpy as np

# Files the loader reads itself (Pillow, or OpenEXR); others are exported as pixels.
_READABLE = {".png", ".jpg", ".jpeg", ".exr", ".bmp", ".tga", ".tif", ".tiff"}
_LINEAR = {"Non-Color", "Linear Rec.709", "Linear CIE-XYZ E", "Linear Rec.2020", "Raw", "Linear"}
_WRAP = {"REPEAT": "repeat", "EXTEND": "clamp", "MIRROR": "mirror", "CLIP": "clamp"}
_FLIP_V = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 1.0], [0.0, 0.0, 1.0]])


class Images:
    """The bitmaps of one material's Image Texture nodes, and the UV map they read."""

    def __init__(self, owner, report):
        self.owner, self.report = owner, report
        self.uv_map = None  # None: no texture; "": the mesh's render UV map; else a name
        self._bitmaps = {}

    def bitmap(self, link, what):
        """The bitmap dictionary for the node a link comes from (its colour or its alpha), or
        None when it is not an Image Texture (the caller reports the input as unsupported)."""
        node, output = link.from_node, link.from_socket.name
        if node.bl_idname != "ShaderNodeTexImage" or output not in ("Color", "Alpha"):
            return None
        if node.image is None:
            self.report.warn(f"{self.owner}: image texture '{node.name}' has no image; using {what}'s value")
            return None
        key = (node.name, output)
        if key not in self._bitmaps:
            d = _image(node.image, self.owner, self.report) if output == "Color" else _alpha(node.image, self.owner)
            if node.projection != "FLAT":
                self.report.warn(f"{self.owner}: '{node.name}' uses {node.projection} projection; read as FLAT")
            if node.interpolation in ("Cubic", "Smart"):
                self.report.warn(f"{self.owner}: '{node.name}' is interpolated linearly, not {node.interpolation}")
            if node.extension == "CLIP":
                self.report.warn(f"{self.owner}: '{node.name}' clips to black in Cycles; Volpath extends its edge")
            d["filter_type"] = "nearest" if node.interpolation == "Closest" else "bilinear"
            d["wrap_mode"] = _WRAP[node.extension]
            uv_map, to_uv = self._coordinates(node)
            if not np.allclose(to_uv, np.eye(3)):
                d["to_uv"] = to_uv
            if self.uv_map is not None and uv_map != self.uv_map:
                self.report.warn(f"{self.owner}: textures read different UV maps; all read '{self.uv_map}'")
            elif self.uv_map is None:
                self.uv_map = uv_map
            self._bitmaps[key] = d
        return self._bitmaps[key]

    def _coordinates(self, node):
        """(UV map name, "" for the render one; the scene's 3x3 to_uv) of an image's Vector
        input: unlinked, a UV Map or Texture Coordinate's UV, through Mapping nodes."""
        m, socket, uv_map = np.eye(3), node.inputs["Vector"], ""
        while socket.is_linked:
            link = socket.links[0]
            source = link.from_node
            if source.bl_idname == "ShaderNodeMapping":
                m = m @ _mapping(source, self.owner, self.report)
                socket = source.inputs["Vector"]
            elif source.bl_idname == "ShaderNodeUVMap":
                uv_map = source.uv_map
                break
            elif source.bl_idname == "ShaderNodeTexCoord" and link.from_socket.name == "UV":
                break
            else:
                self.report.warn(
                    f"{self.owner}: '{node.name}' reads coordinates from '{source.name}' ({source.bl_label}); "
                    "using the UV map"
                )
                break
        return uv_map, _FLIP_V @ m @ _FLIP_V


def _mapping_matrix(node, owner, report):
    """A Mapping node's map as a 4x4 affine matrix: Point and Texture (its inverse) with
    their Location, Vector without; Normal is reported and ignored."""
    from mathutils import Euler, Matrix

    def value(name):
        socket = node.inputs[name]
        if socket.is_linked:
            report.warn(f"{owner}: '{name}' of '{node.name}' is driven by nodes; using its value")
        return socket.default_value

    kind = node.vector_type
    if kind == "NORMAL":
        report.warn(f"{owner}: mapping '{node.name}' of type Normal is ignored")
        return np.eye(4)
    location = value("Location") if kind in ("POINT", "TEXTURE") else (0, 0, 0)
    m = Matrix.LocRotScale(location, Euler(value("Rotation"), "XYZ"), value("Scale"))
    if kind == "TEXTURE":
        m = m.inverted_safe()
    return np.array(m, dtype=np.float64)


def _mapping(node, owner, report):
    """A Mapping node's map of (u, v) as a 3x3 affine matrix (in Blender's UV frame)."""
    # The UV's third coordinate is 0: only x and y and the translation act on (u, v).
    return _mapping_matrix(node, owner, report)[np.ix_([0, 1, 3], [0, 1, 3])]


def _image(image, owner, report):
    """A bitmap dictionary without its sampling: the file if the loader can read it as
    Blender does, otherwise the pixels."""
    colorspace = image.colorspace_settings.name
    raw = colorspace in _LINEAR
    if not raw and colorspace != "sRGB":
        report.warn(f"{owner}: image '{image.name}' is in '{colorspace}'; read as sRGB")
    path = os.path.abspath(_bpy_path(image)) if image.source == "FILE" and image.filepath else ""
    if (
        path
        and image.packed_file is None
        and not image.is_dirty
        and os.path.splitext(path)[1].lower() in _READABLE
        and os.path.isfile(path)
    ):
        d = {"type": "bitmap", "filename": path}
        if raw and not path.lower().endswith(".exr"):
            d["raw"] = True
        return d
    # A byte image's pixels are its bytes / 255, a float image's are scene linear.
    texels = _pixels(image, owner)[:, :, :3]
    if image.is_float:
        return {"type": "bitmap", "data": np.ascontiguousarray(texels)}
    d = {"type": "bitmap", "data": np.ascontiguousarray(np.round(np.clip(texels, 0, 1) * 255).astype(np.uint8))}
    if raw:
        d["raw"] = True
    return d


def _pixels(image, owner):
    """An image's RGBA pixels (h, w, 4), rows top first."""
    w, h = image.size  # loads the image if it can
    if w == 0 or h == 0:
        raise _export_error(f"{owner}: image '{image.name}' has no pixels (is its file missing?)")
    pixels = np.empty(w * h * 4, np.float32)
    image.pixels.foreach_get(pixels)
    return pixels.reshape(h, w, 4)[::-1]  # Blender's rows start at the bottom


def _alpha(image, owner):
    """The image's alpha channel as a raw one-channel bitmap (8-bit for byte images)."""
    alpha = np.ascontiguousarray(_pixels(image, owner)[:, :, 3:])
    if image.is_float:
        return {"type": "bitmap", "data": alpha}
    return {"type": "bitmap", "data": np.round(np.clip(alpha, 0, 1) * 255).astype(np.uint8), "raw": True}


def _bpy_path(image):
    import bpy

    return bpy.path.abspath(image.filepath, library=image.library)


def _export_error(message):
    from . import ExportError

    return ExportError(message)
