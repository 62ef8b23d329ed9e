// Epic's energy-bound table (models/epic.h, models/energy_bound.h): the published R + TT + TRT
// albedo over theta_o. The multiple-scattering term is added at eval time in closed form.
#include "hairbsdf/models/epic.h"

namespace hairbsdf {

namespace {

// E(theta_o) of R + TT + TRT. dω = d(sin theta_i) dphi, and every lobe is a Gaussian in
// sin theta_i (sd beta_p, centre alpha_p - sin theta_o) times a smooth azimuthal factor, so each
// lobe is integrated by its own product rule: sin theta_i over the centre +- 6 beta_p (clipped to
// [-1, 1]) and phi over [-pi, pi], with TRT's narrow exp(17 cos phi) (sd about 0.25) resolved
// around phi = 0.
EnergyBoundTable build_epic_energy_table(const EpicHairParams& params) {
    EpicHairParams published = params;
    published.energy = EnergyMode::Published;
    published.scatter = 0.0;
    const EpicHair model(published);
    QuadratureRule phi_rule[3];
    phi_rule[0] = gauss_legendre_rule(-kPi, kPi, 4);
    phi_rule[1] = gauss_legendre_rule(-kPi, kPi, 4);
    append_gauss_legendre(phi_rule[2], -kPi, -1.0, 1);
    append_gauss_legendre(phi_rule[2], -1.0, 1.0, 4);
    append_gauss_legendre(phi_rule[2], 1.0, kPi, 1);
    const std::array<double, 3>& beta = model.betas();
    const std::array<double, 3>& alpha = model.alphas();
    // E changes over about beta_p in sin theta_o (where a lobe's Gaussian leaves [-1, 1]).
    EnergyBoundTable table(EnergyBoundTable::views_for_scale(std::min({beta[0], beta[1], beta[2]})));
    for_each_view(table.views(), [&](int k) {
        const double theta_o = table.view_theta(k);
        ShadingContext ctx;
        ctx.tangent = {1, 0, 0};
        ctx.wo = {std::sin(theta_o), std::cos(theta_o), 0.0};
        const EpicHair::ShadingPoint sp = model.prepare(ctx);
        RGB total;
        for (int p = 0; p < 3; ++p) {
            if (p == 1 && params.variant == EpicVariant::Environment) continue;  // no TT
            const double centre = alpha[size_t(p)] - sp.sin_theta_o, width = 6.0 * beta[size_t(p)];
            const QuadratureRule s_rule =
                gauss_legendre_rule(std::max(-1.0, centre - width), std::min(1.0, centre + width), 3);
            for (size_t i = 0; i < s_rule.x.size(); ++i) {
                const double s = s_rule.x[i], c = cos_from_sin(s);
                RGB row;
                for (size_t j = 0; j < phi_rule[p].x.size(); ++j) {
                    const Vec3 wi = sp.frame.direction(s, c, phi_rule[p].x[j] - 0.5 * kPi);
                    row += phi_rule[p].w[j] * model.published_lobe(sp, wi, p);
                }
                total += s_rule.w[i] * row;
            }
        }
        table.node(0, k) = total;
    });
    return table;
}

}  // namespace

std::shared_ptr<const EnergyBoundTable> epic_energy_table(const EpicHairParams& params) {
    const RGB& c = params.base_color;
    const std::vector<double> key = {c.r, c.g, c.b, params.r_scale, params.roughness, params.shift,
                                     params.variant == EpicVariant::Direct ? 0.0 : 1.0};
    return energy_bound_table("epic", key, [&] { return build_epic_energy_table(params); });
}

}  // namespace hairbsdf
