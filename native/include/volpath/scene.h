// The in-memory scene: plain arrays of shapes, BSDFs, media and lights, indexed by int
// (-1 = none). Loaders and exporters fill it through the builder functions.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "bsdf.h"
#include "geometry.h"
#include "light.h"
#include "medium.h"

namespace volpath {

struct ShapeInfo {
    int bsdf = -1;
    int light = -1;  // the AreaLight on this shape
    // Only shapes with a medium interface change the medium a ray travels in:
    // leaving through the front (along the normal) enters `exterior`, else `interior`.
    bool medium_interface = false;
    int interior = -1, exterior = -1;
    // The kinds of rays that pass through the shape, emission and all (RayKind bits:
    // Blender's ray visibility; lights, which Cycles hides from the camera unless asked).
    uint8_t hidden_from = 0;
    bool hides_from(RayKind kind) const { return (hidden_from & uint8_t(kind)) != 0; }
};

// Mitsuba's perspective camera: looks along +z of `to_world`, +x of the camera points to
// the left of the image and +y up.
struct Camera {
    Transform to_world;
    Real tan_half_x = 1, tan_half_y = 1;
    // Lens shift: the image window's centre on the z = 1 plane, in camera coordinates.
    Real shift_x = 0, shift_y = 0;
    int width = 64, height = 64;
    Real near_clip = 1e-2, far_clip = 1e4;
    int medium = -1;
    bool gaussian_filter = false;  // Mitsuba's default: stddev 0.5 px, radius 2 px
};

struct Scene {
    Geometry geometry;
    std::vector<ShapeInfo> shapes;
    std::vector<BSDF> bsdfs;
    std::vector<Texture> textures;
    std::vector<Medium> media;
    std::vector<Light> lights;
    // Per light, the kinds of rays it is hidden from (RayKind bits, Blender's ray
    // visibility of lights): Scatter, it lights no medium (neither NEE from a scattering
    // vertex nor a scattered ray that meets it count it); Shadow, it casts no shadow (NEE
    // toward it ignores what lies between, and only camera rays count it where they meet
    // it: NEE alone lights the scene, unweighted); Diffuse, Glossy, Transmission, it lights
    // surfaces through their other lobes only (NEE evaluates those; a bounce that finds it
    // counts the share of its BSDF value they hold).
    std::vector<uint8_t> light_hidden_from;
    bool lights_hide_lobes = false;  // a light hides from Diffuse, Glossy or Transmission; set by build()
    bool light_hides_from(int light, RayKind kind) const {
        return (light_hidden_from[size_t(light)] & uint8_t(kind)) != 0;
    }
    std::vector<int> infinite_lights;  // indices into lights
    // All but environment lights: NEE also from distances drawn for them on homogeneous
    // media segments (see SegmentVertex in the integrator). Indices into lights.
    std::vector<int> segment_lights;
    // The lights NEE chooses from under MIS: all but constant environments (see add_light).
    std::vector<int> mis_nee_lights;
    // The lights NEE chooses from at a free-flight collision in a homogeneous medium, where
    // every segment estimates the segment lights by a distance of its own: the environments
    // among NEE's lights, [0] without MIS, [1] under MIS.
    std::vector<int> collision_nee_lights[2];
    Camera camera;
    bool built = false;

    int add_bsdf(const BSDF &b);
    int add_medium(const Medium &m);
    int add_texture(Texture t);
    // Makes one of the BSDF's parameters vary as `param` says (its texture added before).
    void bind_texture(int bsdf, const TexturedParam &param);
    // `emission`: an area light on the shape, or none.
    // `group`: the shape group it belongs to (see add_group), or -1.
    int add_shape_mesh(TriangleMesh mesh, const ShapeInfo &info, const AreaEmission *emission = nullptr,
                       int group = -1);
    int add_shape_sphere(const Sphere &s, const ShapeInfo &info, const AreaEmission *emission = nullptr);
    int add_shape_box(const Box &b, const ShapeInfo &info);  // boxes do not emit
    // Shape groups hold meshes that neither emit nor bound media, traced only through their
    // instances: each places the whole group by an affine map (Mitsuba's shapegroup and
    // instance).
    int add_group() { return geometry.add_group(); }
    int add_instance(int group, const Transform &to_world, const Transform &to_local);
    int add_light(const Light &l, uint8_t hidden_from = 0);  // counts point_and_directional
    // Replaces light i, and the rays it is hidden from, by another of its kind (an
    // animation's sun, a lamp edited in the viewport); build() then redoes what depends on
    // the lights, not the geometry.
    void set_light(int i, const Light &l, uint8_t hidden_from);
    void build();
    bool geometry_built = false;  // the BVH is up to date with the shapes

