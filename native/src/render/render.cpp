#include "volpath/render.h"

#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

namespace volpath {

namespace {

// Offset of a pixel sample from the pixel centre. Box: uniform over the pixel.
// Gaussian (Mitsuba's default filter, stddev 0.5 px truncated at 2 px): sampled exactly,
// so every sample has weight one.
Vec2 filter_offset(const Camera &camera, Sampler &sampler) {
    if (!camera.gaussian_filter) {
        const Vec2 u = sampler.next_2d();
        return {u.x - 0.5, u.y - 0.5};
    }
    for (;;) {
        const Vec2 u = sampler.next_2d();
        const Real r = 0.5 * std::sqrt(-2.0 * std::log1p(-u.x)), phi = 2.0 * kPi * u.y;
        const Vec2 o{r * std::cos(phi), r * std::sin(phi)};
        if (std::abs(o.x) <= 2.0 && std::abs(o.y) <= 2.0) return o;
    }
}

Ray camera_ray(const Camera &c, Real px, Real py, Real time) {
    const Vec3 local = normalize(Vec3((1.0 - 2.0 * px / c.width) * c.tan_half_x + c.shift_x,
                                      (1.0 - 2.0 * py / c.height) * c.tan_half_y + c.shift_y, 1.0));
    const Transform to_world = c.motion.moves() ? c.motion.at(time) : c.to_world;
    const Vec3 d = normalize(to_world.vector(local));
    return Ray{to_world.point(Vec3(0.0)), d, c.near_clip / local.z, c.far_clip / local.z, time};
}

// The seed of a half-buffer's sequence: the even samples keep the render's own.
uint64_t half_seed(uint64_t seed, uint64_t half) { return half ? mix64(seed ^ 0x8f1bbcdcca62c1d6ULL) : seed; }

}  // namespace

SurfaceFeatures first_surface(const Scene &scene, Ray ray) {
    for (int crossing = 0; crossing < 256; ++crossing) {
        Intersection its;
        if (!scene.intersect(ray, its)) break;
        const ShapeInfo &shape = scene.shapes[size_t(its.shape)];
        if (shape.hides_from(RayKind::Camera)) {
            ray = spawn_ray(ray.time, its.p, its.n, ray.d);
            continue;
        }
        if (shape.light >= 0) return {Spectrum(1.0), Vec3(0.0), true, its.p};
        if (shape.bsdf >= 0) {
            // Blends and masks as the middle of their choices would have them.
            SurfacePoint surface;
            surface_at(scene, shape.bsdf, its, 0.5, surface);
            if (surface.bsdf && !is_null(*surface.bsdf))
                return {bsdf_albedo(*surface.bsdf), dot(surface.ns, ray.d) > 0 ? -surface.ns : surface.ns, true, its.p};
        }
        ray = spawn_ray(ray.time, its.p, its.n, ray.d);
    }
    return {};
}

RenderStats render(const Scene &scene, const RenderSettings &settings, float *image, RenderProgress &progress) {
    const auto start = std::chrono::steady_clock::now();
    const Camera &cam = scene.camera;
    const Vec3 eye = cam.to_world.point(Vec3(0.0)), forward = normalize(cam.to_world.vector(Vec3(0, 0, 1)));
    const int tiles_x = (cam.width + kTileSize - 1) / kTileSize;
    const int64_t tiles_total = int64_t(tiles_x) * ((cam.height + kTileSize - 1) / kTileSize);
    const int64_t pixels = int64_t(cam.width) * cam.height;
    auto samples_of = [&](uint64_t pixel) { return settings.counts ? int64_t(settings.counts[pixel]) : settings.spp; };
    progress.samples_total = 0;
    for (int64_t p = 0; p < pixels; ++p) progress.samples_total += samples_of(p);
    std::atomic<int64_t> next_tile{0};
    std::atomic<uint64_t> nonfinite{0}, negative{0};
    std::mutex totals_mutex;
    double clamped = 0, light = 0;  // channel averages, summed over samples

    auto worker = [&] {
        uint64_t local_nonfinite = 0, local_negative = 0;
        double local_clamped = 0, local_light = 0;
        for (;;) {
            const int64_t tile = next_tile.fetch_add(1);
            if (tile >= tiles_total || progress.cancel.load(std::memory_order_relaxed)) break;
            const int x0 = int(tile % tiles_x) * kTileSize, y0 = int(tile / tiles_x) * kTileSize;
            int64_t tile_samples = 0;
            for (int y = y0; y < std::min(y0 + kTileSize, cam.height); ++y) {
                for (int x = x0; x < std::min(x0 + kTileSize, cam.width); ++x) {
                    if (progress.cancel.load(std::memory_order_relaxed)) break;
                    const uint64_t pixel = uint64_t(y) * cam.width + x;
                    const int64_t count = samples_of(pixel);
                    if (count == 0) continue;
                    const uint64_t first = settings.first_sample + (settings.starts ? settings.starts[pixel] : 0);
                    Spectrum sum[2] = {Spectrum(0.0), Spectrum(0.0)}, albedo(0.0);
                    Vec3 normal(0.0);
                    double depth = 0, hits = 0;
                    for (int64_t s = 0; s < count; ++s) {
                        // A pixel of many samples must not delay a cancel.
                        if ((s & 63) == 63 && progress.cancel.load(std::memory_order_relaxed)) break;
                        const uint64_t index = first + uint64_t(s), half = settings.halves ? index & 1 : 0;
                        Sampler sampler(half_seed(settings.seed, half), pixel, settings.halves ? index >> 1 : index,
                                        settings.low_discrepancy);
                        const Vec2 o = filter_offset(cam, sampler);
                        // (Drawn only where something moves: a still scene keeps its bits.)
                        const Real time = scene.context.motion ? sampler.next_1d() : 0.0;
                        const Ray ray = camera_ray(cam, x + 0.5 + o.x, y + 0.5 + o.y, time);
                        if (settings.features) {
                            const SurfaceFeatures f = first_surface(scene, ray);
                            albedo += f.albedo, normal += f.normal;
                            if (f.hit) depth += dot(f.position - eye, forward), hits += 1;
                        }
                        const Spectrum L = radiance(scene, ray, cam.medium, sampler, settings.tracer);
                        if (!is_finite(L)) {
                            ++local_nonfinite;
                            continue;
                        }
                        const Spectrum kept = clamp_zero(L);
                        if (!(kept == L)) {
                            ++local_negative;
                            local_clamped += average(kept - L);
                        }
                        local_light += average(kept);
                        sum[half] += kept;
                    }
                    tile_samples += count;
                    const Spectrum mean = (sum[0] + sum[1]) / Real(count);
                    float *out = image + pixel * 3;
                    out[0] = float(mean.x), out[1] = float(mean.y), out[2] = float(mean.z);
                    if (settings.halves) {
                        double *h = settings.halves + pixel * 6;
                        h[0] += sum[0].x, h[1] += sum[0].y, h[2] += sum[0].z;
                        h[3] += sum[1].x, h[4] += sum[1].y, h[5] += sum[1].z;
                    }
                    if (settings.features) {
                        double *f = settings.features + pixel * 8;
                        f[0] += albedo.x, f[1] += albedo.y, f[2] += albedo.z;
                        f[3] += normal.x, f[4] += normal.y, f[5] += normal.z;
                        f[6] += depth, f[7] += hits;
                    }
                }
            }
            progress.samples_done.fetch_add(tile_samples);
        }
        nonfinite.fetch_add(local_nonfinite);
        negative.fetch_add(local_negative);
        const std::lock_guard<std::mutex> lock(totals_mutex);
        clamped += local_clamped, light += local_light;
    };

    int n_threads = settings.threads > 0 ? settings.threads : int(std::thread::hardware_concurrency());
    n_threads = std::max(1, std::min<int>(n_threads, int(tiles_total)));
    std::vector<std::thread> pool;
    for (int i = 1; i < n_threads; ++i) pool.emplace_back(worker);
    worker();
    for (auto &t : pool) t.join();

    RenderStats stats;
    stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    stats.nonfinite_samples = nonfinite.load();
    stats.negative_samples = negative.load();
    stats.clamped_share = light > 0 ? clamped / light : 0.0;
    stats.cancelled = progress.cancel.load();
    return stats;
}

}  // namespace volpath
