// Marschner 2003 (models/marschner.h): the cubic root solve, sampler consistency, robustness.
#include <cstdio>
#include <gtest/gtest.h>

#include "hairbsdf/albedo.h"
#include "hairbsdf/closures.h"
#include "test_util.h"

using namespace hairbsdf;

TEST(Marschner, RootsSolveTheCubicAndLieInRange) {
    for (int p = 0; p < 3; ++p) {
        for (double eta_prime : {1.2, 1.55, 2.5}) {
            const double c = std::asin(1.0 / eta_prime);
            for (double phi = -3.1; phi < 3.1; phi += 0.05) {
                std::array<double, 6> g{};
                const int n = MarschnerHair::solve_gamma(p, c, phi, g);
                // R covers every phi once; TT is monotonic (at most one root; none outside its
                // deflection range, e.g. backwards for eta' near 1); TRT has up to three.
                if (p == 0) {
                    EXPECT_EQ(n, 1) << phi;
                }
                if (p == 1) {
                    EXPECT_LE(n, 1) << eta_prime << " " << phi;
                }
                EXPECT_LE(n, 3);
                for (int k = 0; k < n; ++k) {
                    const double x = g[size_t(k)];
                    EXPECT_LE(std::fabs(x), 0.5 * kPi);
                    const double value = (6.0 * p * c / kPi - 2.0) * x - 8.0 * p * c / (kPi * kPi * kPi) * x * x * x + p * kPi;
                    EXPECT_NEAR(wrap_angle(value - phi), 0.0, 1e-9);
                }
            }
        }
    }
}

TEST(Marschner, SampleWeightIsEvalOverPdfAndNothingIsNaN) {
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (double beta : {0.005, 0.13, 0.7}) {
        MarschnerHairParams p;
        p.beta_r = beta;
        p.glint_scale = 5.0;
        p.eccentricity = 0.5;
        const MarschnerHair m(p);
        for (int i = 0; i < test::scaled(10000); ++i) {
            ShadingContext ctx;
            ctx.wo = i % 100 == 0 ? Vec3{1, 0, 0} : test::random_unit(rng);
            ctx.normal = i % 2 ? test::random_unit(rng) : Vec3{};
            const auto sp = m.prepare(ctx);
            const BsdfSample s = m.sample(sp, {uni(rng), uni(rng), i % 7 == 0 ? 1.0 : uni(rng)});
            ASSERT_NO_FATAL_FAILURE(test::expect_sample_matches_eval(m, sp, s, i % 3 == 0 ? ctx.wo : test::random_unit(rng)));
        }
    }
}

TEST(Marschner, EnergyTableMatchesDenseQuadrature) {
    // The bounded model's table of the published albedo against the library's brute-force
    // quadrature (3 panels per lobe width) at table nodes, within 1 % (the rules converge unevenly
    // through the jumps where roots appear and vanish); orientation node 0 is the major axis along
    // the frame's y, what a zero normal gives.
    for (double eccentricity : {1.0, 0.9}) {
        MarschnerHairParams p;
        p.sigma_a = RGB(0.0, 0.2, 0.6);
        p.eccentricity = eccentricity;
        const MarschnerHair bounded(p);
        ASSERT_TRUE(bounded.energy_table());
        const EnergyBoundTable& table = *bounded.energy_table();
        EXPECT_EQ(table.orientations(), MarschnerHair::orientation_nodes(eccentricity));
        std::printf("[ energy table ] eccentricity %.2f: %d orientations built in %.2f s\n", eccentricity,
                    table.orientations(), table.build_seconds);  // a benchmark figure, never asserted
        p.energy = EnergyMode::Published;
        const ClosureSum published({Closure{RGB(1.0), MarschnerHair(p)}});
        for (int k : {3, 8, 20, 32, 45, 61}) {
            ShadingContext ctx;
            ctx.wo = test::direction(table.view_theta(k), 0.0);
            const RGB brute = directional_albedo(published, ctx, {3.0, 40'000'000});
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(table.node(0, k)[c], brute[c], 1e-2 * std::max(brute[c], 0.1)) << eccentricity << " " << k;
        }
    }
}
