// repair_scene's fallbacks (render/scene.h): a bad camera or integrator setting takes the struct's own default.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "hairbsdf/render/scene.h"

using namespace hairbsdf::render;

namespace {

bool has_warning(const std::vector<std::string>& warnings, const std::string& text) {
    for (const std::string& w : warnings)
        if (w.find(text) != std::string::npos) return true;
    return false;
}

}  // namespace

TEST(RenderRepair, BadCameraSettingsTakeCameraDescDefaults) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    SceneDesc s;
    s.camera.matrix_world[5] = nan;
    s.camera.pixel_aspect = -1;
    s.camera.sensor_width = 0;
    s.camera.sensor_height = nan;
    s.camera.lens = -50;
    s.camera.ortho_scale = std::numeric_limits<double>::infinity();
    const std::vector<std::string> warnings = repair_scene(s);
    const CameraDesc defaults{};
    EXPECT_EQ(s.camera.matrix_world, defaults.matrix_world);
    EXPECT_EQ(s.camera.pixel_aspect, defaults.pixel_aspect);
    EXPECT_EQ(s.camera.sensor_width, defaults.sensor_width);
    EXPECT_EQ(s.camera.sensor_height, defaults.sensor_height);
    EXPECT_EQ(s.camera.lens, defaults.lens);
    EXPECT_EQ(s.camera.ortho_scale, defaults.ortho_scale);
    EXPECT_TRUE(has_warning(warnings, "lens must be > 0; using " + std::to_string(defaults.lens)));
}

TEST(RenderRepair, BadIntegratorSettingsTakeIntegratorSettingsDefaults) {
    SceneDesc s;
    s.integrator.filter_width = -1;
    s.integrator.exposure = std::numeric_limits<double>::quiet_NaN();
    const std::vector<std::string> warnings = repair_scene(s);
    const IntegratorSettings defaults{};
    EXPECT_EQ(s.integrator.filter_width, defaults.filter_width);
    EXPECT_EQ(s.integrator.exposure, defaults.exposure);
    EXPECT_TRUE(has_warning(warnings, "filter_width must be > 0; using " + std::to_string(defaults.filter_width)));
}
