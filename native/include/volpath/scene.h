// The in-memory scene: its description (plain arrays of shapes, BSDFs, media and lights,
// indexed by int, -1 = none), which loaders and exporters fill through the builder
// functions, and the render context derived from it.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bsdf.h"
#include "geometry.h"
#include "light.h"
#include "light_sampler.h"
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
    MotionKeys motion;             // to_world over the shutter (motion blur), if it moves
};

// What a render reads besides the scene's description, all of it derived from the
// description by Scene::build(): the lights each next-event strategy chooses among, the sun
// that guides flights through the air and the sky maps it lights, and what makes shape
// queries cheap. A frame's update (a light or the camera moved) rebuilds this one object;
// the description stays as loaders and exporters wrote it, and the BVH as it was built.
// (What depends on one medium alone, its majorant grid and the air's transmittance table,
// is built with the medium by add_medium and kept with it: no frame changes it.)
struct RenderContext {
    // Lights by role (indices into Scene::lights).
    std::vector<int> infinite_lights;  // environments and suns: found by rays that escape
    // All but environment lights: NEE also from distances drawn for them on homogeneous
    // media segments (see SegmentVertex in the integrator).
    std::vector<int> segment_lights;
    // The lights NEE chooses from under MIS: all but constant environments (a direction
    // drawn in proportion to the scattering function is at least as good a sample of a
    // uniform sky as NEE's uniform one, and the path traces it anyway).
    std::vector<int> mis_nee_lights;
    // Chooses among mis_nee_lights, where there are several, by their importance at the point.
    LightSampler nee_sampler;
    // The lights NEE chooses from at a free-flight collision in a homogeneous medium, where
    // every segment estimates the segment lights by a distance of its own: the environments
    // among NEE's lights, [0] without MIS, [1] under MIS.
    std::vector<int> collision_nee_lights[2];
    size_t point_and_directional = 0;
    bool lights_hide_lobes = false;  // a light hides from Diffuse, Glossy or Transmission rays
    bool has_environment = false;    // an EnvironmentLight among the lights
    // Whether the camera or an instance moves over the shutter: each camera ray then draws
    // its time (motion blur).
    bool motion = false;
    // The first sun or directional light, which guides free flights in the air.
    std::optional<SunGuide> sun;
    int sun_light = -1;  // its index
    // Whether NEE under MIS chooses that sun alone: the light scattered in the air then has
    // models whose integrals are known (AirSegment::light_model, the SkyMap), control
    // variates for the guided free flight, wherever nothing but a planet shadows the sun.
    bool sun_alone_under_mis = false;
    // Per medium: the sky map of guided air that a sun lights, seen from the camera; else null.
    std::vector<std::shared_ptr<const SkyMap>> sky_maps;
    // The bounds of the shapes that may shadow the air besides the planets and the air's
    // own boundaries (terrain, buildings, a fog bank's box); invalid if there are none.
    Bounds local_bounds;
    // Whether every shape stops shadow rays outright (none is null, masked or hidden from
    // them): a shadow ray then only asks whether it hits anything.
    bool shadows_stop_at_any_hit = false;
    // Per shape: whether it is a flat null medium boundary (a mesh or box) that another flat
    // surface may lie on (the only boundaries Scene::surface_on_boundary looks around: the
    // look costs a short ray query per crossing).
    std::vector<uint8_t> boundary_with_contact;
    // The medium inside the enclosure's interface, where rays need not test for leaving it
    // (-2: none).
    int enclosed_medium = -2;
    // Per medium: the shape that holds it, if that is the only shape whose interface names
    // the medium (as its interior) and it is empty inside (Geometry::empty_inside); else -1.
    std::vector<int> medium_container;
};

// The scene's description: plain arrays of shapes, BSDFs, media and lights, indexed by int
// (-1 = none), the camera, and the context a render reads (built from them by build()).
struct Scene {
    Geometry geometry;
    std::vector<ShapeInfo> shapes;
    std::vector<BSDF> bsdfs;
    std::vector<Texture> textures;
    std::vector<Medium> media;
    std::vector<Light> lights;
    // Per light, the kinds of rays it is hidden from (RayKind bits, Blender's ray
    // visibility of lights): Camera, camera rays do not see it (a world that lights the
    // scene behind another that is shown); Scatter, it lights no medium (neither NEE from a scattering
    // vertex nor a scattered ray that meets it count it); Shadow, it casts no shadow (NEE
    // toward it ignores what lies between, and only camera rays count it where they meet
    // it: NEE alone lights the scene, unweighted); Diffuse, Glossy, Transmission, it lights
    // surfaces through their other lobes only (NEE evaluates those; a bounce that finds it
    // counts the share of its BSDF value they hold).
    std::vector<uint8_t> light_hidden_from;
    Camera camera;
    RenderContext context;  // up to date where `built`
    bool built = false;
    bool geometry_built = false;  // the BVH is up to date with the shapes

