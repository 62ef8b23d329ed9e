// Huang hair: the deterministic eval (adaptive cubature for TT, Sobol' points for TRT and TRRT+)
// and Cycles' stochastic eval.
#include "huang_internal.h"

#include "huang_lanes.h"

#include "hairbsdf/math_cubature.h"
#include "hairbsdf/math_quadrature.h"

namespace hairbsdf {

// --- residual (docs/cycles.md §5.4): the TT integrand for the adaptive cubature -----------------

namespace {
// The entry visible-normal disk's radius at the cubature coordinate s in [0, 1]: r = 1 - (1 - s)^3, and the
// disk's area weight 2 r dr/ds. At small roughness TT's exit lobe can live in a thin rim of the disk (grazing
// entry microfacets: 1 - r ~ 1e-5 to 1e-4 at alpha 0.02), where a radius linear in s left it between the
// boxes' points; the cube widens that rim to s within ~0.02-0.05 of 1 (docs/huang.md §4).
inline double entry_disk_radius(double s, double& area_weight) {
    const double t = 1.0 - s;
    const double r = 1.0 - t * t * t;
    area_weight = 6.0 * r * t * t;
    return r;
}
}  // namespace

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
        // The entry disk's radius by entry_disk_radius; the internal disk's linear in u (weight 2u).
        double disk_weight = 0.0;
        const double u1a = entry_disk_radius(x[size_t(k)], disk_weight), u1b = x[size_t(k + 1)];
        f.fill(0.0);
        if (q.kind == 0) {
            EntryState e;
            if (!m.entry_state(sp, gamma, u1a, kTwoPi * u1b, e)) return;
            const RGB v = tt_point_weight(q, disk_weight) * m.tt_exit(e, O);
            f[0] = v.r, f[1] = v.g, f[2] = v.b;
            return;
        }
        const double u2a = x[size_t(k + 2)], u2b = x[size_t(k + 3)];
        const double w = (q.weight * disk_weight) * (2.0 * u2a);
        std::array<double, 9> g;
        m.trt_point(sp, O, gamma, u1a, kTwoPi * u1b, u2a, kTwoPi * u2b, w, final_scale, trrt_scale, g);
        for (int j = 0; j < 9; ++j) f[size_t(j)] = g[size_t(j)];
    }
    // A TT point's weight: the node's, the entry disk's area weight (entry_disk_radius), TT's factor and scale
    // (a Residual exists only where TT's factor is > 0).
    double tt_point_weight(const Problem& q, double area_weight) const {
        return q.weight * area_weight * m.factors_[1] * final_scale;
    }
    // A box's points together: TT at a fixed gamma on the float lanes (huang_tt_lanes) when `lane` is set,
    // else point by point.
    const HuangLanePoint* lane = nullptr;
    void eval_points(int p, const std::array<double, adaptive::kMaxDim>* xs, size_t n,
                     std::array<double, adaptive::kMaxValues>* fs) const {
        const Problem& q = problems[size_t(p)];
        constexpr size_t kMaxPoints = 64;
        if (!lane || q.kind != 0 || q.gamma_free || n > kMaxPoints) {
            for (size_t k = 0; k < n; ++k) eval(p, xs[k], fs[k]);
            return;
        }
        float u1a[kMaxPoints], u1b[kMaxPoints];
        double v[3 * kMaxPoints], disk_weight[kMaxPoints];
        for (size_t k = 0; k < n; ++k) {
            u1a[k] = float(entry_disk_radius(xs[k][0], disk_weight[k]));
            u1b[k] = float(xs[k][1]);
        }
        huang_tt_lanes(m.lanes_, *lane, {n, u1a, u1b, float(q.gamma), float(std::sin(q.gamma)), float(std::cos(q.gamma))}, v);
        for (size_t k = 0; k < n; ++k) {
            const double w = tt_point_weight(q, disk_weight[k]);
            fs[k].fill(0.0);
            for (size_t j = 0; j < 3; ++j) fs[k][j] = w * v[3 * k + j];
        }
    }
};


// --- eval ---------------------------------------------------------------------------------------

