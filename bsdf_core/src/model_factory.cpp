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

const std::vector<ModelParamSpec>& kajiya_kay_schema() {
    static const std::vector<ModelParamSpec> s = {
        rgb("diffuse", {0.5, 0.5, 0.5}, 0, 1, "K_d, the diffuse albedo (diffuse + specular <= 1 per channel)"),
        rgb("specular", {0.5, 0.5, 0.5}, 0, 1, "K_s, the specular albedo at normal view"),
        real("exponent", 60, 0, 10000, "p, the Phong exponent of the specular cone (lobe width 1/sqrt(p))"),
    };
    return s;
}

const std::vector<ModelParamSpec>& epic_schema() {
    static const std::vector<ModelParamSpec> s = {
        rgb("base_color", {0.017513, 0.005763, 0.002059}, 0, 1, "C, the fibre colour"),
        real("specular", 0.5, 0, 1, "scales R by specular / 0.5 (0.5: R as published)"),
        real("scatter", 0, 0, 1, "scales the multiple-scattering fake (0: single fibre only)"),
        real("roughness", 0.35, 0, 1, "r: beta_R = r^2, beta_TT = beta_R / 2, beta_TRT = 2 beta_R"),
        real("shift", 0.035, -0.25, 0.25, "alpha_R = -2 shift, alpha_TT = shift, alpha_TRT = 4 shift (sin theta)"),
        choice("variant", {"direct", "environment"}, "direct lights, or the environment-light variant"),
        energy_choice("the notes"),
    };
    return s;
}

const std::vector<ModelParamSpec>& scheuermann_schema() {
    static const std::vector<ModelParamSpec> s = {
        rgb("primary_color", {0.5, 0.5, 0.5}, 0, 1, "c_1 (primary + secondary <= 1 per channel)"),
        rgb("secondary_color", {0.5, 0.35, 0.2}, 0, 1, "c_2, the hair-coloured secondary highlight"),
        real("primary_exponent", 240, 0, 10000, "p_1"),
        real("secondary_exponent", 60, 0, 10000, "p_2"),
        real("primary_shift", 0.0349208, -1, 1, "tangent shift of lobe 1 (tan 2 deg)"),
        real("secondary_shift", -0.0699268, -1, 1, "tangent shift of lobe 2 (-tan 4 deg)"),
        real("shift_texture", 0.5, 0, 1, "the shift texture's value (0.5: no extra shift)"),
        real("noise", 1, 0, 1, "the noise texture's value, masks lobe 2"),
    };
    return s;
}

