// Huang hair: setup, deterministic eval, mixture sampler and pdf, Cycles' stochastic eval and
// sampler. Formulas: cycles-hair-notes §5 and docs/huang.md; directions named as in Cycles'
// local frame: I = the viewer (Cycles' wi), O = the light (Cycles' wo).
#include "hairbsdf/models/huang.h"

#include <cstring>

namespace hairbsdf {

namespace {

constexpr double kHClamp = 0.999;
constexpr double kRStep = 0.7;
constexpr double kResidualStep = 0.8;
constexpr double kTirEpsilon = 1e-5;
constexpr double kUniformProbability = 0.02;  // defensive uniform component of the mixture

inline double sin_theta(Vec3 w) { return w.y; }
inline double cos_theta(Vec3 w) { return safe_sqrt(w.x * w.x + w.z * w.z); }
inline double dir_phi(Vec3 w) { return std::atan2(w.x, w.z); }
inline double luminance3(const double* v) { return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]; }

bool visible(Vec3 v, Vec3 m, Vec3 h) { return dot(v, h) > 0.0 && dot(v, m) > 0.0; }
bool visible(Vec3 a, Vec3 b, Vec3 m, Vec3 h) { return visible(a, m, h) && visible(b, m, h); }

// Visible-normal sample for direction v around the unit normal m from u in [0,1]^2, with the
// disk radius linear in u[0] (the caller multiplies by the weight 2 u[0]); frame (s, t, m).
Vec3 vndf_sample(Vec3 v, Vec3 m, Vec3 s, Vec3 t, double alpha, double r, double angle) {
    const Vec3 vl{dot(v, s), dot(v, t), dot(v, m)};
    const Vec3 hl = ggx::vndf_from_disk(vl, alpha, r * std::cos(angle), r * std::sin(angle));
    return hl.x * s + hl.y * t + hl.z * m;
}

// Density of the visible normal h for v around m (solid angle), 0 outside the support.
inline double vndf_density(const HuangHair::Component& c, Vec3 h, double alpha2) {
    const double hm = dot(h, c.m);
    const double vh = dot(c.v, h);
    if (!(hm > 0.0) || !(vh > 0.0)) return 0.0;
    return ggx::D(alpha2, hm) * vh * c.inv_norm;
}

// Gauss-Kronrod 7-15 on [a, b] for a scalar function; returns the estimate and |K15 - G7|.
template <class F>
std::pair<double, double> gauss_kronrod(F f, double a, double b) {
    static constexpr double xk[8] = {0.991455371120812639, 0.949107912342758525, 0.864864423359769073,
                                     0.741531185599394440, 0.586087235467691130, 0.405845151377397167,
                                     0.207784955007898468, 0.0};
    static constexpr double wk[8] = {0.022935322010529225, 0.063092092629978553, 0.104790010322250184,
                                     0.140653259715525919, 0.169004726639267903, 0.190350578064785410,
                                     0.204432940075298892, 0.209482141084727828};
    static constexpr double wg[4] = {0.129484966168869693, 0.279705391489276668, 0.381830050505118945,
                                     0.417959183673469388};
    const double c = 0.5 * (a + b), hw = 0.5 * (b - a);
    const double fc = f(c);
    double k = wk[7] * fc, g = wg[3] * fc;
    for (int j = 0; j < 7; ++j) {
        const double fs = f(c - hw * xk[j]) + f(c + hw * xk[j]);
        k += wk[j] * fs;
        if (j % 2 == 1) g += wg[j / 2] * fs;
    }
    return {k * hw, std::fabs((k - g) * hw)};
}

// Adaptive Gauss-Kronrod (bisection of the worst interval) over the breakpoints.
template <class F>
double adaptive_gk(F f, const std::vector<double>& breaks, double rel_tol, int max_intervals) {
    struct Piece {
        double a, b, value, error;
    };
    std::vector<Piece> pieces;
    double total = 0, error = 0;
    for (size_t i = 0; i + 1 < breaks.size(); ++i) {
        if (!(breaks[i + 1] > breaks[i])) continue;
        const auto r = gauss_kronrod(f, breaks[i], breaks[i + 1]);
        pieces.push_back({breaks[i], breaks[i + 1], r.first, r.second});
        total += r.first;
        error += r.second;
    }
    auto worse = [](const Piece& a, const Piece& b) { return a.error < b.error; };
    std::make_heap(pieces.begin(), pieces.end(), worse);
    while (!pieces.empty() && error > rel_tol * std::fabs(total) + 1e-300 && int(pieces.size()) < max_intervals) {
        std::pop_heap(pieces.begin(), pieces.end(), worse);
        const Piece p = pieces.back();
        pieces.pop_back();
        total -= p.value;
        error -= p.error;
        const double m = 0.5 * (p.a + p.b);
        for (const auto& ab : {std::make_pair(p.a, m), std::make_pair(m, p.b)}) {
            const auto r = gauss_kronrod(f, ab.first, ab.second);
            pieces.push_back({ab.first, ab.second, r.first, r.second});
            std::push_heap(pieces.begin(), pieces.end(), worse);
            total += r.first;
            error += r.second;
        }
    }
    return total;
}

// Sobol' points (Joe-Kuo direction numbers, dimensions 1-5) with a digital shift.
struct Sobol {
    uint32_t v[5][32];
    Sobol() {
        const int s[5] = {0, 1, 2, 3, 3}, a[5] = {0, 0, 1, 1, 2};
        const uint32_t m[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 3, 0}, {1, 3, 1}, {1, 1, 1}};
        for (int k = 0; k < 32; ++k) v[0][k] = 1u << (31 - k);
        for (int d = 1; d < 5; ++d) {
            for (int k = 0; k < s[d]; ++k) v[d][k] = m[d][k] << (31 - k);
            for (int k = s[d]; k < 32; ++k) {
                uint32_t x = v[d][k - s[d]] ^ (v[d][k - s[d]] >> s[d]);
                for (int j = 1; j < s[d]; ++j)
                    if ((a[d] >> (s[d] - 1 - j)) & 1) x ^= v[d][k - j];
                v[d][k] = x;
            }
        }
    }
    // Point i (Gray-code free, direct) in dimension d.
    uint32_t point(uint32_t i, int d) const {
        uint32_t x = 0;
        for (int k = 0; i; ++k, i >>= 1)
            if (i & 1) x ^= v[d][k];
        return x;
    }
};
inline const Sobol& sobol() {
    static const Sobol s;
    return s;
}

