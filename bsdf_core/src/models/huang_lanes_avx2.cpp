// Huang's lanes built for avx2 (compile flags in bsdf_core/CMakeLists.txt; chosen in huang_lanes.cpp).
#define HAIRBSDF_BATCH_NS avx2
#include "huang_lanes_kernel.h"

namespace hairbsdf {
namespace huang_lanes_detail {
void huang_residual_avx2(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes,
                         double* out) {
    avx2::HuangLanes<xsimd::fma3<xsimd::avx2>>{c, p}.run(nodes, out);
}
void huang_trt_avx2(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangTrtPoints& points,
                     double* out) {
    avx2::HuangLanes<xsimd::fma3<xsimd::avx2>>{c, p}.run_trt(points, out);
}
void huang_tt_avx2(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangTtPoints& points,
                    double* out) {
    avx2::HuangLanes<xsimd::fma3<xsimd::avx2>>{c, p}.run_tt(points, out);
}
double huang_r_avx2(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes) {
    return avx2::HuangLanes<xsimd::fma3<xsimd::avx2>>{c, p}.run_r(nodes);
}
}  // namespace huang_lanes_detail
}  // namespace hairbsdf
