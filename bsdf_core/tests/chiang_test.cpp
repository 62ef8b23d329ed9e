// Chiang hair (models/chiang.h) with Blender's parameter mapping (params/principled_hair.h).
#include <gtest/gtest.h>

#include "hairbsdf/albedo.h"
#include "hairbsdf/params/principled_hair.h"
#include "test_util.h"

using namespace hairbsdf;

namespace {

PrincipledHairInputs white_hair(double roughness, double radial_roughness, double offset) {
    PrincipledHairInputs in;
    in.parametrization = Parametrization::Absorption;
    in.absorption_coefficient = RGB(0.0);
    in.roughness = roughness;
    in.radial_roughness = radial_roughness;
    in.offset = offset;
    return in;
}

ClosureSum single(const ChiangHairParams& p) { return ClosureSum({Closure{RGB(1.0), ChiangHair(p)}}); }

// Melanin hair with random roughnesses, offset and (every third row) coat; row i picks the accuracy and the
// tilt convention, so that consecutive rows cover all four.
ChiangHairParams random_chiang_params(std::mt19937_64& rng, long i) {
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    PrincipledHairInputs in;
    in.parametrization = Parametrization::Melanin;
    in.melanin = uni(rng);
    in.roughness = 0.05 + 0.95 * uni(rng);
    in.radial_roughness = 0.05 + 0.95 * uni(rng);
    in.coat = i % 3 == 0 ? uni(rng) : 0.0;
    in.offset = 0.1 * (uni(rng) - 0.5);
    const Accuracy acc = i % 2 ? Accuracy::Exact : Accuracy::Cycles;
    const TiltConvention tilt = i % 4 < 2 ? TiltConvention::Blender42 : TiltConvention::Blender34;
    return chiang_params_from_principled(in, acc, tilt);
}

ShadingContext fibre_context(Vec3 wo, double h) {
    ShadingContext ctx;
    ctx.wo = wo;
    ctx.h = h;
    return ctx;
}

}  // namespace

TEST(PrincipledHairMapping, RoughnessPolynomials) {
    EXPECT_NEAR(longitudinal_variance(0.3), 0.084611, 1e-6);
    EXPECT_NEAR(azimuthal_scale(0.3), 0.11716, 1e-5);
    EXPECT_NEAR(longitudinal_variance(1.0), 27.44, 0.005);
    EXPECT_NEAR(azimuthal_scale(1.0), 4.281, 0.001);
    EXPECT_NEAR(longitudinal_variance(0.1), 0.0065157, 1e-7);
    EXPECT_NEAR(longitudinal_variance(0.5), 0.32036, 1e-5);
    EXPECT_NEAR(longitudinal_variance(0.001), 5.3e-7, 0.05e-7);
}

TEST(PrincipledHairMapping, AbsorptionFromColorAndMelanin) {
    EXPECT_NEAR(albedo_roughness_scale(0.3), 5.8884, 1e-4);
    const RGB def = absorption_from_color(RGB(0.017513, 0.005763, 0.002059), 0.3);
    EXPECT_NEAR(def.r, 0.4718, 1e-4);
    EXPECT_NEAR(def.g, 0.7668, 1e-4);
    EXPECT_NEAR(def.b, 1.1035, 1e-4);
    const RGB c = absorption_from_color(RGB(0.5, 0.3, 0.1), 0.3);
    EXPECT_NEAR(c.r, 0.013857, 1e-6);
    EXPECT_NEAR(c.g, 0.041806, 1e-6);
    EXPECT_NEAR(c.b, 0.152910, 1e-6);
    // Melanin 0.8, all pheomelanin, white tint: quantity -ln(0.2) = 1.6094.
    const RGB m = absorption_from_melanin(0.8, 1.0, RGB(1.0), 0.3);
    EXPECT_NEAR(m.r, 1.6094379 * 0.343, 1e-6);
    EXPECT_NEAR(m.b, 1.6094379 * 1.924, 1e-6);
    EXPECT_TRUE(std::isinf(absorption_from_color(RGB(0.0, 0.5, 0.5), 0.3).r));
}

