// Huang hair: parameters, cross-section geometry, setup of a shading point (frame, visible
// interval, Simpson nodes) and the R integrand. Formulas: docs/cycles.md §5 and docs/huang.md;
// directions named as in Cycles' local frame: I = the viewer (Cycles' wi), O = the light (Cycles' wo).
// The rest: huang_paths.cpp (paths through the fibre), huang_eval.cpp, huang_sample.cpp.
#include "huang_internal.h"

namespace hairbsdf {

HuangHair::HuangHair(const HuangHairParams& params)
    : params_(params),
      trrt_m_(4.0 * clamp(params.roughness, 0.001, 1.0), Accuracy::Cycles),
      trrt_sampler_(4.0 * clamp(params.roughness, 0.001, 1.0), Accuracy::Exact) {
    alpha_ = clamp(std::isfinite(params.roughness) ? params.roughness : 0.3, 0.001, 1.0);
    alpha2_ = alpha_ * alpha_;
    sqrt_alpha_ = std::sqrt(alpha_);
    tilt_ = -params.offset;
    tan_tilt_ = std::tan(tilt_);
    sin_tilt_ = std::sin(tilt_);
    cos_tilt_ = std::cos(tilt_);
    double b = params.aspect_ratio;
    if (b > 1.0) b = 1.0 / b;  // Cycles swaps the axes; the major axis stays on the normal (docs/huang.md §1)
    b_ = clamp(std::isfinite(b) ? b : 1.0, 1e-4, 1.0);
    e2_ = 1.0 - b_ * b_;
    eta_ = params.eta;
    inv_eta_ = 1.0 / eta_;
    // TRRT+'s shell: from the critical cosine of total internal reflection (inside, relative index
    // 1 / eta) up to where the internal Fresnel factor falls to kTrrtShellFresnel (it decreases with
    // the cosine). No shell where eta <= 1 (no total internal reflection).
    trrt_shell_lo_ = trrt_shell_hi_ = 0.0;
    if (eta_ > 1.0) {
        trrt_shell_lo_ = std::sqrt(1.0 - inv_eta_ * inv_eta_);
        double lo = trrt_shell_lo_, hi = 1.0;
        if (ggx::fresnel(hi, inv_eta_) >= kTrrtShellFresnel) lo = hi;
        for (int k = 0; k < 60 && lo < hi; ++k) {
            const double mid = 0.5 * (lo + hi);
            (ggx::fresnel(mid, inv_eta_) > kTrrtShellFresnel ? lo : hi) = mid;
        }
        trrt_shell_hi_ = hi;
    }
    z_eta_ = huang::energy_scale_z(eta_);
    z_inv_eta_ = huang::energy_scale_z(inv_eta_);
    factors_ = {std::max(params.r_factor, 0.0), std::max(params.tt_factor, 0.0), std::max(params.trt_factor, 0.0)};
    fill_lane_constants();
}

void HuangHair::fill_lane_constants() {
    HuangLaneConstants& l = lanes_;
    l.alpha = float(alpha_);
    l.alpha2 = float(alpha2_);
    l.sin_tilt = float(sin_tilt_);
    l.cos_tilt = float(cos_tilt_);
    l.b = float(b_);
    l.e2 = float(e2_);
    l.eta = float(eta_);
    l.inv_eta = float(inv_eta_);
    l.sigma_a[0] = float(params_.sigma_a.r);
    l.sigma_a[1] = float(params_.sigma_a.g);
    l.sigma_a[2] = float(params_.sigma_a.b);
    l.shell_lo = float(trrt_shell_lo_);
    l.shell_hi = float(trrt_shell_hi_);
    l.circular = b_ == 1.0;
    const bool v5 = params_.glass_albedo_table == GlassAlbedoTable::Cycles5;
    l.sqrt_mu = v5;
    l.row_size = v5 ? 32 : 16;
    // The row at the table's mu nodes j / (n - 1) (sqrt(mu) nodes for Cycles 5.x), by the table's own lookup.
    for (int j = 0; j < l.row_size; ++j) {
        const double y = double(j) / double(l.row_size - 1);
        auto row = [&](double eta, double z) {
            const int which = huang::glass_albedo_side(eta);
            return float(v5 ? huang::lookup_table_3d(huang::kGgxGlassAlbedo5[which], sqrt_alpha_, y, z)
                            : huang::lookup_table_3d(huang::kGgxGlassAlbedo[which], sqrt_alpha_, y, z));
        };
        l.energy_entering[j] = row(eta_, z_eta_);
        l.energy_leaving[j] = row(inv_eta_, z_inv_eta_);
    }
}

// --- cross-section geometry (docs/cycles.md §5.1) ----------------------------------------------

double HuangHair::h_to_gamma(double h_div_r, Vec3 w) const {
    if (b_ == 1.0) return -safe_asin(h_div_r);
    return std::atan2(w.z, -b_ * w.x) - std::acos(clamp(-h_div_r, -1.0, 1.0));
}

double HuangHair::dgamma_dh(double sin_phi, double cos_phi, double gamma) const {
    return dgamma_dh_sc(sin_phi, cos_phi, std::sin(gamma), std::cos(gamma));
}

Vec3 HuangHair::mesonormal(double tilt, double gamma) const {
    return mesonormal_sc(std::sin(tilt), std::cos(tilt), std::sin(gamma), std::cos(gamma));
}

double HuangHair::arc_length(double gamma) const { return arc_length_sc(std::sin(gamma)); }

RGB HuangHair::absorption(double path, double cos_t) const {
    const RGB s = params_.sigma_a;
    auto ch = [&](double sigma) {
        if (sigma == 0.0) return 1.0;
        return std::exp(-sigma * path / cos_t);
    };
    return {ch(s.r), ch(s.g), ch(s.b)};
}

// --- setup ------------------------------------------------------------------------------------

void HuangHair::set_frame(const ShadingContext& ctx, ShadingPoint& sp) const {
    const Vec3 T = ctx.tangent;
    Vec3 x;
    if (b_ == 1.0) {
        x = normalize(cross(T, ctx.wo));
    } else {
        x = normalize(cross(T, normalize(cross(ctx.normal, T))));
    }
    if (!(dot(x, x) > 0.5) || !isfinite(x)) {
        Vec3 a, bb;
        make_orthonormals(T, a, bb);  // Cycles: make_orthonormals(Y, &Z, &N)
        sp.z = a;
        sp.x = bb;
    } else {
        sp.x = x;
        sp.z = normalize(cross(x, T));
    }
    sp.y = T;
    sp.I = to_local(sp, ctx.wo);
    const Vec3 I = sp.I;
    const double ct = cos_theta(I);
    sp.sin_phi_i = ct > 0 ? I.x / ct : 0.0;
    sp.cos_phi_i = ct > 0 ? I.z / ct : 1.0;
    sp.r = e2_ == 0.0 ? 1.0 : std::sqrt(std::max(1.0 - e2_ * I.x * I.x / std::max(I.x * I.x + I.z * I.z, 1e-300), 0.0));
    sp.gamma_base = b_ == 1.0 ? 0.0 : std::atan2(I.z, -b_ * I.x);
    sp.h = ctx.h;
    sp.transparent = !(std::fabs(ctx.h) < sp.r);
}

HuangHair::ShadingPoint HuangHair::prepare(const ShadingContext& ctx) const {
    ShadingPoint sp;
    set_frame(ctx, sp);
    const Vec3 I = sp.I;
    const double ct = cos_theta(I);
    if (sp.transparent || !(ct > 0) || !isfinite(I)) return sp;

    // Visible interval of h (docs/cycles.md §5.2).
    const double half_span = std::acos(std::max(-tan_tilt_ * (I.y / ct), 0.0));
    if (std::isnan(half_span)) return sp;
    const double phi_i = b_ == 1.0 ? 0.0 : dir_phi(I);
    auto phi_to_h = [&](double phi) {
        if (b_ == 1.0) return -std::sin(phi);
        const double g = std::atan2(std::sin(phi), b_ * std::cos(phi));
        return -sp.cos_phi_i * std::sin(g) + b_ * sp.sin_phi_i * std::cos(g);
    };
    double lo = phi_to_h(phi_i + half_span), hi = phi_to_h(phi_i - half_span);
    double dh = 2.0;
    sp.near_field = ctx.near_field && sp.r > ctx.pixel_coverage;
    if (sp.near_field) {
        const double nlo = std::max(-sp.r, ctx.h - ctx.pixel_coverage);
        const double nhi = std::min(sp.r, ctx.h + ctx.pixel_coverage);
        dh = (nhi - nlo) / sp.r;
        lo = std::max(lo, nlo);
        hi = std::min(hi, nhi);
    }
    lo = std::max(lo / sp.r, -kHClamp);
    hi = std::min(hi / sp.r, kHClamp);
    if (!(lo < hi) || !(dh > 0)) return sp;
    sp.h_lo = lo;
    sp.h_hi = hi;
    sp.norm = 1.0 / (ct * dh);
    sp.valid = std::isfinite(sp.norm);
    if (!sp.valid) return sp;

    if (params_.quadrature == HuangQuadrature::Cycles) {
        sp.r_nodes = simpson_nodes(lo, hi, kRStep);
        sp.residual_nodes = simpson_nodes(lo, hi, kResidualStep);
    }
    if (params_.mixture_detail != HuangHairParams::MixtureDetail::None) build_sampler(sp);
    return sp;
}

std::vector<HuangHair::Node> HuangHair::simpson_nodes(double lo, double hi, double step) const {
    const double range = hi - lo;
    const long n = 2 * long(std::ceil(range / (step * alpha_) * 0.5)) * simpson_refinement_;
    const double res = range / double(n);
    std::vector<Node> nodes(size_t(n + 1));
    for (long i = 0; i <= n; ++i) {
        const double w = (i == 0 || i == n) ? 0.5 : double(i % 2 + 1);
        nodes[size_t(i)] = {lo + double(i) * res, w * (2.0 / 3.0) * res};
    }
    return nodes;
}

// --- R lobe (docs/cycles.md §5.3) ----------------------------------------------------------------

double HuangHair::r_integrand_sc(const ShadingPoint& sp, Vec3 O, Vec3 wh, double sin_gamma, double cos_gamma) const {
    const Vec3 wm = mesonormal_sc(sin_tilt_, cos_tilt_, sin_gamma, cos_gamma);
    const Vec3 macro{wm.x, 0.0, wm.z};
    const Vec3 I = sp.I;
    if (!visible(I, O, macro, wh)) return 0.0;
    const double cos_mi = dot(wm, I);
    return ggx::D(alpha2_, dot(wm, wh)) * ggx::G2(alpha2_, cos_mi, dot(wm, O)) * arc_length_sc(sin_gamma) *
           energy_scale_entering(cos_mi);
}

double HuangHair::r_integrand_gamma(const ShadingPoint& sp, Vec3 O, Vec3 wh, double gamma) const {
    return r_integrand_sc(sp, O, wh, std::sin(gamma), std::cos(gamma));
}

// One sine and cosine of gamma per node, shared by the mesonormal, the arc length and d gamma / dh.
double HuangHair::r_integrand(const ShadingPoint& sp, Vec3 O, Vec3 wh, double h) const {
    const double gamma = h_to_gamma(sp, h);
    const double sin_gamma = std::sin(gamma), cos_gamma = std::cos(gamma);
    const double v = r_integrand_sc(sp, O, wh, sin_gamma, cos_gamma);
    return v == 0.0 ? 0.0 : v * dgamma_dh_sc(sp.sin_phi_i, sp.cos_phi_i, sin_gamma, cos_gamma);
}

}  // namespace hairbsdf
