// Cycles 4.5's light tree (render/light_tree.h): structure, importance values, and that the
// selection pdf is a distribution matching what sample() draws.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

#include "hairbsdf/render/light_tree.h"
#include "hairbsdf/render/lights.h"

using namespace hairbsdf;
using namespace hairbsdf::render;

namespace {

LightDesc point_light(double x, double y, double z, double power, double radius = 0.1, bool soft = true) {
    LightDesc d;
    d.type = LightType::Point;
    d.position = {x, y, z};
    d.strength = RGB(power);
    d.radius = radius;
    d.soft_falloff = soft;
    return d;
}

LightDesc spot_light(double x, double y, double z, Vec3 dir, double power) {
    LightDesc d = point_light(x, y, z, power);
    d.type = LightType::Spot;
    d.direction = {dir.x, dir.y, dir.z};
    d.spot_size = 1.0;
    d.spot_blend = 0.3;
    return d;
}

LightDesc area_light(double x, double y, double z, double power, double spread = kPi) {
    LightDesc d;
    d.type = LightType::Area;
    d.strength = RGB(power);
    // rotated: faces -Z rotated about x by 0.4
    const double c = std::cos(0.4), s = std::sin(0.4);
    d.matrix_world = {1, 0, 0, x, 0, c, -s, y, 0, s, c, z, 0, 0, 0, 1};
    d.has_matrix = true;
    d.size_x = 0.5;
    d.size_y = 0.8;
    d.shape = AreaShape::Rectangle;
    d.spread = spread;
    return d;
}

LightDesc sun_light(Vec3 to_sun, double strength, double angle = 0.1) {
    LightDesc d;
    d.type = LightType::Sun;
    d.direction = {to_sun.x, to_sun.y, to_sun.z};
    d.strength = RGB(strength);
    d.angle = angle;
    return d;
}

EnvironmentDesc small_texture() {
    EnvironmentDesc d;
    d.width = 8;
    d.height = 4;
    d.weight = RGB(1.0);
    d.pixels.assign(size_t(8 * 4 * 3), 0.2f);
    d.pixels[(size_t(1) * 8 + 3) * 3] = 30.0f;
    return d;
}

// A mixed scene: points (sphere and soft), spots, areas, two suns and a textured world.
SceneDesc mixed_scene() {
    SceneDesc s;
    s.integrator.light_tree = true;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> U(-3.0, 3.0);
    for (int i = 0; i < 14; ++i) s.lights.push_back(point_light(U(rng), U(rng), U(rng), 10 + 5 * i, 0.05 * (i % 4), i % 2));
    s.lights.push_back(spot_light(0.5, 1, 2, normalize(Vec3{0.1, -0.2, -1}), 200));
    s.lights.push_back(spot_light(-2, 0, 1, normalize(Vec3{1, 0, 0}), 80));
    s.lights.push_back(area_light(1, 2, 3, 50));
    s.lights.push_back(area_light(-1, -2, 2.5, 30, 1.0));
    s.lights.push_back(sun_light(normalize(Vec3{0.3, 0.2, 1}), 3.0));
    s.lights.push_back(sun_light(normalize(Vec3{-0.5, 0.1, 0.4}), 1.0, 0.02));
    s.world_texture = small_texture();
    return s;
}

Vec3 random_unit(std::mt19937& rng) {
    std::normal_distribution<double> G;
    return normalize(Vec3{G(rng), G(rng), G(rng)});
}

}  // namespace

// The merge is in float, as Cycles': hand values to float precision, results exactly float values.
TEST(RenderLightTree, ConeMergeMatchesHandValues) {
    const LightTreeCone a{{0, 0, -1}, 0.0, 0.3}, b{{1, 0, 0}, 0.0, 0.5};
    const LightTreeCone m = merge_cones(a, b);
    EXPECT_NEAR(m.theta_o, kPi / 4, 1e-7);
    EXPECT_NEAR(m.theta_e, 0.5, 1e-7);
    EXPECT_NEAR(m.axis.x, std::sqrt(0.5), 1e-7);
    EXPECT_NEAR(m.axis.z, -std::sqrt(0.5), 1e-7);
    EXPECT_EQ(m.theta_o, double(float(m.theta_o)));
    EXPECT_EQ(m.axis.x, double(float(m.axis.x)));
    // A cone containing the other keeps its axis; a point light's cone (theta_o = pi) absorbs all.
    const LightTreeCone wide{{0, 0, 1}, kPi, kPi / 2};
    const LightTreeCone w = merge_cones(a, wide);
    EXPECT_EQ(w.theta_o, kPi);
    EXPECT_EQ(w.axis.z, 1.0);
    EXPECT_EQ(w.theta_e, double(float(kPi / 2)));
    // Empty cones are ignored.
    EXPECT_EQ(merge_cones(LightTreeCone{}, b).axis.x, 1.0);
}