TEST(PrincipledHairMapping, CoatAndClamps) {
    PrincipledHairInputs in;
    in.roughness = 0.4;
    in.coat = 0.5;
    ChiangHairParams p = chiang_params_from_principled(in);
    EXPECT_NEAR(p.v[0], longitudinal_variance(0.2), 1e-15);      // coat scales the R roughness
    EXPECT_NEAR(p.v_sample[0], longitudinal_variance(0.4), 1e-15);  // the sampler keeps it (Cycles)
    EXPECT_NEAR(p.v[1], 0.25 * longitudinal_variance(0.4), 1e-15);
    in.roughness = 3.0;
    in.radial_roughness = -1.0;
    in.coat = 2.0;
    p = chiang_params_from_principled(in);
    EXPECT_DOUBLE_EQ(p.v[1], 0.25 * longitudinal_variance(1.0));
    EXPECT_DOUBLE_EQ(p.v[0], longitudinal_variance(0.001));
    EXPECT_DOUBLE_EQ(p.s[0], azimuthal_scale(0.001));
}

// With sigma_a = 0 the exact model conserves energy for every fixed h and theta_o,
// with a cuticle tilt: the albedo by deterministic quadrature is 1 +- 1e-3.
TEST(ChiangHair, WhiteFurnaceByQuadratureIsOne) {
    const bool small = test::scale() < 1.0;
    std::vector<double> betas = small ? std::vector<double>{0.2, 1.0} : std::vector<double>{0.2, 0.3, 0.5, 0.7, 1.0};
    for (double beta_m : betas) {
        for (double beta_n : {0.3, 0.8}) {
            for (double offset : {0.05, -0.07}) {
                const ClosureSum bsdf = single(chiang_params_from_principled(white_hair(beta_m, beta_n, offset),
                                                                             Accuracy::Exact));
                for (double h : {-0.9, 0.0, 0.7}) {
                    for (double theta_o_deg : {-60.0, 0.0, 30.0, 80.0}) {
                        const Vec3 wo = test::direction(theta_o_deg * kPi / 180, 0.3);
                        const RGB a = directional_albedo(bsdf, fibre_context(wo, h));
                        EXPECT_NEAR(a.r, 1.0, 1e-3) << beta_m << " " << beta_n << " " << offset << " " << h << " "
                                                    << theta_o_deg;
                        EXPECT_DOUBLE_EQ(a.r, a.b);
                    }
                }
            }
        }
    }
}

// The value, pdf and weight a sample reports agree with eval() and pdf() at its direction.
TEST(ChiangHair, SampleIsConsistentWithEvalAndPdf) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const long n = test::scaled(20000);
    int checked = 0;
    for (long i = 0; i < n; ++i) {
        const ClosureSum bsdf = single(random_chiang_params(rng, i));
        const ShadingContext ctx = fibre_context(test::random_unit(rng), 2 * uni(rng) - 1);
        const BsdfSample s = bsdf.sample(ctx, {uni(rng), uni(rng), uni(rng)});
        if (s.lobe < 0) continue;
        ++checked;
        EXPECT_NEAR(length(s.wi), 1.0, 1e-12);
        const BsdfEval e = bsdf.eval(ctx, s.wi);
        EXPECT_LT(test::relative_error(e.pdf, s.pdf), 1e-9);
        for (int c = 0; c < 3; ++c) {
            EXPECT_LT(test::relative_error(e.value()[c], s.value[c], 1e-300), 1e-9);
            EXPECT_LT(test::relative_error(s.weight[c] * s.pdf, s.value[c], 1e-300), 1e-12);
        }
    }
    EXPECT_GT(checked, n * 9 / 10);
}

// f(h, wo, wi) = f(-h, M wo, M wi) with M the mirror z -> -z (phi -> -phi).
TEST(ChiangHair, MirrorSymmetry) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (long i = 0; i < test::scaled(20000); ++i) {
        PrincipledHairInputs in;
        in.parametrization = Parametrization::Color;
        in.color = RGB(uni(rng), uni(rng), uni(rng));
        in.roughness = 0.05 + 0.95 * uni(rng);
        in.radial_roughness = 0.05 + 0.95 * uni(rng);
        in.offset = 0.1 * (uni(rng) - 0.5);
        const ClosureSum bsdf = single(chiang_params_from_principled(
            in, i % 2 ? Accuracy::Exact : Accuracy::Cycles,
            i % 4 < 2 ? TiltConvention::Blender42 : TiltConvention::Blender34));
        const Vec3 wo = test::random_unit(rng), wi = test::random_unit(rng);
        const double h = 2 * uni(rng) - 1;
        const Vec3 mwo{wo.x, wo.y, -wo.z}, mwi{wi.x, wi.y, -wi.z};
        const BsdfEval a = bsdf.eval(fibre_context(wo, h), wi);
        const BsdfEval b = bsdf.eval(fibre_context(mwo, -h), mwi);
        for (int c = 0; c < 3; ++c) EXPECT_LT(test::relative_error(a.value()[c], b.value()[c]), 1e-9);
        EXPECT_LT(test::relative_error(a.pdf, b.pdf), 1e-9);
    }
}

