// Surface scattering. Directions are in the shading frame (z = shading normal) and both
// point away from the surface: wi towards the previous vertex, wo towards the next.
// Like Mitsuba, non-transmissive BSDFs are one-sided (black from behind) unless twosided.
#pragma once

#include <variant>
#include <vector>

#include "math.h"
#include "texture.h"

namespace volpath {

// An index-matched boundary: rays pass straight through, only the medium changes.
struct NullBSDF {};
// Lambertian reflection.
struct DiffuseBSDF {
    Spectrum reflectance{0.5};
};
// Smooth dielectric interface; eta = interior / exterior index of refraction. The tints
// scale the reflected and the transmitted light (Mitsuba's specular_reflectance and
// specular_transmittance; Blender's glass colours).
struct DielectricBSDF {
    Real eta = 1.5046 / 1.000277;
    Spectrum reflectance{1.0}, transmittance{1.0};
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
    // The coating's Fresnel reflectance averaged over the hemisphere outside (set by
    // rough_plastic): what the base's inter-reflections under the coating come to.
    Real fdr_exterior = 0.0920;
};
RoughPlasticBSDF rough_plastic(const Spectrum &diffuse, const Spectrum &specular, Real alpha, Real eta);

// A rough dielectric interface (Walter et al. 2007) with a GGX distribution: reflection
// and refraction off microfacets, in proportion to their Fresnel reflectance (Mitsuba's and
// lajolla's `roughdielectric`). eta = interior / exterior.
struct RoughDielectricBSDF {
    Real eta = 1.5046 / 1.000277;
    Real alpha = 0.1;                               // GGX roughness
    Spectrum reflectance{1.0}, transmittance{1.0};  // tints, as the smooth one's
};

using BSDFModel = std::variant<NullBSDF, DiffuseBSDF, DielectricBSDF, ThinDielectricBSDF, RoughPlasticBSDF,
                               RoughDielectricBSDF, ConductorBSDF>;

// Surfaces made of other BSDFs (indices into Scene::bsdfs), resolved at each hit into one
// leaf BSDF and a shading normal (Scene's surface_at).
// blendbsdf: (1 - weight) a + weight b, one of the two chosen per hit in that proportion
// (each strategy at the hit then sees the same BSDF, so the choice needs no MIS weight).
struct BlendLayer {
    int a = -1, b = -1;
    Real weight = 0.5;
};
// mask: the nested BSDF with probability `opacity`, else the ray passes straight through.
struct MaskLayer {
    int nested = -1;
    Real opacity = 1;
};
// normalmap: the nested BSDF about a normal read from a texture of tangent-space normals
// (RGB = (n + 1) / 2, x along dp/du, z along the shading normal); `strength` blends it with
// the unperturbed normal, as Blender's Normal Map node does.
struct NormalMapLayer {
    int nested = -1, texture = -1;
    Real strength = 1;
};
// bumpmap: the nested BSDF about the normal of the surface displaced along its normal by
// scale * height(uv) (the texture's first channel), blended by `strength` as Blender's Bump.
struct BumpMapLayer {
    int nested = -1, texture = -1;
    Real scale = 1, strength = 1;
};
using Layer = std::variant<std::monostate, BlendLayer, MaskLayer, NormalMapLayer, BumpMapLayer>;

// A BSDF parameter given by a texture: offset + scale * texture(uv), with `scale` a 3x3
// matrix (diagonal in RGB; in a spectral pass it takes the texture's RGB to the pass's
// wavelengths), squared where a roughness is given as Blender's and Mitsuba's principled
// give it (alpha = roughness^2). A roughness, weight or opacity takes the first channel.
struct TexturedParam {
    enum class Name : uint8_t { Reflectance, Specular, Alpha, Weight, Opacity } name = Name::Reflectance;
    int texture = -1;  // into Scene::textures
    Real scale[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    Spectrum offset{0.0};
    bool squared = false;
};

struct BSDF {
    BSDFModel model;  // unused where `layer` is set
    bool twosided = false;
    std::vector<TexturedParam> textured;  // the parameters that vary over the surface
    Layer layer;                          // monostate: a leaf, `model` itself
};

inline bool is_layered(const BSDF &b) { return !std::holds_alternative<std::monostate>(b.layer); }

// Whether the BSDF has the parameter (diffuse and rough plastic have a reflectance, rough
// plastic and conductors a specular tint, the microfacet models an alpha, a blend a weight,
// a mask an opacity).
bool has_param(const BSDF &bsdf, TexturedParam::Name name);
// A layer's weight or opacity at uv (its texture's, if it has one).
Real layer_param(const BSDF &bsdf, const std::vector<Texture> &textures, Vec2 uv, Real constant);
// The BSDF at a surface point: `bsdf` itself if nothing in it is textured, else `local`,
// set to its model with the textured parameters looked up at uv.
const BSDF &bsdf_at(const BSDF &bsdf, const std::vector<Texture> &textures, Vec2 uv, BSDF &local);

struct BSDFSample {
    Vec3 wo;
    Spectrum weight;  // f * |cos wo| / pdf
    Real pdf = 0;
    bool delta = false;
    bool diffuse = false;  // from a diffuse lobe (else glossy or specular)
};

inline bool is_null(const BSDF &b) { return !is_layered(b) && std::holds_alternative<NullBSDF>(b.model); }
inline bool is_delta(const BSDF &b) {
    if (const auto *c = std::get_if<ConductorBSDF>(&b.model)) return c->alpha == 0;
    return std::holds_alternative<DielectricBSDF>(b.model) || std::holds_alternative<ThinDielectricBSDF>(b.model);
}

// The colour a denoiser's albedo pass holds for the surface: its diffuse reflectance, or
// white where it reflects or transmits specularly.
Spectrum bsdf_albedo(const BSDF &bsdf);
// The ray kinds of a BSDF's lobes (RayKind bits): Diffuse, Glossy (specular included) and
// Transmission.
constexpr uint8_t kLobeRays = uint8_t(RayKind::Diffuse) | uint8_t(RayKind::Glossy) | uint8_t(RayKind::Transmission);
// f(wi, wo) * |cos wo|; with `hidden_lobes` (kLobeRays bits), from the other lobes alone:
// what a light hidden from those rays lights (Blender's ray visibility of lights).
Spectrum bsdf_eval(const BSDF &bsdf, Vec3 wi, Vec3 wo, uint8_t hidden_lobes = 0);
Real bsdf_pdf(const BSDF &bsdf, Vec3 wi, Vec3 wo);
bool bsdf_sample(const BSDF &bsdf, Vec3 wi, Real u_lobe, Vec2 u, BSDFSample &out);

// Unpolarised Fresnel reflectance of a conductor of complex index eta + i k, per channel,
// for a cosine in (0, 1]; 1 where eta = k = 0.
Spectrum fresnel_conductor(Real cos_theta_i, const Spectrum &eta, const Spectrum &k);

// Fresnel reflectance of a dielectric interface averaged over a cosine-weighted hemisphere
// on the side that sees relative index eta, by quadrature.
Real fresnel_diffuse_reflectance(Real eta);

// Unpolarised Fresnel reflectance of a dielectric interface for a cosine on either side
// (eta = interior / exterior). Sets the signed cosine of the refracted direction.
Real fresnel_dielectric(Real cos_theta_i, Real eta, Real *cos_theta_t = nullptr);

}  // namespace volpath
