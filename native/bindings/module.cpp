// pybind11 glue for volpath._core: conversions and GIL handling only.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>

#include "volpath/light_distances.h"
#include "volpath/render.h"
#include "volpath/sky_map.h"

namespace py = pybind11;
using namespace volpath;

namespace {

using Array3 = std::array<double, 3>;
Vec3 vec(const Array3 &a) { return {a[0], a[1], a[2]}; }

Transform transform(const py::array_t<double, py::array::c_style | py::array::forcecast> &m) {
    if (m.ndim() != 2 || m.shape(0) != 4 || m.shape(1) != 4)
        throw std::invalid_argument("expected a 4x4 matrix");
    Transform t;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) t.m[i][j] = m.at(i, j);
    return t;
}

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

using GridPtr = std::shared_ptr<VoxelGrid>;

// (z, y, x, c) float32 -> sparse VoxelGrid, c in {1, 3}.
GridPtr grid_from_dense(const FloatArray &a) {
    if (a.ndim() != 4 || (a.shape(3) != 1 && a.shape(3) != 3) || a.shape(0) < 1 || a.shape(1) < 1 ||
        a.shape(2) < 1)
        throw std::invalid_argument("expected a grid of shape (z, y, x, 1 or 3)");
    const int res[3] = {int(a.shape(2)), int(a.shape(1)), int(a.shape(0))};
    return std::make_shared<VoxelGrid>(sparse_grid(a.data(), res, int(a.shape(3))));
}

// Bricks as OpenVDB leaves hand them over: an index per brick (bz, by, bx), -1 for an empty
// brick, into `bricks` of shape (n, 8, 8, 8, c) laid out (z, y, x) inside.
GridPtr grid_from_bricks(std::array<int, 3> res, const py::array_t<int32_t, py::array::c_style | py::array::forcecast> &index,
                         const FloatArray &bricks) {
    constexpr int B = VoxelGrid::kBrick;
    auto g = std::make_shared<VoxelGrid>();
    for (int a = 0; a < 3; ++a) {
        if (res[a] < 1) throw std::invalid_argument("grid resolution must be positive");
        g->res[a] = res[a], g->bricks[a] = (res[a] + B - 1) / B;
    }
    if (index.ndim() != 3 || index.shape(0) != g->bricks[2] || index.shape(1) != g->bricks[1] ||
        index.shape(2) != g->bricks[0])
        throw std::invalid_argument("brick index must have shape ceil(res / 8) as (z, y, x)");
    if (bricks.ndim() != 5 || bricks.shape(1) != B || bricks.shape(2) != B || bricks.shape(3) != B ||
        (bricks.shape(4) != 1 && bricks.shape(4) != 3))
        throw std::invalid_argument("bricks must have shape (n, 8, 8, 8, 1 or 3)");
    g->channels = int(bricks.shape(4));
    const int32_t n = int32_t(bricks.shape(0));
    g->brick_index.assign(index.data(), index.data() + index.size());
    for (int32_t b : g->brick_index)
        if (b < -1 || b >= n) throw std::invalid_argument("brick index out of range");
    g->data.assign(bricks.data(), bricks.data() + bricks.size());
    return g;
}

// A read-only numpy view of a vector the grid owns (the grid stays alive with the view).
template <typename T>
py::array_t<T> view(const GridPtr &g, const std::vector<T> &v, std::vector<py::ssize_t> shape) {
    py::array_t<T> a(shape, v.data(), py::cast(g));
    py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
    return a;
}

PlacedGrid placed(const GridPtr &g, const std::optional<DoubleArray> &world_to_grid) {
    if (!g) return {};
    if (!world_to_grid) throw std::invalid_argument("a grid needs its world_to_grid matrix");
    return {g, transform(*world_to_grid)};
}

std::vector<Vec3> points(const DoubleArray &a, const char *what) {
    if (a.ndim() != 2 || a.shape(1) != 3) throw std::invalid_argument(std::string(what) + " must have shape (n, 3)");
    std::vector<Vec3> out(size_t(a.shape(0)));
    for (size_t i = 0; i < out.size(); ++i) out[i] = {a.at(i, 0), a.at(i, 1), a.at(i, 2)};
    return out;
}

PhaseFunction phase(double g) {
    if (g == 0) return IsotropicPhase{};
    return HenyeyGreenstein{g};
}

// A new light, or (replace >= 0) that light replaced: an animation's next frame.
int add_or_replace(Scene &s, const Light &l, int replace) {
    if (replace < 0) return s.add_light(l);
    s.set_light(replace, l);
    return replace;
}

ShapeInfo shape_info(int bsdf, int interior, int exterior, bool medium_interface) {
    ShapeInfo info;
    info.bsdf = bsdf;
    info.interior = interior, info.exterior = exterior;
    info.medium_interface = medium_interface;
    return info;
}

