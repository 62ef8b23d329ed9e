// Special functions and helpers of hairbsdf/math.h.
#include <gtest/gtest.h>

#include "hairbsdf/math.h"
#include "test_util.h"

using namespace hairbsdf;

TEST(Bessel, ExactI0MatchesHighPrecisionValues) {
    // Values from mpmath at 30 digits.
    const double cases[][2] = {{0.5, 1.0634833707413235},  {1, 1.2660658777520083},
                               {5, 27.239871823604447},     {10, 2815.7166284662545},
                               {20, 43558282.559553533},    {30, 781672297823.97749},
                               {100, 1.0737517071310738e42}};
    for (const auto& c : cases) EXPECT_LT(test::relative_error(bessel_i0(c[0]), c[1]), 1e-13) << c[0];
    EXPECT_EQ(bessel_i0(0.0), 1.0);
    EXPECT_NEAR(log_bessel_i0(1000.0), 995.62730888986946467, 1e-11);
    EXPECT_NEAR(log_bessel_i0(1e6), 999992.17330631281325, 1e-8);
}

TEST(Bessel, LogI0IsContinuousAcrossItsBranchSwitch) {
    const double x = kBesselSeriesLimit;
    const double below = std::log(bessel_i0_series(std::nextafter(x, 0.0)));
    const double above = log_bessel_i0_asymptotic(x);
    EXPECT_LT(std::fabs(below - above) / above, 1e-14);
    }

TEST(Bessel, CyclesApproximationsHaveTheirKnownErrors) {
    // The 10-term series is 2.0% low just below the switch at 12 (docs/validation.md §3.2) ...
    EXPECT_NEAR(cycles_bessel_i0(12.0) / bessel_i0(12.0), 0.980, 0.002);
    // ... and exact for small arguments.
    EXPECT_LT(test::relative_error(cycles_bessel_i0(1.0), bessel_i0(1.0)), 1e-15);
    // The asymptote above 12 is 0.57% low.
    EXPECT_NEAR(std::exp(cycles_log_bessel_i0(12.001) - log_bessel_i0(12.001)), 0.9943, 0.0005);
}

TEST(Fresnel, KnownValues) {
    EXPECT_NEAR(fresnel_dielectric(1.0, 1.55), 0.046521, 1e-6);
    EXPECT_DOUBLE_EQ(fresnel_dielectric(0.0, 1.55), 1.0);
    EXPECT_DOUBLE_EQ(fresnel_dielectric(0.1, 1.0 / 1.55), 1.0);  // total internal reflection
    EXPECT_NEAR(fresnel_dielectric(1.0, 1.0 / 1.55), 0.046521, 1e-6);
    EXPECT_DOUBLE_EQ(fresnel_dielectric(0.5, 1.0), 0.0);
}

TEST(TrimmedLogistic, IntegratesToOneAndInvertsItsCdf) {
    for (double s : {0.01, 0.05, 0.117, 0.5, 1.0, 5.0}) {
        const double norm = 1.0 / (logistic_cdf(kPi, s) - logistic_cdf(-kPi, s));
        double sum = 0;
        const int n = 200000;
        for (int i = 0; i < n; ++i) {
            const double x = -kPi + (i + 0.5) * kTwoPi / n;
            sum += logistic(x, s) * norm * kTwoPi / n;
        }
        EXPECT_NEAR(sum, 1.0, 1e-6) << s;
        double previous = -kPi;
        for (double u : {0.0, 0x1p-24, 0.1, 0.37, 0.5, 0.9, 1.0 - 0x1p-24, 1.0}) {
            const double x = sample_trimmed_logistic(u, s);
            ASSERT_TRUE(std::isfinite(x));
            EXPECT_GE(x, previous - 1e-12);
            previous = x;
            if (u > 1e-3 && u < 1 - 1e-3) {
                const double cdf = (logistic_cdf(x, s) - logistic_cdf(-kPi, s)) * norm;
                EXPECT_NEAR(cdf, u, 1e-6) << "s=" << s << " u=" << u;
            }
        }
    }
}

