// Cycles' legacy Hair BSDF (models/cycles_hair.h): closed-form albedos, the sampler against its
// own exact density and against eval where Cycles makes them agree, fuzzing.
#include <gtest/gtest.h>

#include "hairbsdf/albedo.h"
#include "hairbsdf/closures.h"
#include "test_util.h"

using namespace hairbsdf;

namespace {
CyclesHair cycles_hair(CyclesHairComponent component, double r1, double r2, double offset = 0.0, RGB color = RGB(1.0)) {
    CyclesHairParams p;
    p.component = component;
    p.color = color;
    p.offset = offset;
    p.roughness_u = r1;
    p.roughness_v = r2;
    return CyclesHair(p);
}
constexpr auto kR = CyclesHairComponent::Reflection;
constexpr auto kT = CyclesHairComponent::Transmission;

// Integral of f(wi) over the sphere by the midpoint rule in (theta, phi), d omega = cos theta
// d theta d phi (the densities have a 1 / cos theta pole at the axis: smooth in theta, not in sin theta).
template <class F>
double sphere_integral(F f, int n_theta = 1200, int n_phi = 1200) {
    double sum = 0;
    for (int i = 0; i < n_theta; ++i) {
        const double theta = -0.5 * kPi + (i + 0.5) * kPi / n_theta;
        for (int j = 0; j < n_phi; ++j) {
            const double phi = -kPi + (j + 0.5) * kTwoPi / n_phi;
            sum += f(test::direction(theta, phi)) * std::cos(theta);
        }
    }
    return sum * (kPi / n_theta) * (kTwoPi / n_phi);
}
}  // namespace

TEST(CyclesHair, DefaultsAreTheBlenderNode) {
    const CyclesHairParams p;
    EXPECT_EQ(p.component, kR);
    EXPECT_EQ(p.color.r, 0.8);
    EXPECT_EQ(p.offset, 0.0);
    EXPECT_EQ(p.roughness_u, 0.1);
    EXPECT_EQ(p.roughness_v, 1.0);
    // Cycles' setup clamps both roughnesses to [0.001, 1].
    const CyclesHair m = cycles_hair(kR, 0.0, 7.0);
    EXPECT_EQ(m.r1(), 0.001);
    EXPECT_EQ(m.r2(), 1.0);
}

// At h = 0 the shading normal is the viewer's perpendicular direction, so the N test and the
// reflection's cos(phi) >= 0 test coincide. Albedos in closed form (white colour):
//   reflection, r2 = 1:   int_{-pi/2}^{pi/2} cos(phi/2)/4 dphi = sin(pi/4) = 0.7071;
//   reflection, r2 <= 1/2: the bump |phi| <= pi r2 lies inside |phi| <= pi/2: 1;
//   transmission, any r2: the Cauchy lives on |phi| >= pi/2, the far half: 1.
// The longitudinal Cauchy integrates to 1 minus what lies within 0.001 rad of the axis.
TEST(CyclesHair, AlbedoAtNormalIncidenceHasClosedForm) {
    struct Case {
        CyclesHairComponent c;
        double r1, r2, offset, expected;
    };
    for (const Case k : {Case{kR, 0.1, 1.0, 0.0, std::sin(0.25 * kPi)}, Case{kR, 0.3, 0.5, 0.2, 1.0},
                         Case{kR, 0.05, 0.2, -0.1, 1.0}, Case{kT, 0.1, 1.0, 0.0, 1.0}, Case{kT, 0.6, 0.05, 0.3, 1.0}}) {
        const ClosureSum c({Closure{RGB(1.0), cycles_hair(k.c, k.r1, k.r2, k.offset)}});
        for (double theta_o : {0.0, 0.4, -1.1}) {
            ShadingContext ctx;
            ctx.wo = test::direction(theta_o, -0.5 * kPi);
            QuadratureOptions q;
            q.panels_per_scale = 4;
            EXPECT_NEAR(directional_albedo(c, ctx, q).r, k.expected, 3e-3) << k.r1 << " " << k.r2 << " " << theta_o;
        }
    }
}