    bool light_hides_from(int light, RayKind kind) const {
        return (light_hidden_from[size_t(light)] & uint8_t(kind)) != 0;
    }
    // Whether only camera rays see the light (hidden from every lobe and from media): it
    // lights nothing, and NEE under MIS never chooses it.
    bool light_lights_nothing(int light) const {
        constexpr uint8_t lit = kLobeRays | uint8_t(RayKind::Scatter);
        return (light_hidden_from[size_t(light)] & lit) == lit;
    }
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
    int add_instance(int group, const Transform &to_world, const Transform &to_local, MotionKeys motion = {});
    int add_light(const Light &l, uint8_t hidden_from = 0);
    // An animation's next frame, where the shapes' description changes but not its layout:
    // instance k moved, a shape group's mesh deformed (Geometry::refit), a shape's BSDF
    // replaced by the last one added (its new parameters: that one is taken off the end, so
    // frames do not accumulate BSDFs; a leaf without textures only). build() then redoes
    // the context, and the BVH only where it changed.
    void set_instance(int k, const Transform &to_world, MotionKeys motion = {});
    void set_group_mesh(int shape, TriangleMesh mesh);
    void replace_bsdf(int bsdf);
    // Replaces light i, and the rays it is hidden from, by another of its kind (an
    // animation's sun, a lamp edited in the viewport); build() then redoes the context, not
    // the geometry.
    void set_light(int i, const Light &l, uint8_t hidden_from);
    // Builds what is out of date: the BVH, then the render context (whose sky maps keep
    // the levels of the previous context's while the sun stays within their elevations).
    void build();

    // NEE's probability of choosing `light` at p: under MIS, among mis_nee_lights by their
    // importance at p (RenderContext::nee_sampler); else uniformly among all lights.
    Real light_select_pdf(int light, bool mis, const Vec3 &p) const;
    // The same at a collision that chooses among collision_nee_lights.
    Real collision_light_select_pdf(int light, bool mis) const;
    bool intersect(const Ray &ray, Intersection &its) const { return geometry.intersect(ray, its); }
    // The same for a ray travelling in `medium` (-1: none), with no traversal from inside
    // the medium's container (see RenderContext::medium_container) or outside the scene's
    // enclosure (Geometry::enclosure), where there is nothing to hit.
    // A surface that lies on a medium's boundary is met before the boundary is crossed
    // (surface_on_boundary).
    bool intersect(const Ray &ray, Intersection &its, int medium) const {
        std::optional<bool> hit;
        if (medium >= 0 && context.medium_container[size_t(medium)] >= 0)
            hit = geometry.intersect_from_inside(context.medium_container[size_t(medium)], ray, its);
        if (!hit) {
            if (medium != context.enclosed_medium && geometry.outside_enclosure(ray)) return false;
            hit = geometry.intersect(ray, its);
        }
        if (*hit && context.boundary_with_contact[size_t(its.shape)]) {
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
    // Whether a ray can hit an emitter (area lights, lights at infinity); with only point
    // and directional lights, light arrives by next-event estimation alone.
    bool has_hittable_emitters() const { return lights.size() > context.point_and_directional; }
    const SunGuide *sun_guide() const { return context.sun ? &*context.sun : nullptr; }
    // The sky map of guided air in `medium` (RenderContext::sky_maps), or null.
    const SkyMap *sky_map(int medium) const { return context.sky_maps[size_t(medium)].get(); }
    // The distances [first, second] within [t0, t1] along `ray` whose points see the sun
    // through local_bounds (first > second: none): there local shapes may shadow the air.
    std::pair<Real, Real> local_sun_shadow(const Ray &ray, Real t0, Real t1) const;
    // Whether the air's light models hold at p: the sun alone, not shadowed by local shapes.
    bool air_models_hold(const Vec3 &p) const {
        if (!context.sun_alone_under_mis || !context.local_bounds.valid()) return context.sun_alone_under_mis;
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
