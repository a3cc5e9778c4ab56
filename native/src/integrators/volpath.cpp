#include <optional>
#include <stdexcept>

#include "common.h"
#include "volpath/light_distances.h"
#include "volpath/sky_map.h"

namespace volpath {

namespace {

// Russian roulette keeps a path with probability min(throughput, kMaxSurvival). Near 1, so
// that long walks in dense, bright media (albedo 0.98-0.99) are not cut for nothing;
// below 1, so that a walk that loses no energy (albedo 1, closed) still ends (the choice's
// measurements, and the other constants': bench/RESULTS.md, "Constants chosen by measurement").
constexpr Real kMaxSurvival = 0.99;

// A shadow ray whose transmittance has fallen below kShadowRouletteT at a boundary goes on
// with probability T / kShadowRouletteT (weighted up to match): from deep inside a dense
// medium, what the rest of the ray finds barely counts.
constexpr Real kShadowRouletteT = 0.05;

// MIS between strategies whose channel-averaged densities are in the ratio a : b : c, with
// the power heuristic. Returns w / a, what multiplies beta * L.
Real mis_over_a(Real a, Real b, Real c = 0) { return a / (a * a + b * b + c * c); }

// What the scattering tracers (all but absorption, absorption.cpp) do.
struct Features {
    bool nee, mis, emission_after_scatter;
    int max_depth;
};

Features features_of(const TracerConfig &c) {
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

const AtmosphereMedium *guided_air(const Medium &m) {
    const auto *air = std::get_if<AtmosphereMedium>(&m);
    return air && air->free_flight == AtmosphereMedium::FreeFlight::Guided ? air : nullptr;
}

// After scattering in guided air, a direction is drawn from the sky map (SkyMap) with this
// probability, else from the phase function; less where the map is also a control variate
// (below): its model then does most of the work that the directions drawn from it would.
constexpr Real kSkyMapShareGuide = 0.5, kSkyMapShareModel = 0.1;
// Russian roulette at every scattering event in the air where the sky map predicts what the
// path brings back: survival kSkyRouletteSurvival, and the map's prediction as a control
// variate (see scatter_in_medium): the walks are cut short, the prediction carries their rest.
constexpr Real kSkyRouletteSurvival = 0.55;
// The same roulette for a surface's bounce that escapes to the sky (Path::roulette_toward_sky).
constexpr Real kSurfaceSkySurvival = 0.3;
// Roulette by the map's predicted share of the sample (Path::roulette_by_share).
constexpr Real kShareKept = 0.1, kShareSurvival = 0.05;
// Mie's share of the map's light scattered at an event has no closed-form integral (its lobe
// is narrow, the map piecewise constant): kMieLobeSamples directions of the lobe estimate it,
// without bias, from the map alone.
constexpr int kMieLobeSamples = 2;
// The map's light a surface's bounce brings back from the air, integrated against the BSDF
// (Path::add_sky_model_integral): estimated from this many stratified BSDF directions.
constexpr int kSurfaceMapSamples = 4;
// Shifts the second coordinate of stratified samples (the golden ratio's fraction: a
// rank-1 lattice with the first).
constexpr Real kLatticeShift = 0.6180339887498949;
// A scattering event in air with a sky map: the map's point, and the phase function's
// lobes as drawn there: Rayleigh or Mie by their channel-averaged shares, so that the
// direction's density is the same in every channel and the path's return carries the
// weight the control variates give their models (the value stays per channel).
struct SkyPoint {
    const SkyMap *map;
    SkyMap::Point at;
    PhaseFunction lobes;
    Real share;  // of directions drawn from the map
    SkyPoint(const SkyMap *map, const Vec3 &p, const PhaseFunction &phase, bool models)
        : map(map), at(map->at(p)), share(models ? kSkyMapShareModel : kSkyMapShareGuide) {
        const auto &air = std::get<RayleighMiePhase>(phase);
        lobes = RayleighMiePhase{Spectrum(average(air.rayleigh_fraction)), air.g};
    }
    // The density of d under the mixture of the map and the lobes.
    Spectrum pdf(const Vec3 &d_in, const Vec3 &d) const {
        return phase_pdf(lobes, dot(d_in, d)) * (1 - share) + Spectrum(share * map->pdf(at, d));
    }
};

// Whether a shadow ray to `light` crosses `m` with a deterministic transmittance: any
// light through guided air, else the sun through air whose sun transmittance is not set
// to ratio tracking.
bool deterministic_through_air(const Light &light, const Medium &m) {
    const auto *air = std::get_if<AtmosphereMedium>(&m);
    return air && (guided_air(m) ||
                   (air->sun_transmittance != AtmosphereMedium::SunTransmittance::Tracking &&
                    (std::holds_alternative<SunLight>(light) || std::holds_alternative<DirectionalLight>(light))));
}

// Whether a ray that escapes the scene can only find `light` there: the scene is lit at
// infinity by suns alone. The guided free flight makes every ray that would leave the air
// for empty space collide in it instead (a sun's disc seen from the air is NEE's alone).
bool leads_to_suns_only(const Scene &scene, const Light &light) {
    return std::holds_alternative<SunLight>(light) && !scene.context.has_environment;
}

// A scattering vertex in a homogeneous medium segment, drawn by one of two distance
// strategies: free flight, or a distance drawn for one light (LightDistances).
// In homogeneous media each light has one NEE strategy: every segment that free flight
// crosses estimates a segment light from a distance drawn for it, whether or not free
// flight then collides there, and free flight's collisions estimate the environments
// (Scene::collision_nee_lights). Free flight's vertex also finds emitters by phase
// sampling; the power heuristic combines the two ways to each light, with the densities
// averaged over channels.
struct SegmentVertex {
    Ray ray;
    Real t_end;                 // the segment is [ray.t_min, t_end]
    Spectrum sigma_t, r_start;  // r_start: the path's r_u where the segment starts
    Real t, pdf;                // the vertex, and its density in the path's channel
    int light = -1;             // >= 0: drawn for this light, else by free flight
};

Real segment_light_select_pdf(const Scene &scene) { return 1.0 / Real(scene.context.segment_lights.size()); }

// Free flight's rescaled density at a vertex drawn for a light, on the scale of the r_u of
// the light's distance strategy: where phase sampling from that vertex starts.
Spectrum free_flight_density(const SegmentVertex &v) {
    const Spectrum T = exp(-v.sigma_t * (v.t - v.ray.t_min));
    return v.r_start * v.sigma_t * T / v.pdf;
}

// What a shadow ray gathers on its way to the light: its transmittance, and the rescaled
// pdfs of the light strategy (r_l) and of the path's own (r_u) that its tracking updates
// (pbrt-v4's SampleLd), so that the MIS weights match those computed when the same path is
// found by phase or BSDF sampling.
struct Shadow {
    Spectrum T{1.0}, r_l{1.0}, r_u{1.0};
    bool left_guided_air = false;  // the last crossing led from guided air into vacuum
};

// The shadow ray's segment [ray.t_min, t_end] through medium m. False: nothing gets through.
bool attenuate(const Medium &m, const Ray &ray, Real t_end, const Light &light, bool delta_light, int channel,
               Sampler &sampler, Shadow &s) {
    if (is_homogeneous(m)) {
        // Closed form. Phase sampling would have to fly through without colliding, unless
        // the medium only absorbs, where both strategies apply T in closed form.
        const auto &h = std::get<HomogeneousMedium>(m);
        const Spectrum T = exp(-(h.sigma_a + h.sigma_s) * (t_end - ray.t_min));
        s.T *= T;
        if (!is_black(h.sigma_s)) s.r_u *= T;
    } else if (deterministic_through_air(light, m)) {
        // Toward the sun through the air, T from a table (or by quadrature): at sunrise the
        // shadow ray crosses an optical depth of tens, where ratio tracking's estimate is
        // mostly noise. The error is the table's: T within 6e-4 of an exact integral
        // (tests/native/test_atmosphere.py). For the MIS weights, the phase strategy's
        // chance to fly through: T per channel under delta tracking, the channel average
        // under the guided free flight, which decides for all channels at once.
        const Spectrum T = exp(-sun_optical_depth(m, ray, t_end));
        s.T *= T;
        s.r_u *= guided_air(m) ? Spectrum(average(T)) : T;
    } else {
        // Ratio tracking. Toward a delta light, which no other strategy finds (no MIS, so
        // r_u is not needed), residual ratio tracking: the minorants' share of the optical
        // depth is exact, only the rest is tracked.
        Spectrum tau_min(0.0), tau_seen(0.0), T_min(1.0);
        const Spectrum T_maj = sample_T_maj(
            m, ray, t_end, channel, sampler,
            [&](const Vec3 &, Real, const MediumProperties &mp, const Spectrum &sigma_maj, const Spectrum &T_seg) {
                const Spectrum sigma_n = clamp_zero(sigma_maj - mp.sigma_a - mp.sigma_s);
                const Real pdf = T_seg[channel] * sigma_maj[channel];
                s.T *= T_seg * sigma_n / pdf;
                s.r_l *= T_seg * sigma_maj / pdf;
                s.r_u *= T_seg * sigma_n / pdf;
                // Russian roulette on a transmittance estimate that got small (the
                // minorants' part so far included: one exp per piece entered).
                if (!(tau_min == tau_seen)) T_min = exp(-tau_min), tau_seen = tau_min;
                const Spectrum Tr = s.T * T_min / average(s.r_l + s.r_u);
                if (max_component(Tr) < 0.05) {
                    if (sampler.independent_1d() < 0.75)
                        s.T = Spectrum(0.0);
                    else
                        s.T /= 0.25;
                }
                return !is_black(s.T);
            },
            /*forced_probability=*/0, /*stratified=*/false, delta_light ? &tau_min : nullptr);
        const Real pdf = T_maj[channel];
        if (!(pdf > 0)) return false;
        s.T *= T_maj / pdf * exp(-tau_min);
        s.r_l *= T_maj / pdf;
        s.r_u *= T_maj / pdf;
    }
    return !is_black(s.T);
}

// The probability that a shadow ray passes the surface it hit: 1 through a null boundary or
// a shape hidden from shadow rays, a mask's chance to let it through, else 0. The path
// through a mask would have had to draw that chance: both T and r_u take it.
Real shadow_pass(const Scene &scene, const Intersection &its) {
    const int bsdf = scene.shapes[its.shape].bsdf;
    const BSDF &b = scene.bsdfs[size_t(bsdf)];
    if (is_null(b) || scene.shapes[its.shape].hides_from(RayKind::Shadow)) return 1;
    return is_layered(b) ? surface_pass(scene, bsdf, scene.geometry.uv(its)) : 0;
}

// Traces the shadow ray (its t_max: the distance to the light) through index-matched
// boundaries, masks and media, starting in medium `current`. False: occluded (nothing to
// estimate, and no tracking paid for on the way there), or ended by Russian roulette.
bool trace_shadow(const Scene &scene, Ray ray, int current, const Light &light, bool delta_light, int channel,
                  Sampler &sampler, Shadow &s) {
    Real remaining = ray.t_max;
    for (int crossing = 0;; ++crossing) {
        if (crossing > kMaxNullCrossings) return false;
        Intersection its;
        if (scene.context.shadows_stop_at_any_hit && scene.geometry.occluded(ray)) return false;
        const bool hit = !scene.context.shadows_stop_at_any_hit && scene.intersect(ray, its, current);
        if (hit) {
            const Real pass = shadow_pass(scene, its);
            if (pass == 0) return false;
            if (pass < 1) s.T *= pass, s.r_u *= pass;
        }
        const Real t_end = hit ? its.t : ray.t_max;
        if (current >= 0 && !attenuate(scene.media[current], ray, t_end, light, delta_light, channel, sampler, s))
            return false;
        if (!hit) return true;
        const ShapeInfo &shape = scene.shapes[its.shape];
        const int next = medium_after_crossing(shape, ray.d, its.n, current);
        s.left_guided_air = next < 0 && current >= 0 && guided_air(scene.media[current]);
        current = next;
        remaining -= its.t;
        ray = spawn_ray(its.p, its.n, ray.d, remaining);
        // Russian roulette before tracing on, where the transmittance so far is small.
        if (const Real T_max = max_component(s.T); T_max < kShadowRouletteT) [[unlikely]] {
            if (!(sampler.independent_1d() * kShadowRouletteT < T_max)) return false;
            s.T *= kShadowRouletteT / T_max;
        }
    }
}

// Next-event estimation from a scattering point: choose a light (uniformly among
// Scene::mis_nee_lights under MIS, else among all lights; on medium segments see `vertex`),
// sample a point on it and trace a shadow ray through index-matched boundaries and media.
// `eval(d, hidden_lobes)` returns the scattering value f (times the cosine, for surfaces; of
// the lobes the light does not hide from, kLobeRays bits), `pdf(d)` the
// density of sampling d per channel: asked for only where phase or BSDF sampling could
// find the light too (MIS). r_p is the path's rescaled unidirectional pdf.
// `vertex`: the point is a SegmentVertex: drawn for its light, or free flight's collision,
// which chooses among Scene::collision_nee_lights (see SegmentVertex).
template <typename Eval, typename Pdf>
Spectrum sample_direct(const Scene &scene, const Vec3 &p, const Vec3 &n, const ShapeInfo *surface, int medium,
                       const Spectrum &beta, const Spectrum &r_p, int channel, bool mis, Sampler &sampler, Eval &&eval,
                       Pdf &&pdf, const SegmentVertex *vertex = nullptr) {
    // No weight (an empty voxel under a majorant cell's peak): no shadow ray to pay for.
    if (is_black(beta)) return Spectrum(0.0);
    const bool toward_light = vertex && vertex->light >= 0, collision = vertex && !toward_light;
    int light = toward_light ? vertex->light : -1;
    Real select = toward_light ? segment_light_select_pdf(scene) : 0;
    if (!toward_light) {
        const std::vector<int> *choice =
            collision ? &scene.context.collision_nee_lights[mis] : (mis ? &scene.context.mis_nee_lights : nullptr);
        const int n = int(choice ? choice->size() : scene.lights.size());
        if (n == 0) return Spectrum(0.0);
        const int i = std::min(int(sampler.next_1d() * n), n - 1);
        light = choice ? (*choice)[size_t(i)] : i;
        select = 1.0 / Real(n);
    }
    if (!surface && scene.light_hides_from(light, RayKind::Scatter)) return Spectrum(0.0);
    // A light that casts no shadow: nothing to trace toward it, and nothing to weigh NEE
    // against (Path::add_emission leaves it to NEE).
    const bool unshadowed = scene.light_hides_from(light, RayKind::Shadow);
    LightSample ls;
    if (!sample_light(scene.lights[light], scene.geometry, p, sampler.next_2d(), ls) || !(ls.pdf > 0) || is_black(ls.L))
        return Spectrum(0.0);
    const Spectrum f = eval(ls.d, surface ? uint8_t(scene.light_hidden_from[size_t(light)] & kLobeRays) : uint8_t(0));
    if (is_black(f)) return Spectrum(0.0);

    Shadow shadow;
    const Ray ray = spawn_ray(p, n, ls.d, std::isfinite(ls.dist) ? ls.dist * (1 - 1e-7) : kInfinity);
    const int start = surface ? medium_after_crossing(*surface, ls.d, n, medium) : medium;
    if (!unshadowed && !trace_shadow(scene, ray, start, scene.lights[light], ls.delta, channel, sampler, shadow))
        return Spectrum(0.0);

    // Rays that leave guided air for nothing but suns never get there by phase sampling.
    if (shadow.left_guided_air && leads_to_suns_only(scene, scene.lights[light])) shadow.r_u = Spectrum(0.0);
    // Phase sampling would start from free flight's vertex.
    const Spectrum r_l = shadow.r_l * (r_p * (select * ls.pdf));
    const Real r_scatter = ls.delta || !mis || unshadowed || is_black(shadow.r_u)
                               ? 0.0
                               : average(shadow.r_u * (toward_light ? free_flight_density(*vertex) : r_p) * pdf(ls.d));
    return beta * f * shadow.T * ls.L * mis_over_a(average(r_l), r_scatter);
}

}  // namespace

void check_tracer_supports(const Scene &scene, Tracer tracer) {
    // The absorption tracer crosses any medium by ratio tracking; the scattering tracers
    // before null scattering sample free flights in homogeneous media only.
    if (tracer == Tracer::NullScattering || tracer == Tracer::Absorption) return;
    for (size_t i = 0; i < scene.media.size(); ++i) {
        if (!is_homogeneous(scene.media[i]))
            throw std::invalid_argument(
                "medium " + std::to_string(i) +
                " is heterogeneous: only the absorption and null_scattering tracers render heterogeneous media");
    }
}

namespace {

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
constexpr int kCollideBranches = 4;
constexpr int kMaxCameraSplits = 8;

// The sky map's light arriving at a surface's point from directions that stay in the air it
// reflects into (none from the others): the model of Path::add_sky_model_integral.
struct SurfaceSky {
    const SkyMap *map;
    SkyMap::Point at;
    const ShapeInfo *shape;
    Vec3 n;
    int medium;
    Spectrum arriving(const Vec3 &d) const {
        return medium_after_crossing(*shape, d, n, medium) == medium ? map->radiance(at, d) : Spectrum(0.0);
    }
};

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
    const Scene &scene;
    const TracerConfig &config;
    const Features feat;
    Sampler &sampler;
    Ray ray;
    int medium;
    Branch branch;
    // The sample's radiance from the camera's other branches (drawn from streams of their
    // own), which Russian roulette's check counts with the path's L.
    Spectrum gathered{0.0};
    Spectrum L{0.0}, beta{1.0}, r_u{1.0}, r_l{1.0};
    const int channel;
    int depth = 0;                       // real scattering events so far
    bool specular_bounce = true;         // the camera counts as specular: nothing to MIS with
    RayKind ray_kind = RayKind::Camera;  // what the current ray was traced for
    bool scattered_in_air = false;       // the current ray's, if a Scatter ray: its event was in the air
    // After a bounce, where a light hides from some lobes (Scene::lights_hide_lobes): the
    // share of the BSDF value in the ray's direction from its diffuse lobe.
    Spectrum diffuse_share{0.0};
    Vec3 prev_p;
    int null_collisions = 0, null_crossings = 0;
    // The last scattering vertex, when a distance drawn for a light could have made it too:
    // r_ld is that strategy's rescaled pdf for the path since (updated like r_l), without
    // its density at the vertex, which depends on the light the path finds.
    std::optional<SegmentVertex> scattered_at;
    Spectrum r_ld{0.0};
    // The camera ray's medium segments: the one the path is in (counted at each change of
    // medium and each cut of the air), the last one split, and whether this path may split
    // (the forced collisions' branches do not: one split per segment and sample).
    int segment = 0, split_at = -1;
    bool may_split = true;
    // A forced branch's index among its segment's: the stratum of the collision
    // probability that its forced collision is drawn in.
    int stratum = 0, strata = 1;

