// Scheuermann's parameter table (param_table.h), beside ScheuermannHairParams (models/scheuermann.h).
#pragma once

#include "hairbsdf/models/scheuermann.h"
#include "hairbsdf/params/param_table.h"

namespace hairbsdf {

template <>
struct ParamTable<ScheuermannHairParams> {
    static constexpr const char* model = "scheuermann";
    static constexpr const char* title = "Scheuermann (ATI) 2004";
    static constexpr const char* summary = "Two shifted Kajiya-Kay lobes (docs/models.md §3)";
    static const std::vector<ParamRow<ScheuermannHairParams>>& rows() {
        using P = ScheuermannHairParams;
        namespace r = param_rows;
        static const std::vector<ParamRow<P>> s = {
            r::color<P>("primary_color", &P::primary_color, 0, 1, "c_1 (primary + secondary <= 1 per channel)"),
            r::color<P>("secondary_color", &P::secondary_color, 0, 1, "c_2, the hair-coloured secondary highlight"),
            r::number<P>("primary_exponent", &P::primary_exponent, 0, 10000, "p_1"),
            r::number<P>("secondary_exponent", &P::secondary_exponent, 0, 10000, "p_2"),
            r::number<P>("primary_shift", &P::primary_shift, -1, 1, "tangent shift of lobe 1 (tan 2 deg)"),
            r::number<P>("secondary_shift", &P::secondary_shift, -1, 1, "tangent shift of lobe 2 (-tan 4 deg)"),
            r::number<P>("shift_texture", &P::shift_texture, 0, 1, "the shift texture's value (0.5: no extra shift)"),
            r::number<P>("noise", &P::noise, 0, 1, "the noise texture's value, masks lobe 2"),
        };
        return s;
    }
};

}  // namespace hairbsdf
