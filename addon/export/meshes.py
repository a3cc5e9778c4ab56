"""Evaluated meshes (modifiers applied) to triangle arrays, one shape per material slot.

Arrays stay in object space as float32 (what Blender stores) and the object's matrix goes
into ``to_world``: instances share their arrays, and a scene written to PLY renders to
the same bits as the one kept in memory.
"""

import numpy as np


def triangles(obj, uv_map=None):
    """{material_index: (positions, indices, normals or None, uvs or None)} of an evaluated
    object, or {} when it has no faces. ``uv_map``: None for no texture coordinates, "" for
    the UV map Cycles renders with, or a UV map's name. UVs are per face corner: a vertex is
    split where its corners' UVs (or split normals) differ. v is flipped, as the scene
    format has it (v = 0 at an image's top row)."""
    try:
        mesh = obj.to_mesh()
    except RuntimeError:
        return {}
    if mesh is None:
        return {}
    try:
        mesh.calc_loop_triangles()
        n_tris = len(mesh.loop_triangles)
        if n_tris == 0:
            return {}
        verts = np.empty(len(mesh.vertices) * 3, np.float32)
        mesh.vertices.foreach_get("co", verts)
        verts = verts.reshape(-1, 3)
        tri_verts = np.empty(n_tris * 3, np.int32)
        mesh.loop_triangles.foreach_get("vertices", tri_verts)
        tri_verts = tri_verts.reshape(-1, 3)
        materials = np.empty(n_tris, np.int32)
        mesh.loop_triangles.foreach_get("material_index", materials)
        tri_loops = np.empty(n_tris * 3, np.int32)
        mesh.loop_triangles.foreach_get("loops", tri_loops)
        domain = mesh.normals_domain
        layer = _uv_layer(mesh, uv_map)
        point_normals = None
        if domain == "POINT":  # smooth shading
            point_normals = np.empty(len(mesh.vertices) * 3, np.float32)
            mesh.vertex_normals.foreach_get("vector", point_normals)
            point_normals = point_normals.reshape(-1, 3)
        uvs = None
        if layer is not None:
            corner_uv = np.empty(len(mesh.loops) * 2, np.float32)
            layer.uv.foreach_get("vector", corner_uv)
            corner_uv = corner_uv.reshape(-1, 2)[tri_loops]
            corner_uv[:, 1] = 1 - corner_uv[:, 1]
            corner_n = _corner_normals(mesh, tri_loops) if domain == "CORNER" else np.zeros((len(tri_loops), 0))
            # One vertex per distinct (vertex, uv, split normal) among the corners.
            key = np.hstack([tri_verts.reshape(-1, 1), corner_uv, corner_n])
            key, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
            corner_vertex = tri_verts.ravel()[first]
            positions, uvs = verts[corner_vertex], np.ascontiguousarray(key[:, 1:3], dtype=np.float32)
            normals = (
                corner_n[first].astype(np.float32)
                if domain == "CORNER"
                else None
                if point_normals is None
                else point_normals[corner_vertex]
            )
            indices = inverse.reshape(-1, 3).astype(np.uint32)
        elif domain == "CORNER":  # split normals: one vertex per triangle corner
            positions, normals = verts[tri_verts.ravel()], _corner_normals(mesh, tri_loops)
            indices = np.arange(n_tris * 3, dtype=np.uint32).reshape(-1, 3)
        else:
            positions, indices, normals = verts, tri_verts.astype(np.uint32), point_normals
        parts = {}
        for m in np.unique(materials):
            sel = indices[materials == m]
            used, remap = np.unique(sel, return_inverse=True)
            parts[int(m)] = (
                np.ascontiguousarray(positions[used]),
                remap.reshape(-1, 3).astype(np.uint32),
                None if normals is None else np.ascontiguousarray(normals[used]),
                None if uvs is None else np.ascontiguousarray(uvs[used]),
            )
        return parts
    finally:
        obj.to_mesh_clear()


def _corner_normals(mesh, tri_loops):
    corner = np.empty(len(mesh.loops) * 3, np.float32)
    mesh.corner_normals.foreach_get("vector", corner)
    return corner.reshape(-1, 3)[tri_loops]


def _uv_layer(mesh, uv_map):
    """The UV layer named ``uv_map`` ("" for the one Cycles renders with), or None."""
    if uv_map is None or len(mesh.uv_layers) == 0:
        return None
    if uv_map:
        return mesh.uv_layers.get(uv_map)
    return next((layer for layer in mesh.uv_layers if layer.active_render), mesh.uv_layers.active)
