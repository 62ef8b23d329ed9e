// Camera rays and the pixel filter (render/camera.h, render/film.h).
#include <gtest/gtest.h>

#include <random>

#include "hairbsdf/render/camera.h"
#include "hairbsdf/render/film.h"

using namespace hairbsdf;
using namespace hairbsdf::render;

namespace {

CameraDesc looking_down_minus_z() {
    CameraDesc d;  // identity matrix: camera at the origin looking along -Z, +Y up
    d.width = 200;
    d.height = 100;
    d.lens = 50;
    d.sensor_width = 36;
    d.sensor_height = 24;
    d.clip_start = 0.5;
    d.clip_end = 10;
    return d;
}

}  // namespace

TEST(RenderCamera, PerspectiveCentreAndEdges) {
    CameraDesc d = looking_down_minus_z();
    const Camera cam(d);
    const Ray c = cam.generate(100.0, 50.0);
    EXPECT_NEAR(c.dir.x, 0, 1e-12);
    EXPECT_NEAR(c.dir.y, 0, 1e-12);
    EXPECT_NEAR(c.dir.z, -1, 1e-12);
    EXPECT_NEAR(c.tmin, 0.5, 1e-12);
    EXPECT_NEAR(c.tmax, 10, 1e-12);
    // AUTO fit, landscape: the sensor width spans the image width: tan = 18 / 50.
    const Ray r = cam.generate(200.0, 50.0);
    EXPECT_NEAR(r.dir.x / -r.dir.z, 18.0 / 50.0, 1e-12);
    const Ray t = cam.generate(100.0, 100.0);  // raster y up: top edge
    EXPECT_NEAR(t.dir.y / -t.dir.z, 9.0 / 50.0, 1e-12);
    // The clip planes are perpendicular to the view axis.
    EXPECT_NEAR(r.tmin * -r.dir.z, 0.5, 1e-12);
}

TEST(RenderCamera, SensorFitAndShift) {
    CameraDesc d = looking_down_minus_z();
    d.sensor_fit = SensorFit::Vertical;
    const Camera v(d);
    EXPECT_NEAR(v.generate(100, 100).dir.y / -v.generate(100, 100).dir.z, 12.0 / 50.0, 1e-12);
    // Portrait image with AUTO: the sensor width spans the height.
    d.sensor_fit = SensorFit::Auto;
    d.width = 100;
    d.height = 200;
    const Camera p(d);
    EXPECT_NEAR(p.generate(50, 200).dir.y / -p.generate(50, 200).dir.z, 18.0 / 50.0, 1e-12);
    // Shift in units of the larger side: shift_x = 0.5 moves the centre by half the width.
    d.width = 200;
    d.height = 100;
    d.shift_x = 0.5;
    const Camera s(d);
    EXPECT_NEAR(s.generate(100, 50).dir.x / -s.generate(100, 50).dir.z, 18.0 / 50.0, 1e-12);
}

TEST(RenderCamera, OrthographicExtentAndMatrix) {
    CameraDesc d = looking_down_minus_z();
    d.type = CameraType::Orthographic;
    d.ortho_scale = 4.0;  // the larger side (width) spans 4 units
    // Camera at (1, 2, 3) rotated 90 degrees about X: looks along +Y... (-Z local -> +Y world)
    d.matrix_world = {1, 0, 0, 1, 0, 0, -1, 2, 0, 1, 0, 3, 0, 0, 0, 1};
    const Camera cam(d);
    const Ray r = cam.generate(200.0, 100.0);  // top-right corner
    EXPECT_NEAR(r.dir.x, 0, 1e-12);
    EXPECT_NEAR(r.dir.y, 1, 1e-12);
    EXPECT_NEAR(r.dir.z, 0, 1e-12);
    EXPECT_NEAR(r.org.x, 1 + 2.0, 1e-12);  // half the width
    EXPECT_NEAR(r.org.z, 3 + 1.0, 1e-12);  // half the height (camera +Y = world +Z)
}

TEST(RenderCamera, PixelRowsAreTopFirst) {
    CameraDesc d = looking_down_minus_z();
    const Camera cam(d);
    EXPECT_EQ(cam.pixel_row_to_raster_y(0), 99);
    EXPECT_EQ(cam.pixel_row_to_raster_y(99), 0);
}

// The importance-sampled offsets have the filter's distribution: mean at the pixel centre,
// variance of the (truncated) profile.
TEST(RenderFilter, ImportanceSampledMoments) {
    struct Case {
        IntegratorSettings::Filter type;
        double width;
    };
    for (const Case c : {Case{IntegratorSettings::Filter::BlackmanHarris, 1.5}, Case{IntegratorSettings::Filter::Gaussian, 1.5},
                         Case{IntegratorSettings::Filter::Box, 3.0}}) {
        const FilterTable table(c.type, c.width);
        // Reference moments of the profile by quadrature.
        auto profile = [&](double x) {
            switch (c.type) {
                case IntegratorSettings::Filter::BlackmanHarris: {
                    const double v = kTwoPi * (x / (2 * c.width) + 0.5);
                    return 0.35875 - 0.48829 * std::cos(v) + 0.14128 * std::cos(2 * v) - 0.01168 * std::cos(3 * v);
                }
                case IntegratorSettings::Filter::Gaussian:
                    return std::exp(-2.0 * sqr(x * 6.0 / (3.0 * c.width)));
                default:
                    return 1.0;
            }
        };
        const double support = c.type == IntegratorSettings::Filter::Box ? 0.5
                               : c.type == IntegratorSettings::Filter::Gaussian ? 1.5 * c.width
                                                                                : c.width;
        double m0 = 0, m2 = 0;
        const int n = 200000;
        for (int i = 0; i < n; ++i) {
            const double x = -support + 2 * support * (i + 0.5) / n;
            m0 += profile(x);
            m2 += profile(x) * x * x;
        }
        const double var_ref = m2 / m0;
        double mean = 0, var = 0, lo = 1e9, hi = -1e9;
        const int m = 400000;
        for (int i = 0; i < m; ++i) {
            // Stratified u, skipping the top 1/1023 (Cycles' zero last table entry, tested below).
            const double u = (i + 0.5) / m * (1022.0 / 1023.0);
            const double o = table.sample(u) - 0.5;
            mean += o;
            var += o * o;
            lo = std::min(lo, o);
            hi = std::max(hi, o);
        }
        mean /= m;
        var /= m;
        SCOPED_TRACE(int(c.type));
        EXPECT_NEAR(mean, 0.0, 2e-3 * support);  // symmetric within the table resolution
        // Cycles' 1024-entry table is coarse (a left Riemann sum inverted with a one-cell
        // shift): its variance is up to ~2% above the profile's (Gaussian), as in Cycles.
        EXPECT_NEAR(var, var_ref, 0.03 * var_ref);
        EXPECT_NEAR(lo, -support, 0.01 * support);
        EXPECT_NEAR(hi, support, 0.01 * support);
    }
}

TEST(RenderFilter, BoxIsOnePixelAndLastEntryIsZero) {
    const FilterTable box(IntegratorSettings::Filter::Box, 0.01);
    EXPECT_NEAR(box.sample(0.0), 0.0, 1e-6);
    EXPECT_NEAR(box.sample(1022.0 / 1023.0), 1.0, 1e-6);
    EXPECT_EQ(box.table().back(), 0.0f);  // as Cycles' table
    EXPECT_NEAR(box.sample(0.5), 0.5, 1e-3);
}