// light_tree_importance in angle form: I_max = cos(theta_i - theta_u) E cos(theta - theta_u - theta_o) / d_min^2
// and I_min = cos(theta_i + theta_u) E cos(theta + theta_u - theta_o ...) / d_max^2 where the cluster is inside.
TEST(RenderLightTree, ImportanceFormulaByHand) {
    const Vec3 N{0, 0, 1};
    const Vec3 ptc = normalize(Vec3{1, 0, 1});  // theta_i = pi/4
    {
        // Cone axis 45 degrees off -ptc: theta = pi/4.
        const LightTreeCone cone{{0, 0, -1}, 0.2, 0.5};
        const double cos_u = 0.9, tu = std::acos(cos_u);
        const LightTreeImportance I = light_tree_importance(N, false, ptc, cos_u, cone, 3.0, 2.0, 3.0);
        EXPECT_NEAR(I.max, std::cos(kPi / 4 - tu) * 3.0 * std::cos(kPi / 4 - tu - 0.2) / 4.0, 1e-12);
        EXPECT_EQ(I.min, 0.0);  // theta + theta_u outside theta_e - theta_o
    }
    {
        const LightTreeCone cone{-1.0 * ptc, 0.2, 0.5};  // pointing straight at P: theta = 0
        const double cos_u = 0.99, tu = std::acos(cos_u);
        const LightTreeImportance I = light_tree_importance(N, false, ptc, cos_u, cone, 3.0, 2.0, 3.0);
        EXPECT_NEAR(I.max, std::cos(kPi / 4 - tu) * 3.0 / 4.0, 1e-12);
        EXPECT_NEAR(I.min, std::cos(kPi / 4 + tu) * 3.0 * std::cos(tu + 0.2) / 9.0, 1e-12);
    }
    {
        // Behind the surface: zero without transmission, |cos| with it.
        const Vec3 below = normalize(Vec3{1, 0, -1});
        const LightTreeCone cone{-1.0 * below, 0.0, kPi / 2};
        EXPECT_EQ(light_tree_importance(N, false, below, 1.0, cone, 1.0, 1.0, 1.0).max, 0.0);
        EXPECT_NEAR(light_tree_importance(N, true, below, 1.0, cone, 1.0, 1.0, 1.0).max, std::sqrt(0.5), 1e-12);
    }
}

TEST(RenderLightTree, EmitterMeasures) {
    const Light p(point_light(1, 2, 3, 100, 0.5, false));
    const LightTreeEmitter& e = p.tree_emitter();
    EXPECT_NEAR(e.energy(), 100 / (4 * kPi), 1e-12);
    EXPECT_EQ(e.measure.cone.theta_o, kPi);
    EXPECT_NEAR(e.measure.bbox.max.x - e.measure.bbox.min.x, 1.0, 1e-12);
    EXPECT_TRUE(e.sphere);
    const Light a(area_light(0, 0, 0, 20, 1.0));
    EXPECT_NEAR(a.tree_emitter().energy(), 20 / kPi, 1e-12);
    EXPECT_NEAR(a.tree_emitter().measure.cone.theta_e, 0.5, 1e-12);
    const Light s(sun_light({0, 0, 1}, 2.0, 0.2));
    EXPECT_NEAR(s.tree_emitter().energy(), 2.0, 1e-12);
    EXPECT_EQ(s.tree_emitter().measure.cone.axis.z, -1.0);
    EXPECT_FALSE(s.tree_emitter().measure.bbox.valid());
}

