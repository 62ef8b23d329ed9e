// Helpers shared by the GoogleTest files.
#pragma once

#include <cstdlib>
#include <random>

#include "hairbsdf/math.h"

namespace hairbsdf::test {

// Test sizes scale with HAIRBSDF_TEST_SCALE (the sanitizer build runs smaller grids).
inline double scale() {
    const char* s = std::getenv("HAIRBSDF_TEST_SCALE");
    return s ? std::max(0.01, std::atof(s)) : 1.0;
}
inline long scaled(long n) { return std::max(1L, long(double(n) * scale())); }

inline Vec3 random_unit(std::mt19937_64& rng) {
    std::normal_distribution<double> g;
    while (true) {
        const Vec3 v{g(rng), g(rng), g(rng)};
        if (length(v) > 1e-6) return normalize(v);
    }
}

// A direction in the fibre frame (x = tangent) from theta and phi.
inline Vec3 direction(double theta, double phi) {
    return {std::sin(theta), std::cos(theta) * std::cos(phi), std::cos(theta) * std::sin(phi)};
}

inline double relative_error(double a, double b, double floor = 1e-12) {
    return std::fabs(a - b) / (std::fabs(b) + floor);
}

}  // namespace hairbsdf::test
