#include "volpath/phase.h"

namespace volpath {

Real hg_eval(Real g, Real mu) {
    const Real denom = 1.0 + g * g - 2.0 * g * mu;
    return kInv4Pi * (1.0 - g * g) / (denom * safe_sqrt(denom));
}

// Inverting the HG cdf: mu = (1 + g^2 - ((1 - g^2) / (1 - g + 2 g u))^2) / (2 g).
// Near g = 0 that form cancels catastrophically, so it falls back to isotropic.
Real hg_sample_mu(Real g, Real u) {
    if (std::abs(g) < 1e-4) return 1.0 - 2.0 * u;
    const Real s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    return std::clamp((1.0 + g * g - s * s) / (2.0 * g), -1.0, 1.0);
}

Real rayleigh_eval(Real mu) { return 3.0 / (16.0 * kPi) * (1.0 + mu * mu); }

// The cdf (3/8)(mu + mu^3/3) + 1/2 = u is the depressed cubic mu^3 + 3 mu - 4 (2u - 1) = 0,
// solved by Cardano's formula (one real root).
Real rayleigh_sample_mu(Real u) {
    const Real q = 2.0 * (2.0 * u - 1.0);
    const Real r = std::sqrt(q * q + 1.0);
    return std::clamp(std::cbrt(q + r) + std::cbrt(q - r), -1.0, 1.0);
}

// Cornette & Shanks (1992): 3/(8 pi) (1 - g^2)(1 + mu^2) / ((2 + g^2)(1 + g^2 - 2 g mu)^{3/2}).
Real cornette_shanks_eval(Real g, Real mu) {
    const Real denom = 1.0 + g * g - 2.0 * g * mu;
    return 3.0 / (8.0 * kPi) * (1.0 - g * g) * (1.0 + mu * mu) / ((2.0 + g * g) * denom * safe_sqrt(denom));
}

Vec3 direction_around(const Vec3 &axis, Real mu, Real u) {
    const Real sin_theta = safe_sqrt(1.0 - mu * mu);
    const Real phi = 2.0 * kPi * u;
    return Frame(axis).to_world({sin_theta * std::cos(phi), sin_theta * std::sin(phi), mu});
}

namespace {
// The Mie lobe is sampled with Henyey-Greenstein of the same g (no closed-form inverse
// exists for Cornette-Shanks); its pdf is then HG's, its value CS's.
Spectrum air_pdf(const RayleighMiePhase &p, Real mu) {
    const Real r = rayleigh_eval(mu), m = hg_eval(p.g, mu);
    return p.rayleigh_fraction * r + (Spectrum(1.0) - p.rayleigh_fraction) * m;
}

struct Eval {
    Real mu;
    Spectrum operator()(const IsotropicPhase &) const { return Spectrum(kInv4Pi); }
    Spectrum operator()(const HenyeyGreenstein &p) const { return Spectrum(hg_eval(p.g, mu)); }
    Spectrum operator()(const RayleighMiePhase &p) const {
        const Real r = rayleigh_eval(mu), m = cornette_shanks_eval(p.g, mu);
        return p.rayleigh_fraction * r + (Spectrum(1.0) - p.rayleigh_fraction) * m;
    }
};
struct Sample {
    const Vec3 &d_in;
    Vec2 u;
    Real u_lobe;
    int channel;
    Real operator()(const IsotropicPhase &) const { return 1.0 - 2.0 * u.x; }
    Real operator()(const HenyeyGreenstein &p) const { return hg_sample_mu(p.g, u.x); }
    Real operator()(const RayleighMiePhase &p) const {
        return u_lobe < p.rayleigh_fraction[channel] ? rayleigh_sample_mu(u.x) : hg_sample_mu(p.g, u.x);
    }
};
}  // namespace

Spectrum phase_eval(const PhaseFunction &phase, Real mu) { return std::visit(Eval{mu}, phase); }
Spectrum phase_pdf(const PhaseFunction &phase, Real mu) {
    if (const auto *air = std::get_if<RayleighMiePhase>(&phase)) return air_pdf(*air, mu);
    return phase_eval(phase, mu);  // the other phase functions are sampled exactly
}

PhaseSample phase_sample(const PhaseFunction &phase, const Vec3 &d_in, Vec2 u, Real u_lobe, int channel) {
    const Real mu = std::visit(Sample{d_in, u, u_lobe, channel}, phase);
    return {direction_around(d_in, mu, u.y), phase_eval(phase, mu), phase_pdf(phase, mu)};
}

}  // namespace volpath
