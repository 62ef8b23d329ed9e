// Huang, Hullin and Hanika 2022, "A Microfacet-based Hair Scattering Model", with the semantics of
// Blender Cycles 4.5's Principled Hair "Huang" closure (docs/cycles.md §2.5, §5; docs/huang.md).
//
// What differs from Cycles, on purpose:
//   * eval is deterministic: the microfacet integrals Cycles estimates with one random visible
//     normal per Simpson node are integrated by adaptive cubature (docs/huang.md §4). Its value is
//     the EXPECTED value of Cycles' eval (HuangQuadrature::Cycles: Cycles' own Simpson nodes in h)
//     or the converged integral (HuangQuadrature::Converged);
//   * the default sampler is a mixture of analytic lobes (visible-normal reflection / refraction
//     lobes around a discrete set of mesonormals, Chiang's longitudinal lobe for TRRT+ and a small
//     uniform component), whose density pdf() returns exactly, so sample/pdf pass a chi-square test
//     and MIS works. HuangSampler::Cycles keeps Cycles' sampler (weight = its energy estimate,
//     pdf reported as 1).
// Frames: the ShadingContext space (fibre frame in the Python API). Internally Huang's local frame:
// y = tangent, x = ellipse major axis (normalize(tangent x wo) for circular fibres), z = x x y.
#pragma once

#include <vector>

#include "hairbsdf/closure.h"
#include "hairbsdf/math_hair_defaults.h"
#include "hairbsdf/models/chiang.h"
#include "hairbsdf/models/huang_ggx.h"

