// Weighted sums of closures (closures.h): linearity of eval and Cycles' mixture pdf.
#include <gtest/gtest.h>

#include "hairbsdf/params/principled_hair.h"
#include "hairbsdf/closures.h"
#include "test_util.h"

using namespace hairbsdf;

namespace {
ChiangHair hair(double melanin, double roughness) {
    PrincipledHairInputs in;
    in.parametrization = Parametrization::Melanin;
    in.melanin = melanin;
    in.roughness = roughness;
    return ChiangHair(chiang_params_from_principled(in, Accuracy::Exact));
}
}  // namespace

TEST(ClosureSum, EvalIsWeightedSumAndPdfIsSampleWeightMixture) {
    const ChiangHair a = hair(0.2, 0.3), b = hair(0.9, 0.6);
    const RGB wa(0.25, 0.5, 0.75), wb(1.0, 0.5, 0.0);
    const ClosureSum sum({Closure{wa, a}, Closure{wb, b}});
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (int i = 0; i < 2000; ++i) {
        ShadingContext ctx;
        ctx.wo = test::random_unit(rng);
        ctx.h = 2 * uni(rng) - 1;
        const Vec3 wi = test::random_unit(rng);
        const BsdfEval ea = a.eval(ctx, wi), eb = b.eval(ctx, wi), e = sum.eval(ctx, wi);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(e.value()[c], wa[c] * ea.value()[c] + wb[c] * eb.value()[c], 1e-12 * (1 + e.value()[c]));
        }
        const double sa = average(wa), sb = average(wb);
        EXPECT_NEAR(e.pdf, (sa * ea.pdf + sb * eb.pdf) / (sa + sb), 1e-12 * (1 + e.pdf));

        const BsdfSample s = sum.sample(ctx, {uni(rng), uni(rng), uni(rng)});
        if (s.lobe < 0) continue;
        const BsdfEval at = sum.eval(ctx, s.wi);
        EXPECT_LT(test::relative_error(at.pdf, s.pdf), 1e-9);
        for (int c = 0; c < 3; ++c) EXPECT_LT(test::relative_error(at.value()[c], s.value[c]), 1e-9);
    }
}

TEST(ClosureSum, ZeroWeightSumGivesNothing) {
    const ClosureSum sum({Closure{RGB(0.0), hair(0.5, 0.3)}});
    ShadingContext ctx;
    EXPECT_EQ(sum.eval(ctx, Vec3{0, 1, 0}).pdf, 0.0);
    EXPECT_EQ(sum.sample(ctx, {0.5, 0.5, 0.5}).lobe, -1);
}
