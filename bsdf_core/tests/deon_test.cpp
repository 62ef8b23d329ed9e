// d'Eon 2011 (models/deon.h): energy conservation, tables against the direct quadrature, sampler.
#include <gtest/gtest.h>

#include "hairbsdf/albedo.h"
#include "hairbsdf/closures.h"
#include "test_util.h"

using namespace hairbsdf;

TEST(Deon, WhiteFibreConservesEnergy) {
    DeonHairParams p;
    p.sigma_a = RGB(0.0);
    const ClosureSum c({Closure{RGB(1.0), DeonHair(p)}});
    for (double theta : {0.0, 0.7, 1.3}) {
        ShadingContext ctx;
        ctx.wo = test::direction(theta, 0.3);
        EXPECT_NEAR(directional_albedo(c, ctx).g, 1.0, 1e-3) << theta;
    }
}

TEST(Deon, TablesMatchDirectQuadrature) {
    DeonHairParams p;
    p.sigma_a = RGB(0.3, 0.6, 1.2);
    const DeonHair tab(p);
    p.tabulated = false;
    const DeonHair direct(p);
    std::mt19937_64 rng(19);
    double max_err = 0, max_val = 0;
    for (int i = 0; i < 1000; ++i) {
        ShadingContext ctx;
        ctx.wo = test::random_unit(rng);
        const Vec3 wi = test::random_unit(rng);
        const BsdfEval a = direct.eval(ctx, wi), b = tab.eval(ctx, wi);
        for (int l = 0; l < 3; ++l) {
            max_err = std::max(max_err, std::fabs(a.lobes[size_t(l)].r - b.lobes[size_t(l)].r));
            max_val = std::max(max_val, a.lobes[size_t(l)].r);
        }
    }
    EXPECT_LT(max_err, 1e-3 * max_val);
}

TEST(Deon, SampleWeightIsEvalOverPdfAndNothingIsNaN) {
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    DeonHairParams p;
    p.roughness = 0.05;
    p.tilt = 0.1;
    const DeonHair m(p);
    for (int i = 0; i < test::scaled(20000); ++i) {
        ShadingContext ctx;
        ctx.wo = i % 100 == 0 ? Vec3{1, 0, 0} : test::random_unit(rng);
        const auto sp = m.prepare(ctx);
        const BsdfSample s = m.sample(sp, {i % 5 == 0 ? 1.0 : uni(rng), uni(rng), i % 7 == 0 ? 1.0 : uni(rng)});
        ASSERT_NO_FATAL_FAILURE(test::expect_sample_matches_eval(m, sp, s, i % 3 == 0 ? ctx.wo : test::random_unit(rng)));
    }
}
