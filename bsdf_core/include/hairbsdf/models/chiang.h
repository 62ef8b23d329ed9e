// Chiang et al. 2016, "A Practical and Controllable Hair and Fur Model for Production
// Path Tracing", as Blender Cycles evaluates and samples it (docs/cycles.md §4).
// Setup, eval, sample and pdf for one closure live here, Cycles-closure style.
#pragma once

#include "hairbsdf/closure.h"
#include "hairbsdf/math_hair_defaults.h"
#include "hairbsdf/math_simd.h"

namespace hairbsdf {

// Chiang's roughness mapping, from the user's roughnesses to the model's numbers.
// The mappings below are written once, over any number type T (double here, SIMD float batches in
// the per-row batch kernels, docs/simd.md); the double functions are these templates.
// Chiang 2016 eq. 7: longitudinal roughness -> variance of M_p.
template <class T>
inline T longitudinal_variance_of(T beta_m) {
    const T b2 = beta_m * beta_m, b4 = b2 * b2, b20 = b4 * b4 * b4 * b4 * b4;
    const T r = T(0.726) * beta_m + T(0.812) * b2 + T(3.7) * b20;
    return r * r;
}
inline double longitudinal_variance(double beta_m) { return longitudinal_variance_of(beta_m); }

// Chiang 2016 eq. 8: azimuthal roughness -> logistic scale, without sqrt(pi/8).
template <class T>
inline T azimuthal_scale_raw_of(T beta_n) {
    const T b2 = beta_n * beta_n, b4 = b2 * b2, b8 = b4 * b4, b16 = b8 * b8;
    return T(0.265) * beta_n + T(1.194) * b2 + T(5.372) * b16 * b4 * b2;
}
inline double azimuthal_scale_raw(double beta_n) { return azimuthal_scale_raw_of(beta_n); }
// ... and with sqrt(pi/8), the scale N_p uses (Cycles folds it in at setup).
inline double azimuthal_scale(double beta_n) { return kSqrtPiOver8 * azimuthal_scale_raw(beta_n); }

// Chiang 2016 eq. 9 denominator; Cycles' bsdf_principled_hair_albedo_roughness_scale.
template <class T>
inline T albedo_roughness_scale_of(T beta_n) {
    const T x = beta_n, x2 = x * x, x3 = x2 * x, x4 = x2 * x2, x5 = x4 * x;
    return T(5.969) - T(0.215) * x + T(2.532) * x2 - T(10.73) * x3 + T(5.574) * x4 + T(0.245) * x5;
}
inline double albedo_roughness_scale(double beta_n) { return albedo_roughness_scale_of(beta_n); }

// `cycles`: Cycles' truncated Bessel series and log branch (the default).
// `exact`: accurate special functions, so that every M_p integrates to 1.
enum class Accuracy { Cycles, Exact };

// Where the cuticle tilt enters M_p. Blender 4.2+ rotates the view angle theta_o;
// Blender 3.4-4.1 rotated the light angle theta_i and used the older sampler (docs/cycles.md §4.4, §5b).
enum class TiltConvention { Blender42, Blender34 };

// The longitudinal sampler's two numbers as Cycles before 3.6 drew them: from an LCG seeded per
// hit with (pixel hash + rng_offset + sample x scramble), where rng_offset grows by 16 at every
// bounce, so a path's successive draws are shifted copies of each other (+0.1647 and +0.0307
// mod 1). That correlation adds light after two or more bounces (docs/engine.md); Cycles 3.6
// draws them independently. `from_cycles_lcg(seed)`: lcg_init, then two float steps.
struct LongitudinalNumbers {
    double theta = 0.5;    // picks sin(theta_i) within the lobe's cone
    double azimuth = 0.5;  // the azimuth around the cone
    static LongitudinalNumbers from_cycles_lcg(uint32_t seed) {
        uint32_t state = seed;
        lcg_step(state);  // lcg_init
        LongitudinalNumbers out;
        out.theta = double(lcg_step(state)) * (1.0 / 4294967295.0);
        out.azimuth = double(lcg_step(state)) * (1.0 / 4294967295.0);
        return out;
    }
};

// Model parameters, already mapped (roughness -> variance and logistic scale).
struct ChiangHairParams {
    RGB sigma_a{0.0};             // absorption per unit fibre diameter
    double eta = blender_hair::kIor;  // relative IOR, used as given (no clamp, as in Cycles)
    std::array<double, 4> v{};    // M_p variance used by eval and pdf: R, TT, TRT, TRRT+
    std::array<double, 4> v_sample{};  // variance the sampler uses (Cycles samples R with the un-coated v)
    std::array<double, 3> s{};    // logistic scale of N_p, sqrt(pi/8) included: R, TT, TRT
    double tilt = 0;              // cuticle tilt in radians = Blender's Offset; R highlight moves by -2*tilt in theta
    std::array<RGB, 4> tint{RGB(1.0), RGB(1.0), RGB(1.0), RGB(1.0)};  // per-lobe tints (MaterialX); 1 for Principled Hair
    Accuracy accuracy = Accuracy::Cycles;
    TiltConvention tilt_convention = TiltConvention::Blender42;
};

// Longitudinal scattering M_p for one lobe (d'Eon et al. 2011 form, docs/cycles.md §4.3), with its
// normalisation precomputed.
class LongitudinalLobe {
public:
    LongitudinalLobe() = default;
    LongitudinalLobe(double v, Accuracy accuracy) : v_(v), inv_v_(1.0 / v), accuracy_(accuracy) {
        if (accuracy == Accuracy::Exact) {
            // log of 1 / (2 v sinh(1/v)), computed without overflow.
            log_norm_ = -std::log(v) - inv_v_ - std::log1p(-std::exp(-2.0 * inv_v_));
        } else if (v <= 0.1) {
            log_norm_ = -inv_v_ + 0.6931 + std::log(0.5 * inv_v_);  // Cycles' constants, 0.6931 included
        } else {
            log_branch_ = false;
            norm_ = 1.0 / (std::sinh(inv_v_) * 2.0 * v);
        }
    }
    // M_p(theta_i, theta_o); both cosines are non-negative. exp(log I0(a) + y) is
    // computed as I0(a) exp(y) where I0 comes from a series, which saves a log. `in_float`: the
    // Cycles branches take the float-accuracy exp (math.h, cycles_float_maths).
    HAIRBSDF_ALWAYS_INLINE double eval(double sin_theta_i, double cos_theta_i, double sin_theta_o,
                                       double cos_theta_o, bool in_float = false) const {
        const double a = cos_theta_i * cos_theta_o * inv_v_;
        const double b = sin_theta_i * sin_theta_o * inv_v_;
        if (accuracy_ == Accuracy::Exact) {
            if (a < kBesselSeriesLimit) return bessel_i0_series(a) * std::exp(log_norm_ - b);
            return std::exp(log_bessel_i0_asymptotic(a) - b + log_norm_);
        }
        if (!log_branch_) return exp_in(in_float, -b) * cycles_bessel_i0(a) * norm_;
        if (a <= 12.0) return cycles_bessel_i0(a) * exp_in(in_float, log_norm_ - b);
        // Cycles' asymptote: log I0(a) = a + (1/(8a) - ln(2 pi) - ln a) / 2.
        return exp_in(in_float, a + 1.0 / (16.0 * a) - b + log_norm_) / std::sqrt(kTwoPi * a);
    }
    double variance() const { return v_; }
    // The Cycles branches' numbers, for the lane-pair form (ChiangHair::mp_pair): M_p = I0(a) exp(add - b) mul
    // below asym_limit, the asymptote exp(a + 1/(16 a) - b + add) / sqrt(2 pi a) above it.
    double inv_v() const { return inv_v_; }
    double cycles_add() const { return log_branch_ ? log_norm_ : 0.0; }
    double cycles_mul() const { return log_branch_ ? 1.0 : norm_; }
    double cycles_asym_limit() const { return log_branch_ ? 12.0 : HUGE_VAL; }

private:
    double v_ = 1, inv_v_ = 1;
    double log_norm_ = 0;  // additive constant of the log forms
    double norm_ = 0;      // multiplicative constant of the direct form
    bool log_branch_ = true;
    Accuracy accuracy_ = Accuracy::Cycles;
};

// d'Eon et al. 2013 sampler of M_p around the direction (sin_theta_o, cos_theta_o):
// returns sin(theta_i). u_theta is clamped to >= 1e-5 as in Cycles. `in_float`: the inlined log and cos
// of math.h (log_in, sincos_in).
inline double sample_longitudinal(double v, double exp_minus_2_over_v, double u_theta, double u_azimuth,
                                  double sin_theta_o, double cos_theta_o, bool in_float = false) {
    u_theta = clamp(u_theta, 1e-5, 1.0);
    const double fac = 1.0 + v * log_in(in_float, u_theta + (1.0 - u_theta) * exp_minus_2_over_v);
    const double cos_azimuth = sincos_in(in_float, kTwoPi * u_azimuth).cos;
    return clamp(-fac * sin_theta_o + cos_from_sin(fac) * cos_azimuth * cos_theta_o, -1.0, 1.0);
}

// Rotation of an angle (sin, cos) by a fixed angle (sin_a, cos_a), returning |cos| (docs/cycles.md §4.3).
struct SinCos {
    double sin, cos;
};
inline SinCos rotate_angle(double sin_t, double cos_t, double sin_a, double cos_a) {
    return {sin_t * cos_a + cos_t * sin_a, std::fabs(cos_t * cos_a - sin_t * sin_a)};
}

// Geometry of one internal pass of the refracted ray at the view's offset h (docs/cycles.md §4.2), handed
// to a pass-transmittance function: the 2D distance of the chord from the axis is |sin_gamma_t|,
// its 3D length 2 cos_gamma_t / cos_theta_t (unit radius).
struct ChiangPassGeometry {
    double sin_gamma_t, cos_gamma_t, cos_theta_t;
};

// A_p for R, TT, TRT and the residual TRRT+ from the Fresnel factor f and the transmittance T of
// one internal pass (docs/cycles.md §4.2): f, (1-f)^2 T, (1-f)^2 T^2 f, and the geometric tail of TRT.
inline std::array<RGB, 4> chiang_attenuation(double f, RGB T) {
    std::array<RGB, 4> out;
    const double one_minus_f = 1.0 - f;
    RGB a = RGB(f);
    out[0] = a;
    a = (one_minus_f * one_minus_f) * T;
    out[1] = a;
    a = a * T * f;
    out[2] = a;
    const RGB tf = f * T;
    auto safe_ratio = [](double x) { return x == 1.0 ? 0.0 : x / (1.0 - x); };
    out[3] = a * RGB(safe_ratio(tf.r), safe_ratio(tf.g), safe_ratio(tf.b));
    return out;
}

class ChiangHair {
public:
    explicit ChiangHair(const ChiangHairParams& params) : params_(params) {
        for (int p = 0; p < 4; ++p) {
            mp_[p] = LongitudinalLobe(params.v[p], params.accuracy);
            exp_minus_2_over_v_[p] = std::exp(-2.0 / params.v_sample[p]);
            pair_inv_v_[p / 2][p % 2] = mp_[p].inv_v();
            pair_add_[p / 2][p % 2] = mp_[p].cycles_add();
            pair_mul_[p / 2][p % 2] = mp_[p].cycles_mul();
            pair_asym_limit_[p / 2][p % 2] = mp_[p].cycles_asym_limit();
        }
        for (const RGB& t : params.tint) tinted_ = tinted_ || t.r != 1.0 || t.g != 1.0 || t.b != 1.0;
        for (int p = 0; p < 3; ++p) {
            logistic_cdf_minus_pi_[p] = logistic_cdf(-kPi, params.s[p]);
            logistic_norm_[p] = 1.0 / (logistic_cdf(kPi, params.s[p]) - logistic_cdf_minus_pi_[p]);
        }
        // Per-lobe tilt of M_p's angle: R by +2 tilt, TT by -tilt, TRT by -4 tilt.
        const double t = params.tilt;
        rotations_ = {SinCos{std::sin(2 * t), std::cos(2 * t)}, SinCos{std::sin(-t), std::cos(-t)},
                      SinCos{std::sin(-4 * t), std::cos(-4 * t)}};
    }

