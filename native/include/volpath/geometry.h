// Shapes (triangle meshes, analytic spheres and boxes) and the BVH over them.
//
// Volpath traces its own double-precision BVH instead of Embree: planet-scale scenes
// need double precision, and Blender's process exports Embree 4's symbols, which a
// module linked to Embree 3 binds to by mistake (native/README.md).
#pragma once

#include <algorithm>
#include <array>
#include <optional>
#include <vector>

#include "math.h"

namespace volpath {

struct TriangleMesh {
    std::vector<Vec3> positions;
    std::vector<Vec3> normals;  // per vertex, optional (smooth shading)
    std::vector<Vec2> uvs;      // per vertex, optional (texture coordinates)
    std::vector<std::array<uint32_t, 3>> triangles;
    // Deformation blur: the positions at evenly spaced times over the shutter (two or more
    // keys, each like `positions`), interpolated linearly between them; none: it holds
    // still. Shading normals stay the frame's.
    std::vector<std::vector<Vec3>> motion;
    Real area(size_t i) const;  // (at `positions`)
    // Texture coordinates at barycentrics (b1, b2) of triangle i (weights of its second and
    // third corners); without uvs, the barycentrics themselves.
    Vec2 uv(size_t i, Real b1, Real b2) const {
        if (uvs.empty()) return {b1, b2};
        const auto &t = triangles[i];
        const Vec2 &t0 = uvs[t[0]], &t1 = uvs[t[1]], &t2 = uvs[t[2]];
        const Real b0 = 1 - b1 - b2;
        return {t0.x * b0 + t1.x * b1 + t2.x * b2, t0.y * b0 + t1.y * b1 + t2.y * b2};
    }
    // Triangle i's corners at `time` in the shutter.
    std::array<Vec3, 3> corners(size_t i, Real time) const {
        const auto &t = triangles[i];
        if (motion.empty()) return {positions[t[0]], positions[t[1]], positions[t[2]]};
        const Real x = std::clamp(time, Real(0), Real(1)) * Real(motion.size() - 1);
        const size_t k = std::min(size_t(x), motion.size() - 2);
        const Real f = x - Real(k);
        std::array<Vec3, 3> c;
        for (int j = 0; j < 3; ++j) c[size_t(j)] = motion[k][t[size_t(j)]] * (1 - f) + motion[k + 1][t[size_t(j)]] * f;
        return c;
    }
};

struct Sphere {
    Vec3 center;
    Real radius = 1;
    bool flip_normals = false;
};

struct Bounds {
    Vec3 lo{kInfinity}, hi{-kInfinity};
    void extend(const Vec3 &p) { lo = min(lo, p), hi = max(hi, p); }
    void extend(const Bounds &b) { lo = min(lo, b.lo), hi = max(hi, b.hi); }
    Vec3 centroid() const { return (lo + hi) * 0.5; }
    Real surface_area() const {
        const Vec3 e = clamp_zero(hi - lo);
        return 2.0 * (e.x * e.y + e.y * e.z + e.z * e.x);
    }
    bool valid() const { return lo.x <= hi.x; }
};

// The cube [-1, 1]^3 under an invertible affine map (the scene language's `cube`, the usual
// container of a medium): one primitive, intersected by the slab test (in world space when
// the box is axis-aligned, else in its own), cheaper than its twelve triangles.
struct Box {
    Transform to_world, to_local;
    bool flip_normals = false;
    // Set by Geometry::add_box: the box itself where it is axis-aligned in world space
    // (else invalid), and its +x, +y, +z faces' world normals.
    Bounds aligned_bounds;
    std::array<Vec3, 3> normals;
};

struct Intersection {
    Real t = kInfinity;
    Vec3 p;
    Vec3 n;   // geometric normal, unit, on the shape's front side
    Vec3 ns;  // shading normal, on the same side as n
    int shape = -1;
    uint32_t prim = 0;
    int instance = -1;  // the instance through which a shape group's shape was hit
    Real time = 0;      // the ray's (where a moving instance was when it was hit)
};

// A map over the shutter's interval: `keys` at evenly spaced times from its opening (0) to
// its closing (1), interpolated linearly between them (see lerp); no keys, it holds still.
struct MotionKeys {
    std::vector<Transform> keys;
    bool moves() const { return !keys.empty(); }
    Transform at(Real time) const {
        const Real x = std::clamp(time, Real(0), Real(1)) * Real(keys.size() - 1);
        const size_t i = std::min(size_t(x), keys.size() - 2);
        return lerp(keys[i], keys[i + 1], x - Real(i));
    }
};

// One entry per scene shape: a mesh, a sphere or a box.
struct ShapeGeometry {
    // (Instance: only a BVH's primitive, one instance of a shape group.)
    enum class Kind : uint8_t { Mesh, Sphere, Box, Instance } kind = Kind::Mesh;
    int index = 0;   // into Geometry::meshes, spheres or boxes
    int group = -1;  // the shape group it belongs to: traced only through its instances
    bool is_sphere() const { return kind == Kind::Sphere; }
};

// A shape group (meshes in their own space, with their own BVH) placed in the scene by an
// affine map: one primitive of the scene's BVH, whose rays are mapped into the group's
// space, where distances along them stay the world ray's (the map is affine, the
// direction is not renormalised).
struct Instance {
    int group = 0;
    Transform to_world, to_local;  // (mirroring where det(to_world) < 0: faces turn as a flattened copy's)
    MotionKeys motion;             // where it moves over the shutter (motion blur), if it does
};

class Geometry {
public:
    std::vector<TriangleMesh> meshes;
    std::vector<Sphere> spheres;
    std::vector<Box> boxes;
    std::vector<ShapeGeometry> shapes;
    std::vector<Instance> instances;

