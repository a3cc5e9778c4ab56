// The scattering tracers' path (pbrt-v4's VolPathIntegrator::Li as a struct): its state and
// the steps its loop takes, defined in volpath.cpp (the loop, surfaces, media, emission,
// roulette) and air.cpp (the guided flight through the atmosphere); next-event estimation
// is direct.h's. Private to the integrators.
#pragma once

#include <optional>

#include "common.h"
#include "sky_variates.h"

namespace volpath {

// Russian roulette keeps a path with probability min(throughput, kMaxSurvival). Near 1, so
// that long walks in dense, bright media (albedo 0.98-0.99) are not cut for nothing;
// below 1, so that a walk that loses no energy (albedo 1, closed) still ends (the choice's
// measurements, and the other constants': bench/RESULTS.md, "Constants chosen by measurement").
inline constexpr Real kMaxSurvival = 0.99;

// MIS between strategies whose channel-averaged densities are in the ratio a : b : c, with
// the power heuristic. Returns w / a, what multiplies beta * L.
inline Real mis_over_a(Real a, Real b, Real c = 0) { return a / (a * a + b * b + c * c); }

// What the scattering tracers (all but absorption, absorption.cpp) do.
struct Features {
    bool nee, mis, emission_after_scatter;
    int max_depth;
};

inline Features features_of(const TracerConfig &c) {
    Features f{};
    f.nee = c.tracer == Tracer::Single || c.tracer >= Tracer::NeeMis;
    f.mis = c.tracer >= Tracer::NeeMis;
    // Without NEE, emitters are found only by hitting them; with NEE but no MIS (single),
    // only the camera ray and specular chains may hit them, or light would count twice.
    f.emission_after_scatter = !f.nee || f.mis;
    f.max_depth = c.max_depth;
    if (c.tracer == Tracer::Single) f.max_depth = c.max_depth < 0 ? 2 : std::min(c.max_depth, 2);
    return f;
}

inline const AtmosphereMedium *guided_air(const Medium &m) {
    const auto *air = std::get_if<AtmosphereMedium>(&m);
    return air && air->free_flight == AtmosphereMedium::FreeFlight::Guided ? air : nullptr;
}

// A scattering vertex in a homogeneous medium segment, drawn by one of two distance
// strategies: free flight, or a distance drawn for one light (LightDistances).
// In homogeneous media each light has one NEE strategy: every segment that free flight
// crosses estimates a segment light from a distance drawn for it, whether or not free
// flight then collides there, and free flight's collisions estimate the environments
// (RenderContext::collision_nee_lights). Free flight's vertex also finds emitters by phase
// sampling; the power heuristic combines the two ways to each light, with the densities
// averaged over channels.
struct SegmentVertex {
    Ray ray;
    Real t_end;                 // the segment is [ray.t_min, t_end]
    Spectrum sigma_t, r_start;  // r_start: the path's r_u where the segment starts
    Real t, pdf;                // the vertex, and its density in the path's channel
    int light = -1;             // >= 0: drawn for this light, else by free flight
};

inline Real segment_light_select_pdf(const Scene &scene) { return 1.0 / Real(scene.context.segment_lights.size()); }

// Free flight's rescaled density at a vertex drawn for a light, on the scale of the r_u of
// the light's distance strategy: where phase sampling from that vertex starts.
inline Spectrum free_flight_density(const SegmentVertex &v) {
    const Spectrum T = exp(-v.sigma_t * (v.t - v.ray.t_min));
    return v.r_start * v.sigma_t * T / v.pdf;
}

// The camera's ray, until its path first scatters, is split on the scattering media it
// crosses into two estimates that add up to the usual one: a branch that crosses the
// medium's segment, weighted by its transmittance T (exact in homogeneous media, by
// residual ratio tracking in grids), and branches forced to a first tentative collision in
// it (weighted by 1 - T_maj) that count only real collisions: where delta tracking from
// there crosses the segment, the branch ends (in a sparse grid, most do; carried on, each
// would repeat the first branch's path beyond the segment). Plain free flight would pick
// one of the two at random and spend the pixel's samples on whichever the draw favoured: a
// bank of fog half transparent to the camera is then noise between what lies behind it and
// the light it scatters. Grids are split wherever the camera ray meets them, with
// kCollideBranches forced collisions in strata, their segments' only NEE; the air too, on
// each piece that fly_through_air cuts at the shapes' sun shadows, with one (beyond the
// shadows the sky's control variates hold: the forced collision's estimate is then the
// map's error alone, not the coin toss of colliding at all); other media only where the
// camera stands in them, with one (a homogeneous segment draws distances for its
// lights whether or not free flight collides: segment_direct). At most kMaxCameraSplits
// splits per camera ray (measurements: bench/RESULTS.md, "Constants chosen by measurement").
inline constexpr int kCollideBranches = 4;
inline constexpr int kMaxCameraSplits = 8;

// Which part of a camera ray's medium segment a path estimates (see above).
enum class Branch { All, PassThrough, Collide };

// Where a split segment ends, found once for all of its branches.
struct FirstHit {
    bool hit;
    Intersection its;
};

// What a step leaves to the path's loop: the ray reached the end of its segment (a surface,
// or nothing), a new ray to follow, or the end of the path.
enum class Step { Reached, NewRay, Ended };

// One path's estimate (pbrt-v4's VolPathIntegrator::Li): its state, and the steps its loop
// takes through media and at surfaces. The weights follow pbrt-v4's rescaled path
// probabilities: r_u for the path's own sampling, r_l for the light strategy's.
struct Path {
    // What the path reads.
    const Scene &scene;
    const TracerConfig &config;
    const Features feat;
    Sampler &sampler;
    const int channel;  // the colour channel that samples distances (spectral MIS)

