// Marschner, Jensen, Cammarano, Worley and Hanrahan 2003, "Light Scattering from Human Hair
// Fibers" (SIGGRAPH 2003), §4 "Scattering model" (as restated in seed 002's Marschner section):
//   S = sum_p M_p(theta_h) N_p(eta'(theta_d); phi) / cos^2 theta_d,
//   M_p = g(beta_p; theta_h - alpha_p)                       (Gaussian longitudinal lobes, §4.3)
//   N_p(p, phi) = sum_roots A(p, h) |2 dphi/dh|^-1          (smooth-fibre azimuthal scattering, §4.1)
//   phi(p, gamma_i) ~ (6pc/pi - 2) gamma_i - 8pc/pi^3 gamma_i^3 + p pi,  c = asin(1/eta')   (cubic fit)
//   eta' = sqrt(eta^2 - sin^2 theta_d) / cos theta_d,  eta'' = eta^2 cos theta_d / sqrt(eta^2 - sin^2 theta_d)
//   A(0, h) = F(eta', eta'', gamma_i),  A(p, h) = (1 - F(eta', eta'', gamma_i))^2 F(1/eta', 1/eta'', gamma_t)^(p-1) T^p
//   TRT: eccentricity through eta*(phi_h) (§4.2), caustic smoothing with w_c, k_G, Delta eta*, Delta h_M (§4.3).
// eval = S cos theta_i (the curve-scattering radiometry L = D int S L_i cos theta_i d omega_i).
//
// Deviations (docs/models.md §4): M_p has unit area in theta_i (the published Gaussian has unit area
// in theta_h = (theta_i + theta_r)/2, which doubles the energy; seed 004 / d'Eon 2011); the absorption
// path is the chord 2 cos gamma_t / cos theta_t (the paper's 2 (1 + cos 2 gamma_t) is a known error),
// with sigma_a in this library's unit (docs/conventions.md).
//
// Lobes: R, TT, TRT. Sampler (the paper has none): a lobe mixture; sin theta_i from a normal
// truncated to [-1, 1] around the lobe's cone, phi from 1/4 cos(phi/2) (R), a trimmed logistic
// around pi (TT) or uniform (TRT), plus 10% uniform directions. Exact pdf.
//
// Energy (docs/models.md §4): energy = Bounded (the default) divides eval per channel by
// max(1, E_c), E_c the published model's directional albedo at this view and cross-section
// orientation, from a table over theta_o x phi_major (src/models/marschner_energy.cpp).
// Published: the paper's model (with the deviations above). Sampler and pdf are the same for both.
#pragma once

#include <memory>

#include "hairbsdf/closure.h"
#include "hairbsdf/math_hair_defaults.h"
#include "hairbsdf/models/energy_bound.h"

namespace hairbsdf {

struct MarschnerHairParams {
    RGB sigma_a = blender_hair::kAbsorptionCoefficient;  // Blender's Principled Hair default absorption
    double eta = 1.55;                    // Table 1
    double eccentricity = 0.9;            // a, Table 1: 0.85-1
    double alpha_r = -0.1309;             // -7.5 deg (Table 1: -10..-5 deg); alpha_TT = -alpha_R/2, alpha_TRT = -3 alpha_R/2
    double beta_r = 0.1309;               // 7.5 deg (Table 1: 5..10 deg); beta_TT = beta_R/2, beta_TRT = 2 beta_R
    double glint_scale = 0.5;             // k_G, Table 1: 0.5-5
    double caustic_width = 0.2618;        // w_c = 15 deg (Table 1: 10..25 deg)
    double caustic_fade = 0.3;            // Delta eta*, Table 1: 0.2-0.4
    double caustic_limit = 0.5;           // Delta h_M, Table 1: 0.5
    EnergyMode energy = EnergyMode::Bounded;
};

// The table of the published albedo over theta_o x phi_major for these parameters (energy
// ignored), from the process-wide cache.
std::shared_ptr<const EnergyBoundTable> marschner_energy_table(const MarschnerHairParams& params);

class MarschnerHair {
public:
    static constexpr double kUniformShare = 0.1;
    static constexpr double kTTLogisticScale = 0.3;

