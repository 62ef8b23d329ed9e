// d'Eon, Francois, Hill, Letteri and Aubry 2011, "An Energy-Conserving Hair Reflectance Model"
// (EGSR 2011), with the importance sampling of d'Eon, Marschner and Hanika 2013 (restated in
// seed 002's Weta section and seed 004). docs/models.md §5.
//   M_p(v, theta_i, theta_o) = csch(1/v) / (2v) e^(-sin theta_i sin theta_o / v) I0(cos theta_i cos theta_o / v)
//        (the energy-conserving longitudinal term, v = beta_p^2; per unit solid angle with d omega =
//        cos theta d theta d phi it integrates to 1), the cone tilted by the cuticle angle per lobe;
//   N_p(phi) = 1/2 int_{-1}^{1} A_p(h) D(beta_p; phi - Phi(p, h)) dh     (the Gaussian detector)
//        Phi(p, h) = 2 p gamma_t - 2 gamma_i + p pi, gamma_i = asin h, gamma_t = asin(h / eta'),
//        D a Gaussian of sd beta_p wrapped on the circle;
//   A_0 = f, A_1 = (1 - f)^2 T, A_2 = (1 - f)^2 f T^2, f = F(cos theta_o cos gamma_i), T = exp(-2 sigma_a cos gamma_t / cos theta_t)
//   plus the residual TRRT+ lobe (A_2 f T / (1 - f T), M with v_TRT, uniform in phi), so that the
//   model conserves energy when sigma_a = 0.
// The h integral is composite Gauss-Legendre in gamma_i (dh = cos gamma_i d gamma_i). N_p and the
// sampling density (the same integral with A = 1) are tabulated over (|sin theta_o|, phi) at
// construction (rows uniform in |theta_o|) and interpolated bilinearly; `tabulated = false` evaluates the quadrature directly.
// Sampler (2013): lobe by mean attenuation, theta_i exactly from M_p, h uniform and phi = Phi(p, h)
// + a wrapped-Gaussian offset (u0 split into two numbers); its pdf is the A = 1 integral.
#pragma once

#include <memory>
#include <vector>

#include "hairbsdf/closure.h"
#include "hairbsdf/math_hair_defaults.h"

namespace hairbsdf {

struct DeonHairParams {
    RGB sigma_a = blender_hair::kAbsorptionCoefficient;  // per unit diameter, this library's unit (docs/conventions.md)
    double eta = blender_hair::kIor;
    double roughness = 0.1309;   // beta_R (radians): M variance beta^2 and detector sd; TT x1/2, TRT x2
    double tilt = blender_hair::kOffset;  // cuticle tilt alpha (Blender's 2 degrees): R by 2 alpha, TT -alpha, TRT -4 alpha
    bool tabulated = true;
};

class DeonHair {
public:
    struct SinCosPair {
        double sin, cos;
    };
    static constexpr int kPanels = 64;       // composite 4-point Gauss-Legendre panels in gamma_i
    static constexpr int kRows = 161;        // |theta_o| in [0, pi/2], uniform in the angle
    static constexpr int kColumns = 1024;    // phi in [-pi, pi)
    static constexpr int kWrap = 3;          // wrapped Gaussian: images k = -3..3

    explicit DeonHair(const DeonHairParams& p) : params_(p) {
        const double b = std::max(p.roughness, 2e-3);
        beta_ = {b, 0.5 * b, 2.0 * b};
        for (int k = 0; k < 4; ++k) {
            const double v = sqr(beta_[size_t(std::min(k, 2))]);
            v_[size_t(k)] = v;
            log_norm_[size_t(k)] = -std::log(v) - 1.0 / v - std::log1p(-std::exp(-2.0 / v));  // log csch(1/v)/(2v)
            exp_m2v_[size_t(k)] = std::exp(-2.0 / v);
        }
        const double t = p.tilt;
        rot_ = {SinCosPair{std::sin(2 * t), std::cos(2 * t)}, SinCosPair{std::sin(-t), std::cos(-t)},
                SinCosPair{std::sin(-4 * t), std::cos(-4 * t)}};
        if (p.tabulated) build_tables();
    }
    const DeonHairParams& params() const { return params_; }
    std::array<double, 2> angular_scales() const { return {beta_[1], beta_[1]}; }

    // M_p per unit solid angle (exact I0).
    double longitudinal(int k, double sin_i, double cos_i, double sin_o, double cos_o) const {
        const double a = cos_i * cos_o / v_[size_t(k)], bb = sin_i * sin_o / v_[size_t(k)];
        if (a < kBesselSeriesLimit) return bessel_i0_series(a) * std::exp(log_norm_[size_t(k)] - bb);
        return std::exp(log_bessel_i0_asymptotic(a) - bb + log_norm_[size_t(k)]);
    }
    static double wrapped_gaussian(double beta, double x) {
        x = wrap_angle(x);
        const int images = beta < 0.5 ? 0 : kWrap;  // narrower: the other images are below 1e-8
        double s = 0;
        for (int k = -images; k <= images; ++k) s += std::exp(-0.5 * sqr((x + kTwoPi * k) / beta));
        return s / (beta * 2.5066282746310002);
    }

