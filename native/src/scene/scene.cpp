#include "volpath/scene.h"

#include "volpath/sky_map.h"

#include <algorithm>
#include <set>
#include <sstream>
#include <stdexcept>

namespace volpath {

int Scene::add_bsdf(const BSDF &b) {
    // A layer's BSDFs come before it: the layers form no cycle.
    const auto known = [&](int i) { return i >= 0 && size_t(i) < bsdfs.size(); };
    const auto texture_known = [&](int i) { return i >= 0 && size_t(i) < textures.size(); };
    bool ok = true;
    if (const auto *blend = std::get_if<BlendLayer>(&b.layer)) ok = known(blend->a) && known(blend->b);
    if (const auto *mask = std::get_if<MaskLayer>(&b.layer)) ok = known(mask->nested);
    if (const auto *nm = std::get_if<NormalMapLayer>(&b.layer)) ok = known(nm->nested) && texture_known(nm->texture);
    if (const auto *bump = std::get_if<BumpMapLayer>(&b.layer))
        ok = known(bump->nested) && texture_known(bump->texture);
    if (!ok) throw std::invalid_argument("a layered bsdf names a bsdf or texture that does not exist yet");
    bsdfs.push_back(b);
    return int(bsdfs.size()) - 1;
}

int Scene::add_texture(Texture t) {
    textures.push_back(std::move(t));
    return int(textures.size()) - 1;
}

void Scene::bind_texture(int bsdf, const TexturedParam &param) {
    if (bsdf < 0 || size_t(bsdf) >= bsdfs.size()) throw std::invalid_argument("bsdf index out of range");
    if (param.texture < 0 || size_t(param.texture) >= textures.size())
        throw std::invalid_argument("texture index out of range");
    if (!has_param(bsdfs[size_t(bsdf)], param.name))
        throw std::invalid_argument("this bsdf has no such parameter to texture");
    bsdfs[size_t(bsdf)].textured.push_back(param);
}

int Scene::add_medium(const Medium &m) {
    media.push_back(m);
    prepare_medium(media.back());
    built = false;
    return int(media.size()) - 1;
}

namespace {
void check_hidden_from(uint8_t hidden_from) {
    if (hidden_from &
        ~uint8_t(uint8_t(RayKind::Camera) | kLobeRays | uint8_t(RayKind::Scatter) | uint8_t(RayKind::Shadow)))
        throw std::invalid_argument(
            "a light can be hidden from camera, diffuse, glossy, transmission, scatter and shadow rays only");
}
}  // namespace

int Scene::add_light(const Light &l, uint8_t hidden_from) {
    check_hidden_from(hidden_from);
    lights.push_back(l);
    light_hidden_from.push_back(hidden_from);
    built = false;
    return int(lights.size()) - 1;
}

void Scene::set_light(int i, const Light &l, uint8_t hidden_from) {
    if (lights.at(size_t(i)).index() != l.index())
        throw std::invalid_argument("a light can only be replaced by one of its kind");
    check_hidden_from(hidden_from);
    lights[size_t(i)] = l;
    light_hidden_from[size_t(i)] = hidden_from;
    built = false;
}

Real Scene::light_select_pdf(int light, bool mis, const Vec3 &p) const {
    if (!mis) return lights.empty() ? 0.0 : 1.0 / Real(lights.size());
    // One candidate is always chosen (whatever its importance: a single light's images keep
    // their bits); among several, the sampler knows which are candidates.
    const std::vector<int> &candidates = context.mis_nee_lights;
    if (candidates.size() == 1) return candidates[0] == light ? 1.0 : 0.0;
    return candidates.empty() ? 0.0 : context.nee_sampler.pdf(p, light);
}

Real Scene::collision_light_select_pdf(int light, bool mis) const {
    const std::vector<int> &choice = context.collision_nee_lights[mis];
    return std::find(choice.begin(), choice.end(), light) != choice.end() ? 1.0 / Real(choice.size()) : 0.0;
}

namespace {
void check_info(const Scene &s, const ShapeInfo &info) {
    auto check = [](int i, size_t n, const char *what) {
        if (i < -1 || i >= int(n)) throw std::out_of_range(std::string("invalid ") + what + " index");
    };
    check(info.bsdf, s.bsdfs.size(), "bsdf");
    check(info.interior, s.media.size(), "interior medium");
    check(info.exterior, s.media.size(), "exterior medium");
    if (info.bsdf < 0) throw std::invalid_argument("a shape needs a bsdf");
}

void check_mesh(const TriangleMesh &mesh) {
    for (const auto &t : mesh.triangles)
        for (uint32_t v : t)
            if (v >= mesh.positions.size()) throw std::out_of_range("triangle index out of range");
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size())
        throw std::invalid_argument("need one normal per vertex");
    if (mesh.motion.size() == 1) throw std::invalid_argument("a motion needs at least two keys");
    for (const auto &key : mesh.motion)
        if (key.size() != mesh.positions.size()) throw std::invalid_argument("each motion key needs every position");
}

AreaLight area_light(const Scene &scene, int shape, const AreaEmission &e) {
    if (!(e.spread > 0 && e.spread <= kPi)) throw std::invalid_argument("an area light's spread must be in (0, pi]");
    AreaLight light{shape, e.radiance};
    light.twosided = e.twosided, light.spread = e.spread;
    light.spot = e.spot;
    light.soft_falloff = e.soft_falloff;
    if (e.texture >= 0) {
        light.texture = std::make_shared<const Texture>(scene.textures.at(size_t(e.texture)));
        light.mean_texture = mean_luminance(*light.texture);
    }
    return light;
}
}  // namespace

