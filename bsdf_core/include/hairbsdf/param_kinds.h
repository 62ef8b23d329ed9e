// The parameter kinds' names: the "type" of a schema dict in Python, where _core.PARAM_KINDS
// lists them in ParamKind's order (hairbsdf/_param_docs.py unpacks them).
#pragma once

#include "hairbsdf/model_params.h"

namespace hairbsdf {

inline constexpr ParamKind kParamKinds[] = {ParamKind::Float, ParamKind::RGB, ParamKind::Choice, ParamKind::Bool,
                                            ParamKind::Int, ParamKind::Vector2};

inline const char* param_kind_name(ParamKind kind) {
    switch (kind) {
        case ParamKind::Float: return "float";
        case ParamKind::RGB: return "rgb";
        case ParamKind::Choice: return "choice";
        case ParamKind::Bool: return "bool";
        case ParamKind::Int: return "int";
        case ParamKind::Vector2: return "vector2";
    }
    return "";
}

}  // namespace hairbsdf