    const ChiangHairParams& params() const { return params_; }

    // Cycles' Filter Glossy (bsdf_principled_hair_blur): v, s and the R-lobe variance become
    // max(roughness, value) of the mapped values (docs/cycles.md §6).
    ChiangHair blurred(double roughness) const {
        ChiangHairParams b = params_;
        const double v = std::max(roughness, params_.v_sample[0]);
        const double v_r = std::max(roughness, params_.v[0]);
        const double s = std::max(roughness, params_.s[0]);
        b.v = {v_r, 0.25 * v, 4.0 * v, 4.0 * v};
        b.v_sample = {v, 0.25 * v, 4.0 * v, 4.0 * v};
        b.s = {s, s, s};
        return ChiangHair(b);
    }
    static uint8_t scatter_label(int lobe) { return hair_lobe_label(lobe); }

    // Narrowest lobe widths in theta and phi (radians), for quadrature resolution.
    std::array<double, 2> angular_scales() const {
        double theta = 1e9, phi = 1e9;
        for (double v : params_.v) theta = std::min(theta, std::sqrt(v));
        for (double s : params_.s) phi = std::min(phi, s);
        return {theta, phi};
    }

    // Everything that depends only on the view direction and h: computed once per
    // shading point (Cycles' closure setup), then shared by eval, pdf and sample. view_terms writes every
    // field; the numbers have no default (a value-initialised ViewTerms{} is zero).
    struct ViewTerms {
        double sin_theta_o, cos_theta_o, phi_o;
        double gamma_o, gamma_t;
        std::array<RGB, 4> attenuation;    // A_p with tints
        std::array<double, 4> lobe_weight;  // a_p: luminance-normalised selection probabilities
        std::array<SinCos, 3> tilted;       // tilted view angle per lobe (4.2 convention)
        std::array<double, 3> azimuth_center;  // centre of N_p in phi - phi_o: R, TT, TRT
        bool valid = false;
        bool in_float = false;  // float_maths() as view_terms read it, for eval and sample to reuse
    };

