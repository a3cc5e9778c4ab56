// Warps from the unit square to directions and discrete choices, each with its pdf.
#pragma once

#include <vector>

#include "math.h"

namespace volpath {

inline Vec3 sample_uniform_sphere(Vec2 u) {
    const Real z = 1.0 - 2.0 * u.x;
    const Real r = safe_sqrt(1.0 - z * z);
    const Real phi = 2.0 * kPi * u.y;
    return {r * std::cos(phi), r * std::sin(phi), z};
}
constexpr Real uniform_sphere_pdf() { return kInv4Pi; }

// Cosine-weighted hemisphere around +z (Malley's method on a concentric disk).
inline Vec3 sample_cosine_hemisphere(Vec2 u) {
    const Real a = 2.0 * u.x - 1.0, b = 2.0 * u.y - 1.0;
    Real r, phi;
    if (a == 0 && b == 0) {
        r = 0, phi = 0;
    } else if (std::abs(a) > std::abs(b)) {
        r = a, phi = (kPi / 4.0) * (b / a);
    } else {
        r = b, phi = kPi / 2.0 - (kPi / 4.0) * (a / b);
    }
    const Real x = r * std::cos(phi), y = r * std::sin(phi);
    return {x, y, safe_sqrt(1.0 - x * x - y * y)};
}
inline Real cosine_hemisphere_pdf(Real cos_theta) { return std::max(cos_theta, 0.0) * kInvPi; }

// Uniform over the cone of directions within acos(cos_max) of +z.
inline Vec3 sample_uniform_cone(Vec2 u, Real cos_max) {
    const Real cos_theta = 1.0 - u.x * (1.0 - cos_max);
    const Real sin_theta = safe_sqrt(1.0 - cos_theta * cos_theta);
    const Real phi = 2.0 * kPi * u.y;
    return {sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta};
}
inline Real uniform_cone_pdf(Real cos_max) { return 1.0 / (2.0 * kPi * (1.0 - cos_max)); }

// Barycentrics uniform over a triangle (Heitz 2019, low-distortion square-to-triangle map).
inline Vec2 sample_uniform_triangle(Vec2 u) {
    Real b0, b1;
    if (u.x < u.y) {
        b0 = u.x / 2, b1 = u.y - b0;
    } else {
        b1 = u.y / 2, b0 = u.x - b1;
    }
    return {b0, b1};
}

// Equiangular distances (Kulla and Fajardo 2012): t in [t0, t1] along o + t d with
// density proportional to 1 / |o + t d - c|^2, the falloff of a point light at c. The
// angle seen from c is uniform between theta_a and theta_b; t1 may be infinite.
struct Equiangular {
    Real t_closest = 0, D = 0;  // the line's closest approach to c, and its distance
    Real theta_a = 0, theta_b = 0;
};
inline Equiangular equiangular(const Vec3 &c, const Vec3 &o, const Vec3 &d, Real t0, Real t1) {
    Equiangular e;
    e.t_closest = dot(c - o, d);
    e.D = length(c - o - d * e.t_closest);
    // A line through c (D = 0) has no finite density: theta_a = theta_b marks it unusable.
    if (e.D > 0 && t1 > t0) {
        e.theta_a = std::atan2(t0 - e.t_closest, e.D);
        e.theta_b = std::atan2(t1 - e.t_closest, e.D);
    }
    return e;
}
inline bool is_valid(const Equiangular &e) { return e.theta_b > e.theta_a; }
inline Real sample_equiangular(const Equiangular &e, Real u, Real t0, Real t1) {
    const Real theta = e.theta_a + u * (e.theta_b - e.theta_a);
    return std::clamp(e.t_closest + e.D * std::tan(theta), t0, t1);
}
inline Real equiangular_pdf(const Equiangular &e, Real t) {
    if (!is_valid(e)) return 0;
    const Real s = t - e.t_closest;
    return e.D / ((e.theta_b - e.theta_a) * (e.D * e.D + s * s));
}

// Piecewise-constant 1D distribution over n cells of [0, 1).
struct Distribution1D {
    std::vector<Real> func, cdf;
    Real integral = 0;

