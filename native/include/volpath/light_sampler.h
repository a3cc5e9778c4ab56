// Choosing the light for next-event estimation by what each may give the point it lights
// (pbrt-v4's light sampling by importance): a distant light's irradiance, a point light's
// intensity over the squared distance, an area light's radiance times the solid angle it
// may subtend. Near and bright lights are chosen more often than far and dim ones. Many
// local lights are chosen through a tree of their bounds (a light BVH: each step down picks
// a child by the power it holds over its squared distance), so that a choice costs the
// tree's depth, not the number of lights. A share (kUniformShare) of the choices is spread
// evenly over all candidates, for what the estimates ignore (occlusion, the BSDF, a
// surface's orientation). The probability of a light depends on the point: an emitter that
// the path finds is weighted with the probability NEE would have had at the path's last
// vertex.
#pragma once

#include <vector>

#include "light.h"

namespace volpath {

// What a light's importance at a point needs.
struct LightBound {
    enum class Kind : uint8_t { Distant, Point, Area, Sphere };
    Kind kind = Kind::Distant;
    Real power = 0;  // luminance: a distant light's irradiance, a point's intensity, an area's peak radiance
    Vec3 position;   // a point light's; a sphere's centre; a point of a flat area light's plane
    Bounds bounds;   // where a local light lies
    Real area = 0, radius = 0;
    Vec3 facing{0.0};  // a flat one-sided area light's normal (the side it lights); else zero
    SpotCone spot;     // a point light's
    Real flux = 0;     // a local light's power over all directions (luminance), for the tree
};
LightBound light_bound(const Light &light, const Geometry &geometry);
// The light's importance at p: an estimate of the irradiance it may bring there; 0 only where
// it surely brings none (the back of a flat one-sided light, outside a spot's cone).
Real light_importance(const LightBound &b, const Vec3 &p);

class LightSampler {
public:
    // The share of the choices spread evenly over the candidates.
    static constexpr Real kUniformShare = 0.1;
    // Up to this many local lights are weighed one by one; more go into the tree.
    static constexpr size_t kLinearLights = 16;

    LightSampler() = default;
    LightSampler(const std::vector<Light> &lights, const std::vector<int> &candidates, const Geometry &geometry);
    // A light for the point p by u in [0, 1), and its probability; -1 where none is chosen
    // (every light's importance at p is 0 and the uniform share was not drawn).
    int sample(const Vec3 &p, Real u, Real &pdf) const;
    // The probability that sample(p, .) chooses `light` (an index into the scene's lights).
    Real pdf(const Vec3 &p, int light) const;

private:
    struct Node {
        Bounds bounds;
        Real flux = 0;
        int child = -1;  // the first of two children (the second follows it); -1: a leaf
        int slot = -1;   // a leaf's light (its place among the candidates)
    };
    std::vector<int> lights_;           // the candidates (indices into the scene's lights)
    std::vector<LightBound> bounds_;    // theirs, in the same order
    std::vector<int> slot_;             // per scene light: its place among the candidates, or -1
    std::vector<int> distant_, local_;  // candidates by kind (places)
    std::vector<Node> nodes_;           // the tree over local_ (root first), if it has more than kLinearLights
    std::vector<uint64_t> trail_;       // per candidate in the tree: its path from the root, a bit per level

    void build(int index, std::vector<int> &slots, size_t begin, size_t end, uint64_t trail, int depth);
    Real node_importance(const Node &n, const Vec3 &p) const;
    // The local lights' importance together at p (the tree's root, or their sum).
    Real local_importance(const Vec3 &p) const;
    // Importance sampling without the uniform share: a place, and its probability.
    int importance_sample(const Vec3 &p, Real u, Real &pdf) const;
    Real importance_pdf(const Vec3 &p, int slot) const;
    Real pdf_of_slot(const Vec3 &p, int slot) const;
};

}  // namespace volpath
