// pybind11 bindings: hairbsdf._core. Batch calls take C-contiguous float64 arrays
// (the Python layer validates and converts), release the GIL and split the batch
// across threads. Directions are in the fibre frame (tangent = +x), docs/conventions.md.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

#include "hairbsdf/albedo.h"
#include "hairbsdf/closures.h"
#include "hairbsdf/params/materialx.h"
#include "hairbsdf/params/principled_hair.h"

namespace py = pybind11;
using namespace hairbsdf;

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

std::atomic<int> g_num_threads{int(std::max(1u, std::thread::hardware_concurrency()))};

// Runs fn(begin, end) over [0, n) in contiguous chunks on up to g_num_threads threads.
template <class Fn>
void parallel_for(size_t n, size_t min_chunk, Fn fn) {
    const size_t threads = std::min<size_t>(size_t(g_num_threads.load()), (n + min_chunk - 1) / min_chunk);
    if (threads <= 1) {
        fn(size_t(0), n);
        return;
    }
    std::vector<std::thread> pool;
    const size_t chunk = (n + threads - 1) / threads;
    for (size_t t = 0; t < threads; ++t) {
        const size_t begin = t * chunk, end = std::min(n, begin + chunk);
        if (begin >= end) break;
        pool.emplace_back([=, &fn] { fn(begin, end); });
    }
    for (auto& th : pool) th.join();
}

