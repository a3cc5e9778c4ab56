#include "volpath/sky_map.h"

#include <algorithm>
#include <atomic>
#include <thread>

#include "volpath/geometry.h"

namespace volpath {

namespace {

constexpr int NA = SkyMap::kAltitudes, NE = SkyMap::kElevations, NZ = SkyMap::kZenith, NP = SkyMap::kAzimuth;

// The zenith cosine at warped coordinate y in [0, 1]: the lower half below the horizon
// mu_h, the upper half above it, each quadratic in y so that cells crowd next to mu_h,
// where the light changes fastest (the bright band along the horizon, the ground's edge).
Real zenith_cosine(Real y, Real mu_h) {
    return y < 0.5 ? mu_h - (1 + mu_h) * sqr(1 - 2 * y) : mu_h + (1 - mu_h) * sqr(2 * y - 1);
}
Real warped_zenith(Real mu, Real mu_h) {
    return mu < mu_h ? 0.5 * (1 - std::sqrt(std::max(mu_h - mu, 0.0) / (1 + mu_h)))
                     : 0.5 * (1 + std::sqrt(std::max(mu - mu_h, 0.0) / (1 - mu_h)));
}
Real azimuth(int ip) { return 2 * kPi * ip / NP - kPi; }

// The zenith at p, the horizontal axes toward the sun's azimuth and across it, and the
// sun's elevation there.
struct LocalFrame {
    Vec3 up, toward_sun, across;
    Real altitude, sun_elevation;
    LocalFrame(const Vec3 &center, Real planet_radius, const Vec3 &to_sun, const Vec3 &p) {
        const Vec3 v = p - center;
        const Real r = length(v);
        up = v / r;
        altitude = r - planet_radius;
        const Real sin_e = std::clamp(dot(up, to_sun), -1.0, 1.0);
        sun_elevation = std::asin(sin_e);
        const Vec3 s = to_sun - up * sin_e;
        const Real ls = length(s);
        toward_sun = ls > 1e-9 ? s / ls : Frame(up).s;  // the sun at the zenith: any azimuth
        across = cross(up, toward_sun);
    }
};

// Radiance arriving at p from direction d: the sun's single scattering along d to the
// ground or out of the air, and the ground lit by the sun.
Spectrum arriving_radiance(const AtmosphereMedium &air, const SunGuide &sun, const Spectrum &ground_albedo,
                           const Vec3 &p, const Vec3 &d) {
    Real g0, g1;
    const bool ground = sphere_roots(air.center, air.planet_radius, p, d, g0, g1) && g0 > 0;
    const Ray ray{p, d, 0, kInfinity};
    const AirSegment seg = air_segment(air, ray, ground ? g0 : kInfinity, &sun);
    Spectrum L = seg.light_integral();
    if (ground && !is_black(ground_albedo)) {
        const Vec3 q = ray.at(g0), n = normalize(q - air.center);
        Spectrum tau;
        const Real cos_sun = dot(n, sun.to_sun);
        if (cos_sun > 0 && air.tabulated_tau_to_top(q, sun.to_sun, tau))
            L += sun.irradiance * exp(-tau) * seg.transmittance(g0) * ground_albedo * (cos_sun * kInvPi);
    }
    return L;
}

// Integrals over the cell [mu_lo, mu_hi] x [phi_lo, phi_hi] of w w^T, w = (sin cos phi,
// sin sin phi, mu): xx, yy, zz, xy, xz, yz.
void cell_moments(Real a, Real b, Real c, Real d, Real out[6]) {
    const Real sin2 = (b - a) - (b * b * b - a * a * a) / 3;                       // integral of 1 - mu^2
    const Real cos2 = (b * b * b - a * a * a) / 3;                                 // of mu^2
    const Real mixed = (std::pow(1 - a * a, 1.5) - std::pow(1 - b * b, 1.5)) / 3;  // of mu sqrt(1 - mu^2)
    const Real cc = (d - c) / 2 + (std::sin(2 * d) - std::sin(2 * c)) / 4;
    const Real ss = (d - c) / 2 - (std::sin(2 * d) - std::sin(2 * c)) / 4;
    const Real cs = (sqr(std::sin(d)) - sqr(std::sin(c))) / 2;
    out[0] = sin2 * cc, out[1] = sin2 * ss, out[2] = cos2 * (d - c);
    out[3] = sin2 * cs, out[4] = mixed * (std::sin(d) - std::sin(c)), out[5] = mixed * (std::cos(c) - std::cos(d));
}

// The level's distribution and integrals from its cells' radiance.
void finish_level(SkyMap::Level &level, Real mu_h) {
    std::vector<Real> f(size_t(NZ) * NP);
    level.total = Spectrum(0.0);
    for (auto &moment : level.moment) moment = Spectrum(0.0);
    for (int iz = 0; iz < NZ; ++iz) {
        const Real mu_lo = zenith_cosine(Real(iz) / NZ, mu_h), mu_hi = zenith_cosine(Real(iz + 1) / NZ, mu_h);
        for (int ip = 0; ip < NP; ++ip) {
            const Spectrum &L = level.radiance[size_t(iz) * NP + ip];
            // In proportion to radiance times the cell's solid angle (the cells of a row
            // share their width in azimuth).
            f[size_t(iz) * NP + ip] = average(L) * (mu_hi - mu_lo);
            Real w[6];
            cell_moments(mu_lo, mu_hi, azimuth(ip), azimuth(ip + 1), w);
            level.total += L * ((mu_hi - mu_lo) * (2 * kPi / NP));
            for (int i = 0; i < 6; ++i) level.moment[i] += L * w[i];
        }
    }
    level.directions = Distribution2D(f, NP, NZ);
}

// Runs fn(0..n-1) on all cores; each index writes only its own results.
template <typename Fn>
void parallel_for(size_t n, Fn &&fn) {
    std::atomic<size_t> next{0};
    auto worker = [&] {
        for (size_t i; (i = next.fetch_add(1)) < n;) fn(i);
    };
    std::vector<std::thread> pool(std::max(1u, std::thread::hardware_concurrency()) - 1);
    for (auto &t : pool) t = std::thread(worker);
    worker();
    for (auto &t : pool) t.join();
}
}  // namespace

std::shared_ptr<const SkyMap> build_sky_map(const AtmosphereMedium &air, const SunGuide &sun,
                                            const Spectrum &ground_albedo, const Vec3 &viewpoint,
                                            const SkyMap *previous) {
    auto map = std::make_shared<SkyMap>();
    SkyMap &m = *map;
    m.center = air.center, m.to_sun = sun.to_sun;
    m.irradiance = sun.irradiance, m.ground_albedo = ground_albedo;
    m.planet_radius = air.planet_radius, m.height = air.top_radius - air.planet_radius;
    // Sun elevations within 8 degrees of the viewpoint's (the air a view from inside sees
    // lies within ~900 km of it), on a grid fixed in elevation so that nearby suns share
    // levels; all of them from outside the air.
    const LocalFrame view(air.center, air.planet_radius, sun.to_sun, viewpoint);
    Real half = 8 * kPi / 180, mid = 0;
    const Real step = 2 * half / (NE - 1);
    if (view.altitude >= m.height)
        half = kPi / 2;
    else
        mid = std::clamp(step * std::round(view.sun_elevation / step), -kPi / 2 + half, kPi / 2 - half);
    m.elevation_lo = mid - half, m.elevation_step = 2 * half / (NE - 1);
    // Where the map stands for the light well enough to be a control variate: not in
    // twilight, nor seen from space through its coarse elevations.
    m.models_light = view.altitude < m.height && view.sun_elevation >= 0;
    // Levels crowd near the ground, where the air is densest (cubic spacing); the lowest
    // just off the ground, the top just inside.
    for (int j = 0; j < NA; ++j) {
        m.radius[j] = air.planet_radius * (1 + 1e-7) + m.height * std::pow(Real(j) / (NA - 1), 3.0) * (1 - 1e-6);
        m.horizon[j] = -safe_sqrt(1 - sqr(air.planet_radius / m.radius[j]));
    }
    if (previous && previous->elevation_lo == m.elevation_lo && previous->elevation_step == m.elevation_step &&
        previous->irradiance == m.irradiance && previous->ground_albedo == m.ground_albedo) {
        m.levels = previous->levels;
        return map;
    }
    // The levels are made for a sun along +z (see build_sky_map's note), by a map `up`
    // that looks them up for the twice scattered light.
    SkyMap up = m;
    up.to_sun = Vec3(0, 0, 1);
    auto levels = std::make_shared<std::vector<SkyMap::Level>>(size_t(NA) * NE);
    up.levels = levels;
    // A level's point: at its radius, with its sun at its elevation; and the direction
    // through the middle of each of its cells.
    auto origin = [&](size_t l) {
        const Real e = m.elevation_lo + Real(l / NA) * m.elevation_step;
        return air.center + (up.to_sun * std::sin(e) + Frame(up.to_sun).s * std::cos(e)) * m.radius[l % NA];
    };
    auto cell_direction = [&](const LocalFrame &frame, size_t l, int iz, int ip) {
        const Real mu_h = m.horizon[l % NA];
        const Real mu = 0.5 * (zenith_cosine(Real(iz) / NZ, mu_h) + zenith_cosine(Real(iz + 1) / NZ, mu_h));
        const Real phi = 0.5 * (azimuth(ip) + azimuth(ip + 1)), s = safe_sqrt(1 - mu * mu);
        return frame.up * mu + (frame.toward_sun * std::cos(phi) + frame.across * std::sin(phi)) * s;
    };
    const SunGuide sun_up{up.to_sun, sun.irradiance};
    // First the sun's single scattering and the sunlit ground.
    parallel_for(levels->size(), [&](size_t l) {
        const Vec3 p = origin(l);
        const LocalFrame frame(air.center, air.planet_radius, up.to_sun, p);
        SkyMap::Level &level = (*levels)[l];
        level.radiance.resize(size_t(NZ) * NP);
        for (int iz = 0; iz < NZ; ++iz)
            for (int ip = 0; ip < NP; ++ip)
                level.radiance[size_t(iz) * NP + ip] =
                    arriving_radiance(air, sun_up, ground_albedo, p, cell_direction(frame, l, iz, ip));
        finish_level(level, m.horizon[l % NA]);
    });
    // Then twice scattered light: along each cell's ray, the first map's light scattered
    // back by the air (air_segment's with the map). Higher orders follow a geometric series in
    // each level's ratio of the two (at most 0.8).
    std::vector<std::vector<Spectrum>> twice(levels->size());
    parallel_for(levels->size(), [&](size_t l) {
        const Vec3 p = origin(l);
        const LocalFrame frame(air.center, air.planet_radius, up.to_sun, p);
        const Real mu_h = m.horizon[l % NA];
        twice[l].resize(size_t(NZ) * NP);
        Spectrum total(0.0);
        for (int iz = 0; iz < NZ; ++iz)
            for (int ip = 0; ip < NP; ++ip) {
                const Vec3 d = cell_direction(frame, l, iz, ip);
                Real g0, g1;
                const bool ground = sphere_roots(air.center, air.planet_radius, p, d, g0, g1) && g0 > 0;
                const Spectrum L =
                    air_segment(air, Ray{p, d, 0, kInfinity}, ground ? g0 : kInfinity, nullptr, &up).light_integral();
                twice[l][size_t(iz) * NP + ip] = L;
                total += L * ((zenith_cosine(Real(iz + 1) / NZ, mu_h) - zenith_cosine(Real(iz) / NZ, mu_h)) *
                              (2 * kPi / NP));
            }
        const Spectrum ratio = min(safe_div(total, (*levels)[l].total), Spectrum(0.8));
        for (Spectrum &L : twice[l]) L = L / (Spectrum(1.0) - ratio);
    });
    parallel_for(levels->size(), [&](size_t l) {
        SkyMap::Level &level = (*levels)[l];
        for (size_t c = 0; c < level.radiance.size(); ++c) level.radiance[c] += twice[l][c];
        finish_level(level, m.horizon[l % NA]);
    });
    m.levels = levels;
    return map;
}

SkyMap::Point SkyMap::at(const Vec3 &p) const {
    const LocalFrame frame(center, planet_radius, to_sun, p);
    const Real a = std::cbrt(std::clamp(frame.altitude / height, 0.0, 1.0)) * (NA - 1);
    const int j0 = std::min(int(a), NA - 2), j1 = j0 + 1;
    const Real w1 = std::clamp(a - j0, 0.0, 1.0);
    const int k = elevation_step > 0
                      ? std::clamp(int(std::lround((frame.sun_elevation - elevation_lo) / elevation_step)), 0, NE - 1)
                      : 0;
    return {frame.up,
            frame.toward_sun,
            frame.across,
            {&(*levels)[size_t(k) * NA + j0], &(*levels)[size_t(k) * NA + j1]},
            {horizon[j0], horizon[j1]},
            {1 - w1, w1}};
}

namespace {
// Where direction d falls in a level of horizon mu_h: its cell, its unit-square point and
// the cell's width in zenith cosine (x, the azimuth, is the same in every level).
struct Cell {
    size_t index;
    Vec2 xy;
    Real width;
};
size_t cell_index(Real x, Real y) {
    return size_t(std::clamp(int(y * NZ), 0, NZ - 1)) * NP + size_t(std::clamp(int(x * NP), 0, NP - 1));
}
Cell cell_of(Real x, Real mu, Real mu_h) {
    const Vec2 xy{x, warped_zenith(mu, mu_h)};
    const int iz = std::clamp(int(xy.y * NZ), 0, NZ - 1);
    return {cell_index(xy.x, xy.y), xy, zenith_cosine(Real(iz + 1) / NZ, mu_h) - zenith_cosine(Real(iz) / NZ, mu_h)};
}
struct Direction {
    Real x, mu;
    Direction(const SkyMap::Point &at, const Vec3 &d)
        : x((std::atan2(dot(d, at.across), dot(d, at.toward_sun)) + kPi) / (2 * kPi)),
          mu(std::clamp(dot(d, at.up), -1.0, 1.0)) {}
};
Real level_pdf(const SkyMap::Level &level, const Cell &c) {
    return c.width > 0 ? level.directions.pdf(c.xy) / (c.width * NZ * 2 * kPi) : 0.0;
}
}  // namespace

Real SkyMap::pdf(const Point &at, const Vec3 &d) const {
    const Direction dir(at, d);
    Real pdf = 0;
    for (int i = 0; i < 2; ++i)
        if (at.weight[i] > 0) pdf += at.weight[i] * level_pdf(*at.level[i], cell_of(dir.x, dir.mu, at.horizon[i]));
    return pdf;
}

Vec3 SkyMap::sample(const Point &at, Vec2 u, Real u_level, Real &pdf_out) const {
    const int i = u_level < at.weight[0] ? 0 : 1;
    Real pdf_square;
    const Vec2 xy = at.level[i]->directions.sample(u, &pdf_square);
    // Uniform in the zenith cosine (so in solid angle) inside the cell.
    const int iz = std::clamp(int(xy.y * NZ), 0, NZ - 1);
    const Real mu_lo = zenith_cosine(Real(iz) / NZ, at.horizon[i]),
               mu_hi = zenith_cosine(Real(iz + 1) / NZ, at.horizon[i]);
    const Real mu = mu_lo + (xy.y * NZ - iz) * (mu_hi - mu_lo);
    const Real phi = 2 * kPi * xy.x - kPi, s = safe_sqrt(1 - mu * mu);
    const Vec3 d = at.up * mu + (at.toward_sun * std::cos(phi) + at.across * std::sin(phi)) * s;
    const Real own = mu_hi > mu_lo ? pdf_square / ((mu_hi - mu_lo) * NZ * 2 * kPi) : 0.0;
    pdf_out = at.weight[i] * own;
    if (at.weight[1 - i] > 0)
        pdf_out += at.weight[1 - i] * level_pdf(*at.level[1 - i], cell_of(xy.x, mu, at.horizon[1 - i]));
    return d;
}

Spectrum SkyMap::radiance(const Point &at, const Vec3 &d) const {
    const Direction dir(at, d);
    Spectrum L(0.0);
    for (int i = 0; i < 2; ++i)
        if (at.weight[i] > 0)
            L += at.level[i]->radiance[cell_index(dir.x, warped_zenith(dir.mu, at.horizon[i]))] * at.weight[i];
    return L;
}

// p_R(mu) = 3/(16 pi) (1 + mu^2): the integral is 3/(16 pi) (total + d^T M d).
Spectrum SkyMap::rayleigh_integral(const Point &at, const Vec3 &d_in) const {
    const Real x = dot(d_in, at.toward_sun), y = dot(d_in, at.across), z = dot(d_in, at.up);
    Spectrum sum(0.0);
    for (int i = 0; i < 2; ++i) {
        if (!(at.weight[i] > 0)) continue;
        const Spectrum *M = at.level[i]->moment;
        const Spectrum quadratic =
            M[0] * (x * x) + M[1] * (y * y) + M[2] * (z * z) + (M[3] * (x * y) + M[4] * (x * z) + M[5] * (y * z)) * 2.0;
        sum += (at.level[i]->total + quadratic) * at.weight[i];
    }
    return sum * (3.0 / (16.0 * kPi));
}

}  // namespace volpath
