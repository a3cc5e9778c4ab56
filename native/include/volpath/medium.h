// Participating media: what the null-scattering estimators need of them is the
// coefficients at a point and a majorant sigma_maj >= sigma_t over ray segments.
#pragma once

#include <variant>
#include <vector>

#include "phase.h"
#include "sampler.h"

namespace volpath {

struct HomogeneousMedium {
    Spectrum sigma_a, sigma_s;
    PhaseFunction phase;
};

// A dense voxel grid filling [0,1]^3 in its own space, x fastest, 1 or 3 channels.
// Voxel centres sit at (i + 0.5) / res; lookups are trilinear and clamp at the border.
struct VoxelGrid {
    int res[3] = {0, 0, 0};
    int channels = 1;
    std::vector<float> data;

    bool empty() const { return data.empty(); }
    Spectrum lookup(const Vec3 &p) const;
    Spectrum max_value() const;
};

// sigma_t(x) = scale * density(x), sigma_s = albedo * sigma_t; the albedo is a grid or a
// constant. One global majorant for now (max density * scale per channel).
struct GridMedium {
    VoxelGrid density;
    VoxelGrid albedo_grid;  // empty: use `albedo`
    Spectrum albedo{1.0};
    Real scale = 1;
    Transform world_to_grid;
    Spectrum sigma_maj;
    PhaseFunction phase;
};

using Medium = std::variant<HomogeneousMedium, GridMedium>;

struct MediumProperties {
    Spectrum sigma_a, sigma_s;
};

inline bool is_homogeneous(const Medium &m) { return std::holds_alternative<HomogeneousMedium>(m); }
MediumProperties medium_properties(const Medium &m, const Vec3 &p);
const PhaseFunction &medium_phase(const Medium &m);
void prepare_medium(Medium &m);  // computes majorants

// The part [t0, t1] of the ray inside which the medium may be non-empty, with its
// majorant. Returns false when the ray misses it within t_max.
struct MajorantSegment {
    Real t0 = 0, t1 = 0;
    Spectrum sigma_maj;
};
bool majorant_segment(const Medium &m, const Ray &ray, Real t_max, MajorantSegment &seg);

// Tentative collisions against the majorant, distances sampled in `channel` (pbrt's
// SampleT_maj). At each collision the callback gets the point, the coefficients there,
// sigma_maj and the majorant transmittance T_maj since the previous collision; it
// returns false to stop. The result is T_maj from the last collision to t_max (or 1 if
// the callback stopped the walk).
template <typename Callback>
Spectrum sample_T_maj(const Medium &medium, const Ray &ray, Real t_max, int channel,
                      Sampler &rng, Callback &&callback) {
    MajorantSegment seg;
    if (!majorant_segment(medium, ray, t_max, seg)) return Spectrum(1.0);
    const Real sigma_c = seg.sigma_maj[channel];
    if (sigma_c <= 0) return exp(-seg.sigma_maj * (seg.t1 - seg.t0));
    Real t = seg.t0;
    for (;;) {
        const Real dt = -std::log1p(-rng.next_1d()) / sigma_c;
        if (t + dt >= seg.t1) return exp(-seg.sigma_maj * (seg.t1 - t));
        t += dt;
        const Vec3 p = ray.at(t);
        if (!callback(p, t, medium_properties(medium, p), seg.sigma_maj, exp(-seg.sigma_maj * dt)))
            return Spectrum(1.0);
    }
}

}  // namespace volpath
