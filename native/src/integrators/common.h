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

// The integral of T(t) = exp(-sigma_t t) over [0, d], per channel: what a homogeneous
// segment's emission sigma_a Le is weighted by (expm1: exact for thin media too).
inline Spectrum transmittance_integral(const Spectrum &sigma_t, Real d) {
    Spectrum span;
    for (int c = 0; c < 3; ++c) span[c] = sigma_t[c] > 0 ? -std::expm1(-sigma_t[c] * d) / sigma_t[c] : d;
    return span;
}

// The absorption tracer (absorption.cpp).
Spectrum absorption_radiance(const Scene &scene, Ray ray, int medium, Sampler &sampler);

}  // namespace volpath