    // Direct quadrature: per-lobe N_p (RGB, with A_p), the sampling density (A = 1) and the mean
    // attenuations <A_p> = 1/2 int A_p dh (p = 0..3), for |sin theta_o| = s and azimuth phi.
    struct Azimuthal {
        std::array<RGB, 3> n{};
        std::array<double, 3> density{};
        std::array<RGB, 4> mean_a{};
    };
    Azimuthal azimuthal_direct(double s, double phi, bool with_phi = true) const {
        Azimuthal out;
        for_each_node(s, [&](double weight, const std::array<RGB, 4>& a, const std::array<double, 3>& Phi) {
            for (int p = 0; p < 4; ++p) out.mean_a[size_t(p)] += (0.5 * weight) * a[size_t(p)];
            if (!with_phi) return;
            for (int p = 0; p < 3; ++p) {
                const double d = wrapped_gaussian(beta_[size_t(p)], phi - Phi[size_t(p)]);
                out.n[size_t(p)] += (0.5 * weight * d) * a[size_t(p)];
                out.density[size_t(p)] += 0.5 * weight * d;
            }
        });
        return out;
    }

    struct ShadingPoint {
        explicit ShadingPoint(const FibreFrame& f) : frame(f) {}
        FibreFrame frame;
        double sin_theta_o = 0, cos_theta_o = 1, abs_sin = 0;
        std::array<SinCosPair, 3> tilted{};
        std::array<RGB, 4> mean_a{};
        std::array<double, 4> lobe_weight{};
        double eta_prime = 1.55;
        bool valid = false;
    };
    ShadingPoint prepare(const ShadingContext& ctx) const {
        ShadingPoint sp(FibreFrame(ctx.tangent, ctx.wo));
        sp.sin_theta_o = sp.frame.sin_theta(ctx.wo);
        sp.cos_theta_o = cos_from_sin(sp.sin_theta_o);
        sp.abs_sin = std::fabs(sp.sin_theta_o);
        for (int p = 0; p < 3; ++p) {
            const SinCosPair& r = rot_[size_t(p)];
            sp.tilted[size_t(p)] = {sp.sin_theta_o * r.cos + sp.cos_theta_o * r.sin,
                                    std::fabs(sp.cos_theta_o * r.cos - sp.sin_theta_o * r.sin)};
        }
        sp.eta_prime = eta_prime(sp.abs_sin);
        sp.mean_a = params_.tabulated ? row_mean(sp.abs_sin) : azimuthal_direct(sp.abs_sin, 0.0, false).mean_a;
        double total = 0;
        for (int p = 0; p < 4; ++p) total += (sp.lobe_weight[size_t(p)] = std::max(0.0, luminance(sp.mean_a[size_t(p)])));
        if (!(total > 0) || !std::isfinite(total)) return sp;
        for (double& w : sp.lobe_weight) w /= total;
        sp.valid = true;
        return sp;
    }

    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const {
        BsdfEval out;
        if (!sp.valid) return out;
        const double sin_i = sp.frame.sin_theta(wi), cos_i = cos_from_sin(sin_i);
        const double phi = sp.frame.phi(wi) + 0.5 * kPi;
        Azimuthal az;
        if (params_.tabulated) {
            lookup(sp.abs_sin, phi, az);
        } else {
            az = azimuthal_direct(sp.abs_sin, phi);
        }
        for (int p = 0; p < 3; ++p) {
            const double m = longitudinal(p, sin_i, cos_i, sp.tilted[size_t(p)].sin, sp.tilted[size_t(p)].cos);
            out.lobes[size_t(p)] = m * az.n[size_t(p)];
            out.pdf += sp.lobe_weight[size_t(p)] * m * az.density[size_t(p)];
        }
        const double m3 = longitudinal(3, sin_i, cos_i, sp.sin_theta_o, sp.cos_theta_o) * kInvTwoPi;
        out.lobes[3] = m3 * sp.mean_a[3];
        out.pdf += sp.lobe_weight[3] * m3;
        if (!std::isfinite(out.pdf) || !isfinite(out.value())) return {};
        return out;
    }
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const { return eval(prepare(ctx), wi); }
    double pdf(const ShadingPoint& sp, Vec3 wi) const { return eval(sp, wi).pdf; }
    double pdf(const ShadingContext& ctx, Vec3 wi) const { return pdf(prepare(ctx), wi); }

