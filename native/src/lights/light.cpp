#include "volpath/light.h"

namespace volpath {

namespace {

Vec2 direction_to_uv(const EnvironmentLight &env, const Vec3 &d) {
    const Vec3 v = normalize(env.to_local.vector(d));
    Real u = std::atan2(v.x, -v.z) * kInv2Pi;
    u -= std::floor(u);
    return {u, std::acos(std::clamp(v.y, -1.0, 1.0)) * kInvPi};
}

Vec3 uv_to_direction(const EnvironmentLight &env, Vec2 uv) {
    const Real theta = uv.y * kPi, phi = uv.x * 2.0 * kPi;
    const Real s = std::sin(theta);
    return normalize(env.to_world.vector({s * std::sin(phi), std::cos(theta), -s * std::cos(phi)}));
}

Spectrum bilinear(const EnvironmentLight &env, Vec2 uv) {
    const Real x = uv.x * env.width - 0.5, y = uv.y * env.height - 0.5;
    const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    const Real fx = x - x0, fy = y - y0;
    auto at = [&](int xi, int yi) {
        xi = ((xi % env.width) + env.width) % env.width;  // wraps in longitude
        yi = std::clamp(yi, 0, env.height - 1);
        return env.pixels[size_t(yi) * env.width + xi];
    };
    return (at(x0, y0) * (1 - fx) + at(x0 + 1, y0) * fx) * (1 - fy) +
           (at(x0, y0 + 1) * (1 - fx) + at(x0 + 1, y0 + 1) * fx) * fy;
}

// Mapping (u, v) to the sphere stretches area by 2 pi^2 sin(theta).
Real env_pdf(const EnvironmentLight &env, const Vec3 &d) {
    if (env.width == 0) return uniform_sphere_pdf();
    const Vec2 uv = direction_to_uv(env, d);
    const Real sin_theta = std::sin(uv.y * kPi);
    if (sin_theta <= 0) return 0;
    return env.distribution.pdf(uv) / (2.0 * kPi * kPi * sin_theta);
}

struct Sample {
    const Geometry &geometry;
    const Vec3 &ref;
    Vec2 u;
    LightSample &out;

