// pybind11 glue for volpath._core: conversions and GIL handling only. The tests' probes
// into the core's parts are a module of their own (probes.cpp: volpath._probes).
#include <pybind11/native_enum.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>

#include "convert.h"
#include "volpath/mesh_files.h"
#include "volpath/render.h"

using namespace volpath;
using namespace volpath::bindings;

namespace {

using GridPtr = std::shared_ptr<VoxelGrid>;

// (z, y, x, c) float32 -> sparse VoxelGrid, c in {1, 3}.
GridPtr grid_from_dense(const FloatArray &a) {
    if (a.ndim() != 4 || (a.shape(3) != 1 && a.shape(3) != 3) || a.shape(0) < 1 || a.shape(1) < 1 || a.shape(2) < 1)
        throw std::invalid_argument("expected a grid of shape (z, y, x, 1 or 3)");
    const int res[3] = {int(a.shape(2)), int(a.shape(1)), int(a.shape(0))};
    return std::make_shared<VoxelGrid>(sparse_grid(a.data(), res, int(a.shape(3))));
}

// Bricks as OpenVDB leaves hand them over: an index per brick (bz, by, bx), -1 for an empty
// brick, into `bricks` of shape (n, 8, 8, 8, c) laid out (z, y, x) inside.
GridPtr grid_from_bricks(std::array<int, 3> res,
                         const py::array_t<int32_t, py::array::c_style | py::array::forcecast> &index,
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

// A new light, or (replace >= 0) that light replaced: an animation's next frame, a light
// edited in the viewport.
int add_or_replace(Scene &s, const Light &l, int replace, int hidden_from) {
    if (replace < 0) return s.add_light(l, uint8_t(hidden_from));
    s.set_light(replace, l, uint8_t(hidden_from));
    return replace;
}

ShapeInfo shape_info(int bsdf, int interior, int exterior, bool medium_interface, int hidden_from) {
    ShapeInfo info;
    info.bsdf = bsdf;
    info.interior = interior, info.exterior = exterior;
    info.medium_interface = medium_interface;
    if (hidden_from < 0 || hidden_from > 63) throw std::invalid_argument("hidden_from must be RayKind bits (0-63)");
    info.hidden_from = uint8_t(hidden_from);
    return info;
}

// Checks what the core assumes of its settings, with the parameter's name in the message.
void check(const RenderSettings &s) {
    const TracerConfig &t = s.tracer;
    if (s.spp < 1) throw std::invalid_argument("spp must be at least 1, got " + std::to_string(s.spp));
    if (s.threads < 0) throw std::invalid_argument("threads must be 0 (all cores) or more");
    if (t.max_depth == 0 || t.max_depth < -1)
        throw std::invalid_argument("max_depth must be -1 (unlimited) or at least 1");
    if (t.rr_depth < 1) throw std::invalid_argument("rr_depth must be at least 1");
    if (t.max_null_collisions < 1) throw std::invalid_argument("max_null_collisions must be at least 1");
}

py::tuple render_py(Scene &scene, RenderSettings settings, py::object progress_cb, py::object out, py::object starts,
                    py::object counts, py::object halves, py::object features) {
    check(settings);
    if (!scene.built) scene.build();
    check_tracer_supports(scene, settings.tracer.tracer);
    // Adaptive rendering's per-pixel arrays, used in place (the caller keeps them alive).
    const auto pixel_array = [&](py::object a, const char *name, std::vector<py::ssize_t> shape, auto *type) {
        using T = std::remove_pointer_t<decltype(type)>;
        if (a.is_none()) return static_cast<T *>(nullptr);
        auto array = py::array_t<T>::ensure(a);
        if (!array || array.ptr() != a.ptr() || !(array.flags() & py::array::c_style) || !array.writeable() ||
            std::vector<py::ssize_t>(array.shape(), array.shape() + array.ndim()) != shape)
            throw std::invalid_argument(
                std::string(name) + " must be a writeable C-contiguous array of shape (height, width" +
                (shape.size() > 2 ? ", 2, 3)" : ")") + " and dtype " + py::str(py::dtype::of<T>()).cast<std::string>());
        return array.mutable_data();
    };
    const py::ssize_t h = scene.camera.height, w = scene.camera.width;
    settings.starts = pixel_array(starts, "starts", {h, w}, static_cast<uint32_t *>(nullptr));
    settings.counts = pixel_array(counts, "counts", {h, w}, static_cast<uint32_t *>(nullptr));
    settings.halves = pixel_array(halves, "halves", {h, w, 2, 3}, static_cast<double *>(nullptr));
    settings.features = pixel_array(features, "features", {h, w, 8}, static_cast<double *>(nullptr));

    // Rendering into a caller's array lets a progress callback show finished tiles.
    py::array_t<float> image;
    if (out.is_none()) {
        image = py::array_t<float>({scene.camera.height, scene.camera.width, 3});
    } else {
        image = py::array_t<float>::ensure(out);
        if (!image || image.ndim() != 3 || image.shape(0) != scene.camera.height ||
            image.shape(1) != scene.camera.width || image.shape(2) != 3 || !image.writeable() ||
            !(image.flags() & py::array::c_style) || image.ptr() != out.ptr())
            throw std::invalid_argument(
                "out must be a writeable C-contiguous float32 array of shape (height, width, 3)");
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
                    const double done = progress.samples_total
                                            ? double(progress.samples_done.load()) / double(progress.samples_total)
                                            : 1.0;
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

// An (n, columns) array that owns the vector's memory (no copy), or None when it is empty.
template <class T>
py::object columns(std::vector<T> &&values, py::ssize_t width) {
    if (values.empty()) return py::none();
    auto *owned = new std::vector<T>(std::move(values));
    py::capsule owner(owned, [](void *p) { delete static_cast<std::vector<T> *>(p); });
    return py::array_t<T>({py::ssize_t(owned->size()) / width, width}, owned->data(), owner);
}

// (positions, triangles, normals or None, uvs or None) from read_obj or read_ply.
py::tuple mesh_file(MeshArrays (*read)(const std::string &), const std::string &path) {
    MeshArrays mesh;
    {
        py::gil_scoped_release release;
        mesh = read(path);
    }
    return py::make_tuple(columns(std::move(mesh.positions), 3), columns(std::move(mesh.triangles), 3),
                          columns(std::move(mesh.normals), 3), columns(std::move(mesh.uvs), 2));
}

// The render settings as Python sees them: every default is the C++ struct's own.
void bind_settings(py::module_ &m) {
    py::native_enum<Tracer>(m, "Tracer", "enum.Enum",
                            "The five tracers, each a superset of the one before (docs/tracers.md).")
        .value("absorption", Tracer::Absorption)
        .value("single", Tracer::Single)
        .value("multiple", Tracer::Multiple)
        .value("nee_mis", Tracer::NeeMis)
        .value("null_scattering", Tracer::NullScattering)
        .finalize();

    const TracerConfig t;
    static_assert(TracerConfig{}.tracer == Tracer::NullScattering, "the default's description below names it");
    py::class_<TracerConfig>(m, "TracerConfig", "Which tracer, and the bounds on its paths.")
        .def(py::init([](Tracer tracer, int max_depth, int rr_depth, int max_null_collisions, bool light_distances) {
                 return TracerConfig{tracer, max_depth, rr_depth, max_null_collisions, light_distances};
             }),
             py::kw_only(), py::arg_v("tracer", t.tracer, "Tracer.null_scattering"), py::arg("max_depth") = t.max_depth,
             py::arg("rr_depth") = t.rr_depth, py::arg("max_null_collisions") = t.max_null_collisions,
             py::arg("light_distances") = t.light_distances)
        .def_readwrite("tracer", &TracerConfig::tracer)
        .def_readwrite("max_depth", &TracerConfig::max_depth,
                       "Path segments as Mitsuba counts them: 1 = emitters seen directly, -1 = unlimited.")
        .def_readwrite("rr_depth", &TracerConfig::rr_depth, "Scattering events before Russian roulette may end a path.")
        .def_readwrite("max_null_collisions", &TracerConfig::max_null_collisions,
                       "Safety cap on null collisions per path segment.")
        .def_readwrite("light_distances", &TracerConfig::light_distances,
                       "NEE in homogeneous media also from distances drawn for the lights, combined by MIS.")
        .def("__repr__", [](const TracerConfig &c) {
            return "TracerConfig(tracer=" + py::repr(py::cast(c.tracer)).cast<std::string>() +
                   ", max_depth=" + std::to_string(c.max_depth) + ", rr_depth=" + std::to_string(c.rr_depth) +
                   ", max_null_collisions=" + std::to_string(c.max_null_collisions) +
                   ", light_distances=" + (c.light_distances ? "True" : "False") + ")";
        });

    const RenderSettings r;
    py::class_<RenderSettings>(m, "RenderSettings", "What one call of render() takes besides the scene.")
        .def(py::init([](int spp, uint64_t seed, uint64_t first_sample, bool low_discrepancy, int threads,
                         const TracerConfig &tracer) {
                 RenderSettings s;
                 s.spp = spp, s.seed = seed, s.first_sample = first_sample;
                 s.low_discrepancy = low_discrepancy, s.threads = threads, s.tracer = tracer;
                 return s;
             }),
             py::kw_only(), py::arg("spp") = r.spp, py::arg("seed") = r.seed, py::arg("first_sample") = r.first_sample,
             py::arg("low_discrepancy") = r.low_discrepancy, py::arg("threads") = r.threads,
             py::arg_v("tracer", r.tracer, "TracerConfig()"))
        .def_readwrite("spp", &RenderSettings::spp)
        .def_readwrite("seed", &RenderSettings::seed, "The same seed gives the same bits on any number of threads.")
        .def_readwrite("first_sample", &RenderSettings::first_sample,
                       "Sample indices first_sample .. first_sample + spp - 1.")
        .def_readwrite("low_discrepancy", &RenderSettings::low_discrepancy,
                       "Owen-scrambled Sobol; False: independent PCG32 numbers.")
        .def_readwrite("threads", &RenderSettings::threads, "Worker threads (0: all hardware threads).")
        .def_readwrite("tracer", &RenderSettings::tracer);
}

}  // namespace

PYBIND11_MODULE(_core, m) {
    m.doc() = "Volpath native core: scene model, tracers and render loop.";

    py::class_<VoxelGrid, GridPtr>(m, "VoxelGrid", "A sparse voxel grid (8^3 bricks, empty ones not stored).")
        .def_static("from_dense", &grid_from_dense, py::arg("data"))
        .def_static("from_bricks", &grid_from_bricks, py::arg("res"), py::arg("brick_index"), py::arg("bricks"))
        .def_property_readonly("res",
                               [](const VoxelGrid &g) {
                                   return std::array<int, 3>{g.res[0], g.res[1], g.res[2]};
                               })
        .def_property_readonly("channels", [](const VoxelGrid &g) { return g.channels; })
        .def_property_readonly("brick_index",
                               [](const GridPtr &g) {
                                   return view(g, g->brick_index, {g->bricks[2], g->bricks[1], g->bricks[0]});
                               })
        .def_property_readonly("bricks",
                               [](const GridPtr &g) {
                                   constexpr int B = VoxelGrid::kBrick;
                                   return view(g, g->data, {py::ssize_t(g->stored_bricks()), B, B, B, g->channels});
                               })
        .def_property_readonly("nbytes",
                               [](const VoxelGrid &g) {
                                   return g.data.size() * sizeof(float) + g.brick_index.size() * sizeof(int32_t) +
                                          sizeof(VoxelGrid);
                               })
        .def(
            "dense",
            [](const VoxelGrid &g) {
                FloatArray a({g.res[2], g.res[1], g.res[0], g.channels});
                float *out = a.mutable_data();
                for (int z = 0; z < g.res[2]; ++z)
                    for (int y = 0; y < g.res[1]; ++y)
                        for (int x = 0; x < g.res[0]; ++x)
                            for (int c = 0; c < g.channels; ++c) *out++ = g.voxel(x, y, z, c);
                return a;
            },
            "The grid as a dense float32 array (z, y, x, c).")
        .def(
            "lookup",
            [](const VoxelGrid &g, Array3 p) {
                const Spectrum v = g.lookup(vec(p));
                return Array3{v[0], v[1], v[2]};
            },
            py::arg("p"), "Trilinear lookup at a point of the unit cube.");

    py::class_<Scene>(m, "Scene")
        .def(py::init<>())
        .def("add_bsdf_null",
             [](Scene &s) {
                 return s.add_bsdf({NullBSDF{}, false});
             })
        .def(
            "add_bsdf_diffuse",
            [](Scene &s, Array3 r, bool twosided) {
                return s.add_bsdf({DiffuseBSDF{vec(r)}, twosided});
            },
            py::arg("reflectance"), py::arg("twosided") = false)
        .def(
            "add_bsdf_dielectric",
            [](Scene &s, double eta, Array3 reflectance, Array3 transmittance) {
                return s.add_bsdf({DielectricBSDF{eta, vec(reflectance), vec(transmittance)}, false});
            },
            py::arg("eta"), py::arg("reflectance") = Array3{1.0, 1.0, 1.0},
            py::arg("transmittance") = Array3{1.0, 1.0, 1.0})
        .def(
            "add_bsdf_roughplastic",
            [](Scene &s, Array3 diffuse, Array3 specular, double alpha, double eta, bool twosided) {
                return s.add_bsdf({rough_plastic(vec(diffuse), vec(specular), std::max(alpha, 1e-4), eta), twosided});
            },
            py::arg("diffuse"), py::arg("specular"), py::arg("alpha"), py::arg("eta"), py::arg("twosided") = false)
        .def(
            "add_bsdf_thindielectric",
            [](Scene &s, double eta) {
                return s.add_bsdf({ThinDielectricBSDF{eta}, false});
            },
            py::arg("eta"))
        .def(
            "add_bsdf_conductor",
            [](Scene &s, Array3 eta, Array3 k, Array3 specular, double alpha, bool twosided) {
                return s.add_bsdf({ConductorBSDF{vec(eta), vec(k), vec(specular), alpha}, twosided});
            },
            py::arg("eta"), py::arg("k"), py::arg("specular"), py::arg("alpha"), py::arg("twosided") = false)
        .def(
            "add_bsdf_roughdielectric",
            [](Scene &s, double eta, double alpha, Array3 reflectance, Array3 transmittance) {
                return s.add_bsdf(
                    {RoughDielectricBSDF{eta, std::max(alpha, 1e-4), vec(reflectance), vec(transmittance)}, false});
            },
            py::arg("eta"), py::arg("alpha"), py::arg("reflectance") = Array3{1.0, 1.0, 1.0},
            py::arg("transmittance") = Array3{1.0, 1.0, 1.0})
        .def(
            "add_bsdf_blend",
            [](Scene &s, int a, int b, double weight) {
                BSDF bsdf;
                bsdf.layer = BlendLayer{a, b, std::clamp(weight, 0.0, 1.0)};
                return s.add_bsdf(bsdf);
            },
            py::arg("a"), py::arg("b"), py::arg("weight"), "(1 - weight) a + weight b (blendbsdf).")
        .def(
            "add_bsdf_mask",
            [](Scene &s, int nested, double opacity) {
                BSDF bsdf;
                bsdf.layer = MaskLayer{nested, std::clamp(opacity, 0.0, 1.0)};
                return s.add_bsdf(bsdf);
            },
            py::arg("nested"), py::arg("opacity"), "The nested BSDF where opaque, else straight through (mask).")
        .def(
            "add_bsdf_normalmap",
            [](Scene &s, int nested, int texture, double strength) {
                BSDF bsdf;
                bsdf.layer = NormalMapLayer{nested, texture, strength};
                return s.add_bsdf(bsdf);
            },
            py::arg("nested"), py::arg("texture"), py::arg("strength") = 1.0,
            "The nested BSDF about normals from a tangent-space normal map (a raw texture).")
        .def(
            "add_bsdf_bumpmap",
            [](Scene &s, int nested, int texture, double scale, double strength) {
                BSDF bsdf;
                bsdf.layer = BumpMapLayer{nested, texture, scale, strength};
                return s.add_bsdf(bsdf);
            },
            py::arg("nested"), py::arg("texture"), py::arg("scale") = 1.0, py::arg("strength") = 1.0,
            "The nested BSDF on the surface displaced by scale * texture(uv) along its normal.")
        .def(
            "add_texture_bitmap",
            [](Scene &s, const py::array &texels, bool srgb, bool bilinear, const std::string &wrap,
               const std::optional<DoubleArray> &to_uv) {
                BitmapTexture t;
                if (texels.ndim() != 3 || (texels.shape(2) != 1 && texels.shape(2) != 3) || texels.shape(0) < 1 ||
                    texels.shape(1) < 1)
                    throw std::invalid_argument("texels must have shape (height, width, 1 or 3)");
                t.height = int(texels.shape(0)), t.width = int(texels.shape(1)), t.channels = int(texels.shape(2));
                if (py::isinstance<py::array_t<uint8_t>>(texels)) {
                    const auto a = py::array_t<uint8_t, py::array::c_style | py::array::forcecast>::ensure(texels);
                    t.bytes.assign(a.data(), a.data() + a.size());
                } else {
                    const auto a = FloatArray::ensure(texels);
                    if (!a) throw std::invalid_argument("texels must be uint8 or float");
                    t.floats.assign(a.data(), a.data() + a.size());
                    for (float v : t.floats)
                        if (!std::isfinite(v)) throw std::invalid_argument("texels must be finite");
                }
                t.srgb = srgb, t.bilinear = bilinear;
                if (wrap == "repeat")
                    t.wrap = BitmapTexture::Wrap::Repeat;
                else if (wrap == "mirror")
                    t.wrap = BitmapTexture::Wrap::Mirror;
                else if (wrap == "clamp")
                    t.wrap = BitmapTexture::Wrap::Clamp;
                else
                    throw std::invalid_argument("wrap must be 'repeat', 'mirror' or 'clamp'");
                t.to_uv = uv_transform(to_uv);
                return s.add_texture(std::move(t));
            },
            py::arg("texels"), py::arg("srgb"), py::arg("bilinear") = true, py::arg("wrap") = "repeat",
            py::arg("to_uv") = py::none(),
            "An image texture from texels (height, width, channels): uint8 (sRGB-encoded if srgb) or float (linear).")
        .def(
            "add_texture_checkerboard",
            [](Scene &s, Array3 color0, Array3 color1, const std::optional<DoubleArray> &to_uv) {
                return s.add_texture(CheckerboardTexture{vec(color0), vec(color1), uv_transform(to_uv)});
            },
            py::arg("color0"), py::arg("color1"), py::arg("to_uv") = py::none())
        .def(
            "bind_texture",
            [](Scene &s, int bsdf, const std::string &name, int texture, const DoubleArray &scale, Array3 offset,
               bool squared) {
                TexturedParam p;
                if (name == "reflectance")
                    p.name = TexturedParam::Name::Reflectance;
                else if (name == "specular")
                    p.name = TexturedParam::Name::Specular;
                else if (name == "alpha")
                    p.name = TexturedParam::Name::Alpha;
                else if (name == "weight")
                    p.name = TexturedParam::Name::Weight;
                else if (name == "opacity")
                    p.name = TexturedParam::Name::Opacity;
                else
                    throw std::invalid_argument(
                        "name must be 'reflectance', 'specular', 'alpha', 'weight' or 'opacity'");
                if (scale.ndim() != 2 || scale.shape(0) != 3 || scale.shape(1) != 3)
                    throw std::invalid_argument("scale must be a 3x3 matrix");
                p.texture = texture;
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j) p.scale[i][j] = scale.at(i, j);
                p.offset = vec(offset);
                p.squared = squared;
                s.bind_texture(bsdf, p);
            },
            py::arg("bsdf"), py::arg("name"), py::arg("texture"), py::arg("scale"), py::arg("offset"),
            py::arg("squared") = false, "Makes a BSDF parameter offset + scale @ texture(uv) (squared if asked).")
        .def(
            "add_medium_homogeneous",
            [](Scene &s, Array3 sigma_a, Array3 sigma_s, double g, Array3 Le) {
                return s.add_medium(HomogeneousMedium{vec(sigma_a), vec(sigma_s), phase(g), vec(Le)});
            },
            py::arg("sigma_a"), py::arg("sigma_s"), py::arg("g") = 0.0, py::arg("Le") = Array3{0.0, 0.0, 0.0})
        .def(
            "add_medium_grid",
            [](Scene &s, const GridPtr &density, const DoubleArray &world_to_grid,
               const std::optional<GridPtr> &albedo_grid, std::optional<DoubleArray> albedo_world_to_grid,
               Array3 albedo, double scale, double g, int majorant_res, const std::optional<GridPtr> &Le_grid,
               std::optional<DoubleArray> Le_world_to_grid, Array3 Le_scale) {
                if (!density) throw std::invalid_argument("a grid medium needs a density grid");
                GridMedium gm;
                gm.majorant_res = majorant_res;
                gm.density = placed(density, world_to_grid);
                gm.albedo_grid = placed(albedo_grid.value_or(nullptr), albedo_world_to_grid);
                gm.Le_grid = placed(Le_grid.value_or(nullptr), Le_world_to_grid);
                gm.Le_scale = vec(Le_scale);
                gm.albedo = vec(albedo);
                gm.scale = scale;
                gm.phase = phase(g);
                return s.add_medium(gm);
            },
            py::arg("density"), py::arg("world_to_grid"), py::arg("albedo_grid") = py::none(),
            py::arg("albedo_world_to_grid") = py::none(), py::arg("albedo") = Array3{1.0, 1.0, 1.0},
            py::arg("scale") = 1.0, py::arg("g") = 0.0, py::arg("majorant_res") = 0, py::arg("Le_grid") = py::none(),
            py::arg("Le_world_to_grid") = py::none(), py::arg("Le_scale") = Array3{0.0, 0.0, 0.0})
        .def(
            "add_mesh",
            [](Scene &s, const DoubleArray &positions, const TriangleArray &triangles,
               std::optional<DoubleArray> normals, int bsdf, int interior, int exterior, bool medium_interface,
               std::optional<Array3> radiance, std::optional<DoubleArray> uvs, int hidden_from, bool emitter_twosided,
               double emitter_spread, int emitter_hidden_from, int group, std::optional<DoubleArray> motion,
               int emitter_texture) {
                AreaEmission emission{radiance ? vec(*radiance) : Spectrum(0.0), emitter_twosided, emitter_spread,
                                      uint8_t(emitter_hidden_from)};
                emission.texture = emitter_texture;
                return s.add_shape_mesh(triangle_mesh(positions, triangles, normals, uvs, motion),
                                        shape_info(bsdf, interior, exterior, medium_interface, hidden_from),
                                        radiance ? &emission : nullptr, group);
            },
            py::arg("positions"), py::arg("triangles"), py::arg("normals"), py::arg("bsdf"), py::arg("interior") = -1,
            py::arg("exterior") = -1, py::arg("medium_interface") = false, py::arg("radiance") = py::none(),
            py::arg("uvs") = py::none(), py::arg("hidden_from") = 0, py::arg("emitter_twosided") = false,
            py::arg("emitter_spread") = kPi, py::arg("emitter_hidden_from") = 0, py::arg("group") = -1,
            py::arg("motion") = py::none(), py::arg("emitter_texture") = -1)
        .def("add_group", &Scene::add_group, "A new, empty shape group (Mitsuba's shapegroup); its index.")
        .def(
            "set_instances",
            [](Scene &s, const py::array_t<int, py::array::c_style | py::array::forcecast> &instances,
               const DoubleArray &to_world) {
                const std::vector<Transform> maps = transforms(to_world, "to_world");
                if (instances.ndim() != 1 || size_t(instances.shape(0)) != maps.size())
                    throw std::invalid_argument("expected one instance per transform");
                for (size_t i = 0; i < maps.size(); ++i) s.set_instance(instances.at(i), maps[i]);
            },
            "Moves instances (an animation's frame): their indices, in the order added, and new maps (n, 4, 4). "
            "build() then refits the BVH.",
            py::arg("instances"), py::arg("to_world"))
        .def(
            "set_instance_motion",
            [](Scene &s, int k, const DoubleArray &keys) {
                if (k < 0 || size_t(k) >= s.geometry.instances.size()) throw std::out_of_range("invalid instance");
                s.set_instance(k, s.geometry.instances[size_t(k)].to_world, motion_keys(keys));
            },
            "Instance k's motion over the shutter: its to_world at evenly spaced times from the shutter's opening "
            "to its closing (K >= 2, 4, 4), interpolated linearly between them (motion blur).",
            py::arg("instance"), py::arg("keys"))
        .def(
            "set_group_mesh",
            [](Scene &s, int shape, const DoubleArray &positions, const TriangleArray &triangles,
               std::optional<DoubleArray> normals, std::optional<DoubleArray> uvs, std::optional<DoubleArray> motion) {
                s.set_group_mesh(shape, triangle_mesh(positions, triangles, normals, uvs, motion));
            },
            "Replaces a shape group's mesh (a deformed mesh at an animation's frame); build() then rebuilds that "
            "group's BVH and refits the scene's.",
            py::arg("shape"), py::arg("positions"), py::arg("triangles"), py::arg("normals") = py::none(),
            py::arg("uvs") = py::none(), py::arg("motion") = py::none())
        .def("replace_bsdf", &Scene::replace_bsdf,
             "Gives BSDF `bsdf` the parameters of the last one added, which is taken off (a material's values at an "
             "animation's frame; a leaf BSDF without textures).",
             py::arg("bsdf"))
        .def(
            "add_instances",
            [](Scene &s, const py::array_t<int, py::array::c_style | py::array::forcecast> &groups,
               const DoubleArray &to_world) {
                const std::vector<Transform> maps = transforms(to_world, "to_world");
                if (groups.ndim() != 1 || size_t(groups.shape(0)) != maps.size())
                    throw std::invalid_argument("expected one group per transform");
                for (size_t i = 0; i < maps.size(); ++i) s.add_instance(groups.at(i), maps[i], maps[i].inverse());
            },
            "Instances of shape groups, one a transform (n, 4, 4): one call for a field of them.", py::arg("groups"),
            py::arg("to_world"))
        .def(
            "add_sphere",
            [](Scene &s, Array3 center, double radius, bool flip, int bsdf, int interior, int exterior,
               bool medium_interface, std::optional<Array3> radiance, int hidden_from, bool emitter_twosided,
               double emitter_spread, int emitter_hidden_from, std::optional<std::tuple<Array3, double, double>> spot,
               bool soft_falloff) {
                AreaEmission emission{radiance ? vec(*radiance) : Spectrum(0.0), emitter_twosided, emitter_spread,
                                      uint8_t(emitter_hidden_from)};
                if (spot) emission.spot = spot_cone(vec(std::get<0>(*spot)), std::get<1>(*spot), std::get<2>(*spot));
                emission.soft_falloff = soft_falloff;
                return s.add_shape_sphere(Sphere{vec(center), radius, flip},
                                          shape_info(bsdf, interior, exterior, medium_interface, hidden_from),
                                          radiance ? &emission : nullptr);
            },
            py::arg("center"), py::arg("radius"), py::arg("flip_normals"), py::arg("bsdf"), py::arg("interior") = -1,
            py::arg("exterior") = -1, py::arg("medium_interface") = false, py::arg("radiance") = py::none(),
            py::arg("hidden_from") = 0, py::arg("emitter_twosided") = false, py::arg("emitter_spread") = kPi,
            py::arg("emitter_hidden_from") = 0, py::arg("emitter_spot") = py::none(),
            py::arg("emitter_soft_falloff") = false)
        .def(
            "add_box",
            [](Scene &s, const DoubleArray &to_world, const DoubleArray &to_local, bool flip, int bsdf, int interior,
               int exterior, bool medium_interface, int hidden_from) {
                return s.add_shape_box(Box{transform(to_world), transform(to_local), flip},
                                       shape_info(bsdf, interior, exterior, medium_interface, hidden_from));
            },
            py::arg("to_world"), py::arg("to_local"), py::arg("flip_normals"), py::arg("bsdf"),
            py::arg("interior") = -1, py::arg("exterior") = -1, py::arg("medium_interface") = false,
            py::arg("hidden_from") = 0)
        .def(
            "add_medium_atmosphere",
            [](Scene &s, Array3 center, double planet_radius, double top_radius, Array3 rayleigh,
               double rayleigh_height, Array3 mie_s, Array3 mie_a, double mie_height, double g, Array3 ozone,
               int pieces, const std::string &sun_transmittance, const std::string &free_flight, bool sky_map) {
                AtmosphereMedium a;
                a.use_sky_map = sky_map;
                using S = AtmosphereMedium::SunTransmittance;
                if (sun_transmittance == "table")
                    a.sun_transmittance = S::Table;
                else if (sun_transmittance == "quadrature")
                    a.sun_transmittance = S::Quadrature;
                else if (sun_transmittance == "tracking")
                    a.sun_transmittance = S::Tracking;
                else
                    throw std::invalid_argument("sun_transmittance must be table, quadrature or tracking");
                if (free_flight == "guided")
                    a.free_flight = AtmosphereMedium::FreeFlight::Guided;
                else if (free_flight == "tracking")
                    a.free_flight = AtmosphereMedium::FreeFlight::Tracking;
                else
                    throw std::invalid_argument("free_flight must be guided or tracking");
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
            py::arg("rayleigh_height"), py::arg("mie_scattering"), py::arg("mie_absorption"), py::arg("mie_height"),
            py::arg("g"), py::arg("ozone"), py::arg("pieces") = 4, py::arg("sun_transmittance") = "table",
            py::arg("free_flight") = "guided", py::arg("sky_map") = true)
        .def(
            "add_sun",
            [](Scene &s, Array3 to_sun, double angular_radius, Array3 irradiance, int replace, int hidden_from) {
                return add_or_replace(s, sun_light(vec(to_sun), angular_radius, vec(irradiance)), replace, hidden_from);
            },
            py::arg("to_sun"), py::arg("angular_radius"), py::arg("irradiance"), py::arg("replace") = -1,
            py::arg("hidden_from") = 0)
        .def(
            "add_point_light",
            [](Scene &s, Array3 p, Array3 intensity, int replace, int hidden_from) {
                return add_or_replace(s, PointLight{vec(p), vec(intensity)}, replace, hidden_from);
            },
            py::arg("position"), py::arg("intensity"), py::arg("replace") = -1, py::arg("hidden_from") = 0)
        .def(
            "add_spot_light",
            [](Scene &s, Array3 p, Array3 direction, double half_angle, double blend, Array3 intensity, int replace,
               int hidden_from) {
                const PointLight light{vec(p), vec(intensity), spot_cone(vec(direction), half_angle, blend)};
                return add_or_replace(s, light, replace, hidden_from);
            },
            "A point light whose light leaves within a cone (half_angle in radians), its outer `blend` share "
            "fading by a smoothstep (Blender's spot lamp).",
            py::arg("position"), py::arg("direction"), py::arg("half_angle"), py::arg("blend"), py::arg("intensity"),
            py::arg("replace") = -1, py::arg("hidden_from") = 0)
        .def(
            "add_directional_light",
            [](Scene &s, Array3 d, Array3 irradiance, int replace, int hidden_from) {
                return add_or_replace(s, DirectionalLight{normalize(vec(d)), vec(irradiance)}, replace, hidden_from);
            },
            py::arg("direction"), py::arg("irradiance"), py::arg("replace") = -1, py::arg("hidden_from") = 0)
        .def(
            "add_environment",
            [](Scene &s, Array3 scale, std::optional<FloatArray> image, const DoubleArray &to_world,
               const DoubleArray &to_local, int replace, int hidden_from) {
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
                    for (size_t i = 0; i < env.pixels.size(); ++i)
                        env.pixels[i] = {p[3 * i], p[3 * i + 1], p[3 * i + 2]};
                }
                return add_or_replace(s, env, replace, hidden_from);
            },
            py::arg("scale"), py::arg("image"), py::arg("to_world"), py::arg("to_local"), py::arg("replace") = -1,
            py::arg("hidden_from") = 0)
        .def(
            "set_camera",
            [](Scene &s, const DoubleArray &to_world, double tan_x, double tan_y, int width, int height,
               double near_clip, double far_clip, int medium, bool gaussian, double shift_x, double shift_y,
               std::optional<DoubleArray> motion) {
                if (width < 1 || height < 1) throw std::invalid_argument("film size must be positive");
                Camera &c = s.camera;
                c.to_world = transform(to_world);
                c.motion = motion ? motion_keys(*motion) : MotionKeys{};
                c.tan_half_x = tan_x, c.tan_half_y = tan_y;
                c.shift_x = shift_x, c.shift_y = shift_y;
                c.width = width, c.height = height;
                c.near_clip = near_clip, c.far_clip = far_clip;
                c.medium = medium;
                c.gaussian_filter = gaussian;
                s.built = false;
            },
            py::arg("to_world"), py::arg("tan_x"), py::arg("tan_y"), py::arg("width"), py::arg("height"),
            py::arg("near_clip"), py::arg("far_clip"), py::arg("medium"), py::arg("gaussian"), py::arg("shift_x") = 0.0,
            py::arg("shift_y") = 0.0, py::arg("motion") = py::none())
        .def("build",
             [](Scene &s) {
                 py::gil_scoped_release release;
                 s.build();
             })
        .def_property_readonly("width", [](const Scene &s) { return s.camera.width; })
        .def_property_readonly("height", [](const Scene &s) { return s.camera.height; })
        .def_property_readonly("light_count", [](const Scene &s) { return s.lights.size(); })
        .def_property_readonly("memory",
                               [](const Scene &s) {
                                   py::dict out;
                                   for (const auto &[part, n] : s.memory()) out[py::str(part)] = n;
                                   return out;
                               })
        .def("__repr__", [](const Scene &s) { return "<volpath._core.Scene: " + s.describe() + ">"; });

    bind_settings(m);
    m.def("render", &render_py, py::arg("scene"), py::arg("settings"), py::kw_only(), py::arg("progress") = py::none(),
          py::arg("out") = py::none(), py::arg("starts") = py::none(), py::arg("counts") = py::none(),
          py::arg("halves") = py::none(), py::arg("features") = py::none(),
          "Renders the scene: (image float32 (height, width, 3), stats dict). progress(fraction) is called from "
          "this thread about 20 times a second (False cancels). Adaptive rendering: pixel p takes counts[p] samples "
          "from first_sample + starts[p] on (uint32, (height, width)), summing even and odd samples into halves "
          "(float64, (height, width, 2, 3)); features (float64, (height, width, 8)) sums the first surface's albedo, "
          "normal, depth and hit count. Those arrays are written in place.");

    py::register_exception<MeshFileError>(m, "MeshFileError", PyExc_ValueError);
    m.def(
        "read_obj", [](const std::string &path) { return mesh_file(read_obj, path); }, py::arg("path"),
        "(positions, triangles, normals or None, uvs or None) from a Wavefront OBJ file.");
    m.def(
        "read_ply", [](const std::string &path) { return mesh_file(read_ply, path); }, py::arg("path"),
        "(positions, triangles, normals or None, uvs or None) from a PLY file (ASCII or binary).");
}