    // The estimate so far (pbrt-v4's names): L the radiance gathered, beta the throughput
    // over the path's pdf in `channel`, r_u and r_l the rescaled pdfs of the path's own
    // sampling and of the light strategy; `gathered`, the sample's radiance from the
    // camera's other branches (drawn from streams of their own), which Russian roulette's
    // check counts with L.
    Spectrum L{0.0}, beta{1.0}, r_u{1.0}, r_l{1.0};
    Spectrum gathered{0.0};

    // Where the path is: its ray, the medium that ray travels in, and what the ray was
    // traced for.
    Ray ray;
    int medium;
    RayKind ray_kind = RayKind::Camera;
    bool specular_bounce = true;    // the camera counts as specular: nothing to MIS with
    bool scattered_in_air = false;  // the current ray's, if a Scatter ray: its event was in the air

    // The last scattering vertex: how deep, where, and what MIS with the lights there needs.
    int depth = 0;  // real scattering events so far
    Vec3 prev_p;
    // After a bounce, where a light hides from some lobes (RenderContext::lights_hide_lobes): the
    // share of the BSDF value in the ray's direction from its diffuse lobe.
    Spectrum diffuse_share{0.0};
    // The vertex, when a distance drawn for a light could have made it too: r_ld is that
    // strategy's rescaled pdf for the path since (updated like r_l), without its density at
    // the vertex, which depends on the light the path finds.
    std::optional<SegmentVertex> scattered_at;
    Spectrum r_ld{0.0};
    int null_collisions = 0, null_crossings = 0;  // safety caps' counts

    // The camera's split segments (see Branch): which part of the segment this path
    // estimates; the camera ray's medium segment it is in (counted at each change of medium
    // and each cut of the air), the last one split, and whether this path may split (the
    // forced collisions' branches do not: one split per segment and sample); a forced
    // branch's stratum of the collision probability among its segment's.
    Branch branch = Branch::All;
    int segment = 0, split_at = -1;
    bool may_split = true;
    int stratum = 0, strata = 1;

    Path(const Scene &scene, Ray ray, int medium, Sampler &sampler, const TracerConfig &config)
        : scene(scene), config(config), feat(features_of(config)), sampler(sampler),
          channel(std::min(int(sampler.next_1d() * 3), 2)), ray(ray), medium(medium), prev_p(ray.o) {}

