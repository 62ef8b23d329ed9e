// Plugins (hairbsdf/plugin.h, models/plugin_hair.h): loading checks and their messages, the
// adapter's frame handling, sample/pdf consistency, and PluginHair inside a ClosureSum.
// The plugins are built from tests/plugins/test_plugin.cpp (bsdf_core/CMakeLists.txt).
#include <gtest/gtest.h>

#include <string>

#include "hairbsdf/albedo.h"
#include "hairbsdf/closures.h"
#include "hairbsdf/params/principled_hair.h"
#include "test_util.h"

using namespace hairbsdf;

namespace {

std::string plugin_path(const std::string& name) { return std::string(HAIRBSDF_TEST_PLUGIN_DIR) + "/test_plugin_" + name + ".so"; }

std::string load_error(const std::string& path) {
    try {
        load_plugin(path);
    } catch (const PluginError& e) {
        return e.what();
    }
    return "";
}

// The ripple plugin's formula in world space: sin(theta) and delta phi about the tangent.
RGB expected_value(const ShadingContext& ctx, Vec3 wi, RGB albedo, double ripple) {
    const FibreFrame f(ctx.tangent, ctx.wo);
    const double s = f.sin_theta(wi);
    const double dphi = f.phi(wi) - f.phi(ctx.wo);
    return (std::sqrt(1 - s * s) / (kPi * kPi) * (1 + ripple * std::cos(dphi))) * albedo;
}

}  // namespace

TEST(Plugin, LoadsWithSchema) {
    const auto lib = load_plugin(plugin_path("valid"));
    EXPECT_EQ(lib->name(), "test_ripple");
    EXPECT_EQ(lib->abi_version(), HAIRBSDF_PLUGIN_ABI_VERSION);
    EXPECT_TRUE(lib->has_lobes());
    ASSERT_EQ(lib->params().size(), 2u);
    EXPECT_EQ(lib->params()[0].name, "albedo");
    EXPECT_TRUE(lib->params()[0].rgb);
    EXPECT_EQ(lib->params()[1].name, "ripple");
    EXPECT_EQ(lib->params()[1].min_value, -1.0);
    EXPECT_EQ(load_plugin(plugin_path("valid")).get(), lib.get());  // loaded once
    const std::vector<double> v = lib->values();
    EXPECT_EQ(v, (std::vector<double>{0.5, 0.5, 0.5, 0.5, 0.5, 0.5}));  // float defaults fill all 3 slots
}

TEST(Plugin, ErrorsNameWhatIsWrong) {
    const std::string wrong = load_error(plugin_path("wrong_abi"));
    EXPECT_NE(wrong.find("ABI version 999 found, 1 expected"), std::string::npos) << wrong;
    EXPECT_NE(wrong.find("test_plugin_wrong_abi.so"), std::string::npos) << wrong;
    const std::string entry = load_error(plugin_path("no_entry"));
    EXPECT_NE(entry.find("missing symbol 'hairbsdf_plugin_entry'"), std::string::npos) << entry;
    const std::string fn = load_error(plugin_path("null_sample"));
    EXPECT_NE(fn.find("missing function 'sample'"), std::string::npos) << fn;
    EXPECT_NE(load_error("/nonexistent/plugin.so").find("'/nonexistent/plugin.so': no such file"), std::string::npos);
    const std::string not_lib = load_error(std::string(HAIRBSDF_TEST_PLUGIN_DIR) + "/../CMakeFiles/../Makefile.notthere");
    EXPECT_NE(not_lib.find("no such file"), std::string::npos);

    const auto lib = load_plugin(plugin_path("valid"));
    try {
        lib->values({{"ripple", {1.5, 0, 0}}});
        FAIL() << "no error for an out-of-range value";
    } catch (const PluginError& e) {
        EXPECT_NE(std::string(e.what()).find("parameter 'ripple' = 1.5 is out of range; allowed [-1, 1]"),
                  std::string::npos)
            << e.what();
    }
    try {
        lib->values({{"ripples", {0.5, 0, 0}}});
        FAIL() << "no error for an unknown name";
    } catch (const PluginError& e) {
        EXPECT_NE(std::string(e.what()).find("unknown parameter 'ripples'; allowed: albedo, ripple"),
                  std::string::npos)
            << e.what();
    }
    try {
        PluginHair(lib, lib->values({{"ripple", {0.25, 0, 0}}}));
        FAIL() << "create's refusal was not reported";
    } catch (const PluginError& e) {
        EXPECT_NE(std::string(e.what()).find("create failed: ripple 0.25 is refused"), std::string::npos) << e.what();
    }
}

