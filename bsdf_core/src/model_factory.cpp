// The zoo's parameter tables and the builder of models by name; see model_factory.h.
// Defaults, ranges and their sources: docs/models.md (one section per model).
#include "hairbsdf/model_factory.h"

#include <cmath>
#include <sstream>

#include "hairbsdf/params/principled_hair.h"

namespace hairbsdf {

namespace {

// --- schema tables ------------------------------------------------------------------------------
ModelParamSpec real(const char* name, double def, double lo, double hi, const char* description) {
    return {name, ParamKind::Float, {def, def, def}, lo, hi, {}, false, description};
}
ModelParamSpec rgb(const char* name, std::array<double, 3> def, double lo, double hi, const char* description) {
    return {name, ParamKind::RGB, def, lo, hi, {}, false, description};
}
ModelParamSpec choice(const char* name, std::vector<std::string> choices, const char* description) {
    return {name, ParamKind::Choice, {0, 0, 0}, 0, double(choices.size() - 1), std::move(choices), false, description};
}
// Epic's and Marschner's `energy` (models/energy_bound.h); `source` names where "published" comes from.
ModelParamSpec energy_choice(const std::string& source) {
    ModelParamSpec spec = choice("energy", {energy_mode_name(EnergyMode::Bounded), energy_mode_name(EnergyMode::Published)},
                                 "");
    spec.description = "bounded: eval / max(1, albedo) per channel, so no view creates energy; published: as in " + source;
    return spec;
}
ModelParamSpec flag(const char* name, bool def, const char* description) {
    const double v = def ? 1.0 : 0.0;
    return {name, ParamKind::Bool, {v, v, v}, 0, 1, {}, false, description};
}

// --- one table per model -----------------------------------------------------------------------
// A row: the parameter's schema (name, range, meaning) and the Params field it sets. A field's
// default is its value in a default-constructed Params (the model's header), so each default is
// written once; rows without a field (choices, derived values) are applied by the builder.
template <class P>
struct Field {
    ModelParamSpec spec;
    double P::*number = nullptr;
    RGB P::*color = nullptr;
    bool P::*boolean = nullptr;
};
template <class P>
Field<P> number_field(const char* name, double P::*field, double lo, double hi, const char* description) {
    return {real(name, P{}.*field, lo, hi, description), field, nullptr, nullptr};
}
template <class P>
Field<P> color_field(const char* name, RGB P::*field, double lo, double hi, const char* description) {
    const RGB d = P{}.*field;
    return {rgb(name, {d.r, d.g, d.b}, lo, hi, description), nullptr, field, nullptr};
}
template <class P>
Field<P> flag_field(const char* name, bool P::*field, const char* description) {
    return {flag(name, P{}.*field, description), nullptr, nullptr, field};
}
template <class P>
Field<P> builder_row(ModelParamSpec spec) {
    return {std::move(spec), nullptr, nullptr, nullptr};
}

template <class P>
std::vector<ModelParamSpec> specs_of(const std::vector<Field<P>>& fields) {
    std::vector<ModelParamSpec> out;
    for (const Field<P>& f : fields) out.push_back(f.spec);
    return out;
}

const std::vector<Field<KajiyaKayHairParams>>& kajiya_kay_fields() {
    using P = KajiyaKayHairParams;
    static const std::vector<Field<P>> s = {
        color_field<P>("diffuse", &P::diffuse, 0, 1, "K_d, the diffuse albedo (diffuse + specular <= 1 per channel)"),
        color_field<P>("specular", &P::specular, 0, 1, "K_s, the specular albedo at normal view"),
        number_field<P>("exponent", &P::exponent, 0, 10000, "p, the Phong exponent of the specular cone (lobe width 1/sqrt(p))"),
    };
    return s;
}

const std::vector<Field<EpicHairParams>>& epic_fields() {
    using P = EpicHairParams;
    static const std::vector<Field<P>> s = {
        color_field<P>("base_color", &P::base_color, 0, 1, "C, the fibre colour"),
        builder_row<P>(real("specular", 0.5 * P{}.r_scale, 0, 1, "scales R by specular / 0.5 (0.5: R as published)")),
        number_field<P>("scatter", &P::scatter, 0, 1, "scales the multiple-scattering fake (0: single fibre only)"),
        number_field<P>("roughness", &P::roughness, 0, 1, "r: beta_R = r^2, beta_TT = beta_R / 2, beta_TRT = 2 beta_R"),
        number_field<P>("shift", &P::shift, -0.25, 0.25, "alpha_R = -2 shift, alpha_TT = shift, alpha_TRT = 4 shift (sin theta)"),
        builder_row<P>(choice("variant", {"direct", "environment"}, "direct lights, or the environment-light variant")),
        builder_row<P>(energy_choice("the notes")),
    };
    return s;
}

const std::vector<Field<ScheuermannHairParams>>& scheuermann_fields() {
    using P = ScheuermannHairParams;
    static const std::vector<Field<P>> s = {
        color_field<P>("primary_color", &P::primary_color, 0, 1, "c_1 (primary + secondary <= 1 per channel)"),
        color_field<P>("secondary_color", &P::secondary_color, 0, 1, "c_2, the hair-coloured secondary highlight"),
        number_field<P>("primary_exponent", &P::primary_exponent, 0, 10000, "p_1"),
        number_field<P>("secondary_exponent", &P::secondary_exponent, 0, 10000, "p_2"),
        number_field<P>("primary_shift", &P::primary_shift, -1, 1, "tangent shift of lobe 1 (tan 2 deg)"),
        number_field<P>("secondary_shift", &P::secondary_shift, -1, 1, "tangent shift of lobe 2 (-tan 4 deg)"),
        number_field<P>("shift_texture", &P::shift_texture, 0, 1, "the shift texture's value (0.5: no extra shift)"),
        number_field<P>("noise", &P::noise, 0, 1, "the noise texture's value, masks lobe 2"),
    };
    return s;
}

const std::vector<Field<MarschnerHairParams>>& marschner_fields() {
    using P = MarschnerHairParams;
    static const std::vector<Field<P>> s = {
        color_field<P>("sigma_a", &P::sigma_a, 0, 1e4, "absorption per unit diameter"),
        number_field<P>("eta", &P::eta, 1.1, 3, "index of refraction"),
        number_field<P>("eccentricity", &P::eccentricity, 0.5, 1, "a, the cross-section's axis ratio"),
        number_field<P>("alpha_r", &P::alpha_r, -0.35, 0.35, "R shift (rad); alpha_TT = -alpha_r / 2, alpha_TRT = -3 alpha_r / 2"),
        number_field<P>("beta_r", &P::beta_r, 0.005, 0.7, "R width (rad); beta_TT = beta_r / 2, beta_TRT = 2 beta_r"),
        number_field<P>("glint_scale", &P::glint_scale, 0, 5, "k_G"),
        number_field<P>("caustic_width", &P::caustic_width, 0.01, 0.7, "w_c (rad)"),
        number_field<P>("caustic_fade", &P::caustic_fade, 0, 1, "Delta eta*"),
        number_field<P>("caustic_limit", &P::caustic_limit, 0, 1, "Delta h_M"),
        builder_row<P>(energy_choice("the paper")),
    };
    return s;
}

// d'Eon's pigment constants (seed 004), per unit concentration and diameter.
constexpr RGB kDeonEumelanin{0.419, 0.697, 1.37};
constexpr RGB kDeonPheomelanin{0.187, 0.4, 1.05};

RGB deon_sigma_a(double melanin, double redness, bool deon_pigments) {
    if (!deon_pigments) return absorption_from_melanin(melanin, redness, RGB(1.0), 0.3);
    const double q = -std::log(std::max(1.0 - melanin, 1e-4));
    return (q * (1 - redness)) * kDeonEumelanin + (q * redness) * kDeonPheomelanin;
}

// Melanin, its redness and the pigment constants are the factory's own inputs: they give sigma_a
// unless sigma_a is given.
const std::vector<Field<DeonHairParams>>& deon_fields() {
    using P = DeonHairParams;
    static const std::vector<Field<P>> s = [] {
        ModelParamSpec sigma = rgb("sigma_a", {0, 0, 0}, 0, 1e4, "absorption; overrides melanin when given");
        const RGB d = deon_sigma_a(0.8, 1.0, false);
        sigma.default_value = {d.r, d.g, d.b};  // what melanin's defaults give (shown, not used)
        sigma.optional = true;
        return std::vector<Field<P>>{
            builder_row<P>(real("melanin", 0.8, 0, 1, "melanin concentration (Principled Hair's mapping)")),
            builder_row<P>(real("melanin_redness", 1.0, 0, 1, "pheomelanin share")),
            builder_row<P>(choice("pigments", {"cycles", "deon"}, "pigment constants: Cycles' or d'Eon's (seed 004)")),
            builder_row<P>(sigma),
            number_field<P>("eta", &P::eta, 1.1, 3, "index of refraction"),
            number_field<P>("roughness", &P::roughness, 0.02, 1, "beta_R (rad); TT x1/2, TRT x2"),
            number_field<P>("tilt", &P::tilt, -0.2, 0.2, "cuticle tilt alpha (rad)"),
            flag_field<P>("tabulated", &P::tabulated, "tables over (|sin theta_o|, phi), or direct quadrature"),
        };
    }();
    return s;
}

const std::vector<Field<YanFurParams>>& yan_fur_fields() {
    using P = YanFurParams;
    static const std::vector<Field<P>> s = {
        number_field<P>("medulla_ratio", &P::medulla_ratio, 0, 0.99, "kappa, the medulla's radius over the fibre's"),
        color_field<P>("cortex_absorption", &P::cortex_absorption, 0, 1e4, "sigma_ca, cortex absorption per unit radius"),
        number_field<P>("medulla_absorption", &P::medulla_absorption, 0, 10, "sigma_ma, medulla absorption per unit radius"),
        number_field<P>("medulla_scattering", &P::medulla_scattering, 0, 10, "sigma_ms, medulla scattering per unit radius"),
        number_field<P>("medulla_g", &P::medulla_g, -0.9, 0.9, "Henyey-Greenstein asymmetry of the medulla (0: isotropic)"),
        number_field<P>("eta", &P::eta, 1.1, 3, "index of refraction of cortex and medulla"),
        number_field<P>("alpha", &P::alpha, -0.2, 0.2, "cuticle tilt (rad, Principled Hair's Offset convention); 5.48 deg"),
        number_field<P>("roughness", &P::roughness, 0.01, 1, "Chiang's beta_m; default: R's longitudinal sd = 11.64 deg"),
        number_field<P>("radial_roughness", &P::radial_roughness, 0.01, 1, "Chiang's beta_n; default: azimuthal sd = 7.49 deg"),
    };
    return s;
}

#define HAIRBSDF_SCHEMA_OF(model)                                                  \
    const std::vector<ModelParamSpec>& model##_schema() {                          \
        static const std::vector<ModelParamSpec> s = specs_of(model##_fields());   \
        return s;                                                                  \
    }
HAIRBSDF_SCHEMA_OF(kajiya_kay)
HAIRBSDF_SCHEMA_OF(epic)
HAIRBSDF_SCHEMA_OF(scheuermann)
HAIRBSDF_SCHEMA_OF(marschner)
HAIRBSDF_SCHEMA_OF(deon)
HAIRBSDF_SCHEMA_OF(yan_fur)
#undef HAIRBSDF_SCHEMA_OF

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
        }
        fail(p, v, "has an unknown kind");
    }

    std::string owner_;
    const std::vector<ModelParamSpec>& schema_;
    std::vector<std::array<double, 3>> values_;
    std::vector<bool> given_;
};

