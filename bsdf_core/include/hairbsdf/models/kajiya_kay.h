// Kajiya and Kay 1989, "Rendering Fur with Three Dimensional Textures" (SIGGRAPH '89), §2.4
// "Lighting model": a diffuse term K_d sin(t, l) and a specular term K_s cos^p(e, e'), where e'
// is the direction on the specular cone closest to the eye. docs/models.md §1.
//
// In the fibre frame (docs/conventions.md) with latitudes theta_i (light) and theta_o (viewer):
//   sin(t, l)  = cos theta_i
//   cos(e, e') = cos(theta_i + theta_o)      (the cone is sin theta_i = -sin theta_o)
// so the value, which as in the paper already contains the projected-area factor, is
//   eval = K_d cos theta_i / pi^2 + K_s max(0, cos(theta_i + theta_o))^p / N_s(p).
// The paper's terms are unnormalised; the constants pi^2 and N_s(p) = 2 pi int cos^(p+1)
// (deviation, docs/models.md) make K_d the exact diffuse albedo and K_s the specular albedo at
// theta_o = 0, its maximum, so K_d + K_s <= 1 bounds the albedo by 1. Neither term depends on
// the azimuth or on h. The model is not reciprocal (both terms follow the paper's asymmetry).
//
// Lobes: 0 (R slot) = specular, 3 (residual slot) = diffuse.
// Sampler (the paper has none), a mixture by luminance of K_d and K_s:
//   diffuse:  sin theta_i = sqrt(u2') cos(2 pi u1), phi uniform: density cos theta_i / pi^2,
//             exactly proportional to the diffuse term;
//   specular: 90% a normal distribution in sin theta_i truncated to [-1, 1], matched to the lobe
//             (mean -sin theta_o e^(-w^2/2), sd sqrt(cos^2 theta_o w^2 + w^4 / 2), w = 1/sqrt(p+1)),
//             10% the diffuse density (defensive); phi uniform. Densities are exact and smooth.
#pragma once

#include "hairbsdf/closure.h"

namespace hairbsdf {

struct KajiyaKayHairParams {
    RGB diffuse{0.5};     // K_d: diffuse albedo
    RGB specular{0.5};    // K_s: specular albedo at theta_o = 0
    double exponent = 60;  // p: Phong exponent of the specular cone
};

class KajiyaKayHair {
public:
    explicit KajiyaKayHair(const KajiyaKayHairParams& params) : params_(params) {
        const double p = params.exponent;
        // N_s(p) = 2 pi int_{-pi/2}^{pi/2} cos^(p+1) = 2 pi sqrt(pi) Gamma(p/2 + 1) / Gamma(p/2 + 3/2).
        spec_norm_ = kTwoPi * std::sqrt(kPi) * std::exp(std::lgamma(0.5 * p + 1.0) - std::lgamma(0.5 * p + 1.5));
        lobe_width_ = 1.0 / std::sqrt(p + 1.0);
        const double wd = std::max(0.0, luminance(params.diffuse));
        const double ws = std::max(0.0, luminance(params.specular));
        const double total = wd + ws;
        if (total > 0) {
            w_normal_ = kSpecularNormalShare * ws / total;
            w_semicircle_ = 1.0 - w_normal_;
        }
    }
    const KajiyaKayHairParams& params() const { return params_; }
    double specular_norm() const { return spec_norm_; }

    std::array<double, 2> angular_scales() const { return {std::min(0.5, lobe_width_), 0.5}; }

    struct ShadingPoint {
        explicit ShadingPoint(const FibreFrame& f) : frame(f) {}
        FibreFrame frame;
        double sin_theta_o = 0, cos_theta_o = 1, theta_o = 0;
        TruncatedNormal spec;  // specular proposal in sin theta_i
    };
    ShadingPoint prepare(const ShadingContext& ctx) const {
        ShadingPoint sp(FibreFrame(ctx.tangent, ctx.wo));
        sp.sin_theta_o = sp.frame.sin_theta(ctx.wo);
        sp.cos_theta_o = cos_from_sin(sp.sin_theta_o);
        sp.theta_o = std::asin(sp.sin_theta_o);
        const double w = lobe_width_;
        sp.spec = TruncatedNormal(-sp.sin_theta_o * std::exp(-0.5 * w * w),
                                  std::sqrt(sqr(sp.cos_theta_o * w) + 0.5 * sqr(w * w)), -1.0, 1.0);
        return sp;
    }

    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const {
        const double sin_theta_i = sp.frame.sin_theta(wi);
        return eval_local(sp, sin_theta_i);
    }
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const { return eval(prepare(ctx), wi); }
    double pdf(const ShadingContext& ctx, Vec3 wi) const { return pdf(prepare(ctx), wi); }
    double pdf(const ShadingPoint& sp, Vec3 wi) const { return eval(sp, wi).pdf; }

    // u2 picks the component and is rescaled: semicircle: u2' radius, u1 angle; normal: u2'.
    // u0 the azimuth.
    BsdfSample sample(const ShadingPoint& sp, const std::array<double, 3>& u) const {
        BsdfSample out;
        if (!(w_normal_ + w_semicircle_ > 0)) return out;
        double sin_theta_i;
        if (u[2] < w_semicircle_) {
            const double r = std::sqrt(clamp(u[2] / w_semicircle_, 0.0, 1.0));
            sin_theta_i = r * std::cos(kTwoPi * u[1]);
        } else {
            if (!(sp.spec.mass() > 0)) return out;
            sin_theta_i = sp.spec.sample((u[2] - w_semicircle_) / w_normal_);
        }
        const BsdfEval e = eval_local(sp, sin_theta_i);
        const Vec3 wi = sp.frame.direction(sin_theta_i, cos_from_sin(sin_theta_i), -0.5 * kPi + kTwoPi * u[0]);
        // Report the lobe that dominates the value.
        return sample_from_eval(wi, e, luminance(e.lobes[LobeR]) >= luminance(e.lobes[LobeTRRT]) ? LobeR : LobeTRRT);
    }
    BsdfSample sample(const ShadingContext& ctx, const std::array<double, 3>& u) const {
        return sample(prepare(ctx), u);
    }

private:
    static constexpr double kSpecularNormalShare = 0.9;

    BsdfEval eval_local(const ShadingPoint& sp, double sin_theta_i) const {
        BsdfEval out;
        const double cos_theta_i = cos_from_sin(sin_theta_i);
        // §2.4: diffuse K_d sin(t, l) = K_d cos theta_i; specular K_s cos^p(e, e') with
        // cos(e, e') = cos(theta_i + theta_o).
        const double diffuse = cos_theta_i / (kPi * kPi);
        const double c = cos_theta_i * sp.cos_theta_o - sin_theta_i * sp.sin_theta_o;
        const double specular = c > 0 ? std::pow(c, params_.exponent) / spec_norm_ : 0.0;
        out.lobes[LobeR] = specular * params_.specular;
        out.lobes[LobeTRRT] = diffuse * params_.diffuse;
        // Densities per solid angle: d omega = d(sin theta) d phi, phi uniform.
        out.pdf = w_semicircle_ * diffuse + w_normal_ * sp.spec.pdf(sin_theta_i) * kInvTwoPi;
        if (!std::isfinite(out.pdf) || !isfinite(out.value())) return {};
        return out;
    }

    KajiyaKayHairParams params_;
    double spec_norm_ = 1;
    double lobe_width_ = 1;
    double w_normal_ = 0, w_semicircle_ = 0;
};

}  // namespace hairbsdf