    struct ShadingPoint {
        FibreFrame frame;
        ViewTerms view;
    };
    // prepare, eval and sample run the AVX2 + FMA build of their bodies (the *_baseline functions below) where
    // the machine has both (scalar_avx2(), src/models/chiang_avx2.cpp); the same formulas, FMA-rounded.
    ShadingPoint prepare(const ShadingContext& ctx) const {
        if (scalar_avx2()) return prepare_avx2(*this, ctx);
        return prepare_baseline(ctx);
    }
    HAIRBSDF_ALWAYS_INLINE ShadingPoint prepare_baseline(const ShadingContext& ctx) const {
        const FibreFrame frame(ctx.tangent, ctx.wo);
        return {frame, view_terms(frame, ctx)};
    }

    // The view terms with Chiang's pass transmittance exp(-sigma_a 2 cos gamma_t / cos theta_t).
    ViewTerms view_terms(const FibreFrame& frame, const ShadingContext& ctx) const {
        const bool in_float = float_maths();
        return view_terms(
            frame, ctx,
            [this, in_float](const ChiangPassGeometry& g) {
                const RGB x = (-2.0 * g.cos_gamma_t / g.cos_theta_t) * params_.sigma_a;
                if (!in_float) return RGB(std::exp(x.r), std::exp(x.g), std::exp(x.b));
                const Double2 rg = exp_float_accuracy(Double2{x.r, x.g});  // red and green in one pair
                return RGB(rg[0], rg[1], exp_float_accuracy(x.b));
            },
            in_float);
    }
    // The same with another transmittance per internal pass (yan_fur's medulla): a callable
    // RGB(const ChiangPassGeometry&). Everything else (Fresnel, A_p, lobe weights) is Chiang's.
    template <class PassTransmittance>
    ViewTerms view_terms(const FibreFrame& frame, const ShadingContext& ctx,
                         const PassTransmittance& pass_transmittance) const {
        return view_terms(frame, ctx, pass_transmittance, float_maths());
    }
    // ... with float_maths() read once by the caller.
    template <class PassTransmittance>
    HAIRBSDF_ALWAYS_INLINE ViewTerms view_terms(const FibreFrame& frame, const ShadingContext& ctx,
                                                const PassTransmittance& pass_transmittance, bool in_float) const {
        ViewTerms vt;
        vt.in_float = in_float;
        const double eta = params_.eta;
        vt.sin_theta_o = frame.sin_theta(ctx.wo);
        vt.cos_theta_o = cos_from_sin(vt.sin_theta_o);
        vt.phi_o = -0.5 * kPi;  // by construction of the frame

        const double sin_theta_t = vt.sin_theta_o / eta;
        const double cos_theta_t = cos_from_sin(sin_theta_t);
        const double h = ctx.h;
        const double cos_gamma_o = cos_from_sin(h);
        vt.gamma_o = asin_in(in_float, h);
        // NaN for eta < 1 at grazing angles, as in Cycles; caught below and returned as 0.
        const double sin_gamma_t = h * vt.cos_theta_o / std::sqrt(eta * eta - sqr(vt.sin_theta_o));
        const double cos_gamma_t = cos_from_sin(sin_gamma_t);
        vt.gamma_t = asin_in(in_float, sin_gamma_t);

        const RGB T = pass_transmittance(ChiangPassGeometry{sin_gamma_t, cos_gamma_t, cos_theta_t});
        const double f = fresnel_dielectric(vt.cos_theta_o * cos_gamma_o, eta);
        vt.attenuation = chiang_attenuation(f, T);

        double total = 0;
        for (int p = 0; p < 4; ++p) {
            if (tinted_) vt.attenuation[p] = vt.attenuation[p] * params_.tint[p];
            vt.lobe_weight[p] = luminance(vt.attenuation[p]);
            total += vt.lobe_weight[p];
        }
        // Every field is written before the validity test, on both paths.
        for (int p = 0; p < 3; ++p) {
            vt.tilted[p] = rotate_angle(vt.sin_theta_o, vt.cos_theta_o, rotations_[p].sin, rotations_[p].cos);
            vt.azimuth_center[p] = 2.0 * p * vt.gamma_t - 2.0 * vt.gamma_o + p * kPi;
        }
        if (!(total > 0) || !std::isfinite(total) || !std::isfinite(vt.gamma_t)) return vt;
        for (double& w : vt.lobe_weight) w /= total;
        vt.valid = true;
        return vt;
    }

    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const {
        if (scalar_avx2()) return eval_avx2(*this, sp, wi);
        return eval_baseline(sp, wi);
    }
    HAIRBSDF_ALWAYS_INLINE BsdfEval eval_baseline(const ShadingPoint& sp, Vec3 wi) const {
        if (!sp.view.valid) return {};
        const double sin_theta_i = sp.frame.sin_theta(wi);
        const bool in_float = sp.view.in_float;
        const double phi = atan2_in(in_float, dot(wi, sp.frame.z), dot(wi, sp.frame.y));  // frame.phi(wi)
        return eval_local(sp.view, sin_theta_i, cos_from_sin(sin_theta_i), phi - sp.view.phi_o, in_float);
    }
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const { return eval(prepare(ctx), wi); }
    double pdf(const ShadingContext& ctx, Vec3 wi) const { return eval(ctx, wi).pdf; }

