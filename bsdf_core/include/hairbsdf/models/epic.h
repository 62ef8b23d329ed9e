// Epic / Unreal 2016: Karis, "Physically Based Hair Shading in Unreal", SIGGRAPH 2016 course
// "Physically Based Shading in Theory and Practice", implemented from the course-notes formulas
// as restated in seed 002 (its "Epic 2016 Siggraph" section), never from Unreal's source.
// docs/models.md §2.
//
//   S = sum_p M_p N_p (+ the multiple-scattering fake), returned as eval (it already is the
//   value a light is multiplied by; no extra cosine).
//   M_p = g(beta_p; sin theta_i + sin theta_r - alpha_p), g a unit-area Gaussian of sd beta_p
//         ("Longitudinal scattering": a Gaussian replaces Weta's energy-conserving M_p);
//   beta_R = r^2, beta_TT = r^2 / 2, beta_TRT = 2 r^2 (r = Roughness);
//   alpha_R = -2 Shift, alpha_TT = Shift, alpha_TRT = 4 Shift.
//   R:   N_R = 1/4 cos(phi/2) A_R,  A_R = F(eta, sqrt(1/2 + 1/2 wi.wr)), F Schlick with F0 of eta;
//   TT:  h_TT ~ (1 + a (0.6 - 0.8 cos phi)) cos(phi/2), a = 1/eta', eta' ~ 1.19/cos theta_d + 0.36 cos theta_d,
//        A_TT = (1 - f)^2 T, f = F(eta, cos theta_d sqrt(1 - h^2)), T = C^(sqrt(1 - h^2 a^2) / (2 cos theta_d)),
//        D_TT ~ exp(-3.65 cos phi - 3.98);
//   TRT: h = sqrt(3)/2, A_TRT = (1 - f)^2 f T, f = F(eta, cos theta_d / 2), T = C^(0.8 / cos theta_d),
//        D_TRT ~ exp(17 cos phi - 16.78);
//   multiple scattering: sqrt(C) (n.wi + 1) / (4 pi) (C / Luma(C))^(1 - Shadow), n the fake normal
//        (wr made perpendicular to the tangent), scaled by Scatter;
//   environment-light variant: R x saturate(wi.wr + 1), TT removed, every beta + 0.2.
// eta = 1.55 (the notes' value, from Marschner 2003). Specular scales R.
//
// Lobes: R, TT, TRT as usual; the multiple-scattering term in the residual slot (3).
// Sampler (the notes have none): a lobe mixture; each lobe samples sin theta_i from its Gaussian
// truncated to [-1, 1] and phi from a density close to its N: R 1/4 cos(phi/2) (inverse CDF),
// TT and TRT the trimmed logistics D(phi, 0.35, pi) and D(phi, 0.15, 0) that the notes' exp fits
// approximate; the multiple-scattering term samples (n.wi + 1) / (4 pi) exactly.
//
// Energy (docs/models.md §2): energy = Bounded (the default) divides eval per channel by
// max(1, E_c), E_c the published model's directional albedo at this view: R + TT + TRT from a table
// over theta_o (src/models/epic_energy.cpp) plus the multiple-scattering term's closed form
// Scatter sqrt(C) (C / Luma)^(1 - Shadow). Published: the notes' model exactly. Sampler and pdf are
// the same for both.
#pragma once

#include <memory>

#include "hairbsdf/closure.h"
#include "hairbsdf/math_hair_defaults.h"
#include "hairbsdf/models/energy_bound.h"

namespace hairbsdf {

enum class EpicVariant { Direct, Environment };

struct EpicHairParams {
    RGB base_color = blender_hair::kColor;  // C
    double r_scale = 1.0;     // multiplier of R (Python: Specular / 0.5)
    double scatter = 0.0;     // multiplier of the multiple-scattering term
    double roughness = 0.35;  // r: beta_R = r^2
    double shift = 0.035;     // radians-like shift of the Gaussians in sin theta (alpha_R = -2 shift)
    EpicVariant variant = EpicVariant::Direct;
    EnergyMode energy = EnergyMode::Bounded;
};

// The table of the published R + TT + TRT albedo over theta_o for these parameters (scatter and
// energy ignored), from the process-wide cache.
std::shared_ptr<const EnergyBoundTable> epic_energy_table(const EpicHairParams& params);

class EpicHair {
public:
    static constexpr double kEta = 1.55;
    static constexpr double kMinBeta = 1e-3;  // floor of every beta (roughness 0 would be a delta)
    static constexpr double kTTLogisticScale = 0.35, kTRTLogisticScale = 0.15;

