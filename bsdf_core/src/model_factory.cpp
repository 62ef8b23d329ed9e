// The builder of zoo models by name, derived from each model's parameter table (params/<model>.h,
// param_table.h); see model_factory.h. Defaults, ranges and their sources: docs/models.md.
#include "hairbsdf/model_factory.h"

#include <cmath>
#include <sstream>

#include "hairbsdf/params/cycles_hair.h"
#include "hairbsdf/params/deon.h"
#include "hairbsdf/params/epic.h"
#include "hairbsdf/params/kajiya_kay.h"
#include "hairbsdf/params/marschner.h"
#include "hairbsdf/params/scheuermann.h"
#include "hairbsdf/params/yan_fur.h"

namespace hairbsdf {

namespace {

// --- values by name -----------------------------------------------------------------------------
std::string number_text(double x, int precision = 10) {
    std::ostringstream s;
    s.precision(precision);
    s << x;
    return s.str();
}
std::string range_text(const ModelParamSpec& p) {
    return "[" + number_text(p.min_value, 6) + ", " + number_text(p.max_value, 6) + "]";
}
std::string triple_text(const std::array<double, 3>& v) {
    return "(" + number_text(v[0]) + ", " + number_text(v[1]) + ", " + number_text(v[2]) + ")";
}
std::string join(const std::vector<std::string>& names) {
    std::string out;
    for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
    return out;
}
std::string value_text(const ModelParamValue& v) {
    if (const double* x = std::get_if<double>(&v)) return number_text(*x);
    if (const auto* t = std::get_if<std::array<double, 3>>(&v)) return triple_text(*t);
    return "'" + std::get<std::string>(v) + "'";
}

// The schema's values with the given ones checked and applied: 3 numbers per parameter
// (Choice: the index, Bool: 0 / 1).
class Values {
public:
    Values(std::string owner, const std::vector<ModelParamSpec>& schema, const ModelParams& given)
        : owner_(std::move(owner)), schema_(schema) {
        for (const ModelParamSpec& p : schema_) values_.push_back(p.default_value), given_.push_back(false);
        for (const auto& [name, value] : given) {
            const size_t i = index(name);
            values_[i] = convert(schema_[i], value);
            given_[i] = true;
        }
    }
    double number(const std::string& name) const { return values_[index(name)][0]; }
    RGB color(const std::string& name) const {
        const auto& v = values_[index(name)];
        return {v[0], v[1], v[2]};
    }
    const std::string& choice(const std::string& name) const {
        const size_t i = index(name);
        return schema_[i].choices[size_t(values_[i][0])];
    }
    bool given(const std::string& name) const { return given_[index(name)]; }
    // The value of schema row i (3 numbers; Choice: the index, Bool: 0 / 1).
    const ParamValue& at(size_t i) const { return values_[i]; }
    // Every channel of a + b in [0, 1] (the zoo's energy bounds).
    void check_sum_at_most_one(const std::string& a, const std::string& b) const {
        const RGB x = color(a), y = color(b);
        const RGB s = x + y;
        if (s.r > 1 + 1e-12 || s.g > 1 + 1e-12 || s.b > 1 + 1e-12)
            throw ModelError(owner_ + ": " + a + " + " + b + " = " + triple_text({s.r, s.g, s.b}) +
                             " is out of range; each channel of the sum must lie in [0, 1] (energy bound)");
    }

private:
    size_t index(const std::string& name) const {
        for (size_t i = 0; i < schema_.size(); ++i)
            if (schema_[i].name == name) return i;
        std::vector<std::string> names;
        for (const ModelParamSpec& p : schema_) names.push_back(p.name);
        throw ModelError(owner_ + " has no parameter '" + name + "'; allowed: " + join(names));
    }
    [[noreturn]] void fail(const ModelParamSpec& p, const ModelParamValue& v, const std::string& what) const {
        throw ModelError(owner_ + ": parameter " + p.name + "=" + value_text(v) + " " + what);
    }
    std::array<double, 3> convert(const ModelParamSpec& p, const ModelParamValue& v) const {
        const double* x = std::get_if<double>(&v);
        const auto* t = std::get_if<std::array<double, 3>>(&v);
        const std::string* s = std::get_if<std::string>(&v);
        switch (p.kind) {
            case ParamKind::Float:
                if (!x) fail(p, v, "is not allowed; expected a number");
                if (!(*x >= p.min_value && *x <= p.max_value)) fail(p, v, "is out of range; allowed: " + range_text(p));
                return {*x, *x, *x};
            case ParamKind::RGB: {
                if (s) fail(p, v, "is not allowed; expected an RGB triple or a number (grey)");
                const std::array<double, 3> c = t ? *t : std::array<double, 3>{*x, *x, *x};
                for (double ch : c)
                    if (!(ch >= p.min_value && ch <= p.max_value))
                        fail(p, v, "is out of range; every channel must lie in " + range_text(p));
                return c;
            }
            case ParamKind::Choice:
                if (s) {
                    for (size_t i = 0; i < p.choices.size(); ++i)
                        if (p.choices[i] == *s) return {double(i), double(i), double(i)};
                }
                fail(p, v, "is not allowed; choose one of: " + join(p.choices));
            case ParamKind::Bool:
                if (!x || !(*x == 0.0 || *x == 1.0)) fail(p, v, "is not allowed; expected a bool (0 or 1)");
                return {*x, *x, *x};
            case ParamKind::Int:
                if (!x || !(*x == std::floor(*x))) fail(p, v, "is not allowed; expected a whole number");
                if (!(*x >= p.min_value && *x <= p.max_value)) fail(p, v, "is out of range; allowed: " + range_text(p));
                return {*x, *x, *x};
            case ParamKind::Vector2:
                break;  // MaterialX's node tables only (params/materialx.h), never a model's
        }
        fail(p, v, "has an unknown kind");
    }

