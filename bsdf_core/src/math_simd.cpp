// The float kernels' instruction set; see hairbsdf/math_simd.h.
#include "hairbsdf/math_simd.h"

#include <atomic>
#include <cstring>

namespace hairbsdf {

namespace {

constexpr const char* kNames[kSimdIsaCount] = {"avx512", "avx2", "sse2"};

SimdIsa best_isa() {
    for (int i = 0; i < kSimdIsaCount; ++i)
        if (simd_isa_supported(SimdIsa(i))) return SimdIsa(i);
    return SimdIsa::sse2;
}

std::atomic<int>& current() {
    static std::atomic<int> isa{int(best_isa())};  // first use, not a static initialiser's order
    return isa;
}

}  // namespace

const char* simd_isa_name(SimdIsa isa) { return kNames[int(isa)]; }

bool simd_isa_supported(SimdIsa isa) {
#if defined(__x86_64__) && defined(__GNUC__)
    __builtin_cpu_init();  // may run from a static initialiser, before the CPU model is read otherwise
    switch (isa) {
        case SimdIsa::avx512:
            return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                   __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512cd");
        case SimdIsa::avx2: return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
        case SimdIsa::sse2: return true;
    }
    return false;
#else
    return isa == SimdIsa::sse2;
#endif
}

SimdIsa simd_isa() { return SimdIsa(current().load(std::memory_order_relaxed)); }

SimdIsa set_simd_isa(const char* name) {
    SimdIsa pick = best_isa();
    for (int i = int(pick); i < kSimdIsaCount; ++i)
        if (name && std::strcmp(name, kNames[i]) == 0) pick = SimdIsa(i);
    current().store(int(pick));
    return pick;
}

}  // namespace hairbsdf