// The world's energy: pi x its average radiance x the Background strength (Cycles counts the
// strength twice: in the importance map and in the shader's emission estimate).
TEST(RenderLightTree, WorldEnergyCountsTheStrengthTwice) {
    EnvironmentDesc tex;
    tex.width = 8;
    tex.height = 4;
    tex.weight = RGB(2.0);
    tex.pixels.assign(size_t(8 * 4 * 3), 0.2f);
    const Light world(RGB(0.0), tex, true);
    const LightTreeEmitter& e = world.tree_emitter();
    EXPECT_EQ(e.kind, LightTreeEmitter::Kind::World);
    // Cycles' importance map at the texture's 8 x 4 texel centres: a constant 0.4 averages to
    // 0.4 x (sum of the rows' sin(theta)) / 4 x pi / 2 (1.026 x 0.4 on 4 rows), times the strength.
    const double rows = (std::sin(kPi / 8) + std::sin(3 * kPi / 8) + std::sin(5 * kPi / 8) + std::sin(7 * kPi / 8)) / 4;
    EXPECT_NEAR(e.energy(), kPi * 0.4 * rows * (kPi / 2) * 2.0, 1e-6);  // texels are float
    // World > Settings > Map Resolution 64: a 64 x 32 map, whose row sum is closer to 2 / pi.
    double rows64 = 0;
    for (int i = 0; i < 32; ++i) rows64 += std::sin(kPi * (i + 0.5) / 32) / 32;
    const Light manual(RGB(0.0), tex, true, 64);
    EXPECT_NEAR(manual.tree_emitter().energy(), kPi * 0.4 * rows64 * (kPi / 2) * 2.0, 1e-6);
    EXPECT_GT(std::fabs(manual.tree_emitter().energy() - e.energy()), 0.02 * e.energy());
    EXPECT_EQ(e.measure.cone.theta_o, kPi);
    // Importance: E whatever the normal, I_min = 0.
    const LightTree t({e});
    const LightTreeImportance I = t.emitter_importance({1, 2, 3}, normalize(Vec3{0.3, -1, 0.2}), false, 0);
    EXPECT_NEAR(I.max, e.energy(), 1e-12);
    EXPECT_EQ(I.min, 0.0);
}

// A sun's importance does not depend on P: I_max = cos(theta_i - theta_u) E, I_min = cos(theta_i + theta_u) E cos^3.
TEST(RenderLightTree, SunImportance) {
    const Light sun(sun_light({0, 0, 1}, 2.0, 0.2));
    const LightTree t({sun.tree_emitter()});
    const Vec3 N = normalize(Vec3{1, 0, 1});
    const double tu = 0.1, ti = kPi / 4;
    for (const Vec3 P : {Vec3{0, 0, 0}, Vec3{5, -3, 2}}) {
        const LightTreeImportance I = t.emitter_importance(P, N, false, 0);
        EXPECT_NEAR(I.max, std::cos(ti - tu) * 2.0, 1e-12);
        EXPECT_NEAR(I.min, std::cos(ti + tu) * 2.0 * std::pow(std::cos(tu), 3), 1e-12);
    }
}

TEST(RenderLightTree, RootSplitsLocalAndDistant) {
    const LightSet set(mixed_scene());
    ASSERT_TRUE(set.uses_tree());
    const LightTree& t = *set.tree();
    const auto& nodes = t.nodes();
    const LightTree::Node& root = nodes[0];
    ASSERT_FALSE(root.leaf());
    const LightTree::Node& right = nodes[size_t(root.right)];
    EXPECT_TRUE(right.distant);
    EXPECT_EQ(right.count, 3);  // two suns and the world
    EXPECT_EQ(right.bit_trail, 1u);
    for (int k = right.first; k < right.first + right.count; ++k) EXPECT_TRUE(t.emitter(t.order()[size_t(k)]).distant());
    int in_leaves = 0;
    for (const auto& n : nodes) {
        if (!n.leaf()) continue;
        EXPECT_LE(n.count, 8);
        in_leaves += n.count;
    }
    EXPECT_EQ(in_leaves, int(set.size()));
}

