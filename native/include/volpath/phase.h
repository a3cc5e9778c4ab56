// Phase functions. Angles are between travel directions: mu = dot(d_in, d_out), so
// mu = 1 is straight on and g > 0 scatters forward. Every phase function integrates
// to one over the sphere.
#pragma once

#include <variant>

#include "math.h"

namespace volpath {

struct IsotropicPhase {};
struct HenyeyGreenstein {
    Real g = 0;
};

using PhaseFunction = std::variant<IsotropicPhase, HenyeyGreenstein>;

struct PhaseSample {
    Vec3 d_out;
    Real pdf = 0;  // equals the phase value: both phase functions are sampled exactly
};

Real phase_eval(const PhaseFunction &phase, Real mu);
PhaseSample phase_sample(const PhaseFunction &phase, const Vec3 &d_in, Vec2 u);

// Henyey-Greenstein density and its inversion method, shared by media that mix lobes.
Real hg_eval(Real g, Real mu);
Real hg_sample_mu(Real g, Real u);
// The direction at polar cosine mu around `axis`, azimuth 2 pi u.
Vec3 direction_around(const Vec3 &axis, Real mu, Real u);

}  // namespace volpath
