// pybind11 bindings: hairbsdf._core. Batch calls take C-contiguous float64 arrays
// (the Python layer validates and converts), release the GIL and split the batch
// across threads. Directions are in the fibre frame (tangent = +x), docs/conventions.md.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <sstream>
#include <atomic>
#include <vector>

#include "hairbsdf/albedo.h"
#include "hairbsdf/batch/batch_rows.h"
#include "hairbsdf/batch/chiang_batch.h"
#include "hairbsdf/math_simd.h"
#include "hairbsdf/closures.h"
#include "hairbsdf/model_factory.h"
#include "hairbsdf/param_kinds.h"
#include "hairbsdf/params/cycles_hair.h"
#include "hairbsdf/params/deon.h"
#include "hairbsdf/params/epic.h"
#include "hairbsdf/params/huang.h"
#include "hairbsdf/params/kajiya_kay.h"
#include "hairbsdf/params/marschner.h"
#include "hairbsdf/params/materialx.h"
#include "hairbsdf/params/principled_hair.h"
#include "hairbsdf/params/scheuermann.h"
#include "hairbsdf/params/yan_fur.h"
#include "hairbsdf/render/scene.h"
#include "model_params.h"
#include "render_passes.h"
#include "scene_schema.h"

namespace py = pybind11;
using namespace hairbsdf;

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

