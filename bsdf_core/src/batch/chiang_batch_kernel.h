// The Chiang batch kernels on xsimd batches (docs/simd.md), included once per instruction set by
// chiang_batch_<isa>.cpp, each inside its own namespace HAIRBSDF_BATCH_NS (no symbol is shared
// between translation units built with different -m flags). The maths follows ChiangHair
// (models/chiang.h) step by step, in float; where the double path takes exp(a - b + log_norm)
// with a, b and log_norm all near 1/v, the kernel folds them into one term, (cos(theta_i + theta_o)
// - 1) / v, so that float keeps its precision at small v.
#pragma once

#include <xsimd/xsimd.hpp>

#include <algorithm>
#include <cmath>
#include <type_traits>

#include "hairbsdf/batch/chiang_batch.h"

// The kernel's helpers are forced inline: GCC kept M_p and the view terms out of line, and a call
// spills every live vector register, since all of them are caller-saved.
#ifndef HAIRBSDF_BATCH_INLINE
#define HAIRBSDF_BATCH_INLINE inline __attribute__((always_inline))
#endif

namespace hairbsdf {
namespace batch_detail {
namespace HAIRBSDF_BATCH_NS {

template <class Arch>
struct ChiangKernel {
    using B = xsimd::batch<float, Arch>;
    using M = xsimd::batch_bool<float, Arch>;
    static constexpr size_t W = B::size;
    static constexpr float kPiF = 3.14159265358979323846f;
    static constexpr float kTwoPiF = 6.28318530717958647692f;

    const ChiangBatchConstants& c;

    // The parameters' numbers per lane, read through one interface: Uniform broadcasts the hoisted
    // ChiangBatchConstants (the compiler keeps them as memory operands), Row holds the ones mapped
    // and prepared per row (row_params). R, TT and TRT share s on the per-row path (Principled Hair).
    struct Uniform {
        const ChiangBatchConstants& c;
        HAIRBSDF_BATCH_INLINE B sigma_a(int k) const { return B(c.sigma_a[k]); }
        HAIRBSDF_BATCH_INLINE B inv_v(int p) const { return B(c.inv_v[p]); }
        HAIRBSDF_BATCH_INLINE B lnorm(int p) const { return B(c.log_norm_plus_inv_v[p]); }
        HAIRBSDF_BATCH_INLINE bool direct(int p) const { return !c.log_branch[p]; }
        HAIRBSDF_BATCH_INLINE B norm(int p) const { return B(c.norm[p]); }
        HAIRBSDF_BATCH_INLINE B s(int p) const { return B(c.s[p]); }
        HAIRBSDF_BATCH_INLINE B logistic_norm(int p) const { return B(c.logistic_norm[p]); }
        HAIRBSDF_BATCH_INLINE B cdf_minus_pi(int p) const { return B(c.cdf_minus_pi[p]); }
        HAIRBSDF_BATCH_INLINE B v_sample(int p) const { return B(c.v_sample[p]); }
        HAIRBSDF_BATCH_INLINE B e2v(int p) const { return B(c.exp_minus_2_over_v[p]); }
    };
    struct Row {
        B sigma[3], inv[4], ln[4], vs[4], e2[4];
        B scale, lnorm_logistic, cdf;
        HAIRBSDF_BATCH_INLINE B sigma_a(int k) const { return sigma[k]; }
        HAIRBSDF_BATCH_INLINE B inv_v(int p) const { return inv[p]; }
        HAIRBSDF_BATCH_INLINE B lnorm(int p) const { return ln[p]; }
        HAIRBSDF_BATCH_INLINE bool direct(int) const { return false; }  // Cycles' direct form as a log form
        HAIRBSDF_BATCH_INLINE B norm(int) const { return B(0.0f); }
        HAIRBSDF_BATCH_INLINE B s(int) const { return scale; }
        HAIRBSDF_BATCH_INLINE B logistic_norm(int) const { return lnorm_logistic; }
        HAIRBSDF_BATCH_INLINE B cdf_minus_pi(int) const { return cdf; }
        HAIRBSDF_BATCH_INLINE B v_sample(int p) const { return vs[p]; }
        HAIRBSDF_BATCH_INLINE B e2v(int p) const { return e2[p]; }
    };

