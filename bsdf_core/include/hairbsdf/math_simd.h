// The SIMD instruction set of the float kernels (the Chiang batch kernels, Huang's lanes; docs/simd.md):
// the best this CPU has, unless a test or benchmark picks another. One choice for all of them.
#pragma once

#include <atomic>

namespace hairbsdf {

enum class SimdIsa { avx512, avx2, sse2 };  // best first
inline constexpr int kSimdIsaCount = 3;

// "avx512", "avx2" or "sse2".
const char* simd_isa_name(SimdIsa isa);
// Whether this CPU runs `isa` (avx512: F, BW, DQ, CD; avx2: with FMA; sse2: always on x86-64).
bool simd_isa_supported(SimdIsa isa);
// The instruction set in use.
SimdIsa simd_isa();
// Picks the named instruction set for tests and benchmarks; an unknown name or one this CPU
// lacks picks the best available. Returns the one now in use.
SimdIsa set_simd_isa(const char* name);

// The scalar double code's AVX2 + FMA builds (ChiangHair's prepare, eval and sample; the Sweep curve
// intersector's exact test): functions marked HAIRBSDF_SCALAR_AVX2 and `flatten`, whose bodies are the
// baseline's, so everything they call from the headers is compiled for AVX2 + FMA inside them. Each
// caller picks that build or the baseline (x86-64's SSE2) per call from this one flag: on where the CPU
// has AVX2 and FMA. set_scalar_avx2(false) selects the baseline builds (the tests compare the two);
// set_scalar_avx2(true) takes AVX2 only where the CPU has it. Returns the builds in use.
#if defined(__x86_64__) && defined(__GNUC__)
#define HAIRBSDF_SCALAR_AVX2 __attribute__((target("avx2,fma")))
inline std::atomic<bool> g_scalar_avx2{simd_isa_supported(SimdIsa::avx2)};
inline bool scalar_avx2() { return g_scalar_avx2.load(std::memory_order_relaxed); }
inline bool set_scalar_avx2(bool on) {
    g_scalar_avx2.store(on && simd_isa_supported(SimdIsa::avx2), std::memory_order_relaxed);
    return scalar_avx2();
}
#else
#define HAIRBSDF_SCALAR_AVX2
inline bool scalar_avx2() { return false; }
inline bool set_scalar_avx2(bool) { return false; }
#endif

}  // namespace hairbsdf
