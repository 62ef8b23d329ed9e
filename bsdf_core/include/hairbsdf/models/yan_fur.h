// Yan, Tseng, Jensen, Ramamoorthi 2015, "Physically-Accurate Fur Reflectance: Modeling,
// Measurement and Rendering" (SIGGRAPH Asia): the double cylinder. docs/models.md §7.
//
// A unit-radius cortex (IOR eta, RGB absorption sigma_ca per unit radius, cuticle tilt alpha,
// Chiang's roughness mapping) around a concentric, index-matched medulla of radius kappa with
// scalar absorption sigma_ma, scattering sigma_ms (per unit radius) and a Henyey-Greenstein phase
// function g (0 = isotropic). Six lobes (closure.h):
//   0 R, 1 TT, 2 TRT, 3 TRRT+  unscattered (near field, at the view's h): Chiang's terms
//        (models/chiang.h) with each internal pass's transmittance multiplied by the medulla's
//          T = exp(-sigma_ca L) exp(-(sigma_ma + sigma_ms) L_m),
//          L = 2 cos gamma_t / cos theta_t,  L_m = 2 sqrt(kappa^2 - sin^2 gamma_t) / cos theta_t
//        (L_m = 0 where the chord at distance |sin gamma_t| = |h| / eta' misses the medulla):
//        the cortex absorption acts along the whole chord, the medulla's extinction on top.
//        kappa = 0 or sigma_m = 0 is Chiang (Principled Hair with this absorption) exactly.
//   4 TTs, 5 TRTs              scattered in the medulla at least once: far-field tables of a 3D
//        random walk through the smooth double cylinder (models/yan_fur_tables.h), cached per
//        (kappa, sigma_ma, sigma_ms, g, eta, sigma_ca). Their angular shape does not depend on
//        h; their energy does: (1 - F(cos theta_o cos gamma_o)) times the analytic share of the
//        entering light that scatters, (1 - T_m) / (1 - f T_c T_m), times the walk's tabulated
//        TTs / TRTs fraction of it for the chord at |h| / eta' (YanFurTable::scattering_prefactor,
//        scattered_per_entering), so that unscattered plus scattered energy is conserved at every
//        h (a pure far-field magnitude is not: docs/models.md §7).
// Sampler: a mixture of Chiang's sampler (weight: luminance of sum A_p) and the two tables
// (weight: luminance of each lobe's energy at theta_o and h); pdf is its exact density.
#pragma once

#include <memory>

#include "hairbsdf/closure.h"
#include "hairbsdf/models/chiang.h"
#include "hairbsdf/models/yan_fur_tables.h"

namespace hairbsdf {

struct YanFurParams {
    double eta = 1.55;
    RGB cortex_absorption{0.64};          // sigma_ca per unit radius (Yan 2015's fit: 0.64)
    double medulla_ratio = 0.88;          // kappa
    double medulla_absorption = 0.17;     // sigma_ma per unit radius
    double medulla_scattering = 1.69;     // sigma_ms per unit radius
    double medulla_g = 0.0;               // Henyey-Greenstein asymmetry of the medulla
    double alpha = 0.0956440430;          // cuticle tilt 5.48 deg, Principled Hair's Offset convention
    double roughness = 0.2238067333;      // Chiang's beta_m: R's longitudinal sd sqrt(v) = 11.64 deg
    double radial_roughness = 0.2186326880;  // Chiang's beta_n: logistic sd pi s / sqrt 3 = 7.49 deg
    // Internal switch (tests, docs): false gives the scattered lobes the pure far-field magnitude
    // (the h average, independent of h); true (the model) gives them the energy the walk leaves
    // at the view's (theta_o, h): (1 - F) x prefactor x the tabulated fraction (see the top).
    bool scattered_at_h = true;
};

class YanFurHair {
public:
    explicit YanFurHair(const YanFurParams& params)
        : params_(params), chiang_(chiang_params(params)),
          table_(yan_fur_table(YanFurTableKey{params.eta, params.cortex_absorption, params.medulla_ratio,
                                              params.medulla_absorption, params.medulla_scattering,
                                              params.medulla_g})) {}

