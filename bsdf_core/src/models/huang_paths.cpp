// Huang hair: the paths through the fibre (docs/cycles.md §5.4): entry, TT exit, internal reflection with
// TRT exit and the TRRT+ series, and the TRT estimator with two strategies.
#include "huang_internal.h"

namespace hairbsdf {

RGB HuangHair::trrt_series(double t, double r, RGB a) const {
    // Geometric series of the TRRT+ attenuation (Cycles' bsdf_hair_huang_eval_trrt).
    const double t_avg = std::max(1.0 - r, 1e-5);
    auto ch = [&](double x) { return t * r * r * t_avg * x * x * x / (1.0 - x * (1.0 - t_avg)); };
    return {ch(a.r), ch(a.g), ch(a.b)};
}

// The caller gives sin and cos of gamma (one per node, shared with d gamma / dh); the angles of the
// ellipse are taken from vectors (atan2(b x, z) for atan2(b sin phi, cos phi)), so one sine and cosine
// of gmt serve its two mesonormals, the path length and the exit's arc length.
bool HuangHair::entry_state(const ShadingPoint& sp, double gamma, double sin_gamma, double cos_gamma, double r1,
                            double angle1, EntryState& e) const {
    const Vec3 I = sp.I;
    e.gamma = gamma;
    e.wmi = mesonormal_sc(sin_tilt_, cos_tilt_, sin_gamma, cos_gamma);
    const Vec3 wmi_ = mesonormal_sc(0.0, 1.0, sin_gamma, cos_gamma);
    e.cos_mi1 = dot(I, e.wmi);
    if (!(e.cos_mi1 > 0.0) || !(dot(I, wmi_) > 0.0)) return false;
    Vec3 s1, t1v;
    make_orthonormals(e.wmi, s1, t1v);
    const Vec3 wh1 = vndf_sample(I, e.wmi, s1, t1v, alpha_, r1, angle1);
    const double cos_hi1 = dot(I, wh1);
    if (!(cos_hi1 > 0.0)) return false;
    double cos_t1 = 0.0;
    const double f1 = ggx::fresnel(cos_hi1, eta_, &cos_t1);
    if (!(f1 < 1.0)) return false;  // total internal reflection: nothing enters
    e.wt = ggx::refract(I, wh1, cos_t1, inv_eta_);
    e.mwt = -1.0 * e.wt;
    e.cos_mo1 = dot(e.mwt, e.wmi);
    if (!visible(I, e.mwt, e.wmi, wh1) || !visible(I, e.mwt, wmi_, wh1)) return false;
    e.t1 = 1.0 - f1;
    e.scale1 = energy_scale_entering(e.cos_mi1);
    const double phi_t = b_ == 1.0 ? dir_phi(e.wt) : 0.0;
    e.phi_t_b = b_ == 1.0 ? phi_t : std::atan2(b_ * e.wt.x, e.wt.z);
    e.gmt = 2.0 * e.phi_t_b - gamma;
    e.sin_gmt = std::sin(e.gmt);
    e.cos_gmt = std::cos(e.gmt);
    e.wmt = mesonormal_sc(-sin_tilt_, cos_tilt_, e.sin_gmt, e.cos_gmt);
    e.wmt_ = mesonormal_sc(0.0, 1.0, e.sin_gmt, e.cos_gmt);
    e.cos_mi2 = dot(e.mwt, e.wmt);
    e.g1o = ggx::G2_over_G1(alpha2_, e.cos_mi1, e.cos_mo1);
    double path_t;
    if (b_ == 1.0) {
        path_t = -2.0 * std::cos(gamma - phi_t);
    } else {  // the chord from gamma to gmt + pi: sin(gmt + pi) = -sin(gmt), cos(gmt + pi) = -cos(gmt)
        const double gx = sin_gamma + e.sin_gmt, gz = b_ * (cos_gamma + e.cos_gmt);
        path_t = std::sqrt(gx * gx + gz * gz);
    }
    e.a_t = absorption(path_t, cos_theta(e.wt));
    e.scale2 = energy_scale_leaving(e.cos_mi2);
    return true;
}

RGB HuangHair::tt_exit(const EntryState& e, Vec3 O) const {
    if (!(dot(O, e.wt) >= inv_eta_ - kTirEpsilon)) return {};
    const Vec3 wh2u = e.mwt + inv_eta_ * O;
    // IOR ~ 1 with O along wt: the half vector degenerates (a delta transmission); Cycles returns
    // garbage of either sign there, we return 0. Both cosines are positive for any real refraction.
    const double len = length(wh2u);
    if (!(len > 1e-7)) return {};
    const double inv_len = 1.0 / len;
    const Vec3 wh2 = inv_len * wh2u;
    const double cos_mh2 = dot(e.wmt, wh2);
    if (!(cos_mh2 >= 0.0)) return {};
    const double cos_hi2 = dot(e.mwt, wh2);
    const double cos_ho2 = -dot(O, wh2);
    if (!(cos_hi2 > 0.0) || !(cos_ho2 > 0.0)) return {};
    const double cos_mo2 = -dot(O, e.wmt);
    const double t2 = (1.0 - ggx::fresnel(cos_hi2, inv_eta_)) * e.scale2;
    const double scalar = e.t1 * e.scale1 * t2 * ggx::D(alpha2_, cos_mh2) * e.g1o * ggx::G2(alpha2_, e.cos_mi2, cos_mo2) /
                          e.cos_mo1 * e.cos_mi1 * cos_hi2 * cos_ho2 * inv_len * inv_len * arc_length_sc(e.sin_gmt);
    const RGB v = scalar * e.a_t;
    return isfinite(v) ? v : RGB();
}

Vec3 HuangHair::trt_exit_mesonormal(const EntryState& e, Vec3 wtr, double* sin_gamma, double* cos_gamma) const {
    const double phi_tr_b = b_ == 1.0 ? dir_phi(wtr) : std::atan2(b_ * wtr.x, wtr.z);
    const double gmtr = e.gamma - 2.0 * (e.phi_t_b - phi_tr_b) + kPi;
    const double s = std::sin(gmtr), c = std::cos(gmtr);
    if (sin_gamma) *sin_gamma = s;
    if (cos_gamma) *cos_gamma = c;
    return mesonormal_sc(-sin_tilt_, cos_tilt_, s, c);
}

// The internal reflection at the second interface with microfacet normal wh2 and the exit to O:
// TRT (returned) and the TRRT+ series (trrt; 0 where Cycles does not add it).
RGB HuangHair::trt_internal(const EntryState& e, Vec3 wh2, Vec3 O, RGB& trrt, Vec3* wtr_out, bool trrt_only) const {
    trrt = RGB();
    const double cos_hi2 = dot(e.mwt, wh2);
    if (!(cos_hi2 > 0.0)) return {};
    const double r2f = ggx::fresnel(cos_hi2, inv_eta_);
    const Vec3 wtr = -1.0 * ggx::reflect(e.wt, wh2);
    if (wtr_out) *wtr_out = wtr;
    const Vec3 mwtr = -1.0 * wtr;
    const RGB series = trrt_series(e.t1, r2f, e.a_t);
    if (dot(mwtr, O) < inv_eta_ - kTirEpsilon) {  // total internal reflection at the exit
        trrt = series;
        return {};
    }
    if (!visible(e.mwt, mwtr, e.wmt, wh2) || !visible(e.mwt, mwtr, e.wmt_, wh2)) return {};
    trrt = series;
    if (trrt_only) return {};
    double sin_gmtr, cos_gmtr;
    const Vec3 wmtr = trt_exit_mesonormal(e, wtr, &sin_gmtr, &cos_gmtr);
    const Vec3 wmtr_ = mesonormal_sc(0.0, 1.0, sin_gmtr, cos_gmtr);
    const Vec3 wh3u = wtr + inv_eta_ * O;
    const double len3 = length(wh3u);
    if (!(len3 > 1e-7)) return {};  // degenerate half vector (IOR ~ 1), as in tt_exit
    const double inv_len3 = 1.0 / len3;
    const Vec3 wh3 = inv_len3 * wh3u;
    const double cos_mh3 = dot(wmtr, wh3);
    const Vec3 mO = -1.0 * O;
    if (cos_mh3 < 0.0 || !visible(wtr, mO, wmtr, wh3) || !visible(wtr, mO, wmtr_, wh3)) return {};
    const double cos_hi3 = dot(wh3, wtr);
    const double cos_ho3 = dot(wh3, mO);
    const double cos_mi3 = dot(wmtr, wtr);
    const double t3 = (1.0 - ggx::fresnel(cos_hi3, inv_eta_)) * energy_scale_leaving(cos_mi3);
    double path_tr;
    if (b_ == 1.0) {
        path_tr = 2.0 * std::fabs(std::cos(dir_phi(wtr) - e.gmt));
    } else {
        const double gx = sin_gmtr - e.sin_gmt, gz = b_ * (cos_gmtr - e.cos_gmt);
        path_tr = std::sqrt(gx * gx + gz * gz);
    }
    const RGB a_tr = absorption(path_tr, cos_theta(wtr));
    const double cos_mo2 = dot(e.wmt, mwtr);
    const double scalar = e.t1 * e.scale1 * r2f * e.scale2 * t3 * ggx::D(alpha2_, cos_mh3) * e.g1o *
                          ggx::G2_over_G1(alpha2_, e.cos_mi2, cos_mo2) * ggx::G2(alpha2_, cos_mi3, dot(wmtr, mO)) /
                          (e.cos_mo1 * cos_mo2) * e.cos_mi1 * e.cos_mi2 * cos_hi3 * cos_ho3 * inv_len3 * inv_len3 *
                          arc_length_sc(sin_gmtr);
    const RGB v = scalar * (e.a_t * a_tr);
    return isfinite(v) ? v : RGB();
}

void HuangHair::trt_point(const ShadingPoint& sp, Vec3 O, double gamma, double r1, double angle1, double r2,
                          double angle2, double weight, double final_scale, double trrt_scale,
                          std::array<double, 9>& f) const {
    f.fill(0.0);
    EntryState e;
    if (!entry_state(sp, gamma, r1, angle1, e)) return;
    if (!(factors_[2] > 0.0)) return;
    trt_from_entry(e, O, r2, angle2, weight, final_scale, trrt_scale, f);
}

// Cycles' internal visible normal: of -wt around the internal mesonormal, disk point (r, angle).
Vec3 HuangHair::internal_normal(const EntryState& e, double r, double angle) const {
    Vec3 s, t;
    make_orthonormals(e.wmt, s, t);
    return vndf_sample(e.mwt, e.wmt, s, t, alpha_, r, angle);
}

void HuangHair::trt_from_entry(const EntryState& e, Vec3 O, double r2, double angle2, double weight,
                               double final_scale, double trrt_scale, std::array<double, 9>& f) const {
    const Vec3 wh2 = internal_normal(e, r2, angle2);
    RGB trrt;
    const RGB v = (weight * factors_[2] * final_scale) * trt_internal(e, wh2, O, trrt);
    const RGB t = (weight * trrt_scale) * trrt;
    f[3] = v.r, f[4] = v.g, f[5] = v.b;
    if (isfinite(t)) f[6] = t.r, f[7] = t.g, f[8] = t.b;
}

// TRRT+'s shell (docs/huang.md §4): the TRRT+ series is large only where the internal Fresnel factor is
// between kTrrtShellFresnel and 1, a thin band of the internal normal's angle to -wt just short of
// total internal reflection, which Cycles' visible normals rarely hit. The proposal: the cosine c to
// -wt uniform over that band; the azimuth around -wt wrapped Cauchy around the internal mesonormal's,
// of scale sqrt(alpha^2 + sin^2 d) / sin(theta) (d = theta - beta: the band's angle from the
// mesonormal), about the width of the GGX lobe where the circle of angle theta crosses it. Density in
// solid angle (d omega = dc d psi): 1 / (the band's width in cosine) x the azimuth's density.
namespace {
// The azimuth's scale at cosine c with sin(theta) = sn, for the mesonormal at angle beta.
double shell_azimuth_scale(double cos_beta, double sin_beta, double c, double sn, double alpha) {
    const double sin_d = sn * cos_beta - c * sin_beta;
    return clamp(std::sqrt(alpha * alpha + sin_d * sin_d) / std::max(sn, 1e-6), 1e-6, 50.0);
}
}  // namespace

HuangHair::ShellFrame HuangHair::trrt_shell_frame(const EntryState& e) const {
    ShellFrame f;
    f.a = e.mwt;
    f.cos_beta = clamp(e.cos_mi2, -1.0, 1.0);
    const Vec3 across = e.wmt - f.cos_beta * f.a;  // the mesonormal's part across a
    f.sin_beta = length(across);
    if (f.sin_beta > 1e-9) {
        f.s = (1.0 / f.sin_beta) * across;
        f.t = cross(f.a, f.s);
    } else {
        make_orthonormals(f.a, f.s, f.t);
    }
    return f;
}

Vec3 HuangHair::trrt_shell_sample(const ShellFrame& f, double u2, double u3) const {
    const double c = trrt_shell_lo_ + u2 * (trrt_shell_hi_ - trrt_shell_lo_);
    const double sn = std::sqrt(std::max(1.0 - c * c, 0.0));
    // Wrapped Cauchy by inversion: psi = 2 atan(x), x = tanh(scale / 2) tan(pi (u3 - 1/2)).
    const double x = std::tanh(0.5 * shell_azimuth_scale(f.cos_beta, f.sin_beta, c, sn, alpha_)) * std::tan(kPi * (u3 - 0.5));
    const double cos_psi = (1.0 - x * x) / (1.0 + x * x), sin_psi = 2.0 * x / (1.0 + x * x);
    return (sn * cos_psi) * f.s + (sn * sin_psi) * f.t + c * f.a;
}

double HuangHair::trrt_shell_density(const ShellFrame& f, Vec3 h) const {
    const double c = dot(f.a, h);
    if (!(c > trrt_shell_lo_) || !(c < trrt_shell_hi_)) return 0.0;
    const double sn = std::sqrt(std::max(1.0 - c * c, 0.0));
    const double cos_psi = clamp(dot(h, f.s) / sn, -1.0, 1.0);
    const double rho = std::exp(-shell_azimuth_scale(f.cos_beta, f.sin_beta, c, sn, alpha_));
    const double azimuth = (1.0 - rho * rho) / (kTwoPi * (1.0 + rho * rho - 2.0 * rho * cos_psi));
    return azimuth / (trrt_shell_hi_ - trrt_shell_lo_);
}

double HuangHair::trrt_visible_share(const ShellFrame& f, const Component& visible_normals, Vec3 h) const {
    const double pc = trrt_shell_density(f, h);
    if (!(pc > 0.0)) return 1.0;
    const double pa = vndf_density(visible_normals, h, alpha2_);
    return pa / (pa + pc);
}

RGB HuangHair::trrt_two_strategies(const EntryState& e, const Component& visible_normals, Vec3 wh2, RGB series,
                                   Vec3 O, double u2, double u3, double weight) const {
    RGB sum = weight * series;
    // Off where -wt does not see the internal mesonormal: the visible normals' density is then not one.
    const bool shell = trrt_shell_ && e.cos_mi2 > 0.0 && trrt_shell_hi_ > trrt_shell_lo_;
    if (!shell) return sum;
    const ShellFrame frame = trrt_shell_frame(e);
    if (!is_zero(series)) sum = trrt_visible_share(frame, visible_normals, wh2) * sum;
    const Vec3 h = trrt_shell_sample(frame, u2, u3);
    RGB shell_series;
    trt_internal(e, h, O, shell_series, nullptr, true);
    if (!is_zero(shell_series)) sum += (weight * trrt_visible_share(frame, visible_normals, h)) * shell_series;
    return sum;
}

// TRT with two strategies for the internal direction, combined by the balance heuristic: the
// internal-reflection visible normals (what Cycles samples: density qa of wtr) and refraction of O
// into the fibre through visible normals around the mesonormal of the specular exit point
// (density qb). One point (u2, u3) feeds both; the TRT integrand g qa / (qa + qb) has no exit
// peak left. TRRT+: the first strategy and the shell (trrt_two_strategies). Returns TRT and TRRT+ sums
// (times weight).
void HuangHair::trt_mis_point(const ShadingPoint& sp, Vec3 O, double gamma, double r1, double angle1, double u2,
                              double u3, double weight, RGB& trt_out, RGB& trrt_out) const {
    trt_out = RGB();
    trrt_out = RGB();
    EntryState e;
    if (!entry_state(sp, gamma, r1, angle1, e)) return;
    const double cos_vm = e.cos_mi2;  // visibility of the internal mesonormal from -wt
    Component ca;
    ca.v = e.mwt;
    ca.m = e.wmt;
    make_orthonormals(ca.m, ca.s, ca.t);
    ca.inv_norm = cos_vm > 0.0 ? 1.0 / (cos_vm * (1.0 + ggx::lambda(alpha2_, cos_vm))) : 0.0;
    auto qa = [&](Vec3 wtr) {  // density of wtr = -reflect(wt, h), h ~ visible normals of -wt
        Vec3 h = normalize(e.wt + wtr);
        if (dot(e.mwt, h) < 0.0) h = -1.0 * h;
        const double c = dot(e.mwt, h);
        return c > 0.0 ? vndf_density(ca, h, alpha2_) / (4.0 * c) : 0.0;
    };
    // Proposal for the exit: the mesonormal where the specular internal reflection leaves.
    const Vec3 wtr0 = -1.0 * ggx::reflect(e.wt, e.wmt);
    const Vec3 out_normal = -1.0 * trt_exit_mesonormal(e, wtr0);
    Component cb;
    cb.v = O;
    cb.m = out_normal;
    make_orthonormals(cb.m, cb.s, cb.t);
    const double ob = dot(O, out_normal);
    const bool use_b = ob > 1e-6;
    cb.inv_norm = use_b ? 1.0 / (ob * (1.0 + ggx::lambda(alpha2_, ob))) : 0.0;
    auto qb = [&](Vec3 wtr) {  // density of wtr = refraction of O through h ~ visible normals of O
        if (!use_b) return 0.0;
        const Vec3 hu = -1.0 * (O + eta_ * wtr);
        const double len = length(hu);
        if (!(len > 0.0)) return 0.0;
        const Vec3 h = (1.0 / len) * hu;
        const double oh = dot(O, h), th = dot(wtr, h);
        if (!(oh > 0.0) || !(th < 0.0)) return 0.0;
        const double d = oh + eta_ * th;
        return vndf_density(cb, h, alpha2_) * eta_ * eta_ * std::fabs(th) / (d * d);
    };
    // Strategy A: Cycles' internal visible normal; TRRT+ with its shell.
    {
        const Vec3 wh2 = vndf_sample(ca.v, ca.m, ca.s, ca.t, alpha_, std::sqrt(u2), kTwoPi * u3);
        RGB trrt;
        Vec3 wtr;
        const RGB g = trt_internal(e, wh2, O, trrt, &wtr);
        trrt_out = trrt_two_strategies(e, ca, wh2, trrt, O, u2, u3, weight);
        if (!is_zero(g)) {
            const double a = qa(wtr), b = qb(wtr);
            if (a > 0.0) trt_out += (weight * a / (a + b)) * g;
        }
    }
    // Strategy B: refraction of O into the fibre.
    if (use_b) {
        const Vec3 h = vndf_sample(cb.v, cb.m, cb.s, cb.t, alpha_, std::sqrt(u2), kTwoPi * u3);
        double cos_t = 0.0;
        if (ggx::fresnel(dot(O, h), eta_, &cos_t) < 1.0 && dot(O, h) > 0.0) {
            const Vec3 wtr = ggx::refract(O, h, cos_t, inv_eta_);
            Vec3 wh2 = normalize(e.wt + wtr);
            if (dot(e.mwt, wh2) < 0.0) wh2 = -1.0 * wh2;
            const double a = qa(wtr), b = qb(wtr);
            if (a > 0.0 && b > 0.0) {
                RGB trrt;
                const RGB g = trt_internal(e, wh2, O, trrt);
                trt_out += (weight * a / (a + b)) * g;
            }
        }
    }
}

}  // namespace hairbsdf
