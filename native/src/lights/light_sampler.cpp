#include "volpath/light_sampler.h"

#include <algorithm>

namespace volpath {

namespace {

struct Bound {
    const Geometry &geometry;
    LightBound operator()(const PointLight &l) const {
        LightBound b;
        b.kind = LightBound::Kind::Point;
        b.power = luminance(l.intensity);
        b.position = l.position;
        b.bounds.extend(l.position);
        b.spot = l.spot;
        b.flux = b.power * 2 * kPi * (1 - l.spot.cos_half);  // intensity x the cone's solid angle
        return b;
    }
    LightBound operator()(const DirectionalLight &l) const { return distant(luminance(l.irradiance)); }
    LightBound operator()(const SunLight &l) const {
        return distant(luminance(l.radiance) * 2 * kPi * (1 - l.cos_max));  // radiance x the disc's solid angle
    }
    // The irradiance of a uniform sky of the map's mean radiance: pi times it. The map's
    // distribution integrates luminance x sin(theta) over the unit square, which the sphere
    // stretches by 2 pi^2: the mean radiance is pi / 2 times that integral.
    LightBound operator()(const EnvironmentLight &env) const {
        const Real mean = env.width == 0 ? 1.0 : kPi / 2 * env.distribution.marginal.integral;
        return distant(kPi * mean * luminance(env.scale));
    }
    LightBound operator()(const AreaLight &l) const {
        LightBound b;
        // The spread's slats pass tan(h) x normalization along the normal: its peak.
        const Real peak = l.spread >= kPi ? 1.0 : l.tan_half_spread * l.spread_normalization;
        const Real radiance = luminance(l.radiance) * l.mean_texture;
        b.power = radiance * peak;
        b.area = l.area;
        b.flux = radiance * kPi * l.area * (l.twosided ? 2 : 1);
        const ShapeGeometry &sg = geometry.shapes[size_t(l.shape)];
        if (sg.is_sphere()) {
            const Sphere &s = geometry.spheres[sg.index];
            b.kind = LightBound::Kind::Sphere;
            b.position = s.center, b.radius = s.radius;
            b.bounds.extend(s.center - Vec3(s.radius)), b.bounds.extend(s.center + Vec3(s.radius));
            return b;
        }
        b.kind = LightBound::Kind::Area;
        const TriangleMesh &m = geometry.meshes[sg.index];
        for (const Vec3 &v : m.positions) b.bounds.extend(v);
        if (!l.twosided && !m.triangles.empty()) {
            b.facing = flat_normal(m);
            b.position = m.positions[m.triangles[0][0]];  // a point of its plane
        }
        return b;
    }

