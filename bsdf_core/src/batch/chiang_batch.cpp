// Constants and run-time dispatch of the Chiang batch kernels and of Huang's residual lanes (docs/simd.md).
#include "hairbsdf/batch/chiang_batch.h"
#include "huang_lanes.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>

namespace hairbsdf {
namespace batch_detail {
size_t run_avx512(const ChiangBatchConstants&, ChiangBatchOp, const ChiangBatchRows&, const ChiangBatchOutput&,
                  size_t, size_t);
size_t run_avx2(const ChiangBatchConstants&, ChiangBatchOp, const ChiangBatchRows&, const ChiangBatchOutput&,
                size_t, size_t);
size_t run_sse2(const ChiangBatchConstants&, ChiangBatchOp, const ChiangBatchRows&, const ChiangBatchOutput&,
                size_t, size_t);
}  // namespace batch_detail

namespace {

using RunFn = size_t (*)(const ChiangBatchConstants&, ChiangBatchOp, const ChiangBatchRows&,
                         const ChiangBatchOutput&, size_t, size_t);
using HuangFn = void (*)(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&, double*);
using HuangRFn = double (*)(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&);
struct Isa {
    const char* name;
    RunFn run;
    HuangFn huang;  // Huang's stochastic eval lanes (huang_lanes.h) on the same instruction set
    HuangRFn huang_r;
    bool (*supported)();
};
bool has_avx512() {
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512cd");
}
bool has_avx2() { return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"); }
bool always() { return true; }
// Best first.
constexpr Isa kIsas[] = {{"avx512", batch_detail::run_avx512, batch_detail::huang_residual_avx512,
                          batch_detail::huang_r_avx512, has_avx512},
                         {"avx2", batch_detail::run_avx2, batch_detail::huang_residual_avx2,
                          batch_detail::huang_r_avx2, has_avx2},
                         {"sse2", batch_detail::run_sse2, batch_detail::huang_residual_sse2,
                          batch_detail::huang_r_sse2, always}};

int best_isa() {
    for (int i = 0; i < 3; ++i)
        if (kIsas[i].supported()) return i;
    return 2;
}
std::atomic<int> g_isa{best_isa()};

}  // namespace

ChiangBatchConstants chiang_batch_constants(const ChiangHairParams& params, RGB weight) {
    ChiangBatchConstants c{};
    const double sigma[3] = {params.sigma_a.r, params.sigma_a.g, params.sigma_a.b};
    const double w[3] = {weight.r, weight.g, weight.b};
    for (int k = 0; k < 3; ++k) {
        c.sigma_a[k] = float(sigma[k]);
        c.weight[k] = float(w[k]);
    }
    c.zero = !(std::fabs(average(weight)) > 0);
    c.eta = float(params.eta);
    c.exact = params.accuracy == Accuracy::Exact;
    c.blender34 = params.tilt_convention == TiltConvention::Blender34;
    for (int p = 0; p < 4; ++p) {
        const RGB& t = params.tint[p];
        c.tint[p][0] = float(t.r);
        c.tint[p][1] = float(t.g);
        c.tint[p][2] = float(t.b);
        // LongitudinalLobe's normalisation, as log_norm + 1/v for the log forms.
        const double v = params.v[p], inv_v = 1.0 / v;
        c.inv_v[p] = float(inv_v);
        c.log_branch[p] = true;
        if (c.exact) {
            c.log_norm_plus_inv_v[p] = float(-std::log(v) - std::log1p(-std::exp(-2.0 * inv_v)));
        } else if (v <= 0.1) {
            c.log_norm_plus_inv_v[p] = float(0.6931 + std::log(0.5 * inv_v));
        } else {
            c.log_branch[p] = false;
            c.norm[p] = float(1.0 / (std::sinh(inv_v) * 2.0 * v));
        }
        c.v_sample[p] = float(params.v_sample[p]);
        c.exp_minus_2_over_v[p] = float(std::exp(-2.0 / params.v_sample[p]));
    }
    const double angles[3] = {2 * params.tilt, -params.tilt, -4 * params.tilt};
    for (int p = 0; p < 3; ++p) {
        const double s = params.s[p];
        c.s[p] = float(s);
        c.logistic_norm[p] = float(1.0 / (logistic_cdf(kPi, s) - logistic_cdf(-kPi, s)));
        c.cdf_minus_pi[p] = float(logistic_cdf(-kPi, s));
        c.rot_sin[p] = float(std::sin(angles[p]));
        c.rot_cos[p] = float(std::cos(angles[p]));
    }
    return c;
}

ChiangBatchConstants chiang_batch_constants_principled(const PrincipledHairInputs& in, Accuracy accuracy,
                                                       TiltConvention tilt, RGB weight) {
    ChiangBatchConstants c = chiang_batch_constants(chiang_params_from_principled(in, accuracy, tilt), weight);
    ChiangBatchConstants::Node& n = c.node;
    n.parametrization = int(in.parametrization);
    n.roughness = float(in.roughness);
    n.radial_roughness = float(in.radial_roughness);
    n.coat = float(in.coat);
    n.random = float(in.random);
    n.random_roughness = float(in.random_roughness);
    n.random_color = float(in.random_color);
    n.melanin = float(in.melanin);
    const double redness = in.melanin_redness;
    const RGB melanin = (1.0 - redness) * kEumelaninAbsorption + redness * kPheomelaninAbsorption;
    const double absorption[3] = {in.absorption_coefficient.r, in.absorption_coefficient.g, in.absorption_coefficient.b};
    const double color[3] = {in.color.r, in.color.g, in.color.b};
    const double tint[3] = {in.tint.r, in.tint.g, in.tint.b};
    const double mel[3] = {melanin.r, melanin.g, melanin.b};
    for (int k = 0; k < 3; ++k) {
        n.absorption[k] = float(absorption[k]);
        n.color_log[k] = float(std::log(std::max(color[k], 0.0)));
        n.tint_log[k] = float(std::log(std::max(tint[k], 0.0)));
        n.melanin_absorption[k] = float(mel[k]);
    }
    return c;
}

size_t chiang_batch_run(const ChiangBatchConstants& c, ChiangBatchOp op, const ChiangBatchRows& rows,
                        const ChiangBatchOutput& out, size_t begin, size_t end) {
    return kIsas[g_isa.load(std::memory_order_relaxed)].run(c, op, rows, out, begin, end);
}

void huang_residual_lanes(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes,
                          double out[9]) {
    kIsas[g_isa.load(std::memory_order_relaxed)].huang(c, p, nodes, out);
}

double huang_r_lanes(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes) {
    return kIsas[g_isa.load(std::memory_order_relaxed)].huang_r(c, p, nodes);
}

const char* chiang_batch_isa() { return kIsas[g_isa.load()].name; }

const char* set_chiang_batch_isa(const char* name) {
    int pick = best_isa();
    for (int i = pick; i < 3; ++i)
        if (name && std::strcmp(name, kIsas[i].name) == 0) pick = i;
    g_isa = pick;
    return chiang_batch_isa();
}

}  // namespace hairbsdf