py::tuple render_py(Scene &scene, int spp, uint64_t seed, int threads, int tracer, int max_depth,
                    int rr_depth, int max_null_collisions, bool light_distances, py::object progress_cb,
                    py::object out, bool low_discrepancy, uint64_t first_sample, py::object starts,
                    py::object counts, py::object halves, py::object features) {
    if (!scene.built) scene.build();
    if (tracer < 0 || tracer > int(Tracer::NullScattering)) throw std::invalid_argument("unknown tracer");
    if (spp < 1) throw std::invalid_argument("spp must be at least 1");
    check_tracer_supports(scene, Tracer(tracer));
    RenderSettings settings;
    settings.spp = spp;
    settings.seed = seed;
    settings.first_sample = first_sample;
    settings.low_discrepancy = low_discrepancy;
    settings.threads = threads;
    settings.tracer = {Tracer(tracer), max_depth, rr_depth, max_null_collisions, light_distances};
    // Adaptive rendering's per-pixel arrays, used in place (the caller keeps them alive).
    const auto pixel_array = [&](py::object a, const char *name, std::vector<py::ssize_t> shape, auto *type) {
        using T = std::remove_pointer_t<decltype(type)>;
        if (a.is_none()) return static_cast<T *>(nullptr);
        auto array = py::array_t<T>::ensure(a);
        if (!array || array.ptr() != a.ptr() || !(array.flags() & py::array::c_style) || !array.writeable() ||
            std::vector<py::ssize_t>(array.shape(), array.shape() + array.ndim()) != shape)
            throw std::invalid_argument(std::string(name) + " must be a writeable C-contiguous array of shape (height, width" +
                                        (shape.size() > 2 ? ", 2, 3)" : ")") + " and dtype " + py::str(py::dtype::of<T>()).cast<std::string>());
        return array.mutable_data();
    };
    const py::ssize_t h = scene.camera.height, w = scene.camera.width;
    settings.starts = pixel_array(starts, "starts", {h, w}, static_cast<uint32_t *>(nullptr));
    settings.counts = pixel_array(counts, "counts", {h, w}, static_cast<uint32_t *>(nullptr));
    settings.halves = pixel_array(halves, "halves", {h, w, 2, 3}, static_cast<double *>(nullptr));
    settings.features = pixel_array(features, "features", {h, w, 2, 3}, static_cast<double *>(nullptr));

    // Rendering into a caller's array lets a progress callback show finished tiles.
    py::array_t<float> image;
    if (out.is_none()) {
        image = py::array_t<float>({scene.camera.height, scene.camera.width, 3});
    } else {
        image = py::array_t<float>::ensure(out);
        if (!image || image.ndim() != 3 || image.shape(0) != scene.camera.height ||
            image.shape(1) != scene.camera.width || image.shape(2) != 3 || !image.writeable() ||
            !(image.flags() & py::array::c_style) || image.ptr() != out.ptr())
            throw std::invalid_argument("out must be a writeable C-contiguous float32 array of shape (height, width, 3)");
    }
    float *pixels = image.mutable_data();
    std::fill(pixels, pixels + image.size(), 0.0f);
    RenderProgress progress;
    RenderStats stats;
    std::exception_ptr failure;
    bool finished = false;
    std::mutex mutex;
    std::condition_variable done;
    bool python_error = false;
    {
        py::gil_scoped_release release;
        std::thread job([&] {
            try {
                stats = render(scene, settings, pixels, progress);
            } catch (...) {
                failure = std::current_exception();
            }
            std::lock_guard<std::mutex> lock(mutex);
            finished = true;
            done.notify_all();
        });
        // Poll for Ctrl-C and report progress while the workers run without the GIL,
        // waking at once when the render ends.
        for (;;) {
            {
                std::unique_lock<std::mutex> lock(mutex);
                if (done.wait_for(lock, std::chrono::milliseconds(50), [&] { return finished; })) break;
            }
            py::gil_scoped_acquire acquire;
            if (python_error) continue;
            if (PyErr_CheckSignals() != 0) {
                python_error = true;
                progress.cancel = true;
                continue;
            }
            if (!progress_cb.is_none()) {
                try {
                    const double done = progress.samples_total ? double(progress.samples_done.load()) /
                                                                         double(progress.samples_total) : 1.0;
                    py::object keep_going = progress_cb(done);
                    if (!keep_going.is_none() && !keep_going.cast<bool>()) progress.cancel = true;
                } catch (py::error_already_set &e) {
                    e.restore();
                    python_error = true;
                    progress.cancel = true;
                }
            }
        }
        job.join();
    }
    if (python_error) throw py::error_already_set();
    if (failure) std::rethrow_exception(failure);
    if (!progress_cb.is_none() && !stats.cancelled) progress_cb(1.0);
    py::dict info;
    info["seconds"] = stats.seconds;
    info["nonfinite_samples"] = stats.nonfinite_samples;
    info["negative_samples"] = stats.negative_samples;
    info["clamped_share"] = stats.clamped_share;
    info["cancelled"] = stats.cancelled;
    return py::make_tuple(image, info);
}

}  // namespace