    // A mesh in shape group `group` (see add_group), or in the scene itself (-1).
    int add_mesh(TriangleMesh mesh, int group = -1);
    int add_sphere(const Sphere &sphere);
    int add_box(const Box &box);
    int add_group() { return group_count_++; }
    int add_instance(int group, const Transform &to_world, const Transform &to_local, MotionKeys motion = {});
    void build();  // must be called after the last add
    // An animation's next frame, after build(): instance k moved, or the mesh of `shape` (a
    // shape group's member) deformed. refit() then brings the BVHs up to date: the changed
    // groups' built again, the scene's refit (its tree kept, the moved instances' leaves
    // and their ancestors' bounds made to fit), so that one object moving in a large scene
    // costs no rebuild of the rest. Rays find the same hits as after a build.
    void set_instance(int k, const Transform &to_world, const Transform &to_local, MotionKeys motion = {});
    void set_group_mesh(int shape, TriangleMesh mesh);
    void refit();
    bool intersect(const Ray &ray, Intersection &its) const;
    // The closest hit on any shape but `skip`.
    bool intersect_except(const Ray &ray, int skip, Intersection &its) const;
    // Whether the ray hits anything between t_min and t_max: the first hit found ends the
    // traversal.
    bool occluded(const Ray &ray) const;
    // Texture coordinates at a hit, worked out only where a texture or a layer asks for
    // them: a mesh's, interpolated (its barycentrics where it has none, as in Mitsuba); a
    // sphere's longitude / (2 pi) and polar angle / pi; a box face's as on Mitsuba's cube.
    Vec2 uv(const Intersection &its) const;
    // The surface's derivatives dp/du and dp/dv at a hit, for its texture coordinates (a
    // mesh's, or its barycentrics; a sphere's; a box face's). Where uv does not vary (a
    // degenerate triangle, a sphere's pole), any two tangents orthogonal to its.n.
    void uv_tangents(const Intersection &its, Vec3 &dpdu, Vec3 &dpdv) const;
    // Whether no other primitive reaches into the shape's interior (a sphere or box; set by
    // build()): a ray from inside it then hits it first, found with no traversal.
    bool empty_inside(int shape) const { return solid_prim_[size_t(shape)] != kNoPrim; }
    // For such a shape: the ray's hit if its origin is inside (the exit, or none before
    // t_max), else nullopt (trace it through the BVH).
    std::optional<bool> intersect_from_inside(int shape, const Ray &ray, Intersection &its) const;
    // The sphere or box that holds every other primitive (a fog box around the scene), or
    // -1; set by build(). A ray that runs outside it can hit nothing.
    int enclosure() const { return enclosure_ == kNoPrim ? -1 : top_.prims[enclosure_].shape; }
    bool outside_enclosure(const Ray &ray) const { return enclosure_ != kNoPrim && moves_away_from_enclosure(ray); }
    Bounds bounds() const;
    // In the world; for a shape in a shape group, the bounds of all the group's instances.
    Bounds shape_bounds(int shape) const;
    // Whether the box `b`, grown by `eps`, may reach the surface of the shape (a sphere's or
    // box's surface exactly; a mesh's wherever its bounds overlap `b`).
    bool may_touch_surface(int shape, const Bounds &b, Real eps) const;
    // Bytes held: the shapes as given (meshes' vertices, normals and triangles, spheres,
    // boxes, instances) and the acceleration structures (BVH nodes and primitives; the
    // scene's and each group's).
    size_t shape_bytes() const;
    size_t bvh_bytes() const;

private:
    struct Primitive {
        int shape;       // -1 for an instance
        uint32_t index;  // the triangle in its mesh, or the instance
    };
    // Bounds as {lo.x, lo.y, lo.z, hi.x, hi.y, hi.z}: a ray picks each axis's near and far
    // plane by its direction's signs, with no min/max per axis. Floats rounded outward: two
    // nodes to a cache line, and no hit is lost (the tests on primitives stay in double).
    struct Node {
        float bounds[6];
        uint32_t first = 0;  // first primitive (leaf) or second child (inner)
        uint16_t count = 0;  // primitives in a leaf, 0 for an inner node
        uint8_t axis = 0;
    };
    // One BVH: the scene's, or a shape group's (of its meshes alone).
    struct Bvh {
        // A triangle is read through its mesh's index triple: a copy of its vertices in BVH
        // order would save that step at 72 bytes a triangle, three times the mesh's own.
        std::vector<Primitive> prims;
        std::vector<ShapeGeometry::Kind> kind;
        std::vector<Node> nodes;
        Bounds bounds;        // of all its primitives, exact
        Bounds fixed_bounds;  // of those but instances (which a refit moves), exact
    };
    Bvh top_;
    std::vector<Bvh> groups_;  // per shape group
    int group_count_ = 0;
    // Per group: the world bounds of all its instances (its shapes' bounds in the scene).
    std::vector<Bounds> group_bounds_;
    // Per shape: its primitive (into top_.prims) if it is a sphere or box empty inside, else kNoPrim.
    static constexpr uint32_t kNoPrim = ~0u;
    std::vector<uint32_t> solid_prim_;
    uint32_t enclosure_ = kNoPrim;  // into top_.prims
    // solid_prim_ and enclosure_ from top_: find_solids after a build, place_solids (from
    // what find_solids kept) after a refit, where only instances moved.
    std::vector<uint32_t> solids_, instance_prims_;  // into top_.prims: the spheres and boxes, the instances
    uint32_t candidate_ = kNoPrim;                   // the largest sphere or box
    bool fixed_held_ = false;                        // it holds all primitives but the instances
    void find_solids();
    void place_solids();
    // What refit() has to bring up to date: the instances moved and the groups changed.
    std::vector<uint32_t> moved_;
    std::vector<uint8_t> group_changed_;
    // Made by refit()'s first call after a build: per node of top_ its parent, per instance
    // its leaf (kNoPrim: none, its group is empty).
    std::vector<uint32_t> parent_, instance_leaf_;
    void index_for_refit();
    void append_prims(int shape, std::vector<Primitive> &list) const;
    bool holds(uint32_t solid, const Primitive &p) const;
    bool moves_away_from_enclosure(const Ray &ray) const;

