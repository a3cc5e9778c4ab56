// Emitters. Sampling returns a direction from a reference point with its solid-angle
// pdf (before the probability of choosing the light); `pdf` for the same direction
// found by another strategy must agree with it (checked by the chi-square tests).
#pragma once

#include <stdexcept>
#include <variant>
#include <vector>

#include "geometry.h"
#include "warp.h"

namespace volpath {

struct PointLight {
    Vec3 position;
    Spectrum intensity;  // W / sr
};

struct DirectionalLight {
    Vec3 direction;  // unit, the direction light travels
    Spectrum irradiance;
};

// Radiance leaving the front side of a shape.
struct AreaLight {
    int shape = -1;
    Spectrum radiance;
    Distribution1D triangle_areas;  // meshes: choose a triangle by area
    Real area = 0;
    Vec3 center;  // area-weighted centroid: where distances drawn for the light aim
    // Emits from both faces (Blender's emission shaders); else from the front (Mitsuba's).
    bool twosided = false;
    // Blender's Spread: the light leaves within spread / 2 of the normal (spread_falloff);
    // kPi: in every direction alike. prepare_light derives the other two.
    Real spread = kPi, tan_half_spread = kInfinity, spread_normalization = 1;
};

// What a shape emits: an area light's radiance, its faces, its spread and its visibility.
struct AreaEmission {
    Spectrum radiance;
    bool twosided = false;
    Real spread = kPi;
    uint8_t hidden_from = 0;  // Scene::light_hidden_from
};

// The cosine at which light from an area light's point with normal n leaves toward a
// receiver that sees it along d: <= 0 where nothing leaves that way (a one-sided back).
inline Real emitting_cos(const AreaLight &l, const Vec3 &n, const Vec3 &d) {
    return l.twosided ? std::abs(dot(n, d)) : -dot(n, d);
}

// The factor on an area light's radiance toward a direction at cos_theta to its normal
// (> 0 on the emitting side). A spread below pi is a grid of slats in front of the
// emitter, as on a soft box: along the normal it hides nothing, and at an angle theta the
// part it lets through falls as tan h - tan theta, to nothing at h, half the spread. The
// power stays the same: over the cone, the integral of (tan h - tan theta) cos theta is
// pi (tan h - h), which spread_normalization divides out.
inline Real spread_falloff(const AreaLight &l, Real cos_theta) {
    if (l.spread >= kPi) return 1;
    const Real tan_theta = safe_sqrt(1 - cos_theta * cos_theta) / cos_theta;
    return std::max(l.tan_half_spread - tan_theta, Real(0)) * l.spread_normalization;
}

// Radiance arriving from infinity: a constant, or a latitude-longitude map (Mitsuba's
// convention: y up, u = atan2(x, -z) / 2 pi, v = acos(y) / pi) times `scale`.
struct EnvironmentLight {
    Spectrum scale{1.0};
    int width = 0, height = 0;  // 0: constant
    std::vector<Spectrum> pixels;
    Distribution2D distribution;
    Transform to_world, to_local;
};

// A distant disc (the sun): uniform radiance within angular radius acos(cos_max) of
// to_sun. Its irradiance at normal incidence is radiance * pi * sin^2(angular radius).
struct SunLight {
    Vec3 to_sun;  // unit, from the scene towards the sun
    Real cos_max = 0.99998907;
    Spectrum radiance;
};
// The sun of irradiance E at normal incidence, angular radius in (0, 0.5) rad.
inline SunLight sun_light(const Vec3 &to_sun, Real angular_radius, const Spectrum &E) {
    if (!(angular_radius > 0 && angular_radius < 0.5))
        throw std::invalid_argument("sun angular radius must be in (0, 0.5) rad");
    const Real sin_r = std::sin(angular_radius);
    return {normalize(to_sun), std::cos(angular_radius), E / (kPi * sin_r * sin_r)};
}

using Light = std::variant<PointLight, DirectionalLight, AreaLight, EnvironmentLight, SunLight>;

inline bool is_constant_environment(const Light &l) {
    const auto *env = std::get_if<EnvironmentLight>(&l);
    return env && env->width == 0;
}

struct LightSample {
    Vec3 d;         // unit, from the reference point towards the light
    Real dist = 0;  // to the light; infinity for lights at infinity
    Spectrum L;     // radiance (or intensity / dist^2, or irradiance for delta lights)
    Real pdf = 0;   // solid angle; 1 for delta lights
    bool delta = false;
};

void prepare_light(Light &light, const Geometry &geometry);
bool sample_light(const Light &light, const Geometry &geometry, const Vec3 &ref, Vec2 u, LightSample &out);
// Solid-angle pdf of reaching the emitter along d from ref; `its` is the point hit on
// an area light (ignored for lights at infinity).
Real light_pdf(const Light &light, const Geometry &geometry, const Vec3 &ref, const Vec3 &d, const Intersection &its);
// Radiance from a light at infinity (environment or sun) along direction d, which points
// away from the scene.
Spectrum infinite_radiance(const Light &light, const Vec3 &d);
inline bool is_infinite(const Light &l) {
    return std::holds_alternative<EnvironmentLight>(l) || std::holds_alternative<SunLight>(l);
}

}  // namespace volpath
