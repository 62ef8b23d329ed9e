// The diffuse and emission models (models/diffuse.h, models/emission.h) and what the renderer
// reads from them through closures.h.
#include <gtest/gtest.h>

#include "hairbsdf/closures.h"
#include "test_util.h"

using namespace hairbsdf;

namespace {
ShadingContext surface(Vec3 n, Vec3 ng, Vec3 wo) {
    ShadingContext ctx;
    ctx.wo = wo;
    ctx.shading_normal = n;
    ctx.geometric_normal = ng;
    return ctx;
}
}  // namespace

TEST(Diffuse, EvalIsCosineOverPiOnTheNormalsSideAndReciprocal) {
    std::mt19937_64 rng(3);
    const DiffuseBsdf m;
    const Vec3 n = normalize(Vec3{0.2, -0.3, 1.0});
    for (int i = 0; i < 2000; ++i) {
        const Vec3 wo = test::random_unit(rng), wi = test::random_unit(rng);
        const BsdfEval e = m.eval(surface(n, n, wo), wi);
        const double c = dot(n, wi);
        if (c > 0) {
            EXPECT_EQ(e.pdf, c / kPi);
            EXPECT_EQ(e.value().r, c / kPi);
            EXPECT_EQ(e.value().b, c / kPi);
            // Reciprocity of the cosine-free BSDF: f(wo, wi) = f(wi, wo) = 1 / pi.
            const double co = dot(n, wo);
            if (co > 0) {
                const BsdfEval back = m.eval(surface(n, n, wi), wo);
                EXPECT_NEAR(e.value().g / c, back.value().g / co, 1e-15);
            }
        } else {
            EXPECT_EQ(e.pdf, 0.0);
            EXPECT_EQ(e.value().g, 0.0);
        }
    }
}

TEST(Diffuse, SamplesFollowTheCosineDensityChiSquare) {
    // A cosine-distributed direction has cos^2(theta) and the azimuth about N independent and
    // uniform: 10 x 8 equal-probability bins, chi-square.
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const DiffuseBsdf m;
    const Vec3 n = normalize(Vec3{-0.5, 0.4, 0.7});
    Vec3 a, b;
    make_orthonormals(n, a, b);
    const auto sp = m.prepare(surface(n, n, n));
    constexpr int kTheta = 10, kPhi = 8;
    const long count = test::scaled(200000);
    std::array<long, kTheta * kPhi> hist{};
    long accepted = 0;
    for (long i = 0; i < count; ++i) {
        const BsdfSample s = m.sample(sp, {uni(rng), uni(rng), uni(rng)});
        ASSERT_NO_FATAL_FAILURE(test::expect_sample_matches_eval(m, sp, s, test::random_unit(rng)));
        if (s.lobe < 0) continue;
        ++accepted;
        const int t = std::min(kTheta - 1, int(sqr(dot(n, s.wi)) * kTheta));
        const double phi = std::atan2(dot(b, s.wi), dot(a, s.wi)) + kPi;
        const int p = std::min(kPhi - 1, int(phi / kTwoPi * kPhi));
        ++hist[size_t(t * kPhi + p)];
        EXPECT_NEAR(s.weight.r, 1.0, 1e-12);  // value / pdf: the albedo is the closure weight
    }
    EXPECT_GT(accepted, count * 99 / 100);
    double chi2 = 0;
    const double expected = double(accepted) / (kTheta * kPhi);
    for (long h : hist) chi2 += sqr(double(h) - expected) / expected;
    EXPECT_LT(chi2, 123.6) << "chi2(0.999, 79 degrees of freedom)";
}

TEST(Diffuse, SamplerRejectsDirectionsBelowTheGeometricNormal) {
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const DiffuseBsdf m;
    const Vec3 n{0, 0, 1}, ng = normalize(Vec3{0.8, 0, 0.6});
    const auto sp = m.prepare(surface(n, ng, n));
    long rejected = 0;
    for (int i = 0; i < 4000; ++i) {
        const BsdfSample s = m.sample(sp, {uni(rng), uni(rng), 0.5});
        if (s.lobe < 0) {
            ++rejected;
            continue;
        }
        EXPECT_GT(dot(ng, s.wi), 0.0);
    }
    EXPECT_GT(rejected, 100);
}

TEST(Diffuse, RendererInterfaceReadsTheModel) {
    const HairModel m{DiffuseBsdf{}};
    const Vec3 n{0, 0, 1};
    const PreparedModel point = prepare_model(m, surface(n, n, n));
    EXPECT_FALSE(model_transmits(m));
    EXPECT_FALSE(model_hair_lobes(m));
    EXPECT_FALSE(model_stochastic_eval(m));
    EXPECT_FALSE(model_transparent(m, point));
    EXPECT_EQ(scatter_label(m, 0), uint8_t(LabelDiffuse | LabelReflect));
    std::optional<HairModel> blurred;
    EXPECT_FALSE(blur_model(m, 0.5, blurred));
    uint32_t state = 0;
    const Vec3 wi = normalize(Vec3{0.3, 0.1, 0.9});
    EXPECT_EQ(eval_at_hit(m, point, wi, state).pdf, dot(n, wi) / kPi);
    const ScatterSample s = sample_at_hit(m, point, {0.3, 0.6, 0.2}, nullptr, state, true);
    EXPECT_EQ(s.lobe, LobeR);
    EXPECT_EQ(s.pdf, dot(n, s.wi) / kPi);
    // In a closure sum with a hair model, the sum's eval adds weight x cos / pi.
    ShadingContext ctx = surface(n, n, n);
    const ClosureSum sum({Closure{RGB(0.5, 0.25, 1.0), DiffuseBsdf{}}});
    EXPECT_DOUBLE_EQ(sum.eval(ctx, wi).value().g, 0.25 * dot(n, wi) / kPi);
}

TEST(Emission, RadianceIsStrengthTimesWeightTimesColor) {
    const Emission e(RGB(0.1, 0.2, 0.4), 3.0);
    const RGB r = e.radiance(RGB(1.0, 0.5, 2.0));
    EXPECT_DOUBLE_EQ(r.r, 0.3);
    EXPECT_DOUBLE_EQ(r.g, 0.3);
    EXPECT_DOUBLE_EQ(r.b, 2.4);
}
