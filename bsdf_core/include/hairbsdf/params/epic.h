// Epic's parameter table (param_table.h), beside EpicHairParams (models/epic.h).
#pragma once

#include "hairbsdf/models/epic.h"
#include "hairbsdf/params/param_table.h"

namespace hairbsdf {

template <>
struct ParamTable<EpicHairParams> {
    static constexpr const char* model = "epic";
    static constexpr const char* title = "Epic / Unreal 2016";
    static constexpr const char* summary = "Karis's real-time hair (docs/models.md §2)";
    static const std::vector<ParamRow<EpicHairParams>>& rows() {
        using P = EpicHairParams;
        namespace r = param_rows;
        static const std::vector<ParamRow<P>> s = {
            r::color<P>("base_color", &P::base_color, 0, 1, "C, the fibre colour"),
            r::converted<P>(
                "specular", 0, 1, "scales R by specular / 0.5 (0.5: R as published)",
                [](const P& p) { return 0.5 * p.r_scale; }, [](P& p, double x) { p.r_scale = x / 0.5; }),
            r::number<P>("scatter", &P::scatter, 0, 1, "scales the multiple-scattering fake (0: single fibre only)"),
            r::number<P>("roughness", &P::roughness, 0, 1, "r: beta_R = r^2, beta_TT = beta_R / 2, beta_TRT = 2 beta_R"),
            r::number<P>("shift", &P::shift, -0.25, 0.25, "alpha_R = -2 shift, alpha_TT = shift, alpha_TRT = 4 shift (sin theta)"),
            r::choice<P, EpicVariant>("variant", &P::variant,
                                      {{"direct", EpicVariant::Direct}, {"environment", EpicVariant::Environment}},
                                      "direct lights, or the environment-light variant"),
            r::energy<P>("the notes"),
        };
        return s;
    }
};

}  // namespace hairbsdf
