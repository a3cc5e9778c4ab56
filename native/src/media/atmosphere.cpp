// The atmosphere: its density profiles, the table of optical depths to the top, its
// majorants and the guided free flight's segments (AirSegment).
#include <algorithm>
#include <utility>

#include "media.h"
#include "volpath/geometry.h"
#include "volpath/sky_map.h"

namespace volpath {

Real AtmosphereMedium::ozone_profile(Real h) const {
    if (h <= ozone_bottom || h >= ozone_top) return 0.0;
    return h < ozone_peak ? (h - ozone_bottom) / (ozone_peak - ozone_bottom)
                          : (ozone_top - h) / (ozone_top - ozone_peak);
}

void AtmosphereMedium::densities(Real h, Real &rayleigh, Real &mie, Real &ozone) const {
    h = std::max(h, 0.0);  // below the ground (rounding) counts as the ground
    rayleigh = std::exp(-h / rayleigh_height);
    mie = std::exp(-h / mie_height);
    ozone = ozone_profile(h);
}

Spectrum AtmosphereMedium::sigma_t(Real h) const {
    Real rayleigh, mie, ozone;
    densities(h, rayleigh, mie, ozone);
    return rayleigh_sigma_s * rayleigh + (mie_sigma_s + mie_sigma_a) * mie + ozone_sigma_a * ozone;
}

namespace {
// Bruneton 2017's coordinates of the transmittance table: x_r from the ground (0) to the
// top (1) by rho = sqrt(r^2 - R^2); x_mu by where the distance d to the top lies between
// its least (straight up) and greatest (along the horizon) values. Smooth in both.
struct TableCoordinates {
    Real H, rho, r, d_min, d_max;
    TableCoordinates(const AtmosphereMedium &m, Real r_) {
        const Real R = m.planet_radius, Rt = m.top_radius;
        H = std::sqrt(Rt * Rt - R * R);
        r = std::clamp(r_, R, Rt);
        rho = std::sqrt(std::max(r * r - R * R, 0.0));
        d_min = Rt - r, d_max = rho + H;
    }
    Real distance_to_top(const AtmosphereMedium &m, Real mu) const {
        const Real Rt = m.top_radius;
        return std::max(0.0, -r * mu + std::sqrt(std::max(r * r * (mu * mu - 1) + Rt * Rt, 0.0)));
    }
};

// Optical depth from radius r along a direction of cosine mu (to the local zenith) over
// distance d, by Simpson's rule: altitude along the ray is sqrt(r^2 + t^2 + 2 r mu t) - R.
Spectrum tau_along(const AtmosphereMedium &m, Real r, Real mu, Real d, int steps) {
    Spectrum tau(0.0);
    const Real h = d / steps;
    for (int k = 0; k <= steps; ++k) {
        const Real t = k * h;
        const Real altitude = std::sqrt(std::max(r * r + t * t + 2 * r * mu * t, 0.0)) - m.planet_radius;
        tau += m.sigma_t(altitude) * (simpson_weight(k, steps) * h / 3.0);
    }
    return tau;
}
}  // namespace

void build_tau_table(AtmosphereMedium &m) {
    constexpr int NR = AtmosphereMedium::kTableR, NMU = AtmosphereMedium::kTableMu;
    // 64 Simpson intervals per entry: more change nothing measurable (the bilinear
    // interpolation's error dominates), fewer show at ozone's kinks.
    constexpr int kSteps = 64;
    m.tau_to_top.assign(size_t(NR) * NMU * 3, 0.0f);
    const Real R = m.planet_radius;
    for (int i = 0; i < NR; ++i) {
        const Real H = std::sqrt(m.top_radius * m.top_radius - R * R), rho = H * i / (NR - 1);
        const TableCoordinates c(m, std::sqrt(rho * rho + R * R));
        for (int j = 0; j < NMU; ++j) {
            const Real d = c.d_min + (c.d_max - c.d_min) * j / (NMU - 1);
            const Real mu = d == 0 ? 1.0 : std::clamp((H * H - c.rho * c.rho - d * d) / (2 * c.r * d), -1.0, 1.0);
            const Spectrum tau = tau_along(m, c.r, mu, d, kSteps);
            for (int k = 0; k < 3; ++k) m.tau_to_top[(size_t(i) * NMU + j) * 3 + k] = float(tau[k]);
        }
    }
}

namespace {
// The lowest and highest altitudes along [a, b] of a ray: at the point nearest the planet's
// centre (clamped to the interval) and at the higher end.
std::pair<Real, Real> altitude_range(const AtmosphereMedium &m, const Ray &ray, Real a, Real b) {
    const Real t_closest = std::clamp(dot(m.center - ray.o, ray.d), a, b);
    return {m.altitude(ray.at(t_closest)), std::max(m.altitude(ray.at(a)), m.altitude(ray.at(b)))};
}
}  // namespace

Spectrum air_majorant(const AtmosphereMedium &m, const Ray &ray, Real a, Real b) {
    const auto [h_min, h_max] = altitude_range(m, ray, a, b);
    Real r, mie, o;
    m.densities(h_min, r, mie, o);
    // Ozone's tent peaks inside [h_min, h_max] or at the end nearer the peak.
    const Real h_oz = std::clamp(m.ozone_peak, std::max(h_min, 0.0), std::max(h_max, 0.0));
    const Spectrum sigma_maj =
        m.rayleigh_sigma_s * r + (m.mie_sigma_s + m.mie_sigma_a) * mie + m.ozone_sigma_a * m.ozone_profile(h_oz);
    // A small safety factor covers rounding in the altitude of the lowest point.
    return sigma_maj * (1.0 + 1e-9);
}

bool AtmosphereMedium::tabulated_tau_to_top(const Vec3 &p, const Vec3 &d, Spectrum &tau) const {
    if (tau_to_top.empty()) return false;
    const Vec3 v = p - center;
    const Real r = length(v);
    if (r > top_radius * (1 + 1e-9)) return false;
    const Real mu = dot(v, d) / r, R = planet_radius;
    if (mu < 0 && r * r * (mu * mu - 1) + R * R >= 0) return false;  // d meets the ground
    const TableCoordinates c(*this, r);
    const Real x_r = c.rho / c.H;
    const Real x_mu = c.d_max > c.d_min ? (c.distance_to_top(*this, mu) - c.d_min) / (c.d_max - c.d_min) : 0.0;
    // Bilinear between the entries around (x_r, x_mu).
    const Real u = std::clamp(x_r, 0.0, 1.0) * (kTableR - 1), w = std::clamp(x_mu, 0.0, 1.0) * (kTableMu - 1);
    const int i = std::min(int(u), kTableR - 2), j = std::min(int(w), kTableMu - 2);
    const Real fu = u - i, fw = w - j;
    const float *row0 = &tau_to_top[(size_t(i) * kTableMu + j) * 3], *row1 = row0 + kTableMu * 3;
    for (int k = 0; k < 3; ++k)
        tau[k] = (row0[k] * (1 - fw) + row0[3 + k] * fw) * (1 - fu) + (row1[k] * (1 - fw) + row1[3 + k] * fw) * fu;
    return true;
}

namespace {
// Integral over an interval of length dt of a density that is exp(-h / H) at altitudes h0
// and h1 at its ends and exponential in between (altitude linear along the interval).
Real exponential_integral(Real rho0, Real rho1, Real h0, Real h1, Real H, Real dt) {
    const Real dh = h1 - h0;
    // Nearly level: the trapezoid rule is exact to O(dh^2), and the closed form cancels.
    if (std::abs(dh) < 1e-6 * H) return 0.5 * (rho0 + rho1) * dt;
    return (rho0 - rho1) * H * dt / dh;
}

// Integral over [0, delta] of the exponential through (0, a) and (delta, b), a, b > 0:
// (b - a) delta / ln(b / a), one logarithm; near b = a its series (r - 1) / ln r =
// 1 + x / 2 - x^2 / 12 + ..., x = r - 1, where the quotient would cancel. (Not log1p(x):
// for b / a below 1e-16, x rounds to -1.)
Real exp_interpolated_integral(Real a, Real b, Real delta) {
    const Real r = b / a, x = r - 1;
    if (std::abs(x) < 1e-4) return a * delta * (1 + x * (0.5 - x / 12));
    return (b - a) * delta / std::log(r);
}
}  // namespace

namespace {
void add_scattered_light(AirSegment &s, const SkyMap &map);

// sigma_t at a node from its densities.
Spectrum node_sigma_t(const AtmosphereMedium &m, const AirSegment::Node &q) {
    return m.rayleigh_sigma_s * q.rayleigh + (m.mie_sigma_s + m.mie_sigma_a) * q.mie + m.ozone_sigma_a * q.ozone;
}

// The guide's node weights: half free flight, half the nodes' light (the sun's single
// scattering, or all the light scattered back), each normalised by its trapezoidal integral
// per channel, then averaged over the channels (the balance heuristic over per-channel
// densities: every channel's integrand is covered, whose shapes differ most in the sun's
// transmittance). The weights only need be positive wherever air is: the floor keeps them so.
void set_weights(AirSegment &s, const Spectrum *free_flight) {
    const int K = s.n - 1;
    Spectrum mass_free(0.0), mass_lit(0.0);
    for (int k = 1; k <= K; ++k) {
        const Real dt = s.node[k].t - s.node[k - 1].t;
        mass_free += (free_flight[k - 1] + free_flight[k]) * (0.5 * dt);
        mass_lit += (s.node[k - 1].light + s.node[k].light) * (0.5 * dt);
    }
    if (!(max_component(mass_free) > 0)) {  // no air on the segment: nothing collides
        for (int k = 0; k <= K; ++k) s.node[k].weight = s.node[k].mass = 0;
        return;
    }
    const Real share_lit = max_component(mass_lit) > 0 ? 0.5 : 0.0;
    const Spectrum w_free = safe_div(Spectrum(1 - share_lit), mass_free),
                   w_lit = safe_div(Spectrum(share_lit), mass_lit);
    for (int k = 0; k <= K; ++k) {
        AirSegment::Node &q = s.node[k];
        q.weight = std::max(average(w_free * free_flight[k] + w_lit * q.light), 1e-300);
        q.mass = k == 0 ? 0.0
                        : s.node[k - 1].mass +
                              exp_interpolated_integral(s.node[k - 1].weight, q.weight, q.t - s.node[k - 1].t);
    }
}

// The table's depth to the top from ray.at(a), along -d if d meets the ground ahead (so
// that the lookups from a and from any later point along the ray both see the sky).
bool table_start(const AtmosphereMedium &m, const Ray &ray, Real a, bool &downward, Spectrum &tau_start) {
    const Vec3 v = ray.at(a) - m.center;
    const Real r = length(v), mu_a = dot(v, ray.d) / r;
    downward = mu_a < 0 && r * r * (mu_a * mu_a - 1) + m.planet_radius * m.planet_radius >= 0;
    return m.tabulated_tau_to_top(ray.at(a), downward ? -ray.d : ray.d, tau_start);
}
}  // namespace

Spectrum air_optical_depth(const AtmosphereMedium &m, const Ray &ray, Real t_max) {
    Real r0, r1;
    if (!sphere_roots(m.center, m.top_radius, ray.o, ray.d, r0, r1)) return Spectrum(0.0);
    const Real a = std::max(ray.t_min, r0), b = std::min(t_max, r1);
    if (!(a < b)) return Spectrum(0.0);
    bool downward;
    Spectrum tau_start, tau_end;
    if (table_start(m, ray, a, downward, tau_start) &&
        m.tabulated_tau_to_top(ray.at(b), downward ? -ray.d : ray.d, tau_end))
        return clamp_zero(downward ? tau_end - tau_start : tau_start - tau_end);
    return air_segment(m, ray, t_max, nullptr).optical_depth(t_max);
}

AirSegment air_segment(const AtmosphereMedium &m, const Ray &ray, Real t_max, const SunGuide *sun, const SkyMap *map) {
    AirSegment s;
    s.air = &m, s.ray = ray;
    Real r0, r1;
    if (!sphere_roots(m.center, m.top_radius, ray.o, ray.d, r0, r1)) return s;
    const Real a = std::max(ray.t_min, r0), b = std::min(t_max, r1);
    if (!(a < b)) return s;
    // Intervals on each side of the lowest point in proportion to the side's length. A
    // segment that stays level (within kLevelSpan of the thinner scale height) has nearly
    // constant densities and sunlight along it, the light exponential with T: its two ends
    // model it (the camera's few hundred metres of air before the terrain, most bounces).
    constexpr Real kLevelSpan = 0.05;
    const Real tc = std::clamp(dot(m.center - ray.o, ray.d), a, b);
    const auto [h_min, h_max] = altitude_range(m, ray, a, b);
    const int K = h_max - h_min < kLevelSpan * std::min(m.mie_height, m.rayleigh_height) ? 1 : AirSegment::kNodes - 1;
    const int left = K == 1 || tc == a ? 0
                     : tc == b         ? K
                                       : std::clamp(int(std::lround(K * (tc - a) / (b - a))), 1, K - 1);
    // Free flight and the sun's single scattering at the nodes, each normalised below.
    const Real mu = sun ? dot(ray.d, sun->to_sun) : 0;
    const Real p_rayleigh = rayleigh_eval(mu), p_mie = cornette_shanks_eval(m.mie_g, mu);
    const Spectrum mie_t = m.mie_sigma_s + m.mie_sigma_a;
    Spectrum free_flight[AirSegment::kNodes];
    for (int k = 0; k <= K; ++k) {
        AirSegment::Node &q = s.node[k];
        const Real x = k <= left ? Real(left - k) / left : Real(k - left) / (K - left);
        q.t = k == 0 ? a : k == K ? b : k <= left ? tc - (tc - a) * x * x : tc + (b - tc) * x * x;
        const Vec3 p = ray.at(q.t);
        q.h = m.altitude(p);
        m.densities(q.h, q.rayleigh, q.mie, q.ozone);
        if (k == 0) {
            q.I_rayleigh = q.I_mie = q.I_ozone = 0;
        } else {
            const AirSegment::Node &prev = s.node[k - 1];
            const Real dt = q.t - prev.t, h0 = std::max(prev.h, 0.0), h1 = std::max(q.h, 0.0);
            q.I_rayleigh =
                prev.I_rayleigh + exponential_integral(prev.rayleigh, q.rayleigh, h0, h1, m.rayleigh_height, dt);
            q.I_mie = prev.I_mie + exponential_integral(prev.mie, q.mie, h0, h1, m.mie_height, dt);
            q.I_ozone = prev.I_ozone + 0.5 * (prev.ozone + q.ozone) * dt;
        }
        const Spectrum s_r = m.rayleigh_sigma_s * q.rayleigh, s_m = m.mie_sigma_s * q.mie;
        const Spectrum T = q.T =
            exp(-(m.rayleigh_sigma_s * q.I_rayleigh + mie_t * q.I_mie + m.ozone_sigma_a * q.I_ozone));
        free_flight[k] = node_sigma_t(m, q) * T;
        Spectrum tau_sun;
        q.light = sun && m.tabulated_tau_to_top(p, sun->to_sun, tau_sun)
                      ? sun->irradiance * T * exp(-tau_sun) * (s_r * p_rayleigh + s_m * p_mie)
                      : Spectrum(0.0);
    }
    s.n = K + 1;
    if (!table_start(m, ray, a, s.downward, s.tau_start)) s.tau_start = Spectrum(kInfinity);
    // Not across the planet's shadow: the sun's model runs linearly into it from the last
    // lit node, where NEE finds nothing, so there it would overestimate by far.
    bool lit = true, shadowed = true;
    for (int k = 0; k < s.n; ++k) (is_black(s.node[k].light) ? lit : shadowed) = false;
    s.models_light = lit || shadowed;
    if (map && s.models_light) add_scattered_light(s, *map);
    // Collisions follow the light (the sun's, or all of it with the map's): the weights are
    // normalised per channel, so the sun's irradiance drops out. With the map's light, twice
    // and more scattered light is gathered where it scatters.
    set_weights(s, free_flight);
    return s;
}

namespace {
// Rayleigh's share exactly (SkyMap::rayleigh_integral); Mie's lobe is narrow, its share
// taken as the map's light arriving along the ray.
void add_scattered_light(AirSegment &s, const SkyMap &map) {
    const AtmosphereMedium &m = *s.air;
    // The map's light changes slowly along the ray (the densities do not): looked up at
    // every other node, linear in t between.
    Spectrum rayleigh[AirSegment::kNodes], mie[AirSegment::kNodes];
    for (int k = 0; k < s.n; ++k) {
        if (k % 2 == 1 && k + 1 < s.n) continue;
        const SkyMap::Point at = map.at(s.ray.at(s.node[k].t));
        rayleigh[k] = map.rayleigh_integral(at, s.ray.d), mie[k] = map.radiance(at, s.ray.d);
    }
    for (int k = 1; k + 1 < s.n; k += 2) {
        const Real w = (s.node[k].t - s.node[k - 1].t) / (s.node[k + 1].t - s.node[k - 1].t);
        rayleigh[k] = rayleigh[k - 1] * (1 - w) + rayleigh[k + 1] * w, mie[k] = mie[k - 1] * (1 - w) + mie[k + 1] * w;
    }
    for (int k = 0; k < s.n; ++k) {
        AirSegment::Node &q = s.node[k];
        q.light += q.T * (m.rayleigh_sigma_s * q.rayleigh * rayleigh[k] + m.mie_sigma_s * q.mie * mie[k]);
    }
}
}  // namespace

Spectrum AirSegment::optical_depth(Real t_at) const {
    if (n == 0 || t_at <= node[0].t) return Spectrum(0.0);
    const AtmosphereMedium &m = *air;
    t_at = std::min(t_at, node[n - 1].t);
    Spectrum tau_end;
    if (is_finite(tau_start) && m.tabulated_tau_to_top(ray.at(t_at), downward ? -ray.d : ray.d, tau_end))
        return clamp_zero(downward ? tau_end - tau_start : tau_start - tau_end);
    // Off the table (a ray through a planet without ground): the nodes' quadrature.
    int k = 0;
    while (k + 2 < n && node[k + 1].t <= t_at) ++k;
    const Node &q = node[k];
    const Real h0 = std::max(q.h, 0.0), h = std::max(m.altitude(ray.at(t_at)), 0.0), dt = t_at - q.t;
    Real rayleigh, mie, ozone;
    m.densities(h, rayleigh, mie, ozone);
    const Real I_r = q.I_rayleigh + exponential_integral(q.rayleigh, rayleigh, h0, h, m.rayleigh_height, dt);
    const Real I_m = q.I_mie + exponential_integral(q.mie, mie, h0, h, m.mie_height, dt);
    const Real I_o = q.I_ozone + 0.5 * (q.ozone + ozone) * dt;
    return m.rayleigh_sigma_s * I_r + (m.mie_sigma_s + m.mie_sigma_a) * I_m + m.ozone_sigma_a * I_o;
}

bool AirSegment::sample(Real u, Real &t_out, Real &pdf) const {
    if (n == 0 || !(node[n - 1].mass > 0)) return false;
    const Real target = u * node[n - 1].mass;
    int k = 0;
    while (k + 2 < n && node[k + 1].mass <= target) ++k;
    // Invert the exponential's integral from node k: a expm1(x s) / x = rest.
    const Node &q = node[k];
    const Real delta = node[k + 1].t - q.t, a = q.weight, rest = std::max(target - q.mass, 0.0);
    const Real x = std::log(node[k + 1].weight / a) / delta;
    Real s = x == 0 ? rest / a : std::log1p(rest * x / a) / x;
    if (!std::isfinite(s)) s = delta;
    s = std::clamp(s, 0.0, delta);
    t_out = q.t + s;
    pdf = a * std::exp(x * s) / node[n - 1].mass;
    return pdf > 0 && std::isfinite(pdf);
}

namespace {
// The model between two nodes a distance delta apart, at s in [0, delta], and its integral.
Real light_between(Real a, Real b, Real delta, Real s) {
    if (a > 0 && b > 0) return a * std::exp(std::log(b / a) * s / delta);
    return a + (b - a) * s / delta;
}
Real light_integral_between(Real a, Real b, Real delta) {
    if (a > 0 && b > 0) return exp_interpolated_integral(a, b, delta);
    return 0.5 * (a + b) * delta;
}
}  // namespace

Spectrum AirSegment::light_model(Real t) const {
    if (n == 0 || t < node[0].t || t > node[n - 1].t) return Spectrum(0.0);
    int k = 0;
    while (k + 2 < n && node[k + 1].t <= t) ++k;
    const Node &q = node[k], &r = node[k + 1];
    const Real delta = r.t - q.t, s = std::clamp(t - q.t, 0.0, delta);
    if (!(delta > 0)) return q.light;
    return {light_between(q.light.x, r.light.x, delta, s), light_between(q.light.y, r.light.y, delta, s),
            light_between(q.light.z, r.light.z, delta, s)};
}

Spectrum AirSegment::light_integral() const {
    Spectrum total(0.0);
    for (int k = 0; k + 1 < n; ++k) {
        const Node &q = node[k], &r = node[k + 1];
        const Real delta = r.t - q.t;
        if (!(delta > 0)) continue;
        total += Spectrum(light_integral_between(q.light.x, r.light.x, delta),
                          light_integral_between(q.light.y, r.light.y, delta),
                          light_integral_between(q.light.z, r.light.z, delta));
    }
    return total;
}

}  // namespace volpath
