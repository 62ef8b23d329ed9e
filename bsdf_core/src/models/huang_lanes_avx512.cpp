// Huang's lanes built for avx512 (compile flags in bsdf_core/CMakeLists.txt; chosen in huang_lanes.cpp).
#define HAIRBSDF_BATCH_NS avx512
#include "huang_lanes_kernel.h"

namespace hairbsdf {
namespace huang_lanes_detail {
void huang_residual_avx512(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes,
                         double* out) {
    avx512::HuangLanes<xsimd::avx512bw>{c, p}.run(nodes, out);
}
void huang_trt_avx512(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangTrtPoints& points,
                     double* out) {
    avx512::HuangLanes<xsimd::avx512bw>{c, p}.run_trt(points, out);
}
void huang_tt_avx512(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangTtPoints& points,
                    double* out) {
    avx512::HuangLanes<xsimd::avx512bw>{c, p}.run_tt(points, out);
}
double huang_r_avx512(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes) {
    return avx512::HuangLanes<xsimd::avx512bw>{c, p}.run_r(nodes);
}
}  // namespace huang_lanes_detail
}  // namespace hairbsdf