// Cycles' LCG (lcg_step_float).
inline double lcg_float(uint32_t& state) {
    state = 1103515245u * state + 12345u;
    return double(float(state) * (1.0f / float(0xFFFFFFFFu)));
}

}  // namespace

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
    factors_ = {std::max(params.r_factor, 0.0), std::max(params.tt_factor, 0.0), std::max(params.trt_factor, 0.0)};
}

// --- cross-section geometry (notes §5.1) ------------------------------------------------------

double HuangHair::h_to_gamma(double h_div_r, Vec3 w) const {
    if (b_ == 1.0) return -safe_asin(h_div_r);
    return std::atan2(w.z, -b_ * w.x) - std::acos(clamp(-h_div_r, -1.0, 1.0));
}

double HuangHair::dgamma_dh(double sin_phi, double cos_phi, double gamma) const {
    const double d = b_ == 1.0 ? std::cos(gamma) : cos_phi * std::cos(gamma) + b_ * sin_phi * std::sin(gamma);
    return d != 0.0 ? 1.0 / d : 0.0;
}

Vec3 HuangHair::mesonormal(double tilt, double gamma) const {
    const double st = std::sin(tilt), ct = std::cos(tilt);
    double sp = std::sin(gamma), cp = std::cos(gamma);
    if (b_ != 1.0 && std::fabs(cp) >= 1e-6) {
        const double n = std::sqrt(cp * cp + b_ * b_ * sp * sp);
        sp = b_ * sp / n;
        cp = cp / n;
    }
    return {sp * ct, st, cp * ct};
}

double HuangHair::arc_length(double gamma) const {
    return e2_ == 0.0 ? 1.0 : std::sqrt(1.0 - e2_ * sqr(std::sin(gamma)));
}

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
        ggx::orthonormals(T, a, bb);  // Cycles: make_orthonormals(Y, &Z, &N)
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
    sp.h = ctx.h;
    sp.transparent = !(std::fabs(ctx.h) < sp.r);
}