namespace {
// TT's cubature runs on the float lanes from this tolerance up. Float rounding puts a floor of about 1e-6 to
// 1e-5 of TT under the boxes' error estimates (the Genz-Malik rules' difference), which held tighter targets
// (measured: tolerance 1e-5 spent a 2e6-point budget where double converged in 2e4) from converging.
constexpr double kTtLanesMinTolerance = 1e-3;
}  // namespace

// Below this O's angle to the fibre, every tilted mesonormal faces away from O (dot(O, mesonormal) < 0).
bool HuangHair::tilt_hides(Vec3 O) const { return tan_tilt_ * (O.y / cos_theta(O)) < -1.0; }

// TRRT+'s factor at O: Cycles' longitudinal M (v = 4 alpha), 1 / 2 pi in azimuth, 2 / pi, the point's norm.
double HuangHair::trrt_scale_at(const ShadingPoint& sp, Vec3 O) const {
    return trrt_m_.eval(sp.I.y, cos_theta(sp.I), O.y, cos_theta(O)) * kInvTwoPi * (2.0 / kPi) * sp.norm;
}

// R's lobe value from its integral over h (Simpson sum or quadrature; wh = normalize(I + O)).
double HuangHair::r_lobe(const ShadingPoint& sp, Vec3 wh, double integral) const {
    return factors_[0] * 0.25 * ggx::fresnel(dot(sp.I, wh), eta_) * integral * sp.norm;
}

namespace {
// The shading point and O for the float lanes (huang_lanes.h), with the eval's scale factors.
HuangLanePoint lane_point(const HuangHair::ShadingPoint& sp, Vec3 O, Vec3 wh, double tt_scale, double trt_scale,
                          double trrt_scale) {
    HuangLanePoint p{};
    const double i[3] = {sp.I.x, sp.I.y, sp.I.z}, o[3] = {O.x, O.y, O.z}, h[3] = {wh.x, wh.y, wh.z};
    for (int k = 0; k < 3; ++k) {
        p.I[k] = float(i[k]);
        p.O[k] = float(o[k]);
        p.wh[k] = float(h[k]);
    }
    p.gamma_base = float(sp.gamma_base);
    p.sin_phi_i = float(sp.sin_phi_i);
    p.cos_phi_i = float(sp.cos_phi_i);
    p.tt_scale = float(tt_scale);
    p.trt_scale = float(trt_scale);
    p.trrt_scale = float(trrt_scale);
    p.tt = tt_scale > 0.0;
    p.trt = trt_scale > 0.0;
    return p;
}

// The unshifted Sobol' points [from, to) of dimensions 0-3, one array per dimension (the TRT lanes' input).
struct SobolColumns {
    std::vector<uint32_t> x[4];
    const uint32_t* columns[4];
    SobolColumns(uint32_t from, uint32_t to) {
        const Sobol& so = sobol();
        for (int d = 0; d < 4; ++d) {
            x[d].resize(to - from);
            for (uint32_t i = from; i < to; ++i) x[d][i - from] = so.point(i, d);
            columns[d] = x[d].data();
        }
    }
};
}  // namespace

void HuangHair::trt_node_points(const ShadingPoint& sp, Vec3 O, const Node& n, const uint32_t (&sh)[4],
                                uint32_t from, uint32_t to, const uint32_t* const* columns, double trt_scale,
                                double trrt_scale, double acc[6]) const {
    if (columns) {
        const HuangLanePoint p = lane_point(sp, O, Vec3{0, 0, 1}, 0.0, 1.0, 1.0);
        HuangTrtPoints pts{};
        pts.count = to - from;
        for (int d = 0; d < 4; ++d) {
            pts.sobol[d] = columns[d];
            pts.shift[d] = sh[d];
        }
        pts.gamma = float(n.h);
        pts.sin_gamma = float(std::sin(n.h));
        pts.cos_gamma = float(std::cos(n.h));
        pts.weight = float(n.weight);
        pts.trrt_shell = trrt_shell_;
        double sums[6] = {};
        huang_trt_lanes(lanes_, p, pts, sums);
        for (int j = 0; j < 3; ++j) {
            acc[j] += trt_scale * sums[j];
            acc[3 + j] += trrt_scale * sums[3 + j];
        }
        return;
    }
    const Sobol& so = sobol();
    for (uint32_t i = from; i < to; ++i) {
        const double u0 = double(so.point(i, 0) ^ sh[0]) * 0x1p-32;
        const double u1 = double(so.point(i, 1) ^ sh[1]) * 0x1p-32;
        const double u2 = double(so.point(i, 2) ^ sh[2]) * 0x1p-32;
        const double u3 = double(so.point(i, 3) ^ sh[3]) * 0x1p-32;
        RGB trt, trrt;
        trt_mis_point(sp, O, n.h, u0, kTwoPi * u1, u2, u3, 2.0 * u0 * n.weight, trt, trrt);
        trt = trt_scale * trt;
        trrt = trrt_scale * trrt;
        if (isfinite(trt)) acc[0] += trt.r, acc[1] += trt.g, acc[2] += trt.b;
        if (isfinite(trrt)) acc[3] += trrt.r, acc[4] += trrt.g, acc[5] += trrt.b;
    }
}

