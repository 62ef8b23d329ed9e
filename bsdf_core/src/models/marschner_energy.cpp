// Marschner's energy-bound table (models/marschner.h, models/energy_bound.h): the published albedo
// over theta_o x the cross-section's orientation (MarschnerHair::orientation_nodes).
#include "hairbsdf/models/marschner.h"

#include <cmath>

namespace hairbsdf {

namespace {

// E(theta_o, phi_major) = sum_p int cos theta_i d theta_i int dphi lobe_p. M_p is a Gaussian in
// theta_i (sd 2 beta_p, centre 2 alpha_p - theta_o), so theta_i runs over the centre +- 6 sd
// (clipped to [-pi/2, pi/2]) per lobe. phi: for R and TT the change of variables phi -> h gives
// int N_p dphi = 1/2 int A(p, h) dh exactly (Gauss-Legendre in gamma); TRT (eccentricity makes
// eta* depend on phi, caustics and glints of width w_c replace the roots) by phi on uniform panels
// no wider than 2 w_c (12 to 64).
// Against a dense brute-force quadrature the nodes agree within about 0.5 % (the integrand has
// jumps where roots appear and vanish, so the rules converge unevenly; tests/marschner_test.cpp).
EnergyBoundTable build_marschner_energy_table(const MarschnerHairParams& params) {
    MarschnerHairParams published = params;
    published.energy = EnergyMode::Published;
    const MarschnerHair model(published);
    const std::array<double, 3>& alpha = model.alphas();
    const std::array<double, 3>& beta = model.betas();
    const QuadratureRule gamma_rule = gauss_legendre_rule(-0.5 * kPi, 0.5 * kPi, 4);
    const int trt_panels = int(std::clamp(std::ceil(kTwoPi / (2.0 * std::max(params.caustic_width, 1e-3))), 12.0, 64.0));
    const QuadratureRule trt_rule = gauss_legendre_rule(-kPi, kPi, trt_panels);
    const int orientations = MarschnerHair::orientation_nodes(params.eccentricity);
    // E changes over about a lobe's width 2 beta_p in theta_o (and steeply near grazing).
    EnergyBoundTable table(EnergyBoundTable::views_for_scale(2.0 * std::min({beta[0], beta[1], beta[2]})),
                           orientations);
    for_each_view(table.views(), [&](int k) {
        const double theta_o = table.view_theta(k);
        ShadingContext ctx;
        ctx.tangent = {1, 0, 0};
        ctx.wo = {std::sin(theta_o), std::cos(theta_o), 0.0};
        MarschnerHair::ShadingPoint sp = model.prepare(ctx);
        RGB r_and_tt;
        std::vector<RGB> trt(size_t(orientations), RGB(0.0));
        for (int p = 0; p < 3; ++p) {
            const double centre = 2.0 * alpha[size_t(p)] - sp.theta_o, width = 12.0 * beta[size_t(p)];
            // Near grazing views cos theta_i / cos^2 theta_d is steep at a clipped end: graded panels there.
            const double lo = std::max(-0.5 * kPi, centre - width), hi = std::min(0.5 * kPi, centre + width);
            const bool grazing = std::fabs(theta_o) > 1.3;  // 75 deg
            const QuadratureRule theta_rule = graded_gauss_legendre_rule(
                lo, hi, p == 2 ? 2 : 4, grazing && lo == -0.5 * kPi, grazing && hi == 0.5 * kPi);
            for (size_t i = 0; i < theta_rule.x.size(); ++i) {
                const double sin_theta_i = std::sin(theta_rule.x[i]);
                const MarschnerHair::LobeGeometry g = model.lobe_geometry(sp, sin_theta_i);
                const double w = theta_rule.w[i] * std::cos(theta_rule.x[i]);
                if (p < 2) {
                    // int N_p dphi = 1/2 int A(p, h) dh (every root of phi(gamma) once; exact through
                    // TT's own caustics at eta' < 1.155), h = sin gamma.
                    const auto indices = MarschnerHair::bravais(params.eta, g.sin_theta_d, g.cos_theta_d);
                    const double m = model.longitudinal(p, g.theta_h);
                    RGB row;
                    for (size_t j = 0; j < gamma_rule.x.size(); ++j)
                        row += (0.5 * gamma_rule.w[j] * std::cos(gamma_rule.x[j])) *
                               model.attenuation(p, indices.perpendicular, indices.parallel, gamma_rule.x[j],
                                                 g.cos_theta_t);
                    r_and_tt += (w * m * g.geometry) * row;
                } else {
                    for (int o = 0; o < orientations; ++o) {
                        sp.phi_major = MarschnerHair::orientation_phi_major(o, orientations);
                        RGB row;
                        for (size_t j = 0; j < trt_rule.x.size(); ++j)
                            row += trt_rule.w[j] * model.lobe(2, sp, g, trt_rule.x[j] - 0.5 * kPi);
                        trt[size_t(o)] += w * row;
                    }
                }
            }
        }
        for (int o = 0; o < orientations; ++o) table.node(o, k) = r_and_tt + trt[size_t(o)];
    });
    return table;
}

}  // namespace

std::shared_ptr<const EnergyBoundTable> marschner_energy_table(const MarschnerHairParams& params) {
    const RGB& s = params.sigma_a;
    const std::vector<double> key = {s.r,          s.g,         s.b,           params.eta,          params.eccentricity,
                                     params.alpha_r, params.beta_r, params.glint_scale, params.caustic_width,
                                     params.caustic_fade, params.caustic_limit};
    return energy_bound_table("marschner", key, [&] { return build_marschner_energy_table(params); });
}

}  // namespace hairbsdf
