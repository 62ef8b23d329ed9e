// Huang's lanes on the float kernels' instruction set (hairbsdf/math_simd.h); see huang_lanes.h.
#include "huang_lanes.h"

#include "hairbsdf/math_simd.h"

namespace hairbsdf {

namespace {

using ResidualFn = void (*)(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&, double*);
using RFn = double (*)(const HuangLaneConstants&, const HuangLanePoint&, const HuangLaneNodes&);
// Indexed by SimdIsa.
constexpr ResidualFn kResidual[kSimdIsaCount] = {huang_lanes_detail::huang_residual_avx512,
                                                 huang_lanes_detail::huang_residual_avx2,
                                                 huang_lanes_detail::huang_residual_sse2};
using TrtFn = void (*)(const HuangLaneConstants&, const HuangLanePoint&, const HuangTrtPoints&, double*);
constexpr TrtFn kTrt[kSimdIsaCount] = {huang_lanes_detail::huang_trt_avx512, huang_lanes_detail::huang_trt_avx2,
                                       huang_lanes_detail::huang_trt_sse2};
using TtFn = void (*)(const HuangLaneConstants&, const HuangLanePoint&, const HuangTtPoints&, double*);
constexpr TtFn kTt[kSimdIsaCount] = {huang_lanes_detail::huang_tt_avx512, huang_lanes_detail::huang_tt_avx2,
                                     huang_lanes_detail::huang_tt_sse2};
constexpr RFn kR[kSimdIsaCount] = {huang_lanes_detail::huang_r_avx512, huang_lanes_detail::huang_r_avx2,
                                   huang_lanes_detail::huang_r_sse2};

}  // namespace

void huang_residual_lanes(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes,
                          double out[9]) {
    kResidual[int(simd_isa())](c, p, nodes, out);
}

void huang_trt_lanes(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangTrtPoints& points,
                     double out[6]) {
    kTrt[int(simd_isa())](c, p, points, out);
}

void huang_tt_lanes(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangTtPoints& points, double* out) {
    kTt[int(simd_isa())](c, p, points, out);
}

double huang_r_lanes(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes) {
    return kR[int(simd_isa())](c, p, nodes);
}

}  // namespace hairbsdf