int Scene::add_shape_mesh(TriangleMesh mesh, const ShapeInfo &info, const AreaEmission *emission, int group) {
    check_info(*this, info);
    if (group >= 0 && (emission || info.medium_interface))
        throw std::invalid_argument("a shape group's shapes can neither emit nor bound a medium");
    // (Lights and media boundaries hold still: their sampling and containment know no time.)
    if (group < 0 && !mesh.motion.empty())
        throw std::invalid_argument("only a shape group's meshes deform in the shutter");
    check_mesh(mesh);
    geometry_built = false;
    const int id = geometry.add_mesh(std::move(mesh), group);
    shapes.push_back(info);
    if (emission) shapes.back().light = add_light(area_light(*this, id, *emission), emission->hidden_from);
    built = false;
    return id;
}

int Scene::add_shape_sphere(const Sphere &s, const ShapeInfo &info, const AreaEmission *emission) {
    check_info(*this, info);
    if (!(s.radius > 0)) throw std::invalid_argument("sphere radius must be positive");
    geometry_built = false;
    if (emission && emission->texture >= 0) throw std::invalid_argument("only meshes take an emission map");
    const int id = geometry.add_sphere(s);
    shapes.push_back(info);
    if (emission) shapes.back().light = add_light(area_light(*this, id, *emission), emission->hidden_from);
    built = false;
    return id;
}

int Scene::add_shape_box(const Box &b, const ShapeInfo &info) {
    check_info(*this, info);
    geometry_built = false;
    const int id = geometry.add_box(b);
    shapes.push_back(info);
    built = false;
    return id;
}

int Scene::add_instance(int group, const Transform &to_world, const Transform &to_local, MotionKeys motion) {
    geometry_built = built = false;
    return geometry.add_instance(group, to_world, to_local, std::move(motion));
}

