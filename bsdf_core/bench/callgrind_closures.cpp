// The cost of going through ClosureSum: `sum` runs the scalar eval of a one-closure Chiang sum,
// `direct` the model's own prepare + eval at the same inputs. scripts/bench --callgrind counts
// each loop's instructions under callgrind (only inside run_sum / run_direct); the ratio is
// ClosureSum's overhead (goal <= 1.05, docs/benchmarks.md). `sample` runs the model's own
// prepare + sample (run_sample). These three run the scalar path's dispatched build (AVX2 + FMA where the CPU,
// or valgrind, has them: scalar_avx2); a third argument `baseline` runs the baseline (SSE2) build.
// `kernel_eval`, `kernel_pdf` and
// `kernel_sample` run the float32 batch kernels (docs/simd.md) over the same rows in one call
// (run_kernel); under valgrind they take the AVX2 path (valgrind has no AVX-512). `rows_eval`,
// `rows_pdf` and `rows_sample` do the same with per-row inputs (roughness, radial roughness, coat,
// random and melanin vary per row), so that the per-row `prepare` is counted too.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

#include "hairbsdf/batch/chiang_batch.h"
#include "hairbsdf/closures.h"
#include "hairbsdf/math_simd.h"
#include "hairbsdf/params/principled_hair.h"

using namespace hairbsdf;

namespace {
struct Inputs {
    std::vector<ShadingContext> ctx;
    std::vector<Vec3> wi;
    std::vector<std::array<double, 3>> u;
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
__attribute__((noinline)) double run_sample(const ChiangHair& model, const Inputs& in) {
    double acc = 0;
    for (size_t i = 0; i < in.ctx.size(); ++i) acc += model.sample(model.prepare(in.ctx[i]), in.u[i]).pdf;
    return acc;
}
struct KernelRows {
    std::vector<float> wo, wi, h, u;
    std::vector<float> roughness, radial_roughness, coat, random, melanin;  // per-row inputs (rows_*)
};

__attribute__((noinline)) size_t run_kernel(const ChiangBatchConstants& c, ChiangBatchOp op, const KernelRows& in,
                                            std::vector<float>& value, std::vector<float>& pdf,
                                            std::vector<float>& wi, std::vector<int32_t>& lobe) {
    ChiangBatchRows rows;
    rows.wo = in.wo.data();
    rows.wi = in.wi.data();
    rows.h = in.h.data();
    rows.u = in.u.data();
    if (!in.roughness.empty()) {
        rows.inputs.roughness = in.roughness.data();
        rows.inputs.radial_roughness = in.radial_roughness.data();
        rows.inputs.coat = in.coat.data();
        rows.inputs.random = in.random.data();
        rows.inputs.melanin = in.melanin.data();
    }
    ChiangBatchOutput out;
    out.value = value.data();
    out.weight = value.data();
    out.pdf = pdf.data();
    out.wi = wi.data();
    out.lobe = lobe.data();
    return chiang_batch_run(c, op, rows, out, 0, in.h.size());
}
}  // namespace

int main(int argc, char** argv) {
    const bool per_row = argc >= 2 && std::strncmp(argv[1], "rows_", 5) == 0;
    const bool kernel = argc >= 2 && (std::strncmp(argv[1], "kernel_", 7) == 0 || per_row);
    const char* op_name = argc >= 2 ? argv[1] + (per_row ? 5 : 7) : "";
    if (argc < 2 || (std::strcmp(argv[1], "sum") != 0 && std::strcmp(argv[1], "direct") != 0 &&
                     std::strcmp(argv[1], "sample") != 0 &&
                     !(kernel && (std::strcmp(op_name, "eval") == 0 || std::strcmp(op_name, "pdf") == 0 ||
                                  std::strcmp(op_name, "sample") == 0)))) {
        std::fprintf(stderr,
                     "usage: %s sum|direct|sample|kernel_eval|kernel_pdf|kernel_sample|rows_eval|rows_pdf|rows_sample "
                     "[calls] [baseline]\n",
                     argv[0]);
        return 2;
    }
    const size_t calls = argc > 2 ? size_t(std::atol(argv[2])) : 10000;
    if (argc > 3 && std::strcmp(argv[3], "baseline") == 0) set_scalar_avx2(false);
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
    // The sampler's numbers from their own generator, so that the other modes' rows stay as they were.
    std::mt19937_64 rng_u(2);
    for (size_t i = 0; i < calls; ++i) in.u.push_back({uni(rng_u), uni(rng_u), uni(rng_u)});
    PrincipledHairInputs principled;
    principled.parametrization = Parametrization::Melanin;
    principled.roughness = 0.3;
    const ChiangHair model(chiang_params_from_principled(principled, Accuracy::Cycles));
    if (kernel) {
        KernelRows rows;
        for (size_t i = 0; i < calls; ++i) {
            const ShadingContext& c = in.ctx[i];
            for (double x : {c.wo.x, c.wo.y, c.wo.z}) rows.wo.push_back(float(x));
            for (double x : {in.wi[i].x, in.wi[i].y, in.wi[i].z}) rows.wi.push_back(float(x));
            for (int k = 0; k < 3; ++k) rows.u.push_back(float(uni(rng)));
            rows.h.push_back(float(c.h));
            if (per_row) {
                rows.roughness.push_back(float(0.1 + 0.7 * uni(rng)));
                rows.radial_roughness.push_back(float(0.1 + 0.7 * uni(rng)));
                rows.coat.push_back(float(0.5 * uni(rng)));
                rows.random.push_back(float(uni(rng)));
                rows.melanin.push_back(float(0.1 + 0.8 * uni(rng)));
            }
        }
        std::vector<float> value(3 * calls), pdf(calls), wi(3 * calls);
        std::vector<int32_t> lobe(calls);
        const ChiangBatchOp op = std::strcmp(op_name, "eval") == 0  ? ChiangBatchOp::Eval
                                 : std::strcmp(op_name, "pdf") == 0 ? ChiangBatchOp::Pdf
                                                                    : ChiangBatchOp::Sample;
        const ChiangBatchConstants constants =
            per_row ? chiang_batch_constants_principled(principled, Accuracy::Cycles, TiltConvention::Blender42, RGB(1.0))
                    : chiang_batch_constants(model.params(), RGB(1.0));
        const size_t bad = run_kernel(constants, op, rows, value, pdf, wi, lobe);
        double acc = 0;
        for (float p : pdf) acc += p;
        std::printf("%s %zu rows on %s, %zu bad, checksum %.9g\n", argv[1], calls, simd_isa_name(simd_isa()), bad, acc);
        return 0;
    }
    const ClosureSum sum({Closure{RGB(1.0), model}});
    const double acc = std::strcmp(argv[1], "sum") == 0      ? run_sum(sum, in)
                       : std::strcmp(argv[1], "sample") == 0 ? run_sample(model, in)
                                                             : run_direct(model, in);
    std::printf("%s %zu calls on the %s build, checksum %.17g\n", argv[1], calls,
                scalar_avx2() ? "avx2" : "baseline", acc);
    return 0;
}
