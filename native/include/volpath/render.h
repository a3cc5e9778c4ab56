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
    uint64_t first_sample = 0;    // sample indices first_sample .. first_sample + spp - 1
    bool low_discrepancy = true;  // Owen-scrambled Sobol; false: independent PCG32
    int threads = 0;              // 0: all hardware threads
    TracerConfig tracer;
    // Adaptive rendering (both per pixel, row-major, or null): pixel p takes `counts[p]`
    // samples (0: left as it is) from index first_sample + starts[p] on.
    const uint32_t *starts = nullptr, *counts = nullptr;
    // Two half-buffers (per pixel: the sums of the even and of the odd sample indices, 6
    // doubles, added to): even and odd samples then come from two independent sequences
    // (the even ones are the seed's own), so the halves' difference estimates the
    // variance of their mean without bias, stratified sampling or not.
    double *halves = nullptr;
    // The first surface's passes (see first_surface), per pixel 8 doubles summed over the
    // samples, added to: albedo RGB, normal xyz, depth along the camera's view axis (where
    // a surface is hit), and the count of samples that hit one; or null.
    double *features = nullptr;
};

struct RenderProgress {
    std::atomic<int64_t> samples_done{0};  // counted as tiles finish
    int64_t samples_total = 0;
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

// What the albedo, normal and depth passes (a denoiser's, Blender's) hold for a camera
// ray: the first surface it meets through index-matched boundaries (media are looked
// through), its albedo (bsdf_albedo), world-space shading normal facing the ray, and where
// it is; white and no normal where the ray leaves the scene or meets an emitter.
struct SurfaceFeatures {
    Spectrum albedo{1.0};
    Vec3 normal{0.0};
    bool hit = false;
    Vec3 position{0.0};
};
SurfaceFeatures first_surface(const Scene &scene, Ray ray);

// Renders into `image` (height * width * 3 floats, row-major, linear RGB): each pixel's
// mean over the samples it took in this call.
RenderStats render(const Scene &scene, const RenderSettings &settings, float *image, RenderProgress &progress);

constexpr int kTileSize = 16;

}  // namespace volpath