    // The Chiang parameters of the unscattered lobes: Principled Hair's roughness mapping (TT v/4,
    // TRT and TRRT+ 4v), exact special functions, Blender 4.2's tilt convention.
    static ChiangHairParams chiang_params(const YanFurParams& p) {
        ChiangHairParams c;
        c.sigma_a = p.cortex_absorption;
        c.eta = p.eta;
        const double v = longitudinal_variance(clamp(p.roughness, 0.001, 1.0));
        c.v = {v, 0.25 * v, 4.0 * v, 4.0 * v};
        c.v_sample = c.v;
        const double s = azimuthal_scale(clamp(p.radial_roughness, 0.001, 1.0));
        c.s = {s, s, s};
        c.tilt = p.alpha;
        c.accuracy = Accuracy::Exact;
        c.tilt_convention = TiltConvention::Blender42;
        return c;
    }

    const YanFurParams& params() const { return params_; }
    const ChiangHair& chiang() const { return chiang_; }
    const std::shared_ptr<const YanFurTable>& table() const { return table_; }
    std::array<double, 2> angular_scales() const { return chiang_.angular_scales(); }

    struct ShadingPoint {
        FibreFrame frame;
        ChiangHair::ViewTerms view;
        int node[2] = {0, 0};
        double node_blend[2] = {1.0, 0.0};            // interpolation weights of the two nodes
        std::array<std::array<RGB, 2>, 2> h_scale{};  // [lobe][node] factor of the table at |h|
        std::array<std::array<double, 2>, 2> node_pick{};  // [lobe][node] sampler's node choice
        std::array<double, 2> pick_norm{};            // [lobe] sum of blend * energy luminance
        std::array<double, 3> weight{};               // unscattered, TTs, TRTs selection
        bool mirror = false;                          // sin theta_o < 0: sin theta_i flips
        bool valid = false;
    };

