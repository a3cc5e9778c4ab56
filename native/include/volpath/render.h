// The render loop: tiles handed to worker threads, one sampler per pixel sample, so an
// image depends on the seed only, never on the thread count or the schedule.
#pragma once

#include <atomic>
#include <cstdint>

#include "integrator.h"

namespace volpath {

struct RenderSettings {
    int spp = 16;
    uint64_t seed = 0;
    uint64_t first_sample = 0;  // sample indices first_sample .. first_sample + spp - 1
    bool low_discrepancy = true;  // Owen-scrambled Sobol; false: independent PCG32
    int threads = 0;  // 0: all hardware threads
    TracerConfig tracer;
};

struct RenderProgress {
    std::atomic<int64_t> tiles_done{0};
    int64_t tiles_total = 0;
    std::atomic<bool> cancel{false};
};

struct RenderStats {
    double seconds = 0;
    uint64_t nonfinite_samples = 0;  // discarded (counted, never silently dropped)
    // Samples with a channel below zero, which only the air's control variates can give
    // (rarely; see the integrator): such channels count as 0, and `clamped_share` is the
    // light that adds, over the image's light (a bias, measured and stated).
    uint64_t negative_samples = 0;
    double clamped_share = 0;
    bool cancelled = false;
};

// Renders into `image` (height * width * 3 floats, row-major, linear RGB).
RenderStats render(const Scene &scene, const RenderSettings &settings, float *image,
                   RenderProgress &progress);

constexpr int kTileSize = 16;
inline int64_t tile_count(const Camera &c) {
    return int64_t((c.width + kTileSize - 1) / kTileSize) * ((c.height + kTileSize - 1) / kTileSize);
}

}  // namespace volpath
