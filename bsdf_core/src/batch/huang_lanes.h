// Huang's stochastic eval (Cycles' estimator: R's Simpson sum, and TT, TRT and TRRT+ at each residual Simpson
// node with the visible normals drawn from its LCG) as float SIMD lanes over the nodes (docs/simd.md). The caller
// draws every node's numbers first, in Cycles' order, so the lanes keep the estimator. Private to bsdf_core.
#pragma once

#include <cstddef>

#include "hairbsdf/models/huang.h"

namespace hairbsdf {

// The nodes of one eval and their draws (entry disk: u1a, u1b; internal disk: u2a, u2b, read only with TRT).
struct HuangLaneNodes {
    size_t count;
    const float* h;       // r-normalised h
    const float* weight;  // Simpson weight
    const float *u1a, *u1b, *u2a, *u2b;
};

// The shading point and outgoing direction (Huang's local frame) with the eval's scale factors.
struct HuangLanePoint {
    float I[3], O[3];
    float wh[3];  // normalize(I + O), for R
    float gamma_base, sin_phi_i, cos_phi_i;  // ShadingPoint's
    float tt_scale;    // TT factor x final_scale
    float trt_scale;   // TRT factor x final_scale
    float trrt_scale;
    bool tt, trt;      // the lobes with a positive factor
};

// Adds TT rgb, TRT rgb and TRRT+ rgb of every node into out[0..8], on the batch kernels' instruction set.
void huang_residual_lanes(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes,
                          double out[9]);
// R's Simpson sum over its nodes (h and weight only; the draws are not read): sum of weight x r_integrand.
double huang_r_lanes(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes);

namespace batch_detail {
void huang_residual_sse2(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&, double*);
void huang_residual_avx2(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&, double*);
void huang_residual_avx512(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&, double*);
double huang_r_sse2(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&);
double huang_r_avx2(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&);
double huang_r_avx512(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&);
}  // namespace batch_detail

}  // namespace hairbsdf