    explicit MarschnerHair(const MarschnerHairParams& p) : params_(p) {
        alpha_ = {p.alpha_r, -0.5 * p.alpha_r, -1.5 * p.alpha_r};
        beta_ = {std::max(p.beta_r, 1e-3), std::max(0.5 * p.beta_r, 1e-3), std::max(2.0 * p.beta_r, 1e-3)};
        const double a2 = sqr(std::max(p.eccentricity, 1e-3));
        eta_star1_ = 2.0 * (p.eta - 1.0) * a2 - p.eta + 2.0;  // §4.2
        eta_star2_ = 2.0 * (p.eta - 1.0) / a2 - p.eta + 2.0;
        tt_norm_ = 1.0 / (logistic_cdf(kPi, kTTLogisticScale) - logistic_cdf(-kPi, kTTLogisticScale));
        if (p.energy == EnergyMode::Bounded) energy_table_ = marschner_energy_table(p);
    }
    const MarschnerHairParams& params() const { return params_; }
    const std::shared_ptr<const EnergyBoundTable>& energy_table() const { return energy_table_; }
    // Shift and width of each lobe's longitudinal Gaussian in theta_h (R, TT, TRT).
    const std::array<double, 3>& alphas() const { return alpha_; }
    const std::array<double, 3>& betas() const { return beta_; }
    // M_p with unit area in theta_i: g(beta_p; theta_h - alpha_p) / 2.
    double longitudinal(int p, double theta_h) const {
        return 0.5 * gaussian(beta_[size_t(p)], theta_h - alpha_[size_t(p)]);
    }
    // Bravais indices of the 2D problem for relative index eta: eta' (perpendicular) and eta'' (parallel).
    struct BravaisIndices {
        double perpendicular, parallel;
    };
    static BravaisIndices bravais(double eta, double sin_theta_d, double cos_theta_d) {
        const double root = std::sqrt(std::max(eta * eta - sqr(sin_theta_d), 1e-12));
        return {root / cos_theta_d, eta * eta * cos_theta_d / root};
    }

    // The table's orientation nodes: E depends on the major axis phi_major only through TRT's
    // eta*(phi_h); it is pi-periodic and even in phi_major, so phi_major in [0, pi/2] suffices.
    // Nodes uniform there (linear in between): 1 for a circular fibre, 9 (11.25 deg apart) over
    // Table 1's range 0.85-1, where with glints E has features about 20 deg wide in phi_major, and up
    // to 25 (3.75 deg) at the schema's 0.5, where they are sharper.
    static int orientation_nodes(double eccentricity) {
        if (eccentricity >= 1.0) return 1;
        if (eccentricity >= 0.85) return 9;
        return 9 + int(std::ceil(16.0 * (0.85 - eccentricity) / 0.35));
    }
    static double orientation_phi_major(int j, int nodes) { return nodes > 1 ? 0.5 * kPi * j / (nodes - 1) : 0.0; }
    // E_c at theta_o for the cross-section's axis at phi_major (energy = Bounded only).
    RGB bound_albedo(double theta_o, double phi_major) const {
        const int n = energy_table_->orientations();
        if (n == 1) return energy_table_->albedo(theta_o, 0);
        double a = std::fabs(std::remainder(phi_major, kPi));  // fold into [0, pi/2]
        const double x = clamp(a / (0.5 * kPi) * (n - 1), 0.0, n - 1.0);
        const int lo = std::min(int(x), n - 2);
        const double f = x - lo;
        return (1.0 - f) * energy_table_->albedo(theta_o, lo) + f * energy_table_->albedo(theta_o, lo + 1);
    }

    std::array<double, 2> angular_scales() const {
        return {std::max(beta_[1], 2e-3), std::max(std::min(0.2, 0.5 * params_.caustic_width), 2e-3)};
    }

    // Fresnel of the 2D problem: perpendicular polarisation with eta1, parallel with eta2, for
    // the incidence angle gamma (§4.1). Total internal reflection gives 1.
    static double fresnel2(double eta1, double eta2, double gamma) {
        const double ci = std::fabs(std::cos(gamma)), si = std::sin(gamma);
        auto rs = [&](double e) {
            const double st = si / e;
            if (std::fabs(st) >= 1.0) return 1.0;
            const double ct = std::sqrt(1.0 - st * st);
            return sqr((ci - e * ct) / (ci + e * ct));
        };
        auto rp = [&](double e) {
            const double st = si / e;
            if (std::fabs(st) >= 1.0) return 1.0;
            const double ct = std::sqrt(1.0 - st * st);
            return sqr((e * ci - ct) / (e * ci + ct));
        };
        return clamp(0.5 * (rs(eta1) + rp(eta2)), 0.0, 1.0);
    }

