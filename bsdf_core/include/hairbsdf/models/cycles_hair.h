// Cycles' legacy "Hair BSDF" node (Reflection or Transmission component), an OSL-era
// phenomenological fibre model kept in Cycles since 2013. docs/models.md §6.
//
// Both components are a product of a longitudinal and an azimuthal density; Cycles' eval
// returns exactly the density it would sample with, so eval / pdf is the colour. Angles in the
// fibre frame (docs/conventions.md): theta_r = theta_o of the viewer, theta_i of the light,
// phi the azimuth of the light measured from the viewer's azimuth.
//
//   longitudinal (both): a Cauchy density of scale r1 in theta_h - offset, theta_h = (theta_i +
//     theta_r) / 2, truncated to theta_i in [-pi/2, pi/2] and written per unit solid angle:
//       p_theta = r1 / (2 (t^2 + r1^2) (A - B) cos theta_i),   t = theta_h - offset,
//       A, B = atan(((theta_r +- pi/2) / 2 - offset) / r1)
//   reflection azimuth: the cos(x/2)/4 bump stretched by r2,
//       p_phi = cos(min(|phi| / r2, pi) / 2) / (4 r2), and 0 where cos phi < 0;
//   transmission azimuth: a Cauchy density of scale r2 about phi = pi, truncated to |p| <= pi/2,
//       p_phi = r2 / (C (p^2 + r2^2)),  p = pi - |phi|,  C = 2 atan(pi / (2 r2)).
//   eval = colour x p_theta x p_phi; zero within 0.001 rad of the fibre axis.
//
// Cycles' conventions reproduced here:
//   - roughness clamped to [0.001, 1] (setup); the stored offset is minus the node's Offset;
//   - reflection has value only where wi . N >= 0 and transmission only where wi . N < 0, N the
//     shading normal at the hit (for a tube or a ribbon seen from wo at offset h:
//     N = -h y - sqrt(1 - h^2) z in the view frame of FibreFrame);
//   - the sampler ignores both restrictions (weight = colour everywhere), and the reflection
//     sampler draws phi = 2 r2 asin(1 - 2u) but reports the density cos(phi / 2) / (4 r2), the
//     true density only for r2 = 1. `sample` returns Cycles' numbers; the exact density of the
//     sampler is `sampler_density` (used by the tests);
//   - labels: reflection GLOSSY REFLECT, transmission GLOSSY TRANSMIT; not blurred by Filter Glossy.
// Cycles evaluates with fast_acosf / fast_atan2f / fast_cosf in single precision; this file uses
// exact double-precision functions (differences ~1e-4 rad in the angles).
#pragma once

#include "hairbsdf/closure.h"

namespace hairbsdf {

enum class CyclesHairComponent { Reflection, Transmission };

struct CyclesHairParams {
    CyclesHairComponent component = CyclesHairComponent::Reflection;
    RGB color{0.8};            // the node's Color (Blender default 0.8 grey)
    double offset = 0;         // the node's Offset in radians (default 0)
    double roughness_u = 0.1;  // RoughnessU: longitudinal (default 0.1)
    double roughness_v = 1.0;  // RoughnessV: azimuthal (default 1)
};

class CyclesHair {
public:
    static constexpr double kMinRoughness = 0.001;
    static constexpr double kAxisGuard = 0.001;  // no value within this angle of the fibre axis

    explicit CyclesHair(const CyclesHairParams& params) : params_(params) {
        r1_ = clamp(params.roughness_u, kMinRoughness, 1.0);
        r2_ = clamp(params.roughness_v, kMinRoughness, 1.0);
        offset_ = -params.offset;  // Cycles stores minus the socket value
        c_tt_ = 2.0 * std::atan(0.5 * kPi / r2_);
    }
    const CyclesHairParams& params() const { return params_; }
    bool reflection() const { return params_.component == CyclesHairComponent::Reflection; }
    CyclesHair blurred(double) const { return *this; }  // Cycles' bsdf_blur skips the legacy Hair BSDF
    uint8_t scatter_label(int) const { return uint8_t(LabelGlossy | (reflection() ? LabelReflect : LabelTransmit)); }
    bool transmits() const { return !reflection(); }  // Cycles' SD_BSDF_HAS_TRANSMISSION
    static constexpr bool kSampleValueIsEval = false;  // Cycles' sampler value is not its eval
    double r1() const { return r1_; }
    double r2() const { return r2_; }

