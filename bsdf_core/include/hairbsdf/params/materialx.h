// MaterialX `chiang_hair_bsdf` and its support nodes (docs/materialx.md, which records
// every name, default and the differences between the spec and its backends).
#pragma once

#include <limits>

#include "hairbsdf/params/param_table.h"
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

// Inputs of the support nodes, with their nodedef defaults.
struct ChiangHairRoughnessInputs {
    double longitudinal = 0.1, azimuthal = 0.2;
    double scale_TT = 0.5, scale_TRT = 2.0;  // on the standard deviation: v scales by their squares
};
struct ChiangHairAbsorptionFromColorInputs {
    RGB color{1.0};
    double azimuthal_roughness = 0.2;
};
// The pigment colours are exp(-sigma) of d'Eon's coefficients.
struct DeonHairAbsorptionFromMelaninInputs {
    double melanin_concentration = 0.25, melanin_redness = 0.5;
    RGB eumelanin_color{0.657704, 0.498077, 0.254107};
    RGB pheomelanin_color{0.829444, 0.67032, 0.349938};
};

// The nodes' tables (param_table.h): names and defaults for hairbsdf.materialx. Ranges are what
// the nodes accept (MaterialX declares none); `model` is the node's name.
namespace param_rows {
template <class P>
ParamRow<P> vector2(const char* name, Vec2 P::*field, double lo, double hi, const char* description) {
    return bound<P>(
        spec(name, ParamKind::Vector2, lo, hi, description),
        [field](const P& p) { return ParamValue{(p.*field).x, (p.*field).y, 0.0}; },
        [field](P& p, const ParamValue& v) { p.*field = Vec2{v[0], v[1]}; });
}
constexpr double kUnbounded = std::numeric_limits<double>::infinity();
}  // namespace param_rows

template <>
struct ParamTable<ChiangHairBsdfInputs> {
    static constexpr const char* model = "chiang_hair_bsdf";
    static const std::vector<ParamRow<ChiangHairBsdfInputs>>& rows() {
        using P = ChiangHairBsdfInputs;
        namespace r = param_rows;
        constexpr double inf = r::kUnbounded;
        static const std::vector<ParamRow<P>> s = {
            r::color<P>("tint_R", &P::tint_R, -inf, inf, "R lobe tint (floored at 0)"),
            r::color<P>("tint_TT", &P::tint_TT, -inf, inf, "TT lobe tint (floored at 0)"),
            r::color<P>("tint_TRT", &P::tint_TRT, -inf, inf, "TRT and TRRT+ lobes' tint (floored at 0)"),
            r::number<P>("ior", &P::ior, -inf, inf, "index of refraction"),
            r::vector2<P>("roughness_R", &P::roughness_R, 0, inf, "R lobe (v, s), s without sqrt(pi/8)"),
            r::vector2<P>("roughness_TT", &P::roughness_TT, 0, inf, "TT lobe (v, s)"),
            r::vector2<P>("roughness_TRT", &P::roughness_TRT, 0, inf, "TRT and TRRT+ lobes' (v, s)"),
            r::number<P>("cuticle_angle", &P::cuticle_angle, -inf, inf, "0.5: no tilt; tilt = (c - 0.5) * pi"),
            r::color<P>("absorption_coefficient", &P::absorption_coefficient, -inf, inf, "sigma_a per channel"),
        };
        return s;
    }
};

template <>
struct ParamTable<ChiangHairRoughnessInputs> {
    static constexpr const char* model = "chiang_hair_roughness";
    static const std::vector<ParamRow<ChiangHairRoughnessInputs>>& rows() {
        using P = ChiangHairRoughnessInputs;
        namespace r = param_rows;
        constexpr double inf = r::kUnbounded;
        static const std::vector<ParamRow<P>> s = {
            r::number<P>("longitudinal", &P::longitudinal, -inf, inf, "beta_m, clamped to [0.001, 1]"),
            r::number<P>("azimuthal", &P::azimuthal, -inf, inf, "beta_n, clamped to [0.001, 1]"),
            r::number<P>("scale_TT", &P::scale_TT, -inf, inf, "TT's v = scale_TT^2 v"),
            r::number<P>("scale_TRT", &P::scale_TRT, -inf, inf, "TRT's v = scale_TRT^2 v"),
        };
        return s;
    }
};