    // Real roots gamma in [-pi/2, pi/2] of phi_hat(p, gamma) = phi (mod 2 pi); returns the count.
    static int solve_gamma(int p, double c, double phi, std::array<double, 6>& roots) {
        const double a1 = 6.0 * p * c / kPi - 2.0, a3 = -8.0 * p * c / (kPi * kPi * kPi);
        int n = 0;
        for (int k = -2; k <= 2; ++k) {
            const double target = wrap_angle(phi) + kTwoPi * k - p * kPi;  // a3 g^3 + a1 g = target
            double r[3];
            int m = 0;
            if (std::fabs(a3) < 1e-15) {
                r[m++] = target / a1;
            } else {
                // g^3 + P g + Q = 0
                const double P = a1 / a3, Q = -target / a3;
                const double disc = sqr(Q / 2) + P * P * P / 27;
                if (disc > 0) {
                    const double s = std::sqrt(disc);
                    r[m++] = std::cbrt(-Q / 2 + s) + std::cbrt(-Q / 2 - s);
                } else {
                    const double rho = std::sqrt(-P / 3);
                    const double th = std::acos(clamp(-Q / (2 * rho * rho * rho), -1.0, 1.0));
                    for (int j = 0; j < 3; ++j) r[m++] = 2 * rho * std::cos((th + kTwoPi * j) / 3);
                }
            }
            for (int j = 0; j < m && n < 6; ++j)
                if (std::fabs(r[j]) <= 0.5 * kPi) roots[size_t(n++)] = r[j];
        }
        return n;
    }

    struct ShadingPoint {
        ShadingPoint(const FibreFrame& f) : frame(f) {}
        FibreFrame frame;
        double sin_theta_o = 0, theta_o = 0;
        double phi_major = 0;  // azimuth of the cross-section's major axis in the frame
        std::array<TruncatedNormal, 3> longitudinal{};
        std::array<double, 4> lobe_weight{};  // R, TT, TRT, uniform
        RGB energy_scale{1.0};                // 1 / max(1, E_c) (energy = Bounded), else 1
    };
    ShadingPoint prepare(const ShadingContext& ctx) const {
        ShadingPoint sp(FibreFrame(ctx.tangent, ctx.wo));
        sp.sin_theta_o = sp.frame.sin_theta(ctx.wo);
        sp.theta_o = std::asin(sp.sin_theta_o);
        const Vec3 n = ctx.normal - dot(ctx.normal, sp.frame.x) * sp.frame.x;
        sp.phi_major = length(n) > 1e-9 ? sp.frame.phi(n) : 0.0;  // no normal: the frame's y
        if (energy_table_) sp.energy_scale = EnergyBoundTable::bound_scale(bound_albedo(sp.theta_o, sp.phi_major));
        for (int p = 0; p < 3; ++p) {
            // Peak of M_p: theta_i = 2 alpha_p - theta_o; width 2 beta_p in theta_i.
            const double center = clamp(2.0 * alpha_[size_t(p)] - sp.theta_o, -0.5 * kPi, 0.5 * kPi);
            const double w = 2.0 * beta_[size_t(p)];
            sp.longitudinal[size_t(p)] =
                TruncatedNormal(std::sin(center), std::sqrt(sqr(std::cos(center) * w) + 0.5 * sqr(w * w)), -1.0, 1.0);
        }
        // Lobe weights from the h = 0 attenuations at normal incidence.
        const double f0 = fresnel2(params_.eta, params_.eta, 0.0);
        const double cos_t = cos_from_sin(sp.sin_theta_o / params_.eta);
        const RGB T = exp((-2.0 / cos_t) * params_.sigma_a);
        const std::array<double, 3> w = {std::max(f0, 0.02), sqr(1 - f0) * luminance(T),
                                         std::max(sqr(1 - f0) * f0 * luminance(T * T), 1e-3)};
        const double total = (w[0] + w[1] + w[2]) / (1.0 - kUniformShare);
        for (int p = 0; p < 3; ++p) sp.lobe_weight[size_t(p)] = w[size_t(p)] / total;
        sp.lobe_weight[3] = kUniformShare;
        return sp;
    }