    // The per-row `prepare`: chiang_params_from_principled's mapping (Random Roughness, the clamps,
    // coat, the roughness polynomials of models/chiang.h, the three parametrizations) and then what
    // chiang_batch_constants computes from the mapped numbers, on every lane. Cycles' direct form of
    // M_p's normalisation (v > 0.1), 1 / (2 v sinh(1/v)), is taken in the log form, where it is the
    // exact normalisation: log_norm + 1/v = -log v - log(1 - e^(-2/v)); with a <= 1/v < 12 M_p then
    // takes I0(a) e^(...) as the direct form does.
    HAIRBSDF_BATCH_INLINE Row row_params(B roughness, B radial, B coat, B random, B melanin,
                                         const B absorption[3]) const {
        const ChiangBatchConstants::Node& n = c.node;
        Row q;
        const B factor = B(1.0f) + B(2.0f) * (random - B(0.5f)) * B(n.random_roughness);
        roughness = roughness * factor;
        radial = radial * factor;
        const B beta_m = clampb(roughness, 0.001f, 1.0f), beta_n = clampb(radial, 0.001f, 1.0f);
        const B beta_coat = clampb((B(1.0f) - clampb(coat, 0.0f, 1.0f)) * beta_m, 0.001f, 1.0f);
        const B v = longitudinal_variance_of(beta_m);
        q.scale = B(float(kSqrtPiOver8)) * azimuthal_scale_raw_of(beta_n);
        if (n.parametrization == int(Parametrization::Absorption)) {
            for (int k = 0; k < 3; ++k) q.sigma[k] = absorption[k];
        } else {
            // Color: (log C / P(radial))^2; Melanin: its pigments plus the tint's Color term.
            const bool color = n.parametrization == int(Parametrization::Color);
            const B inv_p = B(1.0f) / albedo_roughness_scale_of(radial);
            for (int k = 0; k < 3; ++k) {
                const B l = B(color ? n.color_log[k] : n.tint_log[k]) * inv_p;
                q.sigma[k] = l * l;
            }
            if (!color) {
                const B color_factor =
                    B(1.0f) + B(2.0f) * (random - B(0.5f)) * B(std::min(std::max(n.random_color, 0.0f), 1.0f));
                const B quantity = -xsimd::log(xsimd::max(B(1.0f) - melanin * color_factor, B(1e-4f)));
                for (int k = 0; k < 3; ++k) q.sigma[k] = xsimd::fma(quantity, B(n.melanin_absorption[k]), q.sigma[k]);
            }
        }
        const B vs[3] = {longitudinal_variance_of(beta_coat), B(0.25f) * v, B(4.0f) * v};
        constexpr float kCyclesLogOffset = float(0.6931 - 0.69314718055994531);  // 0.6931 + log(1/2)
        for (int p = 0; p < 3; ++p) {
            const B inv = B(1.0f) / vs[p];
            const B log_v = xsimd::log(vs[p]);
            const B exact = -log_v - xsimd::log(-xsimd::expm1(B(-2.0f) * inv));
            q.inv[p] = inv;
            q.ln[p] = c.exact ? exact : xsimd::select(vs[p] <= B(0.1f), B(kCyclesLogOffset) - log_v, exact);
        }
        q.inv[3] = q.inv[2];
        q.ln[3] = q.ln[2];
        q.vs[0] = v;
        for (int p = 1; p < 4; ++p) q.vs[p] = vs[std::min(p, 2)];
        for (int p = 0; p < 3; ++p) q.e2[p] = xsimd::exp(B(-2.0f) / q.vs[p]);
        q.e2[3] = q.e2[2];
        // The trimmed logistic on [-pi, pi]: with e = exp(-pi / s), cdf(-pi) = e / (1 + e) and
        // 1 / (cdf(pi) - cdf(-pi)) = (1 + e) / (1 - e).
        const B e = xsimd::exp(B(-kPiF) / q.scale);
        q.cdf = e / (B(1.0f) + e);
        q.lnorm_logistic = (B(1.0f) + e) / (B(1.0f) - e);
        return q;
    }

    HAIRBSDF_BATCH_INLINE static B clampb(B x, float lo, float hi) { return xsimd::min(xsimd::max(x, B(lo)), B(hi)); }
    HAIRBSDF_BATCH_INLINE static B cos_from_sin(B s) { return xsimd::sqrt(xsimd::max(B(1.0f) - s * s, B(0.0f))); }
    HAIRBSDF_BATCH_INLINE static M finite(B x) { return xsimd::isfinite(x); }

