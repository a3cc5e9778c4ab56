"""Triangle meshes from Wavefront OBJ and PLY (ASCII and binary) files, as numpy arrays."""

import os
from typing import NamedTuple

import numpy as np

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


def _check(path, positions, triangles, normals, uvs=None):
    n = len(positions)
    if n == 0 or len(triangles) == 0:
        raise SceneError(f"{path}: the mesh has no triangles")
    if triangles.min() < 0 or triangles.max() >= n:
        raise SceneError(f"{path}: a face refers to a vertex that does not exist (vertices: {n})")
    if not np.all(np.isfinite(positions)):
        raise SceneError(f"{path}: vertex positions must be finite")
    if normals is not None and (len(normals) != n or not np.all(np.isfinite(normals))):
        normals = None
    if uvs is not None and (len(uvs) != n or not np.all(np.isfinite(uvs))):
        raise SceneError(f"{path}: texture coordinates must be finite, one pair per vertex")
    return Mesh(positions.astype(np.float64), triangles.astype(np.uint32), normals, uvs)


def load_obj(path):
    """OBJ: v, vt, vn and f (polygons fan-triangulated; negative indices allowed). As in
    Mitsuba, v is flipped (OBJ puts v = 0 at an image's bottom row)."""
    v, vt, vn, corners, faces = [], [], [], {}, []
    out_pos, out_uv, out_nrm = [], [], []
    with open(path, encoding="utf-8", errors="replace") as f:
        for line_no, line in enumerate(f, 1):
            parts = line.split()
            if not parts or parts[0].startswith("#"):
                continue
            try:
                if parts[0] == "v":
                    v.append([float(x) for x in parts[1:4]])
                elif parts[0] == "vt":
                    vt.append([float(parts[1]), 1.0 - float(parts[2]) if len(parts) > 2 else 1.0])
                elif parts[0] == "vn":
                    vn.append([float(x) for x in parts[1:4]])
                elif parts[0] == "f":
                    idx = []
                    for c in parts[1:]:
                        fields = c.split("/")
                        pi = _obj_index(fields, 0, len(v))
                        ti = _obj_index(fields, 1, len(vt))
                        ni = _obj_index(fields, 2, len(vn))
                        if not (0 <= pi < len(v)) or ti >= len(vt) or ni >= len(vn):
                            raise SceneError(f"{path}:{line_no}: face refers to a missing vertex")
                        key = (pi, ti, ni)
                        if key not in corners:
                            corners[key] = len(out_pos)
                            out_pos.append(v[pi])
                            out_uv.append(vt[ti] if ti >= 0 else None)
                            out_nrm.append(vn[ni] if ni >= 0 else None)
                        idx.append(corners[key])
                    if len(idx) < 3:
                        raise SceneError(f"{path}:{line_no}: a face needs at least 3 vertices")
                    faces.extend([idx[0], idx[i], idx[i + 1]] for i in range(1, len(idx) - 1))
            except (ValueError, IndexError):
                raise SceneError(f"{path}:{line_no}: malformed '{parts[0]}' line (expected numbers)") from None
    positions = np.array(out_pos, dtype=np.float64).reshape(-1, 3)
    normals = uvs = None
    if out_nrm and all(n is not None for n in out_nrm):
        normals = np.array(out_nrm, dtype=np.float64)
    if out_uv and all(t is not None for t in out_uv):
        uvs = np.array(out_uv, dtype=np.float64)
    return _check(path, positions, np.array(faces, dtype=np.int64).reshape(-1, 3), normals, uvs)


def _obj_index(fields, i, count):
    """The 0-based index in field i of an OBJ face corner (v/vt/vn), or -1 if absent."""
    if len(fields) <= i or not fields[i]:
        return -1
    k = int(fields[i])
    return k - 1 if k > 0 else count + k


_PLY_TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}