Vec3 vec_at(const double* p, size_t i) { return {p[3 * i], p[3 * i + 1], p[3 * i + 2]}; }
RGB rgb_from(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

ShadingContext fibre_context(const double* wo, const double* h, size_t i) {
    ShadingContext ctx;
    ctx.tangent = {1, 0, 0};
    ctx.wo = vec_at(wo, i);
    ctx.h = h[i];
    return ctx;
}

void store(double* out, size_t i, RGB c) {
    out[3 * i] = c.r;
    out[3 * i + 1] = c.g;
    out[3 * i + 2] = c.b;
}

size_t rows(const Array& a) { return size_t(a.shape(0)); }

// Prepares the closures for row i, reusing the previous row's shading point when the
// view direction and h repeat (gonio sweeps: one wo, many wi).
class PointCache {
public:
    explicit PointCache(const ClosureSum& bsdf) : bsdf_(bsdf) {}
    const ClosureSum::ShadingPoint& at(const double* wo, const double* h, size_t i) {
        const ShadingContext ctx = fibre_context(wo, h, i);
        if (!valid_ || ctx.wo.x != last_.wo.x || ctx.wo.y != last_.wo.y || ctx.wo.z != last_.wo.z || ctx.h != last_.h) {
            bsdf_.prepare(ctx, point_);
            last_ = ctx;
            valid_ = true;
        }
        return point_;
    }

private:
    const ClosureSum& bsdf_;
    ClosureSum::ShadingPoint point_;
    ShadingContext last_;
    bool valid_ = false;
};

py::array_t<double> new_array(std::vector<py::ssize_t> shape) { return py::array_t<double>(shape); }

// Batch methods of a closure sum. Shapes are checked in Python; asserted again here.
void check_rows(const Array& a, size_t n, int cols, const char* name) {
    if (rows(a) != n || (cols > 0 && (a.ndim() != 2 || a.shape(1) != cols)) || (cols == 0 && a.ndim() != 1))
        throw py::value_error(std::string("internal: bad shape for ") + name);
}

py::array_t<double> batch_eval(const ClosureSum& bsdf, const Array& wo, const Array& wi, const Array& h,
                               bool lobes) {
    const size_t n = rows(wo);
    check_rows(wo, n, 3, "wo");
    check_rows(wi, n, 3, "wi");
    check_rows(h, n, 0, "h");
    auto out = lobes ? new_array({py::ssize_t(n), kLobeCount, 3}) : new_array({py::ssize_t(n), 3});
    double* o = out.mutable_data();
    const double *pwo = wo.data(), *pwi = wi.data(), *ph = h.data();
    {
        py::gil_scoped_release release;
        parallel_for(n, 4096, [&](size_t b, size_t e) {
            PointCache cache(bsdf);
            for (size_t i = b; i < e; ++i) {
                const BsdfEval r = bsdf.eval(cache.at(pwo, ph, i), vec_at(pwi, i));
                if (lobes) {
                    for (int p = 0; p < kLobeCount; ++p) store(o + 3 * kLobeCount * i, size_t(p), r.lobes[p]);
                } else {
                    store(o, i, r.value());
                }
            }
        });
    }
    return out;
}

py::array_t<double> batch_pdf(const ClosureSum& bsdf, const Array& wo, const Array& wi, const Array& h) {
    const size_t n = rows(wo);
    check_rows(wo, n, 3, "wo");
    check_rows(wi, n, 3, "wi");
    check_rows(h, n, 0, "h");
    auto out = new_array({py::ssize_t(n)});
    double* o = out.mutable_data();
    const double *pwo = wo.data(), *pwi = wi.data(), *ph = h.data();
    {
        py::gil_scoped_release release;
        parallel_for(n, 4096, [&](size_t b, size_t e) {
            PointCache cache(bsdf);
            for (size_t i = b; i < e; ++i) o[i] = bsdf.eval(cache.at(pwo, ph, i), vec_at(pwi, i)).pdf;
        });
    }
    return out;
}

py::tuple batch_sample(const ClosureSum& bsdf, const Array& wo, const Array& h, const Array& u) {
    const size_t n = rows(wo);
    check_rows(wo, n, 3, "wo");
    check_rows(h, n, 0, "h");
    check_rows(u, n, 3, "u");
    auto wi = new_array({py::ssize_t(n), 3});
    auto weight = new_array({py::ssize_t(n), 3});
    auto pdf = new_array({py::ssize_t(n)});
    py::array_t<int32_t> lobe({py::ssize_t(n)});
    double *owi = wi.mutable_data(), *ow = weight.mutable_data(), *op = pdf.mutable_data();
    int32_t* ol = lobe.mutable_data();
    const double *pwo = wo.data(), *ph = h.data(), *pu = u.data();
    {
        py::gil_scoped_release release;
        parallel_for(n, 2048, [&](size_t b, size_t e) {
            PointCache cache(bsdf);
            for (size_t i = b; i < e; ++i) {
                const BsdfSample s = bsdf.sample(cache.at(pwo, ph, i), {pu[3 * i], pu[3 * i + 1], pu[3 * i + 2]});
                owi[3 * i] = s.wi.x;
                owi[3 * i + 1] = s.wi.y;
                owi[3 * i + 2] = s.wi.z;
                store(ow, i, s.weight);
                op[i] = s.pdf;
                ol[i] = s.lobe;
            }
        });
    }
    return py::make_tuple(wi, weight, pdf, lobe);
}

py::array_t<double> batch_albedo(const ClosureSum& bsdf, const Array& wo, const Array& h, double panels_per_scale,
                                 long max_nodes) {
    const size_t n = rows(wo);
    check_rows(wo, n, 3, "wo");
    check_rows(h, n, 0, "h");
    auto out = new_array({py::ssize_t(n), 3});
    double* o = out.mutable_data();
    const double *pwo = wo.data(), *ph = h.data();
    QuadratureOptions options;
    options.panels_per_scale = panels_per_scale;
    options.max_nodes = max_nodes;
    {
        py::gil_scoped_release release;
        parallel_for(n, 1, [&](size_t b, size_t e) {
            for (size_t i = b; i < e; ++i) store(o, i, directional_albedo(bsdf, fibre_context(pwo, ph, i), options));
        });
    }
    return out;
}

ClosureSum principled_chiang(int parametrization, std::array<double, 3> color, double melanin,
                             double melanin_redness, std::array<double, 3> tint,
                             std::array<double, 3> absorption_coefficient, double roughness,
                             double radial_roughness, double coat, double ior, double offset, double random_color,
                             double random_roughness, double random, int accuracy, int tilt) {
    PrincipledHairInputs in;
    in.parametrization = Parametrization(parametrization);
    in.color = rgb_from(color);
    in.melanin = melanin;
    in.melanin_redness = melanin_redness;
    in.tint = rgb_from(tint);
    in.absorption_coefficient = rgb_from(absorption_coefficient);
    in.roughness = roughness;
    in.radial_roughness = radial_roughness;
    in.coat = coat;
    in.ior = ior;
    in.offset = offset;
    in.random_color = random_color;
    in.random_roughness = random_roughness;
    in.random = random;
    const ChiangHairParams p = chiang_params_from_principled(in, Accuracy(accuracy), TiltConvention(tilt));
    return ClosureSum({Closure{RGB(1.0), ChiangHair(p)}});
}

ClosureSum chiang_from_params(std::array<double, 3> sigma_a, double eta, std::array<double, 4> v,
                              std::array<double, 4> v_sample, std::array<double, 3> s, double tilt,
                              std::array<std::array<double, 3>, 4> tint, int accuracy, int tilt_convention) {
    ChiangHairParams p;
    p.sigma_a = rgb_from(sigma_a);
    p.eta = eta;
    p.v = v;
    p.v_sample = v_sample;
    p.s = s;
    p.tilt = tilt;
    for (int i = 0; i < 4; ++i) p.tint[i] = rgb_from(tint[i]);
    p.accuracy = Accuracy(accuracy);
    p.tilt_convention = TiltConvention(tilt_convention);
    return ClosureSum({Closure{RGB(1.0), ChiangHair(p)}});
}

py::dict chiang_params_dict(const ChiangHairParams& p) {
    py::dict d;
    d["sigma_a"] = std::array<double, 3>{p.sigma_a.r, p.sigma_a.g, p.sigma_a.b};
    d["eta"] = p.eta;
    d["v"] = p.v;
    d["v_sample"] = p.v_sample;
    d["s"] = p.s;
    d["tilt"] = p.tilt;
    return d;
}

template <class Fn>
py::array_t<double> map1(const Array& x, Fn fn) {
    auto out = new_array(std::vector<py::ssize_t>(x.shape(), x.shape() + x.ndim()));
    const double* px = x.data();
    double* o = out.mutable_data();
    for (py::ssize_t i = 0; i < x.size(); ++i) o[i] = fn(px[i]);
    return out;
}

}  // namespace

