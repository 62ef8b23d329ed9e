// Measurements of the Huang model for docs/huang.md (run by hand, not a test):
//   simpson    how far Cycles' Simpson rule over h (steps 0.7 alpha / 0.8 alpha) is from the
//              converged integral, per lobe, far and near field;
//   speed      R and TT at equal error against a converged reference: Cycles' rule (R: its
//              deterministic Simpson sum; TT: its one-random-normal-per-node estimator, averaged as
//              often as needed) versus our deterministic rules at the same error;
//   speed_trt [M [alpha]]  the same for TRT + TRRT+, against the mean of M Cycles evaluations
//              (default 2e6; M / 4 at alpha 0.02); HUANG_MEASURE_VERBOSE=1 prints each configuration;
//   trt_lobes alpha index M max_points  TRT and TRRT+ separately at one of speed_trt's configurations;
//   trt_variance alpha near|far rows points  where the TRT rule's variance is (issue 28).
// Build: cmake --build build/cpp --target huang_measure; run: build/cpp/lab/huang_measure [mode]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <thread>
#include <vector>

#include "hairbsdf/models/huang.h"
#include "hairbsdf/models/huang_lab.h"
#include "hairbsdf/math_quadrature.h"

using namespace hairbsdf;

namespace {

struct Config {
    Vec3 wo, wi;
    double h;
    bool near;
};

double lum(RGB c) { return luminance(c); }

Vec3 unit(std::mt19937_64& rng) {
    std::normal_distribution<double> g;
    for (;;) {
        const Vec3 v{g(rng), g(rng), g(rng)};
        if (length(v) > 1e-6) return normalize(v);
    }
}

// Directions where the BSDF is not negligible: wi drawn from the model's own sampler.
std::vector<Config> configs(const HuangHair& m, int n, bool near, uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uni;
    std::vector<Config> out;
    while (int(out.size()) < n) {
        Config c;
        c.wo = unit(rng);
        if (std::fabs(c.wo.x) > 0.9) continue;
        c.h = 1.6 * uni(rng) - 0.8;
        c.near = near;
        ShadingContext ctx;
        ctx.wo = c.wo;
        ctx.h = c.h;
        ctx.near_field = near;
        ctx.pixel_coverage = 1.0 / 60;
        const auto sp = m.prepare(ctx);
        Vec3 O;
        if (m.sample_direction(sp, {uni(rng), uni(rng), uni(rng)}, O) < 0) continue;
        c.wi = m.to_world(sp, O);
        out.push_back(c);
    }
    return out;
}

HuangHair::ShadingPoint prep(const HuangHair& m, const Config& c) {
    ShadingContext ctx;
    ctx.wo = c.wo;
    ctx.h = c.h;
    ctx.near_field = c.near;
    ctx.pixel_coverage = 1.0 / 60;
    return m.prepare(ctx);
}

HuangHairParams base(double alpha, double r, double tt, double trt) {
    HuangHairParams p;
    p.sigma_a = RGB(0.2, 0.5, 1.0);
    p.roughness = alpha;
    p.offset = 0.0349066;
    p.aspect_ratio = 1.0;
    p.r_factor = r;
    p.tt_factor = tt;
    p.trt_factor = trt;
    p.tolerance = 1e-3;  // the fixed-point TRT rule of these measurements
    p.trt_points = 16384;
    return p;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Values per config per lobe for a model.
std::vector<std::array<double, 4>> values(const HuangHair& m, const std::vector<Config>& cs, double* secs) {
    std::vector<std::array<double, 4>> out;
    const auto t0 = std::chrono::steady_clock::now();
    for (const Config& c : cs) {
        const auto sp = prep(m, c);
        const auto l = m.eval_local(sp, m.to_local(sp, c.wi));
        out.push_back({lum(l[0]), lum(l[1]), lum(l[2]), lum(l[3])});
    }
    if (secs) *secs = seconds_since(t0) / double(cs.size());
    return out;
}

// Cycles' estimator at one configuration over n random evaluations of the given lobes' luminance:
// mean, variance of one eval, and seconds per eval; also each lobe's mean and variance.
struct EstimatorStats {
    double mean, var, secs;
    std::array<double, 4> lobe_mean, lobe_var;
};
EstimatorStats cycles_estimator(const HuangHair& m, const Config& c, std::array<bool, 4> lobes, long n,
                                uint32_t seed) {
    const auto sp = prep(m, c);
    const Vec3 O = m.to_local(sp, c.wi);
    uint32_t rng = seed;
    double s = 0, s2 = 0;
    std::array<double, 4> ls{}, ls2{};
    const auto t0 = std::chrono::steady_clock::now();
    for (long k = 0; k < n; ++k) {
        const auto l = m.eval_cycles_stochastic(sp, O, rng);
        double v = 0;
        for (size_t j = 0; j < 4; ++j) {
            const double lj = lum(l[j]);
            if (lobes[j]) v += lj;
            ls[j] += lj, ls2[j] += lj * lj;
        }
        s += v, s2 += v * v;
    }
    const double secs = seconds_since(t0) / double(n), mean = s / double(n);
    EstimatorStats e{mean, std::max(s2 / double(n) - mean * mean, 0.0), secs, {}, {}};
    for (size_t j = 0; j < 4; ++j) {
        e.lobe_mean[j] = ls[j] / double(n);
        e.lobe_var[j] = std::max(ls2[j] / double(n) - sqr(e.lobe_mean[j]), 0.0);
    }
    return e;
}

// RMS over configs of |a - ref| / ref_total for a lobe subset.
double rms_error(const std::vector<std::array<double, 4>>& a, const std::vector<std::array<double, 4>>& ref,
                 std::array<bool, 4> lobes) {
    double s = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        double d = 0, t = 0;
        for (int l = 0; l < 4; ++l) {
            if (!lobes[size_t(l)]) continue;
            d += a[i][size_t(l)] - ref[i][size_t(l)];
            t += ref[i][size_t(l)];
        }
        s += t > 0 ? sqr(d / t) : 0.0;
    }
    return std::sqrt(s / double(a.size()));
}

void simpson_vs_converged() {
    std::printf("\n## 1. Cycles' Simpson rule vs the converged h integral (per lobe, 40 sampled configurations)\n");
    std::printf("relative difference |simpson - converged| / converged total: median / 90th pct / max\n");
    std::printf("%-6s %-5s %-28s %-28s %-28s %-28s %-28s\n", "alpha", "field", "R", "TT", "TRT", "TRRT+", "total");
    for (double alpha : {0.3, 0.1, 0.02}) {
        for (bool near : {false, true}) {
            HuangHairParams pc = base(alpha, 1, 1, 1), pv = pc;
            pc.trt_points = pv.trt_points = 4096;
            pc.tolerance = pv.tolerance = 1e-4;
            pv.quadrature = HuangQuadrature::Converged;
            const HuangHair mc(pc), mv(pv);
            const auto cs = configs(mc, alpha < 0.05 && !near ? 16 : 40, near, 7);
            const auto a = values(mc, cs, nullptr), b = values(mv, cs, nullptr);
            std::printf("%-6.2f %-5s", alpha, near ? "near" : "far");
            for (int l = 0; l <= 4; ++l) {
                std::vector<double> d;
                for (size_t i = 0; i < cs.size(); ++i) {
                    double ta = 0, tb = 0;
                    for (int k = 0; k < 4; ++k) tb += b[i][size_t(k)];
                    if (l < 4) {
                        ta = a[i][size_t(l)];
                        d.push_back(std::fabs(ta - b[i][size_t(l)]) / tb);
                    } else {
                        for (int k = 0; k < 4; ++k) ta += a[i][size_t(k)];
                        d.push_back(std::fabs(ta - tb) / tb);
                    }
                }
                std::sort(d.begin(), d.end());
                std::printf(" %8.1e/%8.1e/%8.1e ", d[d.size() / 2], d[size_t(0.9 * double(d.size() - 1))], d.back());
            }
            std::printf("\n");
        }
    }
}

void speed() {
    std::printf("\n## 2. Speed at equal error against a converged reference (far field, 24 sampled configurations)\n");
    for (double alpha : {0.3, 0.1, 0.02}) {
        const int n = alpha < 0.05 ? 12 : 24;
        // R lobe: reference = converged adaptive Gauss-Kronrod at 1e-10.
        HuangHairParams pr = base(alpha, 1, 0, 0);
        pr.quadrature = HuangQuadrature::Converged;
        pr.tolerance = 1e-9;
        const auto cs = configs(HuangHair(pr), n, false, 11);
        const auto ref = values(HuangHair(pr), cs, nullptr);
        HuangHairParams ps = base(alpha, 1, 0, 0);
        double t_simpson;
        const auto simp = values(HuangHair(ps), cs, &t_simpson);
        const double e_simpson = rms_error(simp, ref, {true, false, false, false});
        // Our converged rule at the loosest tolerance that reaches the Simpson error.
        double best_t = 0, best_e = 0, best_tol = 0;
        for (double tol : {1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 1e-4, 1e-5, 1e-6}) {
            HuangHairParams pq = pr;
            pq.tolerance = tol;
            double t;
            const auto v = values(HuangHair(pq), cs, &t);
            const double e = rms_error(v, ref, {true, false, false, false});
            if (e <= e_simpson) {
                best_t = t, best_e = e, best_tol = tol;
                break;
            }
        }
        // Simpson with Cycles' rule refined (step 0.7 alpha / k) until it reaches our error.
        double t_refined = 0, e_refined = 0;
        int k_refined = 0;
        for (int k = 1; k <= 4096; k *= 2) {
            // Cycles' rule at the same alpha with k times as many Simpson steps (step 0.7 alpha / k).
            const HuangHairParams pr2 = base(alpha, 1, 0, 0);
            double t;
            const auto v = values(HuangLab::with_simpson_refinement(pr2, k), cs, &t);
            const double e = rms_error(v, ref, {true, false, false, false});
            t_refined = t, e_refined = e, k_refined = k;
            if (e <= best_e) break;
        }
        std::printf("alpha %.2f R lobe:  Cycles' Simpson %.2e s/eval, rms error %.2e | ours %.2e s/eval, rms error %.2e "
                    "(tolerance %.0e) | Simpson refined %dx to that error %.2e s/eval (error %.2e): ratio ours/refined %.3f\n",
                    alpha, t_simpson, e_simpson, best_t, best_e, best_tol, k_refined, t_refined, e_refined,
                    best_t / t_refined);

        // TT lobe: reference = converged h, adaptive 1e-6; Cycles' estimator averaged K times.
        HuangHairParams pt = base(alpha, 0, 1, 0);
        pt.quadrature = HuangQuadrature::Converged;
        pt.tolerance = 1e-6;
        pt.max_evaluations = 5'000'000;
        const auto cst = configs(HuangHair(base(alpha, 0, 1, 0)), n, false, 13);
        const auto reft = values(HuangHair(pt), cst, nullptr);
        HuangHairParams pq = base(alpha, 0, 1, 0);
        pq.quadrature = HuangQuadrature::Converged;
        double t_ours = 0, e_ours = 0, tol_ours = 0;
        for (double tol : {3e-1, 1e-1, 3e-2, 1e-2, 1e-3}) {
            pq.tolerance = tol;
            double t;
            const auto v = values(HuangHair(pq), cst, &t);
            const double e = rms_error(v, reft, {false, true, false, false});
            t_ours = t, e_ours = e, tol_ours = tol;
            if (e <= 1e-2) break;
        }
        // Cycles' estimator with its Simpson steps divided by r: one eval's squared error is
        // bias_r^2 + var_r, the mean of k evals' bias_r^2 + var_r / k. bias_r is deterministic: our
        // eval on the same nodes with the inner integral converged (the estimator's expectation);
        // var_r and the time per eval come from M random evaluations per configuration (a single
        // draw would misjudge a heavy-tailed estimator). Cost at our error: min over r of k t_r.
        std::printf("alpha %.2f TT lobe: ours %.2e s/eval, rms error %.2e (tolerance %.0e)\n", alpha, t_ours, e_ours,
                    tol_ours);
        double best_cost = 0;
        int best_r = 0;
        for (int r = 1; r <= 64; r *= 2) {
            HuangHairParams pe = base(alpha, 0, 1, 0);
            pe.tolerance = 1e-5;
            pe.max_evaluations = 5'000'000;
            const auto expect = values(HuangLab::with_simpson_refinement(pe, r), cst, nullptr);
            const double b2 = sqr(rms_error(expect, reft, {false, true, false, false}));
            const HuangHair cyc = HuangLab::with_simpson_refinement(base(alpha, 0, 1, 0), r);
            const long m = 2000;
            double v2 = 0, t_one = 0;
            for (size_t i = 0; i < cst.size(); ++i) {
                const auto e = cycles_estimator(cyc, cst[i], {false, true, false, false}, m, 1 + uint32_t(i));
                const double ref = reft[i][1] > 0 ? reft[i][1] : 1.0;
                t_one += e.secs;
                v2 += e.var / (ref * ref);
            }
            t_one /= double(cst.size()), v2 /= double(cst.size());
            if (b2 >= sqr(e_ours)) {
                std::printf("  Cycles' rule, steps / %2d: %.2e s/eval, one eval's rms error %.2e, Simpson bias %.2e >= "
                            "ours: never reaches our error\n", r, t_one, std::sqrt(b2 + v2), std::sqrt(b2));
                continue;
            }
            const double k = v2 / (sqr(e_ours) - b2), cost = k * t_one;
            std::printf("  Cycles' rule, steps / %2d: %.2e s/eval, one eval's rms error %.2e, Simpson bias %.2e: needs "
                        "%.0f evals (%.2e s) for our error\n", r, t_one, std::sqrt(b2 + v2), std::sqrt(b2), k, cost);
            if (best_r == 0 || cost < best_cost) best_cost = cost, best_r = r;
            if (b2 < 0.25 * sqr(e_ours)) break;  // finer steps cannot lower the cost much more
        }
        if (best_r)
            std::printf("  ratio ours / Cycles' rule at equal error: %.4f (steps / %d)\n", t_ours / best_cost, best_r);
        else
            std::printf("  Cycles' rule does not reach our error with steps down to / 64\n");
    }
}

// TRT + TRRT+ at equal error, with the noise handled explicitly. Per configuration the reference
// is the mean of M Cycles evaluations (same Simpson nodes, so only the inner microfacet
// integration is compared); one Cycles eval's rms error is the estimator's own standard deviation
// (from the same M evaluations, not from a single draw: the integrand is heavy-tailed), and the
// reference's variance (var / M) is subtracted from our squared error before comparing.
void speed_trt(long m_cycles, double only_alpha) {
    const bool verbose = std::getenv("HUANG_MEASURE_VERBOSE") != nullptr;
    std::printf("\n## 3. TRT + TRRT+ speed at equal error (far field, 12 sampled configurations, "
                "reference: %ld Cycles evals per configuration)\n", m_cycles);
    for (double alpha : {0.3, 0.1, 0.02}) {
        if (only_alpha > 0 && std::fabs(alpha - only_alpha) > 1e-9) continue;
        const HuangHair cyc(base(alpha, 0, 0, 1));
        const auto cs = configs(cyc, 12, false, 17);
        std::vector<double> ref(cs.size()), var(cs.size()), secs(cs.size());
        const long m = alpha < 0.05 ? m_cycles / 4 : m_cycles;
        auto reference = [&](size_t first) {  // two threads, alternate configurations
            for (size_t i = first; i < cs.size(); i += 2) {
                const auto e = cycles_estimator(cyc, cs[i], {false, false, true, true}, m, 77 + uint32_t(i));
                secs[i] = e.secs, ref[i] = e.mean, var[i] = e.var;
            }
        };
        std::thread second(reference, size_t(1));
        reference(0);
        second.join();
        double t_one = 0;
        for (double t : secs) t_one += t;
        t_one /= double(cs.size());
        double one_mse = 0, ref_mse = 0;
        int used = 0;
        for (size_t i = 0; i < cs.size(); ++i) {
            if (!(ref[i] > 0)) continue;
            one_mse += var[i] / sqr(ref[i]);
            ref_mse += var[i] / double(m) / sqr(ref[i]);
            ++used;
        }
        one_mse /= std::max(used, 1), ref_mse /= std::max(used, 1);
        std::printf("alpha %.2f: one Cycles eval %.2e s, rms error %.2e; reference: %ld evals, its own rms error %.1e\n",
                    alpha, t_one, std::sqrt(one_mse), m, std::sqrt(ref_mse));
        for (long npts : {1024L, 4096L, 16384L, 65536L}) {
            HuangHairParams p = base(alpha, 0, 0, 1);
            p.trt_points = npts;
            double t;
            const auto v = values(HuangHair(p), cs, &t);
            double mse = 0;
            for (size_t i = 0; i < cs.size(); ++i)
                if (ref[i] > 0) mse += sqr((v[i][2] + v[i][3] - ref[i]) / ref[i]);
            mse /= std::max(used, 1);
            if (verbose)
                for (size_t i = 0; i < cs.size(); ++i)
                    std::printf("    config %2zu: reference %.4e +- %.1e (relative), ours %+.2e (relative)\n", i, ref[i],
                                std::sqrt(var[i] / double(m)) / ref[i], (v[i][2] + v[i][3] - ref[i]) / ref[i]);
            const double e_raw = std::sqrt(mse);
            if (mse < 2.0 * ref_mse) {  // indistinguishable from the reference's noise: a bound only
                const double k = one_mse / (2.0 * ref_mse);
                std::printf("  ours %6ld points/node: %.2e s/eval, rms error %.2e, within 2x the reference's noise; "
                            "Cycles needs more than %.0f evals: ratio ours/Cycles < %.3f\n",
                            npts, t, e_raw, k, t / (k * t_one));
                continue;
            }
            const double e = std::sqrt(mse - ref_mse), k = one_mse / sqr(e);
            std::printf("  ours %6ld points/node: %.2e s/eval, rms error %.2e (%.2e before removing the reference's "
                        "noise); Cycles needs %.0f evals (%.2e s): ratio ours/Cycles %.3f\n",
                        npts, t, e, e_raw, k, k * t_one, t / (k * t_one));
        }
    }
}


// TRT and TRRT+ separately at one of speed_trt's configurations: Cycles' mean over m evals with
// its standard error, and ours at 1024, 4096, ... up to max_points points per node.
void trt_lobes(double alpha, size_t index, long m, long max_points) {
    const HuangHair cyc(base(alpha, 0, 0, 1));
    const auto cs = configs(cyc, 12, false, 17);
    const Config& c = cs[index];
    std::printf("\n## TRT and TRRT+ at alpha %.2f, configuration %zu (wo %.3f %.3f %.3f, wi %.3f %.3f %.3f, h %.3f)\n",
                alpha, index, c.wo.x, c.wo.y, c.wo.z, c.wi.x, c.wi.y, c.wi.z, c.h);
    const auto e = cycles_estimator(cyc, c, {false, false, true, true}, m, 77 + uint32_t(index));
    std::printf("Cycles, %ld evals: TRT %.4e +- %.1e, TRRT+ %.4e +- %.1e\n", m, e.lobe_mean[2],
                std::sqrt(e.lobe_var[2] / double(m)), e.lobe_mean[3], std::sqrt(e.lobe_var[3] / double(m)));
    for (long npts = 1024; npts <= max_points; npts *= 4) {
        HuangHairParams p = base(alpha, 0, 0, 1);
        p.trt_points = npts;
        const auto v = values(HuangHair(p), {c}, nullptr)[0];
        std::printf("ours, %7ld points/node: TRT %.4e, TRRT+ %.4e\n", npts, v[2], v[3]);
    }
}

// Where the TRT rule's variance is (issue 28): per random row (far or near field), each node's
// TRT + TRRT+ points (`points` scrambled Sobol' points per node) give the spread of one point relative
// to the row's total (the points a 0.5 % standard error needs: (spread / 0.005)^2), the spread of TRT
// and TRRT+ each relative to its own mean, the most that allocating points over the nodes by weight x
// spread can gain (K sum var / (sum sd)^2), and the share of the variance that comes from the entry
// normal (Var E[f | entry] / Var f, from pairs of points sharing the entry).
void trt_variance(double alpha, bool near, int rows, uint32_t points) {
    HuangHairParams p = base(alpha, 1, 1, 1);
    p.tolerance = 1e-2;
    p.trt_points = 0;
    const HuangHair m(p);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> uni;
    const Sobol& so = sobol();
    std::printf("\n## TRT variance, alpha %.2f, %s field, %u points per node\n", alpha, near ? "near" : "far", points);
    std::printf("| row | nodes | TRT+TRRT+ share | spread per point (of total) | points for 0.5 %% | TRT spread | TRRT+ spread | "
                "allocation gain bound | entry share |\n|---|---|---|---|---|---|---|---|---|\n");
    for (int row = 0; row < rows; ++row) {
        const double th_o = (140 * uni(rng) - 70) * kPi / 180, th_i = (140 * uni(rng) - 70) * kPi / 180;
        const double dphi = (2 * uni(rng) - 1) * kPi, h = 1.8 * uni(rng) - 0.9;
        ShadingContext ctx;
        ctx.wo = {std::sin(th_o), std::cos(th_o), 0};
        ctx.h = h;
        ctx.near_field = near;
        ctx.pixel_coverage = near ? 1.0 / 60 : 1.5;
        const auto sp = m.prepare(ctx);
        if (!sp.valid) continue;
        const Vec3 O = m.to_local(sp, {std::sin(th_i), std::cos(th_i) * std::cos(dphi), std::cos(th_i) * std::sin(dphi)});
        const auto lobes = m.eval_local(sp, O);
        const double total = lum(lobes[0]) + lum(lobes[1]) + lum(lobes[2]) + lum(lobes[3]);
        double var = 0, sd = 0, var_entry = 0, trt_mean = 0, trt_var = 0, trrt_mean = 0, trrt_var = 0;
        int k = 0;
        for (const HuangHair::Node& n : sp.residual_nodes) {
            const double gamma = m.h_to_gamma(n.h, sp.I), w = n.weight * m.dgamma_dh(sp.sin_phi_i, sp.cos_phi_i, gamma);
            if (!(w != 0.0 && std::isfinite(w))) continue;
            ++k;
            const uint32_t shift = 0x2545F491u * uint32_t(k);
            double s = 0, s2 = 0, s_pair = 0, s_other = 0, a = 0, a2 = 0, b = 0, b2 = 0;
            for (uint32_t i = 0; i < points; ++i) {
                double u[4], u_other[4];
                for (int d = 0; d < 4; ++d) u[d] = double(so.point(i, d) ^ (shift + uint32_t(d) * 0x9E3779B9u)) * 0x1p-32;
                RGB trt, trrt, trt2, trrt2;
                HuangLab::trt_point(m, sp, O, gamma, w, u, trt, trrt);
                u_other[0] = u[0], u_other[1] = u[1], u_other[2] = uni(rng), u_other[3] = uni(rng);
                HuangLab::trt_point(m, sp, O, gamma, w, u_other, trt2, trrt2);
                const double v = lum(trt) + lum(trrt), v2 = lum(trt2) + lum(trrt2);
                s += v, s2 += v * v, s_pair += v * v2, s_other += v2;
                a += lum(trt), a2 += sqr(lum(trt)), b += lum(trrt), b2 += sqr(lum(trrt));
            }
            const double n_pts = double(points), mean = s / n_pts, var_k = std::max(s2 / n_pts - mean * mean, 0.0);
            var += var_k;
            sd += std::sqrt(var_k);
            var_entry += s_pair / n_pts - mean * s_other / n_pts;
            trt_mean += a / n_pts, trt_var += std::max(a2 / n_pts - sqr(a / n_pts), 0.0);
            trrt_mean += b / n_pts, trrt_var += std::max(b2 / n_pts - sqr(b / n_pts), 0.0);
        }
        if (k == 0 || !(total > 0)) continue;
        const double spread = std::sqrt(k * var) / total;
        std::printf("| %d | %d | %.2f | %.2f | %.0f | %.1f | %.1f | %.2f | %.2f |\n", row, k, (trt_mean + trrt_mean) / total,
                    spread, sqr(spread / 0.005), std::sqrt(k * trt_var) / std::max(trt_mean, 1e-300),
                    std::sqrt(k * trrt_var) / std::max(trrt_mean, 1e-300), k * var / std::max(sd * sd, 1e-300),
                    var_entry / std::max(var, 1e-300));
    }
}

}  // namespace

