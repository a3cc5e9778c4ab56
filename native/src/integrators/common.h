// What the tracers share: how rays cross shapes.
#pragma once

#include "volpath/integrator.h"

namespace volpath {

// The medium a ray travels in after crossing `shape` along d at a point with normal n.
inline int medium_after_crossing(const ShapeInfo &shape, const Vec3 &d, const Vec3 &n, int current) {
    if (!shape.medium_interface) return current;
    return dot(d, n) > 0 ? shape.exterior : shape.interior;
}

// Rays that keep re-entering index-matched surfaces (coincident boundaries) stop here.
constexpr int kMaxNullCrossings = 256;

// The absorption tracer (absorption.cpp).
Spectrum absorption_radiance(const Scene &scene, Ray ray, int medium, Sampler &sampler);

}  // namespace volpath
