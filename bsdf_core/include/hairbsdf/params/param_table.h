// A model's parameter table: one row per named parameter, its schema (name, kind, range, meaning)
// and how it reads and writes the model's Params struct. A row's default is read from a
// default-constructed Params (the model header), so each default is written once.
//
// Each params/<model>.h defines ParamTable<its Params> beside the struct it describes: `model` (the
// factory's name), `title` and `summary` (Blender's override menu) and `rows()`. The factory
// (model_factory.cpp), the bindings' model dicts, the Python keywords (hairbsdf.zoo), the Blender
// override panel and the test of docs/models.md all derive from these tables.
#pragma once

#include <array>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "hairbsdf/math.h"
#include "hairbsdf/model_params.h"
#include "hairbsdf/models/energy_bound.h"

namespace hairbsdf {

// A checked value as the factory holds it: a number three times, an RGB, a choice's index, 0 / 1.
using ParamValue = std::array<double, 3>;

template <class P>
struct ParamRow {
    ModelParamSpec spec;
    // Both null for a row that is no field of P (an input the model's builder derives from).
    std::function<ParamValue(const P&)> get;
    std::function<void(P&, const ParamValue&)> set;
};

// Defined by each params/<model>.h for its Params struct.
template <class P>
struct ParamTable;

// The table's schema rows, in order.
template <class P>
std::vector<ModelParamSpec> param_specs() {
    std::vector<ModelParamSpec> out;
    for (const ParamRow<P>& row : ParamTable<P>::rows()) out.push_back(row.spec);
    return out;
}

namespace param_rows {

inline ModelParamSpec spec(const char* name, ParamKind kind, double lo, double hi, const char* description) {
    ModelParamSpec s;
    s.name = name;
    s.kind = kind;
    s.min_value = lo;
    s.max_value = hi;
    s.description = description;
    return s;
}

// A row bound by get / set; its default is get(P{}).
template <class P>
ParamRow<P> bound(ModelParamSpec s, std::function<ParamValue(const P&)> get, std::function<void(P&, const ParamValue&)> set) {
    s.default_value = get(P{});
    return {std::move(s), std::move(get), std::move(set)};
}

template <class P>
ParamRow<P> number(const char* name, double P::*field, double lo, double hi, const char* description) {
    return bound<P>(
        spec(name, ParamKind::Float, lo, hi, description), [field](const P& p) { return ParamValue{p.*field, p.*field, p.*field}; },
        [field](P& p, const ParamValue& v) { p.*field = v[0]; });
}

template <class P>
ParamRow<P> color(const char* name, RGB P::*field, double lo, double hi, const char* description) {
    return bound<P>(
        spec(name, ParamKind::RGB, lo, hi, description),
        [field](const P& p) { return ParamValue{(p.*field).r, (p.*field).g, (p.*field).b}; },
        [field](P& p, const ParamValue& v) { p.*field = RGB{v[0], v[1], v[2]}; });
}

template <class P>
ParamRow<P> flag(const char* name, bool P::*field, const char* description) {
    return bound<P>(
        spec(name, ParamKind::Bool, 0, 1, description),
        [field](const P& p) {
            const double x = p.*field ? 1.0 : 0.0;
            return ParamValue{x, x, x};
        },
        [field](P& p, const ParamValue& v) { p.*field = v[0] != 0.0; });
}

// The largest whole number an Int row holds exactly (a double's 2^53).
constexpr double kMaxInteger = 9007199254740992.0;

template <class P>
ParamRow<P> integer(const char* name, long P::*field, double lo, double hi, const char* description) {
    return bound<P>(
        spec(name, ParamKind::Int, lo, hi, description),
        [field](const P& p) {
            const double x = double(p.*field);
            return ParamValue{x, x, x};
        },
        [field](P& p, const ParamValue& v) { p.*field = long(v[0]); });
}

// An enum field chosen by name: `choices` pairs each name with its value, in the schema's order.
template <class P, class E>
ParamRow<P> choice(const char* name, E P::*field, std::vector<std::pair<std::string, E>> choices, const char* description) {
    ModelParamSpec s = spec(name, ParamKind::Choice, 0, double(choices.size() - 1), description);
    for (const auto& c : choices) s.choices.push_back(c.first);
    auto get = [field, choices](const P& p) {
        double index = 0;
        for (size_t i = 0; i < choices.size(); ++i)
            if (choices[i].second == p.*field) index = double(i);
        return ParamValue{index, index, index};
    };
    auto set = [field, choices](P& p, const ParamValue& v) { p.*field = choices[size_t(v[0])].second; };
    return bound<P>(std::move(s), get, set);
}

// A number the model stores in another form (Epic's specular as r_scale): get and set convert.
template <class P>
ParamRow<P> converted(const char* name, double lo, double hi, const char* description, std::function<double(const P&)> get,
                      std::function<void(P&, double)> set) {
    return bound<P>(
        spec(name, ParamKind::Float, lo, hi, description),
        [get](const P& p) {
            const double x = get(p);
            return ParamValue{x, x, x};
        },
        [set](P& p, const ParamValue& v) { set(p, v[0]); });
}

// Epic's and Marschner's `energy` (models/energy_bound.h); `source` names where "published" comes from.
template <class P>
ParamRow<P> energy(const std::string& source) {
    ParamRow<P> row = choice<P, EnergyMode>(
        "energy", &P::energy,
        {{energy_mode_name(EnergyMode::Bounded), EnergyMode::Bounded},
         {energy_mode_name(EnergyMode::Published), EnergyMode::Published}},
        "");
    row.spec.description = "bounded: eval / max(1, albedo) per channel, so no view creates energy; published: as in " + source;
    return row;
}

// An input that is no field of P (the builder derives fields from it), with its own default.
template <class P>
ParamRow<P> input(ModelParamSpec s, ParamValue default_value) {
    s.default_value = default_value;
    return {std::move(s), nullptr, nullptr};
}
template <class P>
ParamRow<P> input_number(const char* name, double def, double lo, double hi, const char* description) {
    return input<P>(spec(name, ParamKind::Float, lo, hi, description), {def, def, def});
}
// A choice input; its default is the first choice.
template <class P>
ParamRow<P> input_choice(const char* name, const std::vector<std::string>& choices, const char* description) {
    ModelParamSpec s = spec(name, ParamKind::Choice, 0, double(choices.size() - 1), description);
    s.choices = choices;
    return input<P>(std::move(s), {0, 0, 0});
}

}  // namespace param_rows

}  // namespace hairbsdf
