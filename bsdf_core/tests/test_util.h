// Helpers shared by the GoogleTest files.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <random>

#include "hairbsdf/closure.h"
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

// A model's sample agrees with its eval: weight = eval / pdf and pdf = eval's pdf at the sampled
// direction; nothing is NaN, and eval at `other` is finite with pdf >= 0. Call it through
// ASSERT_NO_FATAL_FAILURE.
template <class Model, class ShadingPoint>
void expect_sample_matches_eval(const Model& m, const ShadingPoint& sp, const BsdfSample& s, Vec3 other) {
    ASSERT_TRUE(isfinite(s.weight) && isfinite(s.wi));
    if (s.lobe >= 0) {
        const BsdfEval e = m.eval(sp, s.wi);
        ASSERT_LT(relative_error(e.pdf, s.pdf), 1e-12);
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(s.weight[c], e.value()[c] / e.pdf, 1e-9 * (1 + s.weight[c]));
    }
    const BsdfEval r = m.eval(sp, other);
    ASSERT_TRUE(isfinite(r.value()) && std::isfinite(r.pdf) && r.pdf >= 0);
}

}  // namespace hairbsdf::test