    Distribution1D() = default;
    explicit Distribution1D(std::vector<Real> f) : func(std::move(f)), cdf(func.size() + 1, 0.0) {
        const size_t n = func.size();
        for (size_t i = 0; i < n; ++i) cdf[i + 1] = cdf[i] + std::max(func[i], 0.0) / Real(n);
        integral = cdf[n];
        if (integral > 0) {
            for (size_t i = 1; i <= n; ++i) cdf[i] /= integral;
        } else {
            for (size_t i = 1; i <= n; ++i) cdf[i] = Real(i) / Real(n);
        }
        cdf[n] = 1.0;
    }
    size_t size() const { return func.size(); }
    // Index of the cell containing u, and the position of u inside that cell in [0, 1).
    size_t sample_discrete(Real u, Real *u_remapped = nullptr) const {
        const size_t i = find_cell(u);
        if (u_remapped) {
            const Real width = cdf[i + 1] - cdf[i];
            *u_remapped = width > 0 ? std::min((u - cdf[i]) / width, 0x1.fffffffffffffp-1) : 0.0;
        }
        return i;
    }
    // Continuous sample in [0, 1) with density func/integral.
    Real sample_continuous(Real u, Real *pdf, size_t *cell) const {
        Real du;
        const size_t i = sample_discrete(u, &du);
        if (pdf) *pdf = integral > 0 ? std::max(func[i], 0.0) / integral : 1.0;
        if (cell) *cell = i;
        return (Real(i) + du) / Real(size());
    }

private:
    size_t find_cell(Real u) const {
        // Largest i with cdf[i] <= u, skipping zero-width cells.
        size_t lo = 0, hi = func.size();
        while (hi - lo > 1) {
            const size_t mid = (lo + hi) / 2;
            if (cdf[mid] <= u)
                lo = mid;
            else
                hi = mid;
        }
        while (lo + 1 < func.size() && cdf[lo + 1] - cdf[lo] <= 0) ++lo;
        return lo;
    }
};

// Piecewise-constant 2D distribution: a marginal over rows, a conditional per row.
struct Distribution2D {
    std::vector<Distribution1D> rows;
    Distribution1D marginal;

    Distribution2D() = default;
    Distribution2D(const std::vector<Real> &f, size_t width, size_t height) {
        std::vector<Real> row_integrals(height);
        rows.reserve(height);
        for (size_t y = 0; y < height; ++y) {
            rows.emplace_back(std::vector<Real>(f.begin() + y * width, f.begin() + (y + 1) * width));
            row_integrals[y] = rows.back().integral;
        }
        marginal = Distribution1D(std::move(row_integrals));
    }
    // Returns (u, v) in [0,1)^2 and the density with respect to the unit square.
    Vec2 sample(Vec2 u, Real *pdf) const {
        Real pdf_row, pdf_col;
        size_t row;
        const Real v = marginal.sample_continuous(u.y, &pdf_row, &row);
        const Real x = rows[row].sample_continuous(u.x, &pdf_col, nullptr);
        *pdf = pdf_row * pdf_col;
        return {x, v};
    }
    Real pdf(Vec2 p) const {
        const size_t h = marginal.size(), w = rows[0].size();
        const size_t iy = std::min(size_t(std::max(p.y, 0.0) * h), h - 1);
        const size_t ix = std::min(size_t(std::max(p.x, 0.0) * w), w - 1);
        if (marginal.integral <= 0) return 1.0;
        return std::max(rows[iy].func[ix], 0.0) / marginal.integral;
    }
};

// Power heuristic (beta = 2) on two strategy densities.
inline Real power_heuristic(Real pdf_a, Real pdf_b) {
    const Real a = pdf_a * pdf_a, b = pdf_b * pdf_b;
    return a + b > 0 ? a / (a + b) : 0.0;
}

}  // namespace volpath
