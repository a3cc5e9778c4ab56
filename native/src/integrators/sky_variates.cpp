#include "sky_variates.h"

namespace volpath {

Spectrum scattered_sky_variate(const SkyPoint &sky, const RayleighMiePhase &air, const Vec3 &d_in, const Vec3 &d_out,
                               const Spectrum &arriving, Real pdf, Vec2 u) {
    const Spectrum &rayleigh = air.rayleigh_fraction, mie = Spectrum(1.0) - rayleigh;
    const Frame forward(d_in);
    Spectrum mie_integral(0.0);
    for (int k = 0; k < kMieLobeSamples; ++k) {
        const Real mu = hg_sample_mu(air.g, (k + u.x) / kMieLobeSamples), sin_theta = safe_sqrt(1 - mu * mu);
        const Real phi = 2 * kPi * std::fmod(u.y + k * kLatticeShift, 1.0);
        const Vec3 w = forward.to_world({sin_theta * std::cos(phi), sin_theta * std::sin(phi), mu});
        mie_integral += sky.map->radiance(sky.at, w) * (cornette_shanks_eval(air.g, mu) / hg_eval(air.g, mu));
    }
    const Real mu = dot(d_in, d_out);
    const Spectrum integral =
        rayleigh * sky.map->rayleigh_integral(sky.at, d_in) + mie * mie_integral / Real(kMieLobeSamples);
    const Spectrum value = (rayleigh * rayleigh_eval(mu) + mie * cornette_shanks_eval(air.g, mu)) * arriving;
    return integral - value / pdf;
}

Spectrum surface_sky_integral(const SurfaceSky &sky, const BSDF &bsdf, const Frame &frame, const Vec3 &wi, Vec2 u,
                              Real u_lobe) {
    Spectrum integral(0.0);
    for (int k = 0; k < kSurfaceMapSamples; ++k) {
        const Vec2 u_k{(k + u.x) / kSurfaceMapSamples, std::fmod(u.y + k * kLatticeShift, 1.0)};
        BSDFSample s;
        if (bsdf_sample(bsdf, wi, std::fmod(u_lobe + Real(k) / kSurfaceMapSamples, 1.0), u_k, s))
            integral += s.weight * sky.arriving(frame.to_world(s.wo));
    }
    return integral;
}

}  // namespace volpath