    // Narrowest lobe widths in theta_i and phi, for quadrature panels.
    std::array<double, 2> angular_scales() const { return {std::min(0.5, 2.0 * r1_), std::min(0.5, r2_)}; }

    struct ShadingPoint {
        explicit ShadingPoint(const FibreFrame& f) : frame(f) {}
        FibreFrame frame;
        Vec3 tangent{1, 0, 0};
        Vec3 loc_y{0, 0, 0};  // the viewer's direction perpendicular to the fibre (Cycles' locy)
        Vec3 loc_x{0, 0, 0};  // loc_y x tangent
        Vec3 normal{0, 0, 0};  // shading normal deciding reflection vs transmission; may be replaced
        double theta_r = 0;
        double a = 0, b = 0;  // atan bounds of the longitudinal Cauchy
        bool valid = false;
    };
    ShadingPoint prepare(const ShadingContext& ctx) const {
        ShadingPoint sp(FibreFrame(ctx.tangent, ctx.wo));
        sp.tangent = ctx.tangent;
        const double iz = dot(ctx.tangent, ctx.wo);
        const Vec3 perp = ctx.wo - iz * ctx.tangent;
        const double len = length(perp);
        if (!(len > 1e-12)) return sp;  // viewer on the fibre axis: Cycles' frame is undefined
        sp.loc_y = (1.0 / len) * perp;
        sp.loc_x = cross(sp.loc_y, ctx.tangent);
        const double h = clamp(ctx.h, -1.0, 1.0);
        sp.normal = (-h) * sp.frame.y - cos_from_sin(h) * sp.frame.z;
        sp.theta_r = std::asin(clamp(iz, -1.0, 1.0));
        sp.a = std::atan(((0.5 * kPi + sp.theta_r) * 0.5 - offset_) / r1_);
        sp.b = std::atan(((-0.5 * kPi + sp.theta_r) * 0.5 - offset_) / r1_);
        sp.valid = sp.a > sp.b;
        if (!(ctx.shading_normal.x == 0 && ctx.shading_normal.y == 0 && ctx.shading_normal.z == 0))
            sp.normal = ctx.shading_normal;  // the renderer: Cycles' N test uses the hit's shading normal
        return sp;
    }

    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const {
        BsdfEval out;
        if (!sp.valid) return out;
        // Reflection lives on the normal's side, transmission on the other (Cycles' N test).
        const bool above = dot(sp.normal, wi) >= 0.0;
        if (above != reflection()) return out;
        const double wz = dot(sp.tangent, wi);
        const double theta_i = std::asin(clamp(wz, -1.0, 1.0));
        if (0.5 * kPi - std::fabs(theta_i) < kAxisGuard) return out;
        const Vec3 perp = wi - wz * sp.tangent;
        const double len = length(perp);
        if (!(len > 0)) return out;
        const double cos_phi = clamp(dot((1.0 / len) * perp, sp.loc_y), -1.0, 1.0);
        double phi_pdf;
        if (reflection()) {
            if (cos_phi < 0.0) return out;
            const double stretched = std::min(std::acos(cos_phi) / r2_, kPi);
            phi_pdf = reflection_phi_density(stretched);
        } else {
            phi_pdf = transmission_phi_density(kPi - std::acos(cos_phi));
        }
        const double pdf = phi_pdf * theta_density(sp, theta_i);
        if (!(pdf > 0) || !std::isfinite(pdf)) return out;
        out.pdf = pdf;
        out.lobes[reflection() ? LobeR : LobeTT] = pdf * params_.color;
        return out;
    }
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const { return eval(prepare(ctx), wi); }
    double pdf(const ShadingPoint& sp, Vec3 wi) const { return eval(sp, wi).pdf; }
    double pdf(const ShadingContext& ctx, Vec3 wi) const { return pdf(prepare(ctx), wi); }

