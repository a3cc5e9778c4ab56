#include "volpath/geometry.h"

#include <cmath>
#include <future>
#include <limits>
#include <stdexcept>
#include <thread>

namespace volpath {

Real TriangleMesh::area(size_t i) const {
    const auto &t = triangles[i];
    return 0.5 * length(cross(positions[t[1]] - positions[t[0]], positions[t[2]] - positions[t[0]]));
}

// With o' = o - c and a unit d, the roots of t^2 + 2 b t + c' = 0 (b = o'.d), with
// c' = |o'|^2 - r^2. The discriminant is r^2 - |f|^2 with f the line's offset from the
// centre (o' - b d), not b^2 - c', which cancels when the ray starts a metre above a
// 6360 km planet or grazes it. The smaller-magnitude root comes from c'/q with
// q = -b - sign(b) sqrt(disc). (c' itself keeps ~1e-9 relative precision 0.1 m above the
// ground: |o'|^2 ~ 4e13 m^2 is exact to ~4e-3 m^2, and c' ~ 2 r h.)
bool sphere_roots(const Vec3 &center, Real radius, const Vec3 &o, const Vec3 &d, Real &t0, Real &t1) {
    const Vec3 oc = o - center;
    const Real b = dot(oc, d);
    const Real r2 = radius * radius;
    const Real c = dot(oc, oc) - r2;
    const Vec3 f = oc - d * b;
    const Real disc = r2 - dot(f, f);
    if (disc < 0) return false;
    const Real q = -b - std::copysign(std::sqrt(disc), b);
    if (q == 0) {
        t0 = t1 = 0;
        return true;
    }
    t0 = c / q, t1 = q;
    if (t0 > t1) std::swap(t0, t1);
    return true;
}

namespace {
// Corner k (its bits pick the x, y, z side) of a box in world space, and of bounds.
Vec3 box_corner(const Box &box, int k) {
    return box.to_world.point({k & 1 ? 1.0 : -1.0, k & 2 ? 1.0 : -1.0, k & 4 ? 1.0 : -1.0});
}
Vec3 bounds_corner(const Bounds &b, int k) {
    return {k & 1 ? b.hi.x : b.lo.x, k & 2 ? b.hi.y : b.lo.y, k & 4 ? b.hi.z : b.lo.z};
}

// The world bounds of a box: its eight corners'.
Bounds corner_bounds(const Box &box) {
    Bounds b;
    for (int corner = 0; corner < 8; ++corner) b.extend(box_corner(box, corner));
    return b;
}
}  // namespace

int Geometry::add_mesh(TriangleMesh mesh, int group) {
    if (group < -1 || group >= group_count_) throw std::out_of_range("invalid shape group");
    meshes.push_back(std::move(mesh));
    shapes.push_back({ShapeGeometry::Kind::Mesh, int(meshes.size()) - 1, group});
    return int(shapes.size()) - 1;
}

int Geometry::add_instance(int group, const Transform &to_world, const Transform &to_local, MotionKeys motion) {
    if (group < 0 || group >= group_count_) throw std::out_of_range("invalid shape group");
    if (motion.keys.size() == 1) throw std::invalid_argument("a motion needs at least two keys");
    instances.push_back({group, to_world, to_local, std::move(motion)});
    return int(instances.size()) - 1;
}

int Geometry::add_sphere(const Sphere &sphere) {
    spheres.push_back(sphere);
    shapes.push_back({ShapeGeometry::Kind::Sphere, int(spheres.size()) - 1});
    return int(shapes.size()) - 1;
}

int Geometry::add_box(const Box &box) {
    boxes.push_back(box);
    Box &b = boxes.back();
    const Transform &m = b.to_world, &inv = b.to_local;
    b.aligned_bounds = Bounds{};
    if (m.m[0][1] == 0 && m.m[0][2] == 0 && m.m[1][0] == 0 && m.m[1][2] == 0 && m.m[2][0] == 0 && m.m[2][1] == 0)
        b.aligned_bounds = corner_bounds(b);
    // A face's world normal is that row of the inverse map (the inverse transpose's column).
    for (int a = 0; a < 3; ++a) b.normals[a] = normalize(Vec3(inv.m[a][0], inv.m[a][1], inv.m[a][2]));
    shapes.push_back({ShapeGeometry::Kind::Box, int(boxes.size()) - 1});
    return int(shapes.size()) - 1;
}

Bounds Geometry::primitive_bounds(const Primitive &p) const {
    Bounds b;
    if (p.shape < 0) {  // an instance: its group's bounds' corners, mapped (at each key of a motion)
        const Instance &inst = instances[p.index];
        const Bounds local = groups_[size_t(inst.group)].bounds;
        auto placed = [&](const Transform &m) {
            for (int k = 0; k < 8; ++k) b.extend(m.point(bounds_corner(local, k)));
        };
        if (!inst.motion.moves()) placed(inst.to_world);
        for (const Transform &m : inst.motion.keys) placed(m);
        return b;
    }
    const ShapeGeometry &s = shapes[p.shape];
    if (s.kind == ShapeGeometry::Kind::Sphere) {
        const Sphere &sp = spheres[s.index];
        b.extend(sp.center - Vec3(sp.radius));
        b.extend(sp.center + Vec3(sp.radius));
    } else if (s.kind == ShapeGeometry::Kind::Box) {
        b = corner_bounds(boxes[s.index]);
    } else {
        const TriangleMesh &m = meshes[s.index];
        for (uint32_t v : m.triangles[p.index]) {
            b.extend(m.positions[v]);
            for (const auto &key : m.motion) b.extend(key[v]);  // (a deformed triangle's corners move on lines)
        }
    }
    return b;
}

namespace {
// The float nearest x on the side away from the box's inside.
float rounded_down(Real x) {
    const float f = float(x);
    return Real(f) > x ? std::nextafter(f, -std::numeric_limits<float>::infinity()) : f;
}
float rounded_up(Real x) {
    const float f = float(x);
    return Real(f) < x ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}
}  // namespace

Geometry::Bvh Geometry::build_bvh(std::vector<Primitive> prims) const {
    Bvh bvh;
    bvh.prims = std::move(prims);
    if (bvh.prims.empty()) return bvh;
    {
        std::vector<BuildBounds> bounds(bvh.prims.size());
        for (size_t i = 0; i < bvh.prims.size(); ++i) {
            const Bounds b = primitive_bounds(bvh.prims[i]);
            bvh.bounds.extend(b);
            if (bvh.prims[i].shape >= 0) bvh.fixed_bounds.extend(b);
            for (int a = 0; a < 3; ++a) bounds[i].lo[a] = rounded_down(b.lo[a]), bounds[i].hi[a] = rounded_up(b.hi[a]);
        }
        bvh.nodes.reserve(2 * bvh.prims.size());
        const int spare_threads = int(std::thread::hardware_concurrency()) - 1;
        build_recursive(bvh.nodes, bvh.prims, bounds, 0, uint32_t(bvh.prims.size()), spare_threads);
    }
    bvh.nodes.shrink_to_fit();  // (its copy, made once the bounds are freed, stays under the build's peak)
    bvh.kind.assign(bvh.prims.size(), ShapeGeometry::Kind::Instance);
    for (size_t i = 0; i < bvh.prims.size(); ++i)
        if (bvh.prims[i].shape >= 0) bvh.kind[i] = shapes[size_t(bvh.prims[i].shape)].kind;
    return bvh;
}

// Shape s's primitives, appended to `list`: a sphere or box, or a mesh's triangles but
// degenerate ones, which no ray hits (unless the mesh deforms in the shutter).
void Geometry::append_prims(int s, std::vector<Primitive> &list) const {
    if (shapes[size_t(s)].kind != ShapeGeometry::Kind::Mesh) {
        list.push_back({s, 0});
        return;
    }
    const auto &m = meshes[size_t(shapes[size_t(s)].index)];
    for (uint32_t i = 0; i < m.triangles.size(); ++i)
        if (m.area(i) > 0 || !m.motion.empty()) list.push_back({s, i});
}

void Geometry::build() {
    // Each group's BVH first: an instance's bounds are its group's.
    std::vector<std::vector<Primitive>> prims(size_t(group_count_) + 1);  // the scene's last
    for (int s = 0; s < int(shapes.size()); ++s)
        append_prims(s, prims[shapes[s].group < 0 ? size_t(group_count_) : size_t(shapes[s].group)]);
    groups_.resize(size_t(group_count_));
    for (int g = 0; g < group_count_; ++g) groups_[size_t(g)] = build_bvh(std::move(prims[size_t(g)]));
    group_bounds_.assign(size_t(group_count_), Bounds{});
    auto &scene_prims = prims.back();
    for (uint32_t k = 0; k < instances.size(); ++k) {
        if (groups_[size_t(instances[k].group)].nodes.empty()) continue;  // an empty group
        scene_prims.push_back({-1, k});
        group_bounds_[size_t(instances[k].group)].extend(primitive_bounds(scene_prims.back()));
    }
    top_ = build_bvh(std::move(scene_prims));
    moved_.clear(), group_changed_.assign(size_t(group_count_), 0);
    parent_.clear(), instance_leaf_.clear();
    find_solids();
}

void Geometry::find_solids() {
    solids_.clear(), instance_prims_.clear();
    candidate_ = kNoPrim;
    // The enclosure's candidate: the largest sphere or box.
    Real area = 0;
    for (uint32_t i = 0; i < top_.prims.size(); ++i) {
        if (top_.kind[i] == ShapeGeometry::Kind::Instance) instance_prims_.push_back(i);
        if (top_.kind[i] != ShapeGeometry::Kind::Sphere && top_.kind[i] != ShapeGeometry::Kind::Box) continue;
        solids_.push_back(i);
        const Bounds b = primitive_bounds(top_.prims[i]);
        if (candidate_ == kNoPrim || b.surface_area() > area) candidate_ = i, area = b.surface_area();
    }
    // Whether it holds every primitive that no frame moves (all but the instances).
    fixed_held_ = candidate_ != kNoPrim;
    for (uint32_t i = 0; i < top_.prims.size() && fixed_held_; ++i)
        if (i != candidate_ && top_.prims[i].shape >= 0 && !holds(candidate_, top_.prims[i])) fixed_held_ = false;
    place_solids();
}

// Spheres and boxes whose bounds no other primitive's overlap are empty inside. Their
// bounds shrink by 1e-9 of their size first, so that a floor touching a sphere's bottom (to
// rounding) does not count: the sphere's exit is then found first within ray_epsilon. The
// enclosure: the candidate, if it holds all the rest.
void Geometry::place_solids() {
    solid_prim_.assign(shapes.size(), kNoPrim);
    for (uint32_t i : solids_) {
        const Bounds b = primitive_bounds(top_.prims[i]);
        const Vec3 margin(1e-9 * max_component(b.hi - b.lo));
        Bounds inner;
        inner.lo = b.lo + margin, inner.hi = b.hi - margin;
        if (!overlaps_another(inner, i)) solid_prim_[size_t(top_.prims[i].shape)] = i;
    }
    enclosure_ = fixed_held_ ? candidate_ : kNoPrim;
    for (uint32_t i : instance_prims_)
        if (enclosure_ != kNoPrim && !holds(enclosure_, top_.prims[i])) enclosure_ = kNoPrim;
}

void Geometry::set_instance(int k, const Transform &to_world, const Transform &to_local, MotionKeys motion) {
    if (k < 0 || size_t(k) >= instances.size()) throw std::out_of_range("invalid instance");
    if (motion.keys.size() == 1) throw std::invalid_argument("a motion needs at least two keys");
    Instance &inst = instances[size_t(k)];
    inst.to_world = to_world, inst.to_local = to_local;
    inst.motion = std::move(motion);
    moved_.push_back(uint32_t(k));
}

void Geometry::set_group_mesh(int shape, TriangleMesh mesh) {
    if (shape < 0 || size_t(shape) >= shapes.size() || shapes[size_t(shape)].kind != ShapeGeometry::Kind::Mesh ||
        shapes[size_t(shape)].group < 0)
        throw std::invalid_argument("only a shape group's mesh can be replaced");
    meshes[size_t(shapes[size_t(shape)].index)] = std::move(mesh);
    group_changed_.resize(size_t(group_count_), 0);
    group_changed_[size_t(shapes[size_t(shape)].group)] = 1;
}

void Geometry::index_for_refit() {
    parent_.assign(top_.nodes.size(), kNoPrim);
    instance_leaf_.assign(instances.size(), kNoPrim);
    for (uint32_t n = 0; n < top_.nodes.size(); ++n) {
        const Node &node = top_.nodes[n];
        if (node.count == 0) {
            parent_[n + 1] = parent_[node.first] = n;
            continue;
        }
        for (uint32_t j = node.first; j < node.first + node.count; ++j)
            if (top_.prims[j].shape < 0) instance_leaf_[top_.prims[j].index] = n;
    }
}

void Geometry::refit() {
    for (int g = 0; g < int(group_changed_.size()); ++g) {
        if (!group_changed_[size_t(g)]) continue;
        std::vector<Primitive> prims;
        for (int s = 0; s < int(shapes.size()); ++s)
            if (shapes[size_t(s)].group == g) append_prims(s, prims);
        groups_[size_t(g)] = build_bvh(std::move(prims));
        for (uint32_t k = 0; k < instances.size(); ++k)
            if (instances[k].group == g) moved_.push_back(k);
    }
    if (moved_.empty()) return;
    if (parent_.empty()) index_for_refit();
    for (uint32_t k : moved_) {
        // A group emptied or filled changes which instances are primitives: build anew.
        if (instance_leaf_[k] == kNoPrim || groups_[size_t(instances[k].group)].nodes.empty()) return build();
    }
    // An instance has a leaf of its own (build_recursive), whose bounds are its own.
    for (uint32_t k : moved_) {
        const Bounds b = primitive_bounds({-1, k});
        uint32_t n = instance_leaf_[k];
        float *nb = top_.nodes[n].bounds;
        for (int a = 0; a < 3; ++a) nb[a] = rounded_down(b.lo[a]), nb[3 + a] = rounded_up(b.hi[a]);
        for (n = parent_[n]; n != kNoPrim; n = parent_[n]) {
            const float *l = top_.nodes[n + 1].bounds, *r = top_.nodes[top_.nodes[n].first].bounds;
            float *out = top_.nodes[n].bounds;
            for (int a = 0; a < 3; ++a) out[a] = std::min(l[a], r[a]), out[3 + a] = std::max(l[3 + a], r[3 + a]);
        }
    }
    moved_.clear(), group_changed_.assign(size_t(group_count_), 0);
    top_.bounds = top_.fixed_bounds;
    group_bounds_.assign(size_t(group_count_), Bounds{});
    for (uint32_t k = 0; k < instances.size(); ++k) {
        if (instance_leaf_[k] == kNoPrim) continue;
        const Bounds b = primitive_bounds({-1, k});
        top_.bounds.extend(b);
        group_bounds_[size_t(instances[k].group)].extend(b);
    }
    place_solids();
}

// Whether the sphere or box `solid` (into top_.prims) holds all of primitive p: its points
// (a triangle's vertices, a box's corners, a sphere's bounding corners) lie inside, and
// the solid is convex.
bool Geometry::holds(uint32_t solid, const Primitive &p) const {
    const ShapeGeometry &g = shapes[top_.prims[solid].shape];
    auto inside = [&](const Vec3 &q) {
        if (g.kind == ShapeGeometry::Kind::Sphere)
            return length(q - spheres[g.index].center) <= spheres[g.index].radius;
        const Vec3 local = boxes[g.index].to_local.point(q);
        return max_component(abs(local)) <= 1;
    };
    const ShapeGeometry::Kind kind = p.shape < 0 ? ShapeGeometry::Kind::Instance : shapes[p.shape].kind;
    if (kind == ShapeGeometry::Kind::Mesh) {
        const TriangleMesh &m = meshes[shapes[p.shape].index];
        for (uint32_t v : m.triangles[p.index])
            if (!inside(m.positions[v])) return false;
        return true;
    }
    const Bounds b = primitive_bounds(p);
    for (int k = 0; k < 8; ++k)
        if (!inside(kind == ShapeGeometry::Kind::Box ? box_corner(boxes[shapes[p.shape].index], k)
                                                     : bounds_corner(b, k)))
            return false;
    return true;
}

// Sufficient, and cheap (no division): the origin is outside the sphere or past one of the
// box's faces, and the ray moves away from it, as rays leaving the enclosure do.
bool Geometry::moves_away_from_enclosure(const Ray &ray) const {
    const ShapeGeometry &g = shapes[top_.prims[enclosure_].shape];
    if (g.kind == ShapeGeometry::Kind::Sphere) {
        const Sphere &sp = spheres[g.index];
        const Vec3 v = ray.o - sp.center;
        const Real away = dot(v, ray.d), r2 = length_squared(v) - sp.radius * sp.radius;
        return away >= 0 && r2 >= 0 && (away > 0 || r2 > 0);
    }
    const Box &box = boxes[g.index];
    const bool aligned = box.aligned_bounds.valid();
    const Vec3 o = aligned ? ray.o : box.to_local.point(ray.o), d = aligned ? ray.d : box.to_local.vector(ray.d);
    const Vec3 lo = aligned ? box.aligned_bounds.lo : Vec3(-1.0), hi = aligned ? box.aligned_bounds.hi : Vec3(1.0);
    // (Not a ray in a face's plane, which could meet what lies on the face.)
    for (int a = 0; a < 3; ++a)
        if ((o[a] >= hi[a] && d[a] >= 0 && (o[a] > hi[a] || d[a] > 0)) ||
            (o[a] <= lo[a] && d[a] <= 0 && (o[a] < lo[a] || d[a] < 0)))
            return true;
    return false;
}

// Whether any primitive but `self` has bounds overlapping `box` (open intervals): the BVH's
// nodes narrow the search to the primitives near it.
bool Geometry::overlaps_another(const Bounds &box, uint32_t self) const {
    auto overlap = [&](const Vec3 &lo, const Vec3 &hi) {
        return lo.x < box.hi.x && hi.x > box.lo.x && lo.y < box.hi.y && hi.y > box.lo.y && lo.z < box.hi.z &&
               hi.z > box.lo.z;
    };
    std::vector<uint32_t> stack{0};
    while (!stack.empty()) {
        const Node &node = top_.nodes[stack.back()];
        const uint32_t current = stack.back();
        stack.pop_back();
        const float *b = node.bounds;
        if (!overlap({b[0], b[1], b[2]}, {b[3], b[4], b[5]})) continue;
        if (node.count == 0) {
            stack.push_back(current + 1), stack.push_back(node.first);
            continue;
        }
        for (uint32_t j = node.first; j < node.first + node.count; ++j) {
            if (j == self) continue;
            const Bounds b = primitive_bounds(top_.prims[j]);
            if (overlap(b.lo, b.hi)) return true;
        }
    }
    return false;
}

Bounds Geometry::shape_bounds(int shape) const {
    const ShapeGeometry &g = shapes[size_t(shape)];
    if (g.group >= 0) return group_bounds_[size_t(g.group)];  // wherever its instances put it
    if (g.kind == ShapeGeometry::Kind::Mesh) {
        Bounds b;
        for (const Vec3 &p : meshes[size_t(g.index)].positions) b.extend(p);
        return b;
    }
    return primitive_bounds({shape, 0});
}

bool Geometry::may_touch_surface(int shape, const Bounds &b, Real eps) const {
    const ShapeGeometry &g = shapes[size_t(shape)];
    const Vec3 lo = b.lo - Vec3(eps), hi = b.hi + Vec3(eps);
    if (g.kind == ShapeGeometry::Kind::Sphere) {
        const Sphere &s = spheres[size_t(g.index)];
        const Vec3 nearest = min(max(s.center, lo), hi);
        const Vec3 farthest(std::abs(lo.x - s.center.x) > std::abs(hi.x - s.center.x) ? lo.x : hi.x,
                            std::abs(lo.y - s.center.y) > std::abs(hi.y - s.center.y) ? lo.y : hi.y,
                            std::abs(lo.z - s.center.z) > std::abs(hi.z - s.center.z) ? lo.z : hi.z);
        return length(nearest - s.center) <= s.radius && length(farthest - s.center) >= s.radius;
    }
    if (g.kind == ShapeGeometry::Kind::Box) {
        // In the box's own space, where it is [-1, 1]^3: the corners' bounds reach its faces
        // if they overlap it without lying strictly inside.
        const Box &box = boxes[size_t(g.index)];
        Bounds local;
        for (int c = 0; c < 8; ++c)
            local.extend(box.to_local.point({c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z}));
        const bool overlaps = local.lo.x <= 1 && local.lo.y <= 1 && local.lo.z <= 1 && local.hi.x >= -1 &&
                              local.hi.y >= -1 && local.hi.z >= -1;
        const bool inside =
            local.lo.x > -1 && local.lo.y > -1 && local.lo.z > -1 && local.hi.x < 1 && local.hi.y < 1 && local.hi.z < 1;
        return overlaps && !inside;
    }
    const Bounds m = shape_bounds(shape);
    return lo.x <= m.hi.x && lo.y <= m.hi.y && lo.z <= m.hi.z && hi.x >= m.lo.x && hi.y >= m.lo.y && hi.z >= m.lo.z;
}

Bounds Geometry::bounds() const { return top_.bounds; }

// Binned surface-area heuristic (Wald 2007): 16 bins along the widest centroid axis.
uint32_t Geometry::build_recursive(std::vector<Node> &nodes, std::vector<Primitive> &prims,
                                   std::vector<BuildBounds> &bounds, uint32_t begin, uint32_t end, int spare_threads) {
    const uint32_t node_index = uint32_t(nodes.size());
    nodes.emplace_back();
    Bounds node_bounds, centroid_bounds;
    for (uint32_t i = begin; i < end; ++i) {
        const Bounds b = bounds[i].widened();
        node_bounds.extend(b);
        centroid_bounds.extend(b.centroid());
    }
    float *nb = nodes[node_index].bounds;
    for (int a = 0; a < 3; ++a) nb[a] = rounded_down(node_bounds.lo[a]), nb[3 + a] = rounded_up(node_bounds.hi[a]);
    const uint32_t count = end - begin;
    auto make_leaf = [&] {
        nodes[node_index].first = begin;
        nodes[node_index].count = uint16_t(count);
        return node_index;
    };
    // An instance costs a traversal of its own: it takes a leaf alone (checked only where a
    // leaf is possible, at most four primitives).
    auto holds_instance = [&] {
        for (uint32_t i = begin; i < end; ++i)
            if (prims[i].shape < 0) return true;
        return false;
    };
    if (count == 1 || (count <= 2 && !holds_instance())) return make_leaf();

    const Vec3 extent = centroid_bounds.hi - centroid_bounds.lo;
    int axis = 0;
    if (extent.y > extent[axis]) axis = 1;
    if (extent.z > extent[axis]) axis = 2;
    if (!(extent[axis] > 0)) {
        if (count <= 8) return make_leaf();
        // All centroids coincide: split in the middle of the list.
        const uint32_t mid = begin + count / 2;
        nodes[node_index].axis = uint8_t(axis);
        build_children(nodes, prims, bounds, node_index, begin, mid, end, spare_threads);
        return node_index;
    }

    constexpr int kBins = 16;
    struct Bin {
        Bounds b;
        uint32_t n = 0;
    } bins[kBins];
    const Real lo = centroid_bounds.lo[axis], scale = kBins / extent[axis];
    auto bin_of = [&](uint32_t i) {
        return std::min(kBins - 1, int((bounds[i].widened().centroid()[axis] - lo) * scale));
    };
    for (uint32_t i = begin; i < end; ++i) {
        Bin &bin = bins[bin_of(i)];
        bin.b.extend(bounds[i].widened());
        ++bin.n;
    }
    Real cost[kBins - 1];
    Bounds left;
    uint32_t n_left = 0;
    for (int i = 0; i < kBins - 1; ++i) {
        left.extend(bins[i].b);
        n_left += bins[i].n;
        cost[i] = n_left ? n_left * left.surface_area() : 0.0;
    }
    Bounds right;
    uint32_t n_right = 0;
    for (int i = kBins - 1; i > 0; --i) {
        right.extend(bins[i].b);
        n_right += bins[i].n;
        if (n_right) cost[i - 1] += n_right * right.surface_area();
    }
    int best = 0;
    for (int i = 1; i < kBins - 1; ++i)
        if (cost[i] < cost[best]) best = i;
    // Relative cost of a leaf: intersecting `count` primitives versus traversing.
    const Real leaf_cost = count * node_bounds.surface_area();
    const Real split_cost = 0.125 * node_bounds.surface_area() + cost[best];
    if (count <= 4 && leaf_cost <= split_cost && !holds_instance()) return make_leaf();

    // Partition in place.
    uint32_t mid = begin;
    for (uint32_t i = begin; i < end; ++i) {
        if (bin_of(i) <= best) {
            std::swap(prims[i], prims[mid]);
            std::swap(bounds[i], bounds[mid]);
            ++mid;
        }
    }
    if (mid == begin || mid == end) mid = begin + count / 2;
    nodes[node_index].axis = uint8_t(axis);
    build_children(nodes, prims, bounds, node_index, begin, mid, end, spare_threads);
    return node_index;
}

// The right subtree is built on a thread of its own (while threads are spare and the range
// is large) into nodes of its own, appended after the left subtree's: where a serial build
// puts them, so the tree is the same whatever the thread count.
void Geometry::build_children(std::vector<Node> &nodes, std::vector<Primitive> &prims, std::vector<BuildBounds> &bounds,
                              uint32_t node, uint32_t begin, uint32_t mid, uint32_t end, int spare_threads) {
    constexpr uint32_t kParallelBuild = 1u << 15;
    if (spare_threads <= 0 || end - begin < kParallelBuild) {
        build_recursive(nodes, prims, bounds, begin, mid, 0);
        nodes[node].first = build_recursive(nodes, prims, bounds, mid, end, 0);
        return;
    }
    const int right_threads = (spare_threads - 1) / 2;
    std::vector<Node> right;
    right.reserve(2 * size_t(end - mid));
    auto right_built =
        std::async(std::launch::async, [&] { build_recursive(right, prims, bounds, mid, end, right_threads); });
    build_recursive(nodes, prims, bounds, begin, mid, spare_threads - 1 - right_threads);
    right_built.get();
    const uint32_t offset = uint32_t(nodes.size());
    for (Node &n : right)
        if (n.count == 0) n.first += offset;  // an inner node's second child
    nodes[node].first = offset;
    nodes.insert(nodes.end(), right.begin(), right.end());
}

namespace {
// A zero component would give 0 * inf = NaN in a slab test; a tiny one does not.
Vec3 safe_inverse(const Vec3 &d) {
    auto inv = [](Real x) { return 1.0 / (x == 0 ? 1e-300 : x); };
    return {inv(d.x), inv(d.y), inv(d.z)};
}

// The entry and exit distances of a ray (o, 1 / d) through the box [lo, hi].
void slab(const Vec3 &lo, const Vec3 &hi, const Vec3 &o, const Vec3 &inv_d, Real &t_near, Real &t_far) {
    t_near = -kInfinity, t_far = kInfinity;
    for (int a = 0; a < 3; ++a) {
        const Real t0 = (lo[a] - o[a]) * inv_d[a], t1 = (hi[a] - o[a]) * inv_d[a];
        t_near = std::max(t_near, std::min(t0, t1));
        t_far = std::min(t_far, std::max(t0, t1));
    }
}
}  // namespace

// Per-ray set-up: the direction's inverse for slab tests, and the shear of the watertight
// ray-triangle test (Woop, Benthin & Wald 2013): vertices are moved into a frame where
// the ray runs along +z from the origin, and the 2D edge functions U, V, W decide the
// hit. Edges shared by two triangles are evaluated identically from both sides, so no
// ray slips between them.
struct Geometry::PreparedRay {
    Vec3 inv_d;
    int kx, ky, kz;
    Real sx, sy, sz;
    explicit PreparedRay(const Vec3 &d) : inv_d(safe_inverse(d)) {
        const Vec3 a = abs(d);
        kz = a.x > a.y ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
        kx = (kz + 1) % 3, ky = (kx + 1) % 3;
        if (d[kz] < 0) std::swap(kx, ky);                  // keep the winding
        sz = inv_d[kz], sx = d[kx] * sz, sy = d[ky] * sz;  // d[kz], the largest, is not 0
    }
};

bool Geometry::solid_roots(uint32_t i, const Ray &ray, const Vec3 *inv_d, Real &t0, Real &t1) const {
    const ShapeGeometry &g = shapes[top_.prims[i].shape];
    if (top_.kind[i] == ShapeGeometry::Kind::Sphere) {
        const Sphere &sp = spheres[g.index];
        return sphere_roots(sp.center, sp.radius, ray.o, ray.d, t0, t1);
    }
    // Slab test in world space if the box is axis-aligned there, else in its own space,
    // where t is the world ray's (the map is affine).
    const Box &box = boxes[g.index];
    if (box.aligned_bounds.valid())
        slab(box.aligned_bounds.lo, box.aligned_bounds.hi, ray.o, inv_d ? *inv_d : safe_inverse(ray.d), t0, t1);
    else
        slab(Vec3(-1.0), Vec3(1.0), box.to_local.point(ray.o), safe_inverse(box.to_local.vector(ray.d)), t0, t1);
    return t0 <= t1;
}

bool Geometry::intersect_primitive(const Bvh &bvh, uint32_t i, const Ray &ray, const PreparedRay &sr, Real t_max,
                                   Hit &hit) const {
    if (bvh.kind[i] != ShapeGeometry::Kind::Mesh) {  // a sphere or box: only in the scene's BVH
        Real t0, t1;
        if (!solid_roots(i, ray, &sr.inv_d, t0, t1)) return false;
        const Real t = t0 > ray.t_min ? t0 : t1;
        if (!(t > ray.t_min && t < t_max)) return false;
        hit.t = t;
    } else {
        const std::array<Vec3, 3> tri = triangle(bvh.prims[i], ray.time);
        const Vec3 a = tri[0] - ray.o, b = tri[1] - ray.o, c = tri[2] - ray.o;
        const Real ax = a[sr.kx] - sr.sx * a[sr.kz], ay = a[sr.ky] - sr.sy * a[sr.kz];
        const Real bx = b[sr.kx] - sr.sx * b[sr.kz], by = b[sr.ky] - sr.sy * b[sr.kz];
        const Real cx = c[sr.kx] - sr.sx * c[sr.kz], cy = c[sr.ky] - sr.sy * c[sr.kz];
        const Real u = cx * by - cy * bx, v = ax * cy - ay * cx, w = bx * ay - by * ax;
        if ((u < 0 || v < 0 || w < 0) && (u > 0 || v > 0 || w > 0)) return false;
        const Real det = u + v + w;
        if (det == 0) return false;
        const Real t = (u * sr.sz * a[sr.kz] + v * sr.sz * b[sr.kz] + w * sr.sz * c[sr.kz]) / det;
        if (!(t > ray.t_min && t < t_max)) return false;
        hit.t = t;
        hit.b0 = u / det, hit.b1 = v / det, hit.b2 = w / det;
    }
    hit.prim = i;
    hit.instance = kNoPrim;
    return true;
}

namespace {

// Each face of a box maps [-1, 1]^2 onto [0, 1]^2, turned as in Mitsuba's cube mesh: per
// axis and side (+, -), u's and v's axis and sign.
constexpr int kFaceUV[3][2][4] = {
    {{1, 1, 2, -1}, {1, 1, 2, 1}}, {{0, -1, 2, -1}, {2, 1, 0, 1}}, {{1, 1, 0, 1}, {1, -1, 0, 1}}};

// The face of a box a point in its space lies on: the axis on which it lies farthest out.
int box_face_axis(const Vec3 &q) {
    const int a = std::abs(q.x) > std::abs(q.y) ? 0 : 1;
    return std::abs(q.z) > std::abs(q[a]) ? 2 : a;
}

}  // namespace

std::pair<Transform, Transform> Geometry::placement(uint32_t k, Real time) const {
    const Instance &inst = instances[k];
    if (!inst.motion.moves()) return {inst.to_world, inst.to_local};
    const Transform m = inst.motion.at(time);
    return {m, m.inverse()};
}

Vec3 Geometry::local_point(const Intersection &its) const {
    return its.instance < 0 ? its.p : placement(uint32_t(its.instance), its.time).second.point(its.p);
}

Vec2 Geometry::uv(const Intersection &its) const {
    const ShapeGeometry &s = shapes[size_t(its.shape)];
    const Vec3 p = local_point(its);
    if (s.kind == ShapeGeometry::Kind::Box) {
        const Vec3 q = boxes[size_t(s.index)].to_local.point(p);
        const int a = box_face_axis(q);
        const int *f = kFaceUV[a][q[a] < 0];
        return {(1 + f[1] * q[f[0]]) * 0.5, (1 + f[3] * q[f[2]]) * 0.5};
    }
    if (s.kind == ShapeGeometry::Kind::Sphere) {
        const Vec3 n = normalize(p - spheres[size_t(s.index)].center);
        const Real phi = std::atan2(n.y, n.x);
        return {(phi < 0 ? phi + 2 * kPi : phi) / (2 * kPi), std::acos(std::clamp(n.z, Real(-1), Real(1))) / kPi};
    }
    // The hit's barycentrics, worked out again from its point (an Intersection that carried
    // them would be larger for every ray, textured or not).
    const TriangleMesh &m = meshes[size_t(s.index)];
    const auto &tri = m.triangles[its.prim];
    const std::array<Vec3, 3> c = m.corners(its.prim, its.time);
    const Vec3 &p0 = c[0], e1 = c[1] - p0, e2 = c[2] - p0;
    const Vec3 d = p - p0;
    const Real d11 = dot(e1, e1), d12 = dot(e1, e2), d22 = dot(e2, e2), det = d11 * d22 - d12 * d12;
    if (!(det > 0)) return m.uvs.empty() ? Vec2{} : m.uvs[tri[0]];
    const Real b1 = (d22 * dot(d, e1) - d12 * dot(d, e2)) / det, b2 = (d11 * dot(d, e2) - d12 * dot(d, e1)) / det;
    return m.uv(its.prim, b1, b2);
}

void Geometry::uv_tangents(const Intersection &its, Vec3 &dpdu, Vec3 &dpdv) const {
    const ShapeGeometry &s = shapes[size_t(its.shape)];
    dpdu = dpdv = Vec3(0.0);
    if (s.kind == ShapeGeometry::Kind::Box) {
        const Box &box = boxes[size_t(s.index)];
        const Vec3 q = box.to_local.point(its.p);
        const int a = box_face_axis(q);
        const int *f = kFaceUV[a][q[a] < 0];
        Vec3 eu(0.0), ev(0.0);
        eu[f[0]] = 2.0 * f[1], ev[f[2]] = 2.0 * f[3];  // u = (1 + sign q[axis]) / 2
        dpdu = box.to_world.vector(eu), dpdv = box.to_world.vector(ev);
    } else if (s.kind == ShapeGeometry::Kind::Sphere) {
        const Sphere &sp = spheres[size_t(s.index)];
        const Vec3 d = its.p - sp.center;  // radius (sin theta cos phi, sin theta sin phi, cos theta)
        const Real rho = std::sqrt(d.x * d.x + d.y * d.y);
        dpdu = Vec3(-d.y, d.x, 0.0) * (2 * kPi);
        if (rho > 0) dpdv = Vec3(d.z * d.x / rho, d.z * d.y / rho, -rho) * kPi;
    } else {
        const TriangleMesh &m = meshes[size_t(s.index)];
        const auto &tri = m.triangles[its.prim];
        const auto [p0, p1, p2] = m.corners(its.prim, its.time);
        if (m.uvs.empty()) {  // uv = (b1, b2)
            dpdu = p1 - p0, dpdv = p2 - p0;
        } else {
            const Vec2 &t0 = m.uvs[tri[0]], &t1 = m.uvs[tri[1]], &t2 = m.uvs[tri[2]];
            const Real du02 = t0.x - t2.x, dv02 = t0.y - t2.y, du12 = t1.x - t2.x, dv12 = t1.y - t2.y;
            const Real det = du02 * dv12 - dv02 * du12;
            if (std::abs(det) > 1e-20) {
                const Vec3 dp02 = p0 - p2, dp12 = p1 - p2;
                dpdu = (dp02 * dv12 - dp12 * dv02) / det;
                dpdv = (dp12 * du02 - dp02 * du12) / det;
            }
        }
        if (its.instance >= 0) {
            const Transform m = placement(uint32_t(its.instance), its.time).first;
            dpdu = m.vector(dpdu), dpdv = m.vector(dpdv);
        }
    }
    if (!(length_squared(cross(dpdu, dpdv)) > 0)) {
        const Frame frame(its.n);
        dpdu = frame.s, dpdv = frame.t;
    }
}

void Geometry::finish(const Hit &hit, const Ray &ray, Intersection &its) const {
    const bool instanced = hit.instance != kNoPrim;
    const Bvh &bvh = instanced ? groups_[size_t(instances[hit.instance].group)] : top_;
    const Primitive &prim = bvh.prims[hit.prim];
    const ShapeGeometry &s = shapes[prim.shape];
    its.t = hit.t;
    its.time = ray.time;
    if (s.kind == ShapeGeometry::Kind::Box) {
        // The face: the axis on which the hit point lies farthest out in the box's space.
        const Box &box = boxes[s.index];
        its.p = ray.at(hit.t);
        const Vec3 q = box.to_local.point(its.p);
        const int a = box_face_axis(q);
        const Vec3 &n = box.normals[a];
        its.n = its.ns = (q[a] < 0) != box.flip_normals ? -n : n;
    } else if (s.kind == ShapeGeometry::Kind::Sphere) {
        const Sphere &sp = spheres[s.index];
        const Vec3 n = normalize(ray.at(hit.t) - sp.center);
        its.p = sp.center + n * sp.radius;  // re-projected onto the surface
        its.n = its.ns = sp.flip_normals ? -n : n;
    } else {
        const std::array<Vec3, 3> v = triangle(prim, ray.time);
        its.p = v[0] * hit.b0 + v[1] * hit.b1 + v[2] * hit.b2;
        its.n = normalize(cross(v[1] - v[0], v[2] - v[0]));
        its.ns = its.n;
        const TriangleMesh &m = meshes[s.index];
        if (!m.normals.empty()) {
            const auto &tri = m.triangles[prim.index];
            const Vec3 ns = m.normals[tri[0]] * hit.b0 + m.normals[tri[1]] * hit.b1 + m.normals[tri[2]] * hit.b2;
            const Real len = length(ns);
            if (len > 0) its.ns = dot(ns, its.n) >= 0 ? ns / len : -ns / len;
        }
    }
    its.shape = prim.shape;
    its.prim = prim.index;
    its.instance = instanced ? int(hit.instance) : -1;
    if (instanced) to_world(its);
}

void Geometry::to_world(Intersection &its) const {
    const auto [to_world, to_local] = placement(uint32_t(its.instance), its.time);
    // Normals map by the inverse transpose: rows of to_local.
    auto normal = [&](const Vec3 &n) {
        const auto &m = to_local.m;
        return normalize(Vec3(m[0][0] * n.x + m[1][0] * n.y + m[2][0] * n.z,
                              m[0][1] * n.x + m[1][1] * n.y + m[2][1] * n.z,
                              m[0][2] * n.x + m[1][2] * n.y + m[2][2] * n.z));
    };
    its.p = to_world.point(its.p);
    const Vec3 n = normal(its.n), ns = normal(its.ns);
    its.n = to_world.determinant3() < 0 ? -n : n;
    its.ns = dot(ns, its.n) >= 0 ? ns : -ns;
}

bool Geometry::intersect(const Ray &ray, Intersection &its) const {
    Hit closest{ray.t_max};
    if (!traverse(ray, closest, false, [](int) { return true; })) return false;
    finish(closest, ray, its);
    return true;
}

bool Geometry::intersect_except(const Ray &ray, int skip, Intersection &its) const {
    Hit closest{ray.t_max};
    if (!traverse(ray, closest, false, [skip](int shape) { return shape != skip; })) return false;
    finish(closest, ray, its);
    return true;
}

bool Geometry::occluded(const Ray &ray) const {
    Hit any{ray.t_max};
    return traverse(ray, any, true, [](int) { return true; });
}

template <typename Leaf>
void Geometry::walk(const Bvh &bvh, const Ray &ray, const Vec3 &inv_d, const Real &t_max, Leaf &&leaf) {
    const bool negative[3] = {inv_d.x < 0, inv_d.y < 0, inv_d.z < 0};
    // Each axis's near and far plane in Node::bounds.
    const int nx = negative[0] ? 3 : 0, ny = negative[1] ? 4 : 1, nz = negative[2] ? 5 : 2;
    const int fx = 3 - nx, fy = 5 - ny, fz = 7 - nz;
    uint32_t stack[64];
    int top = 0;
    uint32_t current = 0;
    for (;;) {
        const Node &node = bvh.nodes[current];
        const float *b = node.bounds;
        const Real t_near = std::max(std::max((b[nx] - ray.o.x) * inv_d.x, (b[ny] - ray.o.y) * inv_d.y),
                                     std::max((b[nz] - ray.o.z) * inv_d.z, ray.t_min));
        // The far bound is widened by a few ulps so that rays grazing a flat box still enter it.
        const Real t_far = std::min(std::min((b[fx] - ray.o.x) * inv_d.x, (b[fy] - ray.o.y) * inv_d.y),
                                    std::min((b[fz] - ray.o.z) * inv_d.z, t_max)) *
                           (1 + 4e-16);
        if (t_near <= t_far) {
            if (node.count > 0) {
                for (uint32_t i = 0; i < node.count; ++i)
                    if (leaf(node.first + i)) return;
            } else {
                // Near child first.
                if (negative[node.axis]) {
                    stack[top++] = current + 1;
                    current = node.first;
                } else {
                    stack[top++] = node.first;
                    current = current + 1;
                }
                continue;
            }
        }
        if (top == 0) break;
        current = stack[--top];
    }
}

template <typename Accept>
bool Geometry::traverse(const Ray &ray, Hit &closest, bool any, Accept &&accept) const {
    if (top_.nodes.empty()) return false;
    const PreparedRay prepared(ray.d);
    bool hit = false;
    walk(top_, ray, prepared.inv_d, closest.t, [&](uint32_t i) {
        const Primitive &prim = top_.prims[i];
        if (top_.kind[i] != ShapeGeometry::Kind::Instance) {
            if (accept(prim.shape)) hit |= intersect_primitive(top_, i, ray, prepared, closest.t, closest);
            return any && hit;
        }
        // The ray in the group's space: the same t, up to a direction no longer unit.
        const Instance &inst = instances[prim.index];
        const Bvh &group = groups_[size_t(inst.group)];
        auto into = [&](const Transform &to_local) {
            return Ray{to_local.point(ray.o), to_local.vector(ray.d), ray.t_min, closest.t, ray.time};
        };
        // (A still instance's ray costs no map built for it.)
        const Ray local = inst.motion.moves() ? into(inst.motion.at(ray.time).inverse()) : into(inst.to_local);
        const PreparedRay local_prepared(local.d);
        walk(group, local, local_prepared.inv_d, closest.t, [&](uint32_t j) {
            if (accept(group.prims[j].shape) &&
                intersect_primitive(group, j, local, local_prepared, closest.t, closest)) {
                closest.instance = prim.index;
                hit = true;
            }
            return any && hit;
        });
        return any && hit;
    });
    return hit;
}

std::optional<bool> Geometry::intersect_from_inside(int shape, const Ray &ray, Intersection &its) const {
    const uint32_t i = solid_prim_[size_t(shape)];
    Real t0, t1;
    if (!solid_roots(i, ray, nullptr, t0, t1) || t0 > ray.t_min || !(t1 > ray.t_min)) return std::nullopt;
    if (!(t1 < ray.t_max)) return false;
    finish(Hit{t1, i}, ray, its);
    return true;
}

template <typename T>
size_t bytes(const std::vector<T> &v) {
    return v.capacity() * sizeof(T);
}

size_t Geometry::shape_bytes() const {
    size_t n = bytes(meshes) + bytes(spheres) + bytes(boxes) + bytes(shapes) + bytes(instances);
    for (const TriangleMesh &m : meshes) n += bytes(m.positions) + bytes(m.normals) + bytes(m.uvs) + bytes(m.triangles);
    return n;
}

size_t Geometry::bvh_bytes() const {
    auto bvh = [](const Bvh &b) { return bytes(b.prims) + bytes(b.kind) + bytes(b.nodes); };
    size_t n = bvh(top_) + bytes(groups_) + bytes(group_bounds_) + bytes(solid_prim_);
    for (const Bvh &g : groups_) n += bvh(g);
    return n;
}

}  // namespace volpath