    static LightBound distant(Real power) {
        LightBound b;
        b.power = power;
        return b;
    }
    // The normal of a flat mesh whose triangles all face one way (the side it lights), or
    // zero where it is not flat or they do not.
    static Vec3 flat_normal(const TriangleMesh &m) {
        Vec3 n(0.0);
        for (const auto &t : m.triangles) {
            const Vec3 c = cross(m.positions[t[1]] - m.positions[t[0]], m.positions[t[2]] - m.positions[t[0]]);
            if (!(length_squared(c) > 0)) continue;
            if (is_black(n)) n = normalize(c);
            if (dot(c, n) <= 0) return Vec3(0.0);
        }
        const Vec3 &o = m.positions[m.triangles[0][0]];
        for (const Vec3 &v : m.positions)
            if (std::abs(dot(v - o, n)) > 1e-9 * (1 + length(v - o))) return Vec3(0.0);
        return n;
    }
};

// The squared distance from p to the box (0 inside).
Real distance_squared(const Bounds &b, const Vec3 &p) {
    const Vec3 d = max(max(b.lo - p, p - b.hi), Vec3(0.0));
    return length_squared(d);
}

}  // namespace

LightBound light_bound(const Light &light, const Geometry &geometry) { return std::visit(Bound{geometry}, light); }

Real light_importance(const LightBound &b, const Vec3 &p) {
    switch (b.kind) {
        case LightBound::Kind::Distant:
            return b.power;
        case LightBound::Kind::Point: {
            const Vec3 to = p - b.position;
            const Real d2 = std::max(length_squared(to), Real(1e-12));
            return b.power * spot_falloff(b.spot, to / std::sqrt(d2)) / d2;
        }
        case LightBound::Kind::Sphere: {
            const Real d2 = length_squared(p - b.position), r2 = b.radius * b.radius;
            const Real solid_angle = d2 > r2 ? 2 * kPi * (1 - safe_sqrt(1 - r2 / d2)) : 4 * kPi;
            return b.power * solid_angle;
        }
        case LightBound::Kind::Area: {
            // In front of a flat one-sided light's plane only.
            if (!is_black(b.facing) && dot(p - b.position, b.facing) <= 0) return 0;
            const Real d2 = distance_squared(b.bounds, p);
            return b.power * std::min(d2 > 0 ? b.area / d2 : kInfinity, 2 * kPi);
        }
    }
    return 0;
}

LightSampler::LightSampler(const std::vector<Light> &lights, const std::vector<int> &candidates,
                           const Geometry &geometry)
    : lights_(candidates), slot_(lights.size(), -1) {
    for (size_t i = 0; i < candidates.size(); ++i) {
        bounds_.push_back(light_bound(lights[size_t(candidates[i])], geometry));
        slot_[size_t(candidates[i])] = int(i);
        (bounds_.back().kind == LightBound::Kind::Distant ? distant_ : local_).push_back(int(i));
    }
    if (local_.size() > kLinearLights) {
        trail_.assign(bounds_.size(), 0);
        std::vector<int> slots = local_;
        nodes_.resize(1);
        build(0, slots, 0, slots.size(), 0, 0);
    }
}

// Node `index` over slots[begin, end): split at the median of the lights' centres along the
// axis where those spread most.
void LightSampler::build(int index, std::vector<int> &slots, size_t begin, size_t end, uint64_t trail, int depth) {
    Node node;
    Bounds centres;
    for (size_t i = begin; i < end; ++i) {
        const LightBound &b = bounds_[size_t(slots[i])];
        node.bounds.extend(b.bounds);
        node.flux += b.flux;
        centres.extend(b.bounds.centroid());
    }
    if (end - begin == 1) {
        node.slot = slots[begin];
        trail_[size_t(node.slot)] = trail;
        nodes_[size_t(index)] = node;
        return;
    }
    const Vec3 extent = centres.hi - centres.lo;
    const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
    const size_t mid = (begin + end) / 2;
    std::nth_element(slots.begin() + long(begin), slots.begin() + long(mid), slots.begin() + long(end),
                     [&](int a, int b) {
                         return bounds_[size_t(a)].bounds.centroid()[axis] < bounds_[size_t(b)].bounds.centroid()[axis];
                     });
    node.child = int(nodes_.size());
    nodes_[size_t(index)] = node;
    nodes_.resize(nodes_.size() + 2);
    build(node.child, slots, begin, mid, trail, depth + 1);
    build(node.child + 1, slots, mid, end, trail | (uint64_t(1) << depth), depth + 1);
}

// A leaf weighs its light as one by one; a node its lights' flux as from the nearest point
// of its bounds, no nearer than a third of its half-diagonal (inside them, its lights may be
// anywhere around). The distance to the centre instead (pbrt-v4's, without its orientation
// cones) weighs the top levels' halves of a scene nearly alike wherever the point is.
Real LightSampler::node_importance(const Node &n, const Vec3 &p) const {
    if (n.slot >= 0) return light_importance(bounds_[size_t(n.slot)], p);
    const Real half_diagonal2 = length_squared(n.bounds.hi - n.bounds.lo) / 4;
    return n.flux / (4 * kPi * std::max(distance_squared(n.bounds, p), 0.1 * half_diagonal2));
}

Real LightSampler::local_importance(const Vec3 &p) const {
    if (!nodes_.empty()) return node_importance(nodes_[0], p);
    Real sum = 0;
    for (int i : local_) sum += light_importance(bounds_[size_t(i)], p);
    return sum;
}

int LightSampler::importance_sample(const Vec3 &p, Real u, Real &pdf) const {
    const Real local = local_importance(p);
    Real total = local;
    for (int i : distant_) total += bounds_[size_t(i)].power;
    if (!(total > 0)) return -1;
    // The distant lights one by one, then the local ones together.
    Real cdf = 0;
    for (int i : distant_) {
        const Real q = bounds_[size_t(i)].power / total;
        if (u < cdf + q) {
            pdf = q;
            return i;
        }
        cdf += q;
    }
    if (!(local > 0)) return -1;  // rounding left u past the distant lights
    pdf = local / total;
    u = std::min((u - cdf) * total / local, Real(1) - 0x1p-53);
    if (nodes_.empty()) {
        for (int i : local_) {
            const Real q = light_importance(bounds_[size_t(i)], p) / local;
            if (u < q || i == local_.back()) {
                pdf *= q;
                return q > 0 ? i : -1;
            }
            u -= q;
        }
    }
    const Node *n = &nodes_[0];
    while (n->slot < 0) {
        const Node &a = nodes_[size_t(n->child)], &b = nodes_[size_t(n->child) + 1];
        const Real wa = node_importance(a, p), wb = node_importance(b, p);
        if (!(wa + wb > 0)) return -1;
        const Real q = wa / (wa + wb);
        if (u < q) {
            pdf *= q, u /= q, n = &a;
        } else {
            pdf *= wb / (wa + wb), u = (u - q) / (1 - q), n = &b;  // as importance_pdf has it
        }
        u = std::min(u, Real(1) - 0x1p-53);
    }
    return n->slot;
}

Real LightSampler::importance_pdf(const Vec3 &p, int slot) const {
    const LightBound &b = bounds_[size_t(slot)];
    const Real local = local_importance(p);
    Real total = local;
    for (int i : distant_) total += bounds_[size_t(i)].power;
    if (!(total > 0)) return 0;
    if (b.kind == LightBound::Kind::Distant) return b.power / total;
    if (!(local > 0)) return 0;
    if (nodes_.empty()) return local / total * (light_importance(b, p) / local);  // as importance_sample has it
    Real pdf = local / total;
    const Node *n = &nodes_[0];
    for (int level = 0; n->slot < 0; ++level) {
        const Node &a = nodes_[size_t(n->child)], &c = nodes_[size_t(n->child) + 1];
        const Real wa = node_importance(a, p), wc = node_importance(c, p);
        if (!(wa + wc > 0)) return 0;
        const bool second = (trail_[size_t(slot)] >> level) & 1;
        pdf *= (second ? wc : wa) / (wa + wc);
        n = second ? &c : &a;
    }
    return pdf;
}

int LightSampler::sample(const Vec3 &p, Real u, Real &pdf) const {
    if (u < kUniformShare) {
        const int slot = std::min(int(u / kUniformShare * Real(lights_.size())), int(lights_.size()) - 1);
        pdf = pdf_of_slot(p, slot);
        return lights_[size_t(slot)];
    }
    // The descent's probability is importance_pdf's, product for product: no second descent.
    Real importance;
    const int slot = importance_sample(p, (u - kUniformShare) / (1 - kUniformShare), importance);
    if (slot < 0) return -1;
    pdf = kUniformShare / Real(lights_.size()) + (1 - kUniformShare) * importance;
    return lights_[size_t(slot)];
}

Real LightSampler::pdf(const Vec3 &p, int light) const {
    const int slot = slot_[size_t(light)];
    return slot < 0 ? 0.0 : pdf_of_slot(p, slot);
}

Real LightSampler::pdf_of_slot(const Vec3 &p, int slot) const {
    return kUniformShare / Real(lights_.size()) + (1 - kUniformShare) * importance_pdf(p, slot);
}

}  // namespace volpath
