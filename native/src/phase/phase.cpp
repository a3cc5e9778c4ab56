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

Vec3 direction_around(const Vec3 &axis, Real mu, Real u) {
    const Real sin_theta = safe_sqrt(1.0 - mu * mu);
    const Real phi = 2.0 * kPi * u;
    return Frame(axis).to_world({sin_theta * std::cos(phi), sin_theta * std::sin(phi), mu});
}

namespace {
struct Eval {
    Real mu;
    Real operator()(const IsotropicPhase &) const { return kInv4Pi; }
    Real operator()(const HenyeyGreenstein &p) const { return hg_eval(p.g, mu); }
};
struct Sample {
    const Vec3 &d_in;
    Vec2 u;
    PhaseSample operator()(const IsotropicPhase &) const {
        const Real mu = 1.0 - 2.0 * u.x;
        return {direction_around(d_in, mu, u.y), kInv4Pi};
    }
    PhaseSample operator()(const HenyeyGreenstein &p) const {
        const Real mu = hg_sample_mu(p.g, u.x);
        return {direction_around(d_in, mu, u.y), hg_eval(p.g, mu)};
    }
};
}  // namespace

Real phase_eval(const PhaseFunction &phase, Real mu) { return std::visit(Eval{mu}, phase); }
PhaseSample phase_sample(const PhaseFunction &phase, const Vec3 &d_in, Vec2 u) {
    return std::visit(Sample{d_in, u}, phase);
}

}  // namespace volpath