PYBIND11_MODULE(_core, m) {
    m.doc() = "Volpath native core: scene model, tracers and render loop.";

    py::class_<VoxelGrid, GridPtr>(m, "VoxelGrid", "A sparse voxel grid (8^3 bricks, empty ones not stored).")
        .def_static("from_dense", &grid_from_dense, py::arg("data"))
        .def_static("from_bricks", &grid_from_bricks, py::arg("res"), py::arg("brick_index"), py::arg("bricks"))
        .def_property_readonly("res", [](const VoxelGrid &g) { return std::array<int, 3>{g.res[0], g.res[1], g.res[2]}; })
        .def_property_readonly("channels", [](const VoxelGrid &g) { return g.channels; })
        .def_property_readonly("brick_index", [](const GridPtr &g) {
            return view(g, g->brick_index, {g->bricks[2], g->bricks[1], g->bricks[0]});
        })
        .def_property_readonly("bricks", [](const GridPtr &g) {
            constexpr int B = VoxelGrid::kBrick;
            return view(g, g->data, {py::ssize_t(g->stored_bricks()), B, B, B, g->channels});
        })
        .def_property_readonly("nbytes", [](const VoxelGrid &g) {
            return g.data.size() * sizeof(float) + g.brick_index.size() * sizeof(int32_t) + sizeof(VoxelGrid);
        })
        .def("dense", [](const VoxelGrid &g) {
            FloatArray a({g.res[2], g.res[1], g.res[0], g.channels});
            float *out = a.mutable_data();
            for (int z = 0; z < g.res[2]; ++z)
                for (int y = 0; y < g.res[1]; ++y)
                    for (int x = 0; x < g.res[0]; ++x)
                        for (int c = 0; c < g.channels; ++c) *out++ = g.voxel(x, y, z, c);
            return a;
        }, "The grid as a dense float32 array (z, y, x, c).")
        .def("lookup", [](const VoxelGrid &g, Array3 p) {
            const Spectrum v = g.lookup(vec(p));
            return Array3{v[0], v[1], v[2]};
        }, py::arg("p"), "Trilinear lookup at a point of the unit cube.");

    py::class_<Scene>(m, "Scene")
        .def(py::init<>())
        .def("add_bsdf_null", [](Scene &s) { return s.add_bsdf({NullBSDF{}, false}); })
        .def("add_bsdf_diffuse",
             [](Scene &s, Array3 r, bool twosided) { return s.add_bsdf({DiffuseBSDF{vec(r)}, twosided}); },
             py::arg("reflectance"), py::arg("twosided") = false)
        .def("add_bsdf_dielectric", [](Scene &s, double eta) { return s.add_bsdf({DielectricBSDF{eta}, false}); },
             py::arg("eta"))
        .def("add_bsdf_roughplastic",
             [](Scene &s, Array3 diffuse, Array3 specular, double alpha, double eta, bool twosided) {
                 return s.add_bsdf({RoughPlasticBSDF{vec(diffuse), vec(specular), std::max(alpha, 1e-4), eta},
                                    twosided});
             },
             py::arg("diffuse"), py::arg("specular"), py::arg("alpha"), py::arg("eta"), py::arg("twosided") = false)
        .def("add_medium_homogeneous",
             [](Scene &s, Array3 sigma_a, Array3 sigma_s, double g, Array3 Le) {
                 return s.add_medium(HomogeneousMedium{vec(sigma_a), vec(sigma_s), phase(g), vec(Le)});
             },
             py::arg("sigma_a"), py::arg("sigma_s"), py::arg("g") = 0.0, py::arg("Le") = Array3{0.0, 0.0, 0.0})
        .def("add_medium_grid",
             [](Scene &s, const GridPtr &density, const DoubleArray &world_to_grid, const GridPtr &albedo_grid,
                std::optional<DoubleArray> albedo_world_to_grid, Array3 albedo, double scale, double g,
                int majorant_res, const GridPtr &Le_grid, std::optional<DoubleArray> Le_world_to_grid,
                Array3 Le_scale) {
                 if (!density) throw std::invalid_argument("a grid medium needs a density grid");
                 GridMedium gm;
                 gm.majorant_res = majorant_res;
                 gm.density = placed(density, world_to_grid);
                 gm.albedo_grid = placed(albedo_grid, albedo_world_to_grid);
                 gm.Le_grid = placed(Le_grid, Le_world_to_grid);
                 gm.Le_scale = vec(Le_scale);
                 gm.albedo = vec(albedo);
                 gm.scale = scale;
                 gm.phase = phase(g);
                 return s.add_medium(gm);
             },
             py::arg("density"), py::arg("world_to_grid"), py::arg("albedo_grid") = GridPtr(),
             py::arg("albedo_world_to_grid") = py::none(), py::arg("albedo") = Array3{1.0, 1.0, 1.0},
             py::arg("scale") = 1.0, py::arg("g") = 0.0, py::arg("majorant_res") = 0,
             py::arg("Le_grid") = GridPtr(), py::arg("Le_world_to_grid") = py::none(),
             py::arg("Le_scale") = Array3{0.0, 0.0, 0.0})
        .def("add_mesh",
             [](Scene &s, const DoubleArray &positions, const py::array_t<uint32_t, py::array::c_style | py::array::forcecast> &triangles,
                std::optional<DoubleArray> normals, int bsdf, int interior, int exterior, bool medium_interface,
                std::optional<Array3> radiance) {
                 TriangleMesh mesh;
                 mesh.positions = points(positions, "positions");
                 if (normals) mesh.normals = points(*normals, "normals");
                 if (triangles.ndim() != 2 || triangles.shape(1) != 3)
                     throw std::invalid_argument("triangles must have shape (n, 3)");
                 mesh.triangles.resize(size_t(triangles.shape(0)));
                 for (size_t i = 0; i < mesh.triangles.size(); ++i)
                     mesh.triangles[i] = {triangles.at(i, 0), triangles.at(i, 1), triangles.at(i, 2)};
                 Spectrum Le = radiance ? vec(*radiance) : Spectrum(0.0);
                 return s.add_shape_mesh(std::move(mesh), shape_info(bsdf, interior, exterior, medium_interface),
                                         radiance ? &Le : nullptr);
             },
             py::arg("positions"), py::arg("triangles"), py::arg("normals"), py::arg("bsdf"),
             py::arg("interior") = -1, py::arg("exterior") = -1, py::arg("medium_interface") = false,
             py::arg("radiance") = py::none())
        .def("add_sphere",
             [](Scene &s, Array3 center, double radius, bool flip, int bsdf, int interior, int exterior,
                bool medium_interface, std::optional<Array3> radiance) {
                 Spectrum Le = radiance ? vec(*radiance) : Spectrum(0.0);
                 return s.add_shape_sphere(Sphere{vec(center), radius, flip},
                                           shape_info(bsdf, interior, exterior, medium_interface),
                                           radiance ? &Le : nullptr);
             },
             py::arg("center"), py::arg("radius"), py::arg("flip_normals"), py::arg("bsdf"),
             py::arg("interior") = -1, py::arg("exterior") = -1, py::arg("medium_interface") = false,
             py::arg("radiance") = py::none())
        .def("add_box",
             [](Scene &s, const DoubleArray &to_world, const DoubleArray &to_local, bool flip, int bsdf, int interior,
                int exterior, bool medium_interface) {
                 return s.add_shape_box(Box{transform(to_world), transform(to_local), flip},
                                        shape_info(bsdf, interior, exterior, medium_interface));
             },
             py::arg("to_world"), py::arg("to_local"), py::arg("flip_normals"), py::arg("bsdf"),
             py::arg("interior") = -1, py::arg("exterior") = -1, py::arg("medium_interface") = false)
        .def("add_medium_atmosphere",
             [](Scene &s, Array3 center, double planet_radius, double top_radius, Array3 rayleigh,
                double rayleigh_height, Array3 mie_s, Array3 mie_a, double mie_height, double g, Array3 ozone,
                int pieces, const std::string &sun_transmittance, const std::string &free_flight, bool sky_map) {
                 AtmosphereMedium a;
                 a.use_sky_map = sky_map;
                 using S = AtmosphereMedium::SunTransmittance;
                 if (sun_transmittance == "table") a.sun_transmittance = S::Table;
                 else if (sun_transmittance == "quadrature") a.sun_transmittance = S::Quadrature;
                 else if (sun_transmittance == "tracking") a.sun_transmittance = S::Tracking;
                 else throw std::invalid_argument("sun_transmittance must be table, quadrature or tracking");
                 if (free_flight == "guided") a.free_flight = AtmosphereMedium::FreeFlight::Guided;
                 else if (free_flight == "tracking") a.free_flight = AtmosphereMedium::FreeFlight::Tracking;
                 else throw std::invalid_argument("free_flight must be guided or tracking");
                 if (a.free_flight == AtmosphereMedium::FreeFlight::Guided && a.sun_transmittance == S::Tracking)
                     throw std::invalid_argument("free_flight guided needs sun_transmittance table or quadrature");
                 a.center = vec(center);
                 a.planet_radius = planet_radius, a.top_radius = top_radius;
                 a.rayleigh_sigma_s = vec(rayleigh), a.rayleigh_height = rayleigh_height;
                 a.mie_sigma_s = vec(mie_s), a.mie_sigma_a = vec(mie_a), a.mie_height = mie_height;
                 a.mie_g = g;
                 a.ozone_sigma_a = vec(ozone);
                 a.pieces = pieces;
                 return s.add_medium(a);
             },
             py::arg("center"), py::arg("planet_radius"), py::arg("top_radius"), py::arg("rayleigh"),
             py::arg("rayleigh_height"), py::arg("mie_scattering"), py::arg("mie_absorption"),
             py::arg("mie_height"), py::arg("g"), py::arg("ozone"), py::arg("pieces") = 4,
             py::arg("sun_transmittance") = "table", py::arg("free_flight") = "guided", py::arg("sky_map") = true)
        .def("add_sun",
             [](Scene &s, Array3 to_sun, double angular_radius, Array3 irradiance, int replace) {
                 if (!(angular_radius > 0 && angular_radius < 0.5))
                     throw std::invalid_argument("sun angular radius must be in (0, 0.5) rad");
                 const double sin_r = std::sin(angular_radius);
                 return add_or_replace(s, SunLight{normalize(vec(to_sun)), std::cos(angular_radius),
                                                   vec(irradiance) / (kPi * sin_r * sin_r)}, replace);
             },
             py::arg("to_sun"), py::arg("angular_radius"), py::arg("irradiance"), py::arg("replace") = -1)
        .def("add_point_light",
             [](Scene &s, Array3 p, Array3 intensity) { return s.add_light(PointLight{vec(p), vec(intensity)}); })
        .def("add_directional_light",
             [](Scene &s, Array3 d, Array3 irradiance, int replace) {
                 return add_or_replace(s, DirectionalLight{normalize(vec(d)), vec(irradiance)}, replace);
             },
             py::arg("direction"), py::arg("irradiance"), py::arg("replace") = -1)
        .def("add_environment",
             [](Scene &s, Array3 scale, std::optional<FloatArray> image, const DoubleArray &to_world,
                const DoubleArray &to_local) {
                 EnvironmentLight env;
                 env.scale = vec(scale);
                 env.to_world = transform(to_world);
                 env.to_local = transform(to_local);
                 if (image) {
                     if (image->ndim() != 3 || image->shape(2) != 3 || image->shape(0) < 1 || image->shape(1) < 1)
                         throw std::invalid_argument("environment image must have shape (h, w, 3)");
                     env.height = int(image->shape(0)), env.width = int(image->shape(1));
                     const float *p = image->data();
                     env.pixels.resize(size_t(env.width) * env.height);
                     for (size_t i = 0; i < env.pixels.size(); ++i) env.pixels[i] = {p[3 * i], p[3 * i + 1], p[3 * i + 2]};
                 }
                 return s.add_light(env);
             },
             py::arg("scale"), py::arg("image"), py::arg("to_world"), py::arg("to_local"))
        .def("set_camera",
             [](Scene &s, const DoubleArray &to_world, double tan_x, double tan_y, int width, int height,
                double near_clip, double far_clip, int medium, bool gaussian, double shift_x, double shift_y) {
                 if (width < 1 || height < 1) throw std::invalid_argument("film size must be positive");
                 Camera &c = s.camera;
                 c.to_world = transform(to_world);
                 c.tan_half_x = tan_x, c.tan_half_y = tan_y;
                 c.shift_x = shift_x, c.shift_y = shift_y;
                 c.width = width, c.height = height;
                 c.near_clip = near_clip, c.far_clip = far_clip;
                 c.medium = medium;
                 c.gaussian_filter = gaussian;
                 s.built = false;
             },
             py::arg("to_world"), py::arg("tan_x"), py::arg("tan_y"), py::arg("width"), py::arg("height"),
             py::arg("near_clip"), py::arg("far_clip"), py::arg("medium"), py::arg("gaussian"),
             py::arg("shift_x") = 0.0, py::arg("shift_y") = 0.0)
        .def("build", [](Scene &s) {
            py::gil_scoped_release release;
            s.build();
        })
        .def_property_readonly("width", [](const Scene &s) { return s.camera.width; })
        .def_property_readonly("height", [](const Scene &s) { return s.camera.height; })
        .def_property_readonly("light_count", [](const Scene &s) { return s.lights.size(); })
        .def("__repr__", [](const Scene &s) { return "<volpath._core.Scene: " + s.describe() + ">"; });

    m.def("render", &render_py, py::arg("scene"), py::arg("spp"), py::arg("seed"), py::arg("threads"),
          py::arg("tracer"), py::arg("max_depth"), py::arg("rr_depth"), py::arg("max_null_collisions"),
          py::arg("light_distances") = true, py::arg("progress") = py::none(), py::arg("out") = py::none(),
          py::arg("low_discrepancy") = true, py::arg("first_sample") = 0, py::arg("starts") = py::none(),
          py::arg("counts") = py::none(), py::arg("halves") = py::none(), py::arg("features") = py::none());

    // The pixel sampler's numbers: (samples, dimensions, 2) from next_2d, or
    // (samples, dimensions) from next_1d, for the sampler's own tests.
    // split_after >= 0: the values of the stream split off after that many dimensions (the
    // second branch of a camera ray in a medium).
    m.def("sampler_values", [](uint64_t seed, uint64_t pixel, int samples, int dimensions, bool low_discrepancy,
                               bool two_d, int split_after) {
        if (samples < 1 || dimensions < 1) throw std::invalid_argument("samples and dimensions must be positive");
        std::vector<py::ssize_t> shape{samples, dimensions};
        if (two_d) shape.push_back(2);
        py::array_t<double> out(shape);
        double *o = out.mutable_data();
        for (int i = 0; i < samples; ++i) {
            Sampler parent(seed, pixel, uint64_t(i), low_discrepancy);
            for (int d = 0; d < split_after; ++d) parent.next_1d();
            Sampler sampler = split_after >= 0 ? parent.split() : parent;
            for (int d = 0; d < dimensions; ++d) {
                if (two_d) {
                    const Vec2 u = sampler.next_2d();
                    *o++ = u.x, *o++ = u.y;
                } else {
                    *o++ = sampler.next_1d();
                }
            }
        }
        return out;
    }, py::arg("seed"), py::arg("pixel"), py::arg("samples"), py::arg("dimensions"), py::arg("low_discrepancy"),
       py::arg("two_d"), py::arg("split_after") = -1);

    // How often a ChoiceChain over `probabilities` makes its first choice at each of them
    // (the last count: none made), one chain per pixel sample, for its chi-square test.
    m.def("choice_chain_counts", [](const std::vector<double> &probabilities, uint64_t seed, int pixels,
                                    int samples, bool low_discrepancy) {
        std::vector<int64_t> counts(probabilities.size() + 1, 0);
        for (int pixel = 0; pixel < pixels; ++pixel)
            for (int i = 0; i < samples; ++i) {
                Sampler sampler(seed, uint64_t(pixel), uint64_t(i), low_discrepancy);
                ChoiceChain chain;
                size_t k = 0;
                while (k < probabilities.size() && !chain.choose(probabilities[k], sampler)) ++k;
                ++counts[k];
            }
        return counts;
    }, py::arg("probabilities"), py::arg("seed"), py::arg("pixels"), py::arg("samples"), py::arg("low_discrepancy"));

    // Sampler access for the statistical tests (chi-square against the pdfs).
    m.def("phase_sample", [](double g, const DoubleArray &u) {
        const size_t n = size_t(u.shape(0));
        py::array_t<double> dirs({n, size_t(3)}), pdfs(n);
        auto d = dirs.mutable_unchecked<2>();
        auto p = pdfs.mutable_unchecked<1>();
        for (size_t i = 0; i < n; ++i) {
            const PhaseSample s = phase_sample(phase(g), {0, 0, 1}, {u.at(i, 0), u.at(i, 1)}, 0.0, 0);
            d(i, 0) = s.d_out.x, d(i, 1) = s.d_out.y, d(i, 2) = s.d_out.z;
            p(i) = s.pdf[0];
        }
        return py::make_tuple(dirs, pdfs);
    });
    m.def("phase_eval", [](double g, double mu) { return phase_eval(phase(g), mu)[0]; });
    m.def("rayleigh_eval", &rayleigh_eval);
    // Equiangular distances toward a point light at c along o + t d, t in [t0, t1]: (t, pdf).
    m.def("equiangular_sample", [](Array3 c, Array3 o, Array3 d, double t0, double t1, const DoubleArray &u) {
        const Equiangular e = equiangular(vec(c), vec(o), normalize(vec(d)), t0, t1);
        if (!is_valid(e)) throw std::invalid_argument("the line passes through the light, or t1 <= t0");
        py::array_t<double> t(u.shape(0)), pdf(u.shape(0));
        for (py::ssize_t i = 0; i < u.shape(0); ++i) {
            t.mutable_at(i) = sample_equiangular(e, u.at(i), t0, t1);
            pdf.mutable_at(i) = equiangular_pdf(e, t.at(i));
        }
        return py::make_tuple(t, pdf);
    });
    // Distances drawn for a light of the scene on the segment [t0, t1] of o + t d through a
    // homogeneous medium of extinction sigma_t (LightDistances): their count, the k-th one for
    // each u, drawn in `channel`, as (t, per-channel density of all the segment's distances),
    // t NaN where the draw fails; and that density at t.
    auto light_distances = [](const Scene &s, int light, Array3 o, Array3 d, double t0, double t1, Array3 sigma_t) {
        const Light &l = s.lights.at(size_t(light));
        if (std::holds_alternative<EnvironmentLight>(l)) throw std::invalid_argument("environments have no distances");
        return LightDistances(l, Ray{vec(o), normalize(vec(d)), t0, t1}, t1, vec(sigma_t));
    };
    m.def("light_distance_count", [light_distances](const Scene &s, int light, Array3 o, Array3 d, double t0, double t1,
                                                    Array3 sigma_t) {
        return light_distances(s, light, o, d, t0, t1, sigma_t).count;
    }, py::arg("scene"), py::arg("light"), py::arg("o"), py::arg("d"), py::arg("t0"), py::arg("t1"), py::arg("sigma_t"));
    m.def("light_distance_sample", [light_distances](const Scene &s, int light, Array3 o, Array3 d, double t0,
                                                     double t1, Array3 sigma_t, int channel, int k, const DoubleArray &u) {
        const LightDistances distances = light_distances(s, light, o, d, t0, t1, sigma_t);
        if (k < 0 || k >= distances.count) throw std::out_of_range("no such distance on this segment");
        if (channel < 0 || channel > 2) throw std::out_of_range("channel must be 0, 1 or 2");
        py::array_t<double> t(u.shape(0)), density({size_t(u.shape(0)), size_t(3)});
        auto p = density.mutable_unchecked<2>();
        for (py::ssize_t i = 0; i < u.shape(0); ++i) {
            Real ti;
            const bool ok = distances.sample(k, u.at(i), channel, ti);
            const Spectrum di = ok ? distances.density(ti) : Spectrum(0.0);
            t.mutable_at(i) = ok ? ti : std::numeric_limits<Real>::quiet_NaN();
            p(i, 0) = di.x, p(i, 1) = di.y, p(i, 2) = di.z;
        }
        return py::make_tuple(t, density);
    }, py::arg("scene"), py::arg("light"), py::arg("o"), py::arg("d"), py::arg("t0"), py::arg("t1"),
       py::arg("sigma_t"), py::arg("channel"), py::arg("k"), py::arg("u"));
    m.def("light_distance_density", [light_distances](const Scene &s, int light, Array3 o, Array3 d, double t0,
                                                      double t1, Array3 sigma_t, double t) {
        const Spectrum p = light_distances(s, light, o, d, t0, t1, sigma_t).density(t);
        return std::array<double, 3>{p.x, p.y, p.z};
    }, py::arg("scene"), py::arg("light"), py::arg("o"), py::arg("d"), py::arg("t0"), py::arg("t1"),
       py::arg("sigma_t"), py::arg("t"));
    // Majorant pieces of a medium along a ray: (t0, t1, sigma_maj, sigma_min) rows.
    m.def("majorant_segments", [](Scene &s, int medium, Array3 o, Array3 d, double t_max) {
        MajorantIterator pieces(s.media.at(size_t(medium)), Ray{vec(o), normalize(vec(d)), 0, t_max}, t_max);
        std::vector<std::array<double, 8>> rows;
        MajorantSegment g;
        while (pieces.next(g))
            rows.push_back({g.t0, g.t1, g.sigma_maj.x, g.sigma_maj.y, g.sigma_maj.z, g.sigma_min.x, g.sigma_min.y,
                            g.sigma_min.z});
        py::array_t<double> out({rows.size(), size_t(8)});
        auto r = out.mutable_unchecked<2>();
        for (size_t i = 0; i < rows.size(); ++i)
            for (int j = 0; j < 8; ++j) r(i, j) = rows[i][j];
        return out;
    });
    m.def("medium_sigma_t", [](Scene &s, int medium, const DoubleArray &p) {
        const std::vector<Vec3> ps = points(p, "points");
        py::array_t<double> out({ps.size(), size_t(3)});
        auto r = out.mutable_unchecked<2>();
        for (size_t i = 0; i < ps.size(); ++i) {
            const MediumProperties mp = medium_properties(s.media.at(size_t(medium)), ps[i]);
            const Spectrum st = mp.sigma_a + mp.sigma_s;
            r(i, 0) = st.x, r(i, 1) = st.y, r(i, 2) = st.z;
        }
        return out;
    });
    m.def("cornette_shanks_eval", &cornette_shanks_eval);
    m.def("air_phase_sample", [](Array3 rayleigh_fraction, double g, int channel, const DoubleArray &u) {
        const size_t n = size_t(u.shape(0));
        py::array_t<double> dirs({n, size_t(3)}), pdfs(n);
        auto d = dirs.mutable_unchecked<2>();
        auto p = pdfs.mutable_unchecked<1>();
        const PhaseFunction air = RayleighMiePhase{vec(rayleigh_fraction), g};
        for (size_t i = 0; i < n; ++i) {
            const PhaseSample s = phase_sample(air, {0, 0, 1}, {u.at(i, 1), u.at(i, 2)}, u.at(i, 0), channel);
            d(i, 0) = s.d_out.x, d(i, 1) = s.d_out.y, d(i, 2) = s.d_out.z;
            p(i) = s.pdf[channel];
        }
        return py::make_tuple(dirs, pdfs);
    });
    m.def("air_phase_pdf", [](Array3 rayleigh_fraction, double g, int channel, double mu) {
        return phase_pdf(RayleighMiePhase{vec(rayleigh_fraction), g}, mu)[channel];
    });
    // Nearest hit of each ray (rows of o and d): t (inf on a miss), the shape index and the
    // geometric normal; `medium`: the one the rays travel in, as the tracers pass it.
    // medium None: the plain BVH traversal; else the ray travels in that medium (-1: none),
    // with the shortcuts of Scene::intersect.
    m.def("intersect", [](Scene &s, const DoubleArray &o, const DoubleArray &d, std::optional<int> medium) {
        if (!s.built) s.build();
        const std::vector<Vec3> os = points(o, "origins"), ds = points(d, "directions");
        if (os.size() != ds.size()) throw std::invalid_argument("need as many origins as directions");
        if (medium && (*medium < -1 || *medium >= int(s.media.size()))) throw std::out_of_range("invalid medium");
        py::array_t<double> t(os.size()), n({py::ssize_t(os.size()), py::ssize_t(3)});
        py::array_t<int> shape(os.size());
        auto tt = t.mutable_unchecked<1>();
        auto nn = n.mutable_unchecked<2>();
        auto ss = shape.mutable_unchecked<1>();
        for (size_t i = 0; i < os.size(); ++i) {
            Intersection its;
            const Ray ray{os[i], normalize(ds[i]), 0, kInfinity};
            const bool hit = medium ? s.intersect(ray, its, *medium) : s.intersect(ray, its);
            tt(i) = hit ? its.t : kInfinity;
            ss(i) = hit ? its.shape : -1;
            for (int k = 0; k < 3; ++k) nn(i, k) = hit ? its.n[k] : 0.0;
        }
        return py::make_tuple(t, shape, n);
    }, py::arg("scene"), py::arg("o"), py::arg("d"), py::arg("medium") = py::none());
    // Per medium: the shape that holds it and nothing else (Scene::medium_container), or -1.
    m.def("medium_containers", [](Scene &s) {
        if (!s.built) s.build();
        return s.medium_container;
    });
    // The shape that holds all others (Geometry::enclosure), or -1.
    m.def("enclosure", [](Scene &s) {
        if (!s.built) s.build();
        return s.geometry.enclosure();
    });
    m.def("sphere_roots", [](Array3 center, double radius, Array3 o, Array3 d) -> py::object {
        double t0, t1;
        if (!sphere_roots(vec(center), radius, vec(o), normalize(vec(d)), t0, t1)) return py::none();
        return py::make_tuple(t0, t1);
    });
    // The optical depth a shadow ray to the sun takes through the air (table or quadrature).
    m.def("sun_optical_depth", [](Scene &s, int medium, Array3 o, Array3 d, double t_max) {
        const Spectrum tau = sun_optical_depth(s.media.at(size_t(medium)), Ray{vec(o), normalize(vec(d)), 0, t_max}, t_max);
        return std::array<double, 3>{tau.x, tau.y, tau.z};
    });
    // The guided free flight's tabulation of one ray through the air (lit by the scene's
    // sun): optical depths at distances ts, and collision distances with their densities
    // for the uniform numbers us.
    m.def("air_segment", [](Scene &s, int medium, Array3 o, Array3 d, double t_max, const DoubleArray &ts,
                            const DoubleArray &us) {
        if (!s.built) s.build();
        const auto &air = std::get<AtmosphereMedium>(s.media.at(size_t(medium)));
        const Ray ray{vec(o), normalize(vec(d)), 0, t_max};
        const AirSegment seg = air_segment(air, ray, t_max, s.sun_guide());
        py::array_t<double> tau({size_t(ts.shape(0)), size_t(3)}), t_out(us.shape(0)), pdf(us.shape(0));
        auto r = tau.mutable_unchecked<2>();
        for (py::ssize_t i = 0; i < ts.shape(0); ++i) {
            const Spectrum v = seg.optical_depth(ts.at(i));
            r(i, 0) = v.x, r(i, 1) = v.y, r(i, 2) = v.z;
        }
        for (py::ssize_t i = 0; i < us.shape(0); ++i) {
            Real t = 0, p = 0;
            if (!seg.sample(us.at(i), t, p)) t = p = std::numeric_limits<double>::quiet_NaN();
            t_out.mutable_at(i) = t, pdf.mutable_at(i) = p;
        }
        return py::make_tuple(tau, t_out, pdf);
    });
    // Where local shapes may shadow the sun along a ray (Scene::local_sun_shadow), with the
    // bounds it tests; (inf, -inf) for none.
    m.def("local_sun_shadow", [](Scene &s, Array3 o, Array3 d, double t0, double t1) {
        if (!s.built) s.build();
        const auto [a, b] = s.local_sun_shadow(Ray{vec(o), normalize(vec(d))}, t0, t1);
        const Bounds &box = s.local_bounds;
        return py::make_tuple(a, b, py::make_tuple(box.lo.x, box.lo.y, box.lo.z), py::make_tuple(box.hi.x, box.hi.y, box.hi.z));
    });
    // The light model of one guided segment (AirSegment::light_model at distances ts, and its
    // integral), with or without the sky map's scattered light.
    m.def("air_light_model", [](Scene &s, int medium, Array3 o, Array3 d, double t_max, const DoubleArray &ts,
                                bool with_map) {
        if (!s.built) s.build();
        const auto &air = std::get<AtmosphereMedium>(s.media.at(size_t(medium)));
        if (with_map && !air.sky_map) throw std::invalid_argument("the medium has no sky map");
        const AirSegment seg = air_segment(air, Ray{vec(o), normalize(vec(d)), 0, t_max}, t_max, s.sun_guide(),
                                           with_map ? air.sky_map.get() : nullptr);
        py::array_t<double> light({size_t(ts.shape(0)), size_t(3)});
        auto r = light.mutable_unchecked<2>();
        for (py::ssize_t i = 0; i < ts.shape(0); ++i) {
            const Spectrum v = seg.light_model(ts.at(i));
            r(i, 0) = v.x, r(i, 1) = v.y, r(i, 2) = v.z;
        }
        const Spectrum total = seg.light_integral();
        return py::make_tuple(light, Array3{total.x, total.y, total.z});
    });
    // The sky map seen from p: its pdf and radiance along dirs (n x 3), directions drawn for
    // the uniform numbers us (m x 3: the unit square and the level's choice) with the
    // densities sample() gives them, its Rayleigh integral for the incoming direction d_in,
    // and whether it models the light well enough for control variates.
    m.def("sky_map", [](Scene &s, int medium, Array3 p, Array3 d_in, const DoubleArray &dirs, const DoubleArray &us) {
        if (!s.built) s.build();
        const auto &air = std::get<AtmosphereMedium>(s.media.at(size_t(medium)));
        if (!air.sky_map) throw std::invalid_argument("the medium has no sky map");
        const SkyMap &map = *air.sky_map;
        const SkyMap::Point at = map.at(vec(p));
        const size_t n = size_t(dirs.shape(0)), k = size_t(us.shape(0));
        py::array_t<double> pdf(n), radiance({n, size_t(3)}), samples({k, size_t(3)}), sample_pdf(k);
        auto rad = radiance.mutable_unchecked<2>();
        for (size_t i = 0; i < n; ++i) {
            const Vec3 d = normalize(Vec3(dirs.at(i, 0), dirs.at(i, 1), dirs.at(i, 2)));
            pdf.mutable_at(i) = map.pdf(at, d);
            const Spectrum L = map.radiance(at, d);
            rad(i, 0) = L.x, rad(i, 1) = L.y, rad(i, 2) = L.z;
        }
        auto smp = samples.mutable_unchecked<2>();
        for (size_t i = 0; i < k; ++i) {
            Real q = 0;
            const Vec3 d = map.sample(at, {us.at(i, 0), us.at(i, 1)}, us.at(i, 2), q);
            smp(i, 0) = d.x, smp(i, 1) = d.y, smp(i, 2) = d.z;
            sample_pdf.mutable_at(i) = q;
        }
        const Spectrum ri = map.rayleigh_integral(at, normalize(vec(d_in)));
        py::dict out;
        out["pdf"] = pdf, out["radiance"] = radiance, out["samples"] = samples, out["sample_pdf"] = sample_pdf;
        out["rayleigh_integral"] = Array3{ri.x, ri.y, ri.z};
        out["models_light"] = map.models_light;
        out["levels"] = reinterpret_cast<uintptr_t>(map.levels.get());  // shared by maps that reuse them
        return out;
    });
    m.def("optical_depth", [](Scene &s, int medium, Array3 o, Array3 d, double t_max, int steps) {
        const Spectrum tau = optical_depth(s.media.at(size_t(medium)), Ray{vec(o), normalize(vec(d)), 0, t_max},
                                           t_max, steps);
        return Array3{tau.x, tau.y, tau.z};
    });
    // Mean of n ratio-tracking estimates per channel, each channel sampled with its own
    // majorant, and the standard errors; `residual`: residual ratio tracking.
    m.def("ratio_tracking", [](Scene &s, int medium, Array3 o, Array3 d, double t_max, int n, uint64_t seed,
                               bool residual) {
        const Medium &m = s.media.at(size_t(medium));
        const Ray ray{vec(o), normalize(vec(d)), 0, t_max};
        Spectrum sum(0.0), sum2(0.0);
        {
            py::gil_scoped_release release;
            for (int c = 0; c < 3; ++c) {
                for (int i = 0; i < n; ++i) {
                    Sampler rng(seed, uint64_t(c), uint64_t(i));
                    const Real T = ratio_tracking(m, ray, t_max, c, rng, residual)[c];
                    sum[c] += T;
                    sum2[c] += T * T;
                }
            }
        }
        const Spectrum mean = sum / Real(n), var = clamp_zero(sum2 / Real(n) - mean * mean);
        return py::make_tuple(Array3{mean.x, mean.y, mean.z},
                              Array3{std::sqrt(var.x / n), std::sqrt(var.y / n), std::sqrt(var.z / n)});
    }, py::arg("scene"), py::arg("medium"), py::arg("o"), py::arg("d"), py::arg("t_max"), py::arg("n"),
       py::arg("seed"), py::arg("residual") = false);
    m.def("light_sample", [](Scene &s, int light, Array3 ref, const DoubleArray &u) {
        if (!s.built) s.build();
        if (light < 0 || light >= int(s.lights.size())) throw std::out_of_range("no such light");
        const size_t n = size_t(u.shape(0));
        py::array_t<double> dirs({n, size_t(3)}), pdfs(n);
        auto d = dirs.mutable_unchecked<2>();
        auto p = pdfs.mutable_unchecked<1>();
        for (size_t i = 0; i < n; ++i) {
            LightSample ls;
            const bool ok = sample_light(s.lights[light], s.geometry, vec(ref), {u.at(i, 0), u.at(i, 1)}, ls);
            d(i, 0) = ls.d.x, d(i, 1) = ls.d.y, d(i, 2) = ls.d.z;
            p(i) = ok ? ls.pdf : 0.0;
        }
        return py::make_tuple(dirs, pdfs);
    });
    // Solid-angle pdf of light `light` along directions d from ref, found by tracing rays.
    m.def("light_pdf", [](Scene &s, int light, Array3 ref, const DoubleArray &dirs) {
        if (!s.built) s.build();
        const Light &l = s.lights.at(size_t(light));
        const std::vector<Vec3> ds = points(dirs, "directions");
        py::array_t<double> out(ds.size());
        auto o = out.mutable_unchecked<1>();
        for (size_t i = 0; i < ds.size(); ++i) {
            const Vec3 d = normalize(ds[i]);
            Intersection its;
            o(i) = 0.0;
            if (const auto *area = std::get_if<AreaLight>(&l)) {
                if (!s.intersect(Ray{vec(ref), d, 0, kInfinity}, its) || its.shape != area->shape ||
                    dot(its.n, d) >= 0)
                    continue;
            }
            o(i) = light_pdf(l, s.geometry, vec(ref), d, its);
        }
        return out;
    });
    m.def("bsdf_sample", [](Scene &s, int bsdf, Array3 wi, const DoubleArray &u) {
        const size_t n = size_t(u.shape(0));
        py::array_t<double> dirs({n, size_t(3)}), pdfs(n);
        auto d = dirs.mutable_unchecked<2>();
        auto p = pdfs.mutable_unchecked<1>();
        for (size_t i = 0; i < n; ++i) {
            BSDFSample bs;
            const bool ok = bsdf_sample(s.bsdfs.at(size_t(bsdf)), normalize(vec(wi)), u.at(i, 0), {u.at(i, 1), u.at(i, 2)}, bs);
            d(i, 0) = bs.wo.x, d(i, 1) = bs.wo.y, d(i, 2) = bs.wo.z;
            p(i) = ok ? bs.pdf : 0.0;
        }
        return py::make_tuple(dirs, pdfs);
    });
    m.def("bsdf_pdf", [](Scene &s, int bsdf, Array3 wi, const DoubleArray &wos) {
        const std::vector<Vec3> ds = points(wos, "directions");
        py::array_t<double> out(ds.size());
        auto o = out.mutable_unchecked<1>();
        for (size_t i = 0; i < ds.size(); ++i)
            o(i) = bsdf_pdf(s.bsdfs.at(size_t(bsdf)), normalize(vec(wi)), normalize(ds[i]));
        return out;
    });
}
