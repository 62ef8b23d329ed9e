// Float32 SIMD batch kernels for one Chiang closure (docs/simd.md): eval, pdf and sample over
// rows of fibre-frame directions (tangent = +x), with the closure's parameters uniform across the
// rows and everything that depends only on them computed once (ChiangBatchConstants), or with
// per-row Principled Hair inputs mapped and prepared per row, vectorised (ChiangBatchRowInputs).
// The kernels run on the best instruction set the CPU has (AVX-512, AVX2 + FMA, else SSE2),
// chosen once at run time. The scalar double path (ChiangHair) stays the reference.
#pragma once

#include <cstddef>
#include <cstdint>

#include "hairbsdf/math.h"
#include "hairbsdf/models/chiang.h"
#include "hairbsdf/params/principled_hair.h"

namespace hairbsdf {

// Everything eval, pdf and sample need that depends only on the parameters and the closure weight,
// in float. Built by chiang_batch_constants().
struct ChiangBatchConstants {
    float sigma_a[3];
    float eta;
    float weight[3];             // the closure weight (OSL's weight * closure)
    float tint[4][3];
    bool zero = false;           // the closure's sample weight is 0: every row is 0
    bool exact = false;          // Accuracy::Exact
    bool blender34 = false;      // TiltConvention::Blender34
    float inv_v[4];              // 1 / v per lobe (eval and pdf)
    float log_norm_plus_inv_v[4];  // log of M_p's normalisation + 1/v (log forms)
    float norm[4];               // M_p's normalisation (Cycles' direct form, v > 0.1)
    bool log_branch[4];          // Cycles: v <= 0.1 uses the log form
    float v_sample[4];
    float exp_minus_2_over_v[4];  // of v_sample
    float s[3];
    float logistic_norm[3];
    float cdf_minus_pi[3];       // logistic_cdf(-pi, s), for the trimmed sampler
    float rot_sin[3], rot_cos[3];  // tilt rotation per lobe (R, TT, TRT)

    // Per-row Principled Hair inputs (ChiangBatchRowInputs): the uniform node inputs the per-row
    // `prepare` starts from. Set by chiang_batch_constants_principled().
    struct Node {
        int parametrization = 0;     // Parametrization
        float roughness, radial_roughness, coat, random, random_roughness, random_color, melanin;
        float absorption[3];         // absorption_coefficient (Absorption)
        float color_log[3];          // log(max(color, 0)) (Color), -inf for a black channel
        float tint_log[3];           // log(max(tint, 0)) (Melanin's tint term)
        float melanin_absorption[3];  // (1 - redness) eumelanin + redness pheomelanin, per unit quantity
    } node{};
};
ChiangBatchConstants chiang_batch_constants(const ChiangHairParams& params, RGB weight);
// The same for principled_hair(model="chiang") inputs, with the node inputs the per-row path needs.
ChiangBatchConstants chiang_batch_constants_principled(const PrincipledHairInputs& in, Accuracy accuracy,
                                                       TiltConvention tilt, RGB weight);

// Per-row Principled Hair node inputs (docs/simd.md): null = the closure's uniform value. Same float
// type as the rows. The kernels map them per row as chiang_params_from_principled() does.
struct ChiangBatchRowInputs {
    const void* roughness = nullptr;         // (n,)
    const void* radial_roughness = nullptr;  // (n,)
    const void* coat = nullptr;              // (n,)
    const void* random = nullptr;            // (n,) the node's Random socket
    const void* melanin = nullptr;           // (n,) used by the Melanin parametrization
    const void* absorption = nullptr;        // (n, 3) absorption_coefficient, Absorption parametrization
    bool any() const { return roughness || radial_roughness || coat || random || melanin || absorption; }
};

// Rows of one batch call: AoS arrays, float32 or float64 (converted while loaded).
// wo, wi, u: (n, 3); h: (n,). Directions need not be unit length.
struct ChiangBatchRows {
    const void* wo = nullptr;
    const void* wi = nullptr;  // eval, pdf
    const void* h = nullptr;
    const void* u = nullptr;   // sample
    bool f64 = false;          // inputs are double
    ChiangBatchRowInputs inputs;  // per-row parameters (none: uniform, prepare hoisted)
};
// Outputs, float32 or float64 (out_f64). Unused ones may be null.
struct ChiangBatchOutput {
    void* value = nullptr;   // eval: (n, 3)
    void* pdf = nullptr;     // pdf, sample: (n,)
    void* wi = nullptr;      // sample: (n, 3)
    void* weight = nullptr;  // sample: (n, 3)
    int32_t* lobe = nullptr;  // sample: (n,)
    bool f64 = false;
};
enum class ChiangBatchOp { Eval, Pdf, Sample };

// Runs `op` on rows [begin, end). Returns the number of rows whose input is not allowed (a
// non-finite number, a zero direction, |h| > 1 + 1e-6, u outside [0, 1]); those rows are
// written as 0 and the caller reports the error (the Python layer names the argument).
size_t chiang_batch_run(const ChiangBatchConstants& c, ChiangBatchOp op, const ChiangBatchRows& rows,
                        const ChiangBatchOutput& out, size_t begin, size_t end);

// The kernels run on the instruction set of hairbsdf/math_simd.h (simd_isa, set_simd_isa).

}  // namespace hairbsdf