    // u = (u0, u1, u2): u2 picks the lobe and, rescaled, theta_i; u1 the azimuth of the
    // longitudinal sampler; u0 the azimuthal offset (docs/conventions.md). `longitudinal`, when
    // given, replaces the numbers for theta_i and the azimuth (Cycles < 3.6, see above).
    BsdfSample sample(const ShadingContext& ctx, const std::array<double, 3>& u) const {
        return sample(prepare(ctx), u);
    }
    BsdfSample sample(const ShadingPoint& sp, const std::array<double, 3>& u,
                      const LongitudinalNumbers* longitudinal = nullptr) const {
        if (scalar_avx2()) return sample_avx2(*this, sp, u, longitudinal);
        return sample_baseline(sp, u, longitudinal);
    }
    HAIRBSDF_ALWAYS_INLINE BsdfSample sample_baseline(const ShadingPoint& sp, const std::array<double, 3>& u,
                                                      const LongitudinalNumbers* longitudinal) const {
        BsdfSample out;
        const FibreFrame& frame = sp.frame;
        const ViewTerms& vt = sp.view;
        if (!vt.valid) return out;

        int p = 0;
        double u_lobe = u[2];
        for (; p < 3; ++p) {
            if (u_lobe < vt.lobe_weight[p]) break;
            u_lobe -= vt.lobe_weight[p];
        }
        u_lobe = vt.lobe_weight[p] > 0 ? u_lobe / vt.lobe_weight[p] : 0.5;

        const double u_theta = longitudinal ? longitudinal->theta : u_lobe;
        const double u_azimuth = longitudinal ? longitudinal->azimuth : u[1];
        const bool in_float = vt.in_float;
        if (in_float && params_.tilt_convention == TiltConvention::Blender42) {
            // sample_lobe_direction's numbers with its two logs (the longitudinal sampler's and the trimmed
            // logistic's) in one lane pair, and the two sin/cos (the sampler's azimuth, the direction's phi) in
            // another: the same values.
            const SinCos o = p < 3 ? vt.tilted[p] : SinCos{vt.sin_theta_o, vt.cos_theta_o};
            const double u_theta_clamped = clamp(u_theta, 1e-5, 1.0);
            const double cdf_minus_pi = p < 3 ? logistic_cdf_minus_pi_[p] : 0.0;
            const double logistic_arg = p < 3 ? 1.0 / (u[0] * (1.0 - 2.0 * cdf_minus_pi) + cdf_minus_pi) - 1.0 : 1.0;
            const Double2 logs = log_float_accuracy(
                Double2{u_theta_clamped + (1.0 - u_theta_clamped) * exp_minus_2_over_v_[p], logistic_arg});
            const double fac = 1.0 + params_.v_sample[p] * logs[0];
            const double phi =
                p < 3 ? vt.azimuth_center[p] + clamp(-params_.s[p] * logs[1], -kPi, kPi) : kTwoPi * u[0];
            const SinCosPair2 sc = sincos_accurate(Double2{kTwoPi * u_azimuth, phi});
            const double sin_theta_i = clamp(-fac * o.sin + cos_from_sin(fac) * sc.cos[0] * o.cos, -1.0, 1.0);
            const double cos_theta_i = cos_from_sin(sin_theta_i);
            const Vec3 wi =
                sin_theta_i * frame.x + (cos_theta_i * sc.sin[1]) * frame.y - (cos_theta_i * sc.cos[1]) * frame.z;
            return sample_from_eval(wi, eval_local(vt, sin_theta_i, cos_theta_i, phi, true), p);
        }
        const LobeDirection d = sample_lobe_direction(vt, p, u_theta, u_azimuth, u[0]);
        const double sin_theta_i = d.sin_theta_i, cos_theta_i = d.cos_theta_i, phi = d.phi;
        // frame.direction(sin_theta_i, cos_theta_i, vt.phi_o + phi) with phi_o = -pi/2: cos(phi - pi/2) = sin(phi),
        // sin(phi - pi/2) = -cos(phi).
        const SinCosPair sc = sincos_in(in_float, phi);
        const Vec3 wi = sin_theta_i * frame.x + (cos_theta_i * sc.sin) * frame.y - (cos_theta_i * sc.cos) * frame.z;
        return sample_from_eval(wi, eval_local(vt, sin_theta_i, cos_theta_i, phi, in_float), p);
    }

