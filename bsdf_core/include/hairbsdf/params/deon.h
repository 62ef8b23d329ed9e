// d'Eon's parameter table (param_table.h), beside DeonHairParams (models/deon.h), and the colour
// inputs it adds: melanin, its redness and the pigment constants give sigma_a unless sigma_a is given.
#pragma once

#include <algorithm>
#include <cmath>

#include "hairbsdf/models/deon.h"
#include "hairbsdf/params/param_table.h"
#include "hairbsdf/params/principled_hair.h"

namespace hairbsdf {

// d'Eon's pigment constants (seed 004), per unit concentration and diameter.
constexpr RGB kDeonEumelanin{0.419, 0.697, 1.37};
constexpr RGB kDeonPheomelanin{0.187, 0.4, 1.05};

// sigma_a from melanin: Principled Hair's mapping (Cycles' pigments, at the node's default Radial
// Roughness), or d'Eon's pigment constants.
inline RGB deon_sigma_a(double melanin, double redness, bool deon_pigments) {
    if (!deon_pigments)
        return absorption_from_melanin(melanin, redness, RGB(1.0), PrincipledHairInputs{}.radial_roughness);
    const double q = -std::log(std::max(1.0 - melanin, 1e-4));
    return (q * (1 - redness)) * kDeonEumelanin + (q * redness) * kDeonPheomelanin;
}

template <>
struct ParamTable<DeonHairParams> {
    static constexpr const char* model = "deon";
    static constexpr const char* title = "d'Eon 2011";
    static constexpr const char* summary = "Energy-conserving R, TT, TRT, TRRT+ (docs/models.md §5)";
    // The melanin inputs' defaults (Principled Hair's).
    static constexpr double kMelanin = blender_hair::kMelanin, kMelaninRedness = blender_hair::kMelaninRedness;
    static const std::vector<ParamRow<DeonHairParams>>& rows() {
        using P = DeonHairParams;
        namespace r = param_rows;
        static const std::vector<ParamRow<P>> s = [] {
            ParamRow<P> sigma = r::color<P>("sigma_a", &P::sigma_a, 0, 1e4, "absorption; overrides melanin when given");
            const RGB d = deon_sigma_a(kMelanin, kMelaninRedness, false);
            sigma.spec.default_value = {d.r, d.g, d.b};  // what melanin's defaults give (shown, not used)
            sigma.spec.optional = true;
            return std::vector<ParamRow<P>>{
                r::input_number<P>("melanin", kMelanin, 0, 1, "melanin concentration (Principled Hair's mapping)"),
                r::input_number<P>("melanin_redness", kMelaninRedness, 0, 1, "pheomelanin share"),
                r::input_choice<P>("pigments", {"cycles", "deon"}, "pigment constants: Cycles' or d'Eon's (seed 004)"),
                sigma,
                r::number<P>("eta", &P::eta, 1.1, 3, "index of refraction"),
                r::number<P>("roughness", &P::roughness, 0.02, 1, "beta_R (rad); TT x1/2, TRT x2"),
                r::number<P>("tilt", &P::tilt, -0.2, 0.2, "cuticle tilt alpha (rad)"),
                r::flag<P>("tabulated", &P::tabulated, "tables over (|sin theta_o|, phi), or direct quadrature"),
            };
        }();
        return s;
    }
};

}  // namespace hairbsdf
