// Huang hair: the mixture sampler with its exact pdf, and Cycles' sampler (pdf reported as 1).
#include "huang_internal.h"

#include <cstring>

namespace hairbsdf {

// --- sampling mixture ---------------------------------------------------------------------------

HuangHair::Component HuangHair::component(Vec3 v, Vec3 m, double probability) const {
    Component c;
    c.v = v;
    c.m = m;
    make_orthonormals(m, c.s, c.t);
    const double vm = dot(v, m);
    c.inv_norm = 1.0 / (vm * (1.0 + ggx::lambda(alpha2_, vm)));
    c.probability = probability;
    return c;
}

// O = refraction of v out of the fibre through h, h ~ visible normals of v around c.m.
bool HuangHair::exit_sample(const Component& c, double r, double angle, Vec3& O) const {
    const Vec3 h = vndf_sample(c.v, c.m, c.s, c.t, alpha_, r, angle);
    double cos_t = 0.0;
    if (!(ggx::fresnel(dot(c.v, h), inv_eta_, &cos_t) < 1.0) || !(dot(c.v, h) > 0.0)) return false;
    O = ggx::refract(c.v, h, cos_t, eta_);
    return true;
}

// h = normalize(eta v + O), Jacobian |O.h| / (eta v.h + O.h)^2.
double HuangHair::exit_density(const Component& c, Vec3 O) const {
    const Vec3 hu = eta_ * c.v + O;
    const double len = length(hu);
    if (!(len > 0.0)) return 0.0;
    const Vec3 h = (1.0 / len) * hu;
    const double vh = dot(c.v, h), oh = dot(O, h);
    if (!(vh > 0.0) || !(oh < 0.0)) return 0.0;
    const double denom = eta_ * vh + oh;
    return vndf_density(c, h, alpha2_) * std::fabs(oh) / (denom * denom);
}

Vec3 HuangHair::reflection_sample(const Component& c, double r, double angle) const {
    const Vec3 h = vndf_sample(c.v, c.m, c.s, c.t, alpha_, r, angle);
    return (2.0 * dot(c.v, h)) * h - c.v;
}

// h = normalize(I + O), Jacobian 1 / (4 I.h).
double HuangHair::reflection_density(Vec3 I, Vec3 O, const Component* components, size_t count,
                                     double probability) const {
    const Vec3 sum = I + O;
    const double len = length(sum);
    if (!(len > 0.0)) return 0.0;
    const Vec3 h = (1.0 / len) * sum;
    const double ih = dot(I, h);
    if (!(ih > 0.0)) return 0.0;
    double q = 0.0;
    for (size_t k = 0; k < count; ++k) q += components[k].probability * vndf_density(components[k], h, alpha2_);
    return probability * q / (4.0 * ih);
}

Vec3 HuangHair::trrt_direction(Vec3 I, double u0, double u1, double u_phi) const {
    const double v = 4.0 * alpha_;
    const double st = sample_longitudinal(v, std::exp(-2.0 / v), u0, u1, I.y, cos_theta(I));
    const double ct = cos_from_sin(st), phi = kTwoPi * u_phi;
    return {std::sin(phi) * ct, st, std::cos(phi) * ct};
}

double HuangHair::trrt_density(Vec3 I, Vec3 O, double probability) const {
    return probability * trrt_sampler_.eval(O.y, cos_theta(O), I.y, cos_theta(I)) * kInvTwoPi;
}

void HuangHair::build_sampler(ShadingPoint& sp) const {
    const Vec3 I = sp.I;
    const double lo = sp.h_lo, hi = sp.h_hi, range = hi - lo;
    auto make = [&](Vec3 v, Vec3 m, double p) { return component(v, m, p); };
    // Component counts: h positions per lobe and entry / internal-reflection points per h.
    const bool coarse = params_.mixture_detail == HuangHairParams::MixtureDetail::Coarse;
    const double max_r = coarse ? 12.0 : 48.0, max_tt = coarse ? 4.0 : 16.0, max_trt = coarse ? 2.0 : 8.0;
    const int tt_grid = coarse ? 2 : 3;   // tt_grid x tt_grid entry points
    const int trt_entries = coarse ? 2 : 4;  // of the 2 x 2 disk grid (coarse: two opposite corners)
    // R: visible-normal reflection around mesonormals spread uniformly in h (Cycles samples h uniformly).
    double e_r = 0.0;
    const int k_r = int(clamp(std::ceil(range / (0.5 * alpha_)), 1.0, max_r));
    for (int k = 0; k < k_r; ++k) {
        const double h = lo + (k + 0.5) * range / k_r;
        const double gamma = h_to_gamma(h, I);
        const Vec3 wm = mesonormal(tilt_, gamma), macro = mesonormal(0.0, gamma);
        if (!(dot(I, wm) > 1e-6) || !(dot(I, macro) > 0.0)) continue;
        sp.reflection.push_back(make(I, wm, 1.0));
        e_r += ggx::fresnel(dot(I, wm), eta_);
    }
    e_r *= factors_[0] / k_r;

    // Deterministic internal paths: entry refraction at (gamma, disk point) -> direction wt and the
    // exit (TT) or internal-reflection (TRT) mesonormal.
    struct Entry {
        bool ok = false;
        Vec3 wt, wmt;
        double gamma = 0, gmt = 0, phi_t_b = 0, t1 = 0;
        RGB a_t;
    };
    auto entry = [&](double gamma, double r, double ang) {
        Entry e;
        const Vec3 wmi = mesonormal(tilt_, gamma), wmi_ = mesonormal(0.0, gamma);
        if (!(dot(I, wmi) > 1e-6) || !(dot(I, wmi_) > 0.0)) return e;
        Vec3 s, t;
        make_orthonormals(wmi, s, t);
        const Vec3 wh1 = vndf_sample(I, wmi, s, t, alpha_, r, ang);
        double cos_t = 0.0;
        const double f1 = ggx::fresnel(dot(I, wh1), eta_, &cos_t);
        if (!(f1 < 1.0) || !(dot(I, wh1) > 0)) return e;
        e.wt = ggx::refract(I, wh1, cos_t, inv_eta_);
        if (!(dot(-1.0 * e.wt, wmi_) > 0.0)) return e;
        const double phi_t = dir_phi(e.wt);
        e.phi_t_b = b_ == 1.0 ? phi_t : std::atan2(b_ * std::sin(phi_t), std::cos(phi_t));
        e.gmt = 2.0 * e.phi_t_b - gamma;
        e.wmt = mesonormal(-tilt_, e.gmt);
        double path;
        if (b_ == 1.0) {
            path = -2.0 * std::cos(gamma - phi_t);
        } else {
            const double gx = std::sin(gamma) - std::sin(e.gmt + kPi), gz = b_ * (std::cos(gamma) - std::cos(e.gmt + kPi));
            path = std::sqrt(gx * gx + gz * gz);
        }
        e.a_t = absorption(path, cos_theta(e.wt));
        e.t1 = 1.0 - f1;
        e.gamma = gamma;
        e.ok = dot(-1.0 * e.wt, e.wmt) > 1e-6 && isfinite(e.a_t);
        return e;
    };
    std::vector<Component> tt, trt;
    std::vector<double> tt_e, trt_e;
    double e_tt = 0.0, e_trt = 0.0, e_trrt = 0.0;
    long tt_tries = 0, trt_tries = 0;
    if (factors_[1] > 0.0) {
        const int k_t = int(clamp(std::ceil(range / alpha_), 1.0, max_tt));
        for (int k = 0; k < k_t; ++k) {
            const double gamma = h_to_gamma(lo + (k + 0.5) * range / k_t, I);
            for (int i = 0; i < tt_grid; ++i) {
                for (int j = 0; j < tt_grid; ++j) {
                    ++tt_tries;
                    const Entry e = entry(gamma, std::sqrt((i + 0.5) / tt_grid), kTwoPi * (j + 0.5) / tt_grid);
                    if (!e.ok) continue;
                    const Vec3 v = -1.0 * e.wt;
                    const double w = e.t1 * luminance(e.a_t) * (1.0 - ggx::fresnel(dot(v, e.wmt), inv_eta_));
                    if (!(w > 0.0)) continue;
                    tt.push_back(make(v, e.wmt, w));
                    e_tt += w;
                }
            }
        }
        e_tt *= factors_[1] / double(std::max(tt_tries, 1L));
    }
    if (factors_[2] > 0.0) {
        const int k_t = int(clamp(std::ceil(range / alpha_), 1.0, max_trt));
        for (int k = 0; k < k_t; ++k) {
            const double gamma = h_to_gamma(lo + (k + 0.5) * range / k_t, I);
            for (int n = 0; n < trt_entries; ++n) {
                const int i = coarse ? 3 * n : n;
                const Entry e = entry(gamma, std::sqrt((i / 2 + 0.5) / 2.0), kTwoPi * (i % 2 + 0.5) / 2.0);
                for (int j = 0; j < 4; ++j) {
                    ++trt_tries;
                    if (!e.ok) continue;
                    const Vec3 mwt = -1.0 * e.wt;
                    Vec3 s, t;
                    make_orthonormals(e.wmt, s, t);
                    const Vec3 wh2 = vndf_sample(mwt, e.wmt, s, t, alpha_, std::sqrt((j / 2 + 0.5) / 2.0),
                                                 kTwoPi * (j % 2 + 0.5) / 2.0);
                    const double r2 = ggx::fresnel(dot(mwt, wh2), inv_eta_);
                    const Vec3 wtr = -1.0 * ggx::reflect(e.wt, wh2);
                    if (!(dot(-1.0 * wtr, e.wmt) > 0.0)) continue;
                    const double phi_tr = dir_phi(wtr);
                    const double phi_tr_b = b_ == 1.0 ? phi_tr : std::atan2(b_ * std::sin(phi_tr), std::cos(phi_tr));
                    const double gmtr = e.gamma - 2.0 * (e.phi_t_b - phi_tr_b) + kPi;
                    const Vec3 wmtr = mesonormal(-tilt_, gmtr);
                    if (!(dot(wtr, wmtr) > 1e-6)) continue;
                    double path;
                    if (b_ == 1.0) {
                        path = 2.0 * std::fabs(std::cos(phi_tr - e.gmt));
                    } else {
                        const double gx = std::sin(gmtr) - std::sin(e.gmt), gz = b_ * (std::cos(gmtr) - std::cos(e.gmt));
                        path = std::sqrt(gx * gx + gz * gz);
                    }
                    const RGB a = e.a_t * absorption(path, cos_theta(wtr));
                    const double w = e.t1 * r2 * luminance(a) * (1.0 - ggx::fresnel(dot(wtr, wmtr), inv_eta_));
                    e_trrt += luminance(trrt_series(e.t1, r2, e.a_t));
                    if (!(w > 0.0) || !std::isfinite(w)) continue;
                    trt.push_back(make(wtr, wmtr, w));
                    e_trt += w;
                }
            }
        }
        e_trt *= factors_[2] / double(std::max(trt_tries, 1L));
        e_trrt /= double(std::max(trt_tries, 1L));
    }
    auto normalise = [](std::vector<Component>& cs) {
        double sum = 0.0;
        for (const Component& c : cs) sum += c.probability;
        for (Component& c : cs) c.probability /= sum;
    };
    if (sp.reflection.empty()) e_r = 0.0;
    if (tt.empty()) e_tt = 0.0;
    if (trt.empty()) e_trt = 0.0;
    normalise(sp.reflection);
    normalise(tt);
    normalise(trt);
    sp.tt_count = tt.size();
    sp.exits = std::move(tt);
    sp.exits.insert(sp.exits.end(), trt.begin(), trt.end());
    // Exit components carry their lobe's probability so pdf sums them in one loop.
    const double e_sum = e_r + e_tt + e_trt + e_trrt;
    const double u = kUniformProbability;
    if (e_sum > 0.0 && std::isfinite(e_sum)) {
        sp.lobe_probability = {(1 - u) * e_r / e_sum, (1 - u) * e_tt / e_sum, (1 - u) * e_trt / e_sum,
                               (1 - u) * e_trrt / e_sum, u};
    } else {
        sp.lobe_probability = {0, 0, 0, 0, 1.0};
    }
}

double HuangHair::pdf_local(const ShadingPoint& sp, Vec3 O) const {
    if (!sp.valid) return 0.0;
    const Vec3 I = sp.I;
    double p = uniform_sphere_density(sp.lobe_probability[4]);
    // R: O = reflect of I about h.
    if (sp.lobe_probability[0] > 0.0)
        p += reflection_density(I, O, sp.reflection.data(), sp.reflection.size(), sp.lobe_probability[0]);
    // TT / TRT: refraction out of the fibre.
    for (size_t k = 0; k < sp.exits.size(); ++k) {
        const Component& c = sp.exits[k];
        p += sp.lobe_probability[k < sp.tt_count ? 1 : 2] * c.probability * exit_density(c, O);
    }
    // TRRT+: Chiang's longitudinal lobe with v = 4 alpha around -theta_I, uniform in phi.
    if (sp.lobe_probability[3] > 0.0) p += trrt_density(I, O, sp.lobe_probability[3]);
    return std::isfinite(p) ? p : 0.0;
}

int HuangHair::sample_direction(const ShadingPoint& sp, const std::array<double, 3>& u, Vec3& O) const {
    const int none = -1;
    if (sp.transparent || !sp.valid || params_.mixture_detail == HuangHairParams::MixtureDetail::None) return none;
    // Lobe, then component, from u[2].
    double ul = u[2];
    int lobe = 4;
    for (int k = 0; k < 5; ++k) {
        const double p = sp.lobe_probability[size_t(k)];
        if (ul < p || k == 4) {
            lobe = k;
            ul = p > 0 ? clamp(ul / p, 0.0, 1.0) : 0.5;
            break;
        }
        ul -= p;
    }
    auto pick = [&](const Component* cs, size_t n) -> const Component* {
        if (n == 0) return nullptr;
        double x = ul;
        for (size_t k = 0; k < n; ++k) {
            if (x < cs[k].probability || k + 1 == n) return &cs[k];
            x -= cs[k].probability;
        }
        return &cs[n - 1];
    };
    const double r = std::sqrt(u[0]), ang = kTwoPi * u[1];
    if (lobe == 0) {
        const Component* c = pick(sp.reflection.data(), sp.reflection.size());
        if (!c) return none;
        O = reflection_sample(*c, r, ang);
    } else if (lobe == 1 || lobe == 2) {
        const Component* c = lobe == 1 ? pick(sp.exits.data(), sp.tt_count)
                                       : pick(sp.exits.data() + sp.tt_count, sp.exits.size() - sp.tt_count);
        if (!c || !exit_sample(*c, r, ang, O)) return none;
    } else if (lobe == 3) {
        O = trrt_direction(sp.I, u[0], u[1], ul);
    } else {
        O = uniform_sphere_direction(u[0], u[1]);
    }
    O = normalize(O);
    if (!isfinite(O) || !(length(O) > 0.5)) return none;
    return std::min(lobe, 3);
}

BsdfSample HuangHair::sample(const ShadingPoint& sp, const std::array<double, 3>& u) const {
    BsdfSample out;
    if (sp.transparent || !sp.valid) return out;
    if (params_.sampler == HuangSampler::Cycles) return sample_cycles(sp, u);
    Vec3 O;
    const int lobe = sample_direction(sp, u, O);
    if (lobe < 0) return out;

    BsdfEval e;
    e.lobes = eval_local(sp, O);
    e.pdf = pdf_local(sp, O);
    return sample_from_eval(to_world(sp, O), e, lobe);
}

// --- Cycles' sampler (pdf reported as 1) --------------------------------------------------------

BsdfSample HuangHair::sample_cycles(const ShadingPoint& sp, const std::array<double, 3>& u) const {
    BsdfSample out;
    // Cycles draws five more numbers from the shading point's LCG; here the LCG is seeded from u.
    uint64_t bits[3];
    std::memcpy(bits, u.data(), sizeof(bits));
    uint32_t rng = uint32_t(lookup3_hash_uint2(uint32_t(bits[0] ^ (bits[0] >> 32)),
                                               uint32_t(bits[1] ^ (bits[1] >> 32)) ^ uint32_t(bits[2] ^ (bits[2] >> 29))));
    const Vec3 I = sp.I;
    const double h_div_r = sp.near_field ? sp.h / sp.r : clamp(2.0 * u[1] - 1.0, -1.0, 1.0);
    const double gamma = h_to_gamma(h_div_r, I);
    const Vec3 wmi_ = mesonormal(0.0, gamma);
    const Vec3 wmi = mesonormal(tilt_, gamma);
    const double cos_mi1 = dot(wmi, I);
    if (cos_mi1 < 0.0 || dot(wmi_, I) < 0.0) return out;
    auto sample_wh = [&](Vec3 v, Vec3 m, double a, double b) {
        Vec3 s, t;
        make_orthonormals(m, s, t);
        return vndf_sample(v, m, s, t, alpha_, std::sqrt(a), kTwoPi * b);
    };
    const double h1b = lcg_step_float(rng);
    const Vec3 wh1 = sample_wh(I, wmi, u[2], h1b);
    const double h2a = lcg_step_float(rng), h2b = lcg_step_float(rng), h3a = lcg_step_float(rng), h3b = lcg_step_float(rng);
    const Vec3 wr = -1.0 * ggx::reflect(I, wh1);
    if (!visible(I, wmi_, wh1)) return out;
    double cos_t1 = 0.0;
    const double r1 = ggx::fresnel(dot(I, wh1), eta_, &cos_t1);
    const double scale1 = energy_scale_entering(cos_mi1);
    const double R = factors_[0] * r1 * scale1 * (visible(wr, wmi_, wh1) ? 1.0 : 0.0) *
                     ggx::G2_over_G1(alpha2_, cos_mi1, dot(wmi, wr));
    RGB TT, TRT, TRRT;
    Vec3 wtt, wtrt, wtrrt;
    if (r1 < 1.0) {
        const Vec3 wt = ggx::refract(I, wh1, cos_t1, inv_eta_);
        const Vec3 mwt = -1.0 * wt;
        const double phi_t = dir_phi(wt);
        const double phi_t_b = b_ == 1.0 ? phi_t : std::atan2(b_ * std::sin(phi_t), std::cos(phi_t));
        const double gmt = 2.0 * phi_t_b - gamma;
        const Vec3 wmt = mesonormal(-tilt_, gmt), wmt_ = mesonormal(0.0, gmt);
        const Vec3 wh2 = sample_wh(mwt, wmt, h2a, h2b);
        const Vec3 wtr = -1.0 * ggx::reflect(wt, wh2);
        const double cos_mi2 = dot(mwt, wmt);
        if (cos_mi2 > 0.0 && visible(mwt, wmi_, wh1) && visible(mwt, wmt_, wh2)) {
            double path;
            if (b_ == 1.0) {
                path = -2.0 * std::cos(phi_t - gamma);
            } else {
                const double gx = std::sin(gamma) - std::sin(gmt + kPi), gz = b_ * (std::cos(gamma) - std::cos(gmt + kPi));
                path = std::sqrt(gx * gx + gz * gz);
            }
            const RGB a_t = absorption(path, cos_theta(wt));
            double cos_t2 = 0.0;
            const double r2 = ggx::fresnel(dot(mwt, wh2), inv_eta_, &cos_t2);
            const double t1 = (1.0 - r1) * scale1 * ggx::G2_over_G1(alpha2_, cos_mi1, dot(wmi, mwt));
            const double t2 = 1.0 - r2;
            const double scale2 = energy_scale_leaving(cos_mi2);
            if (t2 > 0.0) {
                wtt = ggx::refract(mwt, wh2, cos_t2, eta_);
                const Vec3 mwtt = -1.0 * wtt;
                if (dot(wmt, mwtt) > 0.0 && visible(mwtt, wmt_, wh2))
                    TT = (factors_[1] * t1 * t2 * scale2 * ggx::G2_over_G1(alpha2_, cos_mi2, dot(wmt, mwtt))) * a_t;
            }
            const double phi_tr = dir_phi(wtr);
            const double phi_tr_b = b_ == 1.0 ? phi_tr : std::atan2(b_ * std::sin(phi_tr), std::cos(phi_tr));
            const double gmtr = gamma - 2.0 * (phi_t_b - phi_tr_b) + kPi;
            const Vec3 wmtr = mesonormal(-tilt_, gmtr);
            const Vec3 wh3 = sample_wh(wtr, wmtr, h3a, h3b);
            double cos_t3 = 0.0;
            const double r3 = ggx::fresnel(dot(wtr, wh3), inv_eta_, &cos_t3);
            const double cos_mi3 = dot(wmtr, wtr);
            if (cos_mi3 > 0.0) {
                double path_tr;
                if (b_ == 1.0) {
                    path_tr = 2.0 * std::fabs(std::cos(phi_tr - gmt));
                } else {
                    const double gx = std::sin(gmt) - std::sin(gmtr), gz = b_ * (std::cos(gmt) - std::cos(gmtr));
                    path_tr = std::sqrt(gx * gx + gz * gz);
                }
                const RGB a_tr = absorption(path_tr, cos_theta(wtr));
                const RGB tr = (t1 * r2 * scale2 * energy_scale_leaving(cos_mi3) *
                                ggx::G2_over_G1(alpha2_, cos_mi2, dot(wmt, -1.0 * wtr))) * (a_t * a_tr);
                const double t3 = 1.0 - r3;
                if (t3 > 0.0) {
                    wtrt = ggx::refract(wtr, wh3, cos_t3, eta_);
                    const Vec3 mwtrt = -1.0 * wtrt;
                    if (visible(wtr, mwtrt, Vec3{wmtr.x, 0.0, wmtr.z}, wh3))
                        TRT = (factors_[2] * t3 * ggx::G2_over_G1(alpha2_, cos_mi3, dot(wmtr, mwtrt))) * tr;
                }
                const double rand_theta = std::max(lcg_step_float(rng), 1e-5);
                const double fac = 1.0 + 4.0 * alpha_ * std::log(rand_theta + (1.0 - rand_theta) * std::exp(-0.5 / alpha_));
                const double st = -fac * I.y + cos_from_sin(fac) * std::cos(kTwoPi * lcg_step_float(rng)) * cos_theta(I);
                const double ct = cos_from_sin(st);
                const double phi = kTwoPi * lcg_step_float(rng);
                wtrrt = {std::sin(phi) * ct, st, std::cos(phi) * ct};
                const RGB a_avg(std::sqrt(a_t.r * a_tr.r), std::sqrt(a_t.g * a_tr.g), std::sqrt(a_t.b * a_tr.b));
                const double t_avg = std::max(0.5 * (t2 + t3), 1e-5);
                auto res = [&](double a) { return a * t_avg / (1.0 - a * (1.0 - t_avg)); };
                TRRT = (r3 * ggx::G2_over_G1(alpha2_, cos_mi3, dot(wmtr, -1.0 * ggx::reflect(wtr, wh3)))) *
                       (tr * RGB(res(a_avg.r), res(a_avg.g), res(a_avg.b)));
            }
        }
    }
    const double tt = average(TT), trt = average(TRT), trrt = average(TRRT);
    const double total = R + tt + trt + trrt;
    if (!(total > 0.0) || !std::isfinite(total)) return out;
    double sl = u[0] * total;
    Vec3 O;
    RGB weight;
    int lobe;
    if (sl < R) {
        O = wr, weight = RGB(total), lobe = 0;
    } else if (sl < R + tt) {
        O = wtt, weight = (total / tt) * TT, lobe = 1;
    } else if (sl < R + tt + trt) {
        O = wtrt, weight = (total / trt) * TRT, lobe = 2;
    } else {
        O = wtrrt, weight = (total / trrt) * TRRT, lobe = 3;
    }
    if (!isfinite(weight) || !isfinite(O)) return out;
    out.wi = to_world(sp, O);
    out.weight = weight;
    out.value = weight;
    out.pdf = 1.0;
    out.lobe = lobe;
    return out;
}

}  // namespace hairbsdf