HuangHair::ShadingPoint HuangHair::prepare(const ShadingContext& ctx) const {
    ShadingPoint sp;
    set_frame(ctx, sp);
    const Vec3 I = sp.I;
    const double ct = cos_theta(I);
    if (sp.transparent || !(ct > 0) || !isfinite(I)) return sp;

    // Visible interval of h (notes §5.2).
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

// --- R lobe (notes §5.3) ------------------------------------------------------------------------

double HuangHair::r_integrand_gamma(const ShadingPoint& sp, Vec3 O, Vec3 wh, double gamma) const {
    const Vec3 wm = mesonormal(tilt_, gamma);
    const Vec3 macro{wm.x, 0.0, wm.z};
    const Vec3 I = sp.I;
    if (!visible(I, O, macro, wh)) return 0.0;
    const double cos_mi = dot(wm, I);
    return ggx::D(alpha2_, dot(wm, wh)) * ggx::G2(alpha2_, cos_mi, dot(wm, O)) * arc_length(gamma) *
           huang::energy_scale(sqrt_alpha_, cos_mi, eta_);
}

double HuangHair::r_integrand(const ShadingPoint& sp, Vec3 O, Vec3 wh, double h) const {
    const double gamma = h_to_gamma(h, sp.I);
    const double v = r_integrand_gamma(sp, O, wh, gamma);
    return v == 0.0 ? 0.0 : v * dgamma_dh(sp.sin_phi_i, sp.cos_phi_i, gamma);
}

// --- residual (notes §5.4): the TT integrand for the adaptive cubature -------------------------

struct HuangHair::Residual {
    const HuangHair& m;
    const ShadingPoint& sp;
    Vec3 O;
    double trrt_scale;  // M N 2/pi norm
    double final_scale; // norm / eta^2
    // Problems: index p -> (kind, gamma or panel, weight)
    struct Problem {
        int kind;        // 0: TT (entry only); 1: TRT + TRRT+ (entry and internal; not used by eval)
        bool gamma_free; // Converged quadrature: gamma is the first coordinate
        double gamma;    // fixed gamma (Cycles quadrature)
        double weight;   // Simpson weight x |d gamma/dh| (Cycles) or 1 / r (Converged)
    };
    std::vector<Problem> problems;

    int dim(int p) const {
        const Problem& q = problems[size_t(p)];
        return (q.kind == 0 ? 2 : 4) + (q.gamma_free ? 1 : 0);
    }
    int values(int) const { return 9; }
    // TRRT+ is left out of the error norm: its integrand jumps (visibility and total internal
    // reflection switch it on and off) and it is small; it rides along on the TRT boxes.
    double norm(int, const std::array<double, adaptive::kMaxValues>& f) const {
        return std::fabs(luminance3(&f[0])) + std::fabs(luminance3(&f[3])) + trrt_weight * std::fabs(luminance3(&f[6]));
    }
    double trrt_weight = 0.0;
    void eval(int p, const std::array<double, adaptive::kMaxDim>& x, std::array<double, adaptive::kMaxValues>& f) const {
        const Problem& q = problems[size_t(p)];
        int k = 0;
        const double gamma = q.gamma_free ? x[size_t(k++)] : q.gamma;
        // Disk points with a radius linear in u (weight 2u): smooth at the disk centre.
        const double u1a = x[size_t(k)], u1b = x[size_t(k + 1)];
        double w = q.weight * 2.0 * u1a;
        double u2a = 0.0, u2b = 0.0;
        if (q.kind == 1) {
            u2a = x[size_t(k + 2)];
            u2b = x[size_t(k + 3)];
            w *= 2.0 * u2a;
        }
        std::array<double, 9> g;
        m.residual_point(sp, O, gamma, u1a, kTwoPi * u1b, u2a, kTwoPi * u2b, q.kind, w, final_scale, trrt_scale, g);
        for (int j = 0; j < 9; ++j) f[size_t(j)] = g[size_t(j)];
    }
};

}  // namespace hairbsdf

