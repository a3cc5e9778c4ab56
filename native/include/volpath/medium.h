// Participating media: what the null-scattering estimators need of them is the
// coefficients at a point and a majorant sigma_maj >= sigma_t over ray segments.
#pragma once

#include <cstdint>
#include <memory>
#include <variant>
#include <vector>

#include "phase.h"
#include "sampler.h"

namespace volpath {

// Media emit sigma_a * Le per unit length (pbrt's convention: Kirchhoff's law for a
// medium at temperature T has Le = the Planck radiance B(T)).
struct HomogeneousMedium {
    Spectrum sigma_a, sigma_s;
    PhaseFunction phase;
    Spectrum Le{0.0};
};

// A voxel grid filling [0,1]^3 in its own space, 1 or 3 channels, stored sparsely: the
// grid is cut into 8^3 bricks and only bricks holding a non-zero value are kept, so
// memory follows the active voxels, not the bounding box (an OpenVDB leaf is one brick).
// Voxel centres sit at (i + 0.5) / res; lookups are trilinear and clamp at the border.
struct VoxelGrid {
    static constexpr int kLog2Brick = 3, kBrick = 1 << kLog2Brick, kBrickVoxels = kBrick * kBrick * kBrick;
    int res[3] = {0, 0, 0};
    int bricks[3] = {0, 0, 0};  // ceil(res / 8) per axis
    int channels = 1;
    std::vector<int32_t> brick_index;  // per brick, x fastest: its slot in `data`, or -1 (all zero)
    std::vector<float> data;           // kBrickVoxels * channels per stored brick, x fastest inside

    // The value of voxel (x, y, z), channel c (indices inside the grid).
    float voxel(int x, int y, int z, int c) const {
        const int32_t b =
            brick_index[(size_t(z >> kLog2Brick) * bricks[1] + (y >> kLog2Brick)) * bricks[0] + (x >> kLog2Brick)];
        if (b < 0) return 0.0f;
        const int local = (((z & (kBrick - 1)) * kBrick + (y & (kBrick - 1))) * kBrick + (x & (kBrick - 1)));
        return data[(size_t(b) * kBrickVoxels + local) * channels + c];
    }
    Spectrum lookup(const Vec3 &p) const;
    size_t stored_bricks() const { return data.size() / (size_t(kBrickVoxels) * channels); }
};

// A sparse grid from a dense array of res[0] * res[1] * res[2] * channels values, x fastest.
VoxelGrid sparse_grid(const float *dense, const int res[3], int channels);

// A grid with its placement: world points map into the grid's unit cube. A medium's grids
// (density, albedo, emission) each have their own, as OpenVDB grids do.
struct PlacedGrid {
    std::shared_ptr<const VoxelGrid> grid;  // shared: grids are large and read-only
    Transform world_to_grid;
    bool empty() const { return !grid; }
    Spectrum lookup(const Vec3 &p_world) const { return grid->lookup(world_to_grid.point(p_world)); }
};

// Local majorants: the grid's unit cube cut into res^3 cells, each holding the largest
// density any trilinear lookup inside it can return (the voxels whose interpolation
// support reaches into the cell), and the smallest (a minorant, for residual ratio
// tracking). Rays walk it by DDA; res 1 is one global majorant.
struct MajorantGrid {
    struct Cell {
        Spectrum max, min;
    };
    int res = 1;
    std::vector<Cell> cells;   // x fastest
    Spectrum global_max{0.0};  // the largest cell max
    const Cell &at(int x, int y, int z) const { return cells[(size_t(z) * res + y) * res + x]; }
};

// sigma_t(x) = scale * density(x), sigma_s = albedo * sigma_t; the albedo is a grid or a
// constant. The medium fills the density grid's box. Majorants come from a MajorantGrid of
// `majorant_res` cells per axis over that box.
struct GridMedium {
    PlacedGrid density;
    PlacedGrid albedo_grid;  // empty: use `albedo`
    Spectrum albedo{1.0};
    PlacedGrid Le_grid;  // empty: Le = Le_scale everywhere
    Spectrum Le_scale{0.0};
    Real scale = 1;
    // 0: automatic, one cell per ~10 voxels of the density's longest axis but at least 16
    // (or one per voxel): finer cells leave shadow rays toward delta lights less to track
    // beyond the minorants (residual ratio tracking, sample_T_maj), up to where the cells'
    // own cost wins.
    int majorant_res = 0;
    MajorantGrid majorants;
    PhaseFunction phase;
};

struct SkyMap;  // sky_map.h

// A planet's air in metres (Bruneton 2017 / Hillaire 2020 model): Rayleigh and Mie
// scattering with exponential density profiles, Mie absorption, and ozone absorption
// with a tent profile. Altitude h = |p - center| - planet_radius; the medium fills the
// shell up to top_radius. Majorants come per piece of ray from the lowest altitude on
// the piece, where every profile (but ozone's, bounded separately) peaks.
struct AtmosphereMedium {
    Vec3 center;
    Real planet_radius = 6360e3, top_radius = 6420e3;
    Spectrum rayleigh_sigma_s{5.802e-6, 13.558e-6, 33.1e-6};
    Real rayleigh_height = 8e3;
    Spectrum mie_sigma_s{3.996e-6}, mie_sigma_a{0.444e-6};
    Real mie_height = 1.2e3;
    Real mie_g = 0.8;
    Spectrum ozone_sigma_a{0.650e-6, 1.881e-6, 0.085e-6};  // at the peak of the tent
    Real ozone_bottom = 10e3, ozone_peak = 25e3, ozone_top = 40e3;
    int pieces = 4;  // majorant pieces per ray segment
    // Shadow rays to the sun: optical depth to the top of the atmosphere from a table over
    // (altitude, direction) built by prepare_medium; Simpson's rule on each ray; or ratio
    // tracking (unbiased; kept for the accuracy study).
    enum class SunTransmittance { Table, Quadrature, Tracking } sun_transmittance = SunTransmittance::Table;
    // Free flights: guided by the sun along each ray (AirSegment; transmittances from the
    // table, so shadow rays must not track), or delta tracking against the pieces.
    enum class FreeFlight { Guided, Tracking } free_flight = FreeFlight::Guided;
    // Optical depth to the top, kTableR x kTableMu entries (Bruneton 2017's parametrisation:
    // x_r = rho / H, x_mu = where the distance to the top lies between its extremes).
    static constexpr int kTableR = 256, kTableMu = 256;
    // Three floats per entry (the table's error, 6e-4, dwarfs float's 6e-8; half the memory
    // of doubles keeps more of it in cache).
    std::vector<float> tau_to_top;
    // Whether the render context maps where the scene's sun's scattered light comes from,
    // for directions after scattering here and the control variates (guided free flight
    // only; RenderContext::sky_maps); off: the scene language's sky_map, for the accuracy
    // study.
    bool use_sky_map = true;

