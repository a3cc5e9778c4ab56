// The media as one variant: their coefficients and phase functions at a point, their
// preparation, and majorants along rays (MajorantIterator).
#include "volpath/medium.h"

#include <algorithm>
#include <stdexcept>

#include "media.h"
#include "volpath/geometry.h"

namespace volpath {

namespace {
struct Properties {
    const Vec3 &p;
    MediumProperties operator()(const HomogeneousMedium &m) const { return {m.sigma_a, m.sigma_s, m.Le}; }
    MediumProperties operator()(const GridMedium &m) const {
        const Spectrum sigma_t = m.density.lookup(p) * m.scale;
        const Spectrum albedo = m.albedo_grid.empty() ? m.albedo : m.albedo_grid.lookup(p);
        const Spectrum sigma_s = sigma_t * albedo;
        const Spectrum Le = m.Le_grid.empty() ? m.Le_scale : m.Le_grid.lookup(p) * m.Le_scale;
        return {clamp_zero(sigma_t - sigma_s), sigma_s, Le};
    }
    MediumProperties operator()(const AtmosphereMedium &m) const {
        Real r, mie, o;
        m.densities(m.altitude(p), r, mie, o);
        return {m.mie_sigma_a * mie + m.ozone_sigma_a * o, m.rayleigh_sigma_s * r + m.mie_sigma_s * mie, Spectrum(0.0)};
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

// Clips a ray given in a grid's space (o, d and 1 / d; its parameter t stays the world
// distance) to the grid's unit cube by the slab test.
bool clip_to_unit_cube(const Vec3 &o, const Vec3 &d, const Vec3 &inv_d, Real &t0, Real &t1) {
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0) {
            if (o[a] < 0 || o[a] > 1) return false;
            continue;
        }
        Real ta = -o[a] * inv_d[a], tb = (1 - o[a]) * inv_d[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta), t1 = std::min(t1, tb);
    }
    return t0 < t1;
}
}  // namespace

bool is_emissive(const Medium &m) {
    struct Emissive {
        bool operator()(const HomogeneousMedium &h) const { return !is_black(h.Le) && !is_black(h.sigma_a); }
        bool operator()(const GridMedium &g) const { return !is_black(g.Le_scale); }
        bool operator()(const AtmosphereMedium &) const { return false; }
    };
    return std::visit(Emissive{}, m);
}

MediumProperties medium_properties(const Medium &m, const Vec3 &p) { return std::visit(Properties{p}, m); }

PhaseFunction medium_phase(const Medium &m, const Vec3 &p) { return std::visit(Phase{p}, m); }

void prepare_medium(Medium &m) {
    struct Prepare {
        void operator()(HomogeneousMedium &) const {}
        void operator()(GridMedium &grid) const {
            const int *r = grid.density.grid->res;
            const int longest = std::max({r[0], r[1], r[2]});
            const int automatic = std::max((longest + 9) / 10, std::min(longest, 16));
            const int res = std::clamp(grid.majorant_res > 0 ? grid.majorant_res : automatic, 1, kMaxMajorantGridRes);
            grid.majorants = build_majorants(*grid.density.grid, res);
        }
        void operator()(AtmosphereMedium &air) const {
            if (air.free_flight == AtmosphereMedium::FreeFlight::Guided &&
                air.sun_transmittance == AtmosphereMedium::SunTransmittance::Tracking)
                throw std::invalid_argument(
                    "free_flight='guided' takes transmittances by quadrature: it needs "
                    "sun_transmittance 'table' or 'quadrature', not 'tracking'");
            // The guided free flight reads the sun's transmittance from the table too.
            if (air.sun_transmittance == AtmosphereMedium::SunTransmittance::Table ||
                air.free_flight == AtmosphereMedium::FreeFlight::Guided)
                build_tau_table(air);
        }
    };
    std::visit(Prepare{}, m);
}

Spectrum majorant_optical_depth(const Medium &m, const Ray &ray, Real t_max) {
    MajorantIterator pieces(m, ray, t_max);
    MajorantSegment seg;
    Spectrum tau(0.0);
    while (pieces.next(seg)) tau += seg.sigma_maj * (seg.t1 - seg.t0);
    return tau;
}

Spectrum optical_depth(const Medium &m, const Ray &ray, Real t_max, int steps) {
    MajorantIterator pieces(m, ray, t_max);
    MajorantSegment seg;
    steps += steps % 2;
    Spectrum tau(0.0);
    while (pieces.next(seg)) {
        const Real a = seg.t0, h = (seg.t1 - a) / steps;
        for (int k = 0; k <= steps; ++k) {
            const MediumProperties mp = medium_properties(m, ray.at(a + k * h));
            tau += (mp.sigma_a + mp.sigma_s) * (simpson_weight(k, steps) * h / 3.0);
        }
    }
    return tau;
}

Spectrum sun_optical_depth(const Medium &medium, const Ray &ray, Real t_max) {
    const auto &m = std::get<AtmosphereMedium>(medium);
    Real r0, r1;
    Spectrum tau;
    // The table gives the whole way to the top; a segment that stops short (at an object
    // in the air, or the ground) takes the quadrature.
    if (m.sun_transmittance == AtmosphereMedium::SunTransmittance::Table &&
        sphere_roots(m.center, m.top_radius, ray.o, ray.d, r0, r1) && t_max >= r1 * (1 - 1e-9) &&
        m.tabulated_tau_to_top(ray.at(std::max(ray.t_min, r0)), ray.d, tau))
        return tau;
    const Real piece = (t_max - ray.t_min) / m.pieces, H = std::min(m.mie_height, m.rayleigh_height);
    const Real steps = std::min(2 * std::ceil(piece / (0.4 * H)), Real(kSunQuadratureSteps));
    return optical_depth(medium, ray, t_max, std::max(int(steps), 2));
}

MajorantIterator::MajorantIterator(const Medium &m, const Ray &ray, Real t_max) : ray_(ray) {
    t_ = ray.t_min, t_end_ = t_max;
    if (std::visit([&](const auto &medium) { return start(medium); }, m) && t_ < t_end_) medium_ = &m;
}

bool MajorantIterator::start(const HomogeneousMedium &) { return true; }

// 3D DDA through the majorant cells (Amanatides & Woo), in grid space where the ray's
// parameter is still the world distance.
bool MajorantIterator::start(const GridMedium &g) {
    const Transform &to_grid = g.density.world_to_grid;
    const Vec3 o = to_grid.point(ray_.o), d = to_grid.vector(ray_.d);
    const Vec3 inv_d(1 / d.x, 1 / d.y, 1 / d.z);  // used only where d[a] != 0
    if (!clip_to_unit_cube(o, d, inv_d, t_, t_end_)) return false;
    const int res = g.majorants.res;
    const Real inv_res = 1.0 / res;
    const Vec3 p0 = o + d * t_;
    for (int a = 0; a < 3; ++a) {
        cell_[a] = std::clamp(int(p0[a] * res), 0, res - 1);
        if (d[a] == 0) {
            step_[a] = 0, t_next_[a] = kInfinity, t_delta_[a] = kInfinity;
            continue;
        }
        step_[a] = d[a] > 0 ? 1 : -1;
        const Real boundary = Real(cell_[a] + (d[a] > 0 ? 1 : 0)) * inv_res;
        t_next_[a] = t_ + (boundary - p0[a]) * inv_d[a];
        t_delta_[a] = std::abs(inv_d[a]) * inv_res;
    }
    return true;
}

// Clipped to the top of the atmosphere and cut into equal pieces.
bool MajorantIterator::start(const AtmosphereMedium &air) {
    Real r0, r1;
    if (!sphere_roots(air.center, air.top_radius, ray_.o, ray_.d, r0, r1)) return false;
    t_ = std::max(t_, r0), t_end_ = std::min(t_end_, r1);
    t_start_ = t_, pieces_ = std::clamp(air.pieces, 1, kMaxMajorantSegments);
    return true;
}

bool MajorantIterator::next(MajorantSegment &seg) {
    return medium_ && std::visit([&](const auto &medium) { return next(medium, seg); }, *medium_);
}

bool MajorantIterator::next(const HomogeneousMedium &h, MajorantSegment &seg) {
    const Spectrum sigma_t = h.sigma_a + h.sigma_s;
    seg = {t_, t_end_, sigma_t, sigma_t};  // its own majorant and minorant
    medium_ = nullptr;
    return true;
}

bool MajorantIterator::next(const AtmosphereMedium &air, MajorantSegment &seg) {
    const int i = piece_++;
    const Real a = t_start_ + (t_end_ - t_start_) * i / pieces_;
    const Real b = piece_ == pieces_ ? t_end_ : t_start_ + (t_end_ - t_start_) * piece_ / pieces_;
    seg = {a, b, air_majorant(air, ray_, a, b)};
    if (piece_ == pieces_) medium_ = nullptr;
    return true;
}

bool MajorantIterator::next(const GridMedium &grid, MajorantSegment &seg) {
    const MajorantGrid &mg = grid.majorants;
    while (t_ < t_end_) {
        const bool inside = cell_[0] >= 0 && cell_[0] < mg.res && cell_[1] >= 0 && cell_[1] < mg.res && cell_[2] >= 0 &&
                            cell_[2] < mg.res;
        if (!inside) {
            // Rounding left a sliver at the far end: cover it with the global bound.
            seg = {t_, t_end_, mg.global_max * grid.scale, Spectrum(0.0)};
            t_ = t_end_;
            return true;
        }
        const int axis =
            t_next_[0] < t_next_[1] ? (t_next_[0] < t_next_[2] ? 0 : 2) : (t_next_[1] < t_next_[2] ? 1 : 2);
        const Real t_end = std::min(t_next_[axis], t_end_);
        const MajorantGrid::Cell &cell = mg.at(cell_[0], cell_[1], cell_[2]);
        const Real start = t_;
        t_ = t_end;
        cell_[axis] += step_[axis];
        t_next_[axis] += t_delta_[axis];
        if (t_end > start) {
            seg = {start, t_end, cell.max * grid.scale, cell.min * grid.scale};
            return true;
        }
    }
    return false;
}

}  // namespace volpath