// Random and degenerate inputs never give NaN, Inf or negative values, nor crash.
TEST(ChiangHair, FuzzNoNanNoInf) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    auto pick = [&](std::initializer_list<double> special, double lo, double hi) {
        const double r = uni(rng);
        if (r < 0.3) return *(special.begin() + size_t(uni(rng) * special.size()) % special.size());
        return lo + (hi - lo) * uni(rng);
    };
    const double one_minus = 1.0 - 0x1p-24;
    const long n = test::scaled(1000000);
    const long per_closure = 50;
    for (long i = 0; i < n / per_closure; ++i) {
        PrincipledHairInputs in;
        in.parametrization = Parametrization(i % 3);
        in.color = RGB(pick({0.0, 1.0}, 0, 1), pick({0.0, 1.0}, 0, 1), pick({0.0}, 0, 1));
        in.melanin = pick({0.0, 1.0, 2.0}, 0, 1);
        in.melanin_redness = pick({0.0, 1.0}, 0, 1);
        in.absorption_coefficient = RGB(pick({0.0, 1e4}, 0, 50), pick({0.0, 1e4}, 0, 50), pick({1e4}, 0, 50));
        in.roughness = pick({0.0, 1e-4, 1.0, 1.5, -1.0}, 0, 1);
        in.radial_roughness = pick({0.0, 1e-4, 1.0, 1.5}, 0, 1);
        in.coat = pick({0.0, 1.0}, 0, 1);
        in.ior = pick({0.0, 0.5, 0.8, 1.0, 1000.0}, 1, 3);
        in.offset = pick({0.0, 0.1745, -0.1745, 1.5707}, -0.2, 0.2);
        in.random_color = pick({1.0}, 0, 1);
        in.random_roughness = pick({1.0, 5.0}, 0, 1);
        in.random = pick({0.0, 1.0}, 0, 1);
        const ClosureSum bsdf = single(chiang_params_from_principled(
            in, i % 2 ? Accuracy::Exact : Accuracy::Cycles,
            i % 4 < 2 ? TiltConvention::Blender42 : TiltConvention::Blender34));
        for (long k = 0; k < per_closure; ++k) {
            Vec3 wo = test::random_unit(rng), wi = test::random_unit(rng);
            const double r = uni(rng);
            if (r < 0.05) {
                wo = {1, 0, 0};
            } else if (r < 0.1) {
                wo = {-1, 0, 0};
            } else if (r < 0.15) {
                wi = wo;
            } else if (r < 0.2) {
                wi = -1.0 * wo;
            } else if (r < 0.25) {
                wi = {1, 0, 0};
            }
            const double h = pick({-1.0, 1.0, 0.0}, -1, 1);
            const ShadingContext ctx = fibre_context(wo, h);
            const BsdfEval e = bsdf.eval(ctx, wi);
            const RGB v = e.value();
            ASSERT_TRUE(isfinite(v) && std::isfinite(e.pdf));
            ASSERT_TRUE(v.r >= 0 && v.g >= 0 && v.b >= 0 && e.pdf >= 0);
            const std::array<double, 3> u{pick({0.0, one_minus, 1.0}, 0, 1), pick({0.0, one_minus, 1.0}, 0, 1),
                                          pick({0.0, one_minus, 1.0}, 0, 1)};
            const BsdfSample s = bsdf.sample(ctx, u);
            ASSERT_TRUE(isfinite(s.weight) && std::isfinite(s.pdf) && isfinite(s.wi))
                << "closure " << i << " wo " << wo.x << "," << wo.y << "," << wo.z << " h " << h;
            ASSERT_TRUE(s.weight.r >= 0 && s.weight.g >= 0 && s.weight.b >= 0 && s.pdf >= 0);
            if (s.lobe >= 0) {
                ASSERT_NEAR(length(s.wi), 1.0, 1e-9);
            }
        }
    }
}

