// The Chiang batch kernels built for avx2 (compile flags in bsdf_core/CMakeLists.txt).
#define HAIRBSDF_BATCH_NS avx2
#include "chiang_batch_kernel.h"

namespace hairbsdf {
namespace batch_detail {
size_t run_avx2(const ChiangBatchConstants& c, ChiangBatchOp op, const ChiangBatchRows& rows,
                 const ChiangBatchOutput& out, size_t begin, size_t end) {
    return avx2::run<xsimd::fma3<xsimd::avx2>>(c, op, rows, out, begin, end);
}
}  // namespace batch_detail
}  // namespace hairbsdf
