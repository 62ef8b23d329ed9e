// The zoo models behind the engine's interface: ClosureSum (what the renderer calls through
// prepare / eval_model / sample_model) mixes them with Chiang like any other closure.
#include <gtest/gtest.h>

#include "hairbsdf/closures.h"
#include "hairbsdf/params/principled_hair.h"
#include "test_util.h"

using namespace hairbsdf;

TEST(Zoo, ModelsMixInAClosureSumWithChiang) {
    PrincipledHairInputs in;
    in.parametrization = Parametrization::Melanin;
    in.melanin = 0.3;
    const ChiangHair chiang(chiang_params_from_principled(in, Accuracy::Exact));
    EpicHairParams epic;
    epic.scatter = 0.4;
    epic.base_color = RGB(0.7, 0.5, 0.3);
    const ClosureSum sum({Closure{RGB(0.3), chiang}, Closure{RGB(0.5, 0.4, 0.3), KajiyaKayHair(KajiyaKayHairParams{})},
                          Closure{RGB(0.6), EpicHair(epic)}, Closure{RGB(0.2), ScheuermannHair(ScheuermannHairParams{})},
                          Closure{RGB(0.4), MarschnerHair(MarschnerHairParams{})}, Closure{RGB(0.5), DeonHair(DeonHairParams{})},
                          Closure{RGB(0.3), YanFurHair(YanFurParams{})}});
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    int produced = 0;
    for (int i = 0; i < 4000; ++i) {
        ShadingContext ctx;
        ctx.tangent = test::random_unit(rng);  // world space: any tangent
        ctx.wo = test::random_unit(rng);
        ctx.h = 2 * uni(rng) - 1;
        ctx.shadow = uni(rng);
        const auto sp = sum.prepare(ctx);
        const BsdfSample s = sum.sample(sp, {uni(rng), uni(rng), uni(rng)});
        ASSERT_TRUE(isfinite(s.weight));
        if (s.lobe < 0) continue;
        ++produced;
        const BsdfEval e = sum.eval(sp, s.wi);
        ASSERT_LT(test::relative_error(e.pdf, s.pdf), 1e-9);
        ASSERT_LT(test::relative_error(sum.pdf(sp, s.wi), s.pdf), 1e-9);
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(s.weight[c], e.value()[c] / e.pdf, 1e-9 * (1 + s.weight[c]));
    }
    EXPECT_GT(produced, 3900);
}

TEST(Zoo, WorldSpaceEvalIsInvariantUnderRotation) {
    // The models see directions only through the fibre frame built from (tangent, wo).
    const EpicHair epic(EpicHairParams{});
    const ScheuermannHair sch(ScheuermannHairParams{});
    const KajiyaKayHair kk(KajiyaKayHairParams{});
    const MarschnerHair marschner(MarschnerHairParams{});
    const DeonHair deon(DeonHairParams{});
    const YanFurHair yan(YanFurParams{});
    std::mt19937_64 rng(5);
    auto rotate = [](Vec3 v) { return Vec3{v.z, v.x, v.y}; };  // a cyclic permutation is a rotation
    for (int i = 0; i < 500; ++i) {
        ShadingContext a;
        a.tangent = test::random_unit(rng);
        a.wo = test::random_unit(rng);
        ShadingContext b = a;
        b.tangent = rotate(a.tangent);
        b.wo = rotate(a.wo);
        const Vec3 wi = test::random_unit(rng);
        auto check = [&](const auto& m) {
            const BsdfEval ea = m.eval(a, wi), eb = m.eval(b, rotate(wi));
            EXPECT_LT(test::relative_error(ea.pdf, eb.pdf, 1e-12), 1e-9);
            for (int c = 0; c < 3; ++c) EXPECT_NEAR(ea.value()[c], eb.value()[c], 1e-9 * (1 + ea.value()[c]));
        };
        check(epic);
        check(sch);
        check(kk);
        check(marschner);
        check(deon);
        check(yan);
    }
}