namespace hairbsdf {

// Which E_glass tables (the energy compensation of each interface, docs/huang.md §3) the model uses:
// Cycles 4.x's (16^3, mu axis linear, refractions leaving on the incident side counted) or Cycles
// 5.x's (32^3, sqrt(mu) axis, those refractions rejected). docs/blender5.md.
enum class GlassAlbedoTable { Cycles4, Cycles5 };

namespace huang {
// E_glass tables [eta >= 1 | eta < 1][z][y][sqrt(alpha)] (generated, lab/huang_tables.cpp):
// Cycles 4.x (y = mu) and Cycles 5.x (y = sqrt(mu)).
extern const double kGgxGlassAlbedo[2][16][16][16];
extern const double kGgxGlassAlbedo5[2][32][32][32];

// Cycles' lookup_table_read_3D on one n^3 table: coordinates saturated, trilinear.
template <int n>
inline double lookup_table_3d(const double (&t)[n][n][n], double x, double y, double z) {
    auto axis = [](double v, int& i0, int& i1, double& f) {
        v = clamp(v, 0.0, 1.0) * (n - 1);
        i0 = std::min(int(v), n - 1);
        i1 = std::min(i0 + 1, n - 1);
        f = v - i0;
    };
    int x0, x1, y0, y1, z0, z1;
    double fx, fy, fz;
    axis(x, x0, x1, fx);
    axis(y, y0, y1, fy);
    axis(z, z0, z1, fz);
    auto plane = [&](int k) {
        const double a = (1 - fx) * t[k][y0][x0] + fx * t[k][y0][x1];
        const double b = (1 - fx) * t[k][y1][x0] + fx * t[k][y1][x1];
        return (1 - fy) * a + fy * b;
    };
    return (1 - fz) * plane(z0) + fz * plane(z1);
}
// 1 / E_glass(sqrt(alpha), mu, eta): the energy compensation of one interface (docs/cycles.md §5.3),
// from the tables of the chosen Cycles version.
// energy_scale's coordinate of eta: sqrt(|(eta - 1) / (eta + 1)|).
inline double energy_scale_z(double eta) { return std::sqrt(std::fabs((eta - 1.0) / (eta + 1.0))); }
// energy_scale with z = energy_scale_z(eta) computed once per model.
// The tables' first index: eta >= 1 or eta < 1.
inline int glass_albedo_side(double eta) { return eta < 1.0 ? 1 : 0; }
inline double energy_scale_at(GlassAlbedoTable table, double sqrt_alpha, double mu, double eta, double z) {
    const int which = glass_albedo_side(eta);
    const double e = table == GlassAlbedoTable::Cycles5
                         ? lookup_table_3d(kGgxGlassAlbedo5[which], sqrt_alpha, safe_sqrt(mu), z)
                         : lookup_table_3d(kGgxGlassAlbedo[which], sqrt_alpha, mu, z);
    return 1.0 / e;
}
inline double energy_scale(GlassAlbedoTable table, double sqrt_alpha, double mu, double eta) {
    return energy_scale_at(table, sqrt_alpha, mu, eta, energy_scale_z(eta));
}
}  // namespace huang

// h rule of the deterministic eval: Cycles' composite Simpson nodes (steps 0.7 alpha for R and
// 0.8 alpha for the rest; the expected value of Cycles' eval), or the converged integral.
enum class HuangQuadrature { Cycles, Converged };
// Sampler: mixture of analytic lobes with an exact pdf, or Cycles' sampler (pdf reported as 1).
enum class HuangSampler { Mixture, Cycles };

// trt_points: 0 (TRT / TRRT+ points set by `tolerance`) or at least this many fixed points per h node.
constexpr long kMinFixedTrtPoints = 16;
inline bool trt_points_allowed(long n) { return n == 0 || n >= kMinFixedTrtPoints; }

struct HuangHairParams {
    RGB sigma_a{0.0};          // absorption per unit fibre diameter (major axis)
    double roughness = 0.3;    // GGX alpha; clamped to [0.001, 1] like Cycles
    double offset = blender_hair::kOffset;  // Blender's Offset (radians); Cycles' mesonormal tilt is -offset
    double eta = blender_hair::kIor;        // IOR, used as given
    double aspect_ratio = 1.0;  // minor / major axis; > 1 is inverted like Cycles (docs/huang.md §1)
    double r_factor = 1.0, tt_factor = 1.0, trt_factor = 1.0;  // Reflection, Transmission, Secondary Reflection (>= 0)
    HuangQuadrature quadrature = HuangQuadrature::Cycles;
    // The API's defaults (the Python module reads them from here, huang_option_defaults):
    double tolerance = 1e-2;   // error target relative to the row's total (TT cubature, TRT points, albedo)
    long max_evaluations = 200000;  // cap on TT integrand evaluations (and on TRT points) per eval
    long trt_points = 0;       // trt_points_allowed: 0, set by tolerance; else fixed points per h node
    HuangSampler sampler = HuangSampler::Mixture;
    GlassAlbedoTable glass_albedo_table = GlassAlbedoTable::Cycles4;  // Cycles 4.x or 5.x energy compensation
    // Mixture sampler resolution: Full (up to 48 R, 144 TT and 128 TRT components per shading
    // point) or Coarse (up to 12, 16 and 16: the renderer's choice; the pdf stays exact, only
    // the importance sampling is rougher, so renders get noisier but not biased), or None (no
    // mixture is built: for the renderer with Cycles' sampler; sample_direction then returns -1
    // and pdf_local 0).
    enum class MixtureDetail { Full, Coarse, None } mixture_detail = MixtureDetail::Full;
};

// The per-model numbers of Cycles' stochastic eval in float SIMD lanes (src/models/huang_lanes_kernel.h,
// docs/simd.md), filled by the HuangHair constructor. energy_scale's table lookup has only mu varying
// per node (sqrt(alpha) and eta are the model's), so each interface's E_glass is reduced once to a
// row over mu: trilinear interpolation is linear in each coordinate, so interpolating that row in mu
// gives lookup_table_3d's value.
struct HuangLaneConstants {
    static constexpr int kMaxRow = 32;  // the larger table's side (Cycles 5.x)
    float alpha, alpha2, sin_tilt, cos_tilt, b, e2, eta, inv_eta;
    float sigma_a[3];
    float shell_lo, shell_hi;  // TRRT+'s shell: trrt_shell_lo_, trrt_shell_hi_
    bool circular;   // b == 1
    bool sqrt_mu;    // the table's axis is sqrt(mu) (Cycles 5.x)
    int row_size;    // 16 or 32
    float energy_entering[kMaxRow], energy_leaving[kMaxRow];  // E_glass over the mu axis
};

class HuangHair {
public:
    explicit HuangHair(const HuangHairParams& params);
    const HuangHairParams& params() const { return params_; }
    // Cycles' Filter Glossy: alpha <- max(roughness, alpha).
    HuangHair blurred(double roughness) const {
        HuangHairParams b = params_;
        b.roughness = std::max(roughness, params_.roughness);
        return HuangHair(b);
    }
    // Cycles labels every Huang lobe a glossy reflection.
    static uint8_t scatter_label(int) { return uint8_t(LabelGlossy | LabelReflect); }
    // The renderer's eval is Cycles' stochastic estimator (eval_estimate), its LCG state seeded
    // per hit with one uniform number u of the path's sampler.
    static constexpr bool kStochasticEval = true;
    static uint32_t eval_seed(double u) { return uint32_t(u * 4294967296.0); }
    double alpha() const { return alpha_; }
    double aspect_ratio() const { return b_; }