    ShadingPoint prepare(const ShadingContext& ctx) const {
        ShadingPoint sp{FibreFrame(ctx.tangent, ctx.wo), {}};
        const double kappa = params_.medulla_ratio, kappa2 = kappa * kappa;
        const double sigma_mt = params_.medulla_absorption + params_.medulla_scattering;
        const RGB sigma_c = params_.cortex_absorption;
        sp.view = chiang_.view_terms(sp.frame, ctx, [&](const ChiangPassGeometry& g) {
            const RGB cortex = exp((-2.0 * g.cos_gamma_t / g.cos_theta_t) * sigma_c);  // Chiang's T
            const double d2 = g.sin_gamma_t * g.sin_gamma_t;
            if (!(d2 < kappa2) || sigma_mt == 0.0) return cortex;
            return std::exp(-sigma_mt * 2.0 * std::sqrt(kappa2 - d2) / g.cos_theta_t) * cortex;
        });
        const double sin_o = sp.frame.sin_theta(ctx.wo);
        const double cos_o = cos_from_sin(sin_o);
        // Energy entering the fibre at h (exact Fresnel at the entry point, as Chiang's A_p) times
        // the share of it that scatters (YanFurTable::scattering_prefactor).
        const double f = fresnel_dielectric(cos_o * cos_from_sin(clamp(ctx.h, -1.0, 1.0)), params_.eta);
        sp.mirror = sin_o < 0;
        const double x = YanFurTable::node_position(cos_o);
        if (x <= 0) {
            sp.node[0] = sp.node[1] = 0;
        } else if (x >= YanFurTable::kNodes - 1) {
            sp.node[0] = sp.node[1] = YanFurTable::kNodes - 1;
        } else {
            sp.node[0] = int(x);
            sp.node[1] = sp.node[0] + 1;
            sp.node_blend[1] = x - sp.node[0];
            sp.node_blend[0] = 1.0 - sp.node_blend[1];
        }
        // The refracted chord's distance from the axis, |h| / eta' (as Chiang's sin gamma_t).
        const double sin_gamma_t =
            std::fabs(clamp(ctx.h, -1.0, 1.0)) * cos_o / std::sqrt(params_.eta * params_.eta - sin_o * sin_o);
        RGB entering(0.0);
        if (sin_gamma_t < kappa && sigma_mt > 0) {
            const double cos_theta_t = cos_from_sin(sin_o / params_.eta);
            const RGB cortex_pass = exp((-2.0 * cos_from_sin(sin_gamma_t) / cos_theta_t) * sigma_c);
            const double medulla_pass = std::exp(-sigma_mt * 2.0 * std::sqrt(kappa2 - sqr(sin_gamma_t)) / cos_theta_t);
            entering = (1.0 - f) * YanFurTable::scattering_prefactor(f, cortex_pass, medulla_pass);
        }
        double total = 0;
        if (sp.view.valid) {
            RGB a(0.0);
            for (const RGB& ap : sp.view.attenuation) a += ap;
            sp.weight[0] = std::max(0.0, luminance(a));
        }
        for (int lobe = 0; lobe < 2; ++lobe) {
            RGB energy(0.0);
            sp.pick_norm[size_t(lobe)] = 0;
            for (int k = 0; k < 2; ++k) {
                const int n = sp.node[k];
                if (params_.scattered_at_h) {
                    // The far-field shape of node n with the energy the walk leaves at (theta_o, h).
                    const RGB e = table_->energy(lobe, n);
                    const RGB g = entering * table_->scattered_per_entering(lobe, n, sin_gamma_t);  // RGB product
                    sp.h_scale[size_t(lobe)][size_t(k)] =
                        RGB(e.r > 0 ? g.r / e.r : 0.0, e.g > 0 ? g.g / e.g : 0.0, e.b > 0 ? g.b / e.b : 0.0);
                } else {
                    sp.h_scale[size_t(lobe)][size_t(k)] = RGB(1.0);
                }
                energy += sp.node_blend[k] * (sp.h_scale[size_t(lobe)][size_t(k)] * table_->energy(lobe, n));
                sp.node_pick[size_t(lobe)][size_t(k)] = sp.node_blend[k] * table_->energy_luminance(lobe, n);
                sp.pick_norm[size_t(lobe)] += sp.node_pick[size_t(lobe)][size_t(k)];
            }
            sp.weight[size_t(lobe) + 1] = sp.pick_norm[size_t(lobe)] > 0 ? std::max(0.0, luminance(energy)) : 0.0;
        }
        for (double w : sp.weight) total += w;
        if (!(total > 0) || !std::isfinite(total)) return sp;
        for (double& w : sp.weight) w /= total;
        sp.valid = true;
        return sp;
    }

    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const {
        if (!sp.valid) return {};
        const double sin_theta_i = sp.frame.sin_theta(wi);
        const double cos_theta_i = cos_from_sin(sin_theta_i);
        const double phi = sp.frame.phi(wi) - sp.view.phi_o;
        BsdfEval out;
        if (sp.weight[0] > 0) {
            out = chiang_.eval_local(sp.view, sin_theta_i, cos_theta_i, phi);
            out.pdf *= sp.weight[0];
        }
        const int bin = YanFurTable::bin(sp.mirror ? -sin_theta_i : sin_theta_i, std::fabs(wrap_angle(phi)));
        for (int lobe = 0; lobe < 2; ++lobe) {
            if (!(sp.weight[size_t(lobe) + 1] > 0)) continue;
            RGB value(0.0);
            double lum = 0;
            for (int k = 0; k < 2; ++k) {
                if (sp.node_blend[k] == 0.0) continue;
                const RGB d = table_->density(lobe, sp.node[k], bin);
                value += sp.node_blend[k] * (sp.h_scale[size_t(lobe)][size_t(k)] * d);
                lum += sp.node_blend[k] * luminance(d);
            }
            out.lobes[size_t(LobeTTs + lobe)] = value;
            out.pdf += sp.weight[size_t(lobe) + 1] * lum / sp.pick_norm[size_t(lobe)];
        }
        if (!std::isfinite(out.pdf) || !isfinite(out.value())) return {};
        return out;
    }
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const { return eval(prepare(ctx), wi); }
    double pdf(const ShadingContext& ctx, Vec3 wi) const { return eval(ctx, wi).pdf; }
    double pdf(const ShadingPoint& sp, Vec3 wi) const { return eval(sp, wi).pdf; }

