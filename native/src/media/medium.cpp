#include "volpath/medium.h"

#include "volpath/geometry.h"

namespace volpath {

Spectrum VoxelGrid::lookup(const Vec3 &p) const {
    // Continuous voxel coordinates with centres at integers.
    Real c[3] = {p.x * res[0] - 0.5, p.y * res[1] - 0.5, p.z * res[2] - 0.5};
    int i0[3], i1[3];
    Real w[3];
    for (int a = 0; a < 3; ++a) {
        c[a] = std::clamp(c[a], 0.0, Real(res[a] - 1));
        i0[a] = std::min(int(c[a]), res[a] - 1);
        i1[a] = std::min(i0[a] + 1, res[a] - 1);
        w[a] = c[a] - i0[a];
    }
    Spectrum out(0.0);
    for (int corner = 0; corner < 8; ++corner) {
        const int x = (corner & 1) ? i1[0] : i0[0];
        const int y = (corner & 2) ? i1[1] : i0[1];
        const int z = (corner & 4) ? i1[2] : i0[2];
        const Real weight = ((corner & 1) ? w[0] : 1 - w[0]) * ((corner & 2) ? w[1] : 1 - w[1]) *
                            ((corner & 4) ? w[2] : 1 - w[2]);
        if (weight == 0) continue;
        const size_t base = ((size_t(z) * res[1] + y) * res[0] + x) * channels;
        if (channels == 1) {
            out += Spectrum(data[base] * weight);
        } else {
            out += Spectrum(data[base], data[base + 1], data[base + 2]) * weight;
        }
    }
    return out;
}

Spectrum VoxelGrid::max_value() const {
    Spectrum m(0.0);
    for (size_t i = 0; i < data.size(); i += channels) {
        if (channels == 1) {
            m = max(m, Spectrum(data[i]));
        } else {
            m = max(m, Spectrum(data[i], data[i + 1], data[i + 2]));
        }
    }
    return m;
}

Real AtmosphereMedium::ozone_profile(Real h) const {
    if (h <= ozone_bottom || h >= ozone_top) return 0.0;
    return h < ozone_peak ? (h - ozone_bottom) / (ozone_peak - ozone_bottom)
                          : (ozone_top - h) / (ozone_top - ozone_peak);
}

void AtmosphereMedium::densities(Real h, Real &rayleigh, Real &mie, Real &ozone) const {
    h = std::max(h, 0.0);  // below the ground (rounding) counts as the ground
    rayleigh = std::exp(-h / rayleigh_height);
    mie = std::exp(-h / mie_height);
    ozone = ozone_profile(h);
}

namespace {
struct Properties {
    const Vec3 &p;
    MediumProperties operator()(const HomogeneousMedium &m) const { return {m.sigma_a, m.sigma_s}; }
    MediumProperties operator()(const GridMedium &m) const {
        const Vec3 q = m.world_to_grid.point(p);
        const Spectrum sigma_t = m.density.lookup(q) * m.scale;
        const Spectrum albedo = m.albedo_grid.empty() ? m.albedo : m.albedo_grid.lookup(q);
        const Spectrum sigma_s = sigma_t * albedo;
        return {clamp_zero(sigma_t - sigma_s), sigma_s};
    }
    MediumProperties operator()(const AtmosphereMedium &m) const {
        Real r, mie, o;
        m.densities(m.altitude(p), r, mie, o);
        return {m.mie_sigma_a * mie + m.ozone_sigma_a * o, m.rayleigh_sigma_s * r + m.mie_sigma_s * mie};
    }
};

struct Phase {
    const Vec3 &p;
    PhaseFunction operator()(const HomogeneousMedium &m) const { return m.phase; }
    PhaseFunction operator()(const GridMedium &m) const { return m.phase; }
    // Each lobe's share is its share of sigma_s here, per channel.
    PhaseFunction operator()(const AtmosphereMedium &m) const {
        Real r, mie, o;
        m.densities(m.altitude(p), r, mie, o);
        const Spectrum s_r = m.rayleigh_sigma_s * r, s_m = m.mie_sigma_s * mie;
        return RayleighMiePhase{safe_div(s_r, s_r + s_m), m.mie_g};
    }
};

// Clips the ray to the unit cube of a grid (slab test on the affine image of the ray,
// whose parameter t stays the world-space distance).
bool clip_to_grid(const GridMedium &m, const Ray &ray, Real t_max, Real &t0, Real &t1) {
    const Vec3 o = m.world_to_grid.point(ray.o), d = m.world_to_grid.vector(ray.d);
    t0 = ray.t_min, t1 = t_max;
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0) {
            if (o[a] < 0 || o[a] > 1) return false;
            continue;
        }
        Real ta = (0 - o[a]) / d[a], tb = (1 - o[a]) / d[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta), t1 = std::min(t1, tb);
    }
    return t0 < t1;
}

