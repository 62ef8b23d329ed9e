// Huang in float SIMD lanes (docs/simd.md). The stochastic eval (Cycles' estimator: R's Simpson sum, and TT, TRT
// and TRRT+ at each residual Simpson node with the visible normals drawn from its LCG) as lanes over the nodes: the
// caller draws every node's numbers first, in Cycles' order, so the lanes keep the estimator. The deterministic
// eval's TRT rule and TT cubature as lanes over the points of one node. Private to bsdf_core.
#pragma once

#include <cstddef>
#include <cstdint>

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

// Points of the deterministic eval's TRT rule at one node and copy (HuangHair::trt_mis_point): the Sobol'
// points [0, count) of dimensions 0-3, each XORed with the copy's digital shift; each point weighs
// 2 u0 x weight.
struct HuangTrtPoints {
    size_t count;
    const uint32_t* sobol[4];  // unshifted
    uint32_t shift[4];
    float gamma, sin_gamma, cos_gamma;
    float weight;  // the node's Simpson weight x |d gamma / dh|
    bool trrt_shell;  // TRRT+'s shell proposal (strategy C)
};

// Points of the deterministic eval's TT cubature at one node (HuangHair::Residual): entry disk points at
// radius u1a and angle 2 pi u1b.
struct HuangTtPoints {
    size_t count;
    const float *u1a, *u1b;
    float gamma, sin_gamma, cos_gamma;
};

// Adds TT rgb, TRT rgb and TRRT+ rgb of every node into out[0..8], on the batch kernels' instruction set.
void huang_residual_lanes(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes,
                          double out[9]);
// Adds the sums of TRT rgb and TRRT+ rgb over the points (trt_mis_point's values: before the eval's
// factors) into out[0..5]; each lane's values are summed in double.
void huang_trt_lanes(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangTrtPoints& points,
                     double out[6]);
// tt_exit's rgb of each point (before any weight; 0 where the double path gives 0) into out[3 i + channel].
void huang_tt_lanes(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangTtPoints& points, double* out);
// R's Simpson sum over its nodes (h and weight only; the draws are not read): sum of weight x r_integrand.
double huang_r_lanes(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes);

namespace huang_lanes_detail {
void huang_residual_sse2(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&, double*);
void huang_residual_avx2(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&, double*);
void huang_residual_avx512(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&, double*);
void huang_trt_sse2(const HuangLaneConstants&, const HuangLanePoint&, const HuangTrtPoints&, double*);
void huang_trt_avx2(const HuangLaneConstants&, const HuangLanePoint&, const HuangTrtPoints&, double*);
void huang_trt_avx512(const HuangLaneConstants&, const HuangLanePoint&, const HuangTrtPoints&, double*);
void huang_tt_sse2(const HuangLaneConstants&, const HuangLanePoint&, const HuangTtPoints&, double*);
void huang_tt_avx2(const HuangLaneConstants&, const HuangLanePoint&, const HuangTtPoints&, double*);
void huang_tt_avx512(const HuangLaneConstants&, const HuangLanePoint&, const HuangTtPoints&, double*);
double huang_r_sse2(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&);
double huang_r_avx2(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&);
double huang_r_avx512(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&);
}  // namespace huang_lanes_detail

}  // namespace hairbsdf