    bool operator()(const PointLight &l) const {
        const Vec3 to = l.position - ref;
        const Real d2 = length_squared(to);
        if (d2 <= 0) return false;
        out.dist = std::sqrt(d2);
        out.d = to / out.dist;
        out.L = l.intensity * (spot_falloff(l.spot, -out.d) / d2);
        out.pdf = 1;
        out.delta = true;
        return true;
    }
    bool operator()(const DirectionalLight &l) const {
        out.d = -l.direction;
        out.dist = kInfinity;
        out.L = l.irradiance;
        out.pdf = 1;
        out.delta = true;
        return true;
    }
    bool operator()(const EnvironmentLight &env) const {
        out.dist = kInfinity;
        out.delta = false;
        if (env.width == 0) {
            out.d = sample_uniform_sphere(u);
            out.pdf = uniform_sphere_pdf();
            out.L = env.scale;
            return true;
        }
        Real pdf_uv;
        const Vec2 uv = env.distribution.sample(u, &pdf_uv);
        const Real sin_theta = std::sin(uv.y * kPi);
        if (pdf_uv <= 0 || sin_theta <= 0) return false;
        out.d = uv_to_direction(env, uv);
        out.pdf = pdf_uv / (2.0 * kPi * kPi * sin_theta);
        out.L = bilinear(env, uv) * env.scale;
        return true;
    }
    bool operator()(const SunLight &l) const {
        out.d = Frame(l.to_sun).to_world(sample_uniform_cone(u, l.cos_max));
        out.dist = kInfinity;
        out.pdf = uniform_cone_pdf(l.cos_max);
        out.L = l.radiance;
        out.delta = false;
        return true;
    }
    bool operator()(const AreaLight &l) const {
        if (!(l.area > 0)) return false;  // only degenerate triangles: emits nothing
        const ShapeGeometry &sg = geometry.shapes[l.shape];
        out.delta = false;
        Vec3 p, n;
        Real pdf_area;
        Spectrum tint(1.0);  // the emission map's at the point
        if (sg.is_sphere()) {
            const Sphere &s = geometry.spheres[sg.index];
            const Vec3 to_center = s.center - ref;
            const Real dc = length(to_center);
            if (dc > s.radius * (1 + 1e-9)) {
                // Outside: uniform over the cone the sphere subtends.
                const Real sin_max = s.radius / dc;
                const Real cos_max = safe_sqrt(1.0 - sin_max * sin_max);
                const Vec3 axis = to_center / dc;
                const Vec3 d = Frame(axis).to_world(sample_uniform_cone(u, cos_max));
                Real t0, t1;
                if (!sphere_roots(s.center, s.radius, ref, d, t0, t1)) {
                    t0 = dot(to_center, d);  // tangent ray lost to rounding: closest point
                }
                p = ref + d * t0;
                n = normalize(p - s.center);
                if (s.flip_normals) n = -n;
                out.d = d;
                out.dist = t0;
                out.pdf = uniform_cone_pdf(cos_max);
                out.L = area_radiance(l, n, d, ref);
                return out.pdf > 0 && std::isfinite(out.pdf);
            }
            n = sample_uniform_sphere(u);
            p = s.center + n * s.radius;
            if (s.flip_normals) n = -n;
            pdf_area = 1.0 / l.area;
        } else {
            const TriangleMesh &m = geometry.meshes[sg.index];
            Real u_tri;
            const size_t i = l.triangle_areas.sample_discrete(u.x, &u_tri);
            const auto &tri = m.triangles[i];
            const Vec2 b = sample_uniform_triangle({u_tri, u.y});
            const Vec3 &p0 = m.positions[tri[0]], &p1 = m.positions[tri[1]], &p2 = m.positions[tri[2]];
            p = p0 * (1 - b.x - b.y) + p1 * b.x + p2 * b.y;
            n = normalize(cross(p1 - p0, p2 - p0));
            pdf_area = 1.0 / l.area;
            if (l.texture) tint = eval_texture(*l.texture, m.uv(i, b.x, b.y));
        }
        const Vec3 to = p - ref;
        const Real d2 = length_squared(to);
        out.dist = std::sqrt(d2);
        if (!(out.dist > 0)) return false;
        out.d = to / out.dist;
        const Real cos_l = emitting_cos(l, n, out.d);
        if (cos_l <= 0) return false;  // the back of a one-sided emitter is dark
        out.pdf = pdf_area * d2 / cos_l;
        out.L = area_radiance(l, n, out.d, ref) * tint;
        return true;
    }
};

struct Pdf {
    const Geometry &geometry;
    const Vec3 &ref, &d;
    const Intersection &its;
    Real operator()(const PointLight &) const { return 0; }
    Real operator()(const DirectionalLight &) const { return 0; }
    Real operator()(const EnvironmentLight &env) const { return env_pdf(env, d); }
    Real operator()(const SunLight &l) const {
        return dot(d, l.to_sun) >= l.cos_max ? uniform_cone_pdf(l.cos_max) : 0.0;
    }
    Real operator()(const AreaLight &l) const {
        const ShapeGeometry &sg = geometry.shapes[l.shape];
        if (sg.is_sphere()) {
            const Sphere &s = geometry.spheres[sg.index];
            const Real dc = length(s.center - ref);
            if (dc > s.radius * (1 + 1e-9)) {
                const Real sin_max = s.radius / dc;
                return uniform_cone_pdf(safe_sqrt(1.0 - sin_max * sin_max));
            }
        }
        const Real cos_l = std::abs(dot(its.n, d));
        if (cos_l <= 0) return 0;
        return length_squared(its.p - ref) / (cos_l * l.area);
    }
};

}  // namespace

SpotCone spot_cone(const Vec3 &axis, Real half_angle, Real blend) {
    if (!(half_angle > 0 && half_angle <= kPi / 2))
        throw std::invalid_argument("a spot's half-angle must be in (0, pi/2]");
    if (!(blend >= 0 && blend <= 1)) throw std::invalid_argument("a spot's blend must be in [0, 1]");
    if (!(length_squared(axis) > 0)) throw std::invalid_argument("a spot's direction must not be zero");
    SpotCone spot{normalize(axis), std::cos(half_angle)};
    if (blend > 0) spot.inv_smooth = 1 / ((1 - spot.cos_half) * blend);
    return spot;
}

void prepare_light(Light &light, const Geometry &geometry) {
    if (auto *area = std::get_if<AreaLight>(&light)) {
        if (const Real h = area->spread / 2; h < kPi / 2) {
            area->tan_half_spread = std::tan(h);
            // tan h - h cancels for a narrow spread: its series there (next term 17 h^7 / 315).
            area->spread_normalization = 1 / (h < 0.05 ? h * h * h * (1.0 / 3 + h * h * 2 / 15) : std::tan(h) - h);
        }
        const ShapeGeometry &sg = geometry.shapes[area->shape];
        if (sg.is_sphere()) {
            const Sphere &s = geometry.spheres[sg.index];
            area->area = 4.0 * kPi * s.radius * s.radius;
            area->center = s.center;
            area->soft_radius = area->soft_falloff ? s.radius : 0;
        } else {
            const TriangleMesh &m = geometry.meshes[sg.index];
            std::vector<Real> areas(m.triangles.size());
            Vec3 moment(0.0);
            for (size_t i = 0; i < areas.size(); ++i) {
                areas[i] = m.area(i);
                const auto &t = m.triangles[i];
                moment += (m.positions[t[0]] + m.positions[t[1]] + m.positions[t[2]]) * (areas[i] / 3);
            }
            area->triangle_areas = Distribution1D(areas);
            area->area = area->triangle_areas.integral * Real(areas.size());
            if (area->area > 0) area->center = moment / area->area;
        }
    } else if (auto *env = std::get_if<EnvironmentLight>(&light); env && env->width > 0) {
        // Sample in proportion to luminance times the sin(theta) area factor.
        std::vector<Real> f(size_t(env->width) * env->height);
        for (int y = 0; y < env->height; ++y) {
            const Real sin_theta = std::sin((y + 0.5) / env->height * kPi);
            for (int x = 0; x < env->width; ++x) {
                const size_t i = size_t(y) * env->width + x;
                f[i] = std::max(luminance(env->pixels[i]), 0.0) * sin_theta;
            }
        }
        env->distribution = Distribution2D(f, env->width, env->height);
    }
}

bool sample_light(const Light &light, const Geometry &geometry, const Vec3 &ref, Vec2 u, LightSample &out) {
    return std::visit(Sample{geometry, ref, u, out}, light);
}

Real light_pdf(const Light &light, const Geometry &geometry, const Vec3 &ref, const Vec3 &d, const Intersection &its) {
    return std::visit(Pdf{geometry, ref, d, its}, light);
}

Spectrum area_radiance(const AreaLight &l, const Geometry &geometry, const Intersection &its, const Vec3 &d,
                       const Vec3 &ref) {
    const Spectrum L = area_radiance(l, its.n, d, ref);
    return l.texture && !is_black(L) ? L * eval_texture(*l.texture, geometry.uv(its)) : L;
}

Spectrum infinite_radiance(const Light &light, const Vec3 &d) {
    if (const auto *sun = std::get_if<SunLight>(&light))
        return dot(d, sun->to_sun) >= sun->cos_max ? sun->radiance : Spectrum(0.0);
    const auto &env = std::get<EnvironmentLight>(light);
    if (env.width == 0) return env.scale;
    return bilinear(env, direction_to_uv(env, d)) * env.scale;
}

}  // namespace volpath