template <>
struct ParamTable<ChiangHairAbsorptionFromColorInputs> {
    static constexpr const char* model = "chiang_hair_absorption_from_color";
    static const std::vector<ParamRow<ChiangHairAbsorptionFromColorInputs>>& rows() {
        using P = ChiangHairAbsorptionFromColorInputs;
        namespace r = param_rows;
        constexpr double inf = r::kUnbounded;
        static const std::vector<ParamRow<P>> s = {
            r::color<P>("color", &P::color, -inf, inf, "hair colour, clamped to [0.001, 1]"),
            r::number<P>("azimuthal_roughness", &P::azimuthal_roughness, -inf, inf, "beta_n of eq. 9"),
        };
        return s;
    }
};

template <>
struct ParamTable<DeonHairAbsorptionFromMelaninInputs> {
    static constexpr const char* model = "deon_hair_absorption_from_melanin";
    static const std::vector<ParamRow<DeonHairAbsorptionFromMelaninInputs>>& rows() {
        using P = DeonHairAbsorptionFromMelaninInputs;
        namespace r = param_rows;
        constexpr double inf = r::kUnbounded;
        static const std::vector<ParamRow<P>> s = {
            r::number<P>("melanin_concentration", &P::melanin_concentration, -inf, inf, "c; q = -ln(max(1 - c, 1e-4))"),
            r::number<P>("melanin_redness", &P::melanin_redness, -inf, inf, "pheomelanin share"),
            r::color<P>("eumelanin_color", &P::eumelanin_color, -inf, inf, "exp(-sigma) of eumelanin"),
            r::color<P>("pheomelanin_color", &P::pheomelanin_color, -inf, inf, "exp(-sigma) of pheomelanin"),
        };
        return s;
    }
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
inline ChiangHairRoughness chiang_hair_roughness(const ChiangHairRoughnessInputs& in) {
    const double v = longitudinal_variance(clamp(in.longitudinal, 0.001, 1.0));
    const double s = azimuthal_scale_raw(clamp(in.azimuthal, 0.001, 1.0));
    return {{v, s}, {in.scale_TT * in.scale_TT * v, s}, {in.scale_TRT * in.scale_TRT * v, s}};
}

// ND_chiang_hair_absorption_from_color: Chiang 2016 eq. 9 with the colour clamped to [0.001, 1].
inline RGB chiang_hair_absorption_from_color(const ChiangHairAbsorptionFromColorInputs& in) {
    auto c = [](double x) { return clamp(x, 0.001, 1.0); };
    return absorption_from_color(RGB(c(in.color.r), c(in.color.g), c(in.color.b)), in.azimuthal_roughness);
}

// ND_deon_hair_absorption_from_melanin: d'Eon 2011 §6.1 with Blender's linearisation.
inline RGB deon_hair_absorption_from_melanin(const DeonHairAbsorptionFromMelaninInputs& in) {
    const double quantity = -std::log(std::max(1.0 - in.melanin_concentration, 1e-4));
    const double eu = quantity * (1.0 - in.melanin_redness), pheo = quantity * in.melanin_redness;
    auto channel = [&](double e, double p) { return std::max(-eu * std::log(e) - pheo * std::log(p), 0.0); };
    const RGB& e = in.eumelanin_color;
    const RGB& p = in.pheomelanin_color;
    return {channel(e.r, p.r), channel(e.g, p.g), channel(e.b, p.b)};
}

}  // namespace hairbsdf