// Sets every field row's Params field from the checked values.
template <class P>
void apply_fields(const std::vector<Field<P>>& fields, const Values& v, P& p) {
    for (const Field<P>& f : fields) {
        if (f.number) p.*f.number = v.number(f.spec.name);
        if (f.color) p.*f.color = v.color(f.spec.name);
        if (f.boolean) p.*f.boolean = v.number(f.spec.name) != 0.0;
    }
}

std::string owner(const std::string& model) { return "model '" + model + "'"; }

EnergyMode energy_mode(const Values& v) {
    return v.choice("energy") == energy_mode_name(EnergyMode::Bounded) ? EnergyMode::Bounded : EnergyMode::Published;
}

HairModel build_kajiya_kay(const ModelParams& given) {
    const Values v(owner("kajiya_kay"), kajiya_kay_schema(), given);
    v.check_sum_at_most_one("diffuse", "specular");
    KajiyaKayHairParams p;
    apply_fields(kajiya_kay_fields(), v, p);
    return KajiyaKayHair(p);
}

HairModel build_epic(const ModelParams& given) {
    const Values v(owner("epic"), epic_schema(), given);
    EpicHairParams p;
    apply_fields(epic_fields(), v, p);
    p.r_scale = v.number("specular") / 0.5;
    p.variant = v.choice("variant") == "direct" ? EpicVariant::Direct : EpicVariant::Environment;
    p.energy = energy_mode(v);
    return EpicHair(p);
}