    struct View {
        B sin_o, cos_o, gamma_o, gamma_t;
        B att[4][3];
        B w[4];
        B tsin[3], tcos[3];
        B yy, yz, zy, zz;  // the frame's y and z (x is the tangent +x)
        M valid;
    };

    // Fibre frame and view terms (ChiangHair::view_terms) for unit wo and h in [-1, 1].
    template <class Q>
    HAIRBSDF_BATCH_INLINE View view(B wox, B woy, B woz, B h, const Q& q) const {
        View v;
        const B len2 = woy * woy + woz * woz;
        const M degenerate = len2 <= B(1e-24f);
        const B inv_len = B(1.0f) / xsimd::sqrt(xsimd::select(degenerate, B(1.0f), len2));
        v.yy = xsimd::select(degenerate, B(0.0f), -woz * inv_len);
        v.yz = xsimd::select(degenerate, B(1.0f), woy * inv_len);
        v.zy = xsimd::select(degenerate, B(-1.0f), -woy * inv_len);
        v.zz = xsimd::select(degenerate, B(0.0f), -woz * inv_len);

        // Near the fibre axis float cannot take cos from sin (sin rounds to 1): cos theta_o is the
        // length of wo's part across the fibre, and eta^2 - sin^2 is written as eta^2 - 1 + cos^2.
        const B eta(c.eta);
        v.sin_o = clampb(wox, -1.0f, 1.0f);
        v.cos_o = xsimd::min(xsimd::sqrt(len2), B(1.0f));
        const B eta2_minus_sin2 = (eta * eta - B(1.0f)) + v.cos_o * v.cos_o;
        const B cos_t = xsimd::sqrt(xsimd::max(eta2_minus_sin2, B(0.0f))) / eta;
        const B cos_gamma_o = cos_from_sin(h);
        v.gamma_o = xsimd::asin(clampb(h, -1.0f, 1.0f));
        const B sin_gamma_t = h * v.cos_o / xsimd::sqrt(eta2_minus_sin2);
        const M gamma_t_ok = !xsimd::isnan(sin_gamma_t);
        const B cos_gamma_t = cos_from_sin(sin_gamma_t);
        v.gamma_t = xsimd::asin(clampb(xsimd::select(gamma_t_ok, sin_gamma_t, B(0.0f)), -1.0f, 1.0f));

        const B path = B(-2.0f) * cos_gamma_t / cos_t;
        B T[3];
        for (int k = 0; k < 3; ++k) T[k] = xsimd::exp(path * q.sigma_a(k));
        const B f = fresnel(v.cos_o * cos_gamma_o, eta);
        const B one_minus_f = B(1.0f) - f;
        B total(0.0f);
        for (int k = 0; k < 3; ++k) {
            const B a1 = (one_minus_f * one_minus_f) * T[k];
            const B a2 = a1 * T[k] * f;
            const B tf = f * T[k];
            const B ratio = xsimd::select(tf == B(1.0f), B(0.0f), tf / (B(1.0f) - tf));
            v.att[0][k] = f;
            v.att[1][k] = a1;
            v.att[2][k] = a2;
            v.att[3][k] = a2 * ratio;
        }
        for (int p = 0; p < 4; ++p) {
            for (int k = 0; k < 3; ++k) v.att[p][k] = v.att[p][k] * B(c.tint[p][k]);
            v.w[p] = B(float(kLuminanceWeights[0])) * v.att[p][0] + B(float(kLuminanceWeights[1])) * v.att[p][1] +
                     B(float(kLuminanceWeights[2])) * v.att[p][2];
            total = total + v.w[p];
        }
        v.valid = (total > B(0.0f)) & finite(total) & gamma_t_ok;
        const B inv_total = B(1.0f) / total;
        for (int p = 0; p < 4; ++p) v.w[p] = v.w[p] * inv_total;
        for (int p = 0; p < 3; ++p) {
            const B sa(c.rot_sin[p]), ca(c.rot_cos[p]);
            v.tsin[p] = v.sin_o * ca + v.cos_o * sa;
            v.tcos[p] = xsimd::abs(v.cos_o * ca - v.sin_o * sa);
        }
        return v;
    }

    HAIRBSDF_BATCH_INLINE static B fresnel(B cos_i, B eta) {
        const B cc = xsimd::abs(cos_i);
        const B g2 = eta * eta - B(1.0f) + cc * cc;
        const M tir = !(g2 > B(0.0f));
        const B g = xsimd::sqrt(xsimd::max(g2, B(0.0f)));
        const B a = (g - cc) / (g + cc);
        const B b = (cc * (g + cc) - B(1.0f)) / (cc * (g - cc) + B(1.0f));
        return xsimd::select(tir, B(1.0f), B(0.5f) * a * a * (B(1.0f) + b * b));
    }