struct Segments {
    const Ray &ray;
    Real t_max;
    MajorantSegments &out;
    void operator()(const HomogeneousMedium &m) const {
        if (t_max > ray.t_min) out.seg[out.count++] = {ray.t_min, t_max, m.sigma_a + m.sigma_s};
    }
    void operator()(const GridMedium &m) const {
        Real t0, t1;
        if (clip_to_grid(m, ray, t_max, t0, t1)) out.seg[out.count++] = {t0, t1, m.sigma_maj};
    }
    // Clip to the top of the atmosphere, cut into pieces, and bound each piece by the
    // coefficients at its lowest altitude. Altitude along a line is convex in t, so its
    // minimum over [a, b] is at the closest approach to the centre clamped to [a, b]
    // and its maximum at an end.
    void operator()(const AtmosphereMedium &m) const {
        Real r0, r1;
        if (!sphere_roots(m.center, m.top_radius, ray.o, ray.d, r0, r1)) return;
        const Real t0 = std::max(ray.t_min, r0), t1 = std::min(t_max, r1);
        if (!(t0 < t1)) return;
        const Real t_closest = dot(m.center - ray.o, ray.d);
        const int n = std::clamp(m.pieces, 1, kMaxMajorantSegments);
        for (int i = 0; i < n; ++i) {
            const Real a = t0 + (t1 - t0) * i / n, b = i + 1 == n ? t1 : t0 + (t1 - t0) * (i + 1) / n;
            const Real h_min = m.altitude(ray.at(std::clamp(t_closest, a, b)));
            const Real h_max = std::max(m.altitude(ray.at(a)), m.altitude(ray.at(b)));
            Real r, mie, o;
            m.densities(h_min, r, mie, o);
            // Ozone's tent peaks inside [h_min, h_max] or at the end nearer the peak.
            const Real h_oz = std::clamp(m.ozone_peak, std::max(h_min, 0.0), std::max(h_max, 0.0));
            const Spectrum sigma_maj = m.rayleigh_sigma_s * r + (m.mie_sigma_s + m.mie_sigma_a) * mie +
                                       m.ozone_sigma_a * m.ozone_profile(h_oz);
            // A small safety factor covers rounding in the altitude of the lowest point.
            out.seg[out.count++] = {a, b, sigma_maj * (1.0 + 1e-9)};
        }
    }
};
}  // namespace

MediumProperties medium_properties(const Medium &m, const Vec3 &p) {
    return std::visit(Properties{p}, m);
}

PhaseFunction medium_phase(const Medium &m, const Vec3 &p) { return std::visit(Phase{p}, m); }

void prepare_medium(Medium &m) {
    if (auto *grid = std::get_if<GridMedium>(&m)) {
        // Trilinear interpolation never exceeds the largest voxel, so the grid maximum
        // bounds sigma_t everywhere.
        grid->sigma_maj = grid->density.max_value() * grid->scale;
    }
}

Spectrum optical_depth(const Medium &m, const Ray &ray, Real t_max, int steps) {
    MajorantSegments segments;
    majorant_segments(m, ray, t_max, segments);
    steps += steps % 2;
    Spectrum tau(0.0);
    for (int i = 0; i < segments.count; ++i) {
        const Real a = segments.seg[i].t0, h = (segments.seg[i].t1 - a) / steps;
        for (int k = 0; k <= steps; ++k) {
            const MediumProperties mp = medium_properties(m, ray.at(a + k * h));
            const Real w = (k == 0 || k == steps) ? 1.0 : (k % 2 ? 4.0 : 2.0);
            tau += (mp.sigma_a + mp.sigma_s) * (w * h / 3.0);
        }
    }
    return tau;
}

void majorant_segments(const Medium &m, const Ray &ray, Real t_max, MajorantSegments &out) {
    out.count = 0;
    std::visit(Segments{ray, t_max, out}, m);
}

}  // namespace volpath
