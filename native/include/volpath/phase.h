// Phase functions. Angles are between travel directions: mu = dot(d_in, d_out), so
// mu = 1 is straight on and g > 0 scatters forward. Every phase function integrates
// to one over the sphere.
//
// Values and pdfs are per colour channel: in a mixture such as air (Rayleigh + Mie)
// the share of each lobe depends on the wavelength. Sampling follows one channel's
// mixture; the pdfs of the others are what the spectral MIS needs.
#pragma once

#include <variant>

#include "math.h"

namespace volpath {

struct IsotropicPhase {};
struct HenyeyGreenstein {
    Real g = 0;
};
// Air: Rayleigh p_R(mu) = 3/(16 pi) (1 + mu^2) and Cornette-Shanks p_CS(mu, g), mixed
// per channel in proportion to their scattering coefficients (rayleigh_fraction).
struct RayleighMiePhase {
    Spectrum rayleigh_fraction;
    Real g = 0.76;
};

using PhaseFunction = std::variant<IsotropicPhase, HenyeyGreenstein, RayleighMiePhase>;

struct PhaseSample {
    Vec3 d_out;
    Spectrum value;  // phase function per channel
    Spectrum pdf;    // density of d_out had each channel been the sampling channel
};

Spectrum phase_eval(const PhaseFunction &phase, Real mu);
Spectrum phase_pdf(const PhaseFunction &phase, Real mu);
PhaseSample phase_sample(const PhaseFunction &phase, const Vec3 &d_in, Vec2 u, Real u_lobe, int channel);

Real hg_eval(Real g, Real mu);
Real hg_sample_mu(Real g, Real u);
Real rayleigh_eval(Real mu);
Real rayleigh_sample_mu(Real u);
Real cornette_shanks_eval(Real g, Real mu);
// The direction at polar cosine mu around `axis`, azimuth 2 pi u.
Vec3 direction_around(const Vec3 &axis, Real mu, Real u);

}  // namespace volpath
