// The path's flight through the guided air (AirSegment): the segment cut where the scene's
// own shapes shadow the sun, a collision probability shared by all channels, distances drawn
// toward where the sun's light scatters, and the air's light models as control variates.
#include "path.h"

namespace volpath {

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
    return !scene.intersect(spawn_ray(ray.time, its.p, its.n, ray.d), beyond);
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

}  // namespace volpath