    Spectrum trace(const FirstHit *first = nullptr);
    bool splits_segment() const;
    Spectrum split(bool hit, const Intersection &its);

    // Steps through the current medium up to t_end.
    Step fly_through_air(bool hit, const Intersection &its, Real t_end);
    enum class Flight { Crossed, Scattered, Ended };
    Flight guided_flight(const Medium &m, bool hit, const Intersection &its, Real t_end, bool clear);
    struct AirModels {
        const SkyMap *map = nullptr;
        bool light_model = false;  // the segment's scattered light as a control variate
        bool map_model = false;    // and the sky map's light past a collision
        bool predicted = false;    // shadowed air: the models only predict a collision's share
    };
    AirModels air_models(const Medium &m, bool clear) const;
    bool finds_nothing_beyond(bool hit, const Intersection &its) const;
    Real air_collision_probability(const Spectrum &tau, bool hit, const Intersection &its) const;
    Flight collide_in_air(const Medium &m, const AirSegment &seg, Real p_event, bool controlled, bool predicted);
    bool leaves_for_empty_space(bool hit, const Intersection &its) const;
    Step fly_through_medium(Real t_end);
    // Delta tracking on one segment [ray.t_min, t_end]: what its steps share.
    struct Tracking {
        Real t_end;
        bool segment_nee;       // homogeneous: NEE from distances drawn for the lights (segment_direct)
        Spectrum r_start{0.0};  // r_u where the segment starts
        Real forced = 0;        // a forced branch: the probability of a collision it stands for
        bool nee_at_tentative = false;
        ChoiceChain real_or_null;
    };
    enum class Collision { Null, Scattered, Ended };
    bool enter_branch(const Medium &m, bool homogeneous, Real t_end, Real &forced);
    void cross_without_scattering(const HomogeneousMedium &h, Real t_end);
    Step delta_track(const Medium &m, Tracking &seg);
    Collision tentative_collision(const Medium &m, Tracking &seg, const Vec3 &p, Real t, const MediumProperties &mp,
                                  const Spectrum &sigma_maj, const Spectrum &T_seg);
    // At the segment's end.
    void add_infinite_lights(const Intersection &its);
    Step at_surface(const Intersection &its);

    // Scattering and what it gathers.
    // `gathered`: its NEE is taken already (fly_through_medium's forced collisions).
    bool scatter_in_medium(const Vec3 &p, const Medium &m, const SegmentVertex *vertex = nullptr,
                           bool gathered = false);
    bool roulette_after_sky_model(const Spectrum &arriving, Real survival);
    bool roulette_by_share(const Spectrum &arriving);
    Real share_of_sample(const Spectrum &M) const;
    Real share_survival(const Spectrum &M) const;
    bool survive(Real q);
    bool roulette_toward_sky(bool hit, const Intersection &its);
    std::optional<SurfaceSky> add_sky_model_integral(const ShapeInfo &shape, const Intersection &its, const BSDF &bsdf,
                                                     const Frame &frame, const Vec3 &wi);
    bool roulette();
    Spectrum direct_in_medium(const Vec3 &p, const PhaseFunction &phase, const Spectrum &beta_p, const Spectrum &r_p,
                              const SegmentVertex *vertex, const SkyPoint *sky = nullptr);
    void segment_direct(const Medium &m, const HomogeneousMedium &h, Real t_end);
    void add_medium_emission(const MediumProperties &mp, const Spectrum &sigma_maj, const Spectrum &T_seg);
    void add_emission(const Spectrum &emitted, int light, Real pdf_light_dir);
    Spectrum shown_share(int light) const;

    // No further scattering allowed: only emitters hit by the next ray could still count.
    bool last_vertex() const { return feat.max_depth >= 0 && depth + 1 >= feat.max_depth; }
    void scale_r_l(const Spectrum &factor) {
        r_l *= factor;
        r_ld *= factor;
    }
};

}  // namespace volpath
