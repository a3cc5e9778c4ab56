// Emitters. Sampling returns a direction from a reference point with its solid-angle
// pdf (before the probability of choosing the light); `pdf` for the same direction
// found by another strategy must agree with it (checked by the chi-square tests).
#pragma once

#include <memory>
#include <stdexcept>
#include <variant>
#include <vector>

#include "geometry.h"
#include "texture.h"
#include "warp.h"

namespace volpath {

// A spot lamp's cone (Blender's Spot Size and Blend, as Cycles renders them): full
// strength inside, falling by a smoothstep in the cosine over the cone's outer `blend`
// share to nothing at its edge, acos(cos_half) from the axis. No cosine falloff inside.
struct SpotCone {
    Vec3 axis{0, 0, 1};           // unit, where the lamp points
    Real cos_half = -1;           // -1: no cone, light in every direction
    Real inv_smooth = kInfinity;  // 1 / ((1 - cos_half) blend); infinity: a hard edge
};
// The spot's factor on light leaving along the unit direction w.
inline Real spot_falloff(const SpotCone &spot, const Vec3 &w) {
    if (spot.cos_half <= -1) return 1;
    const Real t = (dot(spot.axis, w) - spot.cos_half) * spot.inv_smooth;
    if (!(t > 0)) return 0;
    return t >= 1 ? 1 : t * t * (3 - 2 * t);
}
// The cone of half-angle `half_angle` (radians, in (0, pi/2]) whose outer `blend` share
// (in [0, 1]) fades.
SpotCone spot_cone(const Vec3 &axis, Real half_angle, Real blend);

struct PointLight {
    Vec3 position;
    Spectrum intensity;  // W / sr
    SpotCone spot;
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
    // A Blender lamp with a radius (a sphere): its spot cone, on the direction light
    // leaves in, and Soft Falloff, which dims it toward receivers near it as Cycles does,
    // by D^2 / (D^2 + r^2) at distance D from its centre: the irradiance of a disc of
    // radius r that faces the receiver instead of the sphere's (prepare_light sets
    // soft_radius = r where soft_falloff is on).
    SpotCone spot;
    bool soft_falloff = false;
    Real soft_radius = 0;
    // An emission map (Blender's Emission Color from an image): radiance x texture(uv) on
    // a mesh; its own copy, so that lights need nothing but the geometry. mean_texture: its
    // texels' mean luminance (for the light's importance).
    std::shared_ptr<const Texture> texture;
    Real mean_texture = 1;
};

// What a shape emits: an area light's radiance, its faces, its spread, spot cone, soft
// falloff (spheres) and visibility.
struct AreaEmission {
    Spectrum radiance;
    bool twosided = false;
    Real spread = kPi;
    uint8_t hidden_from = 0;  // Scene::light_hidden_from
    SpotCone spot;
    bool soft_falloff = false;
    int texture = -1;  // an emission map among the scene's textures (meshes only)
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

// The radiance that a receiver at `ref` sees along the unit direction d from an area
// light's point with normal n: 0 from a one-sided light's back; the spread, spot and soft
// falloff applied. Every strategy that finds the light asks this.
inline Spectrum area_radiance(const AreaLight &l, const Vec3 &n, const Vec3 &d, const Vec3 &ref) {
    const Real cos_l = emitting_cos(l, n, d);
    if (cos_l <= 0) return Spectrum(0.0);
    Real f = spread_falloff(l, cos_l) * spot_falloff(l.spot, -d);
    if (l.soft_radius > 0) {
        const Real D2 = length_squared(ref - l.center);
        f *= D2 / (D2 + l.soft_radius * l.soft_radius);
    }
    return l.radiance * f;
}

// The same at a point `its` found on the light's shape (an emission map looked up there).
Spectrum area_radiance(const AreaLight &l, const Geometry &geometry, const Intersection &its, const Vec3 &d,
                       const Vec3 &ref);

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
