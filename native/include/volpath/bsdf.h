// Surface scattering. Directions are in the shading frame (z = shading normal) and both
// point away from the surface: wi towards the previous vertex, wo towards the next.
// Like Mitsuba, non-transmissive BSDFs are one-sided (black from behind) unless twosided.
#pragma once

#include <variant>

#include "math.h"

namespace volpath {

// An index-matched boundary: rays pass straight through, only the medium changes.
struct NullBSDF {};
// Lambertian reflection.
struct DiffuseBSDF {
    Spectrum reflectance{0.5};
};
// Smooth dielectric interface; eta = interior / exterior index of refraction.
struct DielectricBSDF {
    Real eta = 1.5046 / 1.000277;
};
// A thin dielectric sheet (a window pane): light reflects off it, inter-reflections between
// its two faces included, or passes straight through; eta = sheet / surroundings.
struct ThinDielectricBSDF {
    Real eta = 1.5046 / 1.000277;
};
// A metal: reflection with the Fresnel reflectance of a conductor of complex index
// eta + i k (relative to the surroundings), per channel, times `specular`; smooth (alpha 0)
// or rough (GGX). Mitsuba's `conductor` and `roughconductor`.
struct ConductorBSDF {
    Spectrum eta{0.0}, k{0.0};  // eta = k = 0: a perfect mirror (Mitsuba's material "none")
    Spectrum specular{1.0};
    Real alpha = 0;
};
// A diffuse base under a rough dielectric coating with a GGX microfacet distribution
// (the model of Mitsuba's `roughplastic`, with smooth-Fresnel transmittance through the
// coating). Blender's Principled BSDF maps onto it.
struct RoughPlasticBSDF {
    Spectrum diffuse{0.5};
    Spectrum specular{1.0};
    Real alpha = 0.1;  // GGX roughness (Blender roughness squared)
    Real eta = 1.49;
};

// A rough dielectric interface (Walter et al. 2007) with a GGX distribution: reflection
// and refraction off microfacets, in proportion to their Fresnel reflectance (Mitsuba's and
// lajolla's `roughdielectric`). eta = interior / exterior.
struct RoughDielectricBSDF {
    Real eta = 1.5046 / 1.000277;
    Real alpha = 0.1;  // GGX roughness
};

using BSDFModel = std::variant<NullBSDF, DiffuseBSDF, DielectricBSDF, ThinDielectricBSDF, RoughPlasticBSDF,
                               RoughDielectricBSDF, ConductorBSDF>;

struct BSDF {
    BSDFModel model;
    bool twosided = false;
};

struct BSDFSample {
    Vec3 wo;
    Spectrum weight;  // f * |cos wo| / pdf
    Real pdf = 0;
    bool delta = false;
};

inline bool is_null(const BSDF &b) { return std::holds_alternative<NullBSDF>(b.model); }
inline bool is_delta(const BSDF &b) {
    if (const auto *c = std::get_if<ConductorBSDF>(&b.model)) return c->alpha == 0;
    return std::holds_alternative<DielectricBSDF>(b.model) || std::holds_alternative<ThinDielectricBSDF>(b.model);
}

// The colour a denoiser's albedo pass holds for the surface: its diffuse reflectance, or
// white where it reflects or transmits specularly.
Spectrum bsdf_albedo(const BSDF &bsdf);
// f(wi, wo) * |cos wo|.
Spectrum bsdf_eval(const BSDF &bsdf, Vec3 wi, Vec3 wo);
Real bsdf_pdf(const BSDF &bsdf, Vec3 wi, Vec3 wo);
bool bsdf_sample(const BSDF &bsdf, Vec3 wi, Real u_lobe, Vec2 u, BSDFSample &out);

// Unpolarised Fresnel reflectance of a conductor of complex index eta + i k, per channel,
// for a cosine in (0, 1]; 1 where eta = k = 0.
Spectrum fresnel_conductor(Real cos_theta_i, const Spectrum &eta, const Spectrum &k);

// Unpolarised Fresnel reflectance of a dielectric interface for a cosine on either side
// (eta = interior / exterior). Sets the signed cosine of the refracted direction.
Real fresnel_dielectric(Real cos_theta_i, Real eta, Real *cos_theta_t = nullptr);

}  // namespace volpath
