// Blender's Principled Hair BSDF node inputs -> model parameters, as Cycles' SVM maps
// them (docs/cycles.md §1, §2). The only place where sigma_a, v and s are derived
// from node inputs: the Python API, the engine and the tests all call these.
#pragma once

#include "hairbsdf/math_hair_defaults.h"
#include "hairbsdf/models/chiang.h"
#include "hairbsdf/models/huang.h"

namespace hairbsdf {

enum class Parametrization { Color, Melanin, Absorption };  // Blender: COLOR, MELANIN, ABSORPTION

// Socket values; defaults are Blender 4.5's node defaults. Offset is in radians.
struct PrincipledHairInputs {
    Parametrization parametrization = Parametrization::Color;
    RGB color = blender_hair::kColor;
    double melanin = blender_hair::kMelanin;
    double melanin_redness = blender_hair::kMelaninRedness;
    RGB tint{1.0, 1.0, 1.0};
    RGB absorption_coefficient = blender_hair::kAbsorptionCoefficient;
    double roughness = 0.3;
    double radial_roughness = 0.3;
    double coat = 0.0;
    double ior = blender_hair::kIor;
    double offset = blender_hair::kOffset;
    double random_color = 0.0;
    double random_roughness = 0.0;
    double random = 0.0;
    // Huang model only (Blender 4.0+).
    double aspect_ratio = 0.85;
    double reflection = 1.0;            // "Reflection" (R lobe factor)
    double transmission = 1.0;          // "Transmission" (TT)
    double secondary_reflection = 1.0;  // "Secondary Reflection" (TRT)
};

// Direct coloring: sigma_a = (ln(max(C, 0)) / P(beta_n))^2 per channel. A black channel
// gives +inf (fully absorbing), where Cycles before 5.0 took ln of a negative number.
inline RGB absorption_from_color(RGB color, double radial_roughness) {
    const double p = albedo_roughness_scale(radial_roughness);
    auto channel = [p](double c) { return sqr(std::log(std::max(c, 0.0)) / p); };
    return {channel(color.r), channel(color.g), channel(color.b)};
}

// Cycles' pigment absorption (per unit melanin quantity), docs/cycles.md §2.3. These differ from
// pbrt-v3's constants.
constexpr RGB kEumelaninAbsorption{0.506, 0.841, 1.653};
constexpr RGB kPheomelaninAbsorption{0.343, 0.733, 1.924};

// Melanin concentration (after Random Color) -> sigma_a, plus the Tint term.
inline RGB absorption_from_melanin(double melanin, double melanin_redness, RGB tint, double radial_roughness) {
    const double quantity = -std::log(std::max(1.0 - melanin, 1e-4));
    const double eumelanin = quantity * (1.0 - melanin_redness);
    const double pheomelanin = quantity * melanin_redness;
    return eumelanin * kEumelaninAbsorption + pheomelanin * kPheomelaninAbsorption +
           absorption_from_color(tint, radial_roughness);
}

// Blender's node inputs -> the Chiang model, with every clamp Cycles applies (docs/principled_hair.md).
inline ChiangHairParams chiang_params_from_principled(const PrincipledHairInputs& in,
                                                      Accuracy accuracy = Accuracy::Cycles,
                                                      TiltConvention tilt = TiltConvention::Blender42) {
    // Random Roughness: no clamp on the factor, as in SVM.
    const double roughness_factor = 1.0 + 2.0 * (in.random - 0.5) * in.random_roughness;
    const double roughness = in.roughness * roughness_factor;
    const double radial_roughness = in.radial_roughness * roughness_factor;

    ChiangHairParams p;
    switch (in.parametrization) {
        case Parametrization::Absorption:
            p.sigma_a = in.absorption_coefficient;
            break;
        case Parametrization::Melanin: {
            const double color_factor = 1.0 + 2.0 * (in.random - 0.5) * clamp(in.random_color, 0.0, 1.0);
            p.sigma_a = absorption_from_melanin(in.melanin * color_factor, in.melanin_redness, in.tint,
                                                radial_roughness);
            break;
        }
        case Parametrization::Color:
            p.sigma_a = absorption_from_color(in.color, radial_roughness);
            break;
    }

    const double beta_m = clamp(roughness, 0.001, 1.0);
    const double beta_n = clamp(radial_roughness, 0.001, 1.0);
    // Coat lowers the R-lobe roughness before the mapping (docs/cycles.md §2.4 step 2).
    const double beta_coat = clamp((1.0 - clamp(in.coat, 0.0, 1.0)) * beta_m, 0.001, 1.0);
    const double v = longitudinal_variance(beta_m);
    const double v_r = longitudinal_variance(beta_coat);
    p.v = {v_r, 0.25 * v, 4.0 * v, 4.0 * v};
    p.v_sample = {v, 0.25 * v, 4.0 * v, 4.0 * v};  // Cycles samples R with the un-coated v
    const double s = azimuthal_scale(beta_n);
    p.s = {s, s, s};
    p.eta = in.ior;
    p.tilt = in.offset;
    p.accuracy = accuracy;
    p.tilt_convention = tilt;
    return p;
}

// Which roughness the Huang colour / tint -> sigma_a conversion uses (docs/cycles.md §2.5, §2.6):
// SVM uses the randomized Roughness, OSL the randomized Radial Roughness socket.
enum class HuangColorRoughness { Svm, Osl };

// Blender's node inputs -> the Huang model (Cycles 4.5 SVM path, docs/huang.md §2): roughness
// randomized (no clamp on the factor), alpha = clamp(roughness, 0.001, 1) in the model, colour and
// tint converted with the randomized roughness, aspect ratio > 1 inverted, lobe factors clamped >= 0
// (in the model). Radial Roughness and Coat are not used.
inline HuangHairParams huang_params_from_principled(const PrincipledHairInputs& in,
                                                    HuangQuadrature quadrature = HuangQuadrature::Cycles,
                                                    HuangSampler sampler = HuangSampler::Mixture,
                                                    HuangColorRoughness color_roughness = HuangColorRoughness::Svm) {
    const double roughness_factor = 1.0 + 2.0 * (in.random - 0.5) * in.random_roughness;
    const double roughness = in.roughness * roughness_factor;
    const double color_roughness_value =
        color_roughness == HuangColorRoughness::Svm ? roughness : in.radial_roughness * roughness_factor;
    HuangHairParams p;
    switch (in.parametrization) {
        case Parametrization::Absorption:
            p.sigma_a = in.absorption_coefficient;
            break;
        case Parametrization::Melanin: {
            // OSL does not clamp Random Color (docs/cycles.md §2.6).
            const double rc = color_roughness == HuangColorRoughness::Svm ? clamp(in.random_color, 0.0, 1.0) : in.random_color;
            const double color_factor = 1.0 + 2.0 * (in.random - 0.5) * rc;
            p.sigma_a = absorption_from_melanin(in.melanin * color_factor, in.melanin_redness, in.tint,
                                                color_roughness_value);
            break;
        }
        case Parametrization::Color:
            p.sigma_a = absorption_from_color(in.color, color_roughness_value);
            break;
    }
    p.roughness = roughness;
    p.offset = in.offset;
    p.eta = in.ior;
    p.aspect_ratio = in.aspect_ratio;
    p.r_factor = in.reflection;
    p.tt_factor = in.transmission;
    p.trt_factor = in.secondary_reflection;
    p.quadrature = quadrature;
    p.sampler = sampler;
    return p;
}

}  // namespace hairbsdf