    // What the lobes share for one sin theta_i (theta_h and the Bravais inputs).
    struct LobeGeometry {
        double theta_h = 0, geometry = 0, sin_theta_d = 0, cos_theta_d = 1, cos_theta_t = 1;
    };
    LobeGeometry lobe_geometry(const ShadingPoint& sp, double sin_theta_i) const {
        LobeGeometry g;
        const double theta_i = std::asin(sin_theta_i);
        const double theta_d = 0.5 * (sp.theta_o - theta_i);
        g.theta_h = 0.5 * (sp.theta_o + theta_i);
        g.cos_theta_d = std::max(std::cos(theta_d), 1e-6);
        g.geometry = cos_from_sin(sin_theta_i) / sqr(g.cos_theta_d);  // cos theta_i / cos^2 theta_d
        g.sin_theta_d = std::sin(theta_d);
        g.cos_theta_t = cos_from_sin(sp.sin_theta_o / params_.eta);
        return g;
    }
    // Lobe p's eval (as published, without the energy bound) at azimuth phi_i in the frame.
    RGB lobe(int p, const ShadingPoint& sp, const LobeGeometry& g, double phi_i) const {
        const double m = longitudinal(p, g.theta_h);
        double eta = params_.eta;
        if (p == 2) {  // eccentricity: eta*(phi_h), phi_h relative to the major axis (§4.2)
            const double phi_h = 0.5 * (phi_i + (-0.5 * kPi)) - sp.phi_major;
            eta = 0.5 * ((eta_star1_ + eta_star2_) + std::cos(2.0 * phi_h) * (eta_star1_ - eta_star2_));
        }
        const RGB n = azimuthal(p, eta, g.sin_theta_d, g.cos_theta_d, g.cos_theta_t, phi_i + 0.5 * kPi);
        return (m * g.geometry) * n;
    }

    // A(p, h) for the incidence gamma_i (h = sin gamma_i) with indices (e1, e2) of the 2D problem.
    // Public: the energy table integrates it over h.
    RGB attenuation(int p, double e1, double e2, double gamma_i, double cos_theta_t) const {
        if (p == 0) return RGB(fresnel2(e1, e2, gamma_i));
        const double gamma_t = safe_asin(std::sin(gamma_i) / e1);
        const double f_in = fresnel2(e1, e2, gamma_i);
        const double f_back = fresnel2(1.0 / e1, 1.0 / e2, gamma_t);
        const RGB T = exp((-2.0 * std::cos(gamma_t) / cos_theta_t) * params_.sigma_a);
        RGB a = sqr(1.0 - f_in) * T;
        if (p == 2) a = (f_back * a) * T;
        return a;
    }

    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const {
        BsdfEval out;
        const double sin_theta_i = sp.frame.sin_theta(wi);
        const double phi_i = sp.frame.phi(wi);
        const LobeGeometry g = lobe_geometry(sp, sin_theta_i);
        for (int p = 0; p < 3; ++p) out.lobes[size_t(p)] = sp.energy_scale * lobe(p, sp, g, phi_i);
        out.pdf = pdf_local(sp, sin_theta_i, phi_i + 0.5 * kPi);
        if (!std::isfinite(out.pdf) || !isfinite(out.value())) return {};
        return out;
    }
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const { return eval(prepare(ctx), wi); }
    double pdf(const ShadingContext& ctx, Vec3 wi) const { return pdf(prepare(ctx), wi); }
    double pdf(const ShadingPoint& sp, Vec3 wi) const {
        return pdf_local(sp, sp.frame.sin_theta(wi), sp.frame.phi(wi) + 0.5 * kPi);
    }

    // u2 picks the component and, rescaled, sin theta_i (uniform: sin theta_i directly); u0 phi.
    BsdfSample sample(const ShadingPoint& sp, const std::array<double, 3>& u) const {
        BsdfSample out;
        int p = 0;
        double v = u[2];
        for (; p < 3; ++p) {
            if (v < sp.lobe_weight[size_t(p)]) break;
            v -= sp.lobe_weight[size_t(p)];
        }
        v = clamp(v / sp.lobe_weight[size_t(p)], 0.0, 1.0);
        double sin_theta_i, phi;
        if (p == 3) {
            sin_theta_i = 2.0 * v - 1.0;
            phi = kTwoPi * u[0];
        } else {
            if (!(sp.longitudinal[size_t(p)].mass() > 0)) return out;
            sin_theta_i = sp.longitudinal[size_t(p)].sample(v);
            if (p == 0) {
                phi = 2.0 * safe_asin(2.0 * u[0] - 1.0);
            } else if (p == 1) {
                phi = kPi + sample_trimmed_logistic(u[0], kTTLogisticScale);
            } else {
                phi = kTwoPi * u[0];
            }
        }
        const Vec3 wi = sp.frame.direction(sin_theta_i, cos_from_sin(sin_theta_i), phi - 0.5 * kPi);
        const BsdfEval e = eval(sp, wi);
        return sample_from_eval(wi, e, p < 3 ? p : (luminance(e.lobes[0]) >= luminance(e.lobes[1]) ? 0 : 1));
    }
    BsdfSample sample(const ShadingContext& ctx, const std::array<double, 3>& u) const {
        return sample(prepare(ctx), u);
    }

private:
    static double gaussian(double beta, double x) {
        return std::exp(-0.5 * sqr(x / beta)) / (beta * 2.5066282746310002);
    }