HairModel build_scheuermann(const ModelParams& given) {
    const Values v(owner("scheuermann"), scheuermann_schema(), given);
    v.check_sum_at_most_one("primary_color", "secondary_color");
    ScheuermannHairParams p;
    apply_fields(scheuermann_fields(), v, p);
    return ScheuermannHair(p);
}

HairModel build_marschner(const ModelParams& given) {
    const Values v(owner("marschner"), marschner_schema(), given);
    MarschnerHairParams p;
    apply_fields(marschner_fields(), v, p);
    p.energy = energy_mode(v);
    return MarschnerHair(p);
}

HairModel build_deon(const ModelParams& given) {
    const Values v(owner("deon"), deon_schema(), given);
    DeonHairParams p;
    apply_fields(deon_fields(), v, p);
    p.sigma_a = v.given("sigma_a") ? v.color("sigma_a")
                                   : deon_sigma_a(v.number("melanin"), v.number("melanin_redness"),
                                                  v.choice("pigments") == "deon");
    return DeonHair(p);
}

HairModel build_yan_fur(const ModelParams& given) {
    const Values v(owner("yan_fur"), yan_fur_schema(), given);
    YanFurParams p;
    apply_fields(yan_fur_fields(), v, p);
    return YanFurHair(p);
}

struct ZooEntry {
    const char* name;
    const std::vector<ModelParamSpec>& (*schema)();
    HairModel (*build)(const ModelParams&);
};
const ZooEntry kZoo[] = {{"kajiya_kay", kajiya_kay_schema, build_kajiya_kay},
                         {"epic", epic_schema, build_epic},
                         {"scheuermann", scheuermann_schema, build_scheuermann},
                         {"marschner", marschner_schema, build_marschner},
                         {"deon", deon_schema, build_deon},
                         {"yan_fur", yan_fur_schema, build_yan_fur}};

const ZooEntry& zoo_entry(const std::string& model) {
    for (const ZooEntry& e : kZoo)
        if (model == e.name) return e;
    throw ModelError("unknown model '" + model + "'; allowed: " + join(zoo_model_names()) + ", plugin");
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
    if (model == "plugin") return plugin_model_schema(*load_plugin(path));
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
    if (model == "plugin") return make_plugin_model(path, params);
    return make_zoo_model(model, params);
}

}  // namespace hairbsdf
