// Scheuermann (ATI) 2004 (models/scheuermann.h): normalisation, energy, sampler, robustness.
#include <gtest/gtest.h>

#include "hairbsdf/albedo.h"
#include "hairbsdf/closures.h"
#include "test_util.h"

using namespace hairbsdf;

TEST(Scheuermann, LobeAlbedoMatchesBruteForce) {
    // albedo(V) = int g(T.normalize(L + V)) d omega_L by a plain sphere quadrature, T = x.
    for (double p : {0.0, 60.0}) {
        for (double v_t : {-0.7, 0.0, 0.4}) {
            const Vec3 V{v_t, std::sqrt(1 - v_t * v_t), 0};
            const int n = 1000, m = 2000;
            double sum = 0;
            for (int i = 0; i < n; ++i) {
                const double s = -1.0 + (i + 0.5) * 2.0 / n;
                for (int j = 0; j < m; ++j) {
                    const double phi = (j + 0.5) * kTwoPi / m;
                    const Vec3 L{s, cos_from_sin(s) * std::cos(phi), cos_from_sin(s) * std::sin(phi)};
                    const Vec3 H = normalize(L + V);
                    sum += ScheuermannHair::lobe_shape(H.x, p);
                }
            }
            sum *= (2.0 / n) * (kTwoPi / m);
            EXPECT_NEAR(ScheuermannHair::lobe_albedo(p, v_t), sum, 2e-3 * sum) << p << " " << v_t;
        }
    }
}

TEST(Scheuermann, FurnaceBound) {
    for (double p : {0.0, 240.0}) {
        ScheuermannHairParams params;
        params.primary_color = RGB(1.0);
        params.secondary_color = RGB(0.0);
        params.primary_exponent = p;
        const ClosureSum c({Closure{RGB(1.0), ScheuermannHair(params)}});
        for (double theta : {-1.2, -0.3, 0.0, 0.7, 1.5}) {
            ShadingContext ctx;
            ctx.wo = test::direction(theta, 0.3);
            EXPECT_LE(directional_albedo(c, ctx).r, 1.002) << p << " " << theta;
        }
    }
}

TEST(Scheuermann, SampleWeightIsEvalOverPdfAndNothingIsNaN) {
    std::mt19937_64 rng(13);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (double p : {0.0, 240.0, 1e4}) {
        ScheuermannHairParams params;
        params.primary_exponent = p;
        params.secondary_shift = -1.0;
        const ScheuermannHair m(params);
        for (int i = 0; i < test::scaled(20000); ++i) {
            ShadingContext ctx;
            ctx.wo = i % 100 == 0 ? Vec3{1, 0, 0} : test::random_unit(rng);
            const auto sp = m.prepare(ctx);
            const BsdfSample s = m.sample(sp, {uni(rng), uni(rng), i % 7 == 0 ? 1.0 : uni(rng)});
            ASSERT_NO_FATAL_FAILURE(test::expect_sample_matches_eval(m, sp, s, i % 3 == 0 ? -1.0 * ctx.wo : test::random_unit(rng)));
        }
    }
}