namespace {

// The lights by the roles the tracers give them (RenderContext).
void sort_lights(const Scene &scene, RenderContext &c) {
    for (int i = 0; i < int(scene.lights.size()); ++i) {
        const Light &l = scene.lights[size_t(i)];
        const bool environment = std::holds_alternative<EnvironmentLight>(l);
        if (std::holds_alternative<PointLight>(l) || std::holds_alternative<DirectionalLight>(l))
            ++c.point_and_directional;
        if (is_infinite(l)) c.infinite_lights.push_back(i);
        const bool lights_nothing = scene.light_lights_nothing(i);  // a world only shown
        if (!environment && !lights_nothing) c.segment_lights.push_back(i);
        if (!is_constant_environment(l) && !lights_nothing) c.mis_nee_lights.push_back(i);
        if (environment && !lights_nothing) {
            c.collision_nee_lights[0].push_back(i);
            if (!is_constant_environment(l)) c.collision_nee_lights[1].push_back(i);
        }
        c.has_environment |= environment;
        c.lights_hide_lobes |= (scene.light_hidden_from[size_t(i)] & kLobeRays) != 0;
        if (c.sun) continue;
        if (const auto *sun = std::get_if<SunLight>(&l))
            c.sun = SunGuide{sun->to_sun, sun->radiance / uniform_cone_pdf(sun->cos_max)};
        else if (const auto *d = std::get_if<DirectionalLight>(&l))
            c.sun = SunGuide{-d->direction, d->irradiance};
        if (c.sun) c.sun_light = i;
    }
    c.sun_alone_under_mis = c.mis_nee_lights.size() == 1 && c.mis_nee_lights[0] == c.sun_light;
}

// Per medium, the one shape that holds it, empty inside (RenderContext::medium_container).
void find_medium_containers(const Scene &scene, RenderContext &c) {
    const size_t n = scene.media.size();
    c.medium_container.assign(n, -1);
    std::vector<int> interfaces(n, 0);
    for (int i = 0; i < int(scene.shapes.size()); ++i) {
        const ShapeInfo &s = scene.shapes[size_t(i)];
        if (!s.medium_interface) continue;
        for (int m : {s.interior, s.exterior})
            if (m >= 0 && m < int(n)) ++interfaces[size_t(m)];
        if (s.interior >= 0 && s.interior < int(n) && scene.geometry.empty_inside(i))
            c.medium_container[size_t(s.interior)] = i;
    }
    // A medium named by a second interface (or as both sides of one) is not held by one shape.
    for (size_t m = 0; m < n; ++m)
        if (interfaces[m] != 1) c.medium_container[m] = -1;
}

// The flat null boundaries that another flat surface may lie on. Only flat pieces can
// share an area with a boundary: spheres touch others at points.
void find_boundaries_with_contact(const Scene &scene, RenderContext &c) {
    const Geometry &geometry = scene.geometry;
    c.boundary_with_contact.assign(scene.shapes.size(), 0);
    std::vector<int> boundaries;
    std::vector<Bounds> surface_bounds;
    for (int i = 0; i < int(scene.shapes.size()); ++i) {
        if (geometry.shapes[size_t(i)].is_sphere()) continue;
        const bool null = is_null(scene.bsdfs[size_t(scene.shapes[size_t(i)].bsdf)]);
        if (null && scene.shapes[size_t(i)].medium_interface) boundaries.push_back(i);
        if (!null) surface_bounds.push_back(geometry.shape_bounds(i));
    }
    if (boundaries.empty()) return;
    const Bounds all = geometry.bounds();
    const Real eps = 1e-9 * std::max(max_component(abs(all.lo)), max_component(abs(all.hi))) + 1e-12;
    for (int i : boundaries)
        for (const Bounds &b : surface_bounds)
            c.boundary_with_contact[size_t(i)] |= geometry.may_touch_surface(i, b, eps);
}

// Whether a shape may shadow the air: not if it is a sphere that is an atmosphere's ground
// (the tables know that shadow) or lies inside it, or that is a null boundary, all around
// the same centre.
bool shadows_air(const Scene &scene, int shape) {
    const ShapeGeometry &g = scene.geometry.shapes[size_t(shape)];
    if (!g.is_sphere()) return true;
    const Sphere &s = scene.geometry.spheres[g.index];
    for (const Medium &m : scene.media) {
        const auto *air = std::get_if<AtmosphereMedium>(&m);
        if (air && s.center == air->center &&
            (s.radius <= air->planet_radius * (1 + 1e-12) || is_null(scene.bsdfs[scene.shapes[shape].bsdf])))
            return false;
    }
    return true;
}

// Each guided air lit by the sun gets its sky map, its ground's albedo from the diffuse
// sphere that is its ground; a map of the previous context is reused where it can be.
void build_sky_maps(const Scene &scene, const RenderContext *previous, RenderContext &c) {
    c.sky_maps.assign(scene.media.size(), nullptr);
    for (size_t m = 0; m < scene.media.size(); ++m) {
        const auto *air = std::get_if<AtmosphereMedium>(&scene.media[m]);
        if (!air || !c.sun || !air->use_sky_map || air->free_flight != AtmosphereMedium::FreeFlight::Guided) continue;
        Spectrum albedo(0.0);
        for (int i = 0; i < int(scene.shapes.size()); ++i) {
            const ShapeGeometry &g = scene.geometry.shapes[size_t(i)];
            const auto *diffuse = std::get_if<DiffuseBSDF>(&scene.bsdfs[scene.shapes[size_t(i)].bsdf].model);
            if (g.is_sphere() && diffuse && scene.geometry.spheres[g.index].center == air->center &&
                scene.geometry.spheres[g.index].radius == air->planet_radius)
                albedo = diffuse->reflectance;
        }
        const SkyMap *before = previous && m < previous->sky_maps.size() ? previous->sky_maps[m].get() : nullptr;
        c.sky_maps[m] = build_sky_map(*air, *c.sun, albedo, scene.camera.to_world.point(Vec3(0.0)), before);
    }
}

}  // namespace