// Furnace: eval's albedo <= 1.01 for views, h and the roughness / offset extremes (white colour).
// The quadrature resolves one narrow direction at a time (r1 = 0.001 with r2 = 1, r2 = 0.01 with
// r1 >= 0.1); both narrow together, and r2 = 0.001, are covered by
// EvalIsBoundedByTheNormalisedSamplerDensity.
TEST(CyclesHair, FurnaceBound) {
    for (auto comp : {kR, kT}) {
        for (auto [r1, r2] : {std::pair{0.001, 1.0}, {0.1, 0.01}, {1.0, 0.01}, {0.1, 1.0}, {1.0, 1.0}}) {
            {
                for (double offset : {-0.5 * kPi, 0.0, 0.5 * kPi}) {
                    const ClosureSum c({Closure{RGB(1.0), cycles_hair(comp, r1, r2, offset)}});
                    for (double theta_o : {0.8, -1.5}) {
                        for (double h : {0.0, -1.0}) {
                            ShadingContext ctx;
                            ctx.wo = test::direction(theta_o, 0.3);
                            ctx.h = h;
                            QuadratureOptions q;
                            q.max_nodes = r2 < 0.1 ? 1'000'000 : 100'000;
                            EXPECT_LE(directional_albedo(c, ctx, q).r, 1.01) << r1 << " " << r2 << " " << offset;
                        }
                    }
                }
            }
        }
    }
}

// Reflection: eval's density is the sampler's density restricted to eval's support, so with the
// normalisation below its albedo is <= 1 at any roughness, the 0.001 clamp included. Transmission
// at h = 0 likewise (its support is then exactly the sampler's half, |phi| >= pi/2).
TEST(CyclesHair, EvalIsBoundedByTheNormalisedSamplerDensity) {
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (double r : {0.0, 0.001, 0.02, 0.4, 1.0}) {
        // Where the stretched azimuth is clamped to pi eval keeps cos(pi/2) ~ 6e-17 of its scale.
        const double tiny = 1e-14 / sqr(std::max(r, 0.001));
        for (int i = 0; i < 4000; ++i) {
            const CyclesHair refl = cycles_hair(kR, r, r, 0.3 * (uni(rng) - 0.5));
            const CyclesHair trans = cycles_hair(kT, r, r, 0.3 * (uni(rng) - 0.5));
            ShadingContext ctx;
            ctx.wo = test::random_unit(rng);
            ctx.h = 2 * uni(rng) - 1;
            const Vec3 wi = i % 2 ? test::random_unit(rng) : -1.0 * ctx.wo + 0.01 * test::random_unit(rng);
            const auto sp = refl.prepare(ctx);
            ASSERT_LE(refl.eval(sp, wi).pdf, refl.sampler_density(sp, wi) * (1 + 1e-12) + tiny);
            ctx.h = 0;
            const auto st = trans.prepare(ctx);
            ASSERT_LE(trans.eval(st, wi).pdf, trans.sampler_density(st, wi) * (1 + 1e-12) + tiny);
        }
        for (auto comp : {kR, kT}) {
            const CyclesHair m = cycles_hair(comp, std::max(r, 0.05), std::max(r, 0.05));
            ShadingContext ctx;
            ctx.wo = test::direction(0.4, 1.0);
            const auto sp = m.prepare(ctx);
            EXPECT_NEAR(sphere_integral([&](Vec3 wi) { return m.sampler_density(sp, wi); }, 1500, 3000), 1.0, 2e-3);
        }
    }
}

// The sampler's exact density integrates to 1, and the pdf Cycles reports equals it except
// for the reflection sampler with r2 != 1 (Cycles evaluates cos(phi / 2), not cos(phi / 2 r2)).
TEST(CyclesHair, SamplerDensityIsNormalisedAndMatchesTheReportedPdfWhereCyclesAgrees) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (auto comp : {kR, kT}) {
        for (auto [r1, r2] : {std::pair{0.3, 1.0}, {0.2, 0.6}, {0.5, 0.25}}) {
            const CyclesHair m = cycles_hair(comp, r1, r2, 0.05);
            ShadingContext ctx;
            ctx.wo = test::direction(0.3, 0.7);
            ctx.h = 0.4;
            const auto sp = m.prepare(ctx);
            EXPECT_NEAR(sphere_integral([&](Vec3 wi) { return m.sampler_density(sp, wi); }), 1.0, 2e-3)
                << int(comp) << " " << r1 << " " << r2;
            const bool agrees = comp == kT || r2 == 1.0;
            int disagreements = 0;
            for (int i = 0; i < 2000; ++i) {
                const BsdfSample s = m.sample(sp, {uni(rng), uni(rng), uni(rng)});
                if (s.lobe < 0) continue;
                const double exact = m.sampler_density(sp, s.wi);
                if (test::relative_error(s.pdf, exact) > 1e-9) ++disagreements;
                for (int c = 0; c < 3; ++c) ASSERT_DOUBLE_EQ(s.weight[c], 1.0);  // eval / pdf = colour
            }
            if (agrees) {
                EXPECT_EQ(disagreements, 0);
            } else {
                EXPECT_GT(disagreements, 1000);
            }
        }
    }
}