    // u2: lobe, rescaled for theta_i (d'Eon 2013); u1: the cone azimuth of the theta sampler;
    // u0: split into h (high bits) and the detector offset (low bits).
    BsdfSample sample(const ShadingPoint& sp, const std::array<double, 3>& u) const {
        BsdfSample out;
        if (!sp.valid) return out;
        int p = 0;
        double v = u[2];
        for (; p < 3; ++p) {
            if (v < sp.lobe_weight[size_t(p)]) break;
            v -= sp.lobe_weight[size_t(p)];
        }
        if (!(sp.lobe_weight[size_t(p)] > 0)) return out;
        v = clamp(v / sp.lobe_weight[size_t(p)], 1e-12, 1.0);
        const SinCosPair o = p < 3 ? sp.tilted[size_t(p)] : SinCosPair{sp.sin_theta_o, sp.cos_theta_o};
        const double fac = 1.0 + v_[size_t(p)] * std::log(v + (1.0 - v) * exp_m2v_[size_t(p)]);
        const double sin_i = clamp(-fac * o.sin + cos_from_sin(fac) * std::cos(kTwoPi * u[1]) * o.cos, -1.0, 1.0);
        double phi;
        const double scaled = clamp(u[0], 0.0, 1.0) * 65536.0;
        const double u_h = (std::floor(std::min(scaled, 65535.0)) + 0.5) / 65536.0;
        const double u_d = clamp(scaled - std::floor(std::min(scaled, 65535.0)), 1e-12, 1.0 - 1e-12);
        if (p < 3) {
            const double h = 2.0 * u_h - 1.0;
            const double gamma_i = std::asin(h), gamma_t = safe_asin(h / sp.eta_prime);
            phi = 2.0 * p * gamma_t - 2.0 * gamma_i + p * kPi + beta_[size_t(p)] * inverse_normal_cdf(u_d);
        } else {
            phi = kTwoPi * u[0];
        }
        const Vec3 wi = sp.frame.direction(sin_i, cos_from_sin(sin_i), wrap_angle(phi) - 0.5 * kPi);
        const BsdfEval e = eval(sp, wi);
        return sample_from_eval(wi, e, p);
    }
    BsdfSample sample(const ShadingContext& ctx, const std::array<double, 3>& u) const {
        return sample(prepare(ctx), u);
    }

private:
    struct Tables {
        std::vector<RGB> n;          // [lobe][row][column]
        std::vector<double> density;  // [lobe][row][column]
        std::vector<RGB> mean_a;     // [row][lobe 0..3]
    };

    double eta_prime(double s) const {
        const double c = std::max(cos_from_sin(s), 1e-6);
        return std::sqrt(std::max(params_.eta * params_.eta - s * s, 1e-12)) / c;
    }

    // Calls fn(weight, A_p (p = 0..3), Phi_p (p = 0..2)) at every node of the h quadrature.
    template <class Fn>
    void for_each_node(double s, Fn fn) const {
        const double* gx = GaussLegendre<4>::x;
        const double* gw = GaussLegendre<4>::w;
        const double cos_o = cos_from_sin(s);
        const double ep = eta_prime(s);
        const double cos_t = cos_from_sin(s / params_.eta);
        const double width = kPi / kPanels;
        for (int k = 0; k < kPanels; ++k) {
            for (int j = 0; j < 4; ++j) {
                const double gamma_i = -0.5 * kPi + (k + 0.5 + 0.5 * gx[j]) * width;
                const double h = std::sin(gamma_i), weight = 0.5 * width * gw[j] * std::cos(gamma_i);  // dh
                const double gamma_t = safe_asin(h / ep);
                const double f = fresnel_dielectric(cos_o * std::cos(gamma_i), params_.eta);
                const RGB T = exp((-2.0 * std::cos(gamma_t) / std::max(cos_t, 1e-9)) * params_.sigma_a);
                std::array<RGB, 4> a;
                a[0] = RGB(f);
                a[1] = sqr(1.0 - f) * T;
                a[2] = (f * a[1]) * T;
                const RGB ft = f * T;
                auto ratio = [](double x) { return x >= 1.0 ? 0.0 : x / (1.0 - x); };
                a[3] = a[2] * RGB(ratio(ft.r), ratio(ft.g), ratio(ft.b));
                const std::array<double, 3> Phi = {-2.0 * gamma_i, 2.0 * gamma_t - 2.0 * gamma_i + kPi,
                                                   4.0 * gamma_t - 2.0 * gamma_i + 2.0 * kPi};
                fn(weight, a, Phi);
            }
        }
    }

