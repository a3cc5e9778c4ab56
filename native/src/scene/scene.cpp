#include "volpath/scene.h"

#include <sstream>
#include <stdexcept>

namespace volpath {

int Scene::add_bsdf(const BSDF &b) {
    bsdfs.push_back(b);
    return int(bsdfs.size()) - 1;
}

int Scene::add_medium(const Medium &m) {
    media.push_back(m);
    prepare_medium(media.back());
    return int(media.size()) - 1;
}

int Scene::add_light(const Light &l) {
    lights.push_back(l);
    if (std::holds_alternative<PointLight>(l) || std::holds_alternative<DirectionalLight>(l)) ++point_and_directional;
    if (is_infinite(l)) infinite_lights.push_back(int(lights.size()) - 1);
    if (!std::holds_alternative<EnvironmentLight>(l)) segment_lights.push_back(int(lights.size()) - 1);
    // Under MIS a constant environment is left to phase and BSDF sampling: a direction
    // drawn in proportion to the scattering function is at least as good a sample of a
    // uniform sky as NEE's uniform one, and the path traces it anyway, so NEE would pay a
    // shadow ray for nothing. Measured on bench (d) (a sun and a constant sky over a dense
    // cube), at equal work: 1.6x less squared error than choosing the sky half the time.
    if (!is_constant_environment(l)) mis_nee_lights.push_back(int(lights.size()) - 1);
    return int(lights.size()) - 1;
}

Real Scene::light_select_pdf(int light, bool mis) const {
    if (!mis) return lights.empty() ? 0.0 : 1.0 / Real(lights.size());
    return is_constant_environment(lights[light]) ? 0.0 : 1.0 / Real(mis_nee_lights.size());
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
}  // namespace

int Scene::add_shape_mesh(TriangleMesh mesh, const ShapeInfo &info, const Spectrum *radiance) {
    check_info(*this, info);
    for (const auto &t : mesh.triangles)
        for (uint32_t v : t)
            if (v >= mesh.positions.size()) throw std::out_of_range("triangle index out of range");
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size())
        throw std::invalid_argument("need one normal per vertex");
    const int id = geometry.add_mesh(std::move(mesh));
    shapes.push_back(info);
    if (radiance) shapes.back().light = add_light(AreaLight{id, *radiance, {}, 0});
    built = false;
    return id;
}

int Scene::add_shape_sphere(const Sphere &s, const ShapeInfo &info, const Spectrum *radiance) {
    check_info(*this, info);
    if (!(s.radius > 0)) throw std::invalid_argument("sphere radius must be positive");
    const int id = geometry.add_sphere(s);
    shapes.push_back(info);
    if (radiance) shapes.back().light = add_light(AreaLight{id, *radiance, {}, 0});
    built = false;
    return id;
}

void Scene::build() {
    geometry.build();
    for (Light &l : lights) prepare_light(l, geometry);
    sun.reset();
    has_environment = false;
    for (const Light &l : lights) has_environment |= std::holds_alternative<EnvironmentLight>(l);
    for (const Light &l : lights) {
        if (const auto *s = std::get_if<SunLight>(&l)) sun = SunGuide{s->to_sun, s->radiance};
        else if (const auto *d = std::get_if<DirectionalLight>(&l)) sun = SunGuide{-d->direction, d->irradiance};
        if (sun) break;
    }
    if (camera.medium >= int(media.size())) throw std::out_of_range("invalid camera medium");
    built = true;
}

std::string Scene::describe() const {
    std::ostringstream s;
    s << geometry.meshes.size() << " meshes, " << geometry.spheres.size() << " spheres, "
      << media.size() << " media, " << lights.size() << " lights";
    return s.str();
}

}  // namespace volpath