def load_ply(path):
    """PLY: vertex x,y,z (nx,ny,nz) and face vertex_indices lists, any encoding."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise SceneError(f"{path}: not a PLY file (missing 'ply' magic or 'end_header')")
    header = data[:end].decode("ascii", errors="replace").splitlines()
    body_start = data.index(b"\n", end) + 1
    fmt, elements = None, []
    for line in header[1:]:
        p = line.split()
        if not p:
            continue
        if p[0] == "format":
            fmt = p[1]
        elif p[0] == "element":
            elements.append({"name": p[1], "count": int(p[2]), "props": []})
        elif p[0] == "property":
            if not elements:
                raise SceneError(f"{path}: property before any element")
            if p[1] == "list":
                elements[-1]["props"].append((p[4], "list", _PLY_TYPES.get(p[2]), _PLY_TYPES.get(p[3])))
            else:
                elements[-1]["props"].append((p[2], _PLY_TYPES.get(p[1]), None, None))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise SceneError(f"{path}: unknown PLY format '{fmt}'")
    for el in elements:
        for name, t, a, b in el["props"]:
            if t is None or (t == "list" and (a is None or b is None)):
                raise SceneError(f"{path}: unknown type of property '{name}'")
    positions = normals = uvs = faces = None
    if fmt == "ascii":
        tokens = data[body_start:].split()
        pos = 0
        for el in elements:
            rows = []
            for _ in range(el["count"]):
                row = {}
                for name, t, _a, _b in el["props"]:
                    if t == "list":
                        k = int(tokens[pos])
                        pos += 1
                        row[name] = [int(x) for x in tokens[pos : pos + k]]
                        pos += k
                    else:
                        row[name] = float(tokens[pos])
                        pos += 1
                rows.append(row)
            if el["name"] == "vertex":
                scalars = [name for name, t, _a, _b in el["props"] if t != "list"]
                positions, normals, uvs = _vertex_arrays(path, {k: np.array([r[k] for r in rows]) for k in scalars})
            elif el["name"] == "face":
                faces = [r.get("vertex_indices", r.get("vertex_index")) for r in rows]
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        buf, pos = data, body_start
        for el in elements:
            props = el["props"]
            if all(t != "list" for _, t, _, _ in props):
                dt = np.dtype([(name, order + t) for name, t, _, _ in props])
                arr = np.frombuffer(buf, dtype=dt, count=el["count"], offset=pos)
                pos += dt.itemsize * el["count"]
                if el["name"] == "vertex":
                    positions, normals, uvs = _vertex_arrays(path, {k: arr[k] for k in arr.dtype.names})
            else:
                lists, pos = _binary_lists(buf, pos, el, order)
                if el["name"] == "face":
                    faces = lists.get("vertex_indices", lists.get("vertex_index"))
    if positions is None or faces is None:
        raise SceneError(f"{path}: PLY file needs 'vertex' and 'face' elements")
    return _check(path, positions, _fan(faces), normals, uvs)


# The names PLY writers give texture coordinates (Blender, Mitsuba, MeshLab).
_PLY_UV_NAMES = (("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t"))


def _vertex_arrays(path, columns):
    """(positions, normals or None, uvs or None) from a PLY vertex element's columns."""
    if not {"x", "y", "z"} <= columns.keys():
        raise SceneError(f"{path}: the PLY vertex element needs properties x, y and z")

    def stack(*names):
        return np.stack([columns[n] for n in names], axis=1).astype(np.float64)

    positions = stack("x", "y", "z")
    normals = stack("nx", "ny", "nz") if "nx" in columns else None
    uvs = next((stack(u, v) for u, v in _PLY_UV_NAMES if u in columns and v in columns), None)
    return positions, normals, uvs


def _fan(faces):
    """Triangles (m, 3) from polygons: an (n, k) array of k-gons, or a list of index arrays."""
    if isinstance(faces, np.ndarray):
        k = faces.shape[1]
        if k < 3:
            return np.empty((0, 3), np.int64)
        i = np.arange(1, k - 1)
        return np.stack([np.repeat(faces[:, :1], k - 2, axis=1), faces[:, i], faces[:, i + 1]], axis=2).reshape(-1, 3)
    tris = [[f[0], f[i], f[i + 1]] for f in faces for i in range(1, len(f) - 1)]
    return np.array(tris, dtype=np.int64).reshape(-1, 3)


def _binary_lists(buf, pos, el, order):
    """A binary element with list properties: ({list name: (n, k) array when every row's
    list has k entries, else a list of arrays}, position after the element). Meshes whose
    faces all have one size (triangles, quads) are read as one structured array."""
    props, count = el["props"], el["count"]
    first = pos
    fields = []
    for name, t, a, b in props:  # every list assumed to hold as many entries as the first row's
        if t == "list":
            k = int(np.frombuffer(buf, order + a, 1, first)[0]) if count else 0
            fields += [(name + "#", order + a), (name, order + b, (k,))]
            first += np.dtype(a).itemsize + k * np.dtype(b).itemsize
        else:
            fields.append((name, order + t))
            first += np.dtype(t).itemsize
    dt = np.dtype(fields)
    if pos + dt.itemsize * count <= len(buf):
        arr = np.frombuffer(buf, dtype=dt, count=count, offset=pos)
        if all(np.all(arr[name + "#"] == dt[name].shape[0]) for name, t, _, _ in props if t == "list"):
            return {
                name: arr[name].astype(np.int64) for name, t, _, _ in props if t == "list"
            }, pos + dt.itemsize * count
    lists = {name: [] for name, t, _, _ in props if t == "list"}
    for _ in range(count):
        for name, t, a, b in props:
            if t == "list":
                k = int(np.frombuffer(buf, order + a, 1, pos)[0])
                pos += np.dtype(a).itemsize
                lists[name].append(np.frombuffer(buf, order + b, k, pos))
                pos += k * np.dtype(b).itemsize
            else:
                pos += np.dtype(t).itemsize
    return lists, pos


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