    // A direction from lobe p's sampling density (M_p about the lobe's tilted cone, N_p's trimmed
    // logistic; uniform azimuth for TRRT+): u_theta for theta_i, u_azimuth for the longitudinal
    // sampler's azimuth, u_phi for the azimuthal offset. phi is relative to the view's phi_o.
    struct LobeDirection {
        double sin_theta_i, cos_theta_i, phi;
    };
    LobeDirection sample_lobe_direction(const ViewTerms& vt, int p, double u_lobe, double u1, double u0) const {
        const double v = params_.v_sample[p];
        const bool in_float = vt.in_float;
        double sin_theta_i;
        if (params_.tilt_convention == TiltConvention::Blender42) {
            // Sample around the tilted view angle (the importance-sampling fix #114780).
            const SinCos o = p < 3 ? vt.tilted[p] : SinCos{vt.sin_theta_o, vt.cos_theta_o};
            sin_theta_i = sample_longitudinal(v, exp_minus_2_over_v_[p], u_lobe, u1, o.sin, o.cos, in_float);
        } else {
            // Blender 3.4: sample around the untilted view angle, then rotate the result
            // back by the lobe's tilt (the pbrt-v3 scheme that #114780 replaced).
            sin_theta_i = sample_longitudinal(v, exp_minus_2_over_v_[p], u_lobe, u1, vt.sin_theta_o,
                                              vt.cos_theta_o, in_float);
        }
        double cos_theta_i = cos_from_sin(sin_theta_i);

        double phi;
        if (p < 3) {
            // The trimmed logistic's inverse CDF (sample_trimmed_logistic) with its CDF at -pi hoisted.
            const double s = params_.s[p], cdf_minus_pi = logistic_cdf_minus_pi_[p];
            const double x = -s * log_in(in_float, 1.0 / (u0 * (1.0 - 2.0 * cdf_minus_pi) + cdf_minus_pi) - 1.0);
            phi = vt.azimuth_center[p] + clamp(x, -kPi, kPi);
        } else {
            phi = kTwoPi * u0;
        }
        if (params_.tilt_convention == TiltConvention::Blender34 && p < 3) {
            // Rotate theta_i by minus the lobe's tilt; past the pole the direction flips in phi.
            const SinCos& r = rotations_[p];
            const double s = sin_theta_i, c = cos_theta_i;
            sin_theta_i = clamp(s * r.cos - c * r.sin, -1.0, 1.0);
            const double c_rotated = c * r.cos + s * r.sin;
            cos_theta_i = std::fabs(c_rotated);
            if (c_rotated < 0) phi += kPi;
        }
        return {sin_theta_i, cos_theta_i, phi};
    }

