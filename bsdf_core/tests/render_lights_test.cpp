// Light sampling densities and units (render/lights.h).
#include <gtest/gtest.h>

#include <random>

#include "hairbsdf/render/lights.h"

using namespace hairbsdf;
using namespace hairbsdf::render;

namespace {

Vec3 uniform_sphere(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u;
    const double z = 1 - 2 * u(rng), phi = kTwoPi * u(rng), r = std::sqrt(std::max(0.0, 1 - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
}

std::array<double, 16> translate(double x, double y, double z) { return {1, 0, 0, x, 0, 1, 0, y, 0, 0, 1, z, 0, 0, 0, 1}; }

std::vector<LightDesc> finite_lights() {
    std::vector<LightDesc> out;
    LightDesc sphere;
    sphere.type = LightType::Point;
    sphere.position = {0.3, -0.2, 2.0};
    sphere.radius = 0.7;
    sphere.soft_falloff = false;
    out.push_back(sphere);
    LightDesc disk = sphere;
    disk.soft_falloff = true;
    out.push_back(disk);
    LightDesc rect;
    rect.type = LightType::Area;
    rect.shape = AreaShape::Rectangle;
    rect.size_x = 1.5;
    rect.size_y = 0.8;
    rect.matrix_world = translate(0.2, 0.1, 1.5);  // emits along -Z, towards the origin
    out.push_back(rect);
    LightDesc ellipse = rect;
    ellipse.shape = AreaShape::Ellipse;
    out.push_back(ellipse);
    LightDesc spread = rect;
    spread.spread = 1.0;
    out.push_back(spread);
    return out;
}

// The light seen along a sample's direction from p: hit at the sample's distance, with its pdf.
::testing::AssertionResult hit_matches_sample(const Light& light, Vec3 p, const LightSample& s) {
    Ray r;
    r.org = p;
    r.dir = s.wi;
    LightHit h;
    if (!light.intersect(r, 1e30, h)) return ::testing::AssertionFailure() << "no hit along the sample";
    if (!(std::fabs(h.pdf - s.pdf) <= 1e-6 * s.pdf))
        return ::testing::AssertionFailure() << "pdf " << h.pdf << ", sampled " << s.pdf;
    if (!(std::fabs(h.t - s.distance) <= 1e-6 * s.distance))
        return ::testing::AssertionFailure() << "distance " << h.t << ", sampled " << s.distance;
    return ::testing::AssertionSuccess();
}

}  // namespace

// Over directions, each finite light's hit density integrates to 1 (it is a density on
// the set of directions that reach the light), and sample() reports the same density.
TEST(RenderLights, SamplingDensitiesIntegrateToOne) {
    const Vec3 p{0, 0, 0};
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u;
    for (const LightDesc& d : finite_lights()) {
        const Light light(d);
        if (d.type == LightType::Area && d.spread < kPi) continue;  // zero where it cannot light p: below
        const int n = 2000000;
        double integral = 0;
        for (int i = 0; i < n; ++i) {
            Ray r;
            r.org = p;
            r.dir = uniform_sphere(rng);
            LightHit h;
            if (light.intersect(r, 1e30, h)) integral += h.pdf;
        }
        integral *= 4 * kPi / n;
        EXPECT_NEAR(integral, 1.0, 0.01) << int(d.type) << " soft " << d.soft_falloff;
        for (int i = 0; i < 2000; ++i) {
            LightSample s;
            if (!light.sample(p, u(rng), u(rng), s)) continue;
            ASSERT_TRUE(hit_matches_sample(light, p, s));
        }
    }
}

// The irradiance from every light type matches its Cycles unit.
TEST(RenderLights, IrradianceUnits) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u;
    const Vec3 n{0, 0, 1};
    auto irradiance = [&](const Light& l, Vec3 p) {
        double e = 0;
        const int m = 400000;
        for (int i = 0; i < m; ++i) {
            LightSample s;
            if (l.sample(p, u(rng), u(rng), s)) e += s.radiance.r * std::max(0.0, dot(s.wi, n)) / s.pdf;
        }
        return e / m;
    };
    // Sun: irradiance at normal incidence = strength, for any angle.
    for (double angle : {0.0, 0.1, 0.5, 1.5}) {
        LightDesc d;
        d.type = LightType::Sun;
        d.direction = {0, 0, 1};
        d.angle = angle;
        d.strength = RGB(3.0);
        EXPECT_NEAR(irradiance(Light(d), {0, 0, 0}), 3.0, 3.0 * (angle > 0.6 ? 0.02 : 0.005)) << angle;
    }
    // Point light of P watts, far away: E = P / (4 pi d^2), for point, disk and sphere.
    for (int kind = 0; kind < 3; ++kind) {
        LightDesc d;
        d.type = LightType::Point;
        d.position = {0, 0, 10};
        d.strength = RGB(100.0);
        d.radius = kind == 0 ? 0.0 : 0.05;
        d.soft_falloff = kind == 1;
        EXPECT_NEAR(irradiance(Light(d), {0, 0, 0}), 100.0 / (4 * kPi * 100.0), 1e-3) << kind;
    }
    // Area light of P watts (one-sided Lambertian, radiance P / (pi A)), far away on axis:
    // E = L A / d^2 = P / (pi d^2).
    LightDesc a;
    a.type = LightType::Area;
    a.shape = AreaShape::Square;
    a.size_x = 0.1;
    a.strength = RGB(50.0);
    a.matrix_world = translate(0, 0, 10);
    EXPECT_NEAR(irradiance(Light(a), {0, 0, 0}), 50.0 / (kPi * 100.0), 2e-3 * 50.0 / (kPi * 100.0));
    // Spread: the emitted power stays P (Cycles' normalisation). A tiny light 1 unit above
    // the plane z = 0: integrate the irradiance over the lit disk (radius tan(0.3) ~ 0.31).
    LightDesc sp = a;
    sp.spread = 0.6;
    sp.size_x = 0.001;
    sp.matrix_world = translate(0, 0, 1);
    const Light spot_area(sp);
    double power = 0;
    const double extent = 0.5;
    const int grid = 500;
    const double cell = sqr(2 * extent / grid);
    for (int i = 0; i < grid; ++i)
        for (int j = 0; j < grid; ++j) {
            const Vec3 p{-extent + 2 * extent * (i + 0.5) / grid, -extent + 2 * extent * (j + 0.5) / grid, 0};
            LightSample s;
            if (spot_area.sample(p, 0.5, 0.5, s)) power += s.radiance.r * dot(s.wi, n) / s.pdf * cell;
        }
    EXPECT_NEAR(power, 50.0, 0.5);
}

// Rectangles are sampled uniformly in solid angle (Urena et al. 2013). Seen from a point
// above one corner at height d, an a x b rectangle subtends atan(ab / (d sqrt(a^2 + b^2 + d^2))),
// so every sample's 1 / pdf must equal that, and the share of samples landing in a
// sub-rectangle at the same corner must be its own solid angle over the whole.
TEST(RenderLights, RectanglesAreSampledUniformlyInSolidAngle) {
    auto corner_solid_angle = [](double a, double b, double d) {
        return std::atan(a * b / (d * std::sqrt(a * a + b * b + d * d)));
    };
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u;
    for (double d : {0.01, 0.3, 2.0}) {
        const double a = 1.5, b = 0.8;
        LightDesc rect;
        rect.type = LightType::Area;
        rect.shape = AreaShape::Rectangle;
        rect.size_x = a;
        rect.size_y = b;
        rect.matrix_world = translate(0.5 * a, 0.5 * b, d);  // corner above the origin
        const Light light(rect);
        const Vec3 p{0, 0, 0};
        const double whole = corner_solid_angle(a, b, d), part = corner_solid_angle(0.4 * a, 0.7 * b, d);
        const int n = 400000;
        int inside = 0;
        for (int i = 0; i < n; ++i) {
            LightSample s;
            ASSERT_TRUE(light.sample(p, u(rng), u(rng), s));
            ASSERT_NEAR(1.0 / s.pdf, whole, 1e-9 * whole) << d;
            const Vec3 q = p + s.distance * s.wi;
            ASSERT_NEAR(q.z, d, 1e-9);
            ASSERT_GE(q.x, -1e-9);
            ASSERT_LE(q.x, a + 1e-9);
            ASSERT_GE(q.y, -1e-9);
            ASSERT_LE(q.y, b + 1e-9);
            if (q.x < 0.4 * a && q.y < 0.7 * b) ++inside;
        }
        const double expected = part / whole, sigma = std::sqrt(expected * (1 - expected) / n);
        EXPECT_NEAR(double(inside) / n, expected, 5 * sigma) << d;
    }
    // Far away (solid angle below Girard's precision) the light falls back to area sampling,
    // and the irradiance stays P / (pi d^2).
    LightDesc far;
    far.type = LightType::Area;
    far.shape = AreaShape::Square;
    far.size_x = 1e-3;
    far.strength = RGB(50.0);
    far.matrix_world = translate(0, 0, 100);
    const Light light(far);
    LightSample s;
    ASSERT_TRUE(light.sample({0, 0, 0}, 0.3, 0.6, s));
    EXPECT_NEAR(s.radiance.r / s.pdf, 50.0 / (kPi * 1e4), 1e-3 * 50.0 / (kPi * 1e4));
}

// A rectangle with spread < 180 deg is sampled by solid angle over the part that can light p
// (clipped to the square around the disk of radius distance x tan(spread / 2)), as Cycles does.
// Its irradiance by light sampling equals a brute-force integral over directions, sample() and
// intersect() agree on the pdf, the samples stay in the clipped square, and a point the spread
// cannot reach gets no sample.
TEST(RenderLights, NarrowSpreadRectanglesAreClippedAndUnbiased) {
    LightDesc d;
    d.type = LightType::Area;
    d.shape = AreaShape::Rectangle;
    d.size_x = 2.0;
    d.size_y = 1.2;
    d.spread = 0.8;  // tan(0.4) = 0.42: a 0.5 unit light-to-point distance reaches 0.21 on the plane
    d.strength = RGB(10.0);
    d.matrix_world = translate(0, 0, 0.5);
    const Light light(d);
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u;
    const Vec3 n{0, 0, 1};
    for (const Vec3 p : {Vec3{0.3, -0.2, 0.0}, Vec3{0.95, 0.55, 0.0}}) {  // inside; near a corner (partly outside)
        const double reach = 0.5 * std::tan(0.4);
        double by_light = 0;
        const int m = 400000;
        for (int i = 0; i < m; ++i) {
            LightSample s;
            if (!light.sample(p, u(rng), u(rng), s)) continue;
            const Vec3 q = p + s.distance * s.wi;
            ASSERT_LE(std::fabs(q.x - p.x), reach + 1e-9);
            ASSERT_LE(std::fabs(q.y - p.y), reach + 1e-9);
            by_light += s.radiance.r * std::max(0.0, dot(s.wi, n)) / s.pdf;
            if (i % 100 == 0) {
                ASSERT_TRUE(hit_matches_sample(light, p, s));
            }
        }
        by_light /= m;
        // Brute force: cosine-weighted hemisphere directions, radiance from intersect().
        double brute = 0;
        const int k = 4000000;
        for (int i = 0; i < k; ++i) {
            const double r1 = u(rng), r2 = u(rng);
            const double sr = std::sqrt(r1);
            Ray r;
            r.org = p;
            r.dir = Vec3{sr * std::cos(kTwoPi * r2), sr * std::sin(kTwoPi * r2), std::sqrt(1.0 - r1)};
            LightHit h;
            if (light.intersect(r, 1e30, h)) brute += h.radiance.r * kPi;  // cos / (cos / pi)
        }
        brute /= k;
        EXPECT_NEAR(by_light, brute, 0.01 * brute) << p.x;
    }
    LightSample s;
    EXPECT_FALSE(light.sample({3.0, 0.0, 0.0}, 0.5, 0.5, s));  // 2 units beyond the edge, reach 0.21
}

// ---------------------------------------------------------------------------------------
// Emissive triangles (Cycles' mesh lights)

namespace {

// A scene with two point lights and an emissive mesh of `triangles` triangles (a fan of
// different areas around z = 1.5, facing down), material 0 emitting `strength`.
SceneDesc emissive_mesh_scene(int triangles, double strength, EmissionSampling sampling = EmissionSampling::Auto) {
    SceneDesc s;
    MaterialDesc m;
    ClosureDesc e;
    e.type = ClosureDesc::Type::Emission;
    e.color = RGB(1.0, 0.9, 0.8);
    e.strength = strength;
    m.closures.push_back(e);
    m.emission_sampling = sampling;
    s.materials.push_back(m);
    s.meshes.vertices.push_back({0.0f, 0.0f, 1.5f});
    for (int k = 0; k <= triangles; ++k) {
        const double a = 0.9 * k, r = 0.3 + 0.2 * k;
        s.meshes.vertices.push_back({float(r * std::cos(a)), float(r * std::sin(a)), 1.5f});
    }
    for (int k = 0; k < triangles; ++k) {
        s.meshes.triangles.push_back({0, k + 2, k + 1});  // normal -Z
        s.meshes.material.push_back(0);
    }
    for (int i = 0; i < 2; ++i) {
        LightDesc d;
        d.type = LightType::Point;
        d.position = {0.5 * i, -1.0, 2.0};
        d.radius = 0.1;
        s.lights.push_back(d);
    }
    return s;
}

Vec3 vertex(const SceneDesc& s, int tri, int k) {
    const auto& v = s.meshes.vertices[size_t(s.meshes.triangles[size_t(tri)][size_t(k)])];
    return {v[0], v[1], v[2]};
}

}  // namespace

// Cycles 3.x's light distribution: with emissive triangles the lamps share half the
// probability equally and the triangles half by area; sample() draws with those pdfs.
TEST(RenderLights, DistributionGivesTrianglesHalfByArea) {
    const SceneDesc s = emissive_mesh_scene(4, 10.0);
    const LightSet set(s);
    ASSERT_EQ(set.lamp_count(), 2u);
    ASSERT_EQ(set.size(), 6u);
    double area = 0;
    for (size_t i = 2; i < set.size(); ++i) area += set.light(i).triangle_area();
    const LightPickContext at{{0, 0, 0}, {0, 0, 1}, false};
    double sum = 0;
    for (size_t i = 0; i < set.size(); ++i) {
        const double expected = i < 2 ? 0.25 : 0.5 * set.light(i).triangle_area() / area;
        EXPECT_NEAR(set.selection_pdf(int(i), at), expected, 1e-12) << i;
        sum += set.selection_pdf(int(i), at);
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
    // Frequencies: each triangle's picks over n (recovered from the sample's triangle index).
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u;
    const int n = 200000;
    std::vector<int> count(set.size(), 0);
    for (int k = 0; k < n; ++k) {
        LightSample ls;
        if (!set.sample(at, u(rng), u(rng), u(rng), ls)) continue;
        if (ls.triangle >= 0) ++count[size_t(set.triangle_light(ls.triangle))];
    }
    for (size_t i = 2; i < set.size(); ++i) {
        const double p = set.selection_pdf(int(i), at);
        EXPECT_NEAR(count[i], n * p, 5 * std::sqrt(n * p * (1 - p)) + 1) << i;
    }
    // Without lamps the triangles take everything.
    SceneDesc only = s;
    only.lights.clear();
    const LightSet tris(only);
    double tsum = 0;
    for (size_t i = 0; i < tris.size(); ++i) tsum += tris.selection_pdf(int(i), at);
    EXPECT_NEAR(tsum, 1.0, 1e-12);
}

// A triangle's sampling density integrates to 1 over the directions that reach it, from points
// where Cycles samples the solid angle (close) and the area (far); each sample's pdf is the
// density the BSDF-hit side (triangle_pdf) reports for that point, as MIS needs.
TEST(RenderLights, TriangleSamplesMatchTheirHitPdf) {
    const SceneDesc s = emissive_mesh_scene(1, 10.0);
    const LightSet set(s);
    ASSERT_EQ(set.size(), 3u);
    const Light& light = set.light(2);
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<double> u;
    int solid_angle = 0, area = 0;
    const Vec3 a = vertex(s, 0, 0), b = vertex(s, 0, 1), c = vertex(s, 0, 2);
    const Vec3 n_unit = normalize(cross(b - a, c - a));
    const double tri_area = light.triangle_area();
    for (const Vec3 p : {Vec3{0.05, 0.1, 1.49}, Vec3{0.1, 0.05, 1.52}, Vec3{0.3, -0.2, -6.0}, Vec3{0.2, 0.1, 6.0}}) {
        // The integral over directions, as one over the triangle's area: pdf x cos / t^2.
        const int n = 400000;
        double integral = 0;
        for (int i = 0; i < n; ++i) {
            double x = u(rng), y = u(rng);
            if (x + y > 1) {
                x = 1 - x;
                y = 1 - y;
            }
            const Vec3 on = a + x * (b - a) + y * (c - a);
            const Vec3 d = on - p;
            const double t2 = dot(d, d);
            integral += light.triangle_pdf(p, on) * std::fabs(dot(n_unit, d)) / (t2 * std::sqrt(t2));
        }
        integral *= tri_area / n;
        EXPECT_NEAR(integral, 1.0, 0.02) << p.x << " " << p.y << " " << p.z;
        for (int i = 0; i < 2000; ++i) {
            LightSample ls;
            ASSERT_TRUE(light.sample(p, u(rng), u(rng), ls));
            const Vec3 on = p + ls.distance * ls.wi;
            const Vec3 bary = (1 - ls.u - ls.v) * vertex(s, 0, 0) + ls.u * vertex(s, 0, 1) + ls.v * vertex(s, 0, 2);
            ASSERT_NEAR(length(on - bary), 0.0, 1e-6);
            ASSERT_NEAR(ls.pdf, light.triangle_pdf(p, on), 1e-6 * ls.pdf);
            ASSERT_TRUE(ls.use_mis);
        }
        (std::fabs(p.z - 1.5) < 0.1 ? solid_angle : area)++;
    }
    EXPECT_EQ(solid_angle, 2);
    EXPECT_EQ(area, 2);
    // The two branches were both taken: the solid-angle pdf near the plane is not the area one.
    const Vec3 near{0.05, 0.1, 1.49}, on = (1.0 / 3.0) * (a + b + c);
    const Vec3 d = on - near;
    EXPECT_GT(std::fabs(light.triangle_pdf(near, on) - dot(d, d) / (std::fabs(dot(n_unit, normalize(d))) * tri_area)),
              0.01 * light.triangle_pdf(near, on));
}

// Emission Sampling: Auto samples a material whose largest emission channel exceeds 0.5
// (Cycles' rule), None never, Front only from the front side (Cycles 4.x).
TEST(RenderLights, EmissionSamplingChoosesTrianglesAndSides) {
    // two lamps, two triangles
    EXPECT_EQ(LightSet(emissive_mesh_scene(2, 0.5)).size(), 2u);  // 0.5 x 1.0 = 0.5: not above 0.5
    EXPECT_EQ(LightSet(emissive_mesh_scene(2, 0.6)).size(), 2u + 2u);
    EXPECT_EQ(LightSet(emissive_mesh_scene(2, 5.0, EmissionSampling::None)).size(), 2u);
    const SceneDesc front = emissive_mesh_scene(1, 5.0, EmissionSampling::Front);
    const LightSet set(front);
    ASSERT_EQ(set.size(), 3u);
    LightSample ls;
    EXPECT_TRUE(set.light(2).sample({0.1, 0.1, 0.0}, 0.3, 0.4, ls));   // below: the front (normal -Z)
    EXPECT_FALSE(set.light(2).sample({0.1, 0.1, 3.0}, 0.3, 0.4, ls));  // above: the back
    EXPECT_TRUE(set.light(2).samples_side(false));
    EXPECT_FALSE(set.light(2).samples_side(true));
}

// Textured emission: Cycles estimates a linked Colour as 1 and a linked Strength as 1 (the node
// feeding it is not a closure), so Auto samples a textured emitter whose constant part is above 0.5
// and the light tree weighs its triangles by that estimate.
TEST(RenderLights, LinkedEmissionInputsCountAsOneInTheEstimate) {
    double estimate = 0;
    MaterialDesc m = emissive_mesh_scene(1, 0.1).materials[0];  // constant: 0.1 x (1, 0.9, 0.8), not sampled
    EXPECT_EQ(resolved_emission_sampling(m, estimate), EmissionSampling::None);
    m.closures[0].links.push_back({ClosureDesc::Input::Strength, 0});  // strength 1 x (1, 0.9, 0.8)
    EXPECT_EQ(resolved_emission_sampling(m, estimate), EmissionSampling::FrontBack);
    EXPECT_NEAR(estimate, 0.9, 1e-12);
    m.closures[0].links.push_back({ClosureDesc::Input::Color, 3});  // 1 x 1
    EXPECT_EQ(resolved_emission_sampling(m, estimate), EmissionSampling::FrontBack);
    EXPECT_NEAR(estimate, 1.0, 1e-12);
    m.closures[0].links = {{ClosureDesc::Input::Color, 3}};  // 0.1 x 1: not sampled
    EXPECT_EQ(resolved_emission_sampling(m, estimate), EmissionSampling::None);
    EXPECT_NEAR(estimate, 0.1, 1e-12);
}
