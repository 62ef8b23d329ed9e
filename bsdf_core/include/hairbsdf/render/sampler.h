// Random numbers for the path tracer: one independent stream per (pixel, sample, seed),
// so that images do not depend on thread scheduling or tile order.
#pragma once

#include <cstdint>

namespace hairbsdf::render {

// 64-bit finaliser (splitmix64).
inline uint64_t mix64(uint64_t z) {
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// PCG32 (O'Neill 2014), XSH-RR output.
class Sampler {
public:
    Sampler(uint64_t pixel, uint64_t sample, uint64_t seed) {
        const uint64_t stream = mix64(pixel * 0x2545F4914F6CDD1Dull ^ mix64(seed + 0x632BE59BD9B4E019ull));
        inc_ = (stream << 1u) | 1u;
        state_ = 0;
        next_u32();
        state_ += mix64(sample ^ (pixel << 32) ^ seed);
        next_u32();
    }
    uint32_t next_u32() {
        const uint64_t old = state_;
        state_ = old * 6364136223846793005ull + inc_;
        const uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
        const uint32_t rot = uint32_t(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
    }
    // Uniform in [0, 1).
    double next() { return double(next_u32()) * (1.0 / 4294967296.0); }

private:
    uint64_t state_ = 0, inc_ = 1;
};

}  // namespace hairbsdf::render