    Real altitude(const Vec3 &p) const { return length(p - center) - planet_radius; }
    // Optical depth from p along d to the top of the atmosphere, from the table; false
    // where the table does not apply (d meets the ground, p outside the shell).
    bool tabulated_tau_to_top(const Vec3 &p, const Vec3 &d, Spectrum &tau) const;
    Real ozone_profile(Real h) const;
    void densities(Real h, Real &rayleigh, Real &mie, Real &ozone) const;
    Spectrum sigma_t(Real h) const;
};

// Where the sun's light comes from, for guiding collisions in the air: the scene's first
// sun or directional light.
struct SunGuide {
    Vec3 to_sun;
    Spectrum irradiance;  // at normal incidence, above the air (NEE's L / pdf)
};

// One ray segment through the air, tabulated for the guided free flight.
//
// Collisions are drawn from a piecewise-exponential density through kNodes nodes, spaced
// quadratically away from the segment's lowest point (where the air is densest and
// changes fastest), or through its two ends where it stays level. Node weights mix, half
// and half, free flight (sigma_t T) and the sun's single scattering (sigma_s phase T T_sun):
// at sunrise the low air that free flight favours sees the sun through an optical depth of
// tens, so collisions there add almost nothing to the image. Each part is normalised per
// channel and averaged over channels (the balance heuristic over the channels' densities),
// so every channel is covered. For the weights alone, T comes from the nodes (altitude
// taken as linear between them).
//
// The estimator's transmittance comes from the table of optical depths to the top
// (AtmosphereMedium::tau_to_top): the depth from a to t along d is the difference of the
// depths to the top from a and from t (taken along -d when d meets the ground, so that
// both lookups see the sky). T within 1e-3 of an exact integral (test_atmosphere.py).
struct AirSegment {
    static constexpr int kNodes = 5;
    struct Node {
        Real t, h;                        // distance along the ray, altitude
        Real rayleigh, mie, ozone;        // densities
        Real I_rayleigh, I_mie, I_ozone;  // their integrals from the first node
        Spectrum T;                       // the transmittance from the first node they give
        Real weight;                      // collision density, up to the factor 1 / mass of the last node
        Real mass;                        // integral of the weight from the first node
        // The light the air scatters back along the ray here, times T: the sun's single
        // scattering (sigma_s phase T_sun E), and with a sky map the map's scattered light.
        Spectrum light;
    };
    const AtmosphereMedium *air = nullptr;
    Ray ray;
    bool downward = false;  // the ray meets the ground: depths are looked up along -d
    Spectrum tau_start;     // the table's depth to the top from the first node
    int n = 0;              // nodes used; 0 if the ray misses the air
    Node node[kNodes];
    Spectrum optical_depth(Real t) const;  // from the first node to t
    Spectrum transmittance(Real t) const { return exp(-optical_depth(t)); }
    // A collision distance and its density over the segment; false if nothing collides.
    bool sample(Real u, Real &t, Real &pdf) const;
    // The light scattered back along the segment, modelled from the nodes' `light` (per
    // channel, exponential between nodes, linear next to a node where it is 0), and the
    // model's exact integral over the segment: a control variate (see the integrator).
    Spectrum light_model(Real t) const;
    Spectrum light_integral() const;
    bool models_light = false;  // the nodes do not straddle the planet's shadow (the model holds)
};
// `map`: the nodes' light includes the sky map's scattered light (see SkyMap).
AirSegment air_segment(const AtmosphereMedium &m, const Ray &ray, Real t_max, const SunGuide *sun,
                       const SkyMap *map = nullptr);
// The optical depth over [ray.t_min, t_max], as air_segment's optical_depth(t_max) gives it,
// without the nodes where the table covers the segment.
Spectrum air_optical_depth(const AtmosphereMedium &m, const Ray &ray, Real t_max);

using Medium = std::variant<HomogeneousMedium, GridMedium, AtmosphereMedium>;

struct MediumProperties {
    Spectrum sigma_a, sigma_s;
    Spectrum Le{0.0};
};

bool is_emissive(const Medium &m);

inline bool is_homogeneous(const Medium &m) { return std::holds_alternative<HomogeneousMedium>(m); }
MediumProperties medium_properties(const Medium &m, const Vec3 &p);
PhaseFunction medium_phase(const Medium &m, const Vec3 &p);
void prepare_medium(Medium &m);  // computes majorants

// Pieces [t0, t1] of the ray inside which the medium may be non-empty, in order, each
// with a majorant sigma_maj >= sigma_t and a minorant sigma_min <= sigma_t. Outside them
// the medium is empty.
struct MajorantSegment {
    Real t0 = 0, t1 = 0;
    Spectrum sigma_maj, sigma_min{0.0};
};
constexpr int kMaxMajorantGridRes = 64;
constexpr int kMaxMajorantSegments = 16;  // atmosphere pieces

// Walks the majorant pieces along a ray in order, lazily: a grid's cells come from a 3D
// DDA one at a time, the air's pieces one at a time (a path that scatters early never
// pays for the rest of the ray). Nothing is listed up front: the iterator is built for
// every segment and every shadow ray.
class MajorantIterator {
public:
    MajorantIterator(const Medium &m, const Ray &ray, Real t_max);
    bool next(MajorantSegment &seg);

private:
    // Per kind of medium: where the walk starts (false: the ray misses the medium), and
    // the next piece.
    bool start(const HomogeneousMedium &);
    bool start(const GridMedium &g);
    bool start(const AtmosphereMedium &air);
    bool next(const HomogeneousMedium &h, MajorantSegment &seg);
    bool next(const GridMedium &grid, MajorantSegment &seg);
    bool next(const AtmosphereMedium &air, MajorantSegment &seg);