    // Per-lobe values and pdf for theta_i and the azimuth difference phi = phi_i - phi_o (pdf: the
    // density of sample(), the lobe mixture by lobe_weight).
    // `in_float`: float_maths(), read once by the caller.
    BsdfEval eval_local(const ViewTerms& vt, double sin_theta_i, double cos_theta_i, double phi) const {
        return eval_local(vt, sin_theta_i, cos_theta_i, phi, float_maths());
    }
    HAIRBSDF_ALWAYS_INLINE BsdfEval eval_local(const ViewTerms& vt, double sin_theta_i, double cos_theta_i, double phi, bool in_float) const {
        std::array<double, 4> mn;  // M_p N_p per lobe (TRRT+: M_p / 2 pi)
        double pdf = 0;
        if (in_float && params_.tilt_convention == TiltConvention::Blender42) {
            // Lobes in pairs (R, TT) and (TRT, TRRT+), two lanes at once: the same formulas as below.
            const Double2 m01 = mp_pair(0, sin_theta_i, cos_theta_i, Double2{vt.tilted[0].sin, vt.tilted[1].sin},
                                        Double2{vt.tilted[0].cos, vt.tilted[1].cos});
            const Double2 m23 = mp_pair(1, sin_theta_i, cos_theta_i, Double2{vt.tilted[2].sin, vt.sin_theta_o},
                                        Double2{vt.tilted[2].cos, vt.cos_theta_o});
            const double x0 = wrap_angle(phi - vt.azimuth_center[0]), x1 = wrap_angle(phi - vt.azimuth_center[1]);
            const double x2 = wrap_angle(phi - vt.azimuth_center[2]);
            const Double2 s01 = {params_.s[0], params_.s[1]};
            const Double2 e01 = exp_float_accuracy(-Double2{std::fabs(x0), std::fabs(x1)} / s01);
            const Double2 one_e = 1.0 + e01;
            const Double2 np01 = e01 / (s01 * (one_e * one_e)) * Double2{logistic_norm_[0], logistic_norm_[1]};
            const double s2 = params_.s[2], e2 = exp_float_accuracy(-std::fabs(x2) / s2);
            const double np2 = e2 / (s2 * sqr(1.0 + e2)) * logistic_norm_[2];
            mn = {m01[0] * np01[0], m01[1] * np01[1], m23[0] * np2, m23[1] * kInvTwoPi};
            pdf = ((vt.lobe_weight[0] * mn[0] + vt.lobe_weight[1] * mn[1]) + vt.lobe_weight[2] * mn[2]) +
                  vt.lobe_weight[3] * mn[3];
            return finish_eval(vt, mn, pdf);
        }
        for (int p = 0; p < 3; ++p) {
            double mp;
            if (params_.tilt_convention == TiltConvention::Blender42) {
                mp = mp_[p].eval(sin_theta_i, cos_theta_i, vt.tilted[p].sin, vt.tilted[p].cos, in_float);
            } else {
                const SinCos ti = rotate_angle(sin_theta_i, cos_theta_i, rotations_[p].sin, rotations_[p].cos);
                mp = mp_[p].eval(ti.sin, ti.cos, vt.sin_theta_o, vt.cos_theta_o, in_float);
            }
            const double x = wrap_angle(phi - vt.azimuth_center[p]);
            // logistic(x, s) times its trimming's normalisation
            const double s = params_.s[p], e = exp_in(in_float, -std::fabs(x) / s);
            const double np = e / (s * sqr(1.0 + e)) * logistic_norm_[p];
            mn[p] = mp * np;
            pdf += vt.lobe_weight[p] * mn[p];
        }
        mn[3] = mp_[3].eval(sin_theta_i, cos_theta_i, vt.sin_theta_o, vt.cos_theta_o, in_float) * kInvTwoPi;
        pdf += vt.lobe_weight[3] * mn[3];
        return finish_eval(vt, mn, pdf);
    }
    HAIRBSDF_ALWAYS_INLINE static BsdfEval finish_eval(const ViewTerms& vt, const std::array<double, 4>& mn, double pdf) {
        // Built once at the end (no zeroed BsdfEval overwritten lobe by lobe); one finiteness test of the pdf
        // and the value's sum.
        const RGB l0 = mn[0] * vt.attenuation[0], l1 = mn[1] * vt.attenuation[1];
        const RGB l2 = mn[2] * vt.attenuation[2], l3 = mn[3] * vt.attenuation[3];
        const RGB value = (l0 + l1) + (l2 + l3);
        if (!std::isfinite(pdf + value.r + value.g + value.b)) return {};
        return BsdfEval{{l0, l1, l2, l3, RGB(), RGB()}, pdf};
    }

private:
    // The AVX2 + FMA builds of prepare, eval and sample (src/models/chiang_avx2.cpp): each inlines the whole
    // *_baseline body into one function compiled for that instruction set, so that no inline function of the
    // headers is emitted for it (callers without AVX2 never reach AVX2 code).
    HAIRBSDF_SCALAR_AVX2 static ShadingPoint prepare_avx2(const ChiangHair& model, const ShadingContext& ctx);
    HAIRBSDF_SCALAR_AVX2 static BsdfEval eval_avx2(const ChiangHair& model, const ShadingPoint& sp, Vec3 wi);
    HAIRBSDF_SCALAR_AVX2 static BsdfSample sample_avx2(const ChiangHair& model, const ShadingPoint& sp,
                                                       const std::array<double, 3>& u,
                                                       const LongitudinalNumbers* longitudinal);

