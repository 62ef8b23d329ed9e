// Yan fur's parameter table (param_table.h), beside YanFurParams (models/yan_fur.h).
#pragma once

#include "hairbsdf/models/yan_fur.h"
#include "hairbsdf/params/param_table.h"

namespace hairbsdf {

template <>
struct ParamTable<YanFurParams> {
    static constexpr const char* model = "yan_fur";
    static constexpr const char* title = "Yan 2015 fur";
    static constexpr const char* summary = "Double cylinder: cortex and scattering medulla (docs/models.md §7)";
    static const std::vector<ParamRow<YanFurParams>>& rows() {
        using P = YanFurParams;
        namespace r = param_rows;
        static const std::vector<ParamRow<P>> s = {
            r::number<P>("medulla_ratio", &P::medulla_ratio, 0, 0.99, "kappa, the medulla's radius over the fibre's"),
            r::color<P>("cortex_absorption", &P::cortex_absorption, 0, 1e4, "sigma_ca, cortex absorption per unit radius"),
            r::number<P>("medulla_absorption", &P::medulla_absorption, 0, 10, "sigma_ma, medulla absorption per unit radius"),
            r::number<P>("medulla_scattering", &P::medulla_scattering, 0, 10, "sigma_ms, medulla scattering per unit radius"),
            r::number<P>("medulla_g", &P::medulla_g, -0.9, 0.9, "Henyey-Greenstein asymmetry of the medulla (0: isotropic)"),
            r::number<P>("eta", &P::eta, 1.1, 3, "index of refraction of cortex and medulla"),
            r::number<P>("alpha", &P::alpha, -0.2, 0.2, "cuticle tilt (rad, Principled Hair's Offset convention); 5.48 deg"),
            r::number<P>("roughness", &P::roughness, 0.01, 1, "Chiang's beta_m; default: R's longitudinal sd = 11.64 deg"),
            r::number<P>("radial_roughness", &P::radial_roughness, 0.01, 1, "Chiang's beta_n; default: azimuthal sd = 7.49 deg"),
        };
        return s;
    }
};

}  // namespace hairbsdf