    // Quadrature node in the r-normalised h, with its weight (Simpson weight x spacing).
    struct Node {
        double h, weight;
    };
    // One lobe of the sampling mixture: a visible-normal lobe around mesonormal m for the
    // direction v, leaving by reflection (R) or by refraction out of the fibre (TT, TRT).
    struct Component {
        Vec3 v, m;          // local frame
        Vec3 s, t;          // orthonormal frame around m
        double probability; // within its lobe
        double inv_norm;    // 1 / (v.m (1 + Lambda(v.m))) of the visible-normal density
    };

    struct ShadingPoint {
        Vec3 x, y, z;            // Huang's local frame (context space)
        Vec3 I;                  // the viewer in the local frame (Cycles' wi)
        double r = 1;            // projected half width from the viewer
        double h = 0;
        double sin_phi_i = 0, cos_phi_i = 1;
        bool transparent = false;  // |h| >= r: Cycles replaces the closure by a transparent BSDF
        bool near_field = false;
        bool valid = false;      // a non-empty integration interval
        double h_lo = 0, h_hi = 0;  // r-normalised, clamped to +-0.999
        double norm = 0;         // 1 / (cos theta_I dh)
        double gamma_base = 0;   // h_to_gamma's h-independent angle atan2(I.z, -b I.x) (ellipses)
        std::vector<Node> r_nodes, residual_nodes;  // Cycles' Simpson nodes (Cycles quadrature)
        // Sampling mixture (lobe order R, TT, TRT, TRRT+, uniform).
        std::array<double, 5> lobe_probability{};
        std::vector<Component> reflection, exits;  // exits: TT components, then TRT components
        size_t tt_count = 0;
    };
    ShadingPoint prepare(const ShadingContext& ctx) const;

    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const;
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const { return eval(prepare(ctx), wi); }
    double pdf(const ShadingPoint& sp, Vec3 wi) const;
    BsdfSample sample(const ShadingPoint& sp, const std::array<double, 3>& u) const;
    BsdfSample sample(const ShadingContext& ctx, const std::array<double, 3>& u) const {
        return sample(prepare(ctx), u);
    }
    // The mixture sampler's direction alone (local frame), without evaluating the BSDF: returns the
    // lobe (0..3; the uniform component reports 3) or -1. Its density is pdf_local.
    int sample_direction(const ShadingPoint& sp, const std::array<double, 3>& u, Vec3& O) const;
    // Narrowest lobe widths (theta, phi) for quadratures over directions.
    std::array<double, 2> angular_scales() const { return {std::max(0.5 * alpha_, 0.01), std::max(0.5 * alpha_, 0.01)}; }

    // Per-lobe values in the local frame (exposed for tests): the expected value of Cycles' eval.
    // Its TRT and TRRT+ points run as float SIMD lanes (docs/simd.md).
    std::array<RGB, kLobeCount> eval_local(const ShadingPoint& sp, Vec3 O, long* evaluations = nullptr) const;
    // The same eval (same points, shifts and stopping rule) with TRT and TRRT+ in double, one point at a time:
    // the reference the lanes are tested against.
    std::array<RGB, kLobeCount> eval_local_double(const ShadingPoint& sp, Vec3 O, long* evaluations = nullptr) const;
    // Cycles' stochastic eval, one random visible normal per Simpson node (for tests and the
    // noise measurements): `rng_state` is Cycles' LCG state, advanced as Cycles does.
    // Its Simpson nodes (R's and the residual's) run as float SIMD lanes, as Cycles computes in float
    // (docs/simd.md); the nodes, their weights and the draws are those of the double path.
    std::array<RGB, kLobeCount> eval_cycles_stochastic(const ShadingPoint& sp, Vec3 O, uint32_t& rng_state) const;
    // The same estimator (same draws, nodes and weights) in double precision, one node at a time: the
    // reference the lanes are tested against.
    std::array<RGB, kLobeCount> eval_cycles_stochastic_double(const ShadingPoint& sp, Vec3 O, uint32_t& rng_state) const;
    // The mixture density in the local frame.
    double pdf_local(const ShadingPoint& sp, Vec3 O) const;

