"""Evaluated meshes (modifiers applied) to triangle arrays, one shape per material slot.

Arrays stay in object space as float32 (what Blender stores) and the object's matrix goes
into ``to_world``: instances share their arrays, and a scene written to PLY renders to
the same bits as the one kept in memory.
"""

import numpy as np


def triangles(obj):
    """{material_index: (positions, indices, normals or None)} of an evaluated object, or
    {} when it has no faces."""
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
        domain = mesh.normals_domain
        if domain == "CORNER":  # split normals: one vertex per triangle corner
            tri_loops = np.empty(n_tris * 3, np.int32)
            mesh.loop_triangles.foreach_get("loops", tri_loops)
            corner = np.empty(len(mesh.loops) * 3, np.float32)
            mesh.corner_normals.foreach_get("vector", corner)
            positions, normals = verts[tri_verts.ravel()], corner.reshape(-1, 3)[tri_loops]
            indices = np.arange(n_tris * 3, dtype=np.uint32).reshape(-1, 3)
        else:
            positions, indices = verts, tri_verts.astype(np.uint32)
            normals = None
            if domain == "POINT":  # smooth shading
                normals = np.empty(len(mesh.vertices) * 3, np.float32)
                mesh.vertex_normals.foreach_get("vector", normals)
                normals = normals.reshape(-1, 3)
        parts = {}
        for m in np.unique(materials):
            sel = indices[materials == m]
            used, remap = np.unique(sel, return_inverse=True)
            parts[int(m)] = (
                np.ascontiguousarray(positions[used]),
                remap.reshape(-1, 3).astype(np.uint32),
                None if normals is None else np.ascontiguousarray(normals[used]),
            )
        return parts
    finally:
        obj.to_mesh_clear()