int main(int argc, char** argv) {
    const std::string what = argc > 1 ? argv[1] : "all";
    const bool help = what == "-h" || what == "--help";
    auto usage = [&] {
        std::fprintf(help ? stdout : stderr,
                     "usage: huang_measure [all|simpson|speed|speed_trt [M [alpha]]|trt_lobes alpha index M max_points|\n"
                     "                     trt_variance alpha near|far rows points]\n"
                     "  simpson    Cycles' Simpson rule over h vs the converged integral, per lobe\n"
                     "  speed      R and TT: cost at equal error, ours vs Cycles' rule (~4 min)\n"
                     "  speed_trt  TRT + TRRT+: the same against the mean of M Cycles evals per configuration\n"
                     "             (M >= 100, default 2000000; M / 4 at alpha 0.02; alpha: only 0.3, 0.1 or 0.02)\n"
                     "  trt_lobes  TRT and TRRT+ separately at speed_trt's configuration index (0-11): Cycles' mean\n"
                     "             over M evals, ours at 1024, 4096, ... up to max_points points per node\n"
                     "  trt_variance  where the TRT rule's variance is, per random row: spread per point, per lobe,\n"
                     "             the gain bound of allocating points over the nodes, the entry normal's share\n"
                     "  HUANG_MEASURE_VERBOSE=1 prints speed_trt's configurations. docs/huang.md sections 5 and 9.\n");
        return help ? 0 : 2;
    };
    auto alpha_ok = [](double a) { return a == 0.3 || a == 0.1 || a == 0.02; };
    if (what == "trt_variance") {
        if (argc != 6) return usage();
        const double alpha = std::atof(argv[2]);
        const std::string field = argv[3];
        const int rows = std::atoi(argv[4]);
        const long points = std::atol(argv[5]);
        if (!alpha_ok(alpha) || (field != "near" && field != "far") || rows < 1 || points < 16 || points > (1L << 24))
            return usage();
        trt_variance(alpha, field == "near", rows, uint32_t(points));
        return 0;
    }
    if (what == "trt_lobes") {
        if (argc != 6) return usage();
        const double alpha = std::atof(argv[2]);
        const long index = std::atol(argv[3]), m = std::atol(argv[4]), max_points = std::atol(argv[5]);
        if (!alpha_ok(alpha) || index < 0 || index > 11 || m < 100 || max_points < 1024) return usage();
        trt_lobes(alpha, size_t(index), m, max_points);
        return 0;
    }
    const long m = argc > 2 ? std::atol(argv[2]) : 2000000;
    const double only_alpha = argc > 3 ? std::atof(argv[3]) : 0.0;
    const bool known = what == "all" || what == "simpson" || what == "speed" || what == "speed_trt";
    if (!known || m < 100 || !(only_alpha == 0.0 || alpha_ok(only_alpha))) return usage();
    if (what == "all" || what == "simpson") simpson_vs_converged();
    if (what == "all" || what == "speed") speed();
    if (what == "all" || what == "speed_trt") speed_trt(m, only_alpha);
    return 0;
}