// Where eval has value and Cycles' reported density is exact, eval's pdf is the sample's pdf and
// eval / pdf is the colour.
TEST(CyclesHair, SampleMatchesEvalInsideEvalsSupport) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const RGB color{0.2, 0.5, 0.9};
    for (auto comp : {kR, kT}) {
        const CyclesHair m = cycles_hair(comp, 0.15, comp == kR ? 1.0 : 0.4, -0.1, color);
        int inside = 0;
        for (int i = 0; i < test::scaled(20000); ++i) {
            ShadingContext ctx;
            ctx.wo = test::random_unit(rng);
            ctx.h = 2 * uni(rng) - 1;
            const auto sp = m.prepare(ctx);
            const BsdfSample s = m.sample(sp, {uni(rng), uni(rng), uni(rng)});
            ASSERT_TRUE(isfinite(s.weight) && std::isfinite(s.pdf));
            if (s.lobe < 0) continue;
            const BsdfEval e = m.eval(sp, s.wi);
            if (!(e.pdf > 0)) continue;
            ++inside;
            ASSERT_LT(test::relative_error(e.pdf, s.pdf), 1e-9);
            for (int c = 0; c < 3; ++c) {
                ASSERT_NEAR(e.value()[c] / e.pdf, color[c], 1e-12);
                ASSERT_NEAR(s.weight[c], color[c], 1e-12);
            }
        }
        EXPECT_GT(inside, test::scaled(20000) / 4);
    }
}

TEST(CyclesHair, ReflectionAndTransmissionSplitAtTheShadingNormal) {
    const CyclesHair refl = cycles_hair(kR, 0.3, 1.0);
    const CyclesHair trans = cycles_hair(kT, 0.3, 1.0);
    ShadingContext ctx;
    ctx.wo = test::direction(0.0, -0.5 * kPi);  // the viewer at phi = -pi/2 of the fibre frame
    ctx.h = 0.6;                                 // N = -0.6 y - 0.8 z
    const Vec3 n{0, -0.6, -0.8};
    for (double phi = -kPi; phi < kPi; phi += 0.05) {
        const Vec3 wi = test::direction(0.1, phi);
        const double r = refl.eval(ctx, wi).pdf, t = trans.eval(ctx, wi).pdf;
        if (dot(n, wi) < 0) {
            EXPECT_EQ(r, 0.0) << phi;
        } else {
            EXPECT_EQ(t, 0.0) << phi;
        }
        // The reflection bump also needs cos phi >= 0 about the viewer (wi . (-z) >= 0).
        if (wi.z > 1e-12) {
            EXPECT_EQ(r, 0.0) << phi;
        }
    }
}

TEST(CyclesHair, FuzzNothingIsNaN) {
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const Vec3 special[] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1e-300, 0}};
    for (auto comp : {kR, kT}) {
        for (double r : {0.0, 0.001, 0.5, 1.0, 3.0}) {
            for (double offset : {-0.5 * kPi, 0.0, 0.5 * kPi}) {
                const CyclesHair m = cycles_hair(comp, r, 1.0 - 0.5 * r, offset);
                for (int i = 0; i < test::scaled(3000); ++i) {
                    ShadingContext ctx;
                    ctx.wo = i < 25 ? special[i / 5] : test::random_unit(rng);
                    ctx.h = i % 11 == 0 ? 1.0 : 2 * uni(rng) - 1;
                    const Vec3 wi = i < 25 ? special[i % 5] : test::random_unit(rng);
                    const auto sp = m.prepare(ctx);
                    const BsdfEval e = m.eval(sp, wi);
                    ASSERT_TRUE(isfinite(e.value()) && std::isfinite(e.pdf) && e.pdf >= 0);
                    const double u0 = i % 3 == 0 ? 0.0 : (i % 3 == 1 ? 1.0 : uni(rng));
                    const BsdfSample s = m.sample(sp, {u0, i % 2 ? 1.0 : uni(rng), uni(rng)});
                    ASSERT_TRUE(isfinite(s.weight) && std::isfinite(s.pdf) && isfinite(s.wi) && s.pdf >= 0);
                    ASSERT_TRUE(std::isfinite(m.sampler_density(sp, wi)));
                }
            }
        }
    }
}