    Bounds primitive_bounds(const Primitive &p) const;
    bool overlaps_another(const Bounds &box, uint32_t self) const;
    // A mesh primitive's vertices at `time` in the shutter.
    std::array<Vec3, 3> triangle(const Primitive &p, Real time) const {
        return meshes[size_t(shapes[size_t(p.shape)].index)].corners(p.index, time);
    }
    // The BVH over `prims` (taken).
    Bvh build_bvh(std::vector<Primitive> prims) const;
    // A primitive's bounds during the build, in floats rounded outward: half the memory of
    // doubles, and the nodes (rounded so too) bound the same boxes.
    struct BuildBounds {
        float lo[3], hi[3];
        Bounds widened() const { return {{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}}; }
    };
    // The subtree over prims [begin, end), its nodes appended to `nodes`; returns its root.
    static uint32_t build_recursive(std::vector<Node> &nodes, std::vector<Primitive> &prims,
                                    std::vector<BuildBounds> &bounds, uint32_t begin, uint32_t end, int spare_threads);
    static void build_children(std::vector<Node> &nodes, std::vector<Primitive> &prims,
                               std::vector<BuildBounds> &bounds, uint32_t node, uint32_t begin, uint32_t mid,
                               uint32_t end, int spare_threads);
    struct PreparedRay;  // per-ray set-up of the slab and triangle tests
    // The closest hit so far: its distance, and barycentrics for triangles. The point and
    // normals are worked out once, for the hit that stays (finish).
    struct Hit {
        Real t;
        uint32_t prim = 0;            // into top_.prims, or the instance's group's prims
        uint32_t instance = kNoPrim;  // the instance hit, if any
        Real b0 = 0, b1 = 0, b2 = 0;
    };
    bool intersect_primitive(const Bvh &bvh, uint32_t i, const Ray &ray, const PreparedRay &prepared, Real t_max,
                             Hit &hit) const;
    // Calls leaf(i) for each primitive of `bvh` in a node the ray enters before t_max (which
    // leaf may lower), nearer nodes first, until leaf returns true.
    template <typename Leaf>
    static void walk(const Bvh &bvh, const Ray &ray, const Vec3 &inv_d, const Real &t_max, Leaf &&leaf);
    // The BVH traversal, testing only the primitives of shapes `accept(shape)` takes: the
    // closest hit before closest.t, or with `any` the first one found.
    template <typename Accept>
    bool traverse(const Ray &ray, Hit &closest, bool any, Accept &&accept) const;
    // The intersection in a group's space mapped into the world's (by its.instance).
    void to_world(Intersection &its) const;
    // Instance k's maps at `time`: its own, where it does not move.
    std::pair<Transform, Transform> placement(uint32_t k, Real time) const;
    // The hit point in its shape's own space (a group's, else the world's).
    Vec3 local_point(const Intersection &its) const;
    // A sphere's or box's entry and exit distances (t0 <= t1) along the whole line; inv_d:
    // the direction's inverse if the caller has it (else worked out where needed).
    bool solid_roots(uint32_t prim, const Ray &ray, const Vec3 *inv_d, Real &t0, Real &t1) const;
    void finish(const Hit &hit, const Ray &ray, Intersection &its) const;
};

// Ray-sphere distances in the numerically stable form (both roots; t0 <= t1).
// Returns false when the line misses.
bool sphere_roots(const Vec3 &center, Real radius, const Vec3 &o, const Vec3 &d, Real &t0, Real &t1);

}  // namespace volpath