std::array<RGB, kLobeCount> HuangHair::eval_local(const ShadingPoint& sp, Vec3 O, long* evaluations) const {
    return eval_local_impl(sp, O, evaluations, true);
}

std::array<RGB, kLobeCount> HuangHair::eval_local_double(const ShadingPoint& sp, Vec3 O, long* evaluations) const {
    return eval_local_impl(sp, O, evaluations, false);
}

std::array<RGB, kLobeCount> HuangHair::eval_local_impl(const ShadingPoint& sp, Vec3 O, long* evaluations,
                                                       bool lanes) const {
    std::array<RGB, kLobeCount> lobes{};
    if (evaluations) *evaluations = 0;
    if (!sp.valid) return lobes;
    const Vec3 I = sp.I;
    if (tilt_hides(O)) return lobes;
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
        r_value = r_lobe(sp, wh, integral);
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
        const double* x3 = GaussLegendre<3>::x;
        const double* w3 = GaussLegendre<3>::w;
        const double width = (g_hi - g_lo) / panels;
        for (int k = 0; k < panels; ++k)
            for (int q = 0; q < 3; ++q) nodes.push_back({g_lo + width * (k + 0.5 + 0.5 * x3[q]), 0.5 * width * w3[q] / sp.r});
    }
    const double final_scale = sp.norm * inv_eta_ * inv_eta_;
    const double trrt_scale = trrt_scale_at(sp, O);
    long count = 0;

    // TT: a 2D integral over the entry visible normal per node, adaptive cubature with one
    // priority queue over all nodes, to the relative tolerance of the total.
    if (factors_[1] > 0.0 && !nodes.empty()) {
        Residual res{*this, sp, O, trrt_scale, final_scale, {}, 0.0};
        const HuangLanePoint lane = lane_point(sp, O, wh, 1.0, 0.0, 0.0);
        if (lanes && params_.tolerance >= kTtLanesMinTolerance) res.lane = &lane;
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
    if (factors_[2] > 0.0 && params_.trt_points == 0) {
        if (!nodes.empty())
            trt_by_tolerance(sp, O, nodes, trrt_node_factor, std::fabs(r_value) + std::fabs(luminance(lobes[1])),
                             final_scale, trrt_scale, lanes, lobes, count);
    } else if (factors_[2] > 0.0) {
        const uint32_t npts = uint32_t(std::max(params_.trt_points, kMinFixedTrtPoints));
        const SobolColumns columns(0, lanes ? npts : 0);
        double acc[6] = {0, 0, 0, 0, 0, 0};
        uint32_t seed = 0x2545F491u;
        for (size_t kn = 0; kn < nodes.size(); ++kn) {
            const Node& n = nodes[kn];
            const double trrt_factor = kn < trrt_node_factor.size() ? trrt_node_factor[kn] : 1.0;
            uint32_t shift[4];
            for (uint32_t& sh : shift) sh = seed = lookup3_hash_uint2(seed, 0x9E3779B9u);
            // An end node moved 1e-9 inside (trrt_factor 0.5) stays in double: float would lose the move.
            const bool on_lanes = lanes && trrt_factor == 1.0;
            trt_node_points(sp, O, {n.h, n.weight / double(npts)}, shift, 0, npts, on_lanes ? columns.columns : nullptr,
                            factors_[2] * final_scale, trrt_factor * trrt_scale, acc);
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

// --- TRT and TRRT+ to the tolerance (trt_points = 0) ----------------------------------------------

// Randomized quasi-Monte Carlo with the h nodes kept as strata: kTrtReplicates copies of one
// Sobol' set per node, each copy with its own digital shifts; the spread of the copies' totals is
// the standard error of their mean. Points per node double until that error is below half the
// tolerance times the row's total (R + TT + TRT + TRRT+) or the budget is spent, so TRT gets few
// points where it is a small part of the row and many where it dominates. The first round already has
// kTrtMinimum / tolerance points over the row (within the budget): TRT's value on some rows comes from
// rare large points (1 in ~1000), and 4 copies of a few points that all missed them agree, so their
// spread said "done" with TRT 0 (docs/huang.md §4). Budget: max_evaluations
// TRT points (TT's cubature has its own), and at most kTrtBudget / tolerance^2 (what an estimate whose points have a relative
// spread of ~2 needs to reach the target where TRT is the whole row): loose tolerances stay cheap
// on the rows TRT dominates, whose error then exceeds the tolerance (docs/huang.md §4).
namespace {
constexpr int kTrtReplicates = 4;
constexpr uint32_t kTrtFirstPoints = 4;  // per node and replicate
constexpr double kTrtBudget = 20.0;
constexpr double kTrtMinimum = 20.0;  // at least kTrtMinimum / tolerance TRT points per row
}  // namespace

void HuangHair::trt_by_tolerance(const ShadingPoint& sp, Vec3 O, const std::vector<Node>& nodes,
                                 const std::vector<double>& trrt_node_factor, double known_value, double final_scale,
                                 double trrt_scale, bool lanes, std::array<RGB, kLobeCount>& lobes,
                                 long& count) const {
    const size_t node_count = nodes.size();
    std::vector<std::array<uint32_t, 4>> shifts(node_count * kTrtReplicates);
    uint32_t seed = 0x1B873593u;  // not the fixed-point rule's shifts: the two stay independent
    for (auto& row : shifts)
        for (uint32_t& sh : row) sh = seed = lookup3_hash_uint2(seed, 0x9E3779B9u);
    // Per replicate: sums of TRT and TRRT+ (rgb), each point weighted by the node weight.
    std::array<std::array<double, 6>, kTrtReplicates> sums{};
    uint32_t points = 0;  // per node and replicate so far
    auto add = [&](uint32_t from, uint32_t to) {
        const SobolColumns columns(from, lanes ? to : from);  // the points of this round, shared by every node
        for (size_t kn = 0; kn < node_count; ++kn) {
            const double trrt_factor = kn < trrt_node_factor.size() ? trrt_node_factor[kn] : 1.0;
            // An end node moved 1e-9 inside (trrt_factor 0.5) stays in double: float would lose the move.
            const bool on_lanes = lanes && trrt_factor == 1.0;
            for (int r = 0; r < kTrtReplicates; ++r) {
                const auto& shift = shifts[kn * kTrtReplicates + size_t(r)];
                const uint32_t sh[4] = {shift[0], shift[1], shift[2], shift[3]};
                trt_node_points(sp, O, nodes[kn], sh, from, to, on_lanes ? columns.columns : nullptr,
                                factors_[2] * final_scale, trrt_factor * trrt_scale, sums[size_t(r)].data());
            }
        }
        count += long(to - from) * long(node_count) * kTrtReplicates;
        points = to;
    };
    auto luminance_of = [&](int r) {  // replicate r's TRT + TRRT+ estimate
        const auto& v = sums[size_t(r)];
        return (luminance3(&v[0]) + luminance3(&v[3])) / double(points);
    };
    // TRT's own budget (TT's cubature has its own max_evaluations).
    const double budget = std::min(double(params_.max_evaluations), kTrtBudget / (params_.tolerance * params_.tolerance));
    const double per_point = double(node_count) * kTrtReplicates;  // TRT points per point of each node and copy
    uint32_t first = kTrtFirstPoints;
    while (double(first) * per_point < kTrtMinimum / params_.tolerance && 2.0 * double(first) * per_point <= budget)
        first *= 2;
    add(0, first);
    for (;;) {
        double mean = 0.0, var = 0.0;
        for (int r = 0; r < kTrtReplicates; ++r) mean += luminance_of(r) / kTrtReplicates;
        for (int r = 0; r < kTrtReplicates; ++r) var += (luminance_of(r) - mean) * (luminance_of(r) - mean);
        const double standard_error = std::sqrt(var / ((kTrtReplicates - 1) * kTrtReplicates));
        const double target = 0.5 * params_.tolerance * (known_value + std::fabs(mean));
        if (!(standard_error > target)) break;
        const long next = long(points) * long(node_count) * kTrtReplicates;
        const double trt_spent = double(points) * double(node_count) * kTrtReplicates;
        if (trt_spent + double(next) > budget || points >= (1u << 24)) break;
        add(points, 2 * points);
    }
    const double scale = 1.0 / (double(points) * kTrtReplicates);
    std::array<double, 6> mean{};
    for (const auto& v : sums)
        for (int j = 0; j < 6; ++j) mean[size_t(j)] += v[size_t(j)] * scale;
    lobes[2] = RGB(mean[0], mean[1], mean[2]);
    lobes[3] = RGB(mean[3], mean[4], mean[5]);
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

// One entry state per node serves TT and TRT (they share the entry visible normal); the numbers are
// drawn in Cycles' order whether or not the entry succeeds.
void HuangHair::add_residual_node(const ShadingPoint& sp, Vec3 O, double gamma, double sin_gamma, double cos_gamma,
                                  double weight, double final_scale, double trrt_scale, uint32_t& rng,
                                  std::array<double, 9>& acc) const {
    const double a = lcg_step_float(rng), b = lcg_step_float(rng);
    const double r1 = std::sqrt(a), angle1 = kTwoPi * b;
    const bool tt = factors_[1] > 0.0, trt = factors_[2] > 0.0;
    double c = 0.0, d = 0.0;
    if (trt) {
        c = lcg_step_float(rng);
        d = lcg_step_float(rng);
    }
    EntryState e;
    if (!entry_state(sp, gamma, sin_gamma, cos_gamma, r1, angle1, e)) return;
    if (tt) {
        const RGB v = (weight * factors_[1] * final_scale) * tt_exit(e, O);
        acc[0] += v.r, acc[1] += v.g, acc[2] += v.b;
    }
    if (trt) {
        std::array<double, 9> f{};
        trt_from_entry(e, O, std::sqrt(c), kTwoPi * d, weight, final_scale, trrt_scale, f);
        for (size_t k = 3; k < 9; ++k) acc[k] += f[k];
    }
}

void HuangHair::add_residual_nodes(const ShadingPoint& sp, Vec3 O, const std::vector<Node>& nodes, uint32_t& rng,
                                   std::array<RGB, kLobeCount>& lobes) const {
    const double final_scale = sp.norm * inv_eta_ * inv_eta_;
    const double trrt_scale = trrt_scale_at(sp, O);
    std::array<double, 9> acc{};
    for (const Node& n : nodes) {
        const double gamma = h_to_gamma(sp, n.h);
        const double sin_gamma = std::sin(gamma), cos_gamma = std::cos(gamma);
        const double w = n.weight * dgamma_dh_sc(sp.sin_phi_i, sp.cos_phi_i, sin_gamma, cos_gamma);
        add_residual_node(sp, O, gamma, sin_gamma, cos_gamma, w, final_scale, trrt_scale, rng, acc);
    }
    lobes[1] = RGB(acc[0], acc[1], acc[2]);
    lobes[2] = RGB(acc[3], acc[4], acc[5]);
    lobes[3] = RGB(acc[6], acc[7], acc[8]);
}

// The same eval in float lanes: R's nodes, then the residual's with every node's numbers drawn first, in
// add_residual_node's order (src/models/huang_lanes_kernel.h). wh is normalize(I + O) (R only).
void HuangHair::eval_lanes(const ShadingPoint& sp, Vec3 O, Vec3 wh, const std::vector<Node>& r_nodes,
                           const std::vector<Node>& nodes, uint32_t& rng, std::array<RGB, kLobeCount>& lobes) const {
    const size_t count = std::max(r_nodes.size(), nodes.size());
    constexpr size_t kOnStack = 64;  // Cycles' node counts at roughness >= 0.03 fit
    float on_stack[6][kOnStack];
    std::vector<float> on_heap;
    float* column[6];
    if (count > kOnStack) on_heap.resize(6 * count);
    for (size_t a = 0; a < 6; ++a) column[a] = count > kOnStack ? on_heap.data() + a * count : on_stack[a];
    const double final_scale = sp.norm * inv_eta_ * inv_eta_;
    const double trrt_scale = trrt_scale_at(sp, O);
    const bool trt = factors_[2] > 0.0;
    const HuangLanePoint p = lane_point(sp, O, wh, factors_[1] * final_scale, factors_[2] * final_scale, trrt_scale);
    if (factors_[0] > 0.0) {
        for (size_t k = 0; k < r_nodes.size(); ++k) {
            column[0][k] = float(r_nodes[k].h);
            column[1][k] = float(r_nodes[k].weight);
        }
        const double integral = huang_r_lanes(lanes_, p, {r_nodes.size(), column[0], column[1], {}, {}, {}, {}});
        lobes[0] = RGB(r_lobe(sp, wh, integral));
    }
    if (!(factors_[1] > 0.0) && !trt) return;
    for (size_t k = 0; k < nodes.size(); ++k) {
        column[0][k] = float(nodes[k].h);
        column[1][k] = float(nodes[k].weight);
        column[2][k] = float(lcg_step_float(rng));
        column[3][k] = float(lcg_step_float(rng));
        if (trt) {
            column[4][k] = float(lcg_step_float(rng));
            column[5][k] = float(lcg_step_float(rng));
        }
    }
    double acc[9] = {};
    huang_residual_lanes(lanes_, p, {nodes.size(), column[0], column[1], column[2], column[3], column[4], column[5]},
                         acc);
    lobes[1] = RGB(acc[0], acc[1], acc[2]);
    lobes[2] = RGB(acc[3], acc[4], acc[5]);
    lobes[3] = RGB(acc[6], acc[7], acc[8]);
}

std::array<RGB, kLobeCount> HuangHair::eval_cycles_stochastic(const ShadingPoint& sp, Vec3 O, uint32_t& rng) const {
    return eval_cycles_stochastic_impl(sp, O, rng, true);
}

std::array<RGB, kLobeCount> HuangHair::eval_cycles_stochastic_double(const ShadingPoint& sp, Vec3 O,
                                                                     uint32_t& rng) const {
    return eval_cycles_stochastic_impl(sp, O, rng, false);
}

// The Simpson nodes are the shading point's (prepare made them) unless it has none (Converged quadrature).
std::array<RGB, kLobeCount> HuangHair::eval_cycles_stochastic_impl(const ShadingPoint& sp, Vec3 O, uint32_t& rng,
                                                                   bool lanes) const {
    std::array<RGB, kLobeCount> lobes{};
    if (!sp.valid) return lobes;
    const Vec3 I = sp.I;
    if (tilt_hides(O)) return lobes;
    const bool have_nodes = !sp.r_nodes.empty() && !sp.residual_nodes.empty();
    std::vector<Node> r_computed, computed;
    if (!have_nodes) {
        if (factors_[0] > 0.0) r_computed = simpson_nodes(sp.h_lo, sp.h_hi, kRStep);
        if (factors_[1] > 0.0 || factors_[2] > 0.0) computed = simpson_nodes(sp.h_lo, sp.h_hi, kResidualStep);
    }
    const std::vector<Node>& r_nodes = have_nodes ? sp.r_nodes : r_computed;
    const std::vector<Node>& nodes = have_nodes ? sp.residual_nodes : computed;
    const Vec3 wh = normalize(I + O);
    if (lanes) {
        eval_lanes(sp, O, wh, r_nodes, nodes, rng, lobes);
        return lobes;
    }
    if (factors_[0] > 0.0) {
        double integral = 0.0;
        for (const Node& n : r_nodes) integral += n.weight * r_integrand(sp, O, wh, n.h);
        lobes[0] = RGB(r_lobe(sp, wh, integral));
    }
    if (!(factors_[1] > 0.0) && !(factors_[2] > 0.0)) return lobes;
    add_residual_nodes(sp, O, nodes, rng, lobes);
    return lobes;
}

}  // namespace hairbsdf
