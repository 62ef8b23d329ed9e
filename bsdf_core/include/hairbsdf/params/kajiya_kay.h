// Kajiya-Kay's parameter table (param_table.h), beside KajiyaKayHairParams (models/kajiya_kay.h).
#pragma once

#include "hairbsdf/models/kajiya_kay.h"
#include "hairbsdf/params/param_table.h"

namespace hairbsdf {

template <>
struct ParamTable<KajiyaKayHairParams> {
    static constexpr const char* model = "kajiya_kay";
    static constexpr const char* title = "Kajiya-Kay 1989";
    static constexpr const char* summary = "Diffuse and specular cone (docs/models.md §1)";
    static const std::vector<ParamRow<KajiyaKayHairParams>>& rows() {
        using P = KajiyaKayHairParams;
        namespace r = param_rows;
        static const std::vector<ParamRow<P>> s = {
            r::color<P>("diffuse", &P::diffuse, 0, 1, "K_d, the diffuse albedo (diffuse + specular <= 1 per channel)"),
            r::color<P>("specular", &P::specular, 0, 1, "K_s, the specular albedo at normal view"),
            r::number<P>("exponent", &P::exponent, 0, 10000, "p, the Phong exponent of the specular cone (lobe width 1/sqrt(p))"),
        };
        return s;
    }
};

}  // namespace hairbsdf