    void build_tables() {
        auto t = std::make_shared<Tables>();
        t->n.assign(size_t(3 * kRows * kColumns), RGB());
        t->density.assign(size_t(3 * kRows * kColumns), 0.0);
        t->mean_a.assign(size_t(kRows * 4), RGB());
        const double dphi = kTwoPi / kColumns;
        for (int r = 0; r < kRows; ++r) {
            const double s = std::sin(0.5 * kPi * double(r) / (kRows - 1));
            for_each_node(s, [&](double weight, const std::array<RGB, 4>& a, const std::array<double, 3>& Phi) {
                for (int p = 0; p < 4; ++p) t->mean_a[size_t(r * 4 + p)] += (0.5 * weight) * a[size_t(p)];
                for (int p = 0; p < 3; ++p) {
                    const double beta = beta_[size_t(p)];
                    // Columns within 7 sd of the node's direction (all of them for wide lobes).
                    const int reach = std::min(kColumns / 2, int(std::ceil(7.0 * beta / dphi)) + 1);
                    const int centre = int(std::lround((wrap_angle(Phi[size_t(p)]) + kPi) / dphi));
                    const int count = std::min(2 * reach + 1, kColumns);
                    const double phi_w = wrap_angle(Phi[size_t(p)]);
                    // exp(-(x_i + 2 pi k)^2 / 2 beta^2) along the columns by multiplicative
                    // recurrences, one per image k of the wrapped Gaussian (x_i continuous).
                    const int images = beta < 0.5 ? 0 : kWrap;
                    const double inv2b2 = 0.5 / (beta * beta);
                    const double step_ratio = std::exp(-2.0 * dphi * dphi * inv2b2);
                    const double norm = 1.0 / (beta * 2.5066282746310002);
                    std::array<double, 2 * kWrap + 1> g{}, step{};
                    for (int k = -images; k <= images; ++k) {
                        const double x = (centre - reach) * dphi - kPi - phi_w + kTwoPi * k;
                        g[size_t(k + kWrap)] = std::exp(-x * x * inv2b2);
                        step[size_t(k + kWrap)] = std::exp(-(2.0 * x * dphi + dphi * dphi) * inv2b2);
                    }
                    for (int i = 0; i < count; ++i) {
                        const int c = ((centre - reach + i) % kColumns + kColumns) % kColumns;
                        double dg = 0;
                        for (int k = -images; k <= images; ++k) {
                            const size_t j = size_t(k + kWrap);
                            dg += g[j];
                            g[j] *= step[j];
                            step[j] *= step_ratio;
                        }
                        const double d = 0.5 * weight * dg * norm;
                        const size_t idx = size_t((p * kRows + r) * kColumns + c);
                        t->n[idx] += d * a[size_t(p)];
                        t->density[idx] += d;
                    }
                }
            });
        }
        tables_ = t;
    }

    static double row_coordinate(double s) { return std::asin(clamp(s, 0.0, 1.0)) / (0.5 * kPi) * (kRows - 1); }
    std::array<RGB, 4> row_mean(double s) const {
        const double x = row_coordinate(s);
        const int r0 = std::min(int(x), kRows - 2);
        const double w = x - r0;
        std::array<RGB, 4> out;
        for (int p = 0; p < 4; ++p)
            out[size_t(p)] = (1 - w) * tables_->mean_a[size_t(r0 * 4 + p)] + w * tables_->mean_a[size_t((r0 + 1) * 4 + p)];
        return out;
    }
    void lookup(double s, double phi, Azimuthal& az) const {
        const double x = row_coordinate(s);
        const int r0 = std::min(int(x), kRows - 2);
        const double wr = x - r0;
        const double y = (wrap_angle(phi) + kPi) / (kTwoPi / kColumns);
        const int c0 = std::min(int(std::floor(y)), kColumns - 1);
        const int c1 = (c0 + 1) % kColumns;
        const double wc = clamp(y - c0, 0.0, 1.0);
        for (int p = 0; p < 3; ++p) {
            auto at = [&](int r, int c) { return size_t((p * kRows + r) * kColumns + c); };
            const double w00 = (1 - wr) * (1 - wc), w01 = (1 - wr) * wc, w10 = wr * (1 - wc), w11 = wr * wc;
            az.n[size_t(p)] = w00 * tables_->n[at(r0, c0)] + w01 * tables_->n[at(r0, c1)] +
                              w10 * tables_->n[at(r0 + 1, c0)] + w11 * tables_->n[at(r0 + 1, c1)];
            az.density[size_t(p)] = w00 * tables_->density[at(r0, c0)] + w01 * tables_->density[at(r0, c1)] +
                                    w10 * tables_->density[at(r0 + 1, c0)] + w11 * tables_->density[at(r0 + 1, c1)];
        }
    }

    DeonHairParams params_;
    std::array<double, 3> beta_{};
    std::array<double, 4> v_{}, log_norm_{}, exp_m2v_{};
    std::array<SinCosPair, 3> rot_{};
    std::shared_ptr<const Tables> tables_;
};

}  // namespace hairbsdf
