// Named model parameters as plain data: the schema of one parameter (name, kind, default,
// range) and the values a caller gives by name. Shared by the model factory
// (model_factory.h), the renderer's `hair_model` closure (render/scene.h) and the
// bindings; no model code here.
#pragma once

#include <array>
#include <map>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

namespace hairbsdf {

// A bad model name, parameter name, type or value; the message names the parameter and what
// is allowed. (Python: ValueError.)
class ModelError : public std::invalid_argument {
public:
    using std::invalid_argument::invalid_argument;
};

enum class ParamKind {
    Float,   // one number in [min_value, max_value]
    RGB,     // three numbers, each in [min_value, max_value]; a number gives grey
    Choice,  // one of `choices`, given by name; default_value[0] is the default's index
    Bool,    // 0 or 1 (Python: False / True)
    Int,     // a whole number in [min_value, max_value] (Python: int)
    Vector2  // two numbers (MaterialX's vector2; default_value[2] unused): no zoo model's kind
};

struct ModelParamSpec {
    std::string name;
    ParamKind kind = ParamKind::Float;
    std::array<double, 3> default_value{};
    double min_value = 0, max_value = 0;
    std::vector<std::string> choices;  // Choice only
    bool optional = false;             // no default: derived from other parameters when not given
    std::string description;           // one line
};

// A value given by name: a number (Float, Bool, or grey for RGB), an RGB triple, or the name
// of a Choice.
using ModelParamValue = std::variant<double, std::array<double, 3>, std::string>;
using ModelParams = std::map<std::string, ModelParamValue>;

}  // namespace hairbsdf
