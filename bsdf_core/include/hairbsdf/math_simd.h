// The SIMD instruction set of the float kernels (the Chiang batch kernels, Huang's lanes; docs/simd.md):
// the best this CPU has, unless a test or benchmark picks another. One choice for all of them.
#pragma once

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

}  // namespace hairbsdf