TEST(WrapAngle, MapsIntoMinusPiToPi) {
    for (double a : {-20.0, -7.0, -kPi, -1.0, 0.0, 2.0, kPi, 4.0, 13.0, 100.0}) {
        const double w = wrap_angle(a);
        EXPECT_GE(w, -kPi);
        EXPECT_LE(w, kPi);
        EXPECT_NEAR(std::remainder(w - a, kTwoPi), 0.0, 1e-12);
    }
}

// The float-accuracy transcendentals of Accuracy::Cycles' scalar path (math.h) against glibc's
// double functions: relative error within 1e-8 over their ranges, and the edge values.
TEST(FloatAccuracyMaths, ExpAsinAtan2WithinTheirBounds) {
    double worst_exp = 0, worst_asin = 0, worst_atan2 = 0;
    for (double x = -707.0; x < 708.0; x += 0.0137) {
        worst_exp = std::max(worst_exp, std::fabs(exp_float_accuracy(x) / std::exp(x) - 1.0));
    }
    for (double x = -1.0; x <= 1.0; x += 1.0 / 65536.0) {
        if (x != 0.0) worst_asin = std::max(worst_asin, std::fabs(asin_float_accuracy(x) / std::asin(x) - 1.0));
    }
    for (int i = 0; i < 4096; ++i) {
        const double angle = -kPi + kTwoPi * (i + 0.5) / 4096.0;
        for (double r : {1e-6, 1.0, 3e5}) {
            const double y = r * std::sin(angle), x = r * std::cos(angle);
            worst_atan2 = std::max(worst_atan2, std::fabs(atan2_float_accuracy(y, x) / std::atan2(y, x) - 1.0));
        }
    }
    EXPECT_LT(worst_exp, 1e-9);  // the table and cubic: 6e-10
    EXPECT_LT(worst_asin, 1e-8);
    EXPECT_LT(worst_atan2, 1e-8);
    EXPECT_EQ(exp_float_accuracy(-800.0), 0.0);
    EXPECT_EQ(exp_float_accuracy(800.0), HUGE_VAL);
    EXPECT_TRUE(std::isnan(exp_float_accuracy(NAN)));
    EXPECT_EQ(asin_float_accuracy(1.0), 0.5 * kPi);
    EXPECT_EQ(asin_float_accuracy(-1.0), -0.5 * kPi);
    EXPECT_EQ(atan2_float_accuracy(0.0, -1.0), kPi);
    EXPECT_EQ(atan2_float_accuracy(-0.0, -1.0), -kPi);
    EXPECT_EQ(atan2_float_accuracy(0.0, 0.0), 0.0);
    EXPECT_NEAR(atan2_float_accuracy(1.0, 0.0), 0.5 * kPi, 1e-15);
}