    explicit EpicHair(const EpicHairParams& params) : params_(params) {
        const double r2 = sqr(params.roughness);
        const double extra = params.variant == EpicVariant::Environment ? 0.2 : 0.0;
        beta_ = {std::max(r2 + extra, kMinBeta), std::max(0.5 * r2 + extra, kMinBeta),
                 std::max(2.0 * r2 + extra, kMinBeta)};
        alpha_ = {-2.0 * params.shift, params.shift, 4.0 * params.shift};
        f0_ = sqr((1.0 - kEta) / (1.0 + kEta));
        tt_norm_ = 1.0 / (logistic_cdf(kPi, kTTLogisticScale) - logistic_cdf(-kPi, kTTLogisticScale));
        trt_norm_ = 1.0 / (logistic_cdf(kPi, kTRTLogisticScale) - logistic_cdf(-kPi, kTRTLogisticScale));
        const double l = luminance(params.base_color);
        for (int c = 0; c < 3; ++c) {
            const double v = params.base_color[c];
            sqrt_c_[c] = std::sqrt(std::max(v, 0.0));
            c_over_luma_[c] = l > 0 ? std::max(v, 0.0) / l : 0.0;
        }
        if (params.energy == EnergyMode::Bounded) energy_table_ = epic_energy_table(params);
    }
    const EpicHairParams& params() const { return params_; }
    // The R + TT + TRT albedo table of energy = Bounded (null for Published).
    const std::shared_ptr<const EnergyBoundTable>& energy_table() const { return energy_table_; }
    const std::array<double, 3>& betas() const { return beta_; }
    const std::array<double, 3>& alphas() const { return alpha_; }

    std::array<double, 2> angular_scales() const {
        // The narrowest Gaussian (sd beta in sin theta) and the narrowest azimuthal fit (TRT's).
        return {std::max(std::min({beta_[0], beta_[1], beta_[2]}), 2e-3), 0.15};
    }

    // Schlick's Fresnel with F0 from eta (the notes' F(eta, x)).
    double fresnel(double x) const { return f0_ + (1.0 - f0_) * std::pow(1.0 - clamp(x, 0.0, 1.0), 5.0); }

