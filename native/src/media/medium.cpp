#include "volpath/medium.h"

namespace volpath {

Spectrum VoxelGrid::lookup(const Vec3 &p) const {
    // Continuous voxel coordinates with centres at integers.
    Real c[3] = {p.x * res[0] - 0.5, p.y * res[1] - 0.5, p.z * res[2] - 0.5};
    int i0[3], i1[3];
    Real w[3];
    for (int a = 0; a < 3; ++a) {
        c[a] = std::clamp(c[a], 0.0, Real(res[a] - 1));
        i0[a] = std::min(int(c[a]), res[a] - 1);
        i1[a] = std::min(i0[a] + 1, res[a] - 1);
        w[a] = c[a] - i0[a];
    }
    Spectrum out(0.0);
    for (int corner = 0; corner < 8; ++corner) {
        const int x = (corner & 1) ? i1[0] : i0[0];
        const int y = (corner & 2) ? i1[1] : i0[1];
        const int z = (corner & 4) ? i1[2] : i0[2];
        const Real weight = ((corner & 1) ? w[0] : 1 - w[0]) * ((corner & 2) ? w[1] : 1 - w[1]) *
                            ((corner & 4) ? w[2] : 1 - w[2]);
        if (weight == 0) continue;
        const size_t base = ((size_t(z) * res[1] + y) * res[0] + x) * channels;
        if (channels == 1) {
            out += Spectrum(data[base] * weight);
        } else {
            out += Spectrum(data[base], data[base + 1], data[base + 2]) * weight;
        }
    }
    return out;
}

Spectrum VoxelGrid::max_value() const {
    Spectrum m(0.0);
    for (size_t i = 0; i < data.size(); i += channels) {
        if (channels == 1) {
            m = max(m, Spectrum(data[i]));
        } else {
            m = max(m, Spectrum(data[i], data[i + 1], data[i + 2]));
        }
    }
    return m;
}

namespace {
struct Properties {
    const Vec3 &p;
    MediumProperties operator()(const HomogeneousMedium &m) const { return {m.sigma_a, m.sigma_s}; }
    MediumProperties operator()(const GridMedium &m) const {
        const Vec3 q = m.world_to_grid.point(p);
        const Spectrum sigma_t = m.density.lookup(q) * m.scale;
        const Spectrum albedo = m.albedo_grid.empty() ? m.albedo : m.albedo_grid.lookup(q);
        const Spectrum sigma_s = sigma_t * albedo;
        return {clamp_zero(sigma_t - sigma_s), sigma_s};
    }
};

struct Segment {
    const Ray &ray;
    Real t_max;
    MajorantSegment &seg;
    bool operator()(const HomogeneousMedium &m) const {
        seg = {ray.t_min, t_max, m.sigma_a + m.sigma_s};
        return t_max > ray.t_min;
    }
    // Clip the ray to the unit cube in grid space (slab test on the affine image of the
    // ray, whose parameter t is the world-space distance).
    bool operator()(const GridMedium &m) const {
        const Vec3 o = m.world_to_grid.point(ray.o), d = m.world_to_grid.vector(ray.d);
        Real t0 = ray.t_min, t1 = t_max;
        for (int a = 0; a < 3; ++a) {
            if (d[a] == 0) {
                if (o[a] < 0 || o[a] > 1) return false;
                continue;
            }
            Real ta = (0 - o[a]) / d[a], tb = (1 - o[a]) / d[a];
            if (ta > tb) std::swap(ta, tb);
            t0 = std::max(t0, ta), t1 = std::min(t1, tb);
        }
        seg = {t0, t1, m.sigma_maj};
        return t0 < t1;
    }
};
}  // namespace

MediumProperties medium_properties(const Medium &m, const Vec3 &p) {
    return std::visit(Properties{p}, m);
}

const PhaseFunction &medium_phase(const Medium &m) {
    return std::visit([](const auto &x) -> const PhaseFunction & { return x.phase; }, m);
}

void prepare_medium(Medium &m) {
    if (auto *grid = std::get_if<GridMedium>(&m)) {
        // Trilinear interpolation never exceeds the largest voxel, so the grid maximum
        // bounds sigma_t everywhere.
        grid->sigma_maj = grid->density.max_value() * grid->scale;
    }
}

bool majorant_segment(const Medium &m, const Ray &ray, Real t_max, MajorantSegment &seg) {
    return std::visit(Segment{ray, t_max, seg}, m);
}

}  // namespace volpath