    // NEE's probability of choosing `light`: uniform among mis_nee_lights under MIS, else
    // among all lights.
    Real light_select_pdf(int light, bool mis) const;
    // The same at a collision that chooses among collision_nee_lights.
    Real collision_light_select_pdf(int light, bool mis) const;
    bool intersect(const Ray &ray, Intersection &its) const { return geometry.intersect(ray, its); }
    // The same for a ray travelling in `medium` (-1: none), with no traversal from inside
    // the medium's container (see medium_container) or outside the scene's enclosure
    // (Geometry::enclosure), where there is nothing to hit.
    // A surface that lies on a medium's boundary is met before the boundary is crossed
    // (surface_on_boundary).
    bool intersect(const Ray &ray, Intersection &its, int medium) const {
        std::optional<bool> hit;
        if (medium >= 0 && medium_container[size_t(medium)] >= 0)
            hit = geometry.intersect_from_inside(medium_container[size_t(medium)], ray, its);
        if (!hit) {
            if (medium != enclosed_medium && geometry.outside_enclosure(ray)) return false;
            hit = geometry.intersect(ray, its);
        }
        if (*hit && boundary_with_contact[size_t(its.shape)]) {
            Intersection on;
            if (surface_on_boundary(ray, its, on)) its = on;
        }
        return *hit;
    }
    // The surface that lies on a medium's boundary where the ray crosses it at `its` (a box
    // of smoke resting on the floor), if any: within a few ray epsilons of the crossing, of
    // another shape whose BSDF is not null. Such a surface is inside the medium: the ray
    // meets it before it crosses (out.t is on `ray`).
    bool surface_on_boundary(const Ray &ray, const Intersection &its, Intersection &out) const;
    // Per shape, set by build(): whether it is a flat null medium boundary (a mesh or box)
    // that another flat surface may lie on (the only boundaries surface_on_boundary looks
    // around: the look costs a short ray query per crossing).
    std::vector<uint8_t> boundary_with_contact;
    // The medium inside the enclosure's interface, where rays need not test for leaving it
    // (-2: none). Set by build().
    int enclosed_medium = -2;
    // Per medium: the shape that holds it, if that is the only shape whose interface names
    // the medium (as its interior) and it is empty inside (Geometry::empty_inside); else -1.
    // Set by build().
    std::vector<int> medium_container;
    // Whether a ray can hit an emitter (area lights, lights at infinity); with only point
    // and directional lights, light arrives by next-event estimation alone.
    bool has_hittable_emitters() const { return lights.size() > point_and_directional; }
    size_t point_and_directional = 0;
    bool has_environment = false;  // an EnvironmentLight among the lights; set by build()
    // Whether every shape stops shadow rays outright (none is null, masked or hidden from
    // them): a shadow ray then only asks whether it hits anything. Set by build().
    bool shadows_stop_at_any_hit = false;
    // The first sun or directional light, which guides free flights in the air; set by build().
    std::optional<SunGuide> sun;
    const SunGuide *sun_guide() const { return sun ? &*sun : nullptr; }
    // Whether NEE under MIS chooses that sun alone: the light scattered in the air then has
    // models whose integrals are known (AirSegment::light_model, the SkyMap), control
    // variates for the guided free flight, wherever nothing but a planet shadows the sun.
    // Set by build().
    bool sun_alone_under_mis = false;
    // The bounds of the shapes that may shadow the air besides the planets and the air's
    // own boundaries (terrain, buildings, a fog bank's box); invalid if there are none.
    // Set by build().
    Bounds local_bounds;
    // The distances [first, second] within [t0, t1] along `ray` whose points see the sun
    // through local_bounds (first > second: none): there local shapes may shadow the air.
    std::pair<Real, Real> local_sun_shadow(const Ray &ray, Real t0, Real t1) const;
    // Whether the air's light models hold at p: the sun alone, not shadowed by local shapes.
    bool air_models_hold(const Vec3 &p) const {
        if (!sun_alone_under_mis || !local_bounds.valid()) return sun_alone_under_mis;
        const auto [a, b] = local_sun_shadow(Ray{p, Vec3(0, 0, 1)}, 0, 0);  // the point alone: t in [0, 0]
        return a > b;
    }
    std::string describe() const;
    // Bytes the scene holds, by part: "shapes", "bvh", "media" (grids, majorants, the air's
    // tables and sky maps; a grid shared by media counted once), "lights" (environment
    // maps) and "textures".
    std::vector<std::pair<std::string, size_t>> memory() const;
};

// A surface at a hit with its layers resolved (see Layer in bsdf.h) and its textures
// looked up.
struct SurfacePoint {
    // The leaf BSDF; nullptr where a mask, or a null BSDF inside a blend, lets the ray
    // through (a null BSDF on its own is a medium's boundary, returned as it is).
    const BSDF *bsdf = nullptr;
    Real pass = 0;  // then: the probability that it passes (surface_pass)
    Vec3 ns;        // the shading normal: its.ns, or as normal and bump maps turn it
    BSDF local;     // holds a leaf whose parameters are textured
};
// `u` in [0, 1) makes the choices of blends and masks (rescaled after each); only layered
// BSDFs read it.
void surface_at(const Scene &scene, int bsdf, const Intersection &its, Real u, SurfacePoint &out);
// The probability that a ray passes straight through the surface at uv: 1 through a null
// BSDF, 1 - opacity through a mask, blended through a blend, else 0. Shadow rays are
// multiplied by it.
Real surface_pass(const Scene &scene, int bsdf, Vec2 uv);

}  // namespace volpath