void Scene::set_instance(int k, const Transform &to_world, MotionKeys motion) {
    geometry.set_instance(k, to_world, to_world.inverse(), std::move(motion));
    built = false;
}

void Scene::set_group_mesh(int shape, TriangleMesh mesh) {
    check_mesh(mesh);
    geometry.set_group_mesh(shape, std::move(mesh));
    built = false;
}

void Scene::replace_bsdf(int bsdf) {
    if (bsdf < 0 || size_t(bsdf) + 1 >= bsdfs.size()) throw std::out_of_range("invalid bsdf");
    const BSDF &added = bsdfs.back();
    if (is_layered(added) || !added.textured.empty() || is_layered(bsdfs[size_t(bsdf)]))
        throw std::invalid_argument("only a leaf BSDF without textures is replaced in place");
    bsdfs[size_t(bsdf)] = added;
    bsdfs.pop_back();
    built = false;
}

void Scene::build() {
    if (!geometry_built)
        geometry.build();
    else
        geometry.refit();
    geometry_built = true;
    for (Light &l : lights) prepare_light(l, geometry);
    RenderContext c;
    sort_lights(*this, c);
    if (c.mis_nee_lights.size() > 1) c.nee_sampler = LightSampler(lights, c.mis_nee_lights, geometry);
    find_medium_containers(*this, c);
    find_boundaries_with_contact(*this, c);
    c.shadows_stop_at_any_hit = std::none_of(shapes.begin(), shapes.end(), [&](const ShapeInfo &s) {
        const BSDF &b = bsdfs[size_t(s.bsdf)];
        return is_null(b) || is_layered(b) || s.hides_from(RayKind::Shadow);
    });
    c.motion = camera.motion.moves() ||
               std::any_of(geometry.instances.begin(), geometry.instances.end(),
                           [](const Instance &i) { return i.motion.moves(); }) ||
               std::any_of(geometry.meshes.begin(), geometry.meshes.end(),
                           [](const TriangleMesh &m) { return !m.motion.empty(); });
    const int enclosure = geometry.enclosure();
    c.enclosed_medium = enclosure >= 0 && shapes[enclosure].medium_interface ? shapes[enclosure].interior : -2;
    build_sky_maps(*this, &context, c);
    for (int i = 0; i < int(shapes.size()); ++i)
        if (shadows_air(*this, i)) c.local_bounds.extend(geometry.shape_bounds(i));
    if (camera.medium >= int(media.size())) throw std::out_of_range("invalid camera medium");
    context = std::move(c);
    built = true;
}