    struct ShadingPoint {
        ShadingPoint(const FibreFrame& f, Vec3 w) : frame(f), wo(w) {}
        FibreFrame frame;
        Vec3 wo;
        Vec3 fake_normal;  // wo made perpendicular to the tangent (= -frame.z)
        double sin_theta_o = 0, theta_o = 0;
        double shadow = 1;
        RGB ms_color;  // Scatter sqrt(C) (C / Luma)^(1 - Shadow)
        std::array<TruncatedNormal, 3> longitudinal;  // sampling densities of sin theta_i
        std::array<double, 4> lobe_weight{};          // R, TT, TRT, MS selection probabilities
        bool bounded = false;
        RGB energy_scale{1.0};  // 1 / max(1, E_c) (energy = Bounded)
    };
    ShadingPoint prepare(const ShadingContext& ctx) const {
        ShadingPoint sp(FibreFrame(ctx.tangent, ctx.wo), ctx.wo);
        sp.fake_normal = -1.0 * sp.frame.z;
        sp.sin_theta_o = sp.frame.sin_theta(ctx.wo);
        sp.theta_o = std::asin(sp.sin_theta_o);
        const double cos_theta_o = cos_from_sin(sp.sin_theta_o);
        sp.shadow = clamp(ctx.shadow, 0.0, 1.0);
        for (int c = 0; c < 3; ++c) {
            const double ratio = std::pow(c_over_luma_[c], 1.0 - sp.shadow);
            (c == 0 ? sp.ms_color.r : c == 1 ? sp.ms_color.g : sp.ms_color.b) = params_.scatter * sqrt_c_[c] * ratio;
        }
        if (energy_table_) {
            sp.bounded = true;
            sp.energy_scale = EnergyBoundTable::bound_scale(energy_table_->albedo(sp.theta_o) + sp.ms_color);
        }
        for (int p = 0; p < 3; ++p)
            sp.longitudinal[p] = TruncatedNormal(-sp.sin_theta_o + alpha_[p], beta_[p], -1.0, 1.0);
        // Lobe selection from each lobe's attenuation at a representative direction.
        const double cd = std::max(cos_theta_o, 1e-3);
        const RGB& C = params_.base_color;
        auto cpow = [&](double e) { return RGB(std::pow(C.r, e), std::pow(C.g, e), std::pow(C.b, e)); };
        const double f_tt = fresnel(cd), f_trt = fresnel(0.5 * cd);
        std::array<double, 4> w{};
        w[0] = params_.r_scale * fresnel(cd);
        w[1] = params_.variant == EpicVariant::Environment ? 0.0 : sqr(1.0 - f_tt) * luminance(cpow(0.5 / cd));
        w[2] = 0.75 * sqr(1.0 - f_trt) * f_trt * luminance(cpow(0.8 / cd));
        w[3] = luminance(sp.ms_color);
        double total = 0;
        for (double& x : w) total += (x = std::isfinite(x) ? std::max(x, 0.0) : 0.0);
        if (total > 0)
            for (int p = 0; p < 4; ++p) sp.lobe_weight[p] = w[p] / total;
        return sp;
    }

    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const {
        BsdfEval out;
        const double sin_theta_i = sp.frame.sin_theta(wi);
        const double phi = sp.frame.phi(wi) + 0.5 * kPi;  // phi_i - phi_o
        out.lobes = lobes(sp, wi, sin_theta_i, phi);
        if (sp.bounded)
            for (RGB& l : out.lobes) l = l * sp.energy_scale;
        out.pdf = pdf_local(sp, wi, sin_theta_i, phi);
        if (!std::isfinite(out.pdf) || !isfinite(out.value())) return {};
        return out;
    }
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const { return eval(prepare(ctx), wi); }
    double pdf(const ShadingContext& ctx, Vec3 wi) const { return pdf(prepare(ctx), wi); }
    double pdf(const ShadingPoint& sp, Vec3 wi) const {
        return pdf_local(sp, wi, sp.frame.sin_theta(wi), sp.frame.phi(wi) + 0.5 * kPi);
    }
    // Lobe p's published value (without the energy bound); the energy table integrates lobes one by one.
    RGB published_lobe(const ShadingPoint& sp, Vec3 wi, int p) const {
        return lobes(sp, wi, sp.frame.sin_theta(wi), sp.frame.phi(wi) + 0.5 * kPi, p)[size_t(p)];
    }

    // u2 picks the lobe and, rescaled, sin theta_i (MS: the cosine to the fake normal);
    // u0 the azimuth; u1 the MS azimuth around the fake normal.
    BsdfSample sample(const ShadingPoint& sp, const std::array<double, 3>& u) const {
        BsdfSample out;
        int p = 0;
        double v = u[2];
        for (; p < 3; ++p) {
            if (v < sp.lobe_weight[p]) break;
            v -= sp.lobe_weight[p];
        }
        if (!(sp.lobe_weight[p] > 0)) return out;
        v = clamp(v / sp.lobe_weight[p], 0.0, 1.0);
        Vec3 wi;
        if (p < 3) {
            if (!(sp.longitudinal[p].mass() > 0)) return out;
            const double sin_theta_i = sp.longitudinal[p].sample(v);
            double phi;
            if (p == 0) {
                phi = 2.0 * safe_asin(2.0 * u[0] - 1.0);
            } else if (p == 1) {
                phi = kPi + sample_trimmed_logistic(u[0], kTTLogisticScale);
            } else {
                phi = sample_trimmed_logistic(u[0], kTRTLogisticScale);
            }
            wi = sp.frame.direction(sin_theta_i, cos_from_sin(sin_theta_i), phi - 0.5 * kPi);
        } else {
            const double t = clamp(2.0 * std::sqrt(v) - 1.0, -1.0, 1.0);  // density (1 + t) / 2
            const double psi = kTwoPi * u[1];
            const Vec3 b = cross(sp.fake_normal, sp.frame.x);
            wi = t * sp.fake_normal + cos_from_sin(t) * (std::cos(psi) * sp.frame.x + std::sin(psi) * b);
        }
        const BsdfEval e = eval(sp, wi);
        return sample_from_eval(wi, e, p);
    }
    BsdfSample sample(const ShadingContext& ctx, const std::array<double, 3>& u) const {
        return sample(prepare(ctx), u);
    }

private:
    static double gaussian(double beta, double x) {
        return std::exp(-0.5 * sqr(x / beta)) / (beta * 2.5066282746310002);
    }