// Quirk (a): lights with the same x never get an SAOH split; <= 8 of them form one leaf, more
// are halved in array order.
TEST(RenderLightTree, SameXQuirk) {
    std::vector<LightTreeEmitter> e;
    for (int i = 0; i < 5; ++i) e.push_back(Light(point_light(0, 3.0 * i, 0.5 * i * i, 10)).tree_emitter());
    const LightTree five(e);
    const LightTree::Node& left = five.nodes()[size_t(five.nodes()[0].left)];
    EXPECT_TRUE(left.leaf());
    EXPECT_EQ(left.count, 5);
    // The same lights moved off the plane x = 0 are split.
    for (int i = 0; i < 5; ++i) e[size_t(i)] = Light(point_light(0.1 * i, 3.0 * i, 0.5 * i * i, 10)).tree_emitter();
    const LightTree moved(e);
    EXPECT_FALSE(moved.nodes()[size_t(moved.nodes()[0].left)].leaf());
    // Ten in the plane: halved in array order (5 + 5), no reordering.
    e.clear();
    for (int i = 0; i < 10; ++i) e.push_back(Light(point_light(0, 9.0 - i, 0, 10)).tree_emitter());
    const LightTree ten(e);
    const LightTree::Node& l10 = ten.nodes()[size_t(ten.nodes()[0].left)];
    ASSERT_FALSE(l10.leaf());
    const LightTree::Node& a = ten.nodes()[size_t(l10.left)];
    const LightTree::Node& b = ten.nodes()[size_t(l10.right)];
    EXPECT_EQ(a.count, 5);
    EXPECT_EQ(b.count, 5);
    for (int i = 0; i < 10; ++i) EXPECT_EQ(ten.order()[size_t(i)], i);
}

// Three equal point lights evenly spaced along x: splitting {0} | {1, 2} and {0, 1} | {2} cost the
// same but for rounding. Cycles computes measures and SAOH costs in float, where the second split
// is cheaper by one ulp (a float32 emulation of Cycles' formulas in numpy: 4020.0 against
// 4020.0005); in double the two tie and the first one stays.
TEST(RenderLightTree, SaohCostsRoundInFloatAsCycles) {
    auto emitter = [](double x, double power) {
        LightTreeEmitter e;
        e.kind = LightTreeEmitter::Kind::Point;
        e.position = {x, 0, 0};
        e.centroid = e.position;
        e.radius = 0.15;
        e.measure.bbox.grow(e.position - Vec3{0.15, 0.15, 0.15});
        e.measure.bbox.grow(e.position + Vec3{0.15, 0.15, 0.15});
        e.measure.cone = {{0, 0, 1}, kPi, kPi / 2};
        e.measure.energy = power / (4.0 * kPi);
        return e;
    };
    const LightTree t({emitter(0, 1000), emitter(1, 1000), emitter(2, 1000)});
    const LightTree::Node& local = t.nodes()[size_t(t.nodes()[0].left)];
    ASSERT_FALSE(local.leaf());
    const LightTree::Node& right = t.nodes()[size_t(local.right)];  // {2} alone; in double: {1, 2}
    ASSERT_TRUE(right.leaf());
    ASSERT_EQ(right.count, 1);
    EXPECT_EQ(t.order()[size_t(right.first)], 2);
}

// Quirk (d): two far-apart lights are split by SAOH, not left in one leaf.
TEST(RenderLightTree, TwoLightsSplit) {
    std::vector<LightTreeEmitter> e{Light(point_light(-5, 0, 0, 10)).tree_emitter(),
                                    Light(point_light(5, 0, 1, 10)).tree_emitter()};
    const LightTree t(e);
    const LightTree::Node& left = t.nodes()[size_t(t.nodes()[0].left)];
    ASSERT_FALSE(left.leaf());
    EXPECT_EQ(t.nodes()[size_t(left.left)].count, 1);
    EXPECT_EQ(t.nodes()[size_t(left.right)].count, 1);
    EXPECT_EQ(t.nodes()[size_t(left.right)].bit_trail, 2u);  // depth 1 -> bit 1
}

TEST(RenderLightTree, PdfSumsToOneOverLights) {
    SceneDesc s;
    s.integrator.light_tree = true;
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> U(-3.0, 3.0);
    for (int i = 0; i < 20; ++i) s.lights.push_back(point_light(U(rng), U(rng), U(rng), 5 + i, 0.1 * (i % 3), i % 2));
    s.lights.push_back(sun_light(normalize(Vec3{0.3, 0.2, 1}), 3.0));
    const LightSet set(s);
    for (int trial = 0; trial < 200; ++trial) {
        const LightPickContext at{{U(rng), U(rng), U(rng)}, random_unit(rng), true};
        double sum = 0;
        for (size_t i = 0; i < set.size(); ++i) sum += set.selection_pdf(int(i), at);
        EXPECT_NEAR(sum, 1.0, 1e-9) << "trial " << trial;
    }
}

