// Distances drawn along a segment of a homogeneous medium for one light, where NEE toward
// that light then starts (see SegmentVertex in the integrator).
#pragma once

#include <algorithm>
#include <cmath>

#include "light.h"

namespace volpath {

// Lights with a distance strategy of their own (RenderContext::segment_lights): all but
// environments. Seen through thin smoke, free flight's estimates of an environment's light
// that passes through and of the light that scatters in are anticorrelated (one or the
// other), and a second strategy for the in-scattering alone would be noisier.
// The distances follow what reaches the light: the transmittance from the segment's start
// times the transmittance on toward the light, e^(-sigma_t t) e^(-sigma_t (d - t cos)) if
// the medium ended at a plane facing the light at distance d: an exponential of rate
// sigma_t (1 - cos), cos between the segment and the direction toward the light (for
// lights at a point and area lights, toward their centre from the segment's start).
// Segments toward the light spread their distances along their length, segments away from
// it gather them near the start. Each segment takes one such distance whether or not free
// flight then collides on it, and its collision takes no NEE toward these lights.
// The rate's factor (1 - cos) is kept above kMinTowardLightFactor, so that a segment aimed
// at the light still has a proper density where it is unbounded.
constexpr Real kMinTowardLightFactor = 1e-3;
// Where a light at a point (or an area light's centre) is near the segment, its
// inverse-square falloff matters more than the transmittance, and without distances that
// follow it NEE's variance is unbounded (1/D for segments passing at distance D): there
// the segment takes a second distance, equiangular (Kulla and Fajardo 2012), and the two
// are combined by the balance heuristic (their densities add). Near: 1/r^2 peaks on the
// segment at more than kEquiangularPeak times its mean there.
constexpr Real kEquiangularPeak = 4;

// Where equiangular distances aim, for the lights that have one.
inline const Vec3 *light_position(const Light &light) {
    if (const auto *point = std::get_if<PointLight>(&light)) return &point->position;
    if (const auto *area = std::get_if<AreaLight>(&light)) return &area->center;
    return nullptr;
}

// The distances drawn for a light on the segment [ray.t_min, t_end] of a homogeneous
// medium: `count` of them, the k-th by sample(k, ...). density(t) is their density per
// channel, summed over the strategies (the expected number of distances per unit length).
struct LightDistances {
    Spectrum rate;       // the exponential's, per channel
    Equiangular toward;  // the equiangular distance's, if count is 2
    int count = 1;
    Real t0, t1;

    LightDistances(const Light &light, const Ray &ray, Real t_end, const Spectrum &sigma_t) : t0(ray.t_min), t1(t_end) {
        Vec3 w;
        if (const Vec3 *c = light_position(light)) {
            w = normalize(*c - ray.at(t0));
            // 1/r^2's peak over its mean is at most (r_min + length)^2 / r_min^2, at most 4
            // for segments no longer than their least distance to the light.
            const Real t_closest = std::clamp(dot(*c - ray.o, ray.d), t0, t1);
            if (t1 - t0 > length(*c - ray.at(t_closest))) {
                toward = equiangular(*c, ray.o, ray.d, t0, t1);
                if (is_valid(toward) && (t1 - t0) * equiangular_pdf(toward, t_closest) > kEquiangularPeak) count = 2;
            }
        } else if (const auto *directional = std::get_if<DirectionalLight>(&light)) {
            w = -directional->direction;
        } else {
            w = std::get<SunLight>(light).to_sun;
        }
        rate = sigma_t * std::max(1 - dot(ray.d, w), kMinTowardLightFactor);
    }

    Spectrum density(Real t) const {
        const Real s = t - t0, length = t1 - t0;
        auto exponential = [&](Real r) {
            return r > 0 ? r * std::exp(-r * s) / -std::expm1(-r * length) : (std::isfinite(length) ? 1 / length : 0);
        };
        const Spectrum p = is_grey(rate) ? Spectrum(exponential(rate.x))
                                         : Spectrum(exponential(rate.x), exponential(rate.y), exponential(rate.z));
        return count == 1 ? p : p + Spectrum(equiangular_pdf(toward, t));
    }

    // Draws the k-th distance, the exponential's in the path's channel; false where that
    // has no density (rate 0 on an unbounded segment).
    bool sample(int k, Real u, int channel, Real &t) const {
        if (k == 1) {
            t = sample_equiangular(toward, u, t0, t1);
            return true;
        }
        const Real r = rate[channel], length = t1 - t0;
        if (r > 0)
            t = t0 + std::min(-std::log1p(u * std::expm1(-r * length)) / r, length);
        else if (std::isfinite(length))
            t = t0 + u * length;
        else
            return false;
        return true;
    }
};

// The density per channel of the distances drawn for `light` on [ray.t_min, t_end] at t
// (0 for environments).
inline Spectrum light_distance_density(const Light &light, const Ray &ray, Real t_end, const Spectrum &sigma_t,
                                       Real t) {
    if (std::holds_alternative<EnvironmentLight>(light)) return Spectrum(0.0);
    return LightDistances(light, ray, t_end, sigma_t).density(t);
}

}  // namespace volpath