// Cycles < 3.6's per-hit LCG (sample/lcg.h: state = 1103515245 state + 12345; lcg_init steps once,
// each float is state / 0xFFFFFFFF): the first numbers for seed 0, and the shift that a bounce's
// rng_offset of 16 puts between successive hits of one path (16 a^2 and 16 a^3 mod 2^32).
TEST(ChiangHair, CyclesLcgLongitudinalNumbers) {
    const LongitudinalNumbers first = LongitudinalNumbers::from_cycles_lcg(0);
    EXPECT_NEAR(first.theta, 3554416254.0 / 4294967295.0, 1e-15);
    EXPECT_NEAR(first.azimuth, 2802067423.0 / 4294967295.0, 1e-15);
    auto frac = [](double x) { return x - std::floor(x); };
    for (uint32_t seed : {0u, 7u, 123456789u, 4294967290u}) {
        const LongitudinalNumbers a = LongitudinalNumbers::from_cycles_lcg(seed);
        const LongitudinalNumbers b = LongitudinalNumbers::from_cycles_lcg(seed + 16u);
        EXPECT_NEAR(frac(b.theta - a.theta + 1.0), 0.1646980382502079, 1e-8) << seed;
        EXPECT_NEAR(frac(b.azimuth - a.azimuth + 1.0), 0.030697543174028397, 1e-8) << seed;
    }
}

// With given longitudinal numbers the sampler uses them for theta_i and the cone azimuth: the
// sample equals the one whose u2 rescales to that theta number and whose u1 is the azimuth.
TEST(ChiangHair, SampleTakesGivenLongitudinalNumbers) {
    PrincipledHairInputs in;
    in.parametrization = Parametrization::Melanin;
    const ChiangHair hair(chiang_params_from_principled(in, Accuracy::Cycles, TiltConvention::Blender34));
    const auto sp = hair.prepare(fibre_context(normalize(Vec3{0.3, 0.4, 0.8}), 0.2));
    const double u2 = 0.05;  // inside the R lobe's share (R is picked first)
    const double share = sp.view.lobe_weight[0];
    ASSERT_GT(share, u2);
    const LongitudinalNumbers given{u2 / share, 0.7};
    const BsdfSample with = hair.sample(sp, {0.3, 0.1, u2}, &given);
    const BsdfSample plain = hair.sample(sp, {0.3, 0.7, u2});
    ASSERT_EQ(with.lobe, 0);
    EXPECT_NEAR(length(with.wi - plain.wi), 0.0, 1e-12);
    const BsdfSample other = hair.sample(sp, {0.3, 0.1, u2}, nullptr);
    EXPECT_GT(length(other.wi - plain.wi), 1e-6);
}

// Accuracy::Cycles' scalar path computes its transcendentals to float accuracy (math.h); the
// double reference (set_cycles_float_maths(false)) gives the same values to 1e-6 relative of the
// row set's scale, and not bit for bit (the switch takes effect). Accuracy::Exact ignores it.
TEST(ChiangHair, FloatAccuracyMathsMatchTheDoubleReference) {
    PrincipledHairInputs in;
    in.parametrization = Parametrization::Melanin;
    in.offset = 0.05;
    const ChiangHair cycles(chiang_params_from_principled(in, Accuracy::Cycles));
    const ChiangHair exact(chiang_params_from_principled(in, Accuracy::Exact));
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    struct Row {
        ShadingContext ctx;
        Vec3 wi;
        std::array<double, 3> u;
    };
    std::vector<Row> rows;
    for (int i = 0; i < 4000; ++i) {
        Row r;
        r.ctx = fibre_context(normalize(Vec3{uni(rng), uni(rng), uni(rng)}), uni(rng));
        r.wi = normalize(Vec3{uni(rng), uni(rng), uni(rng)});
        r.u = {0.5 + 0.5 * uni(rng), 0.5 + 0.5 * uni(rng), 0.5 + 0.5 * uni(rng)};
        rows.push_back(r);
    }
    auto run = [&](const ChiangHair& hair) {
        std::vector<double> out;
        for (const Row& r : rows) {
            const BsdfEval e = hair.eval(r.ctx, r.wi);
            const BsdfSample s = hair.sample(r.ctx, r.u);
            out.insert(out.end(), {e.pdf, e.value().r, e.value().g, e.value().b, s.pdf, s.wi.x, s.wi.y, s.wi.z});
        }
        return out;
    };
    const std::vector<double> fast = run(cycles), fast_exact = run(exact);
    set_cycles_float_maths(false);
    const std::vector<double> reference = run(cycles), reference_exact = run(exact);
    set_cycles_float_maths(true);
    double scale = 0, worst = 0;
    bool differs = false;
    for (double v : reference) scale = std::max(scale, std::fabs(v));
    for (size_t i = 0; i < fast.size(); ++i) {
        ASSERT_TRUE(std::isfinite(fast[i])) << i;
        const double tolerance = 1e-6 * std::max(std::fabs(reference[i]), 1e-3 * scale);
        worst = std::max(worst, std::fabs(fast[i] - reference[i]) / tolerance);
        differs = differs || fast[i] != reference[i];
    }
    EXPECT_LE(worst, 1.0);
    EXPECT_TRUE(differs);
    EXPECT_EQ(fast_exact, reference_exact);
}

