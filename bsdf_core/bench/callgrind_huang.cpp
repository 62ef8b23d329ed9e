// Instructions per call of Huang's stochastic eval (Cycles' estimator, the engine's eval): scripts/bench
// --callgrind-huang counts them under callgrind inside run_stochastic only. The rows are random
// (wo, wi, h) on the three materials of the huang_ellipse scene (aspect ratio 0.5, 0.8, 1.0, roughness
// 0.3, Cycles' sampler, no mixture: the engine's setting); each ShadingPoint is prepared outside the
// counted loop. Prints the residual Simpson nodes visited, so that the count per node follows.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

#include "hairbsdf/models/huang.h"

using namespace hairbsdf;

namespace {
struct Row {
    const HuangHair* model;
    HuangHair::ShadingPoint sp;
    Vec3 O;
    uint32_t rng;
};

// `lanes`: the engine's eval (float lanes over the nodes); otherwise the double path, one node at a time
// (eval_cycles_stochastic_double, the lanes' reference and the engine's eval before them).
__attribute__((noinline)) double run_stochastic(std::vector<Row>& rows, bool lanes) {
    double acc = 0;
    for (Row& r : rows) {
        const auto lobes = lanes ? r.model->eval_cycles_stochastic(r.sp, r.O, r.rng)
                                 : r.model->eval_cycles_stochastic_double(r.sp, r.O, r.rng);
        for (const RGB& l : lobes) acc += l.r + l.g + l.b;
    }
    return acc;
}
}  // namespace

// `values`: the per-lobe sums of 64 evals of a few fixed rows at full precision (the golden rows of the gtest
// HuangTest.StochasticEvalRowsUnchanged were printed by this mode from the build before the lanes work).
int print_values() {
    const double aspects[3] = {0.5, 0.8, 1.0};
    const double hs[3] = {-0.3, 0.1, 0.55};
    const Vec3 wis[3] = {{-0.5, -0.1, 0.6}, {-0.3, 0.1, -0.9}, {-0.2, -0.3, -0.9}};  // the last two: TT forward
    for (int k = 0; k < 3; ++k) {
        HuangHairParams p;
        p.sigma_a = RGB(0.2, 0.5, 1.0);
        p.roughness = 0.3;
        p.aspect_ratio = aspects[k];
        p.sampler = HuangSampler::Cycles;
        p.mixture_detail = HuangHairParams::MixtureDetail::None;
        const HuangHair m(p);
        ShadingContext c;
        c.normal = {0, 0, 1};  // the ellipse's major axis (huang_ellipse: strands along X, Z up)
        c.wo = normalize(Vec3{0.3, 0.2, 0.9});
        c.h = hs[k];
        const Vec3 wi = normalize(wis[k]);
        const auto sp = m.prepare(c);
        uint32_t rng = 12345u + uint32_t(k);
        std::array<RGB, kLobeCount> lobes{};
        for (int j = 0; j < 64; ++j) {  // 64 evals in a row: many draws of the visible normals
            const auto one = m.eval_cycles_stochastic(sp, m.to_local(sp, wi), rng);
            for (size_t l = 0; l < lobes.size(); ++l) lobes[l] += one[l];
        }
        std::printf("aspect %.1f h %.2f rng_after %u\n", aspects[k], hs[k], rng);
        for (const RGB& l : lobes) std::printf("  %.17g, %.17g, %.17g,\n", l.r, l.g, l.b);
    }
    return 0;
}

int main(int argc, char** argv) {
    if (argc >= 2 && std::strcmp(argv[1], "values") == 0) return print_values();
    const bool lanes = argc >= 2 && std::strcmp(argv[1], "stochastic") == 0;
    if (argc < 2 || (!lanes && std::strcmp(argv[1], "stochastic-double") != 0)) {
        std::fprintf(stderr, "usage: %s stochastic|stochastic-double [calls] | values\n", argv[0]);
        return 2;
    }
    const size_t calls = argc > 2 ? size_t(std::atol(argv[2])) : 2000;
    std::vector<HuangHair> models;
    for (double aspect : {0.5, 0.8, 1.0}) {
        HuangHairParams p;
        p.sigma_a = RGB(0.2, 0.5, 1.0);
        p.roughness = 0.3;
        p.aspect_ratio = aspect;
        p.sampler = HuangSampler::Cycles;
        p.mixture_detail = HuangHairParams::MixtureDetail::None;
        models.emplace_back(p);
    }
    std::mt19937_64 rng(1);
    std::normal_distribution<double> g;
    std::uniform_real_distribution<double> uni;
    std::vector<Row> rows;
    size_t nodes = 0;
    for (size_t i = 0; i < calls; ++i) {
        const HuangHair& m = models[i % models.size()];
        ShadingContext c;
        c.normal = {0, 0, 1};
        c.wo = normalize(Vec3{g(rng), g(rng), g(rng)});
        c.h = 2 * uni(rng) - 1;
        const Vec3 wi = normalize(Vec3{g(rng), g(rng), g(rng)});
        Row r{&m, m.prepare(c), {}, uint32_t(rng())};
        r.O = m.to_local(r.sp, wi);
        if (r.sp.valid) nodes += r.sp.residual_nodes.size();
        rows.push_back(std::move(r));
    }
    const double acc = run_stochastic(rows, lanes);
    std::printf("calls %zu residual_nodes %zu checksum %.17g\n", calls, nodes, acc);
    return 0;
}