    // M_p of the lobe pair `pair` (0: R and TT, 1: TRT and TRRT+) at accuracy `cycles` in float-accuracy maths,
    // branch-free per lane: Cycles' series I0(a) exp(add - b) mul, or above the lane's limit its asymptote.
    HAIRBSDF_ALWAYS_INLINE Double2 mp_pair(int pair, double sin_theta_i, double cos_theta_i, Double2 sin_theta_o,
                                           Double2 cos_theta_o) const {
        const Double2 inv_v = pair_inv_v_[pair];
        const Double2 a = cos_theta_i * cos_theta_o * inv_v;
        const Double2 b = sin_theta_i * sin_theta_o * inv_v;
        const Double2 i0 = cycles_bessel_i0_of_quarter_square(0.25 * a * a);  // on both lanes
        const Double2 add = pair_add_[pair];
        const auto asym = a > pair_asym_limit_[pair];
        const Double2 exponent = asym ? a + 1.0 / (16.0 * a) - b + add : add - b;
        const Double2 root = sqrt2(kTwoPi * a);
        const Double2 factor = asym ? 1.0 / root : i0 * pair_mul_[pair];
        return exp_float_accuracy(exponent) * factor;
    }

    // Cycles accuracy takes float-accuracy exp, asin and atan2 unless the double reference is selected.
    bool float_maths() const { return params_.accuracy == Accuracy::Cycles && cycles_float_maths(); }

    ChiangHairParams params_;
    std::array<LongitudinalLobe, 4> mp_;
    std::array<double, 3> logistic_norm_{};
    std::array<double, 3> logistic_cdf_minus_pi_{};  // logistic_cdf(-pi, s), sample_trimmed_logistic's
    std::array<double, 4> exp_minus_2_over_v_{};
    Double2 pair_inv_v_[2]{}, pair_add_[2]{}, pair_mul_[2]{}, pair_asym_limit_[2]{};  // mp_pair's numbers
    std::array<SinCos, 3> rotations_{};  // tilt rotation per lobe (R, TT, TRT)
    bool tinted_ = false;                // a tint other than 1 (MaterialX's per-lobe tints)
};

}  // namespace hairbsdf