// The sampler's log and sin/cos at accuracy `cycles` (Chiang's sample): log to 1e-10 relative over the
// whole normal range (and near 1, where log is small), sin and cos to 1e-13 absolute over a few turns, so
// that a sampled direction stays a unit vector to 1e-12; other arguments of log go to std::log.
TEST(FloatAccuracyMaths, LogAndSincosWithinTheirBounds) {
    double worst_log = 0, worst_sincos = 0, worst_unit = 0;
    for (double e = -1020.0; e < 1020.0; e += 0.0731) {
        const double x = std::exp2(e);
        worst_log = std::max(worst_log, std::fabs(log_float_accuracy(x) / std::log(x) - 1.0));
    }
    for (double x = 0.99; x < 1.01; x += 1.0 / 65536.0) {
        if (x != 1.0) worst_log = std::max(worst_log, std::fabs(log_float_accuracy(x) / std::log(x) - 1.0));
    }
    for (double x = -4.0 * kPi; x < 4.0 * kPi; x += 1.0 / 4096.0) {
        const SinCosPair sc = sincos_accurate(x);
        worst_sincos = std::max({worst_sincos, std::fabs(sc.sin - std::sin(x)), std::fabs(sc.cos - std::cos(x))});
        worst_unit = std::max(worst_unit, std::fabs(sc.sin * sc.sin + sc.cos * sc.cos - 1.0));
    }
    EXPECT_LT(worst_log, 1e-10);
    EXPECT_LT(worst_sincos, 1e-13);
    EXPECT_LT(worst_unit, 1e-13);
    EXPECT_EQ(log_float_accuracy(1.0), 0.0);
    EXPECT_EQ(log_float_accuracy(0.0), -HUGE_VAL);
    EXPECT_TRUE(std::isnan(log_float_accuracy(-1.0)));
    EXPECT_EQ(log_float_accuracy(HUGE_VAL), HUGE_VAL);
    EXPECT_NEAR(log_float_accuracy(4.9e-324), std::log(4.9e-324), 1e-12);  // subnormal: std::log
    EXPECT_EQ(sincos_accurate(0.0).sin, 0.0);
    EXPECT_EQ(sincos_accurate(0.0).cos, 1.0);
}

// The two-lane exp (Chiang's lobe pairs) gives the scalar form's values, out-of-range and NaN lanes included.
TEST(FloatAccuracyMaths, TwoLaneExpEqualsTheScalarForm) {
    double worst = 0;
    for (double x = -707.0; x < 708.0; x += 0.0137) {
        const Double2 e = exp_float_accuracy(Double2{x, -0.5 * x});
        worst = std::max({worst, std::fabs(e[0] / exp_float_accuracy(x) - 1.0),
                          std::fabs(e[1] / exp_float_accuracy(-0.5 * x) - 1.0)});
    }
    EXPECT_LT(worst, 1e-15);
    const Double2 edge = exp_float_accuracy(Double2{-800.0, 1.0});
    EXPECT_EQ(edge[0], 0.0);
    EXPECT_NEAR(edge[1], std::exp(1.0), 1e-9);
    EXPECT_EQ(exp_float_accuracy(Double2{0.0, 800.0})[1], HUGE_VAL);
    EXPECT_TRUE(std::isnan(exp_float_accuracy(Double2{NAN, 0.0})[0]));
}

// The two-lane log and sin/cos (Chiang's sample) give the scalar forms' values bit for bit, per lane, over the
// scalar tests' ranges; edge lanes (log out of range or NaN) too.
TEST(FloatAccuracyMaths, TwoLaneLogSincosEqualTheScalarForms) {
    auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
    int differ = 0;
    for (double e = -1020.0; e < 1020.0; e += 0.0731) {
        const double x = std::exp2(e), y = std::exp2(-0.5 * e) * 1.37;
        const Double2 l = log_float_accuracy(Double2{x, y});
        differ += !same(l[0], log_float_accuracy(x)) + !same(l[1], log_float_accuracy(y));
    }
    for (double x = -4.0 * kPi; x < 4.0 * kPi; x += 1.0 / 4096.0) {
        const SinCosPair2 sc = sincos_accurate(Double2{x, 0.37 - x});
        const SinCosPair s0 = sincos_accurate(x), s1 = sincos_accurate(0.37 - x);
        differ += !same(sc.sin[0], s0.sin) + !same(sc.cos[0], s0.cos) + !same(sc.sin[1], s1.sin) +
                  !same(sc.cos[1], s1.cos);
    }
    EXPECT_EQ(differ, 0);
    const Double2 l = log_float_accuracy(Double2{0.0, 2.0});
    EXPECT_EQ(l[0], -HUGE_VAL);
    EXPECT_EQ(l[1], log_float_accuracy(2.0));
    EXPECT_TRUE(std::isnan(log_float_accuracy(Double2{-1.0, 1.0})[0]));
}
