// Grid media: the sparse voxel grid and its majorant grid.
#include <algorithm>

#include "media.h"

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
    // Where each of the eight voxels (corner k = x + 2y + 4z) keeps its channels; voxels of
    // empty bricks read zeros. Usually (343 times in 512) all eight share one brick: one
    // indirection for all.
    static const float zeros[3] = {0, 0, 0};
    constexpr int L = kLog2Brick, M = kBrick - 1;
    auto brick_of = [&](int x, int y, int z) {
        return brick_index[(size_t(z >> L) * bricks[1] + (y >> L)) * bricks[0] + (x >> L)];
    };
    auto in_brick = [&](int32_t b, int x, int y, int z) {
        return &data[(size_t(b) * kBrickVoxels + (((z & M) * kBrick + (y & M)) * kBrick + (x & M))) * channels];
    };
    const float *v[8];
    if ((i0[0] >> L) == (i1[0] >> L) && (i0[1] >> L) == (i1[1] >> L) && (i0[2] >> L) == (i1[2] >> L)) {
        const int32_t b = brick_of(i0[0], i0[1], i0[2]);
        if (b < 0) return Spectrum(0.0);
        const float *base = in_brick(b, i0[0], i0[1], i0[2]);
        const int dx = (i1[0] - i0[0]) * channels, dy = (i1[1] - i0[1]) * kBrick * channels,
                  dz = (i1[2] - i0[2]) * kBrick * kBrick * channels;
        for (int k = 0; k < 8; ++k) v[k] = base + (k & 1 ? dx : 0) + (k & 2 ? dy : 0) + (k & 4 ? dz : 0);
    } else {
        for (int k = 0; k < 8; ++k) {
            const int x = k & 1 ? i1[0] : i0[0], y = k & 2 ? i1[1] : i0[1], z = k & 4 ? i1[2] : i0[2];
            const int32_t b = brick_of(x, y, z);
            v[k] = b < 0 ? zeros : in_brick(b, x, y, z);
        }
    }
    // In double from the start: a difference of two floats rounded to float would let the
    // result exceed both voxels (by ~1e-6 relative), and the majorants with it.
    auto lerp = [](Real a, Real b, Real t) { return a + (b - a) * t; };
    Spectrum out(0.0);
    for (int c = 0; c < channels; ++c) {
        const Real x00 = lerp(v[0][c], v[1][c], w[0]), x10 = lerp(v[2][c], v[3][c], w[0]);
        const Real x01 = lerp(v[4][c], v[5][c], w[0]), x11 = lerp(v[6][c], v[7][c], w[0]);
        out[c] = lerp(lerp(x00, x10, w[1]), lerp(x01, x11, w[1]), w[2]);
    }
    return channels == 1 ? Spectrum(out[0]) : out;
}

VoxelGrid sparse_grid(const float *dense, const int res[3], int channels) {
    constexpr int B = VoxelGrid::kBrick;
    VoxelGrid g;
    g.channels = channels;
    for (int a = 0; a < 3; ++a) g.res[a] = res[a], g.bricks[a] = (res[a] + B - 1) / B;
    g.brick_index.assign(size_t(g.bricks[0]) * g.bricks[1] * g.bricks[2], -1);
    std::vector<float> brick(size_t(VoxelGrid::kBrickVoxels) * channels);
    for (int bz = 0; bz < g.bricks[2]; ++bz)
        for (int by = 0; by < g.bricks[1]; ++by)
            for (int bx = 0; bx < g.bricks[0]; ++bx) {
                std::fill(brick.begin(), brick.end(), 0.0f);
                bool any = false;
                for (int z = bz * B; z < std::min(res[2], bz * B + B); ++z)
                    for (int y = by * B; y < std::min(res[1], by * B + B); ++y)
                        for (int x = bx * B; x < std::min(res[0], bx * B + B); ++x)
                            for (int c = 0; c < channels; ++c) {
                                const float v = dense[((size_t(z) * res[1] + y) * res[0] + x) * channels + c];
                                brick[(((z % B) * B + y % B) * B + x % B) * channels + c] = v;
                                any |= v != 0.0f;
                            }
                if (!any) continue;
                g.brick_index[(size_t(bz) * g.bricks[1] + by) * g.bricks[0] + bx] = int32_t(g.stored_bricks());
                g.data.insert(g.data.end(), brick.begin(), brick.end());
            }
    return g;
}

namespace {
// Largest value of the voxels a trilinear lookup can blend anywhere in cell [lo, hi)
// along one axis: centres sit at (i + 0.5) / res, so a point u blends voxels
// floor(u res - 0.5) and the next, clamped at the border.
void voxel_range(Real lo, Real hi, int res, int &i0, int &i1) {
    i0 = std::clamp(int(std::floor(lo * res - 0.5)), 0, res - 1);
    i1 = std::clamp(int(std::floor(hi * res - 0.5)) + 1, 0, res - 1);
}
}  // namespace

// Only stored bricks are visited: empty ones hold zeros, which bound nothing above and
// make the minorant 0.
MajorantGrid build_majorants(const VoxelGrid &g, int res) {
    constexpr int L = VoxelGrid::kLog2Brick;
    MajorantGrid mg;
    mg.res = res;
    mg.cells.assign(size_t(res) * res * res, {});
    for (int cz = 0; cz < res; ++cz)
        for (int cy = 0; cy < res; ++cy)
            for (int cx = 0; cx < res; ++cx) {
                int lo[3], hi[3];
                const int cell[3] = {cx, cy, cz};
                for (int a = 0; a < 3; ++a)
                    voxel_range(Real(cell[a]) / res, Real(cell[a] + 1) / res, g.res[a], lo[a], hi[a]);
                MajorantGrid::Cell &c = mg.cells[(size_t(cz) * res + cy) * res + cx];
                c.max = Spectrum(0.0), c.min = Spectrum(kInfinity);
                for (int bz = lo[2] >> L; bz <= hi[2] >> L; ++bz)
                    for (int by = lo[1] >> L; by <= hi[1] >> L; ++by)
                        for (int bx = lo[0] >> L; bx <= hi[0] >> L; ++bx) {
                            if (g.brick_index[(size_t(bz) * g.bricks[1] + by) * g.bricks[0] + bx] < 0) {
                                c.min = Spectrum(0.0);
                                continue;
                            }
                            for (int z = std::max(lo[2], bz << L); z <= std::min(hi[2], ((bz + 1) << L) - 1); ++z)
                                for (int y = std::max(lo[1], by << L); y <= std::min(hi[1], ((by + 1) << L) - 1); ++y)
                                    for (int x = std::max(lo[0], bx << L); x <= std::min(hi[0], ((bx + 1) << L) - 1);
                                         ++x) {
                                        const Spectrum v = g.channels == 1
                                                               ? Spectrum(g.voxel(x, y, z, 0))
                                                               : Spectrum(g.voxel(x, y, z, 0), g.voxel(x, y, z, 1),
                                                                          g.voxel(x, y, z, 2));
                                        c.max = max(c.max, v), c.min = min(c.min, v);
                                    }
                        }
                mg.global_max = max(mg.global_max, c.max);
            }
    return mg;
}

}  // namespace volpath