    std::string owner_;
    const std::vector<ModelParamSpec>& schema_;
    std::vector<std::array<double, 3>> values_;
    std::vector<bool> given_;
};

// A zoo model's schema: its table's rows (params/<model>.h).
template <class P>
const std::vector<ModelParamSpec>& schema_of() {
    static const std::vector<ModelParamSpec> s = param_specs<P>();
    return s;
}

std::string owner(const std::string& model) { return "model '" + model + "'"; }

// The rules a table's rows do not say: energy bounds between parameters, inputs that derive a field.
void finish(const Values& v, KajiyaKayHairParams&) { v.check_sum_at_most_one("diffuse", "specular"); }
void finish(const Values& v, ScheuermannHairParams&) { v.check_sum_at_most_one("primary_color", "secondary_color"); }
void finish(const Values& v, DeonHairParams& p) {
    if (!v.given("sigma_a"))
        p.sigma_a = deon_sigma_a(v.number("melanin"), v.number("melanin_redness"), v.choice("pigments") == "deon");
}
void finish(const Values&, EpicHairParams&) {}
void finish(const Values&, MarschnerHairParams&) {}
void finish(const Values&, YanFurParams&) {}
void finish(const Values&, CyclesHairParams&) {}

// The checked values set every bound row's field of a default P; then the model's own rules.
template <class P, class Model>
HairModel build(const ModelParams& given) {
    const Values v(owner(ParamTable<P>::model), schema_of<P>(), given);
    P p;
    const std::vector<ParamRow<P>>& rows = ParamTable<P>::rows();
    for (size_t i = 0; i < rows.size(); ++i)
        if (rows[i].set) rows[i].set(p, v.at(i));
    finish(v, p);
    return Model(p);
}

struct ZooEntry {
    const char* name;
    const char* title;
    const char* summary;
    const std::vector<ModelParamSpec>& (*schema)();
    HairModel (*build)(const ModelParams&);
};
template <class P, class Model>
constexpr ZooEntry entry() {
    return {ParamTable<P>::model, ParamTable<P>::title, ParamTable<P>::summary, schema_of<P>, build<P, Model>};
}
const ZooEntry kZoo[] = {entry<KajiyaKayHairParams, KajiyaKayHair>(),   entry<EpicHairParams, EpicHair>(),
                         entry<ScheuermannHairParams, ScheuermannHair>(), entry<MarschnerHairParams, MarschnerHair>(),
                         entry<DeonHairParams, DeonHair>(),             entry<YanFurParams, YanFurHair>()};

// Cycles nodes' closures built by name from their tables, outside the zoo (and its menu).
const ZooEntry kNodeModels[] = {entry<CyclesHairParams, CyclesHair>()};

const ZooEntry& zoo_entry(const std::string& model) {
    for (const ZooEntry& e : kZoo)
        if (model == e.name) return e;
    for (const ZooEntry& e : kNodeModels)
        if (model == e.name) return e;
    throw ModelError("unknown model '" + model + "'; allowed: " + join(model_names()));
}

}  // namespace

const std::vector<std::string>& zoo_model_names() {
    static const std::vector<std::string> names = [] {
        std::vector<std::string> out;
        for (const ZooEntry& e : kZoo) out.push_back(e.name);
        return out;
    }();
    return names;
}

const std::vector<std::string>& model_names() {
    static const std::vector<std::string> names = [] {
        std::vector<std::string> out = zoo_model_names();
        for (const ZooEntry& e : kNodeModels) out.push_back(e.name);
        out.push_back(kPluginModel);
        return out;
    }();
    return names;
}

const std::vector<ZooModel>& zoo_models() {
    static const std::vector<ZooModel> models = [] {
        std::vector<ZooModel> out;
        for (const ZooEntry& e : kZoo) out.push_back({e.name, e.title, e.summary});
        return out;
    }();
    return models;
}

bool is_zoo_model(const std::string& model) {
    for (const ZooEntry& e : kZoo)
        if (model == e.name) return true;
    return false;
}

const std::vector<ModelParamSpec>& zoo_model_schema(const std::string& model) { return zoo_entry(model).schema(); }

std::vector<ModelParamSpec> plugin_model_schema(const PluginLibrary& library) {
    std::vector<ModelParamSpec> out;
    for (const PluginParam& q : library.params()) {
        ModelParamSpec p;
        p.name = q.name;
        p.kind = q.rgb ? ParamKind::RGB : ParamKind::Float;
        p.default_value = q.default_value;
        p.min_value = q.min_value;
        p.max_value = q.max_value;
        p.description = q.description;
        out.push_back(p);
    }
    return out;
}

std::vector<ModelParamSpec> model_schema(const std::string& model, const std::string& path) {
    if (model == kPluginModel) return plugin_model_schema(*load_plugin(path));
    return zoo_model_schema(model);
}

HairModel make_zoo_model(const std::string& model, const ModelParams& params) { return zoo_entry(model).build(params); }

HairModel make_plugin_model(const std::string& path, const ModelParams& params) {
    const std::shared_ptr<const PluginLibrary> library = load_plugin(path);
    const std::vector<ModelParamSpec> schema = plugin_model_schema(*library);
    const Values v("plugin '" + library->name() + "'", schema, params);  // names, types and ranges
    std::vector<std::pair<std::string, std::array<double, 3>>> values;
    for (const ModelParamSpec& p : schema) {
        const RGB c = v.color(p.name);
        values.push_back({p.name, {c.r, c.g, c.b}});
    }
    return PluginHair(library, library->values(values));
}

HairModel make_model(const std::string& model, const std::string& path, const ModelParams& params) {
    if (model == kPluginModel) return make_plugin_model(path, params);
    return make_zoo_model(model, params);
}

}  // namespace hairbsdf
