// The Chiang batch kernels built for sse2 (compile flags in bsdf_core/CMakeLists.txt).
#define HAIRBSDF_BATCH_NS sse2
#include "chiang_batch_kernel.h"

namespace hairbsdf {
namespace batch_detail {
size_t run_sse2(const ChiangBatchConstants& c, ChiangBatchOp op, const ChiangBatchRows& rows,
                 const ChiangBatchOutput& out, size_t begin, size_t end) {
    return sse2::run<xsimd::sse2>(c, op, rows, out, begin, end);
}
}  // namespace batch_detail
}  // namespace hairbsdf