TEST(Plugin, AdapterUsesTheFibreFrameAndSamplesConsistently) {
    const auto lib = load_plugin(plugin_path("valid"));
    const RGB albedo(0.9, 0.5, 0.2);
    const double ripple = -0.7;
    const PluginHair hair(lib, lib->values({{"albedo", {0.9, 0.5, 0.2}}, {"ripple", {ripple, 0, 0}}}));
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (int i = 0; i < 500; ++i) {
        ShadingContext ctx;
        ctx.tangent = test::random_unit(rng);  // world space: the adapter moves into the fibre frame
        ctx.wo = test::random_unit(rng);
        ctx.h = 2 * uni(rng) - 1;
        const Vec3 wi = test::random_unit(rng);
        const auto sp = hair.prepare(ctx);
        const BsdfEval e = hair.eval(sp, wi);
        const RGB want = expected_value(ctx, wi, albedo, ripple);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(e.value()[c], want[c], 1e-12);
            EXPECT_NEAR(e.lobes[LobeTRRT][c], want[c], 1e-12);
        }
        EXPECT_NEAR(e.pdf, hair.pdf(sp, wi), 1e-15);

        const BsdfSample s = hair.sample(sp, {uni(rng), uni(rng), uni(rng)});
        ASSERT_EQ(s.lobe, LobeTRRT);
        EXPECT_NEAR(length(s.wi), 1.0, 1e-12);
        const BsdfEval at = hair.eval(sp, s.wi);
        EXPECT_NEAR(s.pdf, at.pdf, 1e-12 * (1 + at.pdf));
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(s.value[c], at.value()[c], 1e-12 * (1 + at.value()[c]));
            EXPECT_NEAR(s.weight[c], at.value()[c] / at.pdf, 1e-9 * (1 + s.weight[c]));
        }
    }
}

TEST(Plugin, WorksInAClosureSumAndTheAlbedoQuadrature) {
    const auto lib = load_plugin(plugin_path("valid"));
    const PluginHair plugin(lib, lib->values({{"albedo", {0.8, 0.6, 0.4}}}));
    PrincipledHairInputs in;
    in.parametrization = Parametrization::Melanin;
    const ChiangHair chiang(chiang_params_from_principled(in, Accuracy::Exact));
    ShadingContext ctx;
    ctx.wo = test::direction(0.4, 1.0);
    ctx.h = 0.3;
    QuadratureOptions coarse;  // the adapter assumes 0.02 rad lobes; this one is smooth
    coarse.panels_per_scale = 0.25;
    const RGB albedo = directional_albedo(ClosureSum({Closure{RGB(1.0), plugin}}), ctx, coarse);
    EXPECT_NEAR(albedo.r, 0.8, 1e-4);
    EXPECT_NEAR(albedo.b, 0.4, 1e-4);

    const ClosureSum sum({Closure{RGB(0.5), plugin}, Closure{RGB(0.5), chiang}});
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (int i = 0; i < 200; ++i) {
        const Vec3 wi = test::random_unit(rng);
        const BsdfEval e = sum.eval(ctx, wi);
        const double want = 0.5 * plugin.eval(ctx, wi).value().g + 0.5 * chiang.eval(ctx, wi).value().g;
        EXPECT_NEAR(e.value().g, want, 1e-12 * (1 + want));
        EXPECT_NEAR(e.pdf, 0.5 * plugin.pdf(ctx, wi) + 0.5 * chiang.eval(ctx, wi).pdf, 1e-12 * (1 + e.pdf));
        const BsdfSample s = sum.sample(ctx, {uni(rng), uni(rng), uni(rng)});
        if (s.lobe < 0) continue;
        EXPECT_NEAR(s.pdf, sum.pdf(ctx, s.wi), 1e-9 * (1 + s.pdf));
    }
}

#ifdef HAIRBSDF_KAJIYA_KAY_PLUGIN
// The example plugin built by the top-level CMake: in a renderer-style world frame its albedo
// at theta_o = 0 is (1 - w) Kd + w Ks (both lobes are normalised there), and sampling agrees.
TEST(Plugin, KajiyaKayExampleThroughTheAdapter) {
    const auto lib = load_plugin(HAIRBSDF_KAJIYA_KAY_PLUGIN);
    EXPECT_EQ(lib->name(), "kajiya_kay");
    const PluginHair kk(lib, lib->values({{"color", {0.8, 0.5, 0.2}}, {"specular", {0.4, 0, 0}}}));
    ShadingContext ctx;
    ctx.tangent = normalize(Vec3{0.3, -0.2, 0.9});
    ctx.wo = normalize(cross(ctx.tangent, Vec3{1, 0, 0}));  // perpendicular to the fibre: theta_o = 0
    QuadratureOptions coarse;  // the adapter assumes 0.02 rad lobes; these are far wider
    coarse.panels_per_scale = 0.25;
    const RGB albedo = directional_albedo(ClosureSum({Closure{RGB(1.0), kk}}), ctx, coarse);
    EXPECT_NEAR(albedo.r, 0.6 * 0.8 + 0.4, 2e-4);
    EXPECT_NEAR(albedo.b, 0.6 * 0.2 + 0.4, 2e-4);
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (int i = 0; i < 200; ++i) {
        const BsdfSample s = kk.sample(ctx, {uni(rng), uni(rng), uni(rng)});
        ASSERT_TRUE(s.lobe == LobeR || s.lobe == LobeTRRT);
        const BsdfEval e = kk.eval(ctx, s.wi);
        EXPECT_NEAR(s.pdf, e.pdf, 1e-9 * e.pdf);
        EXPECT_NEAR(s.value.g, e.value().g, 1e-9 * e.value().g);
    }
}
#endif
