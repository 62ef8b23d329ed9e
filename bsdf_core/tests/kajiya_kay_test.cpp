// Kajiya-Kay 1989 (models/kajiya_kay.h) and the zoo's sampling helpers in math.h.
#include <gtest/gtest.h>

#include "hairbsdf/albedo.h"
#include "hairbsdf/closures.h"
#include "test_util.h"

using namespace hairbsdf;

TEST(ZooMath, InverseNormalCdfRoundTrips) {
    for (double p : {1e-300, 1e-12, 1e-5, 0.02, 0.3, 0.5, 0.77, 0.99, 1 - 1e-9}) {
        const double z = inverse_normal_cdf(p);
        EXPECT_LT(test::relative_error(normal_cdf(z), p), 1e-12) << p;
    }
}

TEST(ZooMath, TruncatedNormalIsNormalisedAndInvertsItsCdf) {
    for (auto [mean, sd] : {std::pair{0.0, 0.1}, {-0.9, 0.01}, {1.8, 0.05}, {0.3, 3.0}}) {
        const TruncatedNormal t(mean, sd, -1.0, 1.0);
        if (!(t.mass() > 0)) continue;
        double integral = 0;
        const int n = 200000;
        for (int k = 0; k < n; ++k) integral += t.pdf(-1.0 + (k + 0.5) * 2.0 / n) * 2.0 / n;
        EXPECT_NEAR(integral, 1.0, 2e-3) << mean << " " << sd;
        double last = -2;
        for (double u : {0.0, 1e-7, 0.25, 0.5, 0.75, 1.0 - 1e-7, 1.0}) {
            const double x = t.sample(u);
            EXPECT_GE(x, last);
            EXPECT_GE(x, -1.0);
            EXPECT_LE(x, 1.0);
            last = x;
        }
    }
}

TEST(ZooMath, PiecewiseConstantSamplesItsDensity) {
    const PiecewiseConstant1D t([](double x) { return x * x; }, -1.0, 2.0, 300);
    EXPECT_NEAR(t.integral(), 3.0, 1e-9);
    for (double u : {0.1, 0.5, 0.9}) {
        const double x = t.sample(u, -1.0, 2.0);
        EXPECT_NEAR(t.cdf(x), u, 1e-9);
        const double y = t.sample(u, 0.0, 1.0);
        EXPECT_NEAR((t.cdf(y) - t.cdf(0.0)) / t.mass(0.0, 1.0), u, 1e-9);
    }
}

namespace {
KajiyaKayHair kk(double kd, double ks, double p) {
    KajiyaKayHairParams params;
    params.diffuse = RGB(kd);
    params.specular = RGB(ks);
    params.exponent = p;
    return KajiyaKayHair(params);
}
}  // namespace

TEST(KajiyaKay, FurnaceBoundAndNormalisation) {
    for (double p : {0.0, 60.0, 2000.0}) {
        for (auto [kd, ks] : {std::pair{0.5, 0.5}, {1.0, 0.0}, {0.0, 1.0}}) {
            const ClosureSum c({Closure{RGB(1.0), kk(kd, ks, p)}});
            for (double theta : {0.0, 0.5, 1.2, 1.55}) {
                ShadingContext ctx;
                ctx.wo = test::direction(theta, 0.3);
                const double a = directional_albedo(c, ctx).r;
                EXPECT_LE(a, 1.0 + 1e-6) << p << " " << kd << " " << theta;
                if (theta == 0.0) {
                    EXPECT_NEAR(a, kd + ks, 1e-6);
                }
            }
        }
    }
}

TEST(KajiyaKay, SampleWeightIsEvalOverPdfAndNothingIsNaN) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (double p : {0.0, 60.0, 1e4}) {
        const KajiyaKayHair m = kk(0.3, 0.6, p);
        for (int i = 0; i < test::scaled(20000); ++i) {
            ShadingContext ctx;
            ctx.wo = i % 100 == 0 ? Vec3{1, 0, 0} : test::random_unit(rng);
            ctx.h = 2 * uni(rng) - 1;
            const auto sp = m.prepare(ctx);
            const BsdfSample s = m.sample(sp, {uni(rng), uni(rng), i % 7 == 0 ? 1.0 : uni(rng)});
            ASSERT_NO_FATAL_FAILURE(test::expect_sample_matches_eval(m, sp, s, test::random_unit(rng)));
        }
    }
}
