#include "direct.h"

namespace volpath {

namespace {

// A shadow ray whose transmittance has fallen below kShadowRouletteT at a boundary goes on
// with probability T / kShadowRouletteT (weighted up to match): from deep inside a dense
// medium, what the rest of the ray finds barely counts.
constexpr Real kShadowRouletteT = 0.05;

// Whether a shadow ray to `light` crosses `m` with a deterministic transmittance: any
// light through guided air, else the sun through air whose sun transmittance is not set
// to ratio tracking.
bool deterministic_through_air(const Light &light, const Medium &m) {
    const auto *air = std::get_if<AtmosphereMedium>(&m);
    return air && (guided_air(m) ||
                   (air->sun_transmittance != AtmosphereMedium::SunTransmittance::Tracking &&
                    (std::holds_alternative<SunLight>(light) || std::holds_alternative<DirectionalLight>(light))));
}

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

}  // namespace

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
        ray = spawn_ray(ray.time, its.p, its.n, ray.d, remaining);
        // Russian roulette before tracing on, where the transmittance so far is small.
        if (const Real T_max = max_component(s.T); T_max < kShadowRouletteT) [[unlikely]] {
            if (!(sampler.independent_1d() * kShadowRouletteT < T_max)) return false;
            s.T *= kShadowRouletteT / T_max;
        }
    }
}

}  // namespace volpath
