// Layered surfaces (blend, mask, normal and bump maps) resolved at a hit.
#include <algorithm>
#include <cmath>

#include "volpath/scene.h"

namespace volpath {

namespace {

// The shading normal `n` turned toward `turned` by `strength` (1: all the way), kept on the
// geometric normal's side; where it would leave it, `n` as it was.
Vec3 blend_normal(const Vec3 &n, const Vec3 &turned, Real strength, const Vec3 &geometric) {
    const Vec3 m = n + (turned - n) * strength;
    const Real len = length(m);
    if (!(len > 0)) return n;
    const Vec3 out = m / len;
    return dot(out, geometric) > 0 ? out : n;
}

// The tangent along dp/du in the plane normal to n (any tangent where dp/du is along n).
Vec3 tangent_along(const Vec3 &n, const Vec3 &dpdu) {
    const Vec3 s = dpdu - n * dot(n, dpdu);
    const Real len = length(s);
    return len > 1e-12 * length(dpdu) && len > 0 ? s / len : Frame(n).s;
}

Vec3 normal_mapped(const Scene &scene, const NormalMapLayer &layer, const Intersection &its, Vec2 uv, const Vec3 &n) {
    Vec3 dpdu, dpdv;
    scene.geometry.uv_tangents(its, dpdu, dpdv);
    const Vec3 s = tangent_along(n, dpdu), t = cross(n, s);
    const Spectrum c = eval_texture(scene.textures[size_t(layer.texture)], uv);
    const Vec3 m = s * (2 * c[0] - 1) + t * (2 * c[1] - 1) + n * (2 * c[2] - 1);
    const Real len = length(m);
    return len > 0 ? blend_normal(n, m / len, layer.strength, its.n) : n;
}

// The normal of the surface displaced by scale * h(uv) along n: the tangents dp/du and
// dp/dv (in the plane normal to n) gain n times the height's derivatives, taken by central
// differences half a texel apart.
Vec3 bump_mapped(const Scene &scene, const BumpMapLayer &layer, const Intersection &its, Vec2 uv, const Vec3 &n) {
    Vec3 dpdu, dpdv;
    scene.geometry.uv_tangents(its, dpdu, dpdv);
    const Texture &texture = scene.textures[size_t(layer.texture)];
    const Real step = texture_step(texture);
    const auto h = [&](Real du, Real dv) { return eval_texture(texture, {uv.x + du, uv.y + dv})[0]; };
    const Real dh_du = layer.scale * (h(step, 0) - h(-step, 0)) / (2 * step);
    const Real dh_dv = layer.scale * (h(0, step) - h(0, -step)) / (2 * step);
    const Vec3 su = dpdu - n * dot(n, dpdu) + n * dh_du, sv = dpdv - n * dot(n, dpdv) + n * dh_dv;
    Vec3 bumped = cross(su, sv);
    const Real len = length(bumped);
    if (!(len > 0)) return n;
    bumped = bumped / len;
    return blend_normal(n, dot(bumped, n) < 0 ? -bumped : bumped, layer.strength, its.n);
}

}  // namespace

void surface_at(const Scene &scene, int index, const Intersection &its, Real u, SurfacePoint &out) {
    const int top = index;
    out.ns = its.ns;
    const BSDF &first = scene.bsdfs[size_t(index)];
    if (!is_layered(first) && first.textured.empty()) {  // most surfaces: no uv needed
        out.bsdf = &first;
        return;
    }
    const Vec2 uv = scene.geometry.uv(its);
    for (;;) {
        const BSDF &b = scene.bsdfs[size_t(index)];
        if (const auto *blend = std::get_if<BlendLayer>(&b.layer)) {
            const Real w = layer_param(b, scene.textures, uv, blend->weight);
            if (u < w) {
                u = u / w, index = blend->b;
            } else {
                u = (u - w) / (1 - w), index = blend->a;
            }
        } else if (const auto *mask = std::get_if<MaskLayer>(&b.layer)) {
            const Real opacity = layer_param(b, scene.textures, uv, mask->opacity);
            if (u >= opacity) {
                out.bsdf = nullptr;
                out.pass = surface_pass(scene, top, uv);
                return;
            }
            u = u / opacity, index = mask->nested;
        } else if (const auto *normal_map = std::get_if<NormalMapLayer>(&b.layer)) {
            out.ns = normal_mapped(scene, *normal_map, its, uv, out.ns);
            index = normal_map->nested;
        } else if (const auto *bump = std::get_if<BumpMapLayer>(&b.layer)) {
            out.ns = bump_mapped(scene, *bump, its, uv, out.ns);
            index = bump->nested;
        } else if (index != top && is_null(b)) {  // a blend's transparent part: as a mask's
            out.bsdf = nullptr;
            out.pass = surface_pass(scene, top, uv);
            return;
        } else {
            out.bsdf = &bsdf_at(b, scene.textures, uv, out.local);
            return;
        }
        u = std::min(u, std::nextafter(Real(1), Real(0)));  // the rescaling's rounding
    }
}

Real surface_pass(const Scene &scene, int index, Vec2 uv) {
    const BSDF &b = scene.bsdfs[size_t(index)];
    if (const auto *blend = std::get_if<BlendLayer>(&b.layer)) {
        const Real w = layer_param(b, scene.textures, uv, blend->weight);
        return (1 - w) * surface_pass(scene, blend->a, uv) + w * surface_pass(scene, blend->b, uv);
    }
    if (const auto *mask = std::get_if<MaskLayer>(&b.layer))
        return 1 - layer_param(b, scene.textures, uv, mask->opacity) * (1 - surface_pass(scene, mask->nested, uv));
    if (const auto *normal_map = std::get_if<NormalMapLayer>(&b.layer))
        return surface_pass(scene, normal_map->nested, uv);
    if (const auto *bump = std::get_if<BumpMapLayer>(&b.layer)) return surface_pass(scene, bump->nested, uv);
    return is_null(b) ? 1 : 0;
}

}  // namespace volpath
