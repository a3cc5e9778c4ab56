// The scattering tracers' path (path.h): its loop, the camera's split segments, emission
// found along the way, scattering in media, delta tracking, surfaces and Russian roulette.
// The guided flight through the air is air.cpp's, next-event estimation direct.h's.
#include <stdexcept>

#include "direct.h"
#include "volpath/light_distances.h"

namespace volpath {

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
    if ((ray_kind == RayKind::Scatter || ray_kind == RayKind::Camera) && scene.light_hides_from(light, ray_kind))
        return;
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
            const Real select = scattered_at ? scene.collision_light_select_pdf(light, true)
                                             : scene.light_select_pdf(light, true, prev_p);
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
        scene, ray.time, p, Vec3(0.0), nullptr, medium, beta_p, r_p, channel, feat.mis, sampler,
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
    // The map's light scattered here as a control variate (sky_variates.h).
    const Spectrum arriving = sky_model ? map->radiance(sky->at, ps.d_out) : Spectrum(0.0);
    if (sky_model)
        L += beta *
             scattered_sky_variate(*sky, std::get<RayleighMiePhase>(phase), ray.d, ps.d_out, arriving, pdf_c,
                                   sampler.next_2d()) /
             average(r_u);
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
    ray = Ray{p, ps.d_out, 0, kInfinity, ray.time};
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
    L += beta * surface_sky_integral(sky, bsdf, frame, wi, u, u_lobe) / (kSurfaceMapSamples * average(r_u));
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
        L += beta * h.sigma_a * h.Le * transmittance_integral(sigma_t, d) / average(r_u);
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
        ray = spawn_ray(ray.time, its.p, its.n, ray.d, t_left);
        return Step::NewRay;
    };
    if (shape.hides_from(ray_kind)) return pass_through();
    if (shape.light >= 0) {
        const auto &area = std::get<AreaLight>(scene.lights[shape.light]);
        if (const Spectrum Le = area_radiance(area, scene.geometry, its, ray.d, prev_p); !is_black(Le))
            add_emission(Le, shape.light, light_pdf(scene.lights[shape.light], scene.geometry, prev_p, ray.d, its));
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
            scene, ray.time, its.p, its.n, &shape, medium, beta, r_u, channel, feat.mis, sampler,
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
    ray = spawn_ray(ray.time, its.p, its.n, wo);
    if (is_black(beta)) return Step::Ended;
    return roulette() ? Step::NewRay : Step::Ended;
}

Spectrum radiance(const Scene &scene, Ray ray, int medium, Sampler &sampler, const TracerConfig &config) {
    if (config.tracer == Tracer::Absorption) return absorption_radiance(scene, ray, medium, sampler);
    return Path(scene, ray, medium, sampler, config).trace();
}

}  // namespace volpath