    // Cycles' sampler: u0 -> theta_h through the inverse Cauchy CDF, u1 -> phi. Reports Cycles'
    // pdf and value = colour x pdf (weight = colour), without the eval's N and cos phi tests.
    BsdfSample sample(const ShadingPoint& sp, const std::array<double, 3>& u) const {
        BsdfSample out;
        if (!sp.valid) return out;
        const double theta_i = sample_theta_i(sp, u[0]);
        double phi, phi_pdf;
        if (reflection()) {
            phi = 2.0 * r2_ * std::asin(clamp(1.0 - 2.0 * u[1], -1.0, 1.0));
            phi_pdf = reflection_phi_density(phi);  // Cycles' density, exact only for r2 = 1
        } else {
            const double p = r2_ * std::tan(c_tt_ * (u[1] - 0.5));
            phi = p + kPi;
            phi_pdf = transmission_phi_density(p);
        }
        if (0.5 * kPi - std::fabs(theta_i) < kAxisGuard) return out;
        const double pdf = std::fabs(phi_pdf * theta_density(sp, theta_i));
        const Vec3 wi = direction(sp, theta_i, phi);
        BsdfEval e;
        e.pdf = pdf;
        e.lobes[reflection() ? LobeR : LobeTT] = pdf * params_.color;
        return sample_from_eval(wi, e, reflection() ? LobeR : LobeTT);
    }
    BsdfSample sample(const ShadingContext& ctx, const std::array<double, 3>& u) const {
        return sample(prepare(ctx), u);
    }

    // The exact density of `sample`'s directions (differs from the reported pdf for the
    // reflection sampler when r2 != 1, and from eval's support). For tests.
    double sampler_density(const ShadingPoint& sp, Vec3 wi) const {
        if (!sp.valid) return 0.0;
        const double wz = dot(sp.tangent, wi);
        const double theta_i = std::asin(clamp(wz, -1.0, 1.0));
        if (0.5 * kPi - std::fabs(theta_i) < kAxisGuard) return 0.0;
        const Vec3 perp = wi - wz * sp.tangent;
        const double len = length(perp);
        if (!(len > 0)) return 0.0;
        const double phi = std::acos(clamp(dot((1.0 / len) * perp, sp.loc_y), -1.0, 1.0));  // |phi|
        double phi_pdf = 0.0;
        if (reflection()) {
            if (phi <= kPi * r2_) phi_pdf = reflection_phi_density(phi / r2_);
        } else if (phi >= 0.5 * kPi) {
            phi_pdf = transmission_phi_density(kPi - phi);
        }
        return phi_pdf * theta_density(sp, theta_i);
    }

private:
    // cos(x / 2) / (4 r2): the azimuthal bump of the reflection component.
    double reflection_phi_density(double x) const { return std::cos(0.5 * x) * 0.25 / r2_; }
    // Cauchy of scale r2 normalised over [-pi/2, pi/2].
    double transmission_phi_density(double p) const { return r2_ / (c_tt_ * (p * p + r2_ * r2_)); }
    // The truncated longitudinal Cauchy per unit solid angle (1 / cos theta_i).
    double theta_density(const ShadingPoint& sp, double theta_i) const {
        const double t = 0.5 * (theta_i + sp.theta_r) - offset_;
        return r1_ / (2.0 * (t * t + r1_ * r1_) * (sp.a - sp.b) * std::cos(theta_i));
    }
    // Inverse CDF of the truncated Cauchy: t = r1 tan(B + u (A - B)), theta_i = 2 (t + offset) - theta_r.
    double sample_theta_i(const ShadingPoint& sp, double u) const {
        const double t = r1_ * std::tan(u * (sp.a - sp.b) + sp.b);
        return 2.0 * (t + offset_) - sp.theta_r;
    }
    // Cycles' direction from (theta_i, phi): phi measured from loc_y towards -loc_x.
    static Vec3 direction(const ShadingPoint& sp, double theta_i, double phi) {
        const double ct = std::cos(theta_i);
        return (std::cos(phi) * ct) * sp.loc_y - (std::sin(phi) * ct) * sp.loc_x + std::sin(theta_i) * sp.tangent;
    }

    CyclesHairParams params_;
    double r1_ = 0.1, r2_ = 1.0, offset_ = 0.0, c_tt_ = 1.0;
};

}  // namespace hairbsdf
