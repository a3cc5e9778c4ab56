// volpath._probes, a module for the tests only: the core's parts (samplers, media, lights and
// BSDFs) on their own, for chi-square tests and oracles. The wheel leaves it out.
#include <limits>

#include "convert.h"
#include "volpath/light_distances.h"
#include "volpath/render.h"
#include "volpath/sky_map.h"

using namespace volpath;
using namespace volpath::bindings;

PYBIND11_MODULE(_probes, m) {
    m.doc() = "Volpath's test probes into the core's parts (built for the tests, not in the wheel).";
    py::module_::import("volpath._core");  // the Scene type the probes take
    // The pixel sampler's numbers: (samples, dimensions, 2) from next_2d, or
    // (samples, dimensions) from next_1d, for the sampler's own tests.
    // split_after >= 0: the values of the stream split off after that many dimensions (the
    // branch of a camera ray forced to collide in a medium).
    m.def(
        "sampler_values",
        [](uint64_t seed, uint64_t pixel, int samples, int dimensions, bool low_discrepancy, bool two_d,
           int split_after) {
            if (samples < 1 || dimensions < 1) throw std::invalid_argument("samples and dimensions must be positive");
            std::vector<py::ssize_t> shape{samples, dimensions};
            if (two_d) shape.push_back(2);
            py::array_t<double> out(shape);
            double *o = out.mutable_data();
            for (int i = 0; i < samples; ++i) {
                Sampler parent(seed, pixel, uint64_t(i), low_discrepancy);
                for (int d = 0; d < split_after; ++d) parent.next_1d();
                Sampler sampler = split_after >= 0 ? parent.split(1) : parent;
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
        },
        py::arg("seed"), py::arg("pixel"), py::arg("samples"), py::arg("dimensions"), py::arg("low_discrepancy"),
        py::arg("two_d"), py::arg("split_after") = -1);

    // How often a ChoiceChain over `probabilities` makes its first choice at each of them
    // (the last count: none made), one chain per pixel sample, for its chi-square test.
    m.def(
        "choice_chain_counts",
        [](const std::vector<double> &probabilities, uint64_t seed, int pixels, int samples, bool low_discrepancy) {
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
        },
        py::arg("probabilities"), py::arg("seed"), py::arg("pixels"), py::arg("samples"), py::arg("low_discrepancy"));

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
    m.def(
        "light_distance_count",
        [light_distances](const Scene &s, int light, Array3 o, Array3 d, double t0, double t1, Array3 sigma_t) {
            return light_distances(s, light, o, d, t0, t1, sigma_t).count;
        },
        py::arg("scene"), py::arg("light"), py::arg("o"), py::arg("d"), py::arg("t0"), py::arg("t1"),
        py::arg("sigma_t"));
    m.def(
        "light_distance_sample",
        [light_distances](const Scene &s, int light, Array3 o, Array3 d, double t0, double t1, Array3 sigma_t,
                          int channel, int k, const DoubleArray &u) {
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
        },
        py::arg("scene"), py::arg("light"), py::arg("o"), py::arg("d"), py::arg("t0"), py::arg("t1"),
        py::arg("sigma_t"), py::arg("channel"), py::arg("k"), py::arg("u"));
    m.def(
        "light_distance_density",
        [light_distances](const Scene &s, int light, Array3 o, Array3 d, double t0, double t1, Array3 sigma_t,
                          double t) {
            const Spectrum p = light_distances(s, light, o, d, t0, t1, sigma_t).density(t);
            return std::array<double, 3>{p.x, p.y, p.z};
        },
        py::arg("scene"), py::arg("light"), py::arg("o"), py::arg("d"), py::arg("t0"), py::arg("t1"),
        py::arg("sigma_t"), py::arg("t"));
    // Majorant pieces of a medium along a ray: (t0, t1, sigma_maj, sigma_min) rows.
    m.def("majorant_segments", [](Scene &s, int medium, Array3 o, Array3 d, double t_max) {
        MajorantIterator pieces(s.media.at(size_t(medium)), Ray{vec(o), normalize(vec(d)), 0, t_max}, t_max);
        std::vector<std::array<double, 8>> rows;
        MajorantSegment g;
        while (pieces.next(g))
            rows.push_back(
                {g.t0, g.t1, g.sigma_maj.x, g.sigma_maj.y, g.sigma_maj.z, g.sigma_min.x, g.sigma_min.y, g.sigma_min.z});
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
    // with the shortcuts of Scene::intersect. `time`: the rays' time in the shutter.
    m.def(
        "intersect",
        [](Scene &s, const DoubleArray &o, const DoubleArray &d, std::optional<int> medium, double time) {
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
                const Ray ray{os[i], normalize(ds[i]), 0, kInfinity, time};
                const bool hit = medium ? s.intersect(ray, its, *medium) : s.intersect(ray, its);
                tt(i) = hit ? its.t : kInfinity;
                ss(i) = hit ? its.shape : -1;
                for (int k = 0; k < 3; ++k) nn(i, k) = hit ? its.n[k] : 0.0;
            }
            return py::make_tuple(t, shape, n);
        },
        py::arg("scene"), py::arg("o"), py::arg("d"), py::arg("medium") = py::none(), py::arg("time") = 0.0);
    // Per ray: whether it hits anything before t_max (Geometry::occluded, the shadow rays' query).
    m.def(
        "occluded",
        [](Scene &s, const DoubleArray &o, const DoubleArray &d, const DoubleArray &t_max) {
            if (!s.built) s.build();
            const std::vector<Vec3> os = points(o, "origins"), ds = points(d, "directions");
            if (os.size() != ds.size() || t_max.ndim() != 1 || size_t(t_max.shape(0)) != os.size())
                throw std::invalid_argument("need as many origins, directions and t_max");
            py::array_t<bool> out(os.size());
            auto oo = out.mutable_unchecked<1>();
            for (size_t i = 0; i < os.size(); ++i)
                oo(i) = s.geometry.occluded(Ray{os[i], normalize(ds[i]), 0, t_max.at(i)});
            return out;
        },
        py::arg("scene"), py::arg("o"), py::arg("d"), py::arg("t_max"));
    m.def("shadows_stop_at_any_hit", [](Scene &s) {
        s.build();
        return s.context.shadows_stop_at_any_hit;
    });
    // Per medium: the shape that holds it and nothing else (RenderContext::medium_container), or -1.
    // Per shape: whether it is a null medium boundary that a surface may lie on.
    m.def("boundary_with_contact", [](Scene &s) {
        s.build();
        return std::vector<bool>(s.context.boundary_with_contact.begin(), s.context.boundary_with_contact.end());
    });
    m.def("medium_containers", [](Scene &s) {
        if (!s.built) s.build();
        return s.context.medium_container;
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
        const Spectrum tau =
            sun_optical_depth(s.media.at(size_t(medium)), Ray{vec(o), normalize(vec(d)), 0, t_max}, t_max);
        return std::array<double, 3>{tau.x, tau.y, tau.z};
    });
    // The guided free flight's tabulation of one ray through the air (lit by the scene's
    // sun): optical depths at distances ts, and collision distances with their densities
    // for the uniform numbers us.
    m.def("air_segment",
          [](Scene &s, int medium, Array3 o, Array3 d, double t_max, const DoubleArray &ts, const DoubleArray &us) {
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
        const Bounds &box = s.context.local_bounds;
        return py::make_tuple(a, b, py::make_tuple(box.lo.x, box.lo.y, box.lo.z),
                              py::make_tuple(box.hi.x, box.hi.y, box.hi.z));
    });
    // The light model of one guided segment (AirSegment::light_model at distances ts, and its
    // integral), with or without the sky map's scattered light.
    m.def("air_light_model",
          [](Scene &s, int medium, Array3 o, Array3 d, double t_max, const DoubleArray &ts, bool with_map) {
              if (!s.built) s.build();
              const auto &air = std::get<AtmosphereMedium>(s.media.at(size_t(medium)));
              const SkyMap *map = s.sky_map(medium);
              if (with_map && !map) throw std::invalid_argument("the medium has no sky map");
              const AirSegment seg = air_segment(air, Ray{vec(o), normalize(vec(d)), 0, t_max}, t_max, s.sun_guide(),
                                                 with_map ? map : nullptr);
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
        std::get<AtmosphereMedium>(s.media.at(size_t(medium)));  // (throws for another medium)
        if (!s.sky_map(medium)) throw std::invalid_argument("the medium has no sky map");
        const SkyMap &map = *s.sky_map(medium);
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
        const Spectrum tau =
            optical_depth(s.media.at(size_t(medium)), Ray{vec(o), normalize(vec(d)), 0, t_max}, t_max, steps);
        return Array3{tau.x, tau.y, tau.z};
    });
    // Mean of n ratio-tracking estimates per channel, each channel sampled with its own
    // majorant, and the standard errors; `residual`: residual ratio tracking.
    m.def(
        "ratio_tracking",
        [](Scene &s, int medium, Array3 o, Array3 d, double t_max, int n, uint64_t seed, bool residual) {
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
        },
        py::arg("scene"), py::arg("medium"), py::arg("o"), py::arg("d"), py::arg("t_max"), py::arg("n"),
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
                if (!s.intersect(Ray{vec(ref), d, 0, kInfinity}, its) || its.shape != area->shape || dot(its.n, d) >= 0)
                    continue;
            }
            o(i) = light_pdf(l, s.geometry, vec(ref), d, its);
        }
        return out;
    });
    // The texture coordinates where each ray hits, (n, 2); NaN where it misses.
    m.def("surface_uv", [](Scene &s, const DoubleArray &origins, const DoubleArray &dirs) {
        const std::vector<Vec3> os = points(origins, "origins"), ds = points(dirs, "directions");
        if (os.size() != ds.size()) throw std::invalid_argument("origins and directions differ in number");
        py::array_t<double> out({os.size(), size_t(2)});
        auto o = out.mutable_unchecked<2>();
        for (size_t i = 0; i < os.size(); ++i) {
            Intersection its;
            const bool hit = s.intersect(Ray{os[i], normalize(ds[i]), 0, kInfinity}, its);
            const Vec2 uv = hit ? s.geometry.uv(its) : Vec2{std::nan(""), std::nan("")};
            o(i, 0) = uv.x, o(i, 1) = uv.y;
        }
        return out;
    });
    // A texture's (linear) value at each (u, v), (n, 3).
    m.def("texture_eval", [](Scene &s, int texture, const DoubleArray &uvs) {
        if (uvs.ndim() != 2 || uvs.shape(1) != 2) throw std::invalid_argument("uvs must have shape (n, 2)");
        const size_t n = size_t(uvs.shape(0));
        py::array_t<double> out({n, size_t(3)});
        auto o = out.mutable_unchecked<2>();
        for (size_t i = 0; i < n; ++i) {
            const Spectrum v = eval_texture(s.textures.at(size_t(texture)), {uvs.at(i, 0), uvs.at(i, 1)});
            o(i, 0) = v.x, o(i, 1) = v.y, o(i, 2) = v.z;
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
            const bool ok =
                bsdf_sample(s.bsdfs.at(size_t(bsdf)), normalize(vec(wi)), u.at(i, 0), {u.at(i, 1), u.at(i, 2)}, bs);
            d(i, 0) = bs.wo.x, d(i, 1) = bs.wo.y, d(i, 2) = bs.wo.z;
            p(i) = ok ? bs.pdf : 0.0;
        }
        return py::make_tuple(dirs, pdfs);
    });
    // A layered BSDF's samples where the ray (origin, direction) meets the scene: per row of
    // u (layer choice, lobe, 2D), the direction (in the resolved shading frame, as wi), the
    // weight (f |cos wo| / pdf, 0 where the sampler fails) and whether the ray passed
    // straight through (then the direction is -wi).
    m.def("surface_sample", [](Scene &s, int bsdf, Array3 wi, const DoubleArray &u, Array3 origin, Array3 direction) {
        Intersection its;
        if (!s.intersect(Ray{vec(origin), normalize(vec(direction))}, its))
            throw std::invalid_argument("the ray meets nothing");
        const Vec3 w = normalize(vec(wi));
        const size_t n = size_t(u.shape(0));
        py::array_t<double> dirs({n, size_t(3)}), weights({n, size_t(3)});
        py::array_t<bool> passed(n);
        auto d = dirs.mutable_unchecked<2>();
        auto o = weights.mutable_unchecked<2>();
        auto p = passed.mutable_unchecked<1>();
        for (size_t i = 0; i < n; ++i) {
            SurfacePoint surface;
            surface_at(s, bsdf, its, u.at(i, 0), surface);
            BSDFSample bs;
            p(i) = surface.bsdf == nullptr;
            if (p(i)) bs.wo = -w, bs.weight = Spectrum(1.0);
            const bool ok = p(i) || bsdf_sample(*surface.bsdf, w, u.at(i, 1), {u.at(i, 2), u.at(i, 3)}, bs);
            const Spectrum weight = ok ? bs.weight : Spectrum(0.0);
            d(i, 0) = bs.wo.x, d(i, 1) = bs.wo.y, d(i, 2) = bs.wo.z;
            o(i, 0) = weight.x, o(i, 1) = weight.y, o(i, 2) = weight.z;
        }
        return py::make_tuple(dirs, weights, passed);
    });
    m.def("bsdf_pdf", [](Scene &s, int bsdf, Array3 wi, const DoubleArray &wos) {
        const std::vector<Vec3> ds = points(wos, "directions");
        py::array_t<double> out(ds.size());
        auto o = out.mutable_unchecked<1>();
        for (size_t i = 0; i < ds.size(); ++i)
            o(i) = bsdf_pdf(s.bsdfs.at(size_t(bsdf)), normalize(vec(wi)), normalize(ds[i]));
        return out;
    });
    // The weight (f |cos wo| / pdf) of each sample bsdf_sample draws, (n, 3); 0 where it fails.
    m.def("bsdf_sample_weight", [](Scene &s, int bsdf, Array3 wi, const DoubleArray &u) {
        const size_t n = size_t(u.shape(0));
        py::array_t<double> out({n, size_t(3)});
        auto o = out.mutable_unchecked<2>();
        for (size_t i = 0; i < n; ++i) {
            BSDFSample bs;
            const bool ok =
                bsdf_sample(s.bsdfs.at(size_t(bsdf)), normalize(vec(wi)), u.at(i, 0), {u.at(i, 1), u.at(i, 2)}, bs);
            const Spectrum w = ok ? bs.weight : Spectrum(0.0);
            o(i, 0) = w.x, o(i, 1) = w.y, o(i, 2) = w.z;
        }
        return out;
    });
    // f(wi, wo) |cos wo| per direction, (n, 3).
    m.def("bsdf_eval", [](Scene &s, int bsdf, Array3 wi, const DoubleArray &wos) {
        const std::vector<Vec3> ds = points(wos, "directions");
        py::array_t<double> out({ds.size(), size_t(3)});
        auto o = out.mutable_unchecked<2>();
        for (size_t i = 0; i < ds.size(); ++i) {
            const Spectrum f = bsdf_eval(s.bsdfs.at(size_t(bsdf)), normalize(vec(wi)), normalize(ds[i]));
            o(i, 0) = f.x, o(i, 1) = f.y, o(i, 2) = f.z;
        }
        return out;
    });
}
