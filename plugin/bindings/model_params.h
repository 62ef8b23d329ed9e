// Python values -> named model parameters (hairbsdf/model_params.h), shared by the
// _core and _render modules: a number (bool: 0 / 1), an RGB triple (any 3-sequence) or a
// string (a choice). Errors name the parameter, prefixed with `where`.
#pragma once

#include <pybind11/pybind11.h>

#include <string>

#include "hairbsdf/model_params.h"

namespace hairbsdf::bindings {

inline ModelParamValue model_param_value(pybind11::handle v, const std::string& where) {
    namespace py = pybind11;
    if (py::isinstance<py::bool_>(v)) return v.cast<bool>() ? 1.0 : 0.0;
    if (py::isinstance<py::str>(v)) return v.cast<std::string>();
    if (py::isinstance<py::float_>(v) || py::isinstance<py::int_>(v) || py::hasattr(v, "__float__"))
        if (!py::isinstance<py::sequence>(v)) return py::float_(py::reinterpret_borrow<py::object>(v)).cast<double>();
    if (py::isinstance<py::sequence>(v) || py::hasattr(v, "__array__")) {
        py::list items;
        try {
            items = py::list(py::reinterpret_borrow<py::object>(v));
        } catch (const py::error_already_set&) {
            throw py::type_error(where + ": expected a number, an RGB triple or a string");
        }
        if (items.size() == 3) {
            std::array<double, 3> rgb{};
            for (size_t c = 0; c < 3; ++c) {
                py::handle x = items[c];
                if (py::isinstance<py::bool_>(x) || py::isinstance<py::str>(x) || !py::hasattr(x, "__float__"))
                    throw py::type_error(where + ": expected an RGB triple of numbers");
                rgb[c] = py::float_(py::reinterpret_borrow<py::object>(x)).cast<double>();
            }
            return rgb;
        }
        throw py::value_error(where + ": expected an RGB triple (3 numbers), got " + std::to_string(items.size()) +
                              " values");
    }
    throw py::type_error(where + ": expected a number, an RGB triple or a string, got " +
                         std::string(py::str(py::type::of(v).attr("__name__"))));
}

// `prefix(name)` names a parameter in errors, e.g. "scene[...]['params']['exponent']".
template <class Prefix>
ModelParams model_params_from_dict(const pybind11::dict& d, Prefix prefix) {
    ModelParams out;
    for (const auto& item : d) {
        const pybind11::handle k = item.first, v = item.second;
        if (!pybind11::isinstance<pybind11::str>(k)) throw pybind11::type_error("model parameter names must be strings");
        const std::string name = pybind11::cast<std::string>(k);
        out[name] = model_param_value(v, prefix(name));
    }
    return out;
}

}  // namespace hairbsdf::bindings
