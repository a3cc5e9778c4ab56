// BSDF parameters that vary over a surface: looked up in their textures at each hit.
#include <algorithm>

#include "volpath/bsdf.h"

namespace volpath {

namespace {

// Where the parameter lives in the model, or nullptr: a colour (Reflectance, Specular) or
// a roughness (Alpha).
Spectrum *colour_param(BSDFModel &model, TexturedParam::Name name) {
    using Name = TexturedParam::Name;
    if (auto *d = std::get_if<DiffuseBSDF>(&model)) return name == Name::Reflectance ? &d->reflectance : nullptr;
    if (auto *p = std::get_if<RoughPlasticBSDF>(&model)) {
        if (name == Name::Reflectance) return &p->diffuse;
        if (name == Name::Specular) return &p->specular;
    }
    if (auto *c = std::get_if<ConductorBSDF>(&model)) return name == Name::Specular ? &c->specular : nullptr;
    return nullptr;
}

Real *alpha_param(BSDFModel &model) {
    if (auto *p = std::get_if<RoughPlasticBSDF>(&model)) return &p->alpha;
    if (auto *c = std::get_if<ConductorBSDF>(&model)) return &c->alpha;
    if (auto *d = std::get_if<RoughDielectricBSDF>(&model)) return &d->alpha;
    return nullptr;
}

Spectrum param_value(const TexturedParam &param, const std::vector<Texture> &textures, Vec2 uv) {
    const Spectrum t = eval_texture(textures[size_t(param.texture)], uv);
    Spectrum v = param.offset;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) v[i] += param.scale[i][j] * t[j];
    return param.squared ? v * v : v;
}

}  // namespace

bool has_param(const BSDF &bsdf, TexturedParam::Name name) {
    using Name = TexturedParam::Name;
    if (name == Name::Weight) return std::holds_alternative<BlendLayer>(bsdf.layer);
    if (name == Name::Opacity) return std::holds_alternative<MaskLayer>(bsdf.layer);
    if (is_layered(bsdf)) return false;
    BSDFModel copy = bsdf.model;
    return name == Name::Alpha ? alpha_param(copy) != nullptr : colour_param(copy, name) != nullptr;
}

Real layer_param(const BSDF &bsdf, const std::vector<Texture> &textures, Vec2 uv, Real constant) {
    // A layer has one parameter (a blend's weight, a mask's opacity), kept in [0, 1].
    const Real v = bsdf.textured.empty() ? constant : param_value(bsdf.textured[0], textures, uv)[0];
    return std::clamp(v, Real(0), Real(1));
}

const BSDF &bsdf_at(const BSDF &bsdf, const std::vector<Texture> &textures, Vec2 uv, BSDF &local) {
    if (bsdf.textured.empty()) return bsdf;
    local.model = bsdf.model;
    local.twosided = bsdf.twosided;
    for (const TexturedParam &param : bsdf.textured) {
        const Spectrum v = param_value(param, textures, uv);
        if (param.name == TexturedParam::Name::Alpha) {
            // A smooth microfacet model would be a delta one, which the model cannot switch to
            // per point: the floor the loader gives a constant roughness.
            *alpha_param(local.model) = std::max(v[0], Real(1e-3));
        } else {
            *colour_param(local.model, param.name) = clamp_zero(v);
        }
    }
    return local;
}

}  // namespace volpath
