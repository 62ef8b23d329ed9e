// The AVX2 + FMA build of ChiangHair's scalar prepare, eval and sample (chiang.h, docs/simd.md). Each
// function below carries the target attribute and `flatten`, so the *_baseline body and everything it calls
// from the headers is inlined into it and compiled for AVX2 + FMA there; no out-of-line copy of a header
// function is built for AVX2 (a call flatten could not inline goes to the baseline copy), so callers on
// machines without AVX2 never reach AVX2 code. Chosen at run time by scalar_avx2() (math_simd.h).
#include "hairbsdf/models/chiang.h"

#include "hairbsdf/math_simd.h"

namespace hairbsdf {

#if defined(__x86_64__) && defined(__GNUC__)
HAIRBSDF_SCALAR_AVX2 __attribute__((flatten)) ChiangHair::ShadingPoint ChiangHair::prepare_avx2(
    const ChiangHair& model, const ShadingContext& ctx) {
    return model.prepare_baseline(ctx);
}
HAIRBSDF_SCALAR_AVX2 __attribute__((flatten)) BsdfEval ChiangHair::eval_avx2(const ChiangHair& model,
                                                                              const ShadingPoint& sp, Vec3 wi) {
    return model.eval_baseline(sp, wi);
}
HAIRBSDF_SCALAR_AVX2 __attribute__((flatten)) BsdfSample ChiangHair::sample_avx2(
    const ChiangHair& model, const ShadingPoint& sp, const std::array<double, 3>& u,
    const LongitudinalNumbers* longitudinal) {
    return model.sample_baseline(sp, u, longitudinal);
}
#endif

}  // namespace hairbsdf