    // u2 picks unscattered / TTs / TRTs and, rescaled, Chiang's lobe and theta_i (unscattered) or
    // the table node; u1 the table bin and sin theta_i within it; u0 the azimuth (Chiang's offset,
    // or the sign and |phi| within the bin).
    BsdfSample sample(const ShadingPoint& sp, const std::array<double, 3>& u) const {
        if (!sp.valid) return {};
        double v = u[2];
        int component = 0;
        for (; component < 2; ++component) {
            if (v < sp.weight[size_t(component)]) break;
            v -= sp.weight[size_t(component)];
        }
        while (component > 0 && !(sp.weight[size_t(component)] > 0)) --component;  // rounding at u -> 1
        v = clamp(sp.weight[size_t(component)] > 0 ? v / sp.weight[size_t(component)] : 0.5, 0.0, 1.0);
        const ChiangHair::ViewTerms& vt = sp.view;
        if (component == 0) {
            int p = 0;
            for (; p < 3; ++p) {
                if (v < vt.lobe_weight[size_t(p)]) break;
                v -= vt.lobe_weight[size_t(p)];
            }
            v = vt.lobe_weight[size_t(p)] > 0 ? v / vt.lobe_weight[size_t(p)] : 0.5;
            const ChiangHair::LobeDirection d = chiang_.sample_lobe_direction(vt, p, v, u[1], u[0]);
            const Vec3 wi = sp.frame.direction(d.sin_theta_i, d.cos_theta_i, vt.phi_o + d.phi);
            return sample_from_eval(wi, eval(sp, wi), p);
        }
        const int lobe = component - 1;
        const double p0 = sp.node_pick[size_t(lobe)][0] / sp.pick_norm[size_t(lobe)];
        int k = v < p0 ? 0 : 1;
        if (!(sp.node_pick[size_t(lobe)][size_t(k)] > 0)) k = 1 - k;
        double rest;
        const int bin = table_->sample_bin(lobe, sp.node[k], u[1], rest);
        const int t_bin = bin / YanFurTable::kPhi, p_bin = bin % YanFurTable::kPhi;
        double sin_theta_i = clamp(-1.0 + (t_bin + rest) * YanFurTable::bin_width_sin(), -1.0, 1.0);
        if (sp.mirror) sin_theta_i = -sin_theta_i;
        const double w = u[0] < 0.5 ? 2.0 * u[0] : 2.0 * u[0] - 1.0;
        double phi = (p_bin + w) * YanFurTable::bin_width_phi();
        if (u[0] < 0.5) phi = -phi;
        const Vec3 wi = sp.frame.direction(sin_theta_i, cos_from_sin(sin_theta_i), vt.phi_o + phi);
        return sample_from_eval(wi, eval(sp, wi), LobeTTs + lobe);
    }
    BsdfSample sample(const ShadingContext& ctx, const std::array<double, 3>& u) const {
        return sample(prepare(ctx), u);
    }

private:
    YanFurParams params_;
    ChiangHair chiang_;
    std::shared_ptr<const YanFurTable> table_;
};

}  // namespace hairbsdf
