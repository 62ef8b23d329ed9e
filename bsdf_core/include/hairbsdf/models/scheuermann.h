// Scheuermann 2004, "Hair Rendering and Shading" (ATI Research; GDC / SIGGRAPH 2004 sketch),
// the "Shifting specular highlights" and "Specular strand lighting" slides: two Kajiya-Kay
// specular lobes on tangents shifted along the normal, with separate colours and exponents, the
// second one masked by a noise texture. docs/models.md §3.
//
// Per lobe k (slides' ShiftTangent and StrandSpecular):
//   T'_k  = normalize(T + s_k N),  s_k = shift_k + (shift_texture - 1/2)
//   H     = normalize(L + V)
//   spec  = smoothstep(-1, 0, T'.H) sin(T', H)^p_k,   sin(T', H) = sqrt(1 - (T'.H)^2)
//   eval  = c_1 spec_1 / N(p_1) + c_2 noise spec_2 / N(p_2)
// N is the fibre's normal: as in the slides' Kajiya-Kay setting it lies in the plane of T and V,
// N = normalize(V - T (T.V)). The slides' shader has no normalisation; N(p) (ours) is the largest
// directional albedo of the unit lobe over all views, so each colour bounds its lobe's albedo:
//   albedo(V) = int 4 (H.V)+ g(T'.H) d omega_H      (the half-vector Jacobian d omega_L = 4 H.V d omega_H)
// which depends on V only through T'.V; N(p) is its maximum over T'.V (1D quadrature at setup).
//
// Lobes: the primary lobe in the R slot (0), the secondary in the TRT slot (2).
// Sampler (the slides have none): a mixture of the two lobes by luminance of their colours. The
// lobe g(T'.H) lies around the Kajiya-Kay cone T'.L = -T'.V of its shifted tangent, at most
// 2/sqrt(p) wide in T'.L (back scattering; it pinches towards L = -V), so each lobe samples
// T'.L from a normal distribution truncated to [-1, 1] (mean -T'.V e^(-w^2/2), sd
// sqrt((1 - (T'.V)^2) w^2 + w^4/2), w = 2/sqrt(p+1)) and the azimuth about T' uniformly, with
// 10% of uniform directions (defensive). Exact, smooth densities; no half-vector Jacobian, whose
// 1/(H.V) pole at L = -V defeated the chi-square cell integration in a first version.
#pragma once

#include "hairbsdf/closure.h"

namespace hairbsdf {

struct ScheuermannHairParams {
    RGB primary_color{0.5};                  // c_1
    RGB secondary_color{0.5, 0.35, 0.2};     // c_2
    double primary_exponent = 240;           // p_1
    double secondary_exponent = 60;          // p_2
    double primary_shift = 0.0349208;        // shift_1 = tan 2 deg
    double secondary_shift = -0.0699268;     // shift_2 = -tan 4 deg
    double shift_texture = 0.5;              // the specular shift texture's value (0.5 = no shift)
    double noise = 1.0;                      // the specular noise texture's value (mask of lobe 2)
};

class ScheuermannHair {
public:
    // The lobe's unnormalised shape g(t), t = T'.H: smoothstep(-1, 0, t) (1 - t^2)^(p/2).
    static double lobe_shape(double t, double p) {
        const double x = clamp(t + 1.0, 0.0, 1.0);  // smoothstep(-1, 0, t)
        const double s2 = std::max(0.0, 1.0 - t * t);
        return x * x * (3.0 - 2.0 * x) * (p == 0.0 ? 1.0 : std::pow(s2, 0.5 * p));
    }

    // Directional albedo of the unit lobe for a view at cos(T', V) = v_t.
    static double lobe_albedo(double p, double v_t) {
        const double* gx = GaussLegendre<4>::x;
        const double* gw = GaussLegendre<4>::w;
        const double v_p = cos_from_sin(v_t);
        const int panels = int(clamp(16.0 * std::sqrt(p + 1.0), 64.0, 4096.0));
        const double width = 2.0 / panels;
        double sum = 0;
        for (int k = 0; k < panels; ++k) {
            for (int j = 0; j < 4; ++j) {
                const double t = -1.0 + (k + 0.5 + 0.5 * gx[j]) * width;
                // int_0^{2 pi} 4 (a + b cos psi)+ d psi, a = t v_t, b = sqrt(1 - t^2) v_p.
                const double a = t * v_t, b = cos_from_sin(t) * v_p;
                double ring;
                if (a >= b) {
                    ring = kTwoPi * a;
                } else if (a <= -b) {
                    ring = 0.0;
                } else {
                    const double psi0 = std::acos(clamp(-a / b, -1.0, 1.0));
                    ring = 2.0 * (a * psi0 + b * std::sin(psi0));
                }
                sum += 0.5 * width * gw[j] * 4.0 * ring * lobe_shape(t, p);
            }
        }
        return sum;
    }
    // max over v_t of lobe_albedo: a grid, then golden-section refinement.
    static double lobe_norm(double p) {
        double best_v = 0, best = -1;
        for (int k = 0; k <= 40; ++k) {
            const double v = -1.0 + k / 20.0;
            const double a = lobe_albedo(p, v);
            if (a > best) best = a, best_v = v;
        }
        double lo = std::max(-1.0, best_v - 0.05), hi = std::min(1.0, best_v + 0.05);
        const double g = 0.6180339887498949;
        for (int it = 0; it < 40; ++it) {
            const double m1 = hi - g * (hi - lo), m2 = lo + g * (hi - lo);
            if (lobe_albedo(p, m1) > lobe_albedo(p, m2)) hi = m2; else lo = m1;
        }
        return std::max(best, lobe_albedo(p, 0.5 * (lo + hi)));
    }

