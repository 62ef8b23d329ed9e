// The world's environment texture: Cycles' equirectangular lookup and the importance sampler
// (render/environment.h).
#include <gtest/gtest.h>

#include <random>

#include "hairbsdf/render/environment.h"
#include "hairbsdf/render/lights.h"
#include "hairbsdf/render/shading_vm.h"

using namespace hairbsdf;
using namespace hairbsdf::render;

namespace {

// A small texture: a dim gradient with one bright texel.
EnvironmentDesc test_texture(int width = 16, int height = 8) {
    EnvironmentDesc d;
    d.width = width;
    d.height = height;
    d.weight = RGB(1.0, 0.5, 2.0);
    d.pixels.resize(size_t(width) * height * 3);
    for (int r = 0; r < height; ++r)
        for (int c = 0; c < width; ++c) {
            float* p = &d.pixels[(size_t(r) * width + c) * 3];
            p[0] = 0.1f + 0.05f * float(c) / float(width);
            p[1] = 0.2f * float(r) / float(height);
            p[2] = 0.05f;
        }
    float* bright = &d.pixels[(size_t(2) * width + 11) * 3];
    bright[0] = bright[1] = bright[2] = 40.0f;
    return d;
}

Vec3 uniform_sphere(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u;
    const double z = 1 - 2 * u(rng), phi = kTwoPi * u(rng), r = std::sqrt(std::max(0.0, 1 - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
}

// The direction at texel (column, row from the top) centre: theta = pi (row + 0.5) / H,
// atan2(y, x) = pi - 2 pi (column + 0.5) / W.
Vec3 texel_centre(int column, int row, int width, int height) {
    const double theta = kPi * (row + 0.5) / height, phi = kPi - kTwoPi * (column + 0.5) / width;
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

}  // namespace

TEST(RenderEnvironment, EquirectangularCoordinatesAsCycles) {
    double u, v;
    EnvironmentMap::equirectangular_uv({1, 0, 0}, u, v);  // +X: the image's centre column, horizon
    EXPECT_NEAR(u, 0.5, 1e-12);
    EXPECT_NEAR(v, 0.5, 1e-12);
    EnvironmentMap::equirectangular_uv({0, 1, 0}, u, v);  // +Y: a quarter to the left
    EXPECT_NEAR(u, 0.25, 1e-12);
    EnvironmentMap::equirectangular_uv({0, 0, 2}, u, v);  // zenith: the top row (v = 1)
    EXPECT_NEAR(v, 1.0, 1e-12);
    EnvironmentMap::equirectangular_uv({0, 0, -1}, u, v);
    EXPECT_NEAR(v, 0.0, 1e-12);
}

TEST(RenderEnvironment, TexelCentresReturnTexelValues) {
    for (bool closest : {false, true}) {
        EnvironmentDesc d = test_texture();
        d.closest = closest;
        const EnvironmentMap map(d);
        for (int r = 0; r < d.height; ++r)
            for (int c = 0; c < d.width; ++c) {
                const RGB got = map.eval(texel_centre(c, r, d.width, d.height));
                const float* p = &d.pixels[(size_t(r) * d.width + c) * 3];
                EXPECT_NEAR(got.r, d.weight.r * p[0], 1e-4 * (1 + p[0])) << r << " " << c;
                EXPECT_NEAR(got.g, d.weight.g * p[1], 1e-4 * (1 + p[1]));
                EXPECT_NEAR(got.b, d.weight.b * p[2], 1e-4 * (1 + p[2]));
            }
    }
}

TEST(RenderEnvironment, BilinearBetweenTexelsAndRepeatsAcrossTheSeam) {
    const EnvironmentDesc d = test_texture();
    const EnvironmentMap map(d);
    // Halfway between columns 3 and 4 of row 5: the mean of the two texels.
    const double theta = kPi * 5.5 / d.height, phi = kPi - kTwoPi * 4.0 / d.width;
    const RGB got = map.eval({std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)});
    const float* a = &d.pixels[(size_t(5) * d.width + 3) * 3];
    const float* b = &d.pixels[(size_t(5) * d.width + 4) * 3];
    EXPECT_NEAR(got.r, 0.5 * (a[0] + b[0]), 1e-6);
    // At u = 0 (the seam, atan2 = pi) the last and first columns blend.
    const double theta2 = kPi * 5.5 / d.height;
    const RGB seam = map.eval({-std::sin(theta2), 0.0, std::cos(theta2)});
    const float* first = &d.pixels[(size_t(5) * d.width + 0) * 3];
    const float* last = &d.pixels[(size_t(5) * d.width + d.width - 1) * 3];
    EXPECT_NEAR(seam.r, 0.5 * (first[0] + last[0]), 1e-6);
}

TEST(RenderEnvironment, RotationMatrixRotatesTheLookup) {
    EnvironmentDesc d = test_texture();
    // Lookup vector = Rz(90 deg) dir: the world direction -Y looks up what +X shows unrotated.
    d.matrix = {0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0};
    const EnvironmentMap rotated(d);
    const EnvironmentMap plain(test_texture());
    const RGB a = rotated.eval({0, -1, 0}), b = plain.eval({1, 0, 0});
    EXPECT_NEAR(a.r, b.r, 1e-12);
    EXPECT_NEAR(a.g, b.g, 1e-12);
}

TEST(RenderEnvironment, PdfIntegratesToOneAndMatchesTheSampler) {
    for (bool rotated : {false, true}) {
        EnvironmentDesc d = test_texture();
        if (rotated) {
            const double c = std::cos(0.7), s = std::sin(0.7);
            d.matrix = {c, 0, s, 0, 0, 1, 0, 0, -s, 0, c, 0};
        }
        const EnvironmentMap map(d);
        std::mt19937_64 rng(5);
        std::uniform_real_distribution<double> u;
        // Integral of the pdf over the sphere (uniform Monte Carlo).
        const int n = 400000;
        double integral = 0;
        for (int i = 0; i < n; ++i) integral += map.pdf(uniform_sphere(rng)) * 4 * kPi;
        EXPECT_NEAR(integral / n, 1.0, 0.02);
        // Importance-sampled and uniform estimates of the radiance integral agree, and the
        // sampler reports pdf(dir).
        double uniform_est = 0, sampled_est = 0;
        for (int i = 0; i < n; ++i) uniform_est += average(map.eval(uniform_sphere(rng))) * 4 * kPi;
        for (int i = 0; i < n; ++i) {
            double pdf = 0;
            const Vec3 dir = map.sample(u(rng), u(rng), pdf);
            ASSERT_GT(pdf, 0);
            ASSERT_NEAR(pdf, map.pdf(dir), 1e-6 * pdf);
            sampled_est += average(map.eval(dir)) / pdf;
        }
        EXPECT_NEAR(sampled_est / uniform_est, 1.0, 0.03);
    }
}

TEST(RenderEnvironment, NonRotationMappingSamplesUniformly) {
    EnvironmentDesc d = test_texture();
    d.matrix = {2, 0, 0, 0.3, 0, 1, 0, 0, 0, 0, 1, 0};  // scale and translation
    const EnvironmentMap map(d);
    EXPECT_NEAR(map.pdf({0, 0, 1}), 1 / (4 * kPi), 1e-15);
}

TEST(RenderEnvironment, WorldLightUsesTheTexture) {
    const EnvironmentDesc d = test_texture();
    const Light world(RGB(0.1), d);
    const EnvironmentMap map(d);
    LightHit hit;
    const Vec3 dir = texel_centre(11, 2, d.width, d.height);
    ASSERT_TRUE(world.eval_direction(dir, hit));
    EXPECT_NEAR(hit.radiance.r, 0.1 + map.eval(dir).r, 1e-9);
    EXPECT_NEAR(hit.pdf, map.pdf(dir), 1e-12);
    LightSample s;
    ASSERT_TRUE(world.sample({0, 0, 0}, 0.5, 0.5, s));
    EXPECT_NEAR(s.pdf, map.pdf(s.wi), 1e-12);
    EXPECT_TRUE(std::isinf(s.distance));
}

// Cycles enables its background light only for a spatially varying world with MIS on: a
// uniform world is not sampled (NEE skips it, BSDF rays get weight 1).
TEST(RenderEnvironment, OnlyATexturedWorldIsSampledAsALight) {
    SceneDesc uniform;
    uniform.world = RGB(0.05);
    const LightSet plain(uniform);
    EXPECT_EQ(plain.size(), 0u);
    ASSERT_NE(plain.world(), nullptr);
    EXPECT_FALSE(plain.world()->use_mis());
    LightHit hit;
    ASSERT_TRUE(plain.world()->eval_direction({0, 0, 1}, hit));
    EXPECT_NEAR(hit.radiance.g, 0.05, 1e-12);

    SceneDesc textured = uniform;
    textured.world_texture = test_texture();
    const LightSet sampled(textured);
    EXPECT_EQ(sampled.size(), 1u);
    ASSERT_NE(sampled.world(), nullptr);
    EXPECT_TRUE(sampled.world()->use_mis());
    EXPECT_EQ(sampled.world(), &sampled.light(0));

    textured.world_mis = false;  // World > Settings > Sampling: None
    const LightSet off(textured);
    EXPECT_EQ(off.size(), 0u);
    ASSERT_NE(off.world(), nullptr);
    EXPECT_FALSE(off.world()->use_mis());

    const LightSet dark{SceneDesc{}};
    EXPECT_EQ(dark.world(), nullptr);
}

TEST(RenderEnvironment, SrgbEncodedTexelsAreDecodedAfterInterpolating) {
    // Two columns, encoded 0.2 and 0.8: halfway between their centres Cycles reads
    // decode(0.5), not the mean of decode(0.2) and decode(0.8).
    EnvironmentDesc d;
    d.width = 2;
    d.height = 1;
    d.weight = RGB(1.0);
    d.pixels = {0.2f, 0.2f, 0.2f, 0.8f, 0.8f, 0.8f};
    d.srgb_encoded = true;
    const EnvironmentMap map(d);
    const Vec3 between = {-1, 0, 0};  // u = 0, the seam: halfway between column 1 and column 0 (wrapped)
    EXPECT_NEAR(map.eval(between).r, srgb_to_linear(0.5f), 1e-6);
    EXPECT_NEAR(map.eval(texel_centre(1, 0, 2, 1)).g, srgb_to_linear(0.8f), 1e-6);
    d.srgb_encoded = false;
    EXPECT_NEAR(EnvironmentMap(d).eval(between).r, 0.5, 1e-6);
}
