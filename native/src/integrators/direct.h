// Next-event estimation: a light chosen, a point on it sampled, and a shadow ray traced to
// it through index-matched boundaries, masks and media, weighted by MIS against the path's
// own sampling (the rescaled pdfs of pbrt-v4).
#pragma once

#include "path.h"

namespace volpath {

// Whether a ray that escapes the scene can only find `light` there: the scene is lit at
// infinity by suns alone. The guided free flight makes every ray that would leave the air
// for empty space collide in it instead (a sun's disc seen from the air is NEE's alone).
inline bool leads_to_suns_only(const Scene &scene, const Light &light) {
    return std::holds_alternative<SunLight>(light) && !scene.context.has_environment;
}

// What a shadow ray gathers on its way to the light: its transmittance, and the rescaled
// pdfs of the light strategy (r_l) and of the path's own (r_u) that its tracking updates
// (pbrt-v4's SampleLd), so that the MIS weights match those computed when the same path is
// found by phase or BSDF sampling.
struct Shadow {
    Spectrum T{1.0}, r_l{1.0}, r_u{1.0};
    bool left_guided_air = false;  // the last crossing led from guided air into vacuum
};

// Traces the shadow ray (its t_max: the distance to the light) through index-matched
// boundaries, masks and media, starting in medium `current`. False: occluded (nothing to
// estimate, and no tracking paid for on the way there), or ended by Russian roulette.
bool trace_shadow(const Scene &scene, Ray ray, int current, const Light &light, bool delta_light, int channel,
                  Sampler &sampler, Shadow &s);

// NEE's light at p by u, and the probability of choosing it (-1: none): under MIS among
// RenderContext::mis_nee_lights by their importance at p, at a collision among
// collision_nee_lights, else uniformly among all lights.
inline int choose_light(const Scene &scene, const Vec3 &p, bool collision, bool mis, Real u, Real &select) {
    const RenderContext &c = scene.context;
    const std::vector<int> *choice = collision ? &c.collision_nee_lights[mis] : (mis ? &c.mis_nee_lights : nullptr);
    const int n = int(choice ? choice->size() : scene.lights.size());
    if (n == 0) return -1;
    if (choice == &c.mis_nee_lights && n > 1) return c.nee_sampler.sample(p, u, select);
    const int i = std::min(int(u * n), n - 1);
    select = 1.0 / Real(n);
    return choice ? (*choice)[size_t(i)] : i;
}

// Next-event estimation from a scattering point: choose a light (among
// RenderContext::mis_nee_lights by their importance at p under MIS, else uniformly among all
// lights; on medium segments see `vertex`),
// sample a point on it and trace a shadow ray (at the path's `time`) through index-matched
// boundaries and media. `eval(d, hidden_lobes)` returns the scattering value f (times the cosine, for surfaces; of
// the lobes the light does not hide from, kLobeRays bits), `pdf(d)` the
// density of sampling d per channel: asked for only where phase or BSDF sampling could
// find the light too (MIS). r_p is the path's rescaled unidirectional pdf.
// `vertex`: the point is a SegmentVertex: drawn for its light, or free flight's collision,
// which chooses among RenderContext::collision_nee_lights (see SegmentVertex).
template <typename Eval, typename Pdf>
Spectrum sample_direct(const Scene &scene, Real time, const Vec3 &p, const Vec3 &n, const ShapeInfo *surface,
                       int medium, const Spectrum &beta, const Spectrum &r_p, int channel, bool mis, Sampler &sampler,
                       Eval &&eval, Pdf &&pdf, const SegmentVertex *vertex = nullptr) {
    // No weight (an empty voxel under a majorant cell's peak): no shadow ray to pay for.
    if (is_black(beta)) return Spectrum(0.0);
    const bool toward_light = vertex && vertex->light >= 0, collision = vertex && !toward_light;
    int light = toward_light ? vertex->light : -1;
    Real select = toward_light ? segment_light_select_pdf(scene) : 0;
    if (!toward_light) {
        light = choose_light(scene, p, collision, mis, sampler.next_1d(), select);
        if (light < 0) return Spectrum(0.0);
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
    const Ray ray = spawn_ray(time, p, n, ls.d, std::isfinite(ls.dist) ? ls.dist * (1 - 1e-7) : kInfinity);
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

}  // namespace volpath