    const Medium *medium_ = nullptr;  // null: nothing left
    Ray ray_;
    Real t_ = 0, t_end_ = 0;  // what is left of the ray: [t_, t_end_]
    // The air: `pieces_` equal pieces of [t_start_, t_end_], the next is `piece_`.
    Real t_start_ = 0;
    int piece_ = 0, pieces_ = 0;
    // DDA state (grid media only).
    int cell_[3] = {0, 0, 0}, step_[3] = {0, 0, 0};
    Real t_next_[3] = {0, 0, 0}, t_delta_[3] = {0, 0, 0};
};

// Tentative collisions against the majorant, distances sampled in `channel` (pbrt's
// SampleT_maj). At each collision the callback gets the point, the coefficients there,
// sigma_maj and the majorant transmittance T_maj since the previous collision; it
// returns false to stop. The result is T_maj from the last collision to t_max (or 1 if
// the callback stopped the walk).
// Optical depth along [ray.t_min, t_max] by composite Simpson quadrature with `steps`
// intervals on each majorant piece (a deterministic reference for the tests).
Spectrum optical_depth(const Medium &m, const Ray &ray, Real t_max, int steps);

// Optical depth of a shadow ray toward the sun through the air over [ray.t_min, t_max]:
// from the table where the segment runs to the top of the atmosphere, else by Simpson's
// rule on each majorant piece with intervals of at most a fifth of the shortest scale height
// (relative error ~1e-5 where the density is exponential), at most kSunQuadratureSteps.
constexpr int kSunQuadratureSteps = 16;
Spectrum sun_optical_depth(const Medium &m, const Ray &ray, Real t_max);

// Majorant optical depth over [ray.t_min, t_max], per channel.
Spectrum majorant_optical_depth(const Medium &m, const Ray &ray, Real t_max);

// `forced_probability` > 0 forces a first tentative collision within the segment: it is
// the probability 1 - exp(-tau_maj) that the channel's free flight would have collided
// there, and the first distance is drawn from the flight conditioned on colliding (the
// caller weights by that probability and covers the no-collision case separately).
// The optical depth to the next collision is carried across pieces (the exponential
// distribution is memoryless, so this equals resampling at each piece).
// The first distance takes the sampler's next dimension if `stratified`, every later one
// an independent number (Sampler::independent_1d: their count varies); `first_u` >= 0
// is the first uniform itself, drawn by the caller (a stratum of the usual draw).
// `tau_min` non-null: residual tracking, for transmittance estimates (Novak et al. 2014,
// "Residual ratio tracking"). Each piece's minorant is taken out of the medium and its
// optical depth added to *tau_min, as each piece is entered: the caller applies
// exp(-tau_min) exactly, and only the residual medium, sigma_t - sigma_min (handed to the
// callback as absorption), is tracked against sigma_maj - sigma_min. Fewer tentative
// collisions, each weighting T closer to 1: where the density is smooth most of the
// optical depth is the minorant's.
template <typename Callback>
Spectrum sample_T_maj(const Medium &medium, const Ray &ray, Real t_max, int channel, Sampler &rng, Callback &&callback,
                      Real forced_probability = 0, bool stratified = true, Spectrum *tau_min = nullptr,
                      Real first_u = -1) {
    MajorantIterator pieces(medium, ray, t_max);
    MajorantSegment seg;
    // The majorant optical depth accumulates across pieces until the next tentative
    // collision, and becomes T_maj only there (or at t_max): one exponential per collision,
    // none per piece. In the sampling channel T_maj at a collision is exp(-tau) = 1 - u by
    // construction: while the majorant is grey, a collision needs no exponential at all.
    // The optical depth is -log(1 - u), not -log1p(-u): log is twice as fast, and 1 - u is exact
    // for the sampler's uniforms, multiples of 2^-32 (a forced probability scales them:
    // then it is off by 2^-53 at most, far below what any distance here resolves).
    Spectrum tau_maj(0.0);
    Real u = first_u >= 0 ? first_u : stratified ? rng.next_1d() : rng.independent_1d();
    if (forced_probability > 0) u *= forced_probability;
    Real tau = -std::log(1 - u);
    while (pieces.next(seg)) {
        if (tau_min) {
            *tau_min += seg.sigma_min * (seg.t1 - seg.t0);
            seg.sigma_maj = clamp_zero(seg.sigma_maj - seg.sigma_min);
        }
        const Real sigma_c = seg.sigma_maj[channel];
        Real t = seg.t0;
        for (;;) {
            const Real dt = sigma_c > 0 ? tau / sigma_c : kInfinity;
            if (t + dt >= seg.t1) {
                tau -= sigma_c * (seg.t1 - t);
                tau_maj += seg.sigma_maj * (seg.t1 - t);
                break;
            }
            t += dt;
            tau_maj += seg.sigma_maj * dt;
            const Spectrum T_maj = is_grey(tau_maj) ? Spectrum(1 - u) : exp(-tau_maj);
            const Vec3 p = ray.at(t);
            MediumProperties mp = medium_properties(medium, p);
            if (tau_min) mp = {mp.sigma_a + mp.sigma_s - seg.sigma_min, Spectrum(0.0), mp.Le};
            if (!callback(p, t, mp, seg.sigma_maj, T_maj)) return Spectrum(1.0);
            tau_maj = Spectrum(0.0);
            u = rng.independent_1d();
            tau = -std::log(1 - u);
        }
    }
    return exp(-tau_maj);
}

}  // namespace volpath

namespace volpath {
// Unbiased transmittance estimate by ratio tracking, distances sampled in `channel`;
// `residual`: residual ratio tracking against the minorants (see sample_T_maj).
inline Spectrum ratio_tracking(const Medium &m, const Ray &ray, Real t_max, int channel, Sampler &rng,
                               bool residual = false) {
    Spectrum T(1.0), tau_min(0.0);
    const Spectrum T_maj = sample_T_maj(
        m, ray, t_max, channel, rng,
        [&](const Vec3 &, Real, const MediumProperties &mp, const Spectrum &sigma_maj, const Spectrum &T_seg) {
            const Spectrum sigma_n = sigma_maj - mp.sigma_a - mp.sigma_s;
            T *= T_seg * sigma_n / (T_seg[channel] * sigma_maj[channel]);
            return true;
        },
        0, true, residual ? &tau_min : nullptr);
    return T * T_maj / T_maj[channel] * exp(-tau_min);
}
}  // namespace volpath
