// The integrator end to end on tiny scenes with known answers (render/render.h).
#include <gtest/gtest.h>

#include "hairbsdf/render/render.h"

using namespace hairbsdf;
using namespace hairbsdf::render;

namespace {

// A diffuse plane z = 0 (albedo 0.5) seen from above by an orthographic camera.
SceneDesc plane_scene() {
    SceneDesc s;
    s.meshes.vertices = {{-5, -5, 0}, {5, -5, 0}, {5, 5, 0}, {-5, 5, 0}};
    s.meshes.triangles = {{0, 1, 2}, {0, 2, 3}};
    s.meshes.material = {0, 0};
    MaterialDesc m;
    ClosureDesc d;
    d.type = ClosureDesc::Type::Diffuse;
    d.color = RGB(0.5);
    m.closures.push_back(d);
    s.materials.push_back(m);
    s.camera.type = CameraType::Orthographic;
    s.camera.matrix_world = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0, 1};  // at z = 1, looking down
    s.camera.width = 8;
    s.camera.height = 8;
    s.camera.ortho_scale = 2.0;
    s.integrator.samples = 16;
    s.integrator.max_bounces = 4;
    return s;
}

}  // namespace

// Direct light from a delta sun: every pixel is albedo / pi * E cos(theta), exactly.
TEST(RenderIntegrator, DiffusePlaneUnderDeltaSun) {
    SceneDesc s = plane_scene();
    LightDesc sun;
    sun.type = LightType::Sun;
    sun.direction = {0.0, 0.6, 0.8};
    sun.strength = RGB(3.0);
    s.lights.push_back(sun);
    const RenderOutput out = render_scene(s, 2);
    ASSERT_EQ(out.rgba.size(), 8u * 8u * 4u);
    for (size_t i = 0; i < 64; ++i) {
        EXPECT_NEAR(out.rgba[4 * i], 0.5 / kPi * 3.0 * 0.8, 1e-6);
        EXPECT_EQ(out.rgba[4 * i + 3], 1.0f);
    }
    EXPECT_EQ(out.stats.samples, 16);
    EXPECT_EQ(out.stats.nan_count, 0u);
}

// A uniform world of radiance L over a diffuse plane: albedo x L in expectation (NEE of
// the world and BSDF-sampled escapes, combined with MIS).
TEST(RenderIntegrator, DiffusePlaneUnderUniformWorld) {
    SceneDesc s = plane_scene();
    s.world = RGB(2.0);
    s.integrator.samples = 256;
    const RenderOutput out = render_scene(s, 2);
    double mean = 0;
    for (size_t i = 0; i < 64; ++i) mean += out.rgba[4 * i + 1] / 64.0;
    EXPECT_NEAR(mean, 1.0, 0.01);
}

// The image does not depend on the thread count; a transparent film gives alpha = 0 where
// camera rays escape.
TEST(RenderIntegrator, DeterministicAndTransparentFilm) {
    SceneDesc s = plane_scene();
    s.camera.ortho_scale = 20.0;  // the plane covers the middle of the image only
    s.world = RGB(0.5);
    s.integrator.film_transparent = true;
    s.integrator.samples = 4;
    const RenderOutput a = render_scene(s, 1), b = render_scene(s, 2);
    EXPECT_EQ(a.rgba, b.rgba);
    EXPECT_EQ(a.rgba[3], 0.0f);                        // corner: background
    EXPECT_EQ(a.rgba[4 * (4 * 8 + 4) + 3], 1.0f);      // centre: the plane
}

TEST(RenderIntegrator, CancelBeforeRunRendersNothing) {
    SceneDesc s = plane_scene();
    RenderJob job(s, 1);
    job.cancel();
    job.run();
    const RenderOutput out = job.output();
    EXPECT_TRUE(out.stats.cancelled);
    EXPECT_EQ(out.stats.samples, 0);
}
