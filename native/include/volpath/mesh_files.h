// Triangle meshes from Wavefront OBJ and PLY files (ASCII and binary), read in one pass
// without an interpreter's per-face loop: a million faces load in a fraction of a second.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace volpath {

// A mesh as its file gives it: flat arrays, normals and uvs empty where the file has none
// (for OBJ, where any corner lacks them). Polygons are fan-triangulated in order; vertex
// indices are not range-checked here.
struct MeshArrays {
    std::vector<double> positions;   // 3 per vertex
    std::vector<double> normals;     // 3 per vertex, or none
    std::vector<double> uvs;         // 2 per vertex, or none
    std::vector<int64_t> triangles;  // 3 per triangle
};

// Malformed input: the message names the file, and the line where it has lines.
struct MeshFileError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// OBJ: v, vt, vn and f (negative indices allowed); every distinct v/vt/vn corner becomes a
// vertex. As in Mitsuba, v is flipped (OBJ puts v = 0 at an image's bottom row).
MeshArrays read_obj(const std::string &path);

// PLY: vertex x, y, z (nx, ny, nz; u, v or its other common names) and face vertex_indices
// (or vertex_index) lists, in any encoding; other elements and properties are skipped.
MeshArrays read_ply(const std::string &path);

}  // namespace volpath
