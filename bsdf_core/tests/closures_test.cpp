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

// What the renderer reads from each model through closures.h (render::Bsdf uses nothing else).
TEST(RenderInterface, ModelsSayWhatTheRendererNeeds) {
    PrincipledHairInputs in;
    in.parametrization = Parametrization::Melanin;
    in.aspect_ratio = 0.8;
    const HairModel chiang{ChiangHair(chiang_params_from_principled(in))};
    HuangHairParams hp = huang_params_from_principled(in);
    hp.sampler = HuangSampler::Cycles;
    const HairModel huang{HuangHair(hp)};
    CyclesHairParams cp;
    cp.component = CyclesHairComponent::Reflection;
    const HairModel legacy_r{CyclesHair(cp)};
    cp.component = CyclesHairComponent::Transmission;
    const HairModel legacy_t{CyclesHair(cp)};
    const HairModel kk{KajiyaKayHair(KajiyaKayHairParams{})};

    // Stochastic eval: Huang only, seeded from one uniform number of the path's sampler.
    EXPECT_TRUE(model_stochastic_eval(huang));
    EXPECT_FALSE(model_stochastic_eval(chiang) || model_stochastic_eval(legacy_r) || model_stochastic_eval(kk));
    EXPECT_EQ(model_eval_seed(huang, 0.5), 2147483648u);
    EXPECT_EQ(model_eval_seed(chiang, 0.5), 0u);
    // Transmission (SD_BSDF_HAS_TRANSMISSION): hair models yes, the legacy reflection no.
    EXPECT_TRUE(model_transmits(chiang) && model_transmits(huang) && model_transmits(legacy_t) && model_transmits(kk));
    EXPECT_FALSE(model_transmits(legacy_r));
    // Filter Glossy: Principled Hair blurs; a zoo model does not.
    std::optional<HairModel> blurred;
    EXPECT_TRUE(blur_model(chiang, 0.9, blurred));
    EXPECT_FALSE(blur_model(kk, 0.9, blurred));

    ShadingContext ctx;
    ctx.wo = normalize(Vec3{0.1, 0.3, 1.0});
    ctx.h = 0.2;
    const Vec3 wi = normalize(Vec3{0.4, -0.7, -0.2});
    const PreparedModel point = prepare_model(huang, ctx);
    EXPECT_FALSE(model_transparent(huang, point));
    // The stochastic eval advances its state: the same state gives the same value, a new one another.
    uint32_t a = 7, b = 7;
    const BsdfEval first = eval_at_hit(huang, point, wi, a), again = eval_at_hit(huang, point, wi, b);
    EXPECT_EQ(first.value().r, again.value().r);
    EXPECT_NE(a, 7u);
    EXPECT_NE(eval_at_hit(huang, point, wi, a).value().r, first.value().r);
    // A deterministic model's eval at a hit is its eval.
    const PreparedModel cpoint = prepare_model(chiang, ctx);
    uint32_t unused = 0;
    EXPECT_EQ(eval_at_hit(chiang, cpoint, wi, unused).value().g, eval_model(chiang, cpoint, wi).value().g);
    EXPECT_EQ(unused, 0u);
    // Outside the projected ellipse Huang's closure is a transparent one.
    ctx.h = 0.95;
    EXPECT_TRUE(model_transparent(huang, prepare_model(huang, ctx)));
}
