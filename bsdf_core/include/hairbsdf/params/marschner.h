// Marschner's parameter table (param_table.h), beside MarschnerHairParams (models/marschner.h).
#pragma once

#include "hairbsdf/models/marschner.h"
#include "hairbsdf/params/param_table.h"

namespace hairbsdf {

template <>
struct ParamTable<MarschnerHairParams> {
    static constexpr const char* model = "marschner";
    static constexpr const char* title = "Marschner 2003";
    static constexpr const char* summary = "R, TT, TRT with glints (docs/models.md §4)";
    static const std::vector<ParamRow<MarschnerHairParams>>& rows() {
        using P = MarschnerHairParams;
        namespace r = param_rows;
        static const std::vector<ParamRow<P>> s = {
            r::color<P>("sigma_a", &P::sigma_a, 0, 1e4, "absorption per unit diameter"),
            r::number<P>("eta", &P::eta, 1.1, 3, "index of refraction"),
            r::number<P>("eccentricity", &P::eccentricity, 0.5, 1, "a, the cross-section's axis ratio"),
            r::number<P>("alpha_r", &P::alpha_r, -0.35, 0.35, "R shift (rad); alpha_TT = -alpha_r / 2, alpha_TRT = -3 alpha_r / 2"),
            r::number<P>("beta_r", &P::beta_r, 0.005, 0.7, "R width (rad); beta_TT = beta_r / 2, beta_TRT = 2 beta_r"),
            r::number<P>("glint_scale", &P::glint_scale, 0, 5, "k_G"),
            r::number<P>("caustic_width", &P::caustic_width, 0.01, 0.7, "w_c (rad)"),
            r::number<P>("caustic_fade", &P::caustic_fade, 0, 1, "Delta eta*"),
            r::number<P>("caustic_limit", &P::caustic_limit, 0, 1, "Delta h_M"),
            r::energy<P>("the paper"),
        };
        return s;
    }
};

}  // namespace hairbsdf
