// MaterialX `chiang_hair_bsdf` and its support nodes (docs/materialx.md, which records
// every name, default and the differences between the spec and its backends).
#pragma once

#include "hairbsdf/params/principled_hair.h"

namespace hairbsdf {

struct Vec2 {
    double x = 0, y = 0;
};

// Inputs of ND_chiang_hair_bsdf with the nodedef defaults (MaterialX 1.39). Roughness
// pairs are (longitudinal variance v, azimuthal logistic scale s without sqrt(pi/8)).
struct ChiangHairBsdfInputs {
    RGB tint_R{1.0}, tint_TT{1.0}, tint_TRT{1.0};
    double ior = 1.55;
    Vec2 roughness_R{0.1, 0.1};
    Vec2 roughness_TT{0.05, 0.05};
    Vec2 roughness_TRT{0.2, 0.2};
    double cuticle_angle = 0.5;  // normalised: 0 -> -pi/2, 0.5 -> no tilt, 1 -> +pi/2
    RGB absorption_coefficient{0.0};
};

// Floors: what the support nodes give at their lower clamp 0.001 (docs/materialx.md §3.5).
constexpr double kMaterialXMinVariance = 5.2826e-7;
constexpr double kMaterialXMinScale = 2.662e-4;

inline double cuticle_angle_to_radians(double cuticle_angle) { return (cuticle_angle - 0.5) * kPi; }

// The spec tilts theta_i (as Blender 3.4 did) and uses the exact M_p; TRRT+ takes the TRT
// tint and variance; no global 1/pi.
inline ChiangHairParams chiang_params_from_materialx(const ChiangHairBsdfInputs& in) {
    auto floor_rgb = [](RGB c) { return RGB(std::max(c.r, 0.0), std::max(c.g, 0.0), std::max(c.b, 0.0)); };
    auto variance = [](double v) { return std::max(v, kMaterialXMinVariance); };
    auto scale = [](double s) { return kSqrtPiOver8 * std::max(s, kMaterialXMinScale); };
    ChiangHairParams p;
    p.sigma_a = in.absorption_coefficient;
    p.eta = in.ior;
    p.v = {variance(in.roughness_R.x), variance(in.roughness_TT.x), variance(in.roughness_TRT.x),
           variance(in.roughness_TRT.x)};
    p.v_sample = p.v;
    p.s = {scale(in.roughness_R.y), scale(in.roughness_TT.y), scale(in.roughness_TRT.y)};
    p.tilt = cuticle_angle_to_radians(in.cuticle_angle);
    p.tint = {floor_rgb(in.tint_R), floor_rgb(in.tint_TT), floor_rgb(in.tint_TRT), floor_rgb(in.tint_TRT)};
    p.accuracy = Accuracy::Exact;
    p.tilt_convention = TiltConvention::Blender34;
    return p;
}

// ND_chiang_hair_roughness: Chiang 2016 eqs. 7-8 without sqrt(pi/8); only v is scaled.
struct ChiangHairRoughness {
    Vec2 roughness_R, roughness_TT, roughness_TRT;
};
inline ChiangHairRoughness chiang_hair_roughness(double longitudinal = 0.1, double azimuthal = 0.2,
                                                 double scale_TT = 0.5, double scale_TRT = 2.0) {
    const double v = longitudinal_variance(clamp(longitudinal, 0.001, 1.0));
    const double s = azimuthal_scale_raw(clamp(azimuthal, 0.001, 1.0));
    return {{v, s}, {scale_TT * scale_TT * v, s}, {scale_TRT * scale_TRT * v, s}};
}

// ND_chiang_hair_absorption_from_color: Chiang 2016 eq. 9 with the colour clamped to [0.001, 1].
inline RGB chiang_hair_absorption_from_color(RGB color = RGB(1.0), double azimuthal_roughness = 0.2) {
    auto c = [](double x) { return clamp(x, 0.001, 1.0); };
    return absorption_from_color(RGB(c(color.r), c(color.g), c(color.b)), azimuthal_roughness);
}

// ND_deon_hair_absorption_from_melanin: d'Eon 2011 §6.1 with Blender's linearisation; the
// pigment colours are exp(-sigma) of d'Eon's coefficients.
inline RGB deon_hair_absorption_from_melanin(double melanin_concentration = 0.25, double melanin_redness = 0.5,
                                             RGB eumelanin_color = RGB(0.657704, 0.498077, 0.254107),
                                             RGB pheomelanin_color = RGB(0.829444, 0.67032, 0.349938)) {
    const double quantity = -std::log(std::max(1.0 - melanin_concentration, 1e-4));
    const double eu = quantity * (1.0 - melanin_redness), pheo = quantity * melanin_redness;
    auto channel = [&](double e, double p) { return std::max(-eu * std::log(e) - pheo * std::log(p), 0.0); };
    return {channel(eumelanin_color.r, pheomelanin_color.r), channel(eumelanin_color.g, pheomelanin_color.g),
            channel(eumelanin_color.b, pheomelanin_color.b)};
}

}  // namespace hairbsdf