// The scalar path's AVX2 + FMA build (scalar_avx2, src/models/chiang_avx2.cpp) gives the baseline
// build's values to FMA rounding: eval's lobes and pdf, sample's direction, value, pdf and lobe, over both
// accuracies, both tilt conventions, coat and the given longitudinal numbers; and the switch takes effect
// (not bit for bit) where the CPU has AVX2 and FMA.
TEST(ChiangHair, ScalarAvx2BuildMatchesTheBaseline) {
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    struct Row {
        ChiangHair hair;
        ShadingContext ctx;
        Vec3 wi;
        std::array<double, 3> u;
        bool lcg;
    };
    std::vector<Row> rows;
    for (int i = 0; i < 4000; ++i) {
        rows.push_back(Row{ChiangHair(random_chiang_params(rng, i)),
                           fibre_context(test::random_unit(rng), 2 * uni(rng) - 1), test::random_unit(rng),
                           {uni(rng), uni(rng), uni(rng)}, i % 5 == 0});
    }
    auto run = [&]() {
        std::vector<double> out;
        for (const Row& r : rows) {
            const ChiangHair::ShadingPoint sp = r.hair.prepare(r.ctx);
            const BsdfEval e = r.hair.eval(sp, r.wi);
            const LongitudinalNumbers numbers = LongitudinalNumbers::from_cycles_lcg(uint32_t(r.u[0] * 1e9));
            const BsdfSample s = r.hair.sample(sp, r.u, r.lcg ? &numbers : nullptr);
            out.push_back(double(s.lobe));
            out.insert(out.end(), {e.pdf, s.pdf, s.wi.x, s.wi.y, s.wi.z, s.value.r, s.value.g, s.value.b});
            for (int p = 0; p < kChiangLobeCount; ++p)
                out.insert(out.end(), {e.lobes[p].r, e.lobes[p].g, e.lobes[p].b});
        }
        return out;
    };
    const bool avx2 = set_scalar_avx2(true);
    const std::vector<double> dispatched = run();
    EXPECT_FALSE(set_scalar_avx2(false));
    const std::vector<double> baseline = run();
    set_scalar_avx2(true);
    const size_t per_row = dispatched.size() / rows.size();
    double scale = 0, worst = 0;
    int other_lobe = 0;
    bool differs = false;
    for (double v : baseline) scale = std::max(scale, std::fabs(v));
    for (size_t row = 0; row < rows.size(); ++row) {
        const size_t at = row * per_row;
        if (dispatched[at] != baseline[at]) {  // a lobe choice at a weight's boundary, flipped by rounding
            ++other_lobe;
            continue;
        }
        for (size_t i = at + 1; i < at + per_row; ++i) {
            ASSERT_TRUE(std::isfinite(dispatched[i])) << i;
            const double tolerance = 1e-9 * std::max(std::fabs(baseline[i]), 1e-6 * scale);
            worst = std::max(worst, std::fabs(dispatched[i] - baseline[i]) / tolerance);
            differs = differs || dispatched[i] != baseline[i];
        }
    }
    EXPECT_LE(worst, 1.0);
    EXPECT_LE(other_lobe, 2);
    EXPECT_EQ(differs, avx2);
}
