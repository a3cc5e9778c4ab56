// Small vector algebra in double precision.
//
// Everything geometric is double: a planet of radius 6.4e6 m leaves float32 about
// 0.5 m of resolution, which is more than a camera height above the ground.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace volpath {

using Real = double;

constexpr Real kPi = 3.14159265358979323846;
constexpr Real kInvPi = 1.0 / kPi;
constexpr Real kInv2Pi = 1.0 / (2.0 * kPi);
constexpr Real kInv4Pi = 1.0 / (4.0 * kPi);
constexpr Real kInfinity = std::numeric_limits<Real>::infinity();

struct Vec3 {
    Real x = 0, y = 0, z = 0;
    constexpr Vec3() = default;
    constexpr Vec3(Real x_, Real y_, Real z_) : x(x_), y(y_), z(z_) {}
    constexpr explicit Vec3(Real v) : x(v), y(v), z(v) {}
    Real operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
    Real &operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
};

// RGB radiance, throughput and coefficients share the vector type; the name says which.
using Spectrum = Vec3;

struct Vec2 {
    Real x = 0, y = 0;
};

inline Vec3 operator+(const Vec3 &a, const Vec3 &b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(const Vec3 &a, const Vec3 &b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(const Vec3 &a, const Vec3 &b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
inline Vec3 operator/(const Vec3 &a, const Vec3 &b) { return {a.x / b.x, a.y / b.y, a.z / b.z}; }
inline Vec3 operator*(const Vec3 &a, Real s) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3 operator*(Real s, const Vec3 &a) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3 operator/(const Vec3 &a, Real s) { return a * (1.0 / s); }
inline Vec3 operator-(const Vec3 &a) { return {-a.x, -a.y, -a.z}; }
inline Vec3 &operator+=(Vec3 &a, const Vec3 &b) { return a = a + b; }
inline Vec3 &operator-=(Vec3 &a, const Vec3 &b) { return a = a - b; }
inline Vec3 &operator*=(Vec3 &a, const Vec3 &b) { return a = a * b; }
inline Vec3 &operator*=(Vec3 &a, Real s) { return a = a * s; }
inline Vec3 &operator/=(Vec3 &a, Real s) { return a = a / s; }

inline Real dot(const Vec3 &a, const Vec3 &b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(const Vec3 &a, const Vec3 &b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline Real length_squared(const Vec3 &a) { return dot(a, a); }
inline Real length(const Vec3 &a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalize(const Vec3 &a) { return a / length(a); }
inline Vec3 min(const Vec3 &a, const Vec3 &b) { return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)}; }
inline Vec3 max(const Vec3 &a, const Vec3 &b) { return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)}; }
inline Vec3 abs(const Vec3 &a) { return {std::abs(a.x), std::abs(a.y), std::abs(a.z)}; }
// Grey arguments (grey media, most of them) take one exp instead of three.
inline bool operator==(const Vec3 &a, const Vec3 &b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
inline bool is_grey(const Vec3 &a) { return a.x == a.y && a.y == a.z; }
inline Vec3 exp(const Vec3 &a) {
    return is_grey(a) ? Vec3(std::exp(a.x)) : Vec3{std::exp(a.x), std::exp(a.y), std::exp(a.z)};
}
inline Vec3 clamp_zero(const Vec3 &a) { return max(a, Vec3(0.0)); }
inline Real max_component(const Vec3 &a) { return std::max(a.x, std::max(a.y, a.z)); }
inline Real average(const Vec3 &a) { return (a.x + a.y + a.z) * (1.0 / 3.0); }
inline bool is_black(const Vec3 &a) { return a.x == 0 && a.y == 0 && a.z == 0; }
inline bool is_finite(const Vec3 &a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }
inline Real luminance(const Spectrum &s) { return 0.2126 * s.x + 0.7152 * s.y + 0.0722 * s.z; }
// Divides where the divisor is non-zero; 0/0 is 0 (a channel that cannot be sampled).
inline Vec3 safe_div(const Vec3 &a, const Vec3 &b) {
    return {b.x != 0 ? a.x / b.x : 0.0, b.y != 0 ? a.y / b.y : 0.0, b.z != 0 ? a.z / b.z : 0.0};
}
inline Real safe_sqrt(Real v) { return std::sqrt(std::max(v, 0.0)); }
inline Real sqr(Real v) { return v * v; }

// Orthonormal basis around a unit normal (Duff et al. 2017, "Building an orthonormal
// basis, revisited"): branch-free and continuous except at n.z = -1.
struct Frame {
    Vec3 s, t, n;
    Frame() = default;
    explicit Frame(const Vec3 &normal) : n(normal) {
        const Real sign = std::copysign(1.0, n.z);
        const Real a = -1.0 / (sign + n.z);
        const Real b = n.x * n.y * a;
        s = {1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x};
        t = {b, sign + n.y * n.y * a, -n.y};
    }
    Vec3 to_local(const Vec3 &v) const { return {dot(v, s), dot(v, t), dot(v, n)}; }
    Vec3 to_world(const Vec3 &v) const { return s * v.x + t * v.y + n * v.z; }
};

// Row-major affine 4x4 transform; the loader composes them in numpy.
struct Transform {
    Real m[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    Vec3 point(const Vec3 &p) const {
        return {m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
                m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
                m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3]};
    }
    Vec3 vector(const Vec3 &v) const {
        return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z, m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
                m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
    }
    // The linear part's determinant (negative where the map mirrors).
    Real determinant3() const {
        return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    }
    // The inverse of an invertible affine map: the linear part's by cofactors, then the
    // translation taken back through it (each instance needs one: numpy's, per matrix,
    // was most of a large field's load time).
    Transform inverse() const {
        const Real c[3][3] = {{m[1][1] * m[2][2] - m[1][2] * m[2][1], m[0][2] * m[2][1] - m[0][1] * m[2][2],
                               m[0][1] * m[1][2] - m[0][2] * m[1][1]},
                              {m[1][2] * m[2][0] - m[1][0] * m[2][2], m[0][0] * m[2][2] - m[0][2] * m[2][0],
                               m[0][2] * m[1][0] - m[0][0] * m[1][2]},
                              {m[1][0] * m[2][1] - m[1][1] * m[2][0], m[0][1] * m[2][0] - m[0][0] * m[2][1],
                               m[0][0] * m[1][1] - m[0][1] * m[1][0]}};
        const Real inv_det = 1 / (m[0][0] * c[0][0] + m[0][1] * c[1][0] + m[0][2] * c[2][0]);
        Transform t;
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) t.m[i][j] = c[i][j] * inv_det;
            t.m[i][3] = -(t.m[i][0] * m[0][3] + t.m[i][1] * m[1][3] + t.m[i][2] * m[2][3]);
        }
        return t;
    }
};

// Element by element: the map between two keys of a motion. Every point then moves on a
// straight line between its places at the keys, so the keys' bounds bound it throughout.
inline Transform lerp(const Transform &a, const Transform &b, Real f) {
    Transform t;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 4; ++j) t.m[i][j] = (1 - f) * a.m[i][j] + f * b.m[i][j];
    return t;
}