    // Cycles' ten-term I0 series (cycles_bessel_i0) in Horner form.
    HAIRBSDF_BATCH_INLINE static B cycles_i0(B x) {
        const B q = B(0.25f) * x * x;
        B sum(float(1.0 / 131681894400.0));
        sum = xsimd::fma(sum, q, B(float(1.0 / 1625702400.0)));
        sum = xsimd::fma(sum, q, B(float(1.0 / 25401600.0)));
        sum = xsimd::fma(sum, q, B(float(1.0 / 518400.0)));
        sum = xsimd::fma(sum, q, B(float(1.0 / 14400.0)));
        sum = xsimd::fma(sum, q, B(float(1.0 / 576.0)));
        sum = xsimd::fma(sum, q, B(float(1.0 / 36.0)));
        sum = xsimd::fma(sum, q, B(0.25f));
        sum = xsimd::fma(sum, q, B(1.0f));
        return xsimd::fma(sum, q, B(1.0f));
    }
    // I0 to float precision for the `exact` mode: Abramowitz & Stegun 9.8.1 below 3.75 (relative
    // error < 2e-7), and 9.8.2's sqrt(x) e^-x I0(x) polynomial in 3.75 / x above (< 5e-7).
    HAIRBSDF_BATCH_INLINE static B exact_i0_small(B x) {
        const B t = x * B(1.0f / 3.75f);
        const B t2 = t * t;
        B s(0.0045813f);
        s = xsimd::fma(s, t2, B(0.0360768f));
        s = xsimd::fma(s, t2, B(0.2659732f));
        s = xsimd::fma(s, t2, B(1.2067492f));
        s = xsimd::fma(s, t2, B(3.0899424f));
        s = xsimd::fma(s, t2, B(3.5156229f));
        return xsimd::fma(s, t2, B(1.0f));
    }
    HAIRBSDF_BATCH_INLINE static B exact_i0_scaled_large(B x) {  // sqrt(x) e^-x I0(x)
        const B r = B(3.75f) / x;
        B s(0.00392377f);
        s = xsimd::fma(s, r, B(-0.01647633f));
        s = xsimd::fma(s, r, B(0.02635537f));
        s = xsimd::fma(s, r, B(-0.02057706f));
        s = xsimd::fma(s, r, B(0.00916281f));
        s = xsimd::fma(s, r, B(-0.00157565f));
        s = xsimd::fma(s, r, B(0.00225319f));
        s = xsimd::fma(s, r, B(0.01328592f));
        return xsimd::fma(s, r, B(0.39894228f));
    }

    // M_p (LongitudinalLobe::eval) for lobe p.
    template <class Q>
    HAIRBSDF_BATCH_INLINE B mp(int p, B sin_i, B cos_i, B sin_o, B cos_o, const Q& q) const {
        const B inv_v = q.inv_v(p);
        const B cprod = cos_i * cos_o, sprod = sin_i * sin_o;
        const B a = cprod * inv_v;
        const B lnorm = q.lnorm(p);
        // a - b + log_norm = lnorm - (1 - cos(theta_i + theta_o)) / v and log_norm - b = that - a,
        // without cancelling terms of size 1/v: near the lobe's peak 1 - cos is taken from the sine
        // of the sum, sin^2 / (1 + cos), which float keeps to full relative precision.
        const B cos_sum = cprod - sprod;
        const B sin_sum = sin_i * cos_o + cos_i * sin_o;
        const B one_minus_cos = xsimd::select(cos_sum > B(0.0f), sin_sum * sin_sum / (B(1.0f) + cos_sum),
                                              B(1.0f) - cos_sum);
        const B far = lnorm - one_minus_cos * inv_v;
        const B near = far - a;
        if (c.exact) {
            const M small = a <= B(3.75f);
            const B x_large = xsimd::select(small, B(3.75f), a);
            const B large = exact_i0_scaled_large(x_large) / xsimd::sqrt(x_large) * xsimd::exp(far);
            return xsimd::select(small, exact_i0_small(a) * xsimd::exp(near), large);
        }
        if (q.direct(p)) return xsimd::exp(-sprod * inv_v) * cycles_i0(a) * q.norm(p);
        const M small = a <= B(12.0f);
        const B x_large = xsimd::select(small, B(12.0f), a);
        const B large = xsimd::exp(far + B(1.0f / 16.0f) / x_large) / xsimd::sqrt(B(kTwoPiF) * x_large);
        return xsimd::select(small, cycles_i0(xsimd::select(small, a, B(0.0f))) * xsimd::exp(near), large);
    }

