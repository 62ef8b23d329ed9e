// The cost of going through ClosureSum: `sum` runs the scalar eval of a one-closure Chiang sum,
// `direct` the model's own prepare + eval at the same inputs. scripts/bench --callgrind counts
// each loop's instructions under callgrind (only inside run_sum / run_direct); the ratio is
// ClosureSum's overhead (goal <= 1.05, docs/benchmarks.md).
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

#include "hairbsdf/closures.h"
#include "hairbsdf/params/principled_hair.h"

using namespace hairbsdf;

namespace {
struct Inputs {
    std::vector<ShadingContext> ctx;
    std::vector<Vec3> wi;
};

__attribute__((noinline)) double run_sum(const ClosureSum& sum, const Inputs& in) {
    double acc = 0;
    for (size_t i = 0; i < in.ctx.size(); ++i) acc += sum.eval(in.ctx[i], in.wi[i]).pdf;
    return acc;
}

__attribute__((noinline)) double run_direct(const ChiangHair& model, const Inputs& in) {
    double acc = 0;
    for (size_t i = 0; i < in.ctx.size(); ++i) acc += model.eval(model.prepare(in.ctx[i]), in.wi[i]).pdf;
    return acc;
}
}  // namespace

int main(int argc, char** argv) {
    if (argc < 2 || (std::strcmp(argv[1], "sum") != 0 && std::strcmp(argv[1], "direct") != 0)) {
        std::fprintf(stderr, "usage: %s sum|direct [calls]\n", argv[0]);
        return 2;
    }
    const size_t calls = argc > 2 ? size_t(std::atol(argv[2])) : 10000;
    std::mt19937_64 rng(1);
    std::normal_distribution<double> g;
    std::uniform_real_distribution<double> uni;
    Inputs in;
    for (size_t i = 0; i < calls; ++i) {
        ShadingContext c;
        c.wo = normalize(Vec3{g(rng), g(rng), g(rng)});
        c.h = 2 * uni(rng) - 1;
        in.ctx.push_back(c);
        in.wi.push_back(normalize(Vec3{g(rng), g(rng), g(rng)}));
    }
    PrincipledHairInputs principled;
    principled.parametrization = Parametrization::Melanin;
    principled.roughness = 0.3;
    const ChiangHair model(chiang_params_from_principled(principled, Accuracy::Cycles));
    const ClosureSum sum({Closure{RGB(1.0), model}});
    const double acc = std::strcmp(argv[1], "sum") == 0 ? run_sum(sum, in) : run_direct(model, in);
    std::printf("%s %zu calls, checksum %.17g\n", argv[1], calls, acc);
    return 0;
}
