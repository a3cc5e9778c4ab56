// What the bindings share: numpy and tuple conversions.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>

#include "volpath/scene.h"

namespace py = pybind11;

namespace volpath::bindings {

using Array3 = std::array<double, 3>;
inline Vec3 vec(const Array3 &a) { return {a[0], a[1], a[2]}; }

inline Transform transform(const py::array_t<double, py::array::c_style | py::array::forcecast> &m) {
    if (m.ndim() != 2 || m.shape(0) != 4 || m.shape(1) != 4) throw std::invalid_argument("expected a 4x4 matrix");
    Transform t;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) t.m[i][j] = m.at(i, j);
    return t;
}

// A 3x3 affine matrix of texture coordinates (its last row 0 0 1); none: the identity.
inline UVTransform uv_transform(
    const std::optional<py::array_t<double, py::array::c_style | py::array::forcecast>> &to_uv) {
    if (!to_uv) return {};
    const auto &m = *to_uv;
    if (m.ndim() != 2 || m.shape(0) != 3 || m.shape(1) != 3) throw std::invalid_argument("to_uv must be a 3x3 matrix");
    UVTransform t;
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 3; ++j) t.m[i][j] = m.at(i, j);
    return t;
}

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

// An (n, 4, 4) array of matrices.
inline std::vector<Transform> transforms(const DoubleArray &m, const char *what) {
    if (m.ndim() != 3 || m.shape(1) != 4 || m.shape(2) != 4)
        throw std::invalid_argument(std::string(what) + " must have shape (n, 4, 4)");
    std::vector<Transform> out(size_t(m.shape(0)));
    for (size_t i = 0; i < out.size(); ++i)
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) out[i].m[r][c] = m.at(i, r, c);
    return out;
}

// Motion keys (K >= 2, 4, 4): a map at evenly spaced times over the shutter.
inline MotionKeys motion_keys(const DoubleArray &m) {
    MotionKeys motion{transforms(m, "motion")};
    if (motion.keys.size() < 2) throw std::invalid_argument("a motion needs at least two keys");
    return motion;
}

inline std::vector<Vec3> points(const DoubleArray &a, const char *what) {
    if (a.ndim() != 2 || a.shape(1) != 3) throw std::invalid_argument(std::string(what) + " must have shape (n, 3)");
    std::vector<Vec3> out(size_t(a.shape(0)));
    for (size_t i = 0; i < out.size(); ++i) out[i] = {a.at(i, 0), a.at(i, 1), a.at(i, 2)};
    return out;
}

using TriangleArray = py::array_t<uint32_t, py::array::c_style | py::array::forcecast>;

// A mesh from its arrays: positions (n, 3), triangles (m, 3), normals like positions, uvs (n, 2);
// motion: the positions at the shutter's keys (K, n, 3), for a deforming mesh.
inline TriangleMesh triangle_mesh(const DoubleArray &positions, const TriangleArray &triangles,
                                  const std::optional<DoubleArray> &normals, const std::optional<DoubleArray> &uvs,
                                  const std::optional<DoubleArray> &motion = std::nullopt) {
    TriangleMesh mesh;
    if (motion) {
        if (motion->ndim() != 3 || motion->shape(1) != positions.shape(0) || motion->shape(2) != 3)
            throw std::invalid_argument("motion must have shape (K, n, 3), every position at each key");
        mesh.motion.resize(size_t(motion->shape(0)));
        for (size_t k = 0; k < mesh.motion.size(); ++k) {
            mesh.motion[k].resize(size_t(motion->shape(1)));
            for (size_t i = 0; i < mesh.motion[k].size(); ++i)
                mesh.motion[k][i] = {motion->at(k, i, 0), motion->at(k, i, 1), motion->at(k, i, 2)};
        }
    }
    mesh.positions = points(positions, "positions");
    if (normals) mesh.normals = points(*normals, "normals");
    if (uvs) {
        if (uvs->ndim() != 2 || uvs->shape(1) != 2 || uvs->shape(0) != positions.shape(0))
            throw std::invalid_argument("uvs must have shape (n, 2), one per position");
        mesh.uvs.resize(size_t(uvs->shape(0)));
        for (size_t i = 0; i < mesh.uvs.size(); ++i) mesh.uvs[i] = {uvs->at(i, 0), uvs->at(i, 1)};
    }
    if (triangles.ndim() != 2 || triangles.shape(1) != 3)
        throw std::invalid_argument("triangles must have shape (n, 3)");
    mesh.triangles.resize(size_t(triangles.shape(0)));
    for (size_t i = 0; i < mesh.triangles.size(); ++i)
        mesh.triangles[i] = {triangles.at(i, 0), triangles.at(i, 1), triangles.at(i, 2)};
    return mesh;
}

inline PhaseFunction phase(double g) {
    if (g == 0) return IsotropicPhase{};
    return HenyeyGreenstein{g};
}

}  // namespace volpath::bindings