struct Ray {
    Vec3 o, d;  // d is unit length
    Real t_min = 0, t_max = kInfinity;
    // When in the shutter's interval, in [0, 1): where what moves is (see MotionKeys); every
    // ray of a path keeps its camera ray's.
    Real time = 0;
    Vec3 at(Real t) const { return o + d * t; }
};

// What a ray was traced for: from the camera, after a diffuse, glossy (specular included) or
// transmitting bounce, after scattering in a medium, or toward a light (a shadow ray).
enum class RayKind : uint8_t { Camera = 1, Diffuse = 2, Glossy = 4, Transmission = 8, Scatter = 16, Shadow = 32 };

// Offset scale for spawning rays off a surface: relative to the magnitude of the point,
// because double-precision intersection error grows with it.
inline Real ray_epsilon(const Vec3 &p) { return 1e-11 + 1e-9 * max_component(abs(p)); }

// A ray that leaves a surface point on the side of `d` (n = 0 for points in a medium), at
// the path's `time`.
inline Ray spawn_ray(Real time, const Vec3 &p, const Vec3 &n, const Vec3 &d, Real t_max = kInfinity) {
    const Real side = dot(d, n) >= 0 ? 1.0 : -1.0;
    return Ray{p + n * (side * ray_epsilon(p)), d, 0, t_max, time};
}

}  // namespace volpath
