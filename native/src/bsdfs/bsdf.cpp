#include "volpath/bsdf.h"

#include "volpath/warp.h"

namespace volpath {

Real fresnel_dielectric(Real cos_theta_i, Real eta, Real *cos_theta_t) {
    const bool outside = cos_theta_i >= 0;
    const Real eta_it = outside ? eta : 1.0 / eta, eta_ti = 1.0 / eta_it;
    const Real cos_t_sqr = 1.0 - eta_ti * eta_ti * (1.0 - cos_theta_i * cos_theta_i);
    if (cos_t_sqr <= 0) {  // total internal reflection
        if (cos_theta_t) *cos_theta_t = 0;
        return 1.0;
    }
    const Real ci = std::abs(cos_theta_i), ct = std::sqrt(cos_t_sqr);
    const Real a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    const Real a_p = (eta_it * ci - ct) / (eta_it * ci + ct);
    if (cos_theta_t) *cos_theta_t = outside ? -ct : ct;
    return 0.5 * (a_s * a_s + a_p * a_p);
}

Spectrum fresnel_conductor(Real cos_theta_i, const Spectrum &eta, const Spectrum &k) {
    Spectrum out;
    const Real c = std::clamp(cos_theta_i, 0.0, 1.0), c2 = c * c, s2 = 1 - c2;
    for (int i = 0; i < 3; ++i) {
        if (eta[i] == 0 && k[i] == 0) {
            out[i] = 1;
            continue;
        }
        // |r_s|^2 and |r_p|^2 with a^2 + b^2 = |eta^2 - sin^2 + ...| (the usual real form).
        const Real e2 = eta[i] * eta[i], k2 = k[i] * k[i];
        const Real t0 = e2 - k2 - s2, a2b2 = std::sqrt(t0 * t0 + 4 * e2 * k2), a = safe_sqrt(0.5 * (a2b2 + t0));
        const Real rs = (a2b2 + c2 - 2 * a * c) / (a2b2 + c2 + 2 * a * c);
        const Real rp = rs * (a2b2 * c2 + s2 * s2 - 2 * a * c * s2) / (a2b2 * c2 + s2 * s2 + 2 * a * c * s2);
        out[i] = std::clamp(0.5 * (rs + rp), 0.0, 1.0);
    }
    return out;
}

Real fresnel_diffuse_reflectance(Real eta) {
    // The integral of F(mu) 2 mu dmu over (0, 1] is that of F(sqrt(x)) dx: the midpoint
    // rule in x, fine enough that the rough plastic's albedo stays within 1e-6 of physics.
    constexpr int kSteps = 4096;
    Real sum = 0;
    for (int i = 0; i < kSteps; ++i) sum += fresnel_dielectric(std::sqrt((i + 0.5) / kSteps), eta);
    return sum / kSteps;
}

RoughPlasticBSDF rough_plastic(const Spectrum &diffuse, const Spectrum &specular, Real alpha, Real eta) {
    return {diffuse, specular, alpha, eta, fresnel_diffuse_reflectance(eta)};
}

namespace {

// GGX (Trowbridge-Reitz) normal distribution and Smith's separable masking.
Real ggx_d(Real alpha, const Vec3 &h) {
    if (h.z <= 0) return 0;
    const Real a2 = alpha * alpha;
    const Real t = h.z * h.z * (a2 - 1.0) + 1.0;
    return a2 / (kPi * t * t);
}
Real ggx_g1(Real alpha, const Vec3 &v, const Vec3 &h) {
    if (dot(v, h) * v.z <= 0) return 0;
    const Real tan2 = std::max(0.0, 1.0 - v.z * v.z) / (v.z * v.z);
    return 2.0 / (1.0 + std::sqrt(1.0 + alpha * alpha * tan2));
}

// h ~ D(h) cos(theta_h), facing +z: tan^2 theta = alpha^2 u / (1 - u).
Vec3 sample_ggx_normal(Real alpha, Vec2 u) {
    const Real tan2 = alpha * alpha * u.x / (1.0 - u.x);
    const Real cos_h = 1.0 / std::sqrt(1.0 + tan2);
    const Real sin_h = safe_sqrt(1.0 - cos_h * cos_h);
    const Real phi = 2.0 * kPi * u.y;
    return {sin_h * std::cos(phi), sin_h * std::sin(phi), cos_h};
}

// The microfacet normal that takes wi to wo, facing +z: the half vector for reflection,
// the generalised one wi + etap wo for refraction (etap: the index across, seen from wi's
// side); zero where the pair is degenerate or a facet would be seen from behind.
struct Microfacet {
    Vec3 h{0.0};
    Real etap = 1;
    bool reflect = true;
};
Microfacet microfacet(const Vec3 &wi, const Vec3 &wo, Real eta) {
    Microfacet m;
    m.reflect = wi.z * wo.z > 0;
    m.etap = m.reflect ? 1.0 : (wi.z > 0 ? eta : 1.0 / eta);
    const Vec3 h = wi + wo * m.etap;
    if (wi.z == 0 || wo.z == 0 || dot(h, h) == 0) return {};
    m.h = normalize(h) * (h.z < 0 ? -1.0 : 1.0);
    if (dot(m.h, wi) * wi.z <= 0 || dot(m.h, wo) * wo.z <= 0) m.h = Vec3(0.0);
    return m;
}

// Probability of choosing the specular lobe of the rough plastic: proportional to the
// energy each lobe returns at this incident angle, kept away from 0 and 1 so that
// both lobes stay reachable.
Real plastic_specular_probability(const RoughPlasticBSDF &b, Real cos_i) {
    const Real f = fresnel_dielectric(cos_i, b.eta);
    const Real s = f * max_component(b.specular);
    const Real d = (1.0 - f) * max_component(b.diffuse);
    return s + d > 0 ? std::clamp(s / (s + d), 0.05, 0.95) : 0.5;
}

struct Eval {
    Vec3 wi, wo;
    uint8_t hidden = 0;  // lobes left out (RayKind bits)
    bool shows(RayKind lobe) const { return !(hidden & uint8_t(lobe)); }
    Spectrum operator()(const NullBSDF &) const { return Spectrum(0.0); }
    // D G F / (4 |cos_i|) on reflection; on refraction D G (1 - F) |wi.h| |wo.h| /
    // (cos_i (wo.h + wi.h / etap)^2) / etap^2, radiance compressed on entering (pbrt-v4).
    Spectrum operator()(const RoughDielectricBSDF &b) const {
        const Microfacet m = microfacet(wi, wo, b.eta);
        if (m.h.z == 0) return Spectrum(0.0);
        const Real F = fresnel_dielectric(dot(wi, m.h), b.eta);
        const Real DG = ggx_d(b.alpha, m.h) * ggx_g1(b.alpha, wi, m.h) * ggx_g1(b.alpha, wo, m.h);
        if (!shows(m.reflect ? RayKind::Glossy : RayKind::Transmission)) return Spectrum(0.0);
        if (m.reflect) return b.reflectance * (DG * F / (4.0 * std::abs(wi.z)));
        const Real denom = sqr(dot(wo, m.h) + dot(wi, m.h) / m.etap) * std::abs(wi.z);
        return b.transmittance * (DG * (1.0 - F) * std::abs(dot(wo, m.h) * dot(wi, m.h)) / denom / sqr(m.etap));
    }
    Spectrum operator()(const DielectricBSDF &) const { return Spectrum(0.0); }
    Spectrum operator()(const ThinDielectricBSDF &) const { return Spectrum(0.0); }
    Spectrum operator()(const ConductorBSDF &b) const {
        if (b.alpha == 0 || wi.z <= 0 || wo.z <= 0 || !shows(RayKind::Glossy)) return Spectrum(0.0);
        const Vec3 h = normalize(wi + wo);
        const Real DG = ggx_d(b.alpha, h) * ggx_g1(b.alpha, wi, h) * ggx_g1(b.alpha, wo, h);
        return b.specular * fresnel_conductor(dot(wi, h), b.eta, b.k) * (DG / (4.0 * wi.z));
    }
    Spectrum operator()(const DiffuseBSDF &b) const {
        if (wi.z <= 0 || wo.z <= 0 || !shows(RayKind::Diffuse)) return Spectrum(0.0);
        return b.reflectance * (kInvPi * wo.z);
    }
    Spectrum operator()(const RoughPlasticBSDF &b) const {
        if (wi.z <= 0 || wo.z <= 0) return Spectrum(0.0);
        const Vec3 h = normalize(wi + wo);
        const Real f = fresnel_dielectric(dot(wi, h), b.eta);
        const Real spec = f * ggx_d(b.alpha, h) * ggx_g1(b.alpha, wi, h) * ggx_g1(b.alpha, wo, h) / (4.0 * wi.z);
        // Light enters and leaves the coating once each; the base reflects diffusely and
        // inter-reflects under the coating: the series 1 / (1 - Fdr_interior), where
        // eta^2 (1 - Fdr_interior) = 1 - Fdr_exterior (reciprocity). A white base thus
        // returns exactly what entered, 1 - F(wi).
        const Real t_i = 1.0 - fresnel_dielectric(wi.z, b.eta);
        const Real t_o = 1.0 - fresnel_dielectric(wo.z, b.eta);
        const Spectrum diff = b.diffuse * (kInvPi * wo.z * t_i * t_o / (1.0 - b.fdr_exterior));
        return (shows(RayKind::Glossy) ? b.specular * spec : Spectrum(0.0)) +
               (shows(RayKind::Diffuse) ? diff : Spectrum(0.0));
    }
};

struct Pdf {
    Vec3 wi, wo;
    Real operator()(const NullBSDF &) const { return 0; }
    // The facet's density D(h) cos(theta_h), times the Jacobian to wo, times the chance of
    // the lobe (Fresnel's).
    Real operator()(const RoughDielectricBSDF &b) const {
        const Microfacet m = microfacet(wi, wo, b.eta);
        if (m.h.z == 0) return 0;
        const Real F = fresnel_dielectric(dot(wi, m.h), b.eta);
        const Real pdf_h = ggx_d(b.alpha, m.h) * m.h.z;
        if (m.reflect) return pdf_h / (4.0 * std::abs(dot(wo, m.h))) * F;
        return pdf_h * std::abs(dot(wo, m.h)) / sqr(dot(wo, m.h) + dot(wi, m.h) / m.etap) * (1.0 - F);
    }
    Real operator()(const DielectricBSDF &) const { return 0; }
    Real operator()(const ThinDielectricBSDF &) const { return 0; }
    Real operator()(const ConductorBSDF &b) const {
        if (b.alpha == 0 || wi.z <= 0 || wo.z <= 0) return 0;
        const Vec3 h = normalize(wi + wo);
        return ggx_d(b.alpha, h) * h.z / (4.0 * std::abs(dot(wo, h)));
    }
    Real operator()(const DiffuseBSDF &) const { return wi.z > 0 ? cosine_hemisphere_pdf(wo.z) : 0.0; }
    Real operator()(const RoughPlasticBSDF &b) const {
        if (wi.z <= 0 || wo.z <= 0) return 0;
        const Real p_spec = plastic_specular_probability(b, wi.z);
        const Vec3 h = normalize(wi + wo);
        const Real pdf_spec = ggx_d(b.alpha, h) * h.z / (4.0 * std::abs(dot(wo, h)));
        return p_spec * pdf_spec + (1.0 - p_spec) * cosine_hemisphere_pdf(wo.z);
    }
};

struct Sample {
    Vec3 wi;
    Real u_lobe;
    Vec2 u;
    BSDFSample &out;
    // A non-delta sample's density and weight, from the model's own pdf and eval.
    template <typename Model>
    bool finish(const Model &b) const {
        out.pdf = Pdf{wi, out.wo}(b);
        if (!(out.pdf > 0)) return false;
        out.weight = Eval{wi, out.wo}(b) / out.pdf;
        return true;
    }
    bool operator()(const NullBSDF &) const { return false; }
    bool operator()(const DiffuseBSDF &b) const {
        if (wi.z <= 0) return false;
        out.wo = sample_cosine_hemisphere(u);
        out.pdf = cosine_hemisphere_pdf(out.wo.z);
        out.weight = b.reflectance;
        out.delta = false;
        out.diffuse = true;
        return out.pdf > 0;
    }
    bool operator()(const DielectricBSDF &b) const {
        Real cos_t;
        const Real r = fresnel_dielectric(wi.z, b.eta, &cos_t);
        out.delta = true;
        if (u_lobe < r) {
            out.wo = {-wi.x, -wi.y, wi.z};
            out.pdf = r;
            out.weight = b.reflectance;
        } else {
            // Radiance is compressed into a smaller solid angle on entering: scale by eta_ti^2.
            const Real eta_ti = wi.z >= 0 ? 1.0 / b.eta : b.eta;
            out.wo = {-wi.x * eta_ti, -wi.y * eta_ti, cos_t};
            out.pdf = 1.0 - r;
            out.weight = b.transmittance * (eta_ti * eta_ti);
        }
        return true;
    }
    bool operator()(const ConductorBSDF &b) const {
        if (wi.z <= 0) return false;
        if (b.alpha == 0) {
            out.wo = {-wi.x, -wi.y, wi.z};
            out.pdf = 1;
            out.delta = true;
            out.weight = b.specular * fresnel_conductor(wi.z, b.eta, b.k);
            return true;
        }
        const Vec3 h = sample_ggx_normal(b.alpha, u);
        out.wo = h * (2.0 * dot(wi, h)) - wi;
        out.delta = false;
        if (out.wo.z <= 0) return false;
        return finish(b);
    }
    // Each face reflects R; the light that enters bounces between them: R + T^2 R / (1 - R^2)
    // = 2 R / (1 + R) in all, the rest passes through unbent.
    bool operator()(const ThinDielectricBSDF &b) const {
        if (wi.z == 0) return false;
        Real R = fresnel_dielectric(std::abs(wi.z), b.eta);
        if (R < 1) R += (1 - R) * (1 - R) * R / (1 - R * R);
        out.delta = true;
        out.weight = Spectrum(1.0);
        if (u_lobe < R) {
            out.wo = {-wi.x, -wi.y, wi.z};
            out.pdf = R;
        } else {
            out.wo = -wi;
            out.pdf = 1 - R;
        }
        return true;
    }
    bool operator()(const RoughDielectricBSDF &b) const {
        if (wi.z == 0) return false;
        const Vec3 h = sample_ggx_normal(b.alpha, u);
        const Real cos_ih = dot(wi, h);
        if (cos_ih * wi.z <= 0) return false;  // a facet seen from behind
        Real cos_t;
        const Real F = fresnel_dielectric(cos_ih, b.eta, &cos_t);
        const bool reflect = u_lobe < F;
        if (reflect) {
            out.wo = h * (2.0 * cos_ih) - wi;
        } else {
            const Real eta_ti = cos_ih >= 0 ? 1.0 / b.eta : b.eta;
            out.wo = h * (eta_ti * cos_ih + cos_t) - wi * eta_ti;
        }
        // Off a steep facet, a direction may land on the side the other lobe owns: the
        // density there is that lobe's alone.
        if ((out.wo.z * wi.z > 0) != reflect) return false;
        out.delta = false;
        return finish(b);
    }
    bool operator()(const RoughPlasticBSDF &b) const {
        if (wi.z <= 0) return false;
        const Real p_spec = plastic_specular_probability(b, wi.z);
        if (u_lobe < p_spec) {
            const Vec3 h = sample_ggx_normal(b.alpha, u);
            out.wo = h * (2.0 * dot(wi, h)) - wi;
        } else {
            out.wo = sample_cosine_hemisphere(u);
            out.diffuse = true;
        }
        out.delta = false;
        if (out.wo.z <= 0) return false;
        return finish(b);
    }
};

// Two-sided BSDFs see every surface from the front.
void flip_to_front(const BSDF &b, Vec3 &wi, Vec3 &wo) {
    if (b.twosided && wi.z < 0) {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
}

}  // namespace

Spectrum bsdf_albedo(const BSDF &bsdf) {
    struct Albedo {
        Spectrum operator()(const NullBSDF &) const { return Spectrum(0.0); }
        Spectrum operator()(const DiffuseBSDF &b) const { return b.reflectance; }
        Spectrum operator()(const DielectricBSDF &) const { return Spectrum(1.0); }
        Spectrum operator()(const ThinDielectricBSDF &) const { return Spectrum(1.0); }
        Spectrum operator()(const ConductorBSDF &b) const { return b.specular; }
        Spectrum operator()(const RoughPlasticBSDF &b) const { return b.diffuse; }
        Spectrum operator()(const RoughDielectricBSDF &) const { return Spectrum(1.0); }
    };
    return std::visit(Albedo{}, bsdf.model);
}

Spectrum bsdf_eval(const BSDF &bsdf, Vec3 wi, Vec3 wo, uint8_t hidden_lobes) {
    flip_to_front(bsdf, wi, wo);
    return std::visit(Eval{wi, wo, hidden_lobes}, bsdf.model);
}

Real bsdf_pdf(const BSDF &bsdf, Vec3 wi, Vec3 wo) {
    flip_to_front(bsdf, wi, wo);
    return std::visit(Pdf{wi, wo}, bsdf.model);
}

bool bsdf_sample(const BSDF &bsdf, Vec3 wi, Real u_lobe, Vec2 u, BSDFSample &out) {
    const bool flipped = bsdf.twosided && wi.z < 0;
    if (flipped) wi.z = -wi.z;
    if (!std::visit(Sample{wi, u_lobe, u, out}, bsdf.model)) return false;
    if (flipped) out.wo.z = -out.wo.z;
    return true;
}

}  // namespace volpath
