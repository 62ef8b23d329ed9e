// Single-thread cost per call of eval, sample and pdf for the Chiang closure, and of
// prepare + eval / sample for every zoo model at its defaults, in thread CPU time (robust to
// other processes on the machine). Run by scripts/bench; results go in docs/benchmarks.md
// and docs/models.md.
#include <ctime>
#include <cstdio>
#include <random>
#include <vector>

#include "hairbsdf/closures.h"
#include "hairbsdf/model_factory.h"
#include "hairbsdf/params/principled_hair.h"

using namespace hairbsdf;

namespace {
volatile double g_sink = 0;

double thread_cpu_ns() {
    timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return 1e9 * double(ts.tv_sec) + double(ts.tv_nsec);
}

template <class Fn>
double ns_per_call(size_t calls, Fn fn) {
    double best = 1e30;
    for (int repeat = 0; repeat < 5; ++repeat) {
        const double t0 = thread_cpu_ns();
        double acc = 0;
        for (size_t i = 0; i < calls; ++i) acc += fn(i);
        const double t1 = thread_cpu_ns();
        g_sink = g_sink + acc;
        best = std::min(best, (t1 - t0) / double(calls));
    }
    return best;
}
}  // namespace

int main(int argc, char** argv) {
    const size_t calls = argc > 1 ? size_t(std::atol(argv[1])) : 400000;
    std::mt19937_64 rng(1);
    std::normal_distribution<double> g;
    std::uniform_real_distribution<double> uni;
    const size_t n = 4096;
    std::vector<ShadingContext> ctx(n);
    std::vector<Vec3> wi(n);
    std::vector<std::array<double, 3>> u(n);
    for (size_t i = 0; i < n; ++i) {
        ctx[i].wo = normalize(Vec3{g(rng), g(rng), g(rng)});
        ctx[i].h = 2 * uni(rng) - 1;
        wi[i] = normalize(Vec3{g(rng), g(rng), g(rng)});
        u[i] = {uni(rng), uni(rng), uni(rng)};
    }
    std::printf("%-8s %-8s %10s %10s %10s %14s %16s\n", "beta_m", "accuracy", "eval ns", "sample ns", "pdf ns",
                "prepare ns", "prepared eval ns");
    for (double beta : {0.05, 0.3, 0.8}) {
        for (Accuracy acc : {Accuracy::Cycles, Accuracy::Exact}) {
            PrincipledHairInputs in;
            in.parametrization = Parametrization::Melanin;
            in.roughness = beta;
            const ChiangHairParams params = chiang_params_from_principled(in, acc);
            const ChiangHair model(params);
            const ClosureSum bsdf({Closure{RGB(1.0), model}});
            const double e = ns_per_call(calls, [&](size_t i) { return bsdf.eval(ctx[i % n], wi[i % n]).lobes[0].r; });
            const double s = ns_per_call(calls, [&](size_t i) { return bsdf.sample(ctx[i % n], u[i % n]).pdf; });
            const double p = ns_per_call(calls, [&](size_t i) { return bsdf.pdf(ctx[i % n], wi[i % n]); });
            std::vector<ClosureSum::ShadingPoint> points(n);
            for (size_t i = 0; i < n; ++i) points[i] = bsdf.prepare(ctx[i]);
            const double prep = ns_per_call(calls, [&](size_t i) { return model.prepare(ctx[i % n]).view.gamma_o; });
            const double prepared = ns_per_call(calls, [&](size_t i) { return bsdf.eval(points[i % n], wi[i % n]).pdf; });
            std::printf("%-8.2f %-8s %10.1f %10.1f %10.1f %14.1f %16.1f\n", beta,
                        acc == Accuracy::Cycles ? "cycles" : "exact", e, s, p, prep, prepared);
        }
    }
    // Zoo models at their defaults, Chiang (cycles accuracy, beta_m 0.3) for scale. A model's first
    // construction builds its tables (energy bound, scattered lobes); that is outside the timing.
    std::printf("\n%-12s %18s %20s\n", "model", "prepare+eval ns", "prepare+sample ns");
    {
        PrincipledHairInputs in;
        in.parametrization = Parametrization::Melanin;
        in.roughness = 0.3;
        const ClosureSum bsdf({Closure{RGB(1.0), ChiangHair(chiang_params_from_principled(in, Accuracy::Cycles))}});
        const double e = ns_per_call(calls, [&](size_t i) { return bsdf.eval(ctx[i % n], wi[i % n]).lobes[0].r; });
        const double s = ns_per_call(calls, [&](size_t i) { return bsdf.sample(ctx[i % n], u[i % n]).pdf; });
        std::printf("%-12s %18.1f %20.1f\n", "chiang", e, s);
    }
    for (const std::string& name : zoo_model_names()) {
        const ClosureSum bsdf({Closure{RGB(1.0), make_zoo_model(name, {})}});
        const size_t k = name == "deon" || name == "yan_fur" ? calls / 4 : calls;
        const double e = ns_per_call(k, [&](size_t i) { return bsdf.eval(ctx[i % n], wi[i % n]).pdf; });
        const double s = ns_per_call(k, [&](size_t i) { return bsdf.sample(ctx[i % n], u[i % n]).pdf; });
        std::printf("%-12s %18.1f %20.1f\n", name.c_str(), e, s);
    }
    return 0;
}
