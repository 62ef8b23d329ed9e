// Measurements of the Huang model for docs/huang.md (run by hand, not a test):
//   1. how far Cycles' Simpson rule over h (steps 0.7 alpha / 0.8 alpha) is from the converged
//      integral, per lobe, far and near field;
//   2. speed at equal error against a converged reference: Cycles' rule (R: its deterministic
//      Simpson sum; TT / TRT+: its one-random-normal-per-node estimator, averaged as often as
//      needed) versus our deterministic rules at the same error.
// Build: cmake --build build/cpp --target huang_measure; run: build/cpp/bsdf_core/huang_measure
#include <chrono>
#include <cstdio>
#include <random>
#include <vector>

#include "hairbsdf/models/huang.h"

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
            HuangHairParams pk = base(alpha / k, 1, 0, 0);  // step = 0.7 (alpha / k); the model keeps alpha
            (void)pk;
            // Evaluate the R Simpson sum with k times as many intervals via the converged model's
            // integrand: emulate by a Cycles-quadrature model whose roughness parameter is unchanged
            // but whose node spacing is divided by k (HuangHairParams::simpson_refinement).
            HuangHairParams pr2 = base(alpha, 1, 0, 0);
            pr2.simpson_refinement = k;
            double t;
            const auto v = values(HuangHair(pr2), cs, &t);
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
        const HuangHair cyc(base(alpha, 0, 1, 0));
        // One Cycles eval: time and rms error (noise + Simpson bias).
        double t_one = 0;
        std::vector<std::array<double, 4>> one;
        {
            uint32_t rng = 1;
            const auto t0 = std::chrono::steady_clock::now();
            for (const Config& c : cst) {
                const auto sp = prep(cyc, c);
                const auto l = cyc.eval_cycles_stochastic(sp, cyc.to_local(sp, c.wi), rng);
                one.push_back({0, lum(l[1]), 0, 0});
            }
            t_one = seconds_since(t0) / double(cst.size());
        }
        const double e_one = rms_error(one, reft, {false, true, false, false});
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
        // Cycles evaluations needed for the same error: (e_one / e_ours)^2 averaged evals.
        const double k = sqr(e_one / std::max(e_ours, 1e-12));
        std::printf("alpha %.2f TT lobe: one Cycles eval %.2e s, rms error %.2e | ours %.2e s, rms error %.2e "
                    "(tolerance %.0e); Cycles needs %.0f evals for that error: ratio ours/Cycles %.4f\n",
                    alpha, t_one, e_one, t_ours, e_ours, tol_ours, k, t_ours / (k * t_one));
        // TRT + TRRT+: reference = the mean of 20000 Cycles evaluations (same Simpson nodes, so only
        // the inner microfacet integration is compared); ours with trt_points N.
        if (alpha < 0.05) continue;
        const HuangHair cyc3(base(alpha, 0, 0, 1));
        const auto cs3 = configs(HuangHair(base(alpha, 0, 0, 1)), 12, false, 17);
        std::vector<std::array<double, 4>> ref3, one3;
        double t_one3 = 0;
        for (const Config& c : cs3) {
            const auto sp = prep(cyc3, c);
            const Vec3 O = cyc3.to_local(sp, c.wi);
            uint32_t rng = 77;
            std::array<double, 4> acc{};
            const int m = 20000;
            const auto t0 = std::chrono::steady_clock::now();
            for (int k = 0; k < m; ++k) {
                const auto l = cyc3.eval_cycles_stochastic(sp, O, rng);
                if (k == 0) one3.push_back({0, 0, lum(l[2]), lum(l[3])});
                for (int q = 2; q < 4; ++q) acc[size_t(q)] += lum(l[size_t(q)]) / m;
            }
            t_one3 += seconds_since(t0) / m;
            ref3.push_back(acc);
        }
        t_one3 /= double(cs3.size());
        const double e_one3 = rms_error(one3, ref3, {false, false, true, true});
        for (long npts : {1024L, 4096L, 16384L}) {
            HuangHairParams pq3 = base(alpha, 0, 0, 1);
            pq3.trt_points = npts;
            double t;
            const auto v = values(HuangHair(pq3), cs3, &t);
            const double e = rms_error(v, ref3, {false, false, true, true});
            const double k = sqr(e_one3 / std::max(e, 1e-12));
            std::printf("alpha %.2f TRT+TRRT: one Cycles eval %.2e s, rms error %.2e | ours (%5ld points/node) %.2e s, "
                        "rms error %.2e (incl. the reference's own ~%.0e); Cycles needs %.0f evals: ratio %.3f\n",
                        alpha, t_one3, e_one3, npts, t, e, e_one3 / std::sqrt(20000.0), k, t / (k * t_one3));
        }
    }
}

}  // namespace

int main(int argc, char** argv) {
    const std::string what = argc > 1 ? argv[1] : "all";
    if (what == "all" || what == "simpson") simpson_vs_converged();
    if (what == "all" || what == "speed") speed();
    return 0;
}