    // The directional albedo (the integral of eval over directions) by Cycles' stochastic eval with each
    // path's own exit: per sample, a residual node and an R node picked by |weight| (u[0]), the node's
    // random normals as eval_cycles_stochastic draws them (u[1..4]), and per lobe one direction from that
    // path's exit (R: reflection through the visible normals of I; TT, TRT: refraction out through the
    // exit's visible normals; TRRT+: its longitudinal lobe; each with a uniform part), value / density.
    // Its expectation is the albedo of eval_cycles_stochastic, hence of eval (docs/huang.md §6).
    struct AlbedoNode {
        double gamma, sin_gamma, cos_gamma;
        double factor;      // the node's weight (Simpson weight x d gamma / dh) / its probability
        double cumulative;  // running sum of the nodes' probabilities up to and including this one
    };
    struct AlbedoNodes {
        std::vector<AlbedoNode> r, residual;
    };
    AlbedoNodes albedo_nodes(const ShadingPoint& sp) const;
    static constexpr size_t kAlbedoNumbers = 18;
    std::array<RGB, kLobeCount> albedo_sample(const ShadingPoint& sp, const AlbedoNodes& nodes,
                                              const std::array<double, kAlbedoNumbers>& u) const;
    Vec3 to_local(const ShadingPoint& sp, Vec3 w) const { return {dot(w, sp.x), dot(w, sp.y), dot(w, sp.z)}; }
    Vec3 to_world(const ShadingPoint& sp, Vec3 w) const { return w.x * sp.x + w.y * sp.y + w.z * sp.z; }

    // In the renderer. Outside the projected ellipse the closure is a transparent one.
    static bool transparent(const ShadingPoint& sp) { return sp.transparent; }
    // Cycles' eval: the mixture's pdf and, where it is positive, the stochastic per-lobe values.
    BsdfEval eval_estimate(const ShadingPoint& sp, Vec3 wi, uint32_t& rng_state) const {
        BsdfEval out;
        out.pdf = pdf(sp, wi);
        if (out.pdf > 0) out.lobes = eval_cycles_stochastic(sp, to_local(sp, wi), rng_state);
        return out;
    }
    // Cycles' sampler: the traced path's energy estimate as the value with pdf 1; the mixture
    // sampler: its exact density with the stochastic eval. Filter Glossy sees pdf 1 in both.
    ScatterSample sample_estimate(const ShadingPoint& sp, const std::array<double, 3>& u, uint32_t& rng_state) const {
        ScatterSample out;
        out.blur_pdf_one = true;
        if (params_.sampler == HuangSampler::Cycles) {
            const BsdfSample s = sample(sp, u);
            if (s.lobe < 0) return out;
            out.wi = s.wi;
            out.pdf = 1.0;
            out.value = s.value;
            out.lobes[size_t(std::min(s.lobe, kLobeCount - 1))] = s.value;
            out.lobe = s.lobe;
            return out;
        }
        Vec3 local;
        const int lobe = sample_direction(sp, u, local);
        if (lobe < 0) return out;
        const Vec3 wi = to_world(sp, local);
        const double pdf = pdf_local(sp, local);
        if (!(pdf > 0)) return out;
        out.wi = wi;
        out.pdf = pdf;
        out.lobes = eval_cycles_stochastic(sp, to_local(sp, wi), rng_state);
        out.value_from_lobes = true;
        out.lobe = lobe;
        return out;
    }