namespace hairbsdf {

RGB HuangHair::trrt_series(double t, double r, RGB a) const {
    // Geometric series of the TRRT+ attenuation (Cycles' bsdf_hair_huang_eval_trrt).
    const double t_avg = std::max(1.0 - r, 1e-5);
    auto ch = [&](double x) { return t * r * r * t_avg * x * x * x / (1.0 - x * (1.0 - t_avg)); };
    return {ch(a.r), ch(a.g), ch(a.b)};
}

bool HuangHair::entry_state(const ShadingPoint& sp, double gamma, double r1, double angle1, EntryState& e) const {
    const Vec3 I = sp.I;
    e.gamma = gamma;
    e.wmi = mesonormal(tilt_, gamma);
    const Vec3 wmi_ = mesonormal(0.0, gamma);
    e.cos_mi1 = dot(I, e.wmi);
    if (!(e.cos_mi1 > 0.0) || !(dot(I, wmi_) > 0.0)) return false;
    Vec3 s1, t1v;
    ggx::orthonormals(e.wmi, s1, t1v);
    const Vec3 wh1 = vndf_sample(I, e.wmi, s1, t1v, alpha_, r1, angle1);
    const double cos_hi1 = dot(I, wh1);
    if (!(cos_hi1 > 0.0)) return false;
    double cos_t1 = 0.0;
    const double f1 = ggx::fresnel(cos_hi1, eta_, &cos_t1);
    if (!(f1 < 1.0)) return false;  // total internal reflection: nothing enters
    e.t1 = 1.0 - f1;
    e.scale1 = huang::energy_scale(sqrt_alpha_, e.cos_mi1, eta_);
    e.wt = ggx::refract(I, wh1, cos_t1, inv_eta_);
    e.mwt = -1.0 * e.wt;
    const double phi_t = dir_phi(e.wt);
    e.phi_t_b = b_ == 1.0 ? phi_t : std::atan2(b_ * std::sin(phi_t), std::cos(phi_t));
    e.gmt = 2.0 * e.phi_t_b - gamma;
    e.wmt = mesonormal(-tilt_, e.gmt);
    e.wmt_ = mesonormal(0.0, e.gmt);
    e.cos_mo1 = dot(e.mwt, e.wmi);
    e.cos_mi2 = dot(e.mwt, e.wmt);
    if (!visible(I, e.mwt, e.wmi, wh1) || !visible(I, e.mwt, wmi_, wh1)) return false;
    e.g1o = ggx::G2_over_G1(alpha2_, e.cos_mi1, e.cos_mo1);
    double path_t;
    if (b_ == 1.0) {
        path_t = -2.0 * std::cos(gamma - phi_t);
    } else {
        const double gx = std::sin(gamma) - std::sin(e.gmt + kPi), gz = b_ * (std::cos(gamma) - std::cos(e.gmt + kPi));
        path_t = std::sqrt(gx * gx + gz * gz);
    }
    e.a_t = absorption(path_t, cos_theta(e.wt));
    e.scale2 = huang::energy_scale(sqrt_alpha_, e.cos_mi2, inv_eta_);
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
                          e.cos_mo1 * e.cos_mi1 * cos_hi2 * cos_ho2 * inv_len * inv_len * arc_length(e.gmt);
    const RGB v = scalar * e.a_t;
    return isfinite(v) ? v : RGB();
}

// The internal reflection at the second interface with microfacet normal wh2 and the exit to O:
// TRT (returned) and the TRRT+ series (trrt; 0 where Cycles does not add it).
RGB HuangHair::trt_internal(const EntryState& e, Vec3 wh2, Vec3 O, RGB& trrt, Vec3* wtr_out) const {
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
    const double phi_tr = dir_phi(wtr);
    const double phi_tr_b = b_ == 1.0 ? phi_tr : std::atan2(b_ * std::sin(phi_tr), std::cos(phi_tr));
    const double gmtr = e.gamma - 2.0 * (e.phi_t_b - phi_tr_b) + kPi;
    const Vec3 wmtr = mesonormal(-tilt_, gmtr);
    const Vec3 wmtr_ = mesonormal(0.0, gmtr);
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
    const double t3 = (1.0 - ggx::fresnel(cos_hi3, inv_eta_)) * huang::energy_scale(sqrt_alpha_, cos_mi3, inv_eta_);
    double path_tr;
    if (b_ == 1.0) {
        path_tr = 2.0 * std::fabs(std::cos(phi_tr - e.gmt));
    } else {
        const double gx = std::sin(gmtr) - std::sin(e.gmt), gz = b_ * (std::cos(gmtr) - std::cos(e.gmt));
        path_tr = std::sqrt(gx * gx + gz * gz);
    }
    const RGB a_tr = absorption(path_tr, cos_theta(wtr));
    const double cos_mo2 = dot(e.wmt, mwtr);
    const double scalar = e.t1 * e.scale1 * r2f * e.scale2 * t3 * ggx::D(alpha2_, cos_mh3) * e.g1o *
                          ggx::G2_over_G1(alpha2_, e.cos_mi2, cos_mo2) * ggx::G2(alpha2_, cos_mi3, dot(wmtr, mO)) /
                          (e.cos_mo1 * cos_mo2) * e.cos_mi1 * e.cos_mi2 * cos_hi3 * cos_ho3 * inv_len3 * inv_len3 *
                          arc_length(gmtr);
    const RGB v = scalar * (e.a_t * a_tr);
    return isfinite(v) ? v : RGB();
}

void HuangHair::residual_point(const ShadingPoint& sp, Vec3 O, double gamma, double r1, double angle1, double r2,
                               double angle2, int kind, double weight, double final_scale, double trrt_scale,
                               std::array<double, 9>& f) const {
    f.fill(0.0);
    EntryState e;
    if (!entry_state(sp, gamma, r1, angle1, e)) return;
    if (kind == 0) {
        if (!(factors_[1] > 0.0)) return;
        const RGB v = (weight * factors_[1] * final_scale) * tt_exit(e, O);
        f[0] = v.r, f[1] = v.g, f[2] = v.b;
        return;
    }
    if (!(factors_[2] > 0.0)) return;
    Vec3 s2, t2v;
    ggx::orthonormals(e.wmt, s2, t2v);
    const Vec3 wh2 = vndf_sample(e.mwt, e.wmt, s2, t2v, alpha_, r2, angle2);
    RGB trrt;
    const RGB v = (weight * factors_[2] * final_scale) * trt_internal(e, wh2, O, trrt);
    const RGB t = (weight * trrt_scale) * trrt;
    f[3] = v.r, f[4] = v.g, f[5] = v.b;
    if (isfinite(t)) f[6] = t.r, f[7] = t.g, f[8] = t.b;
}

// TRT with two strategies for the internal direction, combined by the balance heuristic: the
// internal-reflection visible normals (what Cycles samples: density qa of wtr) and refraction of O
// into the fibre through visible normals around the mesonormal of the specular exit point
// (density qb). One point (u2, u3) feeds both; the TRT integrand g qa / (qa + qb) has no exit
// peak left. TRRT+ uses the first strategy only. Returns TRT and TRRT+ sums (times weight).
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
    ggx::orthonormals(ca.m, ca.s, ca.t);
    ca.inv_norm = cos_vm > 0.0 ? 1.0 / (cos_vm * (1.0 + ggx::lambda(alpha2_, cos_vm))) : 0.0;
    auto qa = [&](Vec3 wtr) {  // density of wtr = -reflect(wt, h), h ~ visible normals of -wt
        Vec3 h = normalize(e.wt + wtr);
        if (dot(e.mwt, h) < 0.0) h = -1.0 * h;
        const double c = dot(e.mwt, h);
        return c > 0.0 ? vndf_density(ca, h, alpha2_) / (4.0 * c) : 0.0;
    };
    // Proposal for the exit: the mesonormal where the specular internal reflection leaves.
    const Vec3 wtr0 = -1.0 * ggx::reflect(e.wt, e.wmt);
    const double phi_tr0 = dir_phi(wtr0);
    const double phi_tr0_b = b_ == 1.0 ? phi_tr0 : std::atan2(b_ * std::sin(phi_tr0), std::cos(phi_tr0));
    const Vec3 out_normal = -1.0 * mesonormal(-tilt_, e.gamma - 2.0 * (e.phi_t_b - phi_tr0_b) + kPi);
    Component cb;
    cb.v = O;
    cb.m = out_normal;
    ggx::orthonormals(cb.m, cb.s, cb.t);
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
    // Strategy A: Cycles' internal visible normal.
    {
        const Vec3 wh2 = vndf_sample(ca.v, ca.m, ca.s, ca.t, alpha_, std::sqrt(u2), kTwoPi * u3);
        RGB trrt;
        Vec3 wtr;
        const RGB g = trt_internal(e, wh2, O, trrt, &wtr);
        trrt_out = weight * trrt;
        if (g.r != 0.0 || g.g != 0.0 || g.b != 0.0) {
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

// --- eval ---------------------------------------------------------------------------------------

std::array<RGB, kLobeCount> HuangHair::eval_local(const ShadingPoint& sp, Vec3 O, long* evaluations) const {
    std::array<RGB, kLobeCount> lobes{};
    if (evaluations) *evaluations = 0;
    if (!sp.valid) return lobes;
    const Vec3 I = sp.I;
    const double cto = cos_theta(O);
    if (tan_tilt_ * (O.y / cto) < -1.0) return lobes;  // dot(O, mesonormal) < 0 everywhere
    const Vec3 wh = normalize(I + O);

    // R lobe: a 1D integral, Cycles' Simpson nodes or adaptive Gauss-Kronrod in gamma.
    double r_value = 0.0;
    if (factors_[0] > 0.0 && length(I + O) > 0.0) {
        double integral = 0.0;
        if (params_.quadrature == HuangQuadrature::Cycles) {
            for (const Node& n : sp.r_nodes) integral += n.weight * r_integrand(sp, O, wh, n.h);
        } else {
            const double g_lo = h_to_gamma(sp.h_hi, I), g_hi = h_to_gamma(sp.h_lo, I);
            std::vector<double> breaks{g_lo, g_hi};
            auto add_break = [&](double phi) {
                const double g = b_ == 1.0 ? phi : std::atan2(std::sin(phi), b_ * std::cos(phi));
                for (int k = -2; k <= 2; ++k) {
                    const double c = g + kTwoPi * k;
                    if (c > g_lo && c < g_hi) breaks.push_back(c);
                }
            };
            // Visibility of the macro normal from I and O switches at phi_I +- pi/2, phi_O +- pi/2;
            // the lobe peaks where the mesonormal meets the half vector.
            const double phi_i = dir_phi(I), phi_o = dir_phi(O), phi_h = dir_phi(wh);
            add_break(phi_i + 0.5 * kPi);
            add_break(phi_i - 0.5 * kPi);
            add_break(phi_o + 0.5 * kPi);
            add_break(phi_o - 0.5 * kPi);
            add_break(phi_h);
            const int panels = int(clamp(std::ceil((g_hi - g_lo) / (4.0 * alpha_)), 1.0, 32.0));
            for (int k = 1; k < panels; ++k) breaks.push_back(g_lo + (g_hi - g_lo) * k / panels);
            std::sort(breaks.begin(), breaks.end());
            integral = adaptive_gk([&](double g) { return r_integrand_gamma(sp, O, wh, g); }, breaks,
                                   0.1 * params_.tolerance, 4000) / sp.r;
        }
        r_value = factors_[0] * 0.25 * ggx::fresnel(dot(I, wh), eta_) * integral * sp.norm;
        lobes[0] = RGB(r_value);
    }
    if (!(factors_[1] > 0.0) && !(factors_[2] > 0.0)) return lobes;

    // h nodes of the residual: Cycles' Simpson nodes, or 3-point Gauss-Legendre panels in gamma
    // (no 1/cos singularity at the interval ends) of width 0.8 alpha.
    std::vector<Node> nodes;  // (gamma, weight including |d gamma/dh| or 1 / r)
    // TRRT+ has no masking term, so its integrand jumps where the entry mesonormal turns away from
    // the viewer; when the cuticle tilt limits the visible interval, that edge is an end node of
    // Cycles' Simpson rule, which float rounding puts on either side. Its expected value counts half
    // of the inside limit (docs/huang.md §4); the node is moved inside by 1e-9.
    std::vector<double> trrt_node_factor;
    if (params_.quadrature == HuangQuadrature::Cycles) {
        const size_t count = sp.residual_nodes.size();
        for (size_t k = 0; k < count; ++k) {
            const Node& n = sp.residual_nodes[k];
            double gamma = h_to_gamma(n.h, I);
            double trrt_factor = 1.0;
            if (k == 0 || k + 1 == count) {
                const double inward = (k == 0) ? -1e-9 : 1e-9;  // gamma decreases with h
                if (!(dot(I, mesonormal(tilt_, gamma)) > 1e-7)) {
                    gamma += inward;
                    trrt_factor = 0.5;
                }
            }
            const double w = n.weight * dgamma_dh(sp.sin_phi_i, sp.cos_phi_i, gamma);
            if (w != 0.0 && std::isfinite(w)) {
                nodes.push_back({gamma, w});
                trrt_node_factor.push_back(trrt_factor);
            }
        }
    } else {
        const double g_lo = h_to_gamma(sp.h_hi, I), g_hi = h_to_gamma(sp.h_lo, I);
        const int panels = int(clamp(std::ceil((g_hi - g_lo) / (0.8 * alpha_)), 1.0, 512.0));
        static constexpr double x3[3] = {-0.7745966692414834, 0.0, 0.7745966692414834};
        static constexpr double w3[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
        const double width = (g_hi - g_lo) / panels;
        for (int k = 0; k < panels; ++k)
            for (int q = 0; q < 3; ++q) nodes.push_back({g_lo + width * (k + 0.5 + 0.5 * x3[q]), 0.5 * width * w3[q] / sp.r});
    }
    const double final_scale = sp.norm * inv_eta_ * inv_eta_;
    const double trrt_scale = trrt_m_.eval(I.y, cos_theta(I), O.y, cto) * kInvTwoPi * (2.0 / kPi) * sp.norm;
    long count = 0;

    // TT: a 2D integral over the entry visible normal per node, adaptive cubature with one
    // priority queue over all nodes, to the relative tolerance of the total.
    if (factors_[1] > 0.0 && !nodes.empty()) {
        Residual res{*this, sp, O, trrt_scale, final_scale, {}, 0.0};
        adaptive::Integrator<Residual> integ(res);
        const std::array<double, adaptive::kMaxDim> lo{}, hi{1, 1, 1, 1, 1};
        // Each node starts as 3 x 3 boxes: the 17-point rule on the whole disk can miss the exit
        // lobe and underestimate its own error.
        for (const Node& n : nodes) {
            res.problems.push_back({0, false, n.h, n.weight});
            for (int i = 0; i < 3; ++i) {
                for (int j = 0; j < 3; ++j) {
                    std::array<double, adaptive::kMaxDim> blo = lo, bhi = hi;
                    blo[0] = i / 3.0;
                    bhi[0] = (i + 1) / 3.0;
                    blo[1] = j / 3.0;
                    bhi[1] = (j + 1) / 3.0;
                    integ.add(int(res.problems.size()) - 1, blo, bhi);
                }
            }
        }
        const double tol = 0.25 * params_.tolerance;  // the error estimates are optimistic
        integ.refine([&](const std::array<double, adaptive::kMaxValues>& t) { return tol * (std::fabs(r_value) + std::fabs(luminance3(&t[0]))) + 1e-300; },
                     params_.max_evaluations);
        const auto& t = integ.totals();
        lobes[1] = RGB(t[0], t[1], t[2]);
        count += integ.evaluations();
    }

    // TRT and TRRT+: a 4D integral (entry and internal visible normals) per node; its integrand
    // is peaked along a ridge and jumps (visibility, total internal reflection), where product
    // and adaptive rules converge no faster than quasi-Monte Carlo: a fixed digitally shifted
    // Sobol' set (a different shift per node), TRT weighted by multiple importance between the
    // internal-reflection normals and a proposal for the exit (trt_mis_point), docs/huang.md §4.
    if (factors_[2] > 0.0) {
        const uint32_t npts = uint32_t(std::max(params_.trt_points, 16L));
        const Sobol& so = sobol();
        double acc[6] = {0, 0, 0, 0, 0, 0};
        uint32_t seed = 0x2545F491u;
        for (size_t kn = 0; kn < nodes.size(); ++kn) {
            const Node& n = nodes[kn];
            const double trrt_factor = kn < trrt_node_factor.size() ? trrt_node_factor[kn] : 1.0;
            uint32_t shift[4];
            for (uint32_t& sh : shift) sh = seed = lookup3_hash_uint2(seed, 0x9E3779B9u);
            const double w = n.weight / double(npts);
            for (uint32_t i = 0; i < npts; ++i) {
                const double u0 = double(so.point(i, 0) ^ shift[0]) * 0x1p-32;
                const double u1 = double(so.point(i, 1) ^ shift[1]) * 0x1p-32;
                const double u2 = double(so.point(i, 2) ^ shift[2]) * 0x1p-32;
                const double u3 = double(so.point(i, 3) ^ shift[3]) * 0x1p-32;
                RGB trt, trrt;
                trt_mis_point(sp, O, n.h, u0, kTwoPi * u1, u2, u3, 2.0 * u0 * w, trt, trrt);
                trt = (factors_[2] * final_scale) * trt;
                trrt = (trrt_factor * trrt_scale) * trrt;
                acc[0] += trt.r, acc[1] += trt.g, acc[2] += trt.b;
                if (isfinite(trrt)) acc[3] += trrt.r, acc[4] += trrt.g, acc[5] += trrt.b;
            }
            count += npts;
        }
        lobes[2] = RGB(acc[0], acc[1], acc[2]);
        lobes[3] = RGB(acc[3], acc[4], acc[5]);
    }
    if (evaluations) *evaluations = count;
    for (RGB& l : lobes)
        if (!isfinite(l)) l = RGB(0.0);
    return lobes;
}

BsdfEval HuangHair::eval(const ShadingPoint& sp, Vec3 wi) const {
    BsdfEval out;
    if (sp.transparent || !sp.valid) return out;
    const Vec3 O = to_local(sp, wi);
    out.lobes = eval_local(sp, O);
    out.pdf = params_.sampler == HuangSampler::Cycles ? 1.0 : pdf_local(sp, O);
    return out;
}

double HuangHair::pdf(const ShadingPoint& sp, Vec3 wi) const {
    if (sp.transparent || !sp.valid) return 0.0;
    if (params_.sampler == HuangSampler::Cycles) return 1.0;
    return pdf_local(sp, to_local(sp, wi));
}

// --- Cycles' stochastic eval ------------------------------------------------------------------

std::array<RGB, kLobeCount> HuangHair::eval_cycles_stochastic(const ShadingPoint& sp, Vec3 O, uint32_t& rng) const {
    std::array<RGB, kLobeCount> lobes{};
    if (!sp.valid) return lobes;
    const Vec3 I = sp.I;
    const double cto = cos_theta(O);
    if (tan_tilt_ * (O.y / cto) < -1.0) return lobes;
    const Vec3 wh = normalize(I + O);
    if (factors_[0] > 0.0) {
        double integral = 0.0;
        for (const Node& n : simpson_nodes(sp.h_lo, sp.h_hi, kRStep)) integral += n.weight * r_integrand(sp, O, wh, n.h);
        lobes[0] = RGB(factors_[0] * 0.25 * ggx::fresnel(dot(I, wh), eta_) * integral * sp.norm);
    }
    if (!(factors_[1] > 0.0) && !(factors_[2] > 0.0)) return lobes;
    const double final_scale = sp.norm * inv_eta_ * inv_eta_;
    const double trrt_scale = trrt_m_.eval(I.y, cos_theta(I), O.y, cto) * kInvTwoPi * (2.0 / kPi) * sp.norm;
    std::array<double, 9> f{}, acc{};
    for (const Node& n : simpson_nodes(sp.h_lo, sp.h_hi, kResidualStep)) {
        const double gamma = h_to_gamma(n.h, I);
        const double w = n.weight * dgamma_dh(sp.sin_phi_i, sp.cos_phi_i, gamma);
        const double a = lcg_float(rng), b = lcg_float(rng);
        const double r1 = std::sqrt(a), ang1 = kTwoPi * b;
        if (factors_[1] > 0.0) {
            residual_point(sp, O, gamma, r1, ang1, 0, 0, 0, w, final_scale, trrt_scale, f);
            for (int k = 0; k < 9; ++k) acc[size_t(k)] += f[size_t(k)];
        }
        if (factors_[2] > 0.0) {
            const double c = lcg_float(rng), d = lcg_float(rng);
            residual_point(sp, O, gamma, r1, ang1, std::sqrt(c), kTwoPi * d, 1, w, final_scale, trrt_scale, f);
            for (int k = 0; k < 9; ++k) acc[size_t(k)] += f[size_t(k)];
        }
    }
    lobes[1] = RGB(acc[0], acc[1], acc[2]);
    lobes[2] = RGB(acc[3], acc[4], acc[5]);
    lobes[3] = RGB(acc[6], acc[7], acc[8]);
    return lobes;
}

}  // namespace hairbsdf

namespace hairbsdf {

// --- sampling mixture ---------------------------------------------------------------------------

void HuangHair::build_sampler(ShadingPoint& sp) const {
    const Vec3 I = sp.I;
    const double lo = sp.h_lo, hi = sp.h_hi, range = hi - lo;
    auto make = [&](Vec3 v, Vec3 m, double p) {
        Component c;
        c.v = v;
        c.m = m;
        ggx::orthonormals(m, c.s, c.t);
        const double vm = dot(v, m);
        c.inv_norm = 1.0 / (vm * (1.0 + ggx::lambda(alpha2_, vm)));
        c.probability = p;
        return c;
    };
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
        ggx::orthonormals(wmi, s, t);
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
                    ggx::orthonormals(e.wmt, s, t);
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
    double p = sp.lobe_probability[4] / (4.0 * kPi);
    // R: O = reflect of I about h, h = normalize(I + O); Jacobian 1 / (4 I.h).
    if (sp.lobe_probability[0] > 0.0) {
        const Vec3 sum = I + O;
        const double len = length(sum);
        if (len > 0.0) {
            const Vec3 h = (1.0 / len) * sum;
            const double ih = dot(I, h);
            if (ih > 0.0) {
                double q = 0.0;
                for (const Component& c : sp.reflection) q += c.probability * vndf_density(c, h, alpha2_);
                p += sp.lobe_probability[0] * q / (4.0 * ih);
            }
        }
    }
    // TT / TRT: refraction out of the fibre, h = normalize(eta v + O), Jacobian |O.h| / (eta v.h + O.h)^2.
    for (size_t k = 0; k < sp.exits.size(); ++k) {
        const Component& c = sp.exits[k];
        const double lobe_p = sp.lobe_probability[k < sp.tt_count ? 1 : 2];
        const Vec3 hu = eta_ * c.v + O;
        const double len = length(hu);
        if (!(len > 0.0)) continue;
        const Vec3 h = (1.0 / len) * hu;
        const double vh = dot(c.v, h), oh = dot(O, h);
        if (!(vh > 0.0) || !(oh < 0.0)) continue;
        const double denom = eta_ * vh + oh;
        p += lobe_p * c.probability * vndf_density(c, h, alpha2_) * std::fabs(oh) / (denom * denom);
    }
    // TRRT+: Chiang's longitudinal lobe with v = 4 alpha around -theta_I, uniform in phi.
    if (sp.lobe_probability[3] > 0.0)
        p += sp.lobe_probability[3] * trrt_sampler_.eval(O.y, cos_theta(O), I.y, cos_theta(I)) * kInvTwoPi;
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
    const Vec3 I = sp.I;
    const double r = std::sqrt(u[0]), ang = kTwoPi * u[1];
    if (lobe == 0) {
        const Component* c = pick(sp.reflection.data(), sp.reflection.size());
        if (!c) return none;
        const Vec3 h = vndf_sample(c->v, c->m, c->s, c->t, alpha_, r, ang);
        O = (2.0 * dot(I, h)) * h - I;
    } else if (lobe == 1 || lobe == 2) {
        const Component* c = lobe == 1 ? pick(sp.exits.data(), sp.tt_count)
                                       : pick(sp.exits.data() + sp.tt_count, sp.exits.size() - sp.tt_count);
        if (!c) return none;
        const Vec3 h = vndf_sample(c->v, c->m, c->s, c->t, alpha_, r, ang);
        double cos_t = 0.0;
        if (!(ggx::fresnel(dot(c->v, h), inv_eta_, &cos_t) < 1.0) || !(dot(c->v, h) > 0.0)) return none;
        O = ggx::refract(c->v, h, cos_t, eta_);
    } else if (lobe == 3) {
        const double v = 4.0 * alpha_;
        const double st = sample_longitudinal(v, std::exp(-2.0 / v), u[0], u[1], I.y, cos_theta(I));
        const double ct = cos_from_sin(st);
        const double phi = kTwoPi * ul;
        O = {std::sin(phi) * ct, st, std::cos(phi) * ct};
    } else {
        const double y = 1.0 - 2.0 * u[0];
        const double ct = cos_from_sin(y);
        O = {std::sin(ang) * ct, y, std::cos(ang) * ct};
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
        ggx::orthonormals(m, s, t);
        return vndf_sample(v, m, s, t, alpha_, std::sqrt(a), kTwoPi * b);
    };
    const double h1b = lcg_float(rng);
    const Vec3 wh1 = sample_wh(I, wmi, u[2], h1b);
    const double h2a = lcg_float(rng), h2b = lcg_float(rng), h3a = lcg_float(rng), h3b = lcg_float(rng);
    const Vec3 wr = -1.0 * ggx::reflect(I, wh1);
    if (!visible(I, wmi_, wh1)) return out;
    double cos_t1 = 0.0;
    const double r1 = ggx::fresnel(dot(I, wh1), eta_, &cos_t1);
    const double scale1 = huang::energy_scale(sqrt_alpha_, cos_mi1, eta_);
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
            const double scale2 = huang::energy_scale(sqrt_alpha_, cos_mi2, inv_eta_);
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
                const RGB tr = (t1 * r2 * scale2 * huang::energy_scale(sqrt_alpha_, cos_mi3, inv_eta_) *
                                ggx::G2_over_G1(alpha2_, cos_mi2, dot(wmt, -1.0 * wtr))) * (a_t * a_tr);
                const double t3 = 1.0 - r3;
                if (t3 > 0.0) {
                    wtrt = ggx::refract(wtr, wh3, cos_t3, eta_);
                    const Vec3 mwtrt = -1.0 * wtrt;
                    if (visible(wtr, mwtrt, Vec3{wmtr.x, 0.0, wmtr.z}, wh3))
                        TRT = (factors_[2] * t3 * ggx::G2_over_G1(alpha2_, cos_mi3, dot(wmtr, mwtrt))) * tr;
                }
                const double rand_theta = std::max(lcg_float(rng), 1e-5);
                const double fac = 1.0 + 4.0 * alpha_ * std::log(rand_theta + (1.0 - rand_theta) * std::exp(-0.5 / alpha_));
                const double st = -fac * I.y + cos_from_sin(fac) * std::cos(kTwoPi * lcg_float(rng)) * cos_theta(I);
                const double ct = cos_from_sin(st);
                const double phi = kTwoPi * lcg_float(rng);
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