PYBIND11_MODULE(_core, m) {
    m.doc() = "hairbsdf C++ core (use the `hairbsdf` package, not this module)";

    py::class_<ClosureSum>(m, "ClosureSum")
        .def("eval", [](const ClosureSum& c, const Array& wo, const Array& wi, const Array& h) {
            return batch_eval(c, wo, wi, h, false);
        })
        .def("eval_lobes", [](const ClosureSum& c, const Array& wo, const Array& wi, const Array& h) {
            return batch_eval(c, wo, wi, h, true);
        })
        .def("pdf", &batch_pdf)
        .def("sample", &batch_sample)
        .def("albedo", &batch_albedo)
        .def("scaled",
             [](const ClosureSum& c, std::array<double, 3> w) {
                 std::vector<Closure> cs = c.closures();
                 for (Closure& k : cs) k.weight = rgb_from(w) * k.weight;
                 return ClosureSum(cs);
             })
        .def("plus",
             [](const ClosureSum& a, const ClosureSum& b) {
                 std::vector<Closure> cs = a.closures();
                 cs.insert(cs.end(), b.closures().begin(), b.closures().end());
                 return ClosureSum(cs);
             })
        .def("closure_weights",
             [](const ClosureSum& c) {
                 std::vector<std::array<double, 3>> w;
                 for (const Closure& k : c.closures()) w.push_back({k.weight.r, k.weight.g, k.weight.b});
                 return w;
             })
        .def("model_params", [](const ClosureSum& c) {
            py::list out;
            for (const Closure& k : c.closures()) out.append(chiang_params_dict(std::get<ChiangHair>(k.model).params()));
            return out;
        });

    m.def("principled_chiang", &principled_chiang);
    m.def("chiang_from_params", &chiang_from_params);
    m.def("principled_chiang_params",
          [](int parametrization, std::array<double, 3> color, double melanin, double melanin_redness,
             std::array<double, 3> tint, std::array<double, 3> absorption_coefficient, double roughness,
             double radial_roughness, double coat, double ior, double offset, double random_color,
             double random_roughness, double random) {
              ClosureSum c = principled_chiang(parametrization, color, melanin, melanin_redness, tint,
                                               absorption_coefficient, roughness, radial_roughness, coat, ior,
                                               offset, random_color, random_roughness, random, 0, 0);
              return chiang_params_dict(std::get<ChiangHair>(c.closures()[0].model).params());
          });

    m.def("materialx_chiang", [](std::array<std::array<double, 3>, 3> tints, double ior,
                                 std::array<std::array<double, 2>, 3> roughness, double cuticle_angle,
                                 std::array<double, 3> absorption) {
        ChiangHairBsdfInputs in;
        in.tint_R = rgb_from(tints[0]);
        in.tint_TT = rgb_from(tints[1]);
        in.tint_TRT = rgb_from(tints[2]);
        in.ior = ior;
        in.roughness_R = {roughness[0][0], roughness[0][1]};
        in.roughness_TT = {roughness[1][0], roughness[1][1]};
        in.roughness_TRT = {roughness[2][0], roughness[2][1]};
        in.cuticle_angle = cuticle_angle;
        in.absorption_coefficient = rgb_from(absorption);
        return ClosureSum({Closure{RGB(1.0), ChiangHair(chiang_params_from_materialx(in))}});
    });
    m.def("materialx_roughness", [](double l, double a, double k_tt, double k_trt) {
        const ChiangHairRoughness r = chiang_hair_roughness(l, a, k_tt, k_trt);
        return std::array<std::array<double, 2>, 3>{std::array<double, 2>{r.roughness_R.x, r.roughness_R.y},
                                                    std::array<double, 2>{r.roughness_TT.x, r.roughness_TT.y},
                                                    std::array<double, 2>{r.roughness_TRT.x, r.roughness_TRT.y}};
    });
    m.def("materialx_absorption_from_color", [](std::array<double, 3> c, double a) {
        const RGB s = chiang_hair_absorption_from_color(rgb_from(c), a);
        return std::array<double, 3>{s.r, s.g, s.b};
    });
    m.def("materialx_absorption_from_melanin",
          [](double c, double r, std::array<double, 3> eu, std::array<double, 3> pheo) {
              const RGB s = deon_hair_absorption_from_melanin(c, r, rgb_from(eu), rgb_from(pheo));
              return std::array<double, 3>{s.r, s.g, s.b};
          });
    m.def("absorption_from_color", [](std::array<double, 3> c, double radial_roughness) {
        const RGB s = absorption_from_color(rgb_from(c), radial_roughness);
        return std::array<double, 3>{s.r, s.g, s.b};
    });
    m.def("absorption_from_melanin",
          [](double melanin, double redness, std::array<double, 3> tint, double radial_roughness) {
              const RGB s = absorption_from_melanin(melanin, redness, rgb_from(tint), radial_roughness);
              return std::array<double, 3>{s.r, s.g, s.b};
          });
    m.def("longitudinal_variance", [](const Array& b) { return map1(b, longitudinal_variance); });
    m.def("azimuthal_scale", [](const Array& b) { return map1(b, azimuthal_scale); });
    m.def("azimuthal_scale_raw", [](const Array& b) { return map1(b, azimuthal_scale_raw); });
    m.def("albedo_roughness_scale", [](const Array& b) { return map1(b, albedo_roughness_scale); });
    m.def("bessel_i0", [](const Array& x) { return map1(x, bessel_i0); });
    m.def("log_bessel_i0", [](const Array& x) { return map1(x, log_bessel_i0); });
    m.def("cycles_bessel_i0", [](const Array& x) { return map1(x, cycles_bessel_i0); });
    m.def("cycles_log_bessel_i0", [](const Array& x) { return map1(x, cycles_log_bessel_i0); });
    m.def("longitudinal_scattering",
          [](const Array& sin_i, const Array& cos_i, const Array& sin_o, const Array& cos_o, double v, int accuracy) {
              const LongitudinalLobe lobe(v, Accuracy(accuracy));
              auto out = new_array({sin_i.size()});
              double* o = out.mutable_data();
              for (py::ssize_t i = 0; i < sin_i.size(); ++i)
                  o[i] = lobe.eval(sin_i.data()[i], cos_i.data()[i], sin_o.data()[i], cos_o.data()[i]);
              return out;
          });
    m.def("fresnel_dielectric", [](const Array& c, double eta) {
        return map1(c, [eta](double x) { return fresnel_dielectric(x, eta); });
    });
    m.def("sample_trimmed_logistic", [](const Array& u, double s) {
        return map1(u, [s](double x) { return sample_trimmed_logistic(x, s); });
    });
    m.def("cycles_curve_random", [](py::array_t<int64_t, py::array::c_style | py::array::forcecast> idx) {
        auto out = new_array(std::vector<py::ssize_t>(idx.shape(), idx.shape() + idx.ndim()));
        for (py::ssize_t i = 0; i < idx.size(); ++i)
            out.mutable_data()[i] = cycles_curve_random(uint32_t(idx.data()[i]));
        return out;
    });
    m.def("set_num_threads", [](int n) { g_num_threads = std::max(1, n); });
    m.def("get_num_threads", []() { return g_num_threads.load(); });
}