    HAIRBSDF_BATCH_INLINE static B wrap(B x) { return x - B(kTwoPiF) * xsimd::floor((x + B(kPiF)) * B(1.0f / kTwoPiF)); }
    HAIRBSDF_BATCH_INLINE static B center(int p, const View& v) {
        return B(2.0f * p) * v.gamma_t - B(2.0f) * v.gamma_o + B(p * kPiF);
    }

    // ChiangHair::eval_local: the value (without the closure weight) and the pdf; 0 where invalid.
    template <class Q>
    HAIRBSDF_BATCH_INLINE void eval_local(const View& v, B sin_i, B cos_i, B phi, B value[3], B& pdf, const Q& q) const {
        for (int k = 0; k < 3; ++k) value[k] = B(0.0f);
        pdf = B(0.0f);
        for (int p = 0; p < 3; ++p) {
            B m;
            if (c.blender34) {
                const B sa(c.rot_sin[p]), ca(c.rot_cos[p]);
                m = mp(p, sin_i * ca + cos_i * sa, xsimd::abs(cos_i * ca - sin_i * sa), v.sin_o, v.cos_o, q);
            } else {
                m = mp(p, sin_i, cos_i, v.tsin[p], v.tcos[p], q);
            }
            const B s = q.s(p);
            const B x = wrap(phi - center(p, v));
            const B e = xsimd::exp(-xsimd::abs(x) / s);
            const B one_plus_e = B(1.0f) + e;
            const B np = e / (s * one_plus_e * one_plus_e) * q.logistic_norm(p);
            const B mn = m * np;
            for (int k = 0; k < 3; ++k) value[k] = xsimd::fma(mn, v.att[p][k], value[k]);
            pdf = xsimd::fma(v.w[p], mn, pdf);
        }
        const B m3 = mp(3, sin_i, cos_i, v.sin_o, v.cos_o, q) * B(float(kInvTwoPi));
        for (int k = 0; k < 3; ++k) value[k] = xsimd::fma(m3, v.att[3][k], value[k]);
        pdf = xsimd::fma(v.w[3], m3, pdf);
        const M ok = v.valid & finite(pdf) & finite(value[0]) & finite(value[1]) & finite(value[2]);
        for (int k = 0; k < 3; ++k) value[k] = xsimd::select(ok, value[k], B(0.0f));
        pdf = xsimd::select(ok, pdf, B(0.0f));
    }