    // Geometry of the cross-section (public for tests).
    double h_to_gamma(double h_div_r, Vec3 w) const;
    double dgamma_dh(double sin_phi, double cos_phi, double gamma) const;
    Vec3 mesonormal(double tilt, double gamma) const;
    double arc_length(double gamma) const;

private:
    // h_to_gamma(h, sp.I) from the point's gamma_base (one acos per node, no atan2).
    double h_to_gamma(const ShadingPoint& sp, double h_div_r) const {
        if (b_ == 1.0) return -safe_asin(h_div_r);
        return sp.gamma_base - std::acos(clamp(-h_div_r, -1.0, 1.0));
    }
    // dgamma_dh and mesonormal from sin and cos of gamma (and of the tilt), computed once by the caller.
    double dgamma_dh_sc(double sin_phi, double cos_phi, double sin_gamma, double cos_gamma) const {
        const double d = b_ == 1.0 ? cos_gamma : cos_phi * cos_gamma + b_ * sin_phi * sin_gamma;
        return d != 0.0 ? 1.0 / d : 0.0;
    }
    Vec3 mesonormal_sc(double sin_tilt, double cos_tilt, double sin_gamma, double cos_gamma) const {
        if (b_ != 1.0 && std::fabs(cos_gamma) >= 1e-6) {
            const double n = std::sqrt(cos_gamma * cos_gamma + b_ * b_ * sin_gamma * sin_gamma);
            sin_gamma = b_ * sin_gamma / n;
            cos_gamma = cos_gamma / n;
        }
        return {sin_gamma * cos_tilt, sin_tilt, cos_gamma * cos_tilt};
    }
    // huang::energy_scale at the model's roughness entering (eta) or leaving (1 / eta) the fibre.
    double energy_scale_entering(double mu) const {
        return huang::energy_scale_at(params_.glass_albedo_table, sqrt_alpha_, mu, eta_, z_eta_);
    }
    double energy_scale_leaving(double mu) const {
        return huang::energy_scale_at(params_.glass_albedo_table, sqrt_alpha_, mu, inv_eta_, z_inv_eta_);
    }
    double arc_length_sc(double sin_gamma) const { return e2_ == 0.0 ? 1.0 : std::sqrt(1.0 - e2_ * sqr(sin_gamma)); }
    double r_integrand_sc(const ShadingPoint& sp, Vec3 O, Vec3 wh, double sin_gamma, double cos_gamma) const;
    struct Residual;  // integrand of the adaptive residual integration
    // TRT and TRRT+ at mesonormal parameter gamma for the entry visible normal at disk point (r1, angle1)
    // and the internal one at (r2, angle2), times `weight`; writes final eval units into f: TT rgb (zero),
    // TRT rgb, TRRT+ rgb. (TT's points: Residual::eval.)
    void trt_point(const ShadingPoint& sp, Vec3 O, double gamma, double r1, double angle1, double r2,
                   double angle2, double weight, double final_scale, double trrt_scale,
                   std::array<double, 9>& f) const;
    // One residual node of Cycles' stochastic eval: TT and (TRT, TRRT+) at mesonormal gamma, their
    // disk points drawn from rng in Cycles' order, times `weight`, added to acc.
    void add_residual_node(const ShadingPoint& sp, Vec3 O, double gamma, double sin_gamma, double cos_gamma,
                           double weight, double final_scale, double trrt_scale, uint32_t& rng,
                           std::array<double, 9>& acc) const;
    // eval_cycles_stochastic's residual in double, one node at a time: every node of `nodes`, into lobes 1..3.
    void add_residual_nodes(const ShadingPoint& sp, Vec3 O, const std::vector<Node>& nodes, uint32_t& rng,
                            std::array<RGB, kLobeCount>& lobes) const;
    // eval_cycles_stochastic in float lanes: R over r_nodes, the residual over nodes.
    void eval_lanes(const ShadingPoint& sp, Vec3 O, Vec3 wh, const std::vector<Node>& r_nodes,
                    const std::vector<Node>& nodes, uint32_t& rng, std::array<RGB, kLobeCount>& lobes) const;
    std::array<RGB, kLobeCount> eval_cycles_stochastic_impl(const ShadingPoint& sp, Vec3 O, uint32_t& rng,
                                                            bool lanes) const;
    RGB trrt_series(double t, double r, RGB a) const;
    // Cycles' composite Simpson nodes over [lo, hi]: an even count of steps of at most step x alpha
    // (the steps divided by simpson_refinement_).
    std::vector<Node> simpson_nodes(double lo, double hi, double step) const;
    // The path up to the second interface for the entry visible normal at disk point (r1, angle1).
    struct EntryState {
        double gamma, cos_mi1, t1, scale1, phi_t_b, gmt, sin_gmt, cos_gmt, cos_mo1, cos_mi2, g1o, scale2;
        Vec3 wmi, wt, mwt, wmt, wmt_;
        RGB a_t;
    };
    bool entry_state(const ShadingPoint& sp, double gamma, double r1, double angle1, EntryState& e) const {
        return entry_state(sp, gamma, std::sin(gamma), std::cos(gamma), r1, angle1, e);
    }
    bool entry_state(const ShadingPoint& sp, double gamma, double sin_gamma, double cos_gamma, double r1,
                     double angle1, EntryState& e) const;
    // TRT and TRRT+ for the internal visible normal at disk point (r2, angle2), times weight, into f[3..8].
    void trt_from_entry(const EntryState& e, Vec3 O, double r2, double angle2, double weight, double final_scale,
                        double trrt_scale, std::array<double, 9>& f) const;
    RGB tt_exit(const EntryState& e, Vec3 O) const;
    // Cycles' internal visible normal (of -wt around the internal mesonormal) at disk point (r, angle).
    Vec3 internal_normal(const EntryState& e, double r, double angle) const;
    // TRRT+'s factor at O (Cycles' longitudinal M, 1 / 2 pi, 2 / pi, the point's norm).
    double trrt_scale_at(const ShadingPoint& sp, Vec3 O) const;
    // trrt_only: return after the TRRT+ series is known (TRT left 0).
    RGB trt_internal(const EntryState& e, Vec3 wh2, Vec3 O, RGB& trrt, Vec3* wtr_out = nullptr,
                     bool trrt_only = false) const;
    // TRRT+'s shell proposal for the internal microfacet normal (trt_mis_point): its frame at an entry
    // state (a = -wt; s towards the internal mesonormal, at angle beta from a; t = a x s), a point from
    // (u2, u3), and its density (solid angle) at a normal.
    struct ShellFrame {
        Vec3 a, s, t;
        double cos_beta, sin_beta;
    };
    ShellFrame trrt_shell_frame(const EntryState& e) const;
    Vec3 trrt_shell_sample(const ShellFrame& f, double u2, double u3) const;
    double trrt_shell_density(const ShellFrame& f, Vec3 h) const;
    // The balance heuristic's weight of Cycles' internal visible normals (density pa of `visible_normals`)
    // against the shell (pc) at the normal h: pa / (pa + pc), 1 outside the shell.
    double trrt_visible_share(const ShellFrame& f, const Component& visible_normals, Vec3 h) const;
    // TRRT+'s series over the internal normal by two strategies and the balance heuristic: Cycles' visible normal
    // wh2 (of `visible_normals`; the caller's trt_internal gave its series) and the shell's normal from (u2, u3);
    // times weight. Without a shell (off, -wt not seeing the internal mesonormal, no band) weight x series.
    RGB trrt_two_strategies(const EntryState& e, const Component& visible_normals, Vec3 wh2, RGB series, Vec3 O,
                            double u2, double u3, double weight) const;
    std::array<RGB, kLobeCount> eval_local_impl(const ShadingPoint& sp, Vec3 O, long* evaluations, bool lanes) const;
    double r_lobe(const ShadingPoint& sp, Vec3 wh, double integral) const;
    void trt_by_tolerance(const ShadingPoint& sp, Vec3 O, const std::vector<Node>& nodes,
                          const std::vector<double>& trrt_node_factor, double known_value, double final_scale,
                          double trrt_scale, bool lanes, std::array<RGB, kLobeCount>& lobes, long& count) const;
    // TRT and TRRT+ of trt_mis_point over the Sobol' points [from, to) of node n (gamma, weight) with the
    // digital shifts sh, times trt_scale and trrt_scale, added to acc[0..5]; on the float lanes when columns
    // (the unshifted points [from, to), one array per dimension 0-3) is given, else in double.
    void trt_node_points(const ShadingPoint& sp, Vec3 O, const Node& n, const uint32_t (&sh)[4], uint32_t from,
                         uint32_t to, const uint32_t* const* columns, double trt_scale, double trrt_scale,
                         double acc[6]) const;
    void trt_mis_point(const ShadingPoint& sp, Vec3 O, double gamma, double r1, double angle1, double u2, double u3,
                       double weight, RGB& trt, RGB& trrt) const;
    double r_integrand(const ShadingPoint& sp, Vec3 O, Vec3 wh, double h) const;
    double r_integrand_gamma(const ShadingPoint& sp, Vec3 O, Vec3 wh, double gamma) const;
    RGB absorption(double path, double cos_theta) const;
    void build_sampler(ShadingPoint& sp) const;
    void albedo_node(const ShadingPoint& sp, const AlbedoNode& node, bool residual,
                     const std::array<double, kAlbedoNumbers>& u, std::array<RGB, kLobeCount>& lobes) const;
    // A sampling component: visible normals of direction v around the unit normal m.
    Component component(Vec3 v, Vec3 m, double probability) const;
    // Refraction out of the fibre through a visible normal of component c (disk point r, angle; the mixture's
    // TT and TRT exits): false where none leaves (total internal reflection). Its density (solid angle) at O.
    bool exit_sample(const Component& c, double r, double angle, Vec3& O) const;
    double exit_density(const Component& c, Vec3 O) const;
    // Reflection of c.v about a visible normal of component c (disk point r, angle; the mixture's R lobe and the
    // albedo's), not normalised. Its density (solid angle) over `count` components, each by its probability,
    // times `probability`.
    Vec3 reflection_sample(const Component& c, double r, double angle) const;
    double reflection_density(Vec3 I, Vec3 O, const Component* components, size_t count, double probability) const;
    // TRRT+'s direction: Chiang's longitudinal lobe (v = 4 alpha around -theta_I) from (u0, u1), azimuth
    // 2 pi u_phi; not normalised. Its density (solid angle) times `probability`.
    Vec3 trrt_direction(Vec3 I, double u0, double u1, double u_phi) const;
    double trrt_density(Vec3 I, Vec3 O, double probability) const;
    // The eval is 0 for directions the tilted mesonormals turn away from everywhere.
    bool tilt_hides(Vec3 O) const;
    // TRT's exit mesonormal for the internally reflected direction wtr of entry state e (sin and cos of its gamma).
    Vec3 trt_exit_mesonormal(const EntryState& e, Vec3 wtr, double* sin_gamma = nullptr, double* cos_gamma = nullptr) const;
    void fill_lane_constants();
    void set_frame(const ShadingContext& ctx, ShadingPoint& sp) const;  // frame, I, r, transparent
    BsdfSample sample_cycles(const ShadingPoint& sp, const std::array<double, 3>& u) const;

