// Huang's stochastic eval lanes built for avx2 (compile flags in bsdf_core/CMakeLists.txt).
#define HAIRBSDF_BATCH_NS avx2
#include "huang_lanes_kernel.h"

namespace hairbsdf {
namespace batch_detail {
void huang_residual_avx2(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes,
                         double* out) {
    avx2::HuangLanes<xsimd::fma3<xsimd::avx2>>{c, p}.run(nodes, out);
}
double huang_r_avx2(const HuangLaneConstants& c, const HuangLanePoint& p, const HuangLaneNodes& nodes) {
    return avx2::HuangLanes<xsimd::fma3<xsimd::avx2>>{c, p}.run_r(nodes);
}
}  // namespace batch_detail
}  // namespace hairbsdf