    // The published lobes; only >= 0: that lobe alone (the others 0).
    std::array<RGB, kLobeCount> lobes(const ShadingPoint& sp, Vec3 wi, double sin_theta_i, double phi,
                                      int only = -1) const {
        std::array<RGB, kLobeCount> out{};
        const RGB& C = params_.base_color;
        auto cpow = [&](double e) { return RGB(std::pow(C.r, e), std::pow(C.g, e), std::pow(C.b, e)); };
        const double x = sin_theta_i + sp.sin_theta_o;
        const double theta_i = std::asin(sin_theta_i);
        const double cos_theta_d = std::max(std::cos(0.5 * (sp.theta_o - theta_i)), 1e-6);
        const double cos_phi = std::cos(phi);
        const double cos_half_phi = std::sqrt(clamp(0.5 + 0.5 * cos_phi, 0.0, 1.0));
        const double wi_dot_wr = clamp(dot(wi, sp.wo), -1.0, 1.0);
        const bool environment = params_.variant == EpicVariant::Environment;

        // R: M_R N_R, N_R = 1/4 cos(phi/2) F(eta, sqrt(1/2 + 1/2 wi.wr)); Specular scales it.
        if (only < 0 || only == LobeR) {
            double r = gaussian(beta_[0], x - alpha_[0]) * 0.25 * cos_half_phi *
                       fresnel(std::sqrt(clamp(0.5 + 0.5 * wi_dot_wr, 0.0, 1.0))) * params_.r_scale;
            if (environment) r *= clamp(wi_dot_wr + 1.0, 0.0, 1.0);
            out[LobeR] = RGB(r);
        }
        const double eta_prime = 1.19 / cos_theta_d + 0.36 * cos_theta_d;
        const double a = 1.0 / eta_prime;
        // TT (removed in the environment variant).
        if (!environment && (only < 0 || only == LobeTT)) {
            const double h = (1.0 + a * (0.6 - 0.8 * cos_phi)) * cos_half_phi;
            const double f = fresnel(cos_theta_d * safe_sqrt(1.0 - h * h));
            const RGB T = cpow(safe_sqrt(1.0 - sqr(h * a)) / (2.0 * cos_theta_d));
            const double m = gaussian(beta_[1], x - alpha_[1]);
            const double n = std::exp(-3.65 * cos_phi - 3.98);
            out[LobeTT] = (m * n * sqr(1.0 - f)) * T;
        }
        // TRT: h = sqrt(3)/2.
        if (only < 0 || only == LobeTRT) {
            const double f = fresnel(0.5 * cos_theta_d);
            const RGB T = cpow(0.8 / cos_theta_d);
            const double m = gaussian(beta_[2], x - alpha_[2]);
            const double n = std::exp(17.0 * cos_phi - 16.78);
            out[LobeTRT] = (m * n * sqr(1.0 - f) * f) * T;
        }
        // Multiple scattering around the fake normal.
        if (only < 0 || only == LobeTRRT) out[LobeTRRT] = ((dot(sp.fake_normal, wi) + 1.0) / (4.0 * kPi)) * sp.ms_color;
        return out;
    }

    double pdf_local(const ShadingPoint& sp, Vec3 wi, double sin_theta_i, double phi) const {
        double pdf = 0;
        if (sp.lobe_weight[0] > 0) {
            pdf += sp.lobe_weight[0] * sp.longitudinal[0].pdf(sin_theta_i) * 0.25 *
                   std::sqrt(clamp(0.5 + 0.5 * std::cos(phi), 0.0, 1.0));
        }
        if (sp.lobe_weight[1] > 0) {
            pdf += sp.lobe_weight[1] * sp.longitudinal[1].pdf(sin_theta_i) *
                   logistic(wrap_angle(phi - kPi), kTTLogisticScale) * tt_norm_;
        }
        if (sp.lobe_weight[2] > 0) {
            pdf += sp.lobe_weight[2] * sp.longitudinal[2].pdf(sin_theta_i) *
                   logistic(wrap_angle(phi), kTRTLogisticScale) * trt_norm_;
        }
        if (sp.lobe_weight[3] > 0) pdf += sp.lobe_weight[3] * (dot(sp.fake_normal, wi) + 1.0) / (4.0 * kPi);
        return pdf;
    }

    EpicHairParams params_;
    std::array<double, 3> beta_{}, alpha_{};
    double f0_ = 0.04;
    double tt_norm_ = 1, trt_norm_ = 1;
    std::array<double, 3> sqrt_c_{}, c_over_luma_{};
    std::shared_ptr<const EnergyBoundTable> energy_table_;
};

}  // namespace hairbsdf