// With culling (areas, spots, no transmission) mass can be lost, never gained; and sample()
// draws light i with probability pdf(i), returning that pdf.
TEST(RenderLightTree, SamplingFrequenciesMatchPdf) {
    const LightSet set(mixed_scene());
    const LightTree& t = *set.tree();
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> U(-2.0, 2.0), V(0.0, 1.0);
    for (int trial = 0; trial < 6; ++trial) {
        const Vec3 P{U(rng), U(rng), U(rng)}, N = random_unit(rng);
        const bool trans = trial % 2 == 0;
        std::vector<double> pdf(set.size());
        double sum = 0;
        for (size_t i = 0; i < set.size(); ++i) sum += pdf[i] = t.pdf(P, N, trans, int(i));
        EXPECT_LE(sum, 1.0 + 1e-9);
        const int n = 200000;
        std::vector<int> count(set.size(), 0);
        int fails = 0;
        for (int k = 0; k < n; ++k) {
            double p = 0;
            const int i = t.sample(P, N, trans, V(rng), p);
            if (i < 0) {
                ++fails;
                continue;
            }
            ++count[size_t(i)];
            EXPECT_NEAR(p, pdf[size_t(i)], 1e-12 * std::max(1.0, p));
        }
        for (size_t i = 0; i < set.size(); ++i) {
            const double sigma = std::sqrt(n * pdf[i] * (1 - pdf[i])) + 1;
            EXPECT_NEAR(count[i], n * pdf[i], 5 * sigma) << "trial " << trial << " light " << i;
        }
        const double q = std::max(0.0, 1 - sum);
        EXPECT_NEAR(fails, n * q, 5 * (std::sqrt(n * q * (1 - q)) + 1)) << "trial " << trial;
    }
}

// Without integrator.light_tree (Blender 3.x scenes) the pick stays uniform.
TEST(RenderLightTree, OffMeansUniformPick) {
    SceneDesc s = mixed_scene();
    s.integrator.light_tree = false;
    const LightSet set(s);
    EXPECT_FALSE(set.uses_tree());
    const LightPickContext at{{0.1, 0.2, 0.3}, {0, 0, 1}, false};
    for (size_t i = 0; i < set.size(); ++i) EXPECT_DOUBLE_EQ(set.selection_pdf(int(i), at), 1.0 / double(set.size()));
    LightSample ls;
    ASSERT_TRUE(set.sample(at, 0.5, 0.3, 0.7, ls));
}

// Spot: the build's theta_e follows the object scale (atan(tan(t) max(|u|,|v|) / |w|)); the
// importance scales E by the smoothstep of the cone edge seen from P (Cycles 4.2+).
TEST(RenderLightTree, SpotConeAndBlend) {
    LightDesc d = spot_light(0, 0, 0, {0, 0, -1}, 100);
    d.spot_size = 1.0;
    d.spot_blend = 0.5;
    d.radius = 0.1;
    // scale (1, 2, 0.5), no rotation: the light looks along -Z
    d.matrix_world = {1, 0, 0, 0, 0, 2, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, 1};
    d.has_matrix = true;
    const Light spot(d);
    const LightTreeEmitter& e = spot.tree_emitter();
    EXPECT_NEAR(e.measure.cone.theta_e, std::atan(std::tan(0.5) * 2.0 / 0.5), 1e-12);
    EXPECT_EQ(e.measure.cone.theta_o, 0.0);
    const LightTree t({e});
    const Vec3 N{0, 0, 1};
    const double px = 2 * std::tan(1.1);
    const Vec3 P{px, 0, -2};  // 1.1 rad off the axis, in the blend zone of the scaled cone
    const double dist = std::sqrt(px * px + 4), tu = std::atan(0.1 / dist), theta = 1.1;
    const double te = e.measure.cone.theta_e;
    const double smooth = 1.0 / ((1.0 - std::cos(0.5)) * 0.5);
    const double x = (std::cos(std::max(0.0, theta - tu)) - std::cos(te)) * smooth;
    const double blend = x <= 0 ? 0 : (x >= 1 ? 1 : x * x * (3 - 2 * x));
    const double E = 100 / (4 * kPi) * blend;
    const double ti = std::acos(2 / dist);  // angle between N and the direction to the light
    const LightTreeImportance I = t.emitter_importance(P, N, true, 0);
    EXPECT_NEAR(I.max, std::cos(std::max(0.0, ti - tu)) * E * std::cos(std::max(0.0, theta - tu)) / (dist * dist), 1e-9);
    EXPECT_GT(blend, 0.0);
    EXPECT_LT(blend, 1.0);  // the test point sits in the blend zone
}