const std::vector<ModelParamSpec>& marschner_schema() {
    static const std::vector<ModelParamSpec> s = {
        rgb("sigma_a", {0.245531, 0.52, 1.365}, 0, 1e4, "absorption per unit diameter"),
        real("eta", 1.55, 1.1, 3, "index of refraction"),
        real("eccentricity", 0.9, 0.5, 1, "a, the cross-section's axis ratio"),
        real("alpha_r", -0.1309, -0.35, 0.35, "R shift (rad); alpha_TT = -alpha_r / 2, alpha_TRT = -3 alpha_r / 2"),
        real("beta_r", 0.1309, 0.005, 0.7, "R width (rad); beta_TT = beta_r / 2, beta_TRT = 2 beta_r"),
        real("glint_scale", 0.5, 0, 5, "k_G"),
        real("caustic_width", 0.2618, 0.01, 0.7, "w_c (rad)"),
        real("caustic_fade", 0.3, 0, 1, "Delta eta*"),
        real("caustic_limit", 0.5, 0, 1, "Delta h_M"),
        energy_choice("the paper"),
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

const std::vector<ModelParamSpec>& deon_schema() {
    static const std::vector<ModelParamSpec> s = [] {
        ModelParamSpec sigma = rgb("sigma_a", {0, 0, 0}, 0, 1e4, "absorption; overrides melanin when given");
        const RGB d = deon_sigma_a(0.8, 1.0, false);
        sigma.default_value = {d.r, d.g, d.b};  // what melanin's defaults give (shown, not used)
        sigma.optional = true;
        return std::vector<ModelParamSpec>{
            real("melanin", 0.8, 0, 1, "melanin concentration (Principled Hair's mapping)"),
            real("melanin_redness", 1.0, 0, 1, "pheomelanin share"),
            choice("pigments", {"cycles", "deon"}, "pigment constants: Cycles' or d'Eon's (seed 004)"),
            sigma,
            real("eta", 1.55, 1.1, 3, "index of refraction"),
            real("roughness", 0.1309, 0.02, 1, "beta_R (rad); TT x1/2, TRT x2"),
            real("tilt", 0.0349066, -0.2, 0.2, "cuticle tilt alpha (rad)"),
            flag("tabulated", true, "tables over (|sin theta_o|, phi), or direct quadrature"),
        };
    }();
    return s;
}

const std::vector<ModelParamSpec>& yan_fur_schema() {
    static const std::vector<ModelParamSpec> s = {
        real("medulla_ratio", 0.88, 0, 0.99, "kappa, the medulla's radius over the fibre's"),
        rgb("cortex_absorption", {0.64, 0.64, 0.64}, 0, 1e4, "sigma_ca, cortex absorption per unit radius"),
        real("medulla_absorption", 0.17, 0, 10, "sigma_ma, medulla absorption per unit radius"),
        real("medulla_scattering", 1.69, 0, 10, "sigma_ms, medulla scattering per unit radius"),
        real("medulla_g", 0, -0.9, 0.9, "Henyey-Greenstein asymmetry of the medulla (0: isotropic)"),
        real("eta", 1.55, 1.1, 3, "index of refraction of cortex and medulla"),
        real("alpha", 0.0956440430, -0.2, 0.2, "cuticle tilt (rad, Principled Hair's Offset convention); 5.48 deg"),
        real("roughness", 0.2238067333, 0.01, 1, "Chiang's beta_m; default: R's longitudinal sd = 11.64 deg"),
        real("radial_roughness", 0.2186326880, 0.01, 1, "Chiang's beta_n; default: azimuthal sd = 7.49 deg"),
    };
    return s;
}

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

std::string owner(const std::string& model) { return "model '" + model + "'"; }

EnergyMode energy_mode(const Values& v) {
    return v.choice("energy") == energy_mode_name(EnergyMode::Bounded) ? EnergyMode::Bounded : EnergyMode::Published;
}

HairModel build_kajiya_kay(const ModelParams& given) {
    const Values v(owner("kajiya_kay"), kajiya_kay_schema(), given);
    v.check_sum_at_most_one("diffuse", "specular");
    KajiyaKayHairParams p;
    p.diffuse = v.color("diffuse");
    p.specular = v.color("specular");
    p.exponent = v.number("exponent");
    return KajiyaKayHair(p);
}

HairModel build_epic(const ModelParams& given) {
    const Values v(owner("epic"), epic_schema(), given);
    EpicHairParams p;
    p.base_color = v.color("base_color");
    p.r_scale = v.number("specular") / 0.5;
    p.scatter = v.number("scatter");
    p.roughness = v.number("roughness");
    p.shift = v.number("shift");
    p.variant = v.choice("variant") == "direct" ? EpicVariant::Direct : EpicVariant::Environment;
    p.energy = energy_mode(v);
    return EpicHair(p);
}

HairModel build_scheuermann(const ModelParams& given) {
    const Values v(owner("scheuermann"), scheuermann_schema(), given);
    v.check_sum_at_most_one("primary_color", "secondary_color");
    ScheuermannHairParams p;
    p.primary_color = v.color("primary_color");
    p.secondary_color = v.color("secondary_color");
    p.primary_exponent = v.number("primary_exponent");
    p.secondary_exponent = v.number("secondary_exponent");
    p.primary_shift = v.number("primary_shift");
    p.secondary_shift = v.number("secondary_shift");
    p.shift_texture = v.number("shift_texture");
    p.noise = v.number("noise");
    return ScheuermannHair(p);
}

HairModel build_marschner(const ModelParams& given) {
    const Values v(owner("marschner"), marschner_schema(), given);
    MarschnerHairParams p;
    p.sigma_a = v.color("sigma_a");
    p.eta = v.number("eta");
    p.eccentricity = v.number("eccentricity");
    p.alpha_r = v.number("alpha_r");
    p.beta_r = v.number("beta_r");
    p.glint_scale = v.number("glint_scale");
    p.caustic_width = v.number("caustic_width");
    p.caustic_fade = v.number("caustic_fade");
    p.caustic_limit = v.number("caustic_limit");
    p.energy = energy_mode(v);
    return MarschnerHair(p);
}

HairModel build_deon(const ModelParams& given) {
    const Values v(owner("deon"), deon_schema(), given);
    DeonHairParams p;
    p.sigma_a = v.given("sigma_a") ? v.color("sigma_a")
                                   : deon_sigma_a(v.number("melanin"), v.number("melanin_redness"),
                                                  v.choice("pigments") == "deon");
    p.eta = v.number("eta");
    p.roughness = v.number("roughness");
    p.tilt = v.number("tilt");
    p.tabulated = v.number("tabulated") != 0.0;
    return DeonHair(p);
}

HairModel build_yan_fur(const ModelParams& given) {
    const Values v(owner("yan_fur"), yan_fur_schema(), given);
    YanFurParams p;
    p.medulla_ratio = v.number("medulla_ratio");
    p.cortex_absorption = v.color("cortex_absorption");
    p.medulla_absorption = v.number("medulla_absorption");
    p.medulla_scattering = v.number("medulla_scattering");
    p.medulla_g = v.number("medulla_g");
    p.eta = v.number("eta");
    p.alpha = v.number("alpha");
    p.roughness = v.number("roughness");
    p.radial_roughness = v.number("radial_roughness");
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