    // N_p(phi) for relative index eta (eta* for TRT): roots of the cubic phi(gamma_i), with the TRT
    // caustic replaced by Gaussians of width w_c near eta' < 2 (§4.3).
    RGB azimuthal(int p, double eta, double sin_theta_d, double cos_theta_d, double cos_theta_t, double phi) const {
        const BravaisIndices indices = bravais(eta, sin_theta_d, cos_theta_d);
        const double e1 = indices.perpendicular, e2 = indices.parallel;  // eta', eta''
        const double c = std::asin(clamp(1.0 / e1, -1.0, 1.0));
        std::array<double, 6> g{};
        const int n = solve_gamma(p, c, phi, g);
        RGB sum;
        for (int k = 0; k < n; ++k) {
            const double dphi_dgamma = 6.0 * p * c / kPi - 2.0 - 3.0 * 8.0 * p * c / (kPi * kPi * kPi) * sqr(g[size_t(k)]);
            const double inv = std::cos(g[size_t(k)]) / (2.0 * std::max(std::fabs(dphi_dgamma), 1e-4));  // |2 dphi/dh|^-1
            sum += inv * attenuation(p, e1, e2, g[size_t(k)], cos_theta_t);
        }
        if (p != 2) return sum;
        // TRT caustic (§4.3): location, fade t, merged width Delta h, glint Gaussians.
        const double a1 = 12.0 * c / kPi - 2.0;
        if (!(a1 > 0)) return sum;  // eta' >= 2: no caustic
        const double gamma_c = std::sqrt(a1 / (3.0 * 16.0 * c / (kPi * kPi * kPi)));
        if (gamma_c > 0.5 * kPi) return sum;
        const double h_c = std::sin(gamma_c);
        const double phi_c = wrap_angle(a1 * gamma_c - 16.0 * c / (kPi * kPi * kPi) * gamma_c * gamma_c * gamma_c + 2.0 * kPi);
        // d^2 phi / dh^2 at the caustic (dphi/dgamma = 0 there): phi''(gamma) / cos^2 gamma.
        const double d2 = -6.0 * 16.0 * c / (kPi * kPi * kPi) * gamma_c / sqr(std::cos(gamma_c));
        const double wc = std::max(params_.caustic_width, 1e-3);
        const double dh = std::min(params_.caustic_limit, 2.0 * std::sqrt(2.0 * wc / std::max(std::fabs(d2), 1e-9)));
        double t = 1.0;
        const double lo = 2.0 - params_.caustic_fade;
        if (e1 >= 2.0) {
            t = 0.0;
        } else if (e1 > lo && params_.caustic_fade > 0) {
            const double x = (2.0 - e1) / params_.caustic_fade;  // smoothstep(2, 2 - fade, eta')
            t = x * x * (3.0 - 2.0 * x);
        }
        const double g0 = gaussian(wc, 0.0);
        const double ga = gaussian(wc, wrap_angle(phi - phi_c)), gb = gaussian(wc, wrap_angle(phi + phi_c));
        const RGB a_c = attenuation(2, e1, e2, safe_asin(h_c), cos_theta_t);
        return ((1.0 - t * ga / g0) * (1.0 - t * gb / g0)) * sum + (t * params_.glint_scale * dh * (ga + gb)) * a_c;
    }

    double pdf_local(const ShadingPoint& sp, double sin_theta_i, double phi) const {
        double pdf = sp.lobe_weight[3] / (4.0 * kPi);
        pdf += sp.lobe_weight[0] * sp.longitudinal[0].pdf(sin_theta_i) * 0.25 *
               std::sqrt(clamp(0.5 + 0.5 * std::cos(phi), 0.0, 1.0));
        pdf += sp.lobe_weight[1] * sp.longitudinal[1].pdf(sin_theta_i) *
               logistic(wrap_angle(phi - kPi), kTTLogisticScale) * tt_norm_;
        pdf += sp.lobe_weight[2] * sp.longitudinal[2].pdf(sin_theta_i) * kInvTwoPi;
        return pdf;
    }

    MarschnerHairParams params_;
    std::array<double, 3> alpha_{}, beta_{};
    double eta_star1_ = 1.55, eta_star2_ = 1.55;
    double tt_norm_ = 1;
    std::shared_ptr<const EnergyBoundTable> energy_table_;
};

}  // namespace hairbsdf