RGB vec_rgb(const double* p, size_t i) { return {p[3 * i], p[3 * i + 1], p[3 * i + 2]}; }
RGB rgb_from(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

size_t rows(const Array& a) { return size_t(a.shape(0)); }

py::array_t<double> new_array(std::vector<py::ssize_t> shape) { return py::array_t<double>(shape); }

// Batch methods of a closure sum. Shapes are checked in Python; asserted again here.
void check_rows(const Array& a, size_t n, int cols, const char* name) {
    if (rows(a) != n || (cols > 0 && (a.ndim() != 2 || a.shape(1) != cols)) || (cols == 0 && a.ndim() != 1))
        throw py::value_error(std::string("internal: bad shape for ") + name);
}

RowExtras extras_from(const py::object& normal, const py::object& pixel_coverage, const py::object& near_field, size_t n,
                   std::vector<Array>& keep, const py::object& random = py::none(),
                   const py::object& shadow = py::none()) {
    RowExtras x;
    auto get = [&](const py::object& o, int cols, const char* name) -> const double* {
        if (o.is_none()) return nullptr;
        keep.push_back(o.cast<Array>());
        check_rows(keep.back(), n, cols, name);
        return keep.back().data();
    };
    x.normal = get(normal, 3, "normal");
    x.pixel_coverage = get(pixel_coverage, 0, "pixel_coverage");
    x.near_field = get(near_field, 0, "near_field");
    x.random = get(random, 0, "random");
    x.shadow = get(shadow, 0, "shadow");
    return x;
}

// The scalar batch loops (hairbsdf/batch/batch_rows.h) on the arrays, without the GIL.
py::array_t<double> eval_arrays(const ClosureSum& bsdf, const Array& wo, const Array& wi, const Array& h,
                               bool lobes, const RowExtras& extras = {}) {
    const size_t n = rows(wo);
    check_rows(wo, n, 3, "wo");
    check_rows(wi, n, 3, "wi");
    check_rows(h, n, 0, "h");
    auto out = lobes ? new_array({py::ssize_t(n), batch_lobe_count(bsdf), 3}) : new_array({py::ssize_t(n), 3});
    double* o = out.mutable_data();
    {
        py::gil_scoped_release release;
        hairbsdf::batch_eval(bsdf, n, wo.data(), wi.data(), h.data(), lobes, extras, o);
    }
    return out;
}

py::array_t<double> pdf_arrays(const ClosureSum& bsdf, const Array& wo, const Array& wi, const Array& h,
                              const RowExtras& extras = {}) {
    const size_t n = rows(wo);
    check_rows(wo, n, 3, "wo");
    check_rows(wi, n, 3, "wi");
    check_rows(h, n, 0, "h");
    auto out = new_array({py::ssize_t(n)});
    double* o = out.mutable_data();
    {
        py::gil_scoped_release release;
        hairbsdf::batch_pdf(bsdf, n, wo.data(), wi.data(), h.data(), extras, o);
    }
    return out;
}

py::tuple sample_arrays(const ClosureSum& bsdf, const Array& wo, const Array& h, const Array& u,
                       const RowExtras& extras = {}) {
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
    {
        py::gil_scoped_release release;
        hairbsdf::batch_sample(bsdf, n, wo.data(), h.data(), u.data(), extras, owi, ow, op, ol);
    }
    return py::make_tuple(wi, weight, pdf, lobe);
}

py::array_t<double> albedo_arrays(const ClosureSum& bsdf, const Array& wo, const Array& h, double panels_per_scale,
                                 long max_nodes, double huang_tolerance) {
    const size_t n = rows(wo);
    check_rows(wo, n, 3, "wo");
    check_rows(h, n, 0, "h");
    auto out = new_array({py::ssize_t(n), 3});
    double* o = out.mutable_data();
    QuadratureOptions options;
    options.panels_per_scale = panels_per_scale;
    options.max_nodes = max_nodes;
    options.huang_tolerance = huang_tolerance;
    {
        py::gil_scoped_release release;
        hairbsdf::batch_albedo(bsdf, n, wo.data(), h.data(), options, o);
    }
    return out;
}

// Reads the dict `given` into a struct by table rows: apply(row, value) for each row whose name
// (name_of(row)) is a key of `given`; rows not given keep the struct's defaults. A key that no row
// names is a ValueError naming it and the allowed names: "<where>['<key>']: not <what>; allowed: a, b".
template <class Rows, class NameOf, class Apply>
void read_by_rows(const py::dict& given, const Rows& rows, NameOf name_of, Apply apply, const std::string& where,
                  const std::string& what) {
    size_t used = 0;
    for (const auto& row : rows) {
        const py::str name(name_of(row));
        if (!given.contains(name)) continue;
        apply(row, given[name]);
        ++used;
    }
    if (used == given.size()) return;
    std::string allowed;
    for (const auto& row : rows) allowed += (allowed.empty() ? "" : ", ") + std::string(name_of(row));
    for (const auto& item : given) {
        const std::string key = py::str(item.first);
        bool known = false;
        for (const auto& row : rows) known = known || key == name_of(row);
        if (!known) throw py::value_error(where + "['" + key + "']: not " + what + "; allowed: " + allowed);
    }
}

// The scene schema's rows of Principled Hair's inputs ("materials[].closures[].inputs.*", bound to
// PrincipledHairInputs' fields: the one table of the node's inputs), with their keys; found once.
using PrincipledInputRows = std::vector<std::pair<std::string, const bindings::SceneKey*>>;
const PrincipledInputRows& principled_input_rows() {
    static const PrincipledInputRows rows = [] {
        const std::string path = bindings::kPrincipledHairInputsPath;
        PrincipledInputRows out;
        for (const bindings::SceneKey* k : bindings::rows_under(path, ""))
            if (k->field && k->field.owner == typeid(PrincipledHairInputs))
                out.emplace_back(std::string(k->path).substr(path.size() + 1), k);
        return out;
    }();
    return rows;
}

// Principled Hair's inputs from {key: value} (values as hairbsdf.principled checked them) by those
// rows; keys absent keep the struct's defaults (Blender 4.5's), an unknown key is an error.
PrincipledHairInputs principled_inputs_from(int parametrization, const py::dict& inputs) {
    PrincipledHairInputs in;
    in.parametrization = Parametrization(parametrization);
    read_by_rows(
        inputs, principled_input_rows(), [](const auto& row) -> const std::string& { return row.first; },
        [&in](const auto& row, py::handle given) {
            const bindings::SceneKey& key = *row.second;
            py::object value = py::reinterpret_borrow<py::object>(given);
            if (key.kind == bindings::SceneKeyKind::Vector && !py::isinstance<py::tuple>(value)) value = py::tuple(value);
            key.field.assign(key, &in, value);
        },
        "inputs", "a Principled Hair input");
    return in;
}

// principled_hair(model="chiang"): `principled` is (parametrization, inputs, accuracy, tilt), as
// Closure keeps it for chiang_rows.
struct PrincipledChiang {
    PrincipledHairInputs in;
    Accuracy accuracy;
    TiltConvention tilt;
};
PrincipledChiang principled_chiang_from(const py::tuple& principled) {
    if (principled.size() != 4)
        throw py::value_error("internal: principled_chiang takes (parametrization, inputs, accuracy, tilt)");
    return {principled_inputs_from(principled[0].cast<int>(), principled[1].cast<py::dict>()),
            Accuracy(principled[2].cast<int>()), TiltConvention(principled[3].cast<int>())};
}

ClosureSum principled_chiang(const py::tuple& principled) {
    const PrincipledChiang c = principled_chiang_from(principled);
    return ClosureSum({Closure{RGB(1.0), ChiangHair(chiang_params_from_principled(c.in, c.accuracy, c.tilt))}});
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
    std::vector<std::array<double, 3>> tint;
    for (const RGB& t : p.tint) tint.push_back({t.r, t.g, t.b});
    d["tint"] = tint;  // per lobe R, TT, TRT, TRRT+ (MaterialX tints; 1 for Principled Hair)
    return d;
}

// P's inputs from a dict of checked values named as its table's rows (params/param_table.h): a
// number, or a sequence of 2 or 3 numbers; names absent keep P's defaults, an unknown name is an error.
template <class P>
P inputs_from_table(const py::dict& given) {
    P p;
    std::vector<const ParamRow<P>*> rows;  // the rows that take an input
    for (const ParamRow<P>& row : ParamTable<P>::rows())
        if (row.set) rows.push_back(&row);
    read_by_rows(
        given, rows, [](const ParamRow<P>* row) -> const std::string& { return row->spec.name; },
        [&p](const ParamRow<P>* row, py::handle v) {
            ParamValue x{};
            if (py::isinstance<py::sequence>(v)) {
                const std::vector<double> seq = v.cast<std::vector<double>>();
                if (seq.empty() || seq.size() > 3) throw py::value_error(row->spec.name + ": expected 1 to 3 numbers");
                std::copy(seq.begin(), seq.end(), x.begin());
            } else {
                x.fill(v.cast<double>());
            }
            row->set(p, x);
        },
        ParamTable<P>::model, "an input");
    return p;
}

// Huang's options by their table's names (params/huang.h): a choice as its index, else the
// number; each bound row writes its field (a choice's index names its enum value through the table),
// an option not given keeps p's (the table's default). The one check of the options' kinds and
// ranges (their rows'), and of trt_points' rule (models/huang.h).
HuangHairParams huang_options(HuangHairParams p, const py::dict& given) {
    using Row = ParamRow<HuangHairParams>;
    read_by_rows(
        given, ParamTable<HuangHairParams>::rows(), [](const Row& row) -> const std::string& { return row.spec.name; },
        [&p](const Row& row, py::handle v) {
            const ModelParamSpec& spec = row.spec;
            const bool integer = spec.kind == ParamKind::Int || spec.kind == ParamKind::Choice;
            if (integer && (!py::isinstance<py::int_>(v) || py::isinstance<py::bool_>(v)))
                throw py::type_error(spec.name + ": expected an integer, got " + std::string(py::repr(v)));
            const double x = v.cast<double>();
            const double lo = spec.kind == ParamKind::Choice ? 0.0 : spec.min_value;
            const double hi = spec.kind == ParamKind::Choice ? double(spec.choices.size()) - 1 : spec.max_value;
            if (!(x >= lo && x <= hi)) {
                auto text = [integer](double bound) {
                    if (integer) return std::to_string((long long)bound);
                    std::ostringstream os;
                    os << bound;
                    return os.str();
                };
                throw py::value_error(spec.name + "=" + std::string(py::repr(v)) + ": must be in [" + text(lo) + ", " +
                                      text(hi) + "]");
            }
            if (row.set) row.set(p, {x, x, x});  // color_roughness: an input of the node conversion
        },
        "options", "an option of principled_hair(model='huang')");
    if (!trt_points_allowed(p.trt_points))
        throw py::value_error("trt_points=" + std::to_string(p.trt_points) + ": must be 0 (points set by `tolerance`) or "
                              "an integer >= " + std::to_string(kMinFixedTrtPoints));
    return p;
}

// The table's color_roughness choice in `options` (its index), or the row's default.
HuangColorRoughness huang_color_roughness(const py::dict& options) {
    for (const ParamRow<HuangHairParams>& row : ParamTable<HuangHairParams>::rows())
        if (row.spec.name == "color_roughness") {
            const py::str name(row.spec.name);
            const size_t index = options.contains(name) ? options[name].cast<size_t>() : size_t(row.spec.default_value[0]);
            return row.spec.choices.at(index) == "osl" ? HuangColorRoughness::Osl : HuangColorRoughness::Svm;
        }
    throw std::logic_error("params/huang.h has no color_roughness row");
}

// principled_hair(model="huang"): the node's inputs as principled_inputs_from reads them, and
// Huang's options (any not given: its table's default).
ClosureSum principled_huang(int parametrization, const py::dict& inputs, const py::dict& options) {
    const PrincipledHairInputs in = principled_inputs_from(parametrization, inputs);
    HuangHairParams p;  // the options' defaults, for their check before the conversion reads color_roughness
    huang_options(p, options);
    p = huang_params_from_principled(in, HuangQuadrature::Cycles, HuangSampler::Mixture, huang_color_roughness(options));
    return ClosureSum({Closure{RGB(1.0), HuangHair(huang_options(p, options))}});
}

// A zoo model's parameters as its table (params/<model>.h) names them: a number, an RGB triple, a
// choice's name or a bool per bound row.
template <class P>
py::dict table_dict(const P& p) {
    py::dict d;
    d["model"] = ParamTable<P>::model;
    for (const ParamRow<P>& row : ParamTable<P>::rows()) {
        if (!row.get) continue;  // an input the builder derived fields from
        const ParamValue v = row.get(p);
        const py::str name(row.spec.name);
        switch (row.spec.kind) {
            case ParamKind::Float: d[name] = v[0]; break;
            case ParamKind::RGB: d[name] = v; break;
            case ParamKind::Choice: d[name] = row.spec.choices[size_t(v[0])]; break;
            case ParamKind::Bool: d[name] = v[0] != 0.0; break;
            case ParamKind::Int: d[name] = (long long)v[0]; break;
            case ParamKind::Vector2: d[name] = std::array<double, 2>{v[0], v[1]}; break;
        }
    }
    return d;
}

py::dict huang_params_dict(const HuangHair& m) {
    const HuangHairParams& p = m.params();
    py::dict d = table_dict(p);  // "model" and the options, named by their table (params/huang.h)
    d["sigma_a"] = std::array<double, 3>{p.sigma_a.r, p.sigma_a.g, p.sigma_a.b};
    d["roughness"] = m.alpha();
    d["offset"] = p.offset;
    d["eta"] = p.eta;
    d["aspect_ratio"] = m.aspect_ratio();
    d["factors"] = std::array<double, 3>{std::max(p.r_factor, 0.0), std::max(p.tt_factor, 0.0), std::max(p.trt_factor, 0.0)};
    return d;
}

// --- plugins (hairbsdf/plugin.h) ------------------------------------------------------------
py::list plugin_schema(const PluginLibrary& lib) {
    py::list out;
    for (const PluginParam& p : lib.params()) {
        py::dict d;
        d["name"] = p.name;
        d["type"] = param_kind_name(p.rgb ? ParamKind::RGB : ParamKind::Float);
        d["default"] = p.default_value;
        d["min"] = p.min_value;
        d["max"] = p.max_value;
        d["description"] = p.description;
        out.append(d);
    }
    return out;
}

py::dict plugin_params_dict(const PluginHair& m) {
    py::dict d, values;
    d["model"] = kPluginModel;
    d["name"] = m.library().name();
    d["path"] = m.library().path();
    const auto& params = m.library().params();
    for (size_t i = 0; i < params.size(); ++i) {
        const double* v = m.values().data() + 3 * i;
        if (params[i].rgb) {
            values[py::str(params[i].name)] = py::make_tuple(v[0], v[1], v[2]);
        } else {
            values[py::str(params[i].name)] = v[0];
        }
    }
    d["params"] = values;
    return d;
}
py::dict model_dict(const ChiangHair& m) { return chiang_params_dict(m.params()); }
py::dict model_dict(const HuangHair& m) { return huang_params_dict(m); }

// --- the model zoo (docs/models.md) -------------------------------------------------------------
// Each dict carries "model" and, for hairbsdf.testing's quadrature panels, the narrowest lobe
// widths as "v" (a variance in theta) and "s" (a scale in phi).
py::dict zoo_scales(py::dict d, const std::array<double, 2>& scales) {
    d["v"] = std::vector<double>{scales[0] * scales[0]};
    d["s"] = std::vector<double>{scales[1]};
    return d;
}
py::dict model_dict(const KajiyaKayHair& m) {
    py::dict d = table_dict(m.params());
    d["specular_norm"] = m.specular_norm();
    return zoo_scales(d, m.angular_scales());
}
py::dict model_dict(const EpicHair& m) {
    py::dict d = table_dict(m.params());
    d["betas"] = m.betas();
    return zoo_scales(d, m.angular_scales());
}
py::dict model_dict(const ScheuermannHair& m) {
    py::dict d = table_dict(m.params());
    d["norms"] = m.norms();
    return zoo_scales(d, m.angular_scales());
}
py::dict model_dict(const MarschnerHair& m) { return zoo_scales(table_dict(m.params()), m.angular_scales()); }
py::dict model_dict(const DeonHair& m) { return zoo_scales(table_dict(m.params()), m.angular_scales()); }
py::dict model_dict(const YanFurHair& m) {
    py::dict d = table_dict(m.params());
    d["table_build_seconds"] = m.table()->build_seconds();
    return zoo_scales(d, m.angular_scales());
}
py::dict model_dict(const PluginHair& m) { return plugin_params_dict(m); }

// A model's schema (model_factory.h) as dicts: name, type ("float", "rgb", "choice",
// "bool"), default (a number, an (r, g, b) tuple, a choice's name or a bool), min, max,
// choices, optional, description.
py::list schema_list(const std::vector<ModelParamSpec>& schema) {
    py::list out;
    for (const ModelParamSpec& p : schema) {
        py::dict d;
        d["name"] = p.name;
        const std::array<double, 3>& v = p.default_value;
        d["type"] = param_kind_name(p.kind);
        switch (p.kind) {
            case ParamKind::Float: d["default"] = v[0]; break;
            case ParamKind::RGB: d["default"] = py::make_tuple(v[0], v[1], v[2]); break;
            case ParamKind::Choice: d["default"] = p.choices[size_t(v[0])]; break;
            case ParamKind::Bool: d["default"] = v[0] != 0.0; break;
            case ParamKind::Int: d["default"] = (long long)v[0]; break;
            case ParamKind::Vector2: d["default"] = py::make_tuple(v[0], v[1]); break;
        }
        d["min"] = p.min_value;
        d["max"] = p.max_value;
        d["choices"] = p.choices;
        d["optional"] = p.optional;
        d["description"] = p.description;
        out.append(d);
    }
    return out;
}
py::dict model_dict(const DiffuseBsdf&) {
    py::dict d;
    d["model"] = "diffuse";
    return d;
}

py::dict model_dict(const CyclesHair& m) {
    py::dict d = table_dict(m.params());
    d["r1"] = m.r1();  // after Cycles' clamp to [0.001, 1]
    d["r2"] = m.r2();
    return zoo_scales(d, m.angular_scales());
}

const HuangHair& single_huang(const ClosureSum& c) {
    if (c.closures().size() != 1 || !std::holds_alternative<HuangHair>(c.closures()[0].model))
        throw py::value_error("this method needs a single Huang closure");
    return std::get<HuangHair>(c.closures()[0].model);
}

// Per row: projected radius r, transparent (|h| >= r), near field in use, integrand evaluations of
// the residual for wi (when wi is given), and the h interval.
py::dict huang_details(const ClosureSum& c, const Array& wo, const Array& wi, const Array& h, py::object normal,
                       py::object pixel_coverage, py::object near_field) {
    const HuangHair& m = single_huang(c);
    const size_t n = rows(wo);
    std::vector<Array> keep;
    const RowExtras x = extras_from(normal, pixel_coverage, near_field, n, keep);
    auto r = new_array({py::ssize_t(n)}), lo = new_array({py::ssize_t(n)}), hi = new_array({py::ssize_t(n)});
    auto evals = new_array({py::ssize_t(n)});
    py::array_t<bool> transparent({py::ssize_t(n)}), near({py::ssize_t(n)});
    const double *pwo = wo.data(), *pwi = wi.data(), *ph = h.data();
    double *pr = r.mutable_data(), *plo = lo.mutable_data(), *phi = hi.mutable_data(), *pe = evals.mutable_data();
    bool *pt = transparent.mutable_data(), *pn = near.mutable_data();
    {
        py::gil_scoped_release release;
        parallel_for(n, 1, [&](size_t b, size_t e) {
            for (size_t i = b; i < e; ++i) {
                const HuangHair::ShadingPoint sp = m.prepare(fibre_context(pwo, ph, i, x));
                pr[i] = sp.r;
                pt[i] = sp.transparent;
                pn[i] = sp.near_field;
                plo[i] = sp.h_lo;
                phi[i] = sp.h_hi;
                long count = 0;
                if (rows(wi) == n) m.eval_local(sp, m.to_local(sp, row_vec(pwi, i)), &count);
                pe[i] = double(count);
            }
        });
    }
    py::dict d;
    d["radius"] = r;
    d["transparent"] = transparent;
    d["near_field"] = near;
    d["h_lo"] = lo;
    d["h_hi"] = hi;
    d["evaluations"] = evals;
    return d;
}

// Mean of `samples` runs of Cycles' stochastic eval per row, per lobe (N, 4, 3); LCG seeded per
// row from `seed` and the row index.
py::array_t<double> huang_cycles_estimate(const ClosureSum& c, const Array& wo, const Array& wi, const Array& h,
                                          py::object normal, py::object pixel_coverage, py::object near_field,
                                          long samples, uint32_t seed) {
    const HuangHair& m = single_huang(c);
    const size_t n = rows(wo);
    std::vector<Array> keep;
    const RowExtras x = extras_from(normal, pixel_coverage, near_field, n, keep);
    auto out = new_array({py::ssize_t(n), 4, 3});
    double* o = out.mutable_data();
    const double *pwo = wo.data(), *pwi = wi.data(), *ph = h.data();
    {
        py::gil_scoped_release release;
        parallel_for(n, 1, [&](size_t b, size_t e) {
            for (size_t i = b; i < e; ++i) {
                const HuangHair::ShadingPoint sp = m.prepare(fibre_context(pwo, ph, i, x));
                const Vec3 O = m.to_local(sp, row_vec(pwi, i));
                uint32_t rng = lookup3_hash_uint2(uint32_t(i), seed);
                std::array<RGB, 4> acc{};
                for (long k = 0; k < samples; ++k) {
                    const auto l = m.eval_cycles_stochastic(sp, O, rng);
                    for (int p = 0; p < 4; ++p) acc[size_t(p)] += l[size_t(p)];
                }
                for (int p = 0; p < 4; ++p) store_rgb(o + 12 * i, size_t(p), (1.0 / double(samples)) * acc[size_t(p)]);
            }
        });
    }
    return out;
}

// The mixture sampler's directions without evaluating the BSDF: (wi, pdf, lobe); for tests.
py::tuple huang_sample_directions(const ClosureSum& c, const Array& wo, const Array& h, const Array& u,
                                  py::object normal, py::object pixel_coverage, py::object near_field) {
    const HuangHair& m = single_huang(c);
    const size_t n = rows(wo);
    std::vector<Array> keep;
    const RowExtras x = extras_from(normal, pixel_coverage, near_field, n, keep);
    auto wi = new_array({py::ssize_t(n), 3});
    auto pdf = new_array({py::ssize_t(n)});
    py::array_t<int32_t> lobe({py::ssize_t(n)});
    double *owi = wi.mutable_data(), *op = pdf.mutable_data();
    int32_t* ol = lobe.mutable_data();
    const double *pwo = wo.data(), *ph = h.data(), *pu = u.data();
    {
        py::gil_scoped_release release;
        parallel_for(n, 256, [&](size_t b, size_t e) {
            HuangHair::ShadingPoint sp;
            ShadingContext last;
            bool have = false;
            for (size_t i = b; i < e; ++i) {
                const ShadingContext ctx = fibre_context(pwo, ph, i, x);
                if (!have || !same_row_context(ctx, last)) {
                    sp = m.prepare(ctx);
                    last = ctx;
                    have = true;
                }
                Vec3 O;
                const int l = m.sample_direction(sp, {pu[3 * i], pu[3 * i + 1], pu[3 * i + 2]}, O);
                const Vec3 w = l >= 0 ? m.to_world(sp, O) : Vec3{};
                owi[3 * i] = w.x;
                owi[3 * i + 1] = w.y;
                owi[3 * i + 2] = w.z;
                op[i] = l >= 0 ? m.pdf_local(sp, O) : 0.0;
                ol[i] = l;
            }
        });
    }
    return py::make_tuple(wi, pdf, lobe);
}

// --- The Chiang batch kernels (docs/simd.md) --------------------------------------------
// A single Chiang closure with float (N, 3) / (N,) arrays runs on the float32 SIMD kernels;
// anything else (sums, other models, eval_lobes, broadcasting, lists, per-sample extras) on the
// scalar double path above, which stays the reference. "scalar" sends everything there.
std::atomic<bool> g_kernels_on{true};
std::atomic<bool> g_convert_f64{false};  // float64 rows: false = the scalar double path

const Closure* single_chiang(const ClosureSum& bsdf) {
    if (!g_kernels_on.load() || bsdf.closures().size() != 1) return nullptr;
    const Closure& c = bsdf.closures()[0];
    return std::holds_alternative<ChiangHair>(c.model) ? &c : nullptr;
}

bool is_float_array(py::handle o, int ndim) {
    if (!py::isinstance<py::array>(o)) return false;
    const auto a = py::reinterpret_borrow<py::array>(o);
    if (a.ndim() != ndim || (ndim == 2 && a.shape(1) != 3)) return false;
    return a.dtype().is(py::dtype::of<float>()) || a.dtype().is(py::dtype::of<double>());
}
bool is_f32(py::handle o) { return py::reinterpret_borrow<py::array>(o).dtype().is(py::dtype::of<float>()); }

// An output array: `out` when given (checked), else a new one.
py::array output_array(const py::object& out, const char* name, std::vector<py::ssize_t> shape, bool f64) {
    const py::dtype dt = f64 ? py::dtype::of<double>() : py::dtype::of<float>();
    if (out.is_none()) return py::array(dt, shape);
    if (!py::isinstance<py::array>(out))
        throw py::type_error(std::string(name) + ": expected a NumPy array, got " +
                             std::string(py::str(py::type::handle_of(out).attr("__name__"))));
    auto a = py::reinterpret_borrow<py::array>(out);
    bool shape_ok = size_t(a.ndim()) == shape.size();
    for (size_t k = 0; shape_ok && k < shape.size(); ++k) shape_ok = a.shape(py::ssize_t(k)) == shape[k];
    if (!shape_ok || !a.dtype().is(dt) || !(a.flags() & py::array::c_style) || !a.writeable()) {
        std::string want = "(";
        for (size_t k = 0; k < shape.size(); ++k) want += (k ? ", " : "") + std::to_string(shape[k]);
        want += shape.size() == 1 ? ",)" : ")";
        throw py::value_error(std::string(name) + ": must be a writeable C-contiguous " + (f64 ? "float64" : "float32") +
                              " array of shape " + want + " (the inputs' float type)");
    }
    return a;
}

// Runs op on the kernels. Returns None when they do not apply (the caller then validates and
// takes the scalar path, which also names any argument that is not allowed).
// The Principled Hair inputs the Chiang batch calls take per row (docs/simd.md), each by the
// ClosureDesc::Input its scene-schema row drives: that row gives its name (the row's key) and its
// shape (a number: (N,); a vector: (N, columns)).
struct ChiangRowInput {
    render::ClosureDesc::Input input;
    const void* ChiangBatchRowInputs::*kernel;       // where the kernels read the rows
    double PrincipledHairInputs::*number = nullptr;  // where the scalar path writes row i's value
    RGB PrincipledHairInputs::*rgb = nullptr;        // (an RGB input)
    std::string name = {};
    int columns = 0;  // 0: (N,)
};
using In = render::ClosureDesc::Input;
const std::vector<ChiangRowInput>& chiang_row_inputs() {
    static const std::vector<ChiangRowInput> inputs = [] {
        std::vector<ChiangRowInput> out = {
            {In::Roughness, &ChiangBatchRowInputs::roughness, &PrincipledHairInputs::roughness},
            {In::RadialRoughness, &ChiangBatchRowInputs::radial_roughness, &PrincipledHairInputs::radial_roughness},
            {In::Coat, &ChiangBatchRowInputs::coat, &PrincipledHairInputs::coat},
            {In::Random, &ChiangBatchRowInputs::random, &PrincipledHairInputs::random},
            {In::Melanin, &ChiangBatchRowInputs::melanin, &PrincipledHairInputs::melanin},
            {In::AbsorptionCoefficient, &ChiangBatchRowInputs::absorption, nullptr,
             &PrincipledHairInputs::absorption_coefficient}};
        for (ChiangRowInput& r : out) {
            for (const auto& [key, row] : principled_input_rows())
                if (row->link_input == int(r.input)) {
                    r.name = key;
                    r.columns = row->kind == bindings::SceneKeyKind::Vector ? row->columns : 0;
                }
            if (r.name.empty() || (r.columns == 3) != bool(r.rgb) || (r.columns == 0) != bool(r.number))
                throw std::logic_error("a Chiang row input has no Principled Hair schema row of its shape");
        }
        return out;
    }();
    return inputs;
}

py::object kernel_rows(const ChiangBatchConstants& constants, ChiangBatchOp op, py::handle wo, py::handle second,
                       py::handle h, const py::object& out, const py::dict& inputs);

py::object kernel_call(const ClosureSum& bsdf, ChiangBatchOp op, py::handle wo, py::handle second, py::handle h,
                       const py::object& out) {
    const Closure* closure = single_chiang(bsdf);
    if (!closure || !is_float_array(wo, 2) || !is_float_array(second, 2) || !is_float_array(h, 1)) return py::none();
    return kernel_rows(chiang_batch_constants(std::get<ChiangHair>(closure->model).params(), closure->weight), op, wo,
                       second, h, out, py::dict());
}

// Runs op on the kernels with the given constants and per-row inputs (name -> array of N rows, or
// (N, 3) for absorption_coefficient; empty: uniform). None when they do not apply.
py::object kernel_rows(const ChiangBatchConstants& constants, ChiangBatchOp op, py::handle wo, py::handle second,
                       py::handle h, const py::object& out, const py::dict& inputs) {
    if (!g_kernels_on.load() || !is_float_array(wo, 2) || !is_float_array(second, 2) || !is_float_array(h, 1))
        return py::none();
    std::array<py::array, 3> in = {py::reinterpret_borrow<py::array>(wo), py::reinterpret_borrow<py::array>(second),
                                   py::reinterpret_borrow<py::array>(h)};
    const py::ssize_t n = in[0].shape(0);
    if (in[1].shape(0) != n || in[2].shape(0) != n) return py::none();
    // All float32: used in place where C-contiguous (else copied). Any float64: the scalar double
    // path, unless float64 rows are to be converted here (set_batch_kernel(float64="float32")).
    const bool f64 = !(is_f32(wo) && is_f32(second) && is_f32(h));
    if (f64 && !g_convert_f64.load()) return py::none();
    for (auto& a : in) {
        if (f64)
            a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
        else if (!(a.flags() & py::array::c_style))
            a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
    }
    // Per-row inputs: in the rows' float type (float64 converted to float32 here, as the rows are
    // under set_batch_kernel(float64="float32")), C-contiguous, N rows.
    ChiangBatchRows rows;
    std::vector<py::array> row_inputs;
    for (const ChiangRowInput& r : chiang_row_inputs()) {
        if (!inputs.contains(r.name)) continue;
        py::handle given = inputs[py::str(r.name)];
        if (!is_float_array(given, r.columns ? 2 : 1)) return py::none();
        py::array a = py::reinterpret_borrow<py::array>(given);
        if (f64)
            a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
        else
            a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
        if (a.shape(0) != n) return py::none();
        rows.inputs.*r.kernel = a.data();
        row_inputs.push_back(std::move(a));
    }
    rows.wo = in[0].data();
    (op == ChiangBatchOp::Sample ? rows.u : rows.wi) = in[1].data();
    rows.h = in[2].data();
    rows.f64 = f64;
    ChiangBatchOutput o;
    o.f64 = f64;
    py::object result;
    py::array value, pdf, wi, weight;
    py::array_t<int32_t> lobe;
    if (op == ChiangBatchOp::Eval) {
        value = output_array(out, "out", {n, 3}, f64);
        o.value = value.mutable_data();
        result = value;
    } else if (op == ChiangBatchOp::Pdf) {
        pdf = output_array(out, "out", {n}, f64);
        o.pdf = pdf.mutable_data();
        result = pdf;
    } else {
        wi = output_array(py::none(), "wi", {n, 3}, f64);
        weight = output_array(py::none(), "weight", {n, 3}, f64);
        pdf = output_array(py::none(), "pdf", {n}, f64);
        lobe = py::array_t<int32_t>({n});
        o.wi = wi.mutable_data();
        o.weight = weight.mutable_data();
        o.pdf = pdf.mutable_data();
        o.lobe = lobe.mutable_data();
        result = py::make_tuple(wi, weight, pdf, lobe);
    }
    std::atomic<size_t> bad{0};
    {
        py::gil_scoped_release release;
        parallel_for(size_t(n), 16384, [&](size_t b, size_t e) { bad += chiang_batch_run(constants, op, rows, o, b, e); });
    }
    return bad.load() ? py::object(py::none()) : result;
}

// The scalar double path with per-row Principled Hair inputs, the reference of the per-row kernels:
// row i is principled_hair(inputs with row i's values) times `weight`, through ClosureSum. Arrays are
// validated, broadcast, C-contiguous float64 (the Python layer); `second` is wi or u.
py::object scalar_rows(const PrincipledHairInputs& base, Accuracy accuracy, TiltConvention tilt, RGB weight,
                       ChiangBatchOp op, const Array& wo, const Array& second, const Array& h, const py::dict& inputs) {
    const size_t n = rows(wo);
    check_rows(wo, n, 3, "wo");
    check_rows(second, n, 3, op == ChiangBatchOp::Sample ? "u" : "wi");
    check_rows(h, n, 0, "h");
    std::vector<std::pair<const ChiangRowInput*, Array>> given;  // the inputs given, with their rows
    for (const ChiangRowInput& r : chiang_row_inputs()) {
        if (!inputs.contains(r.name)) continue;
        given.emplace_back(&r, inputs[py::str(r.name)].cast<Array>());
        check_rows(given.back().second, n, r.columns, r.name.c_str());
    }
    auto value = new_array({py::ssize_t(n), 3}), pdf = new_array({py::ssize_t(n)});
    auto wi = new_array({py::ssize_t(op == ChiangBatchOp::Sample ? n : 0), 3});
    py::array_t<int32_t> lobe({py::ssize_t(op == ChiangBatchOp::Sample ? n : 0)});
    double *ov = value.mutable_data(), *op_pdf = pdf.mutable_data(), *owi = wi.mutable_data();
    int32_t* ol = lobe.mutable_data();
    const double *pwo = wo.data(), *ps = second.data(), *ph = h.data();
    {
        py::gil_scoped_release release;
        parallel_for(n, 256, [&](size_t b, size_t e) {
            ClosureSum::ShadingPoint point;
            for (size_t i = b; i < e; ++i) {
                PrincipledHairInputs in = base;
                for (const auto& [r, values] : given) {
                    if (r->rgb)
                        in.*r->rgb = vec_rgb(values.data(), i);
                    else
                        in.*r->number = values.data()[i];
                }
                const ClosureSum bsdf({Closure{weight, ChiangHair(chiang_params_from_principled(in, accuracy, tilt))}});
                bsdf.prepare(fibre_context(pwo, ph, i), point);
                if (op == ChiangBatchOp::Sample) {
                    store_sample(bsdf.sample(point, {ps[3 * i], ps[3 * i + 1], ps[3 * i + 2]}), i, owi, ov, op_pdf, ol);
                } else if (op == ChiangBatchOp::Eval) {
                    store_rgb(ov, i, bsdf.eval(point, row_vec(ps, i)).value());
                } else {
                    op_pdf[i] = bsdf.pdf(point, row_vec(ps, i));
                }
            }
        });
    }
    if (op == ChiangBatchOp::Eval) return value;
    if (op == ChiangBatchOp::Pdf) return pdf;
    return py::make_tuple(wi, value, pdf, lobe);
}

// principled_hair(model="chiang") with per-row inputs: `principled` is principled_chiang's argument
// (the uniform inputs, accuracy, tilt). The kernels, or None where they do not apply; with
// `scalar`, the double reference path above.
py::object chiang_rows(int op_index, const py::tuple& principled, std::array<double, 3> weight, const py::dict& inputs,
                       py::handle wo, py::handle second, py::handle h, py::object out, bool scalar) {
    const PrincipledChiang c = principled_chiang_from(principled);
    const ChiangBatchOp op = ChiangBatchOp(op_index);
    if (scalar)
        return scalar_rows(c.in, c.accuracy, c.tilt, rgb_from(weight), op, py::cast<Array>(wo), py::cast<Array>(second),
                           py::cast<Array>(h), inputs);
    return kernel_rows(chiang_batch_constants_principled(c.in, c.accuracy, c.tilt, rgb_from(weight)), op, wo, second, h,
                       out, inputs);
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
            return eval_arrays(c, wo, wi, h, false);
        })
        .def("eval_lobes", [](const ClosureSum& c, const Array& wo, const Array& wi, const Array& h) {
            return eval_arrays(c, wo, wi, h, true);
        })
        .def("pdf", [](const ClosureSum& c, const Array& wo, const Array& wi, const Array& h) { return pdf_arrays(c, wo, wi, h); })
        // The batch kernels: None when they do not apply to these arrays (docs/simd.md).
        .def("kernel_eval", [](const ClosureSum& c, py::handle wo, py::handle wi, py::handle h, py::object out) {
            return kernel_call(c, ChiangBatchOp::Eval, wo, wi, h, out);
        })
        .def("kernel_pdf", [](const ClosureSum& c, py::handle wo, py::handle wi, py::handle h, py::object out) {
            return kernel_call(c, ChiangBatchOp::Pdf, wo, wi, h, out);
        })
        .def("kernel_sample", [](const ClosureSum& c, py::handle wo, py::handle h, py::handle u) {
            return kernel_call(c, ChiangBatchOp::Sample, wo, u, h, py::none());
        })
        .def("sample", [](const ClosureSum& c, const Array& wo, const Array& h, const Array& u) { return sample_arrays(c, wo, h, u); })
        // The same with the optional per-sample shading fields (None = default): normal (N, 3),
        // pixel_coverage (N,), near_field (N,) as 0 / 1.
        .def("eval_ex",
             [](const ClosureSum& c, const Array& wo, const Array& wi, const Array& h, bool lobes, py::object normal,
                py::object pixel_coverage, py::object near_field, py::object random, py::object shadow) {
                 std::vector<Array> keep;
                 const RowExtras x = extras_from(normal, pixel_coverage, near_field, rows(wo), keep, random, shadow);
                 return eval_arrays(c, wo, wi, h, lobes, x);
             },
             py::arg("wo"), py::arg("wi"), py::arg("h"), py::arg("lobes"), py::arg("normal"), py::arg("pixel_coverage"),
             py::arg("near_field"), py::arg("random") = py::none(), py::arg("shadow") = py::none())
        .def("pdf_ex",
             [](const ClosureSum& c, const Array& wo, const Array& wi, const Array& h, py::object normal,
                py::object pixel_coverage, py::object near_field, py::object random, py::object shadow) {
                 std::vector<Array> keep;
                 const RowExtras x = extras_from(normal, pixel_coverage, near_field, rows(wo), keep, random, shadow);
                 return pdf_arrays(c, wo, wi, h, x);
             },
             py::arg("wo"), py::arg("wi"), py::arg("h"), py::arg("normal"), py::arg("pixel_coverage"),
             py::arg("near_field"), py::arg("random") = py::none(), py::arg("shadow") = py::none())
        .def("sample_ex",
             [](const ClosureSum& c, const Array& wo, const Array& h, const Array& u, py::object normal,
                py::object pixel_coverage, py::object near_field, py::object random, py::object shadow) {
                 std::vector<Array> keep;
                 const RowExtras x = extras_from(normal, pixel_coverage, near_field, rows(wo), keep, random, shadow);
                 return sample_arrays(c, wo, h, u, x);
             },
             py::arg("wo"), py::arg("h"), py::arg("u"), py::arg("normal"), py::arg("pixel_coverage"),
             py::arg("near_field"), py::arg("random") = py::none(), py::arg("shadow") = py::none())
        .def("albedo", &albedo_arrays)
        .def("with_huang_tolerance",
             [](const ClosureSum& c, double tolerance) {
                 // The same sum with every Huang closure's tolerance replaced (eval's tolerance= keyword).
                 std::vector<Closure> cs = c.closures();
                 for (Closure& k : cs) {
                     if (const HuangHair* m = std::get_if<HuangHair>(&k.model)) {
                         HuangHairParams p = m->params();
                         p.tolerance = tolerance;
                         k.model = HuangHair(p);
                     }
                 }
                 return ClosureSum(cs);
             })
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
            for (const Closure& k : c.closures()) {
                out.append(std::visit([](const auto& model) { return model_dict(model); }, k.model));
            }
            return out;
        })
        .def("huang_details", &huang_details)
        .def("huang_cycles_estimate", &huang_cycles_estimate)
        .def("huang_sample_directions", &huang_sample_directions);

    py::register_exception<PluginError>(m, "PluginError", PyExc_RuntimeError);
    m.attr("PLUGIN_ABI_VERSION") = HAIRBSDF_PLUGIN_ABI_VERSION;
    // Cycles' default surface colour (render/scene.h): the exporter's fallback diffuse.
    const RGB grey = render::kDefaultSurfaceColor;
    m.attr("DEFAULT_SURFACE_COLOR") = py::make_tuple(grey.r, grey.g, grey.b);
    m.attr("CLOSURES") = bindings::kClosuresPath;  // the scene key of a material's closures
    m.attr("PRINCIPLED_HAIR_INPUTS") = bindings::kPrincipledHairInputsPath;  // the scene key of the node's inputs
    m.attr("LUMINANCE_WEIGHTS") = py::make_tuple(kLuminanceWeights[0], kLuminanceWeights[1], kLuminanceWeights[2]);
    py::class_<PluginLibrary, std::shared_ptr<PluginLibrary>>(m, "PluginLibrary")
        .def_property_readonly("name", &PluginLibrary::name)
        .def_property_readonly("path", &PluginLibrary::path)
        .def_property_readonly("description", &PluginLibrary::description)
        .def_property_readonly("abi_version", &PluginLibrary::abi_version)
        .def_property_readonly("has_lobes", &PluginLibrary::has_lobes)
        .def_property_readonly("params", &plugin_schema)
        // values: 3 per schema parameter in schema order (checked again here).
        .def("create", [](const std::shared_ptr<PluginLibrary>& lib, const std::vector<double>& values) {
            return ClosureSum({Closure{RGB(1.0), PluginHair(lib, values)}});
        });
    m.def("load_plugin", [](const std::string& path) {
        return std::const_pointer_cast<PluginLibrary>(load_plugin(path));
    });

    // The model factory (model_factory.h): the zoo's constructors and hair_model closures.
    m.def("zoo_model_names", &zoo_model_names);
    m.def("model_names", &model_names);  // every name make_model builds
    m.attr("PLUGIN_MODEL") = kPluginModel;
    py::list kinds;  // the parameter kinds' names, in ParamKind's order
    for (ParamKind k : kParamKinds) kinds.append(param_kind_name(k));
    m.attr("PARAM_KINDS") = py::tuple(kinds);
    // (name, title, summary) per zoo model, from the tables (Blender's override menu).
    m.def("zoo_models", []() {
        py::list out;
        for (const ZooModel& z : zoo_models()) out.append(py::make_tuple(z.name, z.title, z.summary));
        return out;
    });

    // The scene format (scene_schema.h): its table and its check, without TBB.
    m.def("scene_schema", &bindings::scene_schema_as_python,
          "The scene format's keys (docs/scene_desc.md), one dict per key: path, kind, dtype, columns, required, "
          "default, allowed, minimum, maximum, only_for, register_link, closed, meaning.");
    m.def("render_passes", &bindings::render_passes_as_python,
          "The passes integrator.passes may name, each with the images it adds to a render's result (key, Blender "
          "pass name, Blender channel ids, channels) and its meaning (plugin/bindings/render_passes.h).");
    m.def("validate_scene", &bindings::check_scene, py::arg("scene"),
          "Checks a scene dict against scene_schema() and returns a normalised copy; errors name the key path.");
    m.def("model_schema", [](const std::string& model, const std::string& path) { return schema_list(model_schema(model, path)); },
          py::arg("model"), py::arg("path") = "");
    m.def("make_model",
          [](const std::string& model, const py::dict& params, const std::string& path) {
              const ModelParams given = bindings::model_params_from_dict(params, [](const std::string& n) { return n; });
              return ClosureSum({Closure{RGB(1.0), make_model(model, path, given)}});
          },
          py::arg("model"), py::arg("params"), py::arg("path") = "");
    m.def("principled_chiang", &principled_chiang, py::arg("principled"));
    // Per-row Principled Hair inputs on a Chiang closure (docs/simd.md); op 0 eval, 1 pdf, 2 sample.
    m.def("chiang_rows", &chiang_rows, py::arg("op"), py::arg("principled"), py::arg("weight"), py::arg("inputs"),
          py::arg("wo"), py::arg("second"), py::arg("h"), py::arg("out"), py::arg("scalar"));
    // name -> columns (0: one number a row, 3: an RGB triple a row), from the scene schema's rows.
    m.attr("CHIANG_ROW_INPUTS") = [] {
        py::dict d;
        for (const ChiangRowInput& r : chiang_row_inputs()) d[py::str(r.name)] = r.columns;
        return d;
    }();
    m.def("principled_huang", &principled_huang, py::arg("parametrization"), py::arg("inputs"), py::arg("options"));
    // Huang's options (params/huang.h): the table as model_schema's dicts, and name -> default.
    m.def("huang_option_schema", [] { return schema_list(param_specs<HuangHairParams>()); });
    m.def("huang_option_defaults", [] {
        py::dict d;
        for (const py::handle row : schema_list(param_specs<HuangHairParams>()))
            d[py::object(row["name"])] = py::object(row["default"]);
        return d;
    });
    m.def("huang_energy_scale", [](const Array& sqrt_alpha, const Array& mu, double eta, int glass_albedo_table) {
        auto out = new_array({sqrt_alpha.size()});
        for (py::ssize_t i = 0; i < sqrt_alpha.size(); ++i)
            out.mutable_data()[i] = huang::energy_scale(GlassAlbedoTable(glass_albedo_table), sqrt_alpha.data()[i],
                                                        mu.data()[i], eta);
        return out;
    });
    m.def("ggx_glass_albedo", [](double alpha, double mu, double eta, bool reject_upward_refraction, double tolerance) {
        return ggx::ggx_glass_albedo(alpha, mu, eta, reject_upward_refraction, tolerance);
    });
    // The E_glass tables of GlassAlbedoTable `glass_albedo_table`: (2, n, n, n), n = 16 (4.x) or 32 (5.x).
    m.def("huang_table", [](int glass_albedo_table) {
        if (GlassAlbedoTable(glass_albedo_table) == GlassAlbedoTable::Cycles5) {
            auto out = new_array({2, 32, 32, 32});
            std::memcpy(out.mutable_data(), &huang::kGgxGlassAlbedo5[0][0][0][0], sizeof(huang::kGgxGlassAlbedo5));
            return out;
        }
        auto out = new_array({2, 16, 16, 16});
        std::memcpy(out.mutable_data(), &huang::kGgxGlassAlbedo[0][0][0][0], sizeof(huang::kGgxGlassAlbedo));
        return out;
    });
    m.def("chiang_from_params", &chiang_from_params);
    m.def("scheuermann_lobe_albedo", [](double p, double v_t) { return ScheuermannHair::lobe_albedo(p, v_t); });

    // MaterialX nodes (params/materialx.h): each takes its inputs as a dict by its table's names.
    m.def("materialx_schema", [](const std::string& node) {
        if (node == ParamTable<ChiangHairBsdfInputs>::model) return schema_list(param_specs<ChiangHairBsdfInputs>());
        if (node == ParamTable<ChiangHairRoughnessInputs>::model)
            return schema_list(param_specs<ChiangHairRoughnessInputs>());
        if (node == ParamTable<ChiangHairAbsorptionFromColorInputs>::model)
            return schema_list(param_specs<ChiangHairAbsorptionFromColorInputs>());
        if (node == ParamTable<DeonHairAbsorptionFromMelaninInputs>::model)
            return schema_list(param_specs<DeonHairAbsorptionFromMelaninInputs>());
        throw py::value_error("node: " + node + " is not a MaterialX node with a table");
    });
    m.def("materialx_chiang", [](const py::dict& inputs) {
        const ChiangHairBsdfInputs in = inputs_from_table<ChiangHairBsdfInputs>(inputs);
        return ClosureSum({Closure{RGB(1.0), ChiangHair(chiang_params_from_materialx(in))}});
    });
    m.def("materialx_roughness", [](const py::dict& inputs) {
        const ChiangHairRoughness r = chiang_hair_roughness(inputs_from_table<ChiangHairRoughnessInputs>(inputs));
        return std::array<std::array<double, 2>, 3>{std::array<double, 2>{r.roughness_R.x, r.roughness_R.y},
                                                    std::array<double, 2>{r.roughness_TT.x, r.roughness_TT.y},
                                                    std::array<double, 2>{r.roughness_TRT.x, r.roughness_TRT.y}};
    });
    m.def("materialx_absorption_from_color", [](const py::dict& inputs) {
        const RGB s = chiang_hair_absorption_from_color(inputs_from_table<ChiangHairAbsorptionFromColorInputs>(inputs));
        return std::array<double, 3>{s.r, s.g, s.b};
    });
    m.def("materialx_absorption_from_melanin", [](const py::dict& inputs) {
        const RGB s = deon_hair_absorption_from_melanin(inputs_from_table<DeonHairAbsorptionFromMelaninInputs>(inputs));
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
    m.def("set_num_threads", &set_batch_threads);
    m.def("get_num_threads", &batch_threads);
    // "scalar" (the double reference path for every call) or an instruction set of the kernels.
    m.def("set_batch_kernel", [](const std::string& name, bool convert_float64) {
        g_kernels_on = name != "scalar";
        g_convert_f64 = convert_float64;
        const SimdIsa isa = set_simd_isa(name == "best" || name == "scalar" ? "" : name.c_str());
        return g_kernels_on.load() ? std::string(simd_isa_name(isa)) : std::string("scalar");
    });
    m.def("get_batch_kernel", []() { return g_kernels_on.load() ? std::string(simd_isa_name(simd_isa())) : std::string("scalar"); });
    // Chiang's scalar Cycles-accuracy transcendentals: float accuracy (true) or the double reference.
    m.def("set_scalar_maths", [](bool in_float) {
        set_cycles_float_maths(in_float);
        return std::string(cycles_float_maths() ? "float" : "double");
    });
    m.def("get_scalar_maths", []() { return std::string(cycles_float_maths() ? "float" : "double"); });
}