    Path(const Scene &scene, Ray ray, int medium, Sampler &sampler, const TracerConfig &config)
        : scene(scene), config(config), feat(features_of(config)), sampler(sampler), ray(ray), medium(medium),
          branch(Branch::All), channel(std::min(int(sampler.next_1d() * 3), 2)), prev_p(ray.o) {}

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

Spectrum Path::trace(const FirstHit *first) {
    for (;;) {
        Intersection its;
        bool hit;
        if (first) {
            hit = first->hit, its = first->its;
            first = nullptr;
        } else {
            hit = scene.intersect(ray, its, medium);
        }
        if (medium >= 0 && splits_segment()) return split(hit, its);
        if (!roulette_toward_sky(hit, its)) return L;
        const Real t_end = hit ? its.t : ray.t_max;
        if (medium >= 0) {
            const Step step =
                guided_air(scene.media[medium]) ? fly_through_air(hit, its, t_end) : fly_through_medium(t_end);
            if (step == Step::Ended) return L;
            if (step == Step::NewRay) continue;
        }
        if (!hit) {
            add_infinite_lights(its);
            return L;
        }
        const Step step = at_surface(its);
        if (step == Step::Ended) return L;
    }
}

bool Path::splits_segment() const {
    if (!may_split || split_at == segment || segment >= kMaxCameraSplits || depth > 0 || ray_kind != RayKind::Camera)
        return false;
    const Medium &m = scene.media[medium];
    if (segment != 0 && !std::holds_alternative<GridMedium>(m) && !guided_air(m)) return false;
    const auto *h = std::get_if<HomogeneousMedium>(&m);
    return !(h && is_black(h->sigma_s));
}

// Splits the segment that ends at `its` (see Branch): this path crosses it, then copies of
// its state at the split, each on a stream of its own, are forced to collide.
Spectrum Path::split(bool hit, const Intersection &its) {
    split_at = segment;
    const FirstHit first{hit, its};
    Path collide = *this;
    collide.may_split = false;
    collide.branch = Branch::Collide;
    collide.L = Spectrum(0.0);
    const int branches = std::holds_alternative<GridMedium>(scene.media[medium]) ? kCollideBranches : 1;
    const Sampler at_split = sampler;
    branch = Branch::PassThrough;
    const Spectrum through = trace(&first);
    Spectrum collided(0.0);
    for (int k = 0; k < branches; ++k) {
        Path path = collide;
        path.stratum = k, path.strata = branches;
        path.gathered = gathered + through + collided / Real(branches);
        sampler = at_split.split(uint64_t(segment * kCollideBranches + k));
        collided += path.trace(&first);
    }
    return through + collided / Real(branches);
}

// Medium emission sigma_a Le at a tentative collision, found with density
// T_seg sigma_maj (pbrt-v4): only path sampling finds it, so its weight is 1 / r_e.
void Path::add_medium_emission(const MediumProperties &mp, const Spectrum &sigma_maj, const Spectrum &T_seg) {
    if (is_black(mp.Le) || (feat.max_depth >= 0 && depth >= feat.max_depth)) return;
    const Real pdf = T_seg[channel] * sigma_maj[channel];
    const Spectrum r_e = r_u * sigma_maj * T_seg / pdf;
    if (pdf > 0 && average(r_e) > 0) L += beta * T_seg / pdf * mp.sigma_a * mp.Le / average(r_e);
}

// The share of the last bounce's BSDF value in the ray's direction from the lobes `light`
// does not hide from. Found by the path, the light then lights what NEE's evaluation of
// those lobes lights, under the same MIS weights (bsdf_pdf is all lobes' density for both).
Spectrum Path::shown_share(int light) const {
    const uint8_t hidden = scene.light_hidden_from[size_t(light)];
    auto shown = [&](RayKind lobe) { return (hidden & uint8_t(lobe)) ? 0.0 : 1.0; };
    if (ray_kind == RayKind::Transmission) return Spectrum(shown(RayKind::Transmission));
    return diffuse_share * shown(RayKind::Diffuse) + (Spectrum(1.0) - diffuse_share) * shown(RayKind::Glossy);
}

// Emission of `light` found by following the path: weighted against NEE from both
// distance strategies where they can find it.
void Path::add_emission(const Spectrum &emitted, int light, Real pdf_light_dir) {
    if (is_black(emitted)) return;
    // Scene::light_hidden_from: a light hidden from scattered rays; one that casts no
    // shadow, which NEE alone finds wherever it can.
    if (ray_kind == RayKind::Scatter && scene.light_hides_from(light, RayKind::Scatter)) return;
    if (feat.nee && !specular_bounce && scene.light_hides_from(light, RayKind::Shadow)) return;
    const Spectrum Le =
        scene.context.lights_hide_lobes && (uint8_t(ray_kind) & kLobeRays) ? emitted * shown_share(light) : emitted;
    if (specular_bounce) {
        L += beta * Le / average(r_u);
    } else if (feat.emission_after_scatter) {
        if (!feat.mis) {
            L += beta * Le / average(r_u);
        } else {
            // After a collision in a homogeneous medium, NEE finds segment lights from
            // the segment's distance, environments from the collision (SegmentVertex).
            Real r_light_distance = 0;
            if (scattered_at) {
                const SegmentVertex &v = *scattered_at;
                r_light_distance =
                    average(r_ld * light_distance_density(scene.lights[light], v.ray, v.t_end, v.sigma_t, v.t) *
                            (segment_light_select_pdf(scene) * pdf_light_dir));
            }
            const Real select =
                scattered_at ? scene.collision_light_select_pdf(light, true) : scene.light_select_pdf(light, true);
            const Spectrum r_light = r_l * (select * pdf_light_dir);
            L += beta * Le * mis_over_a(average(r_u), average(r_light), r_light_distance);
        }
    }
}

// NEE from a point in a medium, reached along ray.d with weight beta_p; `sky`: the
// directions after scattering there mix in the sky map's.
Spectrum Path::direct_in_medium(const Vec3 &p, const PhaseFunction &phase, const Spectrum &beta_p, const Spectrum &r_p,
                                const SegmentVertex *vertex, const SkyPoint *sky) {
    return sample_direct(
        scene, p, Vec3(0.0), nullptr, medium, beta_p, r_p, channel, feat.mis, sampler,
        [&](const Vec3 &d, uint8_t) { return phase_eval(phase, dot(ray.d, d)); },
        [&](const Vec3 &d) { return sky ? sky->pdf(ray.d, d) : phase_pdf(phase, dot(ray.d, d)); }, vertex);
}

// The segment lights of the homogeneous segment [ray.t_min, t_end] that free flight is
// about to sample: NEE from the distances drawn for one of them (SegmentVertex).
void Path::segment_direct(const Medium &m, const HomogeneousMedium &h, Real t_end) {
    const int n = int(scene.context.segment_lights.size());
    const int light = scene.context.segment_lights[std::min(int(sampler.next_1d() * n), n - 1)];
    const Spectrum sigma_t = h.sigma_a + h.sigma_s;
    if (!(t_end > ray.t_min)) return;
    const LightDistances distances(scene.lights[light], ray, t_end, sigma_t);
    for (int k = 0; k < distances.count; ++k) {
        Real t;
        // The second distance is drawn on some segments only: an independent number.
        if (!distances.sample(k, k == 0 ? sampler.next_1d() : sampler.independent_1d(), channel, t)) continue;
        const Spectrum density = distances.density(t);
        if (!(density[channel] > 0)) continue;
        const SegmentVertex vertex{ray, t_end, sigma_t, r_u, t, density[channel], light};
        const Vec3 p = ray.at(t);
        const Spectrum beta_p = beta * exp(-sigma_t * (t - ray.t_min)) * h.sigma_s / density[channel];
        L += direct_in_medium(p, medium_phase(m, p), beta_p, r_u * density / density[channel], &vertex);
    }
}

// A real scattering event at p in medium m, beta already weighted for reaching it:
// NEE, then phase sampling of the next ray and Russian roulette. False: the path ends.
bool Path::scatter_in_medium(const Vec3 &p, const Medium &m, const SegmentVertex *vertex, bool gathered) {
    ++depth;
    const PhaseFunction phase = medium_phase(m, p);
    const SkyMap *map = scene.sky_map(medium);
    const bool models = map && map->models_light && feat.nee && scene.air_models_hold(p);
    const std::optional<SkyPoint> sky = map ? std::optional<SkyPoint>(SkyPoint(map, p, phase, models)) : std::nullopt;
    if (feat.nee) {
        if (!gathered && (!vertex || !scene.context.collision_nee_lights[feat.mis].empty()))
            L += direct_in_medium(p, phase, beta, r_u, vertex, sky ? &*sky : nullptr);
        // Nothing left that the path could find?
        if (!feat.emission_after_scatter || (last_vertex() && !scene.has_hittable_emitters())) return false;
    }
    const Real u_lobe = sampler.next_1d();
    PhaseSample ps;
    if (!sky) {
        ps = phase_sample(phase, ray.d, sampler.next_2d(), u_lobe, channel);
    } else {
        Real pdf_map;
        ps.d_out = u_lobe < sky->share ? map->sample(sky->at, sampler.next_2d(), u_lobe / sky->share, pdf_map)
                                       : phase_sample(sky->lobes, ray.d, sampler.next_2d(),
                                                      (u_lobe - sky->share) / (1 - sky->share), channel)
                                             .d_out;
        ps.value = phase_eval(phase, dot(ray.d, ps.d_out));
        ps.pdf = sky->pdf(ray.d, ps.d_out);
    }
    const Real pdf_c = ps.pdf[channel];
    if (!(pdf_c > 0)) return false;
    const bool sky_model = models && !last_vertex();
    // The map's light scattered here as a control variate: its integral over directions,
    // less its value in the direction drawn (the path then brings the light that truly
    // arrives from there). Rayleigh's share integrates exactly (SkyMap::rayleigh_integral);
    // Mie's by an unbiased estimate from the map alone: directions of its lobe (drawn
    // like Henyey-Greenstein's, stratified, from one 2D sample), independent of d_out.
    const Spectrum arriving = sky_model ? map->radiance(sky->at, ps.d_out) : Spectrum(0.0);
    if (sky_model) {
        const auto &air = std::get<RayleighMiePhase>(phase);
        const Spectrum &rayleigh = air.rayleigh_fraction, mie = Spectrum(1.0) - rayleigh;
        const Vec2 u = sampler.next_2d();
        const Frame forward(ray.d);
        Spectrum mie_integral(0.0);
        for (int k = 0; k < kMieLobeSamples; ++k) {
            const Real mu = hg_sample_mu(air.g, (k + u.x) / kMieLobeSamples), sin_theta = safe_sqrt(1 - mu * mu);
            const Real phi = 2 * kPi * std::fmod(u.y + k * kLatticeShift, 1.0);
            const Vec3 w = forward.to_world({sin_theta * std::cos(phi), sin_theta * std::sin(phi), mu});
            mie_integral += map->radiance(sky->at, w) * (cornette_shanks_eval(air.g, mu) / hg_eval(air.g, mu));
        }
        const Real mu = dot(ray.d, ps.d_out);
        const Spectrum integral =
            rayleigh * map->rayleigh_integral(sky->at, ray.d) + mie * mie_integral / Real(kMieLobeSamples);
        const Spectrum value = (rayleigh * rayleigh_eval(mu) + mie * cornette_shanks_eval(air.g, mu)) * arriving;
        L += beta * (integral - value / pdf_c) / average(r_u);
    }
    // Lobe mixtures make the direction's pdf differ per channel.
    beta *= ps.value / pdf_c;
    r_l = r_u / pdf_c;
    r_u *= ps.pdf / pdf_c;
    if (vertex) {
        scattered_at = *vertex;
        r_ld = vertex->r_start / (vertex->pdf * pdf_c);
    } else {
        scattered_at.reset();
    }
    prev_p = p;
    specular_bounce = false;
    ray_kind = RayKind::Scatter;
    scattered_in_air = map != nullptr;
    null_crossings = 0;
    ray = Ray{p, ps.d_out, 0, kInfinity};
    if (sky_model) return roulette_after_sky_model(arriving, kSkyRouletteSurvival);
    return map && feat.nee ? roulette_by_share(map->radiance(sky->at, ps.d_out)) : roulette();
}

// The largest share over channels that light M, still to come, would have of the sample's
// radiance with it (0 where M is 0).
Real Path::share_of_sample(const Spectrum &M) const {
    Real share = 0;
    for (int c = 0; c < 3; ++c)
        if (M[c] > 0) share = std::max(share, M[c] / (std::max(gathered[c] + L[c], 0.0) + M[c]));
    return share;
}

// Where the map models what the path brings back from its new direction, M, roulette uses
// it as a control variate: M if the path ends here, M (1 - 1/q) and the path's light over q
// if it goes on. Survival at least M / (L + M) per channel, so that neither takes the
// sample's radiance so far below zero.
bool Path::roulette_after_sky_model(const Spectrum &arriving, Real survival) {
    const Spectrum M = beta * arriving / average(r_u);
    const Real q = std::max(survival, share_of_sample(M));
    if (!(sampler.next_1d() < q)) {
        L += M;
        return false;
    }
    L += M * (1 - 1 / q);
    beta /= q;
    return true;
}

// A ray off a surface, or scattered in a medium other than the air (a fog bank in it), that
// meets no shape but the air's top brings back the sky, which the map predicts where the sun
// alone lights the scene: roulette with that prediction as a control variate, as after
// scattering in the air, from the first bounce on (terrain's sky light is mostly its first
// bounce's). Before the flight through the air, where the cost is.
bool Path::roulette_toward_sky(bool hit, const Intersection &its) {
    const bool bounced = (uint8_t(ray_kind) & kLobeRays) || (ray_kind == RayKind::Scatter && !scattered_in_air);
    if (medium < 0 || specular_bounce || !bounced || !scene.context.sun_alone_under_mis) return true;
    const SkyMap *map = scene.sky_map(medium);
    if (!map || !map->models_light || !feat.nee || (feat.max_depth >= 0 && depth + 2 >= feat.max_depth) ||
        (hit && !leaves_for_empty_space(hit, its)))
        return true;
    return roulette_after_sky_model(map->radiance(map->at(ray.o), ray.d), kSurfaceSkySurvival);
}

// Where the map models what a surface's bounce brings back from the air (the sun alone, the
// bounce into the air the map is of), it is a control variate for the bounce: its integral
// against the BSDF is added here, estimated from kSurfaceMapSamples stratified BSDF
// directions, and at_surface takes off its value in the direction the path then takes, from
// which the path brings what truly arrives (roulette_toward_sky adds the value back where it
// ends the path before the air). Added before the path's own direction is drawn, which may
// fail (below a glossy surface's horizon): the value taken off counts that failure as the
// integral's samples do. Under an open sky the bounce's noise is then the map's error alone,
// not the sky's brightness over the directions (the sun's aureole, the horizon's band).
std::optional<SurfaceSky> Path::add_sky_model_integral(const ShapeInfo &shape, const Intersection &its,
                                                       const BSDF &bsdf, const Frame &frame, const Vec3 &wi) {
    if (medium < 0 || !feat.nee || !scene.context.sun_alone_under_mis || is_delta(bsdf) ||
        (feat.max_depth >= 0 && depth + 2 >= feat.max_depth))
        return std::nullopt;
    const SkyMap *map = scene.sky_map(medium);
    if (!map || !map->models_light) return std::nullopt;
    const SurfaceSky sky{map, map->at(its.p), &shape, its.n, medium};
    const Vec2 u = sampler.next_2d();
    const Real u_lobe = sampler.next_1d();
    Spectrum integral(0.0);
    for (int k = 0; k < kSurfaceMapSamples; ++k) {
        const Vec2 u_k{(k + u.x) / kSurfaceMapSamples, std::fmod(u.y + k * kLatticeShift, 1.0)};
        BSDFSample s;
        if (bsdf_sample(bsdf, wi, std::fmod(u_lobe + Real(k) / kSurfaceMapSamples, 1.0), u_k, s))
            integral += s.weight * sky.arriving(frame.to_world(s.wo));
    }
    L += beta * integral / (kSurfaceMapSamples * average(r_u));
    return sky;
}

// Where the map's prediction of what the path brings back, M, is no control variate (local
// shapes may shadow the air), it still tells how much the rest of the walk can add to the
// sample: the walk goes on surely where M is at least kShareKept of the sample's radiance with
// it, else with probability M / (kShareKept (L + M)) in the likeliest channel, and at least
// kShareSurvival. Cuts the camera's forced collisions in a few metres of air before
// terrain: their walks weigh ~1e-4 of what the terrain shows.
bool Path::roulette_by_share(const Spectrum &arriving) {
    const Real q = share_survival(beta * arriving / average(r_u));
    return q >= 1 ? roulette() : survive(q);
}

// The survival probability above for light M still to come, on the sample's scale.
Real Path::share_survival(const Spectrum &M) const { return std::max(share_of_sample(M) / kShareKept, kShareSurvival); }

// Russian roulette on the channel-averaged throughput.
bool Path::roulette() {
    if (depth < config.rr_depth) return true;
    return survive(std::min(max_component(beta / average(r_u)), kMaxSurvival));
}

// Goes on with probability q (surely where q >= 1), beta weighted to match.
bool Path::survive(Real q) {
    if (q >= 1) return true;
    if (!(sampler.next_1d() < q)) return false;
    beta /= q;
    return true;
}

// Through the guided air. Where the scene's own shapes may shadow the sun from the segment,
// the air's light models do not hold: the segment is cut where that starts or ends, and
// each piece is flown on its own (free flight is memoryless), the models serving as
// control variates on the clear pieces alone.
Step Path::fly_through_air(bool hit, const Intersection &its, Real t_end) {
    Real t_piece = t_end;
    bool clear = scene.context.sun_alone_under_mis;
    if (clear && scene.context.local_bounds.valid()) {
        const Real eps = 1e-9 * (1 + std::abs(ray.t_min) + std::abs(t_end));
        const auto [a, b] = scene.local_sun_shadow(ray, ray.t_min, t_end);
        if (a <= b && b > ray.t_min + eps) {
            if (a > ray.t_min + eps)
                t_piece = a;  // clear up to the shadow
            else
                clear = false, t_piece = b;  // shadowed up to its end
        }
    }
    const bool cut = t_piece < t_end;
    const Flight flight = guided_flight(scene.media[medium], hit && !cut, its, t_piece, clear);
    if (flight == Flight::Ended) return Step::Ended;
    if (flight == Flight::Scattered) return Step::NewRay;
    if (cut) {
        ray.t_min = t_piece;
        ++segment;
        return Step::NewRay;
    }
    return Step::Reached;
}

// Whether the ray leaves the air for empty space at `its` (where, under suns alone, only
// a sun's disc could be found).
bool Path::leaves_for_empty_space(bool hit, const Intersection &its) const {
    if (!hit || scene.context.has_environment || !is_null(scene.bsdfs[scene.shapes[its.shape].bsdf]) ||
        medium_after_crossing(scene.shapes[its.shape], ray.d, its.n, medium) >= 0)
        return false;
    Intersection beyond;
    return !scene.intersect(spawn_ray(its.p, its.n, ray.d), beyond);
}

// The guided free flight through the air (AirSegment): pass through or collide with a
// probability shared by all channels (the camera's first segment does both, see
// radiance()); collisions are drawn along the segment toward where the sun's light
// scatters, weighted with the table's transmittance. `hit`: the segment ends at the
// surface `its` (else at a cut, or nowhere); `clear`: the air's light models hold along it.
Path::Flight Path::guided_flight(const Medium &m, bool hit, const Intersection &its, Real t_end, bool clear) {
    const AirModels models = air_models(m, clear);
    // The camera's pass-through branch only looks for what lies beyond: if that is empty
    // space and no sun's disc, nothing (sky pixels, most of a sky's image).
    if (branch == Branch::PassThrough && finds_nothing_beyond(hit, its)) return Flight::Ended;
    // The sun's lookups for the guide serve only a collision and the control variate: the
    // camera's pass-through branch needs T alone, and without the control variate they wait
    // until free flight has chosen to collide (most short segments between shapes do not).
    const AtmosphereMedium &air = *guided_air(m);
    const bool guide_now = branch == Branch::Collide || (branch == Branch::All && models.light_model);
    AirSegment seg;
    if (guide_now)
        seg = air_segment(air, ray, t_end, scene.sun_guide(),
                          models.map_model || models.predicted ? models.map : nullptr);
    const Spectrum tau = guide_now ? seg.optical_depth(t_end) : air_optical_depth(air, ray, t_end), T = exp(-tau);
    const Real p_collide = air_collision_probability(tau, hit, its);
    const bool controlled = models.light_model && p_collide > 0 && seg.models_light;
    if (controlled) L += beta * seg.light_integral() / average(r_u);
    bool collide = branch == Branch::Collide;
    Real p_event = 1;
    if (branch == Branch::All) {
        collide = sampler.next_1d() < p_collide;
        p_event = collide ? p_collide : average(T);
    }
    branch = Branch::All;
    if (collide) {
        if (!guide_now) seg = air_segment(air, ray, t_end, scene.sun_guide(), models.predicted ? models.map : nullptr);
        return collide_in_air(m, seg, p_event, controlled, models.predicted);
    }
    if (!(p_event > 0)) return Flight::Ended;
    beta *= T / p_event;
    scale_r_l(Spectrum(1 / p_event));  // the light strategy needs no flight through: see sample_direct
    return Flight::Crossed;
}

// Which of the air's light models serve a guided flight in m (`clear`: they hold along its
// segment). The light scattered along the segment is a control variate
// (AirSegment::light_model): the model's integral is added, and at a collision the model's
// value there is taken off what the path then gathers (NEE, and past it the light the sky
// map models). Where shapes may shadow the air, the models still bound what a collision
// could gather (they ignore those shadows): collide_in_air's roulette.
Path::AirModels Path::air_models(const Medium &m, bool clear) const {
    AirModels models;
    models.map = scene.sky_map(medium);
    const bool map_models = models.map && models.map->models_light;
    models.light_model = branch != Branch::PassThrough && feat.nee && clear && !last_vertex();
    models.map_model = models.light_model && map_models && (feat.max_depth < 0 || depth + 2 < feat.max_depth);
    models.predicted = !clear && scene.context.sun_alone_under_mis && feat.nee && map_models && !last_vertex();
    return models;
}

// Whether a ray that leaves for empty space there finds nothing, not even a sun's disc.
bool Path::finds_nothing_beyond(bool hit, const Intersection &its) const {
    if (!leaves_for_empty_space(hit, its)) return false;
    for (int index : scene.context.infinite_lights)
        if (!is_black(infinite_radiance(scene.lights[index], ray.d))) return false;
    return true;
}

// The probability that a guided flight collides on a segment of optical depth tau, the same
// in all channels (their average of 1 - T); 1 for a forced branch, 0 for a pass-through.
Real Path::air_collision_probability(const Spectrum &tau, bool hit, const Intersection &its) const {
    if (branch != Branch::All) return branch == Branch::Collide ? 1 : 0;
    Real p_collide = 0;
    for (int c = 0; c < 3; ++c) p_collide -= std::expm1(-tau[c]) / 3;  // 1 - T by expm1: exact for thin air too
    // Leaving the air for empty space under suns alone, a path could only find a sun's
    // disc, which NEE from the last scattering event takes (see sample_direct): always
    // collide. Not after the camera or a specular bounce: no NEE saw the disc.
    if (p_collide > 0 && !specular_bounce && leaves_for_empty_space(hit, its)) p_collide = 1;
    return p_collide;
}

// The guided flight's collision, chosen with probability p_event: a distance drawn from
// the segment's guide, weighted with its transmittance, then the scattering event there.
Path::Flight Path::collide_in_air(const Medium &m, const AirSegment &seg, Real p_event, bool controlled,
                                  bool predicted) {
    if (last_vertex()) return Flight::Ended;
    // A collision in shadowed air pays for NEE through the shapes before roulette_by_share
    // can end its walk: the camera's forced collisions in the few hundred metres of air
    // around it, which gather a few per cent of what the sky beyond or the terrain shows.
    // Roulette first, by the share the models predict for the collision.
    if (predicted && seg.models_light &&
        !survive(share_survival(beta * seg.light_integral() / (p_event * average(r_u)))))
        return Flight::Ended;
    Real t, pdf;
    if (!seg.sample(sampler.next_1d(), t, pdf)) return Flight::Ended;
    const Vec3 p = ray.at(t);
    if (controlled) L -= beta * seg.light_model(t) / (pdf * p_event * average(r_u));
    beta *= seg.transmittance(t) * medium_properties(m, p).sigma_s / (pdf * p_event);
    return !is_black(beta) && scatter_in_medium(p, m) ? Flight::Scattered : Flight::Ended;
}

// Through any other medium: delta tracking against its majorants (null scattering),
// transmittance in closed form where a homogeneous medium does not scatter.
Step Path::fly_through_medium(Real t_end) {
    const Medium &m = scene.media[medium];
    const auto *h = std::get_if<HomogeneousMedium>(&m);
    const bool scatters = !(h && is_black(h->sigma_s));
    const bool pass_through = branch == Branch::PassThrough;
    Tracking seg{t_end, h && scatters && !pass_through && feat.nee && config.light_distances &&
                            !scene.context.segment_lights.empty() && !last_vertex()};
    if (seg.segment_nee) segment_direct(m, *h, t_end);
    seg.r_start = r_u;
    if (branch != Branch::All && !enter_branch(m, h != nullptr, t_end, seg.forced)) return Step::Ended;
    if (!scatters) {
        cross_without_scattering(*h, t_end);
        return Step::Reached;
    }
    return pass_through ? Step::Reached : delta_track(m, seg);
}

// The camera's split segment (see Branch): PassThrough crosses it with weight T_maj (by
// residual ratio tracking in a grid), Collide must collide in it (`forced`: the
// probability it stands for, with which it weights the path). False: nothing left.
bool Path::enter_branch(const Medium &m, bool homogeneous, Real t_end, Real &forced) {
    const bool pass_through = branch == Branch::PassThrough;
    branch = Branch::All;
    if (pass_through && !homogeneous) {
        beta *= ratio_tracking(m, ray, t_end, channel, sampler, /*residual=*/true);
        return !is_black(beta);
    }
    const Spectrum tau = majorant_optical_depth(m, ray, t_end);
    if (!pass_through) {
        forced = -std::expm1(-tau[channel]);
        beta *= forced;
        return forced > 0;
    }
    const Spectrum T_maj = exp(-tau);
    const Real pdf = T_maj[channel];
    if (!(pdf > 0)) return false;
    beta *= T_maj;  // the branch always runs: weighted by the event's probability
    r_u *= T_maj / pdf;
    scale_r_l(Spectrum(1 / pdf));
    return true;
}

// Nothing scatters: transmittance and emission are exact, no sampling: the emission
// integral of sigma_a Le T(t) over the segment.
void Path::cross_without_scattering(const HomogeneousMedium &h, Real t_end) {
    const Spectrum sigma_t = h.sigma_a + h.sigma_s;
    const Real d = t_end - ray.t_min;
    if (!is_black(h.Le) && (feat.max_depth < 0 || depth < feat.max_depth)) {
        Spectrum span;
        for (int c = 0; c < 3; ++c) span[c] = sigma_t[c] > 0 ? -std::expm1(-sigma_t[c] * d) / sigma_t[c] : d;
        L += beta * h.sigma_a * h.Le * span / average(r_u);
    }
    beta *= exp(-sigma_t * d);
}

// Delta tracking over [ray.t_min, seg.t_end] until a real collision scatters the path.
// A grid's forced branch takes NEE at each of its tentative collisions whatever the
// real-or-null choice, weighted by sigma_s / sigma_maj instead of drawn with probability
// sigma_t / sigma_maj: the light a fog bank scatters toward the camera is then no longer a
// coin toss at each collision along the camera's ray. Phase sampling from there still
// follows the choice, which weights it by sigma_s / sigma_maj on average too, as MIS
// expects.
Step Path::delta_track(const Medium &m, Tracking &seg) {
    seg.nee_at_tentative = seg.forced > 0 && feat.nee && std::holds_alternative<GridMedium>(m);
    Collision outcome = Collision::Null;
    const Spectrum T_maj = sample_T_maj(
        m, ray, seg.t_end, channel, sampler,
        [&](const Vec3 &p, Real t, const MediumProperties &mp, const Spectrum &sigma_maj, const Spectrum &T_seg) {
            outcome = tentative_collision(m, seg, p, t, mp, sigma_maj, T_seg);
            return outcome == Collision::Null && !is_black(beta);
        },
        seg.forced, true, nullptr, seg.forced > 0 ? (stratum + sampler.next_1d()) / strata : -1);
    if (outcome == Collision::Ended || (seg.forced > 0 && outcome != Collision::Scattered))
        return Step::Ended;  // (see kCollideBranches)
    if (outcome == Collision::Scattered) return Step::NewRay;
    // No collision before t_end. Homogeneous media are crossed by shadow rays in closed
    // form, so the light strategy's density does not include T there.
    const Real pdf = T_maj[channel];
    if (!(pdf > 0)) return Step::Ended;
    beta *= T_maj / pdf;
    r_u *= T_maj / pdf;
    scale_r_l(is_homogeneous(m) ? Spectrum(1 / pdf) : T_maj / pdf);
    return Step::Reached;
}

// A tentative collision of delta tracking at p: its emission, NEE where the segment gathers
// at every one, then a real or a null collision, in proportion to sigma_t : sigma_n in the
// sampling channel. Absorption is not sampled: it weights beta. All the segment's choices
// come from one uniform (ChoiceChain): the segment is crossed where that exceeds 1 - (the
// tentative collisions' ratio-tracking estimate of T), a threshold stratified over the
// pixel's samples like any dimension, where a number per choice would not be.
Path::Collision Path::tentative_collision(const Medium &m, Tracking &seg, const Vec3 &p, Real t,
                                          const MediumProperties &mp, const Spectrum &sigma_maj,
                                          const Spectrum &T_seg) {
    const Spectrum sigma_t = mp.sigma_a + mp.sigma_s;
    add_medium_emission(mp, sigma_maj, T_seg);
    // (Grey coefficients only: the channels' densities then agree, and the MIS weights
    // with them.)
    const bool gathered = seg.nee_at_tentative && !last_vertex() && is_grey(sigma_maj) && is_grey(sigma_t);
    if (gathered) {
        const Real pdf = T_seg[channel] * sigma_maj[channel];
        L += direct_in_medium(p, medium_phase(m, p), beta * T_seg * mp.sigma_s / pdf, r_u * T_seg * sigma_maj / pdf,
                              nullptr);
    }
    if (seg.real_or_null.choose(sigma_t[channel] / sigma_maj[channel], sampler)) {
        if (last_vertex()) return Collision::Ended;
        const Real pdf = T_seg[channel] * sigma_t[channel];
        beta *= T_seg * mp.sigma_s / pdf;
        r_u *= T_seg * sigma_t / pdf;
        // In a homogeneous segment T_seg runs from its start.
        std::optional<SegmentVertex> vertex;
        if (seg.segment_nee) vertex = SegmentVertex{ray, seg.t_end, sigma_t, seg.r_start, t, pdf, -1};
        const bool goes_on = !is_black(beta) && scatter_in_medium(p, m, vertex ? &*vertex : nullptr, gathered);
        return goes_on ? Collision::Scattered : Collision::Ended;
    }
    if (++null_collisions > config.max_null_collisions) return Collision::Ended;
    const Spectrum sigma_n = clamp_zero(sigma_maj - sigma_t);
    const Real pdf = T_seg[channel] * sigma_n[channel];
    if (!(pdf > 0)) return Collision::Ended;
    beta *= T_seg * sigma_n / pdf;
    r_u *= T_seg * sigma_n / pdf;
    scale_r_l(T_seg * sigma_maj / pdf);
    return Collision::Null;
}

// The ray escaped: the lights at infinity it finds.
void Path::add_infinite_lights(const Intersection &its) {
    for (int index : scene.context.infinite_lights) {
        const Light &light = scene.lights[index];
        add_emission(infinite_radiance(light, ray.d), index, light_pdf(light, scene.geometry, prev_p, ray.d, its));
    }
}

// At a surface: its emission, then a null boundary crossed, or the BSDF's NEE and its
// sampled direction with Russian roulette.
Step Path::at_surface(const Intersection &its) {
    const ShapeInfo &shape = scene.shapes[its.shape];
    // Straight on through: into the medium beyond a boundary, past a shape hidden from this
    // kind of ray, through a mask.
    const auto pass_through = [&] {
        if (++null_crossings > kMaxNullCrossings) return Step::Ended;
        const int next = medium_after_crossing(shape, ray.d, its.n, medium);
        segment += next != medium;
        medium = next;
        const Real t_left = ray.t_max - its.t;
        ray = spawn_ray(its.p, its.n, ray.d, t_left);
        return Step::NewRay;
    };
    if (shape.hides_from(ray_kind)) return pass_through();
    if (shape.light >= 0) {
        const auto &area = std::get<AreaLight>(scene.lights[shape.light]);
        if (const Real cos_l = emitting_cos(area, its.n, ray.d); cos_l > 0)
            add_emission(area.radiance * spread_falloff(area, cos_l), shape.light,
                         light_pdf(scene.lights[shape.light], scene.geometry, prev_p, ray.d, its));
    }
    const BSDF &given = scene.bsdfs[size_t(shape.bsdf)];
    if (is_null(given)) return pass_through();
    SurfacePoint surface;
    surface_at(scene, shape.bsdf, its, is_layered(given) ? sampler.next_1d() : 0, surface);
    if (!surface.bsdf) {
        // Through a mask: drawn with probability `pass`, which NEE's shadow rays multiply
        // by instead (see sample_direct).
        r_l /= surface.pass;
        return pass_through();
    }
    if (feat.max_depth >= 0 && depth + 1 >= feat.max_depth) return Step::Ended;
    ++depth;

    const BSDF &bsdf = *surface.bsdf;
    const Frame frame(surface.ns);
    const Vec3 wi = frame.to_local(-ray.d);
    if (feat.nee && !is_delta(bsdf)) {
        L += sample_direct(
            scene, its.p, its.n, &shape, medium, beta, r_u, channel, feat.mis, sampler,
            [&](const Vec3 &d, uint8_t hidden_lobes) { return bsdf_eval(bsdf, wi, frame.to_local(d), hidden_lobes); },
            [&](const Vec3 &d) { return Spectrum(bsdf_pdf(bsdf, wi, frame.to_local(d))); });
        if (!feat.emission_after_scatter || (last_vertex() && !scene.has_hittable_emitters())) return Step::Ended;
    }
    const std::optional<SurfaceSky> sky = add_sky_model_integral(shape, its, bsdf, frame, wi);
    BSDFSample bs;
    if (!bsdf_sample(bsdf, wi, sampler.next_1d(), sampler.next_2d(), bs)) return Step::Ended;
    const Vec3 wo = frame.to_world(bs.wo);
    if (sky) L -= beta * bs.weight * sky->arriving(wo) / average(r_u);
    beta *= bs.weight;
    specular_bounce = bs.delta;
    ray_kind = bs.wo.z * wi.z < 0 ? RayKind::Transmission : bs.diffuse ? RayKind::Diffuse : RayKind::Glossy;
    if (scene.context.lights_hide_lobes && !bs.delta)
        diffuse_share =
            safe_div(bsdf_eval(bsdf, wi, bs.wo, kLobeRays & ~uint8_t(RayKind::Diffuse)), bs.weight * bs.pdf);
    else
        diffuse_share = Spectrum(0.0);
    if (!bs.delta) r_l = r_u / bs.pdf;
    scattered_at.reset();
    prev_p = its.p;
    null_crossings = 0;
    medium = medium_after_crossing(shape, wo, its.n, medium);
    ray = spawn_ray(its.p, its.n, wo);
    if (is_black(beta)) return Step::Ended;
    return roulette() ? Step::NewRay : Step::Ended;
}

}  // namespace

Spectrum radiance(const Scene &scene, Ray ray, int medium, Sampler &sampler, const TracerConfig &config) {
    if (config.tracer == Tracer::Absorption) return absorption_radiance(scene, ray, medium, sampler);
    return Path(scene, ray, medium, sampler, config).trace();
}

}  // namespace volpath