    explicit ScheuermannHair(const ScheuermannHairParams& params) : params_(params) {
        const double p[2] = {params.primary_exponent, params.secondary_exponent};
        const double shift_offset = params.shift_texture - 0.5;
        shift_ = {params.primary_shift + shift_offset, params.secondary_shift + shift_offset};
        color_ = {params.primary_color, params.noise * params.secondary_color};
        double total = 0;
        for (int k = 0; k < 2; ++k) {
            exponent_[k] = p[k];
            norm_[k] = lobe_norm(p[k]);
            width_[k] = 2.0 / std::sqrt(p[k] + 1.0);
            weight_[k] = std::max(0.0, luminance(color_[k]));
            total += weight_[k];
        }
        if (total > 0)
            for (double& w : weight_) w /= total;
    }
    const ScheuermannHairParams& params() const { return params_; }
    const std::array<double, 2>& norms() const { return norm_; }

    std::array<double, 2> angular_scales() const {
        const double w = 1.0 / std::sqrt(std::max(exponent_[0], exponent_[1]) + 1.0);
        return {std::min(0.5, w), std::min(0.5, w)};
    }

    struct ShadingPoint {
        explicit ShadingPoint(const FibreFrame& f) : frame(f) {}
        FibreFrame frame;
        Vec3 wo;
        std::array<Vec3, 2> tangent{};               // shifted tangents T'_k
        std::array<std::array<Vec3, 2>, 2> basis{};  // two unit vectors perpendicular to T'_k
        std::array<TruncatedNormal, 2> cone{};       // sampling density of T'_k.L
    };
    ShadingPoint prepare(const ShadingContext& ctx) const {
        ShadingPoint sp(FibreFrame(ctx.tangent, ctx.wo));
        sp.wo = ctx.wo;
        const Vec3 n = -1.0 * sp.frame.z;  // normal in the plane of T and V, towards the viewer
        for (int k = 0; k < 2; ++k) {
            const Vec3 t = normalize(sp.frame.x + shift_[k] * n);  // ShiftTangent
            sp.tangent[k] = t;
            // T'_k lies in the (x, n) plane, so y is perpendicular to it.
            sp.basis[k] = {sp.frame.y, cross(t, sp.frame.y)};
            const double v_t = clamp(dot(t, ctx.wo), -1.0, 1.0), w = width_[k];
            sp.cone[k] = TruncatedNormal(-v_t * std::exp(-0.5 * w * w),
                                         std::sqrt((1.0 - v_t * v_t) * w * w + 0.5 * sqr(w * w)), -1.0, 1.0);
        }
        return sp;
    }

    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const {
        BsdfEval out;
        const Vec3 sum = wi + sp.wo;
        const double len = length(sum);
        const int slot[2] = {LobeR, LobeTRT};
        for (int k = 0; k < 2; ++k) {
            if (weight_[k] > 0) {
                out.pdf += weight_[k] * ((1.0 - kUniformShare) * sp.cone[k].pdf(clamp(dot(sp.tangent[k], wi), -1.0, 1.0)) *
                                             kInvTwoPi +
                                         kUniformShare / (2.0 * kTwoPi));
            }
            if (!(len > 1e-9)) continue;  // wi = -wo: no half vector, the value is 0
            const double t = clamp(dot(sp.tangent[k], (1.0 / len) * sum), -1.0, 1.0);
            out.lobes[slot[k]] = (lobe_shape(t, exponent_[k]) / norm_[k]) * color_[k];
        }
        if (!std::isfinite(out.pdf) || !isfinite(out.value())) return {};
        return out;
    }
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const { return eval(prepare(ctx), wi); }
    double pdf(const ShadingContext& ctx, Vec3 wi) const { return pdf(prepare(ctx), wi); }
    double pdf(const ShadingPoint& sp, Vec3 wi) const { return eval(sp, wi).pdf; }

    // u2 picks the lobe and, rescaled, uniform / cone and then T'.L; u0 the azimuth about T'.
    BsdfSample sample(const ShadingPoint& sp, const std::array<double, 3>& u) const {
        BsdfSample out;
        const int k = u[2] < weight_[0] ? 0 : 1;
        if (!(weight_[k] > 0)) return out;
        double v = clamp(k == 0 ? u[2] / weight_[0] : (u[2] - weight_[0]) / weight_[1], 0.0, 1.0);
        double t;
        if (v < kUniformShare) {
            t = clamp(2.0 * v / kUniformShare - 1.0, -1.0, 1.0);
        } else {
            if (!(sp.cone[k].mass() > 0)) return out;
            t = sp.cone[k].sample((v - kUniformShare) / (1.0 - kUniformShare));
        }
        const double psi = kTwoPi * u[0];
        const double r = cos_from_sin(t);
        const Vec3 wi = t * sp.tangent[k] + (r * std::cos(psi)) * sp.basis[k][0] + (r * std::sin(psi)) * sp.basis[k][1];
        const BsdfEval e = eval(sp, wi);
        return sample_from_eval(wi, e, k == 0 ? LobeR : LobeTRT);
    }
    BsdfSample sample(const ShadingContext& ctx, const std::array<double, 3>& u) const {
        return sample(prepare(ctx), u);
    }

private:
    ScheuermannHairParams params_;
    std::array<double, 2> shift_{}, exponent_{}, norm_{}, weight_{}, width_{};
    static constexpr double kUniformShare = 0.1;
    std::array<RGB, 2> color_{};
};

}  // namespace hairbsdf