// Emissive meshes as Cycles 4.5 puts them in the tree: one "mesh" emitter per object in the
// top level, each with a subtree of its triangles. The pdf over lamps and triangles sums to 1
// (transmission: nothing culled) and sample() draws each triangle with its pdf.
TEST(RenderLightTree, EmissiveMeshSubtrees) {
    SceneDesc s;
    s.integrator.light_tree = true;
    MaterialDesc m;
    ClosureDesc e;
    e.type = ClosureDesc::Type::Emission;
    e.strength = 8.0;
    m.closures.push_back(e);
    s.materials.push_back(m);
    std::mt19937 rng(21);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    for (int obj = 0; obj < 2; ++obj) {
        for (int k = 0; k < 11; ++k) {  // 11 triangles: more than a leaf holds
            const int base = int(s.meshes.vertices.size());
            const double cx = 3.0 * obj + 0.4 * k, cy = U(rng), cz = 2.0 + U(rng);
            s.meshes.vertices.push_back({float(cx), float(cy), float(cz)});
            s.meshes.vertices.push_back({float(cx + 0.3), float(cy + 0.1 * U(rng)), float(cz + 0.1 * U(rng))});
            s.meshes.vertices.push_back({float(cx + 0.1), float(cy + 0.3), float(cz + 0.1 * U(rng))});
            s.meshes.triangles.push_back({base, base + 1, base + 2});
            s.meshes.material.push_back(0);
            s.meshes.object.push_back(7 + obj);
        }
    }
    for (int i = 0; i < 5; ++i) s.lights.push_back(point_light(U(rng) * 3, U(rng) * 3, U(rng) * 3, 20 + i));
    s.lights.push_back(sun_light(normalize(Vec3{0.3, 0.2, 1}), 3.0));
    const LightSet set(s);
    ASSERT_EQ(set.size(), 6u + 22u);
    const LightTree& t = *set.tree();
    // Two mesh emitters after the lights, each with an inner subtree over its 11 triangles.
    int meshes = 0;
    for (size_t i = set.size(); i < set.size() + 2; ++i) {
        const LightTreeEmitter& me = t.emitter(int(i));
        ASSERT_EQ(me.kind, LightTreeEmitter::Kind::Mesh);
        EXPECT_FALSE(t.nodes()[size_t(me.subtree)].leaf());
        EXPECT_EQ(t.nodes()[size_t(me.subtree)].bit_trail, 0u);
        ++meshes;
    }
    EXPECT_EQ(meshes, 2);
    std::uniform_real_distribution<double> V(0.0, 1.0);
    for (int trial = 0; trial < 4; ++trial) {
        const Vec3 P{U(rng), U(rng), U(rng)}, N = random_unit(rng);
        const bool trans = trial % 2 == 0;
        std::vector<double> pdf(set.size());
        double sum = 0;
        for (size_t i = 0; i < set.size(); ++i) sum += pdf[i] = t.pdf(P, N, trans, int(i));
        if (trans) {
            EXPECT_NEAR(sum, 1.0, 1e-9) << trial;
        }
        EXPECT_LE(sum, 1.0 + 1e-9);
        const int n = 200000;
        std::vector<int> count(set.size(), 0);
        for (int k = 0; k < n; ++k) {
            double p = 0;
            const int i = t.sample(P, N, trans, V(rng), p);
            if (i < 0) continue;
            ASSERT_LT(size_t(i), set.size());
            ++count[size_t(i)];
            EXPECT_NEAR(p, pdf[size_t(i)], 1e-12 * std::max(1.0, p));
        }
        for (size_t i = 0; i < set.size(); ++i) {
            const double sigma = std::sqrt(n * pdf[i] * (1 - pdf[i])) + 1;
            EXPECT_NEAR(count[i], n * pdf[i], 5 * sigma) << "trial " << trial << " light " << i;
        }
    }
}