    friend struct HuangLab;  // measurement switches (huang_lab.h)

    HuangHairParams params_;
    int simpson_refinement_ = 1;  // 1: Cycles' steps; more only through HuangLab
    bool trrt_shell_ = true;      // TRRT+'s shell proposal in trt_mis_point; off only through HuangLab
    double alpha_, alpha2_, sqrt_alpha_;
    double tilt_;          // Cycles' tilt = -offset
    double tan_tilt_, sin_tilt_, cos_tilt_;
    double b_, e2_;
    double eta_, inv_eta_;
    // Cosines of the internal incidence (on -wt) between which the internal Fresnel factor rises from
    // kTrrtShellFresnel to total internal reflection: where the TRRT+ series is large (huang_paths.cpp).
    double trrt_shell_lo_, trrt_shell_hi_;
    double z_eta_, z_inv_eta_;  // huang::energy_scale_z of eta_ and inv_eta_
    std::array<double, 3> factors_;
    LongitudinalLobe trrt_m_;        // Cycles' M with v = 4 alpha (truncated Bessel series)
    LongitudinalLobe trrt_sampler_;  // exact M with v = 4 alpha: the TRRT+ sampling density
    HuangLaneConstants lanes_;       // the stochastic eval's float lanes
};

}  // namespace hairbsdf