// The points o + t d, t in [t0, t1], whose rays toward the sun, o + t d + u s (u >= 0),
// enter local_bounds: where for some u every axis i has lo_i <= o_i + t d_i + u s_i <= hi_i.
// Each axis bounds u from below and above by functions linear in t (or, where s_i = 0,
// bounds t itself); u exists where every lower bound is below every upper bound, a linear
// condition on t per pair (Fourier-Motzkin elimination). The set is an interval: the
// projection of a convex set.
std::pair<Real, Real> Scene::local_sun_shadow(const Ray &ray, Real t0, Real t1) const {
    const std::pair<Real, Real> none{kInfinity, -kInfinity};
    if (!context.sun || !context.local_bounds.valid()) return none;
    const Vec3 s = context.sun->to_sun;
    struct Linear {
        Real a, b;  // a + b t
    };
    Linear lower[4] = {{0, 0}}, upper[3];  // u >= 0 is the first lower bound
    int n_lower = 1, n_upper = 0;
    Real lo_t = t0, hi_t = t1;
    // a + b t <= 0 narrows [lo_t, hi_t].
    auto at_most_zero = [&](Real a, Real b) {
        if (b > 0)
            hi_t = std::min(hi_t, -a / b);
        else if (b < 0)
            lo_t = std::max(lo_t, -a / b);
        else if (a > 0)
            hi_t = -kInfinity;
    };
    for (int i = 0; i < 3; ++i) {
        const Real o = ray.o[i], d = ray.d[i], lo = context.local_bounds.lo[i], hi = context.local_bounds.hi[i];
        if (s[i] == 0) {
            at_most_zero(lo - o, -d);  // lo <= o + t d
            at_most_zero(o - hi, d);   // o + t d <= hi
            continue;
        }
        const Linear from_lo{(lo - o) / s[i], -d / s[i]}, from_hi{(hi - o) / s[i], -d / s[i]};
        lower[n_lower++] = s[i] > 0 ? from_lo : from_hi;
        upper[n_upper++] = s[i] > 0 ? from_hi : from_lo;
    }
    for (int j = 0; j < n_lower; ++j)
        for (int k = 0; k < n_upper; ++k) at_most_zero(lower[j].a - upper[k].a, lower[j].b - upper[k].b);
    return lo_t <= hi_t ? std::pair<Real, Real>{lo_t, hi_t} : none;
}

std::string Scene::describe() const {
    std::ostringstream s;
    s << geometry.meshes.size() << " meshes, " << geometry.spheres.size() << " spheres, " << geometry.boxes.size()
      << " boxes, " << geometry.instances.size() << " instances, " << media.size() << " media, " << lights.size()
      << " lights";
    return s.str();
}

std::vector<std::pair<std::string, size_t>> Scene::memory() const {
    auto bytes = [](const auto &v) { return v.capacity() * sizeof(v[0]); };
    std::set<const VoxelGrid *> grids;
    size_t media_bytes = 0, light_bytes = 0;
    auto grid_bytes = [&](const PlacedGrid &g) {
        if (g.empty() || !grids.insert(g.grid.get()).second) return size_t(0);
        return bytes(g.grid->data) + bytes(g.grid->brick_index);
    };
    for (const Medium &m : media) {
        if (const auto *g = std::get_if<GridMedium>(&m)) {
            media_bytes += grid_bytes(g->density) + grid_bytes(g->albedo_grid) + grid_bytes(g->Le_grid);
            media_bytes += bytes(g->majorants.cells);
        } else if (const auto *air = std::get_if<AtmosphereMedium>(&m)) {
            media_bytes += bytes(air->tau_to_top);
        }
    }
    for (const auto &map : context.sky_maps)
        if (map)
            for (const SkyMap::Level &level : *map->levels) {
                media_bytes += bytes(level.radiance) + bytes(level.directions.rows) * 2;
                for (const Distribution1D &row : level.directions.rows) media_bytes += bytes(row.func) + bytes(row.cdf);
            }
    for (const Light &l : lights)
        if (const auto *env = std::get_if<EnvironmentLight>(&l)) {
            light_bytes += bytes(env->pixels);
            for (const Distribution1D &row : env->distribution.rows) light_bytes += bytes(row.func) + bytes(row.cdf);
        }
    size_t texture_bytes_total = 0;
    for (const Texture &t : textures) texture_bytes_total += texture_bytes(t);
    return {{"shapes", geometry.shape_bytes()},
            {"bvh", geometry.bvh_bytes()},
            {"media", media_bytes},
            {"lights", light_bytes},
            {"textures", texture_bytes_total}};
}

bool Scene::surface_on_boundary(const Ray &ray, const Intersection &its, Intersection &out) const {
    // Along the ray, a few epsilons of distance from the plane on either side (more where
    // the ray grazes it, up to a limit).
    const Real delta = 4 * ray_epsilon(its.p) / std::max(std::abs(dot(ray.d, its.n)), Real(1e-2));
    const Ray probe{its.p - ray.d * delta, ray.d, 0, 2 * delta, ray.time};
    if (!geometry.intersect_except(probe, its.shape, out) || is_null(bsdfs[size_t(shapes[size_t(out.shape)].bsdf)]))
        return false;
    out.t = its.t + (out.t - delta);
    return true;
}

}  // namespace volpath