    // Picks a per-lobe constant by the lane's lobe index p (0..3).
    HAIRBSDF_BATCH_INLINE static B pick(B p, float a0, float a1, float a2, float a3) {
        return xsimd::select(p == B(0.0f), B(a0), xsimd::select(p == B(1.0f), B(a1), xsimd::select(p == B(2.0f), B(a2), B(a3))));
    }
    HAIRBSDF_BATCH_INLINE static B pick(B p, B a0, B a1, B a2, B a3) {
        return xsimd::select(p == B(0.0f), a0, xsimd::select(p == B(1.0f), a1, xsimd::select(p == B(2.0f), a2, a3)));
    }
};

// Unit vector and the validity of one row's direction (finite, non-zero).
template <class B>
HAIRBSDF_BATCH_INLINE auto normalise(B& x, B& y, B& z) {
    const B len2 = x * x + y * y + z * z;
    const auto ok = xsimd::isfinite(len2) & (len2 > B(0.0f));
    const B inv = B(1.0f) / xsimd::sqrt(xsimd::select(ok, len2, B(1.0f)));
    x = x * inv;
    y = y * inv;
    z = z * inv;
    return ok;
}

constexpr size_t kBlock = 256;  // rows per SoA block

template <class In>
inline float get(const void* p, size_t i) {
    return float(static_cast<const In*>(p)[i]);
}
template <class Out>
inline void put(void* p, size_t i, float v) {
    static_cast<Out*>(p)[i] = Out(v);
}

// PerRow: the rows carry Principled Hair inputs (ChiangBatchRowInputs), mapped and prepared per
// row; else the hoisted constants serve every row.
template <class Arch, class In, class Out, bool PerRow>
size_t run_typed(const ChiangBatchConstants& c, ChiangBatchOp op, const ChiangBatchRows& rows,
                 const ChiangBatchOutput& out, size_t begin, size_t end) {
    using K = ChiangKernel<Arch>;
    using B = typename K::B;
    using M = typename K::M;
    constexpr size_t W = K::W;
    const K kernel{c};
    const bool sample = op == ChiangBatchOp::Sample;
    // wo xyz, wi xyz or u 012, h; per row: roughness, radial roughness, coat, random, melanin,
    // absorption rgb.
    alignas(64) float a[PerRow ? 15 : 7][kBlock];
    constexpr int kInputs = PerRow ? 15 : 7;
    const ChiangBatchRowInputs& in = rows.inputs;
    const void* const scalar_inputs[5] = {in.roughness, in.radial_roughness, in.coat, in.random, in.melanin};
    alignas(64) float r[8][kBlock];   // value rgb / weight rgb, pdf, wi xyz, lobe
    size_t bad_rows = 0;
    for (size_t b0 = begin; b0 < end; b0 += kBlock) {
        const size_t n = std::min(kBlock, end - b0);
        const void* second = sample ? rows.u : rows.wi;
        for (size_t i = 0; i < n; ++i) {
            const size_t row = b0 + i;
            for (int k = 0; k < 3; ++k) {
                a[k][i] = get<In>(rows.wo, 3 * row + k);
                a[3 + k][i] = get<In>(second, 3 * row + k);
            }
            a[6][i] = get<In>(rows.h, row);
        }
        if constexpr (PerRow) {
            for (int slot = 0; slot < 5; ++slot)
                if (scalar_inputs[slot])
                    for (size_t i = 0; i < n; ++i) a[7 + slot][i] = get<In>(scalar_inputs[slot], b0 + i);
            if (in.absorption)
                for (size_t i = 0; i < n; ++i)
                    for (int k = 0; k < 3; ++k) a[12 + k][i] = get<In>(in.absorption, 3 * (b0 + i) + k);
        }
        const size_t padded = (n + W - 1) / W * W;
        for (size_t i = n; i < padded; ++i) {
            for (int k = 0; k < kInputs; ++k) a[k][i] = 0.5f;
        }
        for (size_t j = 0; j < padded; j += W) {
            B wox = B::load_aligned(a[0] + j), woy = B::load_aligned(a[1] + j), woz = B::load_aligned(a[2] + j);
            B s0 = B::load_aligned(a[3] + j), s1 = B::load_aligned(a[4] + j), s2 = B::load_aligned(a[5] + j);
            B h = B::load_aligned(a[6] + j);
            M ok = normalise(wox, woy, woz) & xsimd::isfinite(h) & (xsimd::abs(h) <= B(1.0f + 1e-6f));
            h = K::clampb(h, -1.0f, 1.0f);
            if (sample) {
                ok = ok & (s0 >= B(0.0f)) & (s0 <= B(1.0f)) & (s1 >= B(0.0f)) & (s1 <= B(1.0f)) &
                     (s2 >= B(0.0f)) & (s2 <= B(1.0f));
            } else {
                ok = ok & normalise(s0, s1, s2);
            }
            // Invalid rows compute on a harmless stand-in and are zeroed below.
            wox = xsimd::select(ok, wox, B(0.0f));
            woy = xsimd::select(ok, woy, B(0.0f));
            woz = xsimd::select(ok, woz, B(1.0f));
            h = xsimd::select(ok, h, B(0.0f));
            s0 = xsimd::select(ok, s0, B(0.5f));
            s1 = xsimd::select(ok, s1, B(0.5f));
            s2 = xsimd::select(ok, s2, B(0.5f));
            const size_t lanes = std::min(W, n - std::min(n, j));
            if (!xsimd::all(ok))
                for (size_t l = 0; l < lanes; ++l) bad_rows += ok.get(l) ? 0 : 1;

            using Q = std::conditional_t<PerRow, typename K::Row, typename K::Uniform>;
            const Q q = [&]() -> Q {
                if constexpr (PerRow) {
                    const ChiangBatchConstants::Node& node = c.node;
                    auto input = [&](int slot, float uniform) {
                        return scalar_inputs[slot] ? B::load_aligned(a[7 + slot] + j) : B(uniform);
                    };
                    B absorption[3];
                    for (int k = 0; k < 3; ++k)
                        absorption[k] = in.absorption ? B::load_aligned(a[12 + k] + j) : B(node.absorption[k]);
                    return kernel.row_params(input(0, node.roughness), input(1, node.radial_roughness),
                                             input(2, node.coat), input(3, node.random), input(4, node.melanin),
                                             absorption);
                } else {
                    return Q{c};
                }
            }();
            typename K::View v = kernel.view(wox, woy, woz, h, q);
            v.valid = v.valid & ok;
            if (c.zero) v.valid = M(false);
            B value[3], pdf;
            if (!sample) {
                const B sin_i = K::clampb(s0, -1.0f, 1.0f);
                const B cos_i = xsimd::min(xsimd::sqrt(s1 * s1 + s2 * s2), B(1.0f));  // as cos_o in view()
                const B dy = s1 * v.yy + s2 * v.yz, dz = s1 * v.zy + s2 * v.zz;
                // atan2(0, 0) is 0 as in libm (xsimd's gives NaN): wi along the fibre.
                const M on_axis = (dy == B(0.0f)) & (dz == B(0.0f));
                const B phi = xsimd::atan2(dz, xsimd::select(on_axis, B(1.0f), dy)) + B(0.5f * K::kPiF);
                kernel.eval_local(v, sin_i, cos_i, phi, value, pdf, q);
                for (int k = 0; k < 3; ++k) (value[k] * B(c.weight[k])).store_aligned(r[k] + j);
                pdf.store_aligned(r[3] + j);
                continue;
            }
            // Sample: the lobe from u2 (sequential, as ChiangHair::sample), then its direction.
            B u_lobe = s2, p(3.0f);
            M chosen(false);
            for (int k = 0; k < 3; ++k) {
                const M not_chosen = !chosen;
                const M here = not_chosen & (u_lobe < v.w[k]);
                p = xsimd::select(here, B(float(k)), p);
                chosen = chosen | here;
                u_lobe = xsimd::select(chosen, u_lobe, u_lobe - v.w[k]);
            }
            const B wp = K::pick(p, v.w[0], v.w[1], v.w[2], v.w[3]);
            u_lobe = xsimd::select(wp > B(0.0f), u_lobe / xsimd::select(wp > B(0.0f), wp, B(1.0f)), B(0.5f));
            const M lobe3 = p == B(3.0f);
            B o_sin = v.sin_o, o_cos = v.cos_o;
            if (!c.blender34) {
                o_sin = xsimd::select(lobe3, v.sin_o, K::pick(p, v.tsin[0], v.tsin[1], v.tsin[2], v.sin_o));
                o_cos = xsimd::select(lobe3, v.cos_o, K::pick(p, v.tcos[0], v.tcos[1], v.tcos[2], v.cos_o));
            }
            const B var = K::pick(p, q.v_sample(0), q.v_sample(1), q.v_sample(2), q.v_sample(3));
            const B e2v = K::pick(p, q.e2v(0), q.e2v(1), q.e2v(2), q.e2v(3));
            // fac = 1 - g with g >= 0; sqrt(1 - fac^2) as sqrt(g (2 - g)), exact where fac is near 1.
            const B ut = K::clampb(u_lobe, 1e-5f, 1.0f);
            const B g = -var * xsimd::log(ut + (B(1.0f) - ut) * e2v);
            const B fac = B(1.0f) - g;
            const B sin_fac = xsimd::sqrt(xsimd::max(g * (B(2.0f) - g), B(0.0f)));
            B sin_i = K::clampb(-fac * o_sin + sin_fac * xsimd::cos(B(K::kTwoPiF) * s1) * o_cos, -1.0f, 1.0f);
            B cos_i = K::cos_from_sin(sin_i);
            // Azimuth: the trimmed logistic about the lobe's centre, uniform for TRRT+.
            const B s = K::pick(p, q.s(0), q.s(1), q.s(2), B(1.0f));
            const B cdf = K::pick(p, q.cdf_minus_pi(0), q.cdf_minus_pi(1), q.cdf_minus_pi(2), B(0.0f));
            const B centre = K::pick(p, K::center(0, v), K::center(1, v), K::center(2, v), B(0.0f));
            // The inverse CDF -s log(1 / y - 1), y = u (1 - 2 cdf) + cdf, with 1 - y written out so
            // that u near 1 keeps its precision.
            const B y = s0 * (B(1.0f) - B(2.0f) * cdf) + cdf;
            const B one_minus_y = (B(1.0f) - s0) * (B(1.0f) - cdf) + s0 * cdf;
            const B x = K::clampb(-s * xsimd::log(one_minus_y / y), -K::kPiF, K::kPiF);
            B phi = xsimd::select(lobe3, B(K::kTwoPiF) * s0, centre + x);
            if (c.blender34) {
                const B rs = K::pick(p, c.rot_sin[0], c.rot_sin[1], c.rot_sin[2], 0.0f);
                const B rc = K::pick(p, c.rot_cos[0], c.rot_cos[1], c.rot_cos[2], 1.0f);
                const B s_old = sin_i, c_old = cos_i;
                sin_i = K::clampb(s_old * rc - c_old * rs, -1.0f, 1.0f);
                const B c_rot = c_old * rc + s_old * rs;
                cos_i = xsimd::abs(c_rot);
                phi = phi + xsimd::select(c_rot < B(0.0f), B(K::kPiF), B(0.0f));
            }
            const auto sc = xsimd::sincos(phi);
            const B wi_x = sin_i;
            const B wi_y = cos_i * (sc.first * v.yy - sc.second * v.zy);
            const B wi_z = cos_i * (sc.first * v.yz - sc.second * v.zz);
            kernel.eval_local(v, sin_i, cos_i, phi, value, pdf, q);
            const B inv_pdf = B(1.0f) / xsimd::select(pdf > B(0.0f), pdf, B(1.0f));
            M good = v.valid & (pdf > B(0.0f)) & K::finite(pdf) & K::finite(wi_y) & K::finite(wi_z);
            B weight[3];
            for (int k = 0; k < 3; ++k) {
                weight[k] = value[k] * inv_pdf;
                good = good & K::finite(weight[k]);
            }
            for (int k = 0; k < 3; ++k)
                xsimd::select(good, weight[k] * B(c.weight[k]), B(0.0f)).store_aligned(r[k] + j);
            xsimd::select(good, pdf, B(0.0f)).store_aligned(r[3] + j);
            xsimd::select(good, wi_x, B(0.0f)).store_aligned(r[4] + j);
            xsimd::select(good, wi_y, B(0.0f)).store_aligned(r[5] + j);
            xsimd::select(good, wi_z, B(0.0f)).store_aligned(r[6] + j);
            xsimd::select(good, p, B(-1.0f)).store_aligned(r[7] + j);
        }
        if (op == ChiangBatchOp::Eval) {
            for (size_t i = 0; i < n; ++i)
                for (int k = 0; k < 3; ++k) put<Out>(out.value, 3 * (b0 + i) + k, r[k][i]);
            if (out.pdf)
                for (size_t i = 0; i < n; ++i) put<Out>(out.pdf, b0 + i, r[3][i]);
        } else if (op == ChiangBatchOp::Pdf) {
            for (size_t i = 0; i < n; ++i) put<Out>(out.pdf, b0 + i, r[3][i]);
        } else {
            for (size_t i = 0; i < n; ++i) {
                const size_t row = b0 + i;
                for (int k = 0; k < 3; ++k) {
                    put<Out>(out.weight, 3 * row + k, r[k][i]);
                    put<Out>(out.wi, 3 * row + k, r[4 + k][i]);
                }
                put<Out>(out.pdf, row, r[3][i]);
                out.lobe[row] = int32_t(r[7][i]);
            }
        }
    }
    return bad_rows;
}

template <class Arch, bool PerRow>
size_t run_rows(const ChiangBatchConstants& c, ChiangBatchOp op, const ChiangBatchRows& rows,
                const ChiangBatchOutput& out, size_t begin, size_t end) {
    if (rows.f64) {
        return out.f64 ? run_typed<Arch, double, double, PerRow>(c, op, rows, out, begin, end)
                       : run_typed<Arch, double, float, PerRow>(c, op, rows, out, begin, end);
    }
    return out.f64 ? run_typed<Arch, float, double, PerRow>(c, op, rows, out, begin, end)
                   : run_typed<Arch, float, float, PerRow>(c, op, rows, out, begin, end);
}

template <class Arch>
size_t run(const ChiangBatchConstants& c, ChiangBatchOp op, const ChiangBatchRows& rows,
           const ChiangBatchOutput& out, size_t begin, size_t end) {
    return rows.inputs.any() ? run_rows<Arch, true>(c, op, rows, out, begin, end)
                             : run_rows<Arch, false>(c, op, rows, out, begin, end);
}

}  // namespace HAIRBSDF_BATCH_NS
}  // namespace batch_detail
}  // namespace hairbsdf
