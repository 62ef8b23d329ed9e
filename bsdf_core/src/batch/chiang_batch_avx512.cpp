// The Chiang batch kernels built for avx512 (compile flags in bsdf_core/CMakeLists.txt).
#define HAIRBSDF_BATCH_NS avx512
#include "chiang_batch_kernel.h"

namespace hairbsdf {
namespace batch_detail {
size_t run_avx512(const ChiangBatchConstants& c, ChiangBatchOp op, const ChiangBatchRows& rows,
                 const ChiangBatchOutput& out, size_t begin, size_t end) {
    return avx512::run<xsimd::avx512bw>(c, op, rows, out, begin, end);
}
}  // namespace batch_detail
}  // namespace hairbsdf
