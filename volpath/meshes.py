"""Triangle meshes from Wavefront OBJ and PLY (ASCII and binary) files, as numpy arrays."""

import os
from typing import NamedTuple

import numpy as np

from . import _core
from .errors import SceneError


class Mesh(NamedTuple):
    positions: np.ndarray  # (n, 3) float64
    triangles: np.ndarray  # (m, 3) uint32
    normals: np.ndarray | None = None  # (n, 3)
    uvs: np.ndarray | None = None  # (n, 2): texture coordinates, v = 0 at an image's top row


def load_mesh(path):
    """A Mesh from an OBJ or PLY file."""
    if not os.path.exists(path):
        raise SceneError(f"{path}: mesh file not found")
    ext = os.path.splitext(path)[1].lower()
    if ext == ".obj":
        return load_obj(path)
    if ext == ".ply":
        return load_ply(path)
    raise SceneError(f"{path}: unknown mesh format '{ext}' (expected .obj or .ply)")


def load_obj(path):
    """OBJ: v, vt, vn and f (polygons fan-triangulated; negative indices allowed). As in
    Mitsuba, v is flipped (OBJ puts v = 0 at an image's bottom row)."""
    return _read(_core.read_obj, path)


def load_ply(path):
    """PLY: vertex x,y,z (nx,ny,nz; u,v) and face vertex_indices lists, any encoding."""
    return _read(_core.read_ply, path)


def _read(read, path):
    """The native reader's arrays (native/src/io/mesh_files.cpp), checked."""
    try:
        positions, triangles, normals, uvs = read(os.fspath(path))
    except _core.MeshFileError as e:
        raise SceneError(str(e)) from None
    if positions is None or triangles is None:
        raise SceneError(f"{path}: the mesh has no triangles")
    n = len(positions)
    if triangles.min() < 0 or triangles.max() >= n:
        raise SceneError(f"{path}: a face refers to a vertex that does not exist (vertices: {n})")
    if not np.all(np.isfinite(positions)):
        raise SceneError(f"{path}: vertex positions must be finite")
    if normals is not None and not np.all(np.isfinite(normals)):
        normals = None  # shading falls back to the faces' normals
    if uvs is not None and not np.all(np.isfinite(uvs)):
        raise SceneError(f"{path}: texture coordinates must be finite")
    return Mesh(positions, triangles.astype(np.uint32), normals, uvs)


def write_ply(path, positions, triangles, normals=None, uvs=None):
    """Binary little-endian PLY (what the exporter writes)."""
    positions = np.asarray(positions, np.float32)
    triangles = np.asarray(triangles, np.uint32)
    header = [
        "ply",
        "format binary_little_endian 1.0",
        f"element vertex {len(positions)}",
        "property float x",
        "property float y",
        "property float z",
    ]
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if normals is not None:
        header += ["property float nx", "property float ny", "property float nz"]
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
    if uvs is not None:
        header += ["property float u", "property float v"]
        fields += [("u", "<f4"), ("v", "<f4")]
    header += [f"element face {len(triangles)}", "property list uchar uint vertex_indices", "end_header"]
    verts = np.empty(len(positions), dtype=fields)
    verts["x"], verts["y"], verts["z"] = positions.T
    if normals is not None:
        verts["nx"], verts["ny"], verts["nz"] = np.asarray(normals, np.float32).T
    if uvs is not None:
        verts["u"], verts["v"] = np.asarray(uvs, np.float32).T
    faces = np.empty(len(triangles), dtype=[("n", "u1"), ("i", "<u4", 3)])
    faces["n"], faces["i"] = 3, triangles
    with open(path, "wb") as f:
        f.write(("\n".join(header) + "\n").encode("ascii"))
        f.write(verts.tobytes())
        f.write(faces.tobytes())
