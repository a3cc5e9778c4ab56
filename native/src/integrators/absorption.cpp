// The absorption tracer (tracer 1): what the camera ray sees through emitting and absorbing
// media, nothing scattered:
//
//   L = T(x_0, x_s) Le(x_s) + integral over [0, s] of T(x_0, x_t) sigma_a(x_t) Le(x_t) dt,
//
// with x_s the first surface that stops the ray (or the lights at infinity where none
// does). A homogeneous medium takes T and the emission integral in closed form, with its
// whole extinction sigma_a + sigma_s as absorption; any other medium is crossed by ratio
// tracking against its majorants, whose tentative collisions also estimate its emission
// (weighted by the rescaled path pdf r_u, as pbrt-v4 does). Index-matched boundaries,
// masks and shapes hidden from camera rays are passed straight through.
#include "common.h"

namespace volpath {

namespace {

// The segment [ray.t_min, t_end] through medium m: its emission added to L, beta and r_u
// updated. False: nothing gets through.
bool cross_absorbing(const Medium &m, const Ray &ray, Real t_end, int channel, Sampler &sampler, Spectrum &L,
                     Spectrum &beta, Spectrum &r_u) {
    if (const auto *h = std::get_if<HomogeneousMedium>(&m)) {
        const Spectrum sigma_t = h->sigma_a + h->sigma_s;
        const Real d = t_end - ray.t_min;
        if (!is_black(h->Le)) {
            L += beta * h->sigma_a * h->Le * transmittance_integral(sigma_t, d) / average(r_u);
        }
        beta *= exp(-sigma_t * d);
        return true;
    }
    const Spectrum T_maj = sample_T_maj(
        m, ray, t_end, channel, sampler,
        [&](const Vec3 &, Real, const MediumProperties &mp, const Spectrum &sigma_maj, const Spectrum &T_seg) {
            const Real pdf = T_seg[channel] * sigma_maj[channel];
            // Emission sigma_a Le, found with density T_seg sigma_maj.
            if (!is_black(mp.Le)) {
                const Spectrum r_e = r_u * sigma_maj * T_seg / pdf;
                if (pdf > 0 && average(r_e) > 0) L += beta * T_seg / pdf * mp.sigma_a * mp.Le / average(r_e);
            }
            const Spectrum sigma_n = clamp_zero(sigma_maj - mp.sigma_a - mp.sigma_s);
            beta *= T_seg * sigma_n / pdf;
            r_u *= T_seg * sigma_maj / pdf;
            return !is_black(beta);
        });
    const Real pdf = T_maj[channel];
    if (!(pdf > 0) || is_black(beta)) return false;
    beta *= T_maj / pdf;
    r_u *= T_maj / pdf;
    return true;
}

}  // namespace

Spectrum absorption_radiance(const Scene &scene, Ray ray, int medium, Sampler &sampler) {
    const int channel = std::min(int(sampler.next_1d() * 3), 2);  // samples the tracking's distances
    Spectrum L(0.0), beta(1.0), r_u(1.0);
    const auto add = [&](const Spectrum &Le) {
        if (!is_black(Le)) L += beta * Le / average(r_u);
    };
    const Vec3 camera = ray.o;  // where the lights' falloffs are seen from
    for (int crossings = 0; crossings <= kMaxNullCrossings; ++crossings) {
        Intersection its;
        const bool hit = scene.intersect(ray, its, medium);
        const Real t_end = hit ? its.t : ray.t_max;
        if (medium >= 0 && !cross_absorbing(scene.media[medium], ray, t_end, channel, sampler, L, beta, r_u)) break;
        if (!hit) {
            for (int index : scene.context.infinite_lights)
                if (!scene.light_hides_from(index, RayKind::Camera)) add(infinite_radiance(scene.lights[index], ray.d));
            break;
        }
        const ShapeInfo &shape = scene.shapes[its.shape];
        if (!shape.hides_from(RayKind::Camera)) {
            if (shape.light >= 0) {
                add(area_radiance(std::get<AreaLight>(scene.lights[shape.light]), scene.geometry, its, ray.d, camera));
            }
            // The surface stops the ray unless it is a boundary or lets it through (a mask).
            const BSDF &given = scene.bsdfs[size_t(shape.bsdf)];
            if (!is_null(given)) {
                SurfacePoint surface;
                surface_at(scene, shape.bsdf, its, is_layered(given) ? sampler.next_1d() : 0, surface);
                if (surface.bsdf) break;
            }
        }
        medium = medium_after_crossing(shape, ray.d, its.n, medium);
        ray = spawn_ray(ray.time, its.p, its.n, ray.d, ray.t_max - its.t);
    }
    return L;
}

}  // namespace volpath
