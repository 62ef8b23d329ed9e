// Curve and triangle intersection with Cycles' semantics (render/geometry.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "hairbsdf/math_simd.h"
#include "hairbsdf/render/curve_sweep.h"
#include "hairbsdf/render/geometry.h"

using namespace hairbsdf;
using namespace hairbsdf::render;

namespace {

// Straight strands along +x at the given (y, z), radius r.
SceneDesc strands(std::vector<std::array<double, 2>> yz, float r, CurveShape shape) {
    SceneDesc s;
    s.curve_shape = shape;
    s.curves.offsets.push_back(0);
    for (const auto& p : yz) {
        for (int k = 0; k < 5; ++k) s.curves.points.push_back({-1.0f + 0.5f * k, float(p[0]), float(p[1]), r});
        s.curves.offsets.push_back(int32_t(s.curves.points.size()));
        s.curves.random.push_back(0.5f);
        s.curves.material.push_back(0);
    }
    return s;
}

Ray ray(Vec3 o, Vec3 d) {
    Ray r;
    r.org = o;
    r.dir = normalize(d);
    return r;
}

}  // namespace

TEST(RenderGeometry, ThickCurveFrontHitAndNormal) {
    const SceneDesc s = strands({{0, 0}}, 0.05f, CurveShape::Thick);
    const Geometry g(s);
    const Hit h = g.intersect(ray({0.1, 0.02, 1}, {0, 0, -1}), {});
    ASSERT_TRUE(h);
    EXPECT_EQ(h.kind, PrimKind::Curve);
    EXPECT_EQ(h.prim, 0);
    const Vec3 p = Vec3{0.1, 0.02, 1} + h.t * Vec3{0, 0, -1};
    const CurvePoint c = g.curve_point(h.segment, h.u);
    EXPECT_NEAR(length(p - c.p), 0.05, 1e-5);
    EXPECT_NEAR(c.p.x, 0.1, 1e-5);
    EXPECT_LT(dot(h.ng, Vec3{0, 0, -1}), 0.0);
    EXPECT_GT(normalize(c.dp).x, 0.999);  // tangent root -> tip
}

// With culling on, a ray starting inside a tube does not hit its far wall.
TEST(RenderGeometry, ThickCurveBackFacesCanBeCulled) {
    SceneDesc s = strands({{0, 0}}, 0.05f, CurveShape::Thick);
    s.cull_curve_back_faces = true;
    const Geometry g(s);
    EXPECT_FALSE(g.intersect(ray({0.1, 0, 0}, {0, 0.3, -1}), {}));
    EXPECT_FALSE(g.occluded(ray({0.1, 0, 0}, {0, 0.3, -1}), {}));
    // The same ray from outside hits the front face.
    EXPECT_TRUE(g.intersect(ray({0.1, 0, 1}, {0, 0, -1}), {}));
}

// Cycles' behaviour (the default): the inside of a tube is hit, e.g. by a ray that enters
// through the open end of a strand, or starts inside another strand.
TEST(RenderGeometry, ThickCurveInsideIsHitByDefault) {
    const SceneDesc s = strands({{0, 0}}, 0.05f, CurveShape::Thick);
    const Geometry g(s);
    const Hit inside = g.intersect(ray({0.1, 0, 0}, {0, 0.3, -1}), {});
    ASSERT_TRUE(inside);
    EXPECT_GT(dot(inside.ng, Vec3{0, 0.3, -1}), 0.0);  // a back face
    // Through the open end at x = 1: from below-right, up-left into the tube's top wall.
    EXPECT_TRUE(g.occluded(ray({1.2, 0, -0.1}, {-1, 0, 0.5}), {}));
    // No end caps: a ray just beyond the end misses.
    EXPECT_FALSE(g.intersect(ray({1.02, 0, 1}, {0, 0, -1}), {}));
}

// A ray leaving curve c ignores all of curve c, but not other curves.
TEST(RenderGeometry, SelfIntersectionSkipsTheWholeCurve) {
    const SceneDesc s = strands({{0, 0}, {0, -0.5}}, 0.05f, CurveShape::Thick);
    const Geometry g(s);
    const Ray down = ray({0.1, 0, 1}, {0, 0, -1});
    const Hit first = g.intersect(down, {});
    ASSERT_TRUE(first);
    EXPECT_EQ(first.prim, 0);
    const Hit second = g.intersect(down, {PrimKind::Curve, 0});
    ASSERT_TRUE(second);
    EXPECT_EQ(second.prim, 1);
    EXPECT_FALSE(g.intersect(down, {PrimKind::Curve, 1}).prim == 1 && false);
    // From the hit point on curve 0 towards curve 1: no self hit, no offset needed.
    const Vec3 p = down.org + first.t * down.dir;
    const Hit next = g.intersect(ray(p, {0, 0, -1}), {PrimKind::Curve, 0});
    ASSERT_TRUE(next);
    EXPECT_EQ(next.prim, 1);
    EXPECT_FALSE(g.occluded(ray(p, {0, 0, 1}), {PrimKind::Curve, 0}));
}

// Ribbons: Embree's v in [-1, 1] across the width; h = -v equals -dot(P - C, Y) / r.
TEST(RenderGeometry, RibbonOffsetSign) {
    const SceneDesc s = strands({{0, 0}}, 0.05f, CurveShape::Ribbons);
    const Geometry g(s);
    const Hit h = g.intersect(ray({0.1, 0.02, 1}, {0, 0, -1}), {});
    ASSERT_TRUE(h);
    // wo = +z, X = +x, Y = normalize(X x wo) = -y: -dot(P - C, Y) / r = 0.02 / 0.05.
    EXPECT_NEAR(-h.v, 0.4, 2e-3);
    // Flat-curve hits closer than 2 r are ignored (Embree's, as in Cycles' build).
    EXPECT_FALSE(g.intersect(ray({0.1, 0, 0.08}, {0, 0, -1}), {}));
    EXPECT_TRUE(g.intersect(ray({0.1, 0, 0.11}, {0, 0, -1}), {}));
}

TEST(RenderGeometry, TrianglesAndSelfSkip) {
    SceneDesc s;
    s.meshes.vertices = {{-1, -1, 0}, {1, -1, 0}, {0, 1, 0}};
    s.meshes.triangles = {{0, 1, 2}};
    s.meshes.material = {0};
    const Geometry g(s);
    const Hit h = g.intersect(ray({0, 0, 1}, {0, 0, -1}), {});
    ASSERT_TRUE(h);
    EXPECT_EQ(h.kind, PrimKind::Triangle);
    EXPECT_NEAR(h.t, 1.0, 1e-6);
    EXPECT_FALSE(g.intersect(ray({0, 0, 1}, {0, 0, -1}), {PrimKind::Triangle, 0}));
    const Vec3 o = offset_ray_origin({0, 0, 0}, {0, 0, 1});
    EXPECT_GT(o.z, 0.0);
    EXPECT_LT(o.z, 1e-4);
}

// Curves kept in their object's space (CurveData::object): strand 1 is scaled 3x along y by
// its object (world from object = diag(1, 3, 1) + a shift of 2 in y), strand 0 stays in world
// space. Rays down -z see strand 1 three times as wide; each hit names its own curve and
// segment, and a ray leaving a strand skips it, object space or not.
TEST(RenderGeometry, CurvesInObjectSpaceAreIntersectedThere) {
    SceneDesc s = strands({{0, 0}, {0, 0}}, 0.05f, CurveShape::Thick);
    s.curves.object = {-1, 0};
    s.curves.object_transforms = {{1, 0, 0, 0, 0, 3, 0, 2, 0, 0, 1, 0}};
    const Geometry g(s);
    ASSERT_EQ(g.curve_object_space(0), nullptr);
    ASSERT_NE(g.curve_object_space(1), nullptr);
    for (double y : {2.0, 2.14, 1.86}) {  // inside 3 r = 0.15 of the object-space strand's axis at y = 2
        const Hit h = g.intersect(ray({0.3, y, 1}, {0, 0, -1}), {});
        ASSERT_TRUE(h) << y;
        EXPECT_EQ(h.prim, 1);
        EXPECT_EQ(g.segment_curve(h.segment), 1);
        const CurvePoint c = g.curve_point(h.segment, h.u);  // object space
        EXPECT_NEAR(g.curve_object_space(1)->point_to_world(c.p).x, 0.3, 1e-4);
        EXPECT_FALSE(g.intersect(ray({0.3, y, 1}, {0, 0, -1}), {PrimKind::Curve, 1}));
        EXPECT_TRUE(g.occluded(ray({0.3, y, 1}, {0, 0, -1}), {}));
    }
    EXPECT_FALSE(g.intersect(ray({0.3, 2.17, 1}, {0, 0, -1}), {}));
    const Hit world = g.intersect(ray({0.3, 0.04, 1}, {0, 0, -1}), {});  // the world-space strand: r = 0.05
    ASSERT_TRUE(world);
    EXPECT_EQ(world.prim, 0);
    EXPECT_FALSE(g.intersect(ray({0.3, 0.06, 1}, {0, 0, -1}), {}));
    // The inverse and the normal transform.
    const ObjectSpace& os = *g.curve_object_space(1);
    const Vec3 p = os.point_to_object(os.point_to_world({0.2, -0.4, 0.7}));
    EXPECT_NEAR(p.x, 0.2, 1e-12);
    EXPECT_NEAR(p.y, -0.4, 1e-12);
    const Vec3 n = os.normal_to_world({0, 1, 0});
    EXPECT_NEAR(n.y, 1.0 / 3.0, 1e-12);
}

// Linear 3D Curves (Blender 5.x): straight cones between the keys, joined by spheres. On a
// bent strand the hit lies on the chord between two keys (not on the Catmull-Rom arc), and
// curve_point gives the chord's point and direction.
TEST(RenderGeometry, LinearCurvesFollowTheChords) {
    SceneDesc s;
    s.curve_shape = CurveShape::ThickLinear;
    s.curves.offsets = {0, 3};
    s.curves.points = {{-1.0f, 0.0f, 0.0f, 0.05f}, {0.0f, 0.0f, 0.5f, 0.05f}, {1.0f, 0.0f, 0.0f, 0.05f}};
    s.curves.random = {0.5f};
    s.curves.material = {0};
    const Geometry g(s);
    // Straight down at x = -0.5: the chord from key 0 to key 1 is at z = 0.25 there; the
    // Catmull-Rom arc would lie higher.
    const Hit h = g.intersect(ray({-0.5, 0, 2}, {0, 0, -1}), {});
    ASSERT_TRUE(h);
    const double top = 0.25 + 0.05 * std::sqrt(1.0 + 0.25);  // a cone of radius r around a slope-1/2 line
    EXPECT_NEAR(2.0 - h.t, top, 1e-4);
    const CurvePoint c = g.curve_point(h.segment, h.u);
    EXPECT_NEAR(c.dp.x, 1.0, 1e-6);
    EXPECT_NEAR(c.dp.z, 0.5, 1e-6);
    EXPECT_NEAR(c.r, 0.05, 1e-6);
    // The joint at key 1 is a sphere: a ray straight down at x = 0 hits its top.
    const Hit joint = g.intersect(ray({0.0, 0, 2}, {0, 0, -1}), {});
    ASSERT_TRUE(joint);
    EXPECT_NEAR(2.0 - joint.t, 0.55, 1e-4);
    // Closed ends (spheres), unlike the open Catmull-Rom tubes: just beyond key 2 is still hit.
    EXPECT_TRUE(g.intersect(ray({1.02, 0, 1}, {0, 0, -1}), {}));
}

TEST(RenderGeometry, LinearCurvesCanBeCulled) {
    SceneDesc s = strands({{0, 0}}, 0.05f, CurveShape::ThickLinear);
    s.cull_curve_back_faces = true;
    const Geometry g(s);
    EXPECT_FALSE(g.intersect(ray({0.1, 0, 0}, {0, 0.3, -1}), {}));
    EXPECT_TRUE(g.intersect(ray({0.1, 0, 1}, {0, 0, -1}), {}));
}

namespace {

// The tests' random numbers: a small LCG, the same on every platform, so that the counts in the
// comments below are reproducible.
struct TestRandom {
    uint32_t state;
    double next() {
        state = state * 1664525u + 1013904223u;
        return double(state >> 8) / double(1u << 24);
    }
    Vec3 direction() {  // uniform on the sphere
        const double ct = 2 * next() - 1, phi = 6.283185307 * next(), st = std::sqrt(1 - ct * ct);
        return Vec3{st * std::cos(phi), st * std::sin(phi), ct};
    }
};

// Bent, tapered strands packed so that they cross, and a triangle plane through them, for
// comparing the two intersectors.
// 48 strands (or, `thin`, 400 strands like hair: gently bent, 10x thinner) across a box over a plane.
SceneDesc bent_strands(CurveIntersector intersector, uint32_t seed, bool thin = false) {
    SceneDesc s;
    s.curve_shape = CurveShape::Thick;
    s.curve_intersector = intersector;
    s.curves.offsets.push_back(0);
    TestRandom random{seed};
    auto next = [&] { return random.next(); };
    for (int c = 0; c < (thin ? 400 : 48); ++c) {
        const double y0 = next() - 0.5, z0 = 0.4 * next() - 0.2, bend = (thin ? 1 : 3) * next(), phase = 6.28 * next();
        const int keys = thin ? 12 : 3 + int(6 * next());
        for (int k = 0; k < keys; ++k) {
            const double x = -1 + 2.0 * k / (keys - 1);
            const double r = (thin ? 0.004 : 0.04) * (1.0 - 0.7 * k / (keys - 1)) * (0.5 + next());
            s.curves.points.push_back({float(x), float(y0 + 0.3 * std::sin(bend * x + phase)),
                                       float(z0 + 0.3 * std::cos(bend * 1.3 * x + phase)), float(r)});
        }
        s.curves.offsets.push_back(int32_t(s.curves.points.size()));
        s.curves.random.push_back(0.5f);
        s.curves.material.push_back(0);
    }
    s.meshes.vertices = {{-2, -2, 0.05f}, {2, -2, 0.05f}, {2, 2, 0.05f}, {-2, 2, 0.05f}};
    s.meshes.triangles = {{0, 1, 2}, {0, 2, 3}};
    s.meshes.material = {0, 0};
    return s;
}

// Curve `curve`'s Catmull-Rom control points as the intersectors hold them: its keys, the end keys doubled.
std::vector<std::array<float, 4>> strand_control_points(const SceneDesc& s, size_t curve) {
    const auto first = s.curves.points.begin() + s.curves.offsets[curve];
    const auto last = s.curves.points.begin() + s.curves.offsets[curve + 1];
    std::vector<std::array<float, 4>> cp{*first};
    cp.insert(cp.end(), first, last);
    cp.push_back(*(last - 1));
    return cp;
}

}  // namespace

// The Sweep intersector (Embree's BVH over linear proxies, the exact test) finds the hits of
// Embree's round Catmull-Rom curves: the same curve, distance and centre-line point, on
// strongly bent, tapered strands (a few keys each, radius changing by up to 3x per key), for
// single rays and for the wavefront's streams. Rays from afar, or (`from_near_strands`) from
// points within 2.5 radii of a strand's key, inside its tube or not, like the bounce and shadow
// rays of a render (half of them skip that strand): these reach the exact test's later steps.
// At most one disagreement per `hits_per_disagreement` hits (a hit on another curve, or none,
// or t off by 1e-4), and one occlusion answer per `rays_per_occlusion_disagreement` rays.
static void expect_sweep_finds_embrees_hits(bool from_near_strands, bool thin, int hits_per_disagreement,
                                            int rays_per_occlusion_disagreement) {
    const SceneDesc a = bent_strands(CurveIntersector::Embree, 7, thin), b = bent_strands(CurveIntersector::Sweep, 7, thin);
    const Geometry embree(a), sweep(b);
    TestRandom random{99};
    auto next = [&] { return random.next(); };
    auto random_direction = [&] { return random.direction(); };
    const int n = 20000;
    std::vector<Ray> rays;
    std::vector<SkipPrim> skips;
    for (int i = 0; i < n; ++i) {
        if (from_near_strands) {
            const size_t key = size_t(next() * double(a.curves.points.size())) % a.curves.points.size();
            const auto& k = a.curves.points[key];
            const int curve = int(std::upper_bound(a.curves.offsets.begin(), a.curves.offsets.end(), int32_t(key)) -
                                  a.curves.offsets.begin()) - 1;
            const Vec3 origin = Vec3{k[0], k[1], k[2]} + ((0.2 + 2.3 * next()) * k[3]) * random_direction();
            rays.push_back(ray(origin, random_direction()));
            skips.push_back((i % 2 == 0) ? SkipPrim{PrimKind::Curve, curve} : SkipPrim{});
            continue;
        }
        const Vec3 target{2 * next() - 1, 1.4 * next() - 0.7, 0.8 * next() - 0.4};
        const Vec3 d = random_direction();
        rays.push_back(ray(target - 3.0 * d, d));
        skips.push_back((i % 4 == 0) ? SkipPrim{PrimKind::Curve, int(i % a.curves.random.size())} : SkipPrim{});
    }
    std::vector<Hit> streamed(n);
    std::vector<uint8_t> occluded_streamed(n);
    std::vector<int> no_light(n, -1);
    sweep.intersect_stream(rays.data(), skips.data(), streamed.data(), n);
    sweep.occluded_stream(rays.data(), skips.data(), no_light.data(), occluded_streamed.data(), n);
    int hits = 0, disagreements = 0, occlusion_disagreements = 0, t_mismatch = 0, stream_mismatch = 0;
    for (int i = 0; i < n; ++i) {
        const Ray& r = rays[size_t(i)];
        const Hit ha = embree.intersect(r, skips[size_t(i)]), hb = sweep.intersect(r, skips[size_t(i)]);
        const bool occluded = sweep.occluded(r, skips[size_t(i)]);
        occlusion_disagreements += embree.occluded(r, skips[size_t(i)]) != occluded;
        const Hit& hs = streamed[size_t(i)];
        stream_mismatch += bool(hs) != bool(hb) || (hb && (hs.prim != hb.prim || std::fabs(hs.t - hb.t) > 1e-6)) ||
                           (occluded_streamed[size_t(i)] != 0) != occluded;
        if (bool(ha) != bool(hb) || (ha && (ha.kind != hb.kind || ha.prim != hb.prim))) {
            ++disagreements;
            continue;
        }
        if (!ha || ha.kind != PrimKind::Curve) continue;
        ++hits;
        if (std::fabs(ha.t - hb.t) > 1e-4) {
            ++t_mismatch;
            continue;
        }
        // Embree's surface: the hit lies in the normal plane at u, r(u) from the centre line.
        const Vec3 p = r.org + hb.t * r.dir;
        const CurvePoint c = sweep.curve_point(hb.segment, hb.u);
        EXPECT_NEAR(length(p - c.p), c.r, 1e-5) << i;
        EXPECT_NEAR(dot(p - c.p, normalize(c.dp)), 0.0, 1e-5) << i;
        EXPECT_NEAR(hb.segment + hb.u, ha.segment + ha.u, 1e-3) << i;
    }
    EXPECT_GT(hits, 5000);
    EXPECT_LE(disagreements, hits / hits_per_disagreement) << hits;
    EXPECT_LE(t_mismatch, hits / hits_per_disagreement) << hits;
    EXPECT_LE(occlusion_disagreements, n / rays_per_occlusion_disagreement);
    EXPECT_EQ(stream_mismatch, 0);
}

// Newton's method may lose a hit or find the second where the tube folds on itself at such bends:
// 5 in 11 554 hits here (17 before the passes by nearly straight pieces), so at most one per thousand.
TEST(RenderGeometry, SweepIntersectorFindsEmbreesCatmullRomHits) { expect_sweep_finds_embrees_hits(false, false, 1000, 1000); }

// Known gap (issue 29): rays that start inside another strand's tube. Embree reports that tube's
// far wall a little way along the ray; Sweep misses some of these and finds a farther hit. A proxy
// that holds the ray's origin offers only its exit, which lies past the tube's far wall: where a
// farther hit was accepted first, Embree culls that exit by tfar and never offers it (the exact
// test's later steps do find these far walls: SweepLaterStepsFindEmbreesHits). Where the
// neighbouring segment's proxy finds the root past its joined end, the filter tests the segment it
// lies on (without that: 375 and 70 disagreements, 21 and 28 occlusion answers), and where that
// finds none, this piece's later steps decide (without that: 298 and 34, 10 and 10).
// Now 265 of 10 382 hits on the bent strands and 13 of 10 739 on the thin ones; 0 and 2 occlusion
// answers of 20 000. The bounds sit between, so that losing more of these fails.
TEST(RenderGeometry, SweepIntersectorFindsEmbreesHitsFromNearTheStrands) {
    expect_sweep_finds_embrees_hits(true, false, 36, 5000);
}

TEST(RenderGeometry, SweepIntersectorFindsEmbreesHitsOnThinStrands) {
    expect_sweep_finds_embrees_hits(false, true, 1000, 1000);
    expect_sweep_finds_embrees_hits(true, true, 500, 5000);
}

// Embree's and Sweep's answers to the rays next_ray(0 .. n - 1), without skips: a hit on another primitive or
// none (a disagreement), a curve hit whose distance differs by more than 1e-4, an occlusion answer that differs.
struct IntersectorComparison {
    int hits = 0, disagreements = 0, t_mismatch = 0, occlusion_disagreements = 0;
};
template <class NextRay>
static IntersectorComparison compare_intersectors(const Geometry& embree, const Geometry& sweep, int n,
                                                  NextRay next_ray) {
    IntersectorComparison c;
    for (int i = 0; i < n; ++i) {
        const Ray r = next_ray();
        const Hit ha = embree.intersect(r, {}), hb = sweep.intersect(r, {});
        c.occlusion_disagreements += embree.occluded(r, {}) != sweep.occluded(r, {});
        if (bool(ha) != bool(hb) || (ha && (ha.kind != hb.kind || ha.prim != hb.prim))) {
            ++c.disagreements;
            continue;
        }
        if (!ha || ha.kind != PrimKind::Curve) continue;
        ++c.hits;
        c.t_mismatch += std::fabs(ha.t - hb.t) > 1e-4;
    }
    return c;
}

// At least `min_hits` curve hits, and at most one disagreement (hit or distance) per thousand of them and one
// occlusion answer per thousand rays.
static void expect_intersectors_agree(const IntersectorComparison& c, int n, int min_hits, const char* what) {
    EXPECT_GT(c.hits, min_hits) << what;
    EXPECT_LE(c.disagreements, c.hits / 1000) << what << " " << c.hits;
    EXPECT_LE(c.t_mismatch, c.hits / 1000) << what;
    EXPECT_LE(c.occlusion_disagreements, n / 1000) << what;
}

// In an object's space under a scale and a shear, where the ray's direction in that space is no unit
// vector: Sweep finds Embree's hits on the same strands in the same instance (the thin ones and the
// bent ones), as in world space: 7 of 9 831 hits and 3 of 11 418 disagree, no occlusion answer. With
// capped-cone proxies there too (Embree 3.13's cone intersector takes the direction to be a unit vector)
// 1 856 and 242 hits disagreed, and 332 and 18 occlusion answers.
TEST(RenderGeometry, SweepIntersectorFindsEmbreesHitsInScaledAndShearedObjects) {
    const std::array<double, 12> world_from_object = {1.3, 0.4, 0, 0.1, 0, 1.1, 0.3, -0.2, 0.2, 0, 0.8, 0};
    for (bool thin : {true, false}) {
        SceneDesc a = bent_strands(CurveIntersector::Embree, 7, thin), b = bent_strands(CurveIntersector::Sweep, 7, thin);
        for (SceneDesc* s : {&a, &b}) {
            s->curves.object.assign(s->curves.random.size(), 0);
            s->curves.object_transforms = {world_from_object};
        }
        const Geometry embree(a), sweep(b);
        const ObjectSpace& space = *sweep.curve_object_space(0);
        TestRandom random{99};
        const int n = 20000;
        const IntersectorComparison c = compare_intersectors(embree, sweep, n, [&] {
            const Vec3 target = space.point_to_world({2 * random.next() - 1, 1.4 * random.next() - 0.7,
                                                      0.8 * random.next() - 0.4});
            const Vec3 d = random.direction();
            return ray(target - 3.0 * d, d);
        });
        expect_intersectors_agree(c, n, 5000, thin ? "thin" : "bent");
    }
}

// The exact test's later steps alone (the passes by nearly straight pieces, the bent pieces'
// parts, the careful search), with Newton's first steps skipped (`quick_steps` 0): a render's
// proxy hits lie so near the tube that those first steps decide nearly every candidate, and the
// tests above reach the passes' entry and exit steps too rarely for a fault there to fail them.
// Each strand of the bent strands (or `thin` ones) alone, so that Embree's round Catmull-Rom
// curve is the reference: the nearest hit over all of the strand's pieces must be Embree's (the
// same distance and centre-line point; for a ray from inside, the far wall), and a miss a miss.
// Rays aimed within 1.5 radii of a random point of the centre line, from afar or (`from_near`)
// from that point, inside the tube or not; or (`grazing`) past the tube's side, 0.7-1.05 radii
// from the centre line, across it. Returns the disagreements; `hits` receives Embree's hits.
enum class LaterStepsRays { FromAfar, FromNear, Grazing };

static int sweep_later_steps_disagreements(LaterStepsRays rays, bool thin, int& hits) {
    const SceneDesc all = bent_strands(CurveIntersector::Embree, 11, thin);
    TestRandom random{5};
    auto next = [&] { return random.next(); };
    auto random_direction = [&] { return random.direction(); };
    int disagreements = 0;
    hits = 0;
    for (size_t c = 0; c + 1 < std::min<size_t>(all.curves.offsets.size(), 49); ++c) {
        SceneDesc one;
        one.curve_shape = CurveShape::Thick;
        one.curves.offsets = {0};
        for (int32_t k = all.curves.offsets[c]; k < all.curves.offsets[c + 1]; ++k)
            one.curves.points.push_back(all.curves.points[size_t(k)]);
        one.curves.offsets.push_back(int32_t(one.curves.points.size()));
        one.curves.random = {0.5f};
        one.curves.material = {0};
        const Geometry embree(one);
        const std::vector<std::array<float, 4>> control_points = strand_control_points(one, 0);
        const int segments = int(one.curves.points.size()) - 1;
        for (int i = 0; i < 300; ++i) {
            const int aim_segment = std::min(int(next() * segments), segments - 1);
            const CurvePoint aim = embree.curve_point(aim_segment, next());
            Vec3 target = aim.p + (1.5 * next() * aim.r) * random_direction();
            Vec3 d = random_direction();
            if (rays == LaterStepsRays::Grazing) {
                const Vec3 tangent = normalize(aim.dp);
                const Vec3 n = normalize(cross(tangent, random_direction())), b = cross(tangent, n);
                target = aim.p + ((0.7 + 0.35 * next()) * aim.r) * n;
                const double a = 0.6 * (2 * next() - 1);
                d = std::cos(a) * b + std::sin(a) * tangent;
            }
            const Ray r = ray(rays == LaterStepsRays::FromNear ? target : target - 3.0 * d, d);
            const Hit expected = embree.intersect(r, SkipPrim{});
            SweepHit nearest;
            int nearest_segment = -1;
            for (int segment = 0; segment < segments; ++segment)
                for (int j = 0; j < curve_proxy_pieces; ++j) {
                    const SweepPiece piece =
                        proxy_piece(control_points.data() + segment, j, segment == 0, segment + 1 == segments);
                    const double t_max = nearest.hit ? nearest.t : std::numeric_limits<double>::infinity();
                    const SweepHit found = intersect_sweep(piece, r.org, r.dir, 0.0, 0.5 * (piece.u_begin + piece.u_end),
                                                           r.tmin, t_max, 0);
                    if (found.hit && (!nearest.hit || found.t < nearest.t)) {
                        nearest = found;
                        nearest_segment = segment;
                    }
                }
            hits += bool(expected);
            if (bool(expected) != nearest.hit ||
                (nearest.hit && (std::fabs(expected.t - nearest.t) > 1e-4 ||
                                 std::fabs(expected.segment + expected.u - (nearest_segment + nearest.u)) > 1e-3)))
                ++disagreements;
        }
    }
    return disagreements;
}

// 4, 9 and 12 disagreements in about 13 000 hits on the bent strands, 6, 8 and 24 on the thin ones
// (Embree's grazing hits and misses at float rounding). Planted faults fail it: the pass's entry step
// taken as a miss (12 900 on the bent strands from afar), its exit step as a miss (11 300 from near),
// the entry and exit told apart the wrong way round (850-9 000), the pass's undecided cases taken as
// misses instead of going on to the careful search (45 and 52).
TEST(RenderGeometry, SweepLaterStepsFindEmbreesHits) {
    struct Case {
        LaterStepsRays rays;
        int hits_per_disagreement;
    };
    for (bool thin : {false, true})
        for (const Case& c : {Case{LaterStepsRays::FromAfar, 1000}, Case{LaterStepsRays::FromNear, 500},
                              Case{LaterStepsRays::Grazing, 300}}) {
            int hits = 0;
            const int disagreements = sweep_later_steps_disagreements(c.rays, thin, hits);
            EXPECT_GT(hits, 10000) << thin << int(c.rays);
            EXPECT_LE(disagreements, hits / c.hits_per_disagreement) << "thin " << thin << ", rays " << int(c.rays);
        }
}

// The exact test's AVX2 + FMA build (scalar_avx2, math_simd.h) gives the baseline build's answers to
// FMA rounding: on each bent strand's pieces, rays aimed within 1.5 radii of its centre line from
// afar and from there, with Newton's first steps and without. The same hit or miss (a grazing ray
// may flip: at most one in 2 000) and, for a hit, t and u within 1e-9 and the normal within 1e-6;
// and the switch takes effect (not bit for bit) where the CPU has AVX2 and FMA. Measured: 3 239 hits in
// 3 840 calls, none flipped, none apart. Planted faults fail it: t 1e-8 longer in the AVX2 build (3 239
// apart), the switch ignored (no difference).
TEST(RenderGeometry, SweepAvx2BuildMatchesTheBaseline) {
    const SceneDesc all = bent_strands(CurveIntersector::Embree, 13);
    TestRandom random{17};
    struct Call {
        SweepPiece piece;
        Vec3 org, dir;
        double t_start, u_start;
        int quick_steps;
    };
    std::vector<std::vector<std::array<float, 4>>> strands;
    for (size_t c = 0; c + 1 < all.curves.offsets.size(); ++c) strands.push_back(strand_control_points(all, c));
    std::vector<Call> calls;
    for (const auto& cp : strands) {
        const int segments = int(cp.size()) - 3;
        for (int i = 0; i < 80; ++i) {
            const int segment = std::min(int(random.next() * segments), segments - 1);
            const SweepPiece piece = proxy_piece(cp.data() + segment, int(random.next() * curve_proxy_pieces),
                                                 segment == 0, segment + 1 == segments);
            const double u = piece.u_begin + (piece.u_end - piece.u_begin) * random.next();
            const CurvePoint c = catmull_rom(piece.control_points, u);
            const Vec3 target = c.p + (1.5 * random.next() * c.r) * random.direction(), d = random.direction();
            const bool from_near = i % 2 == 1;
            calls.push_back({piece, from_near ? target : target - 3.0 * d, d, from_near ? 0.0 : 3.0, u, i % 3 == 0 ? 0 : 7});
        }
    }
    auto run = [&] {
        std::vector<SweepHit> out;
        for (const Call& c : calls)
            out.push_back(intersect_sweep(c.piece, c.org, c.dir, c.t_start, c.u_start, 1e-6, 1e30, c.quick_steps));
        return out;
    };
    const bool avx2 = set_scalar_avx2(true);
    const std::vector<SweepHit> dispatched = run();
    EXPECT_FALSE(set_scalar_avx2(false));
    const std::vector<SweepHit> baseline = run();
    set_scalar_avx2(true);
    int hits = 0, flipped = 0, far_apart = 0;
    bool differs = false;
    for (size_t i = 0; i < calls.size(); ++i) {
        const SweepHit &a = dispatched[i], &b = baseline[i];
        hits += b.hit;
        if (a.hit != b.hit) {
            ++flipped;
            continue;
        }
        if (!a.hit) continue;
        differs = differs || a.t != b.t || a.u != b.u || a.normal.x != b.normal.x;
        if (std::fabs(a.t - b.t) > 1e-9 || std::fabs(a.u - b.u) > 1e-9 || length(a.normal - b.normal) > 1e-6 ||
            a.front != b.front)
            ++far_apart;
    }
    EXPECT_GT(hits, 1000);
    EXPECT_LE(flipped, int(calls.size()) / 2000);
    EXPECT_EQ(far_apart, 0);
    EXPECT_EQ(differs, avx2);
}

// Each piece's proxy (sweep_proxy_cone) holds its piece of the tube: on every piece of the bent and
// the thin strands, 33 circles across the piece's u (its ends included), 16 points on each, lie in
// the capped cone, along its axis and across it. Planted faults fail it: the axis not extended
// past the chord's ends, or the radii not widened by the centre line's stray from the chord (each
// also fails SweepIntersectorFindsEmbreesHitsFromNearTheStrands). The radius slope's share of the
// widening is a bound no fault here reaches: without it these pieces still fit.
TEST(RenderGeometry, SweepProxyConesHoldTheirPiecesOfTheTube) {
    for (bool thin : {false, true}) {
        const SceneDesc s = bent_strands(CurveIntersector::Sweep, 3, thin);
        int outside = 0, points = 0;
        for (size_t c = 0; c + 1 < s.curves.offsets.size(); ++c) {
            const std::vector<std::array<float, 4>> cp = strand_control_points(s, c);
            for (size_t segment = 0; segment + 3 < cp.size(); ++segment)
                for (int j = 0; j < curve_proxy_pieces; ++j) {
                    const SweepPiece piece = proxy_piece(&cp[segment], j, segment == 0, segment + 4 == cp.size());
                    const double u0 = piece.u_begin, u1 = piece.u_end;
                    const SweepProxyCone cone = sweep_proxy_cone(piece);
                    const Vec3 axis = cone.end - cone.begin;
                    const double length_axis = length(axis);
                    const Vec3 e = (1.0 / length_axis) * axis;
                    for (int i = 0; i <= 32; ++i) {
                        // The circle at u (the geometry's Catmull-Rom curve, not the exact test's cubic).
                        const CurvePoint at = catmull_rom(&cp[segment], u0 + (u1 - u0) * i / 32);
                        Vec3 n1, n2;
                        make_orthonormals(normalize(at.dp), n1, n2);
                        for (int a = 0; a < 16; ++a) {
                            const double angle = 6.283185307179586 * a / 16;
                            const Vec3 q = at.p + at.r * (std::cos(angle) * n1 + std::sin(angle) * n2);
                            const double along = dot(q - cone.begin, e);
                            const double across = length(q - cone.begin - along * e);
                            const double radius =
                                cone.begin_radius + (cone.end_radius - cone.begin_radius) * along / length_axis;
                            ++points;
                            outside += !(along >= 0 && along <= length_axis && across <= radius);
                        }
                    }
                }
        }
        EXPECT_GT(points, 100000) << thin;
        EXPECT_EQ(outside, 0) << "thin " << thin << ": " << outside << " of " << points;
    }
}

// curve_intersector AUTO (the default): Sweep for THICK curves in world space up to sweep_auto_max_segments segments,
// Embree's own curves beyond (Sweep's proxies' memory), for curves in an object's space (where Embree's, like
// Cycles', reach past a strand's end) and for every other shape; EMBREE and SWEEP hold at any size.
TEST(RenderGeometry, AutoIntersectorTakesSweepUpToItsBound) {
    constexpr size_t bound = sweep_auto_max_segments;
    EXPECT_TRUE(uses_sweep(CurveShape::Thick, CurveIntersector::Auto, bound, false));
    EXPECT_FALSE(uses_sweep(CurveShape::Thick, CurveIntersector::Auto, bound + 1, false));
    EXPECT_FALSE(uses_sweep(CurveShape::Thick, CurveIntersector::Auto, 1, true));
    EXPECT_TRUE(uses_sweep(CurveShape::Thick, CurveIntersector::Sweep, bound + 1, true));
    EXPECT_FALSE(uses_sweep(CurveShape::Thick, CurveIntersector::Embree, 1, false));
    for (CurveShape shape : {CurveShape::Ribbons, CurveShape::ThickLinear})
        EXPECT_FALSE(uses_sweep(shape, CurveIntersector::Auto, 1, false));
    EXPECT_EQ(SceneDesc{}.curve_intersector, CurveIntersector::Auto);
    // A small scene: the default builds Sweep's proxies, EMBREE does not.
    SceneDesc s = bent_strands(CurveIntersector::Auto, 5);
    EXPECT_TRUE(Geometry(s).sweep_curves());
    s.curve_intersector = CurveIntersector::Embree;
    EXPECT_FALSE(Geometry(s).sweep_curves());
    s.curve_intersector = CurveIntersector::Auto;  // one strand in an object's space: Embree's curves for all
    s.curves.object.assign(s.curves.random.size(), -1);
    s.curves.object[0] = 0;
    s.curves.object_transforms = {{1.3, 0.4, 0, 0.1, 0, 1.1, 0.3, -0.2, 0.2, 0, 0.8, 0}};
    EXPECT_FALSE(Geometry(s).sweep_curves());
}

// Repeated keys (a strand's last key three more times, a middle key once more, as exported particle hair can
// have them): a segment between coinciding keys is no tube Sweep's exact test holds, and where its centre line
// stays at the key Embree's surface is a ball of radius r, which Cycles renders. Sweep leaves such segments to Embree's own
// curves (sweep_leaves_to_embree), so it finds Embree's hits there, in world space and in a sheared instance.
// Half of the rays aim within 1.5 radii of a repeated key. World space: 1 of 11 727 hits disagrees and 6 distances;
// instanced: 7 of 11 472 and 9. With every segment to Sweep (the exact test misses the ball) 70 and 68 hits
// disagree, 64 and 69 distances, and 5 and 13 occlusion answers: it fails. (The harness's particle hair in a sheared
// parent, test_engine_transforms.py, lost 2.4 % of its projected area that way.)
TEST(RenderGeometry, SweepLeavesSegmentsOfRepeatedKeysToEmbree) {
    const std::array<double, 12> world_from_object = {1.3, 0.4, 0, 0.1, 0, 1.1, 0.3, -0.2, 0.2, 0, 0.8, 0};
    for (bool instanced : {false, true}) {
        SceneDesc a = bent_strands(CurveIntersector::Embree, 7);
        std::vector<std::array<float, 4>> points;
        std::vector<int32_t> offsets{0};
        std::vector<Vec3> repeated;
        for (size_t c = 0; c + 1 < a.curves.offsets.size(); ++c) {
            const int32_t b = a.curves.offsets[c], e = a.curves.offsets[c + 1], middle = (b + e) / 2;
            for (int32_t k = b; k < e; ++k) {
                points.push_back(a.curves.points[size_t(k)]);
                if (k == middle) points.push_back(a.curves.points[size_t(k)]);
            }
            for (int j = 0; j < 3; ++j) points.push_back(a.curves.points[size_t(e - 1)]);
            offsets.push_back(int32_t(points.size()));
            for (int32_t k : {middle, e - 1}) {
                const auto& p = a.curves.points[size_t(k)];
                repeated.push_back({p[0], p[1], p[2]});
            }
        }
        a.curves.points = points;
        a.curves.offsets = offsets;
        if (instanced) {
            a.curves.object.assign(a.curves.random.size(), 0);
            a.curves.object_transforms = {world_from_object};
        }
        SceneDesc b = a;
        b.curve_intersector = CurveIntersector::Sweep;
        const Geometry embree(a), sweep(b);
        const ObjectSpace* space = sweep.curve_object_space(0);
        auto to_world = [&](Vec3 p) { return space ? space->point_to_world(p) : p; };
        TestRandom random{17};
        const int n = 20000;
        int i = 0;
        const IntersectorComparison c = compare_intersectors(embree, sweep, n, [&] {
            Vec3 target{2 * random.next() - 1, 1.4 * random.next() - 0.7, 0.8 * random.next() - 0.4};
            if (i++ % 2 == 0)
                target = repeated[size_t(random.next() * double(repeated.size())) % repeated.size()] +
                         (1.5 * 0.06 * random.next()) * random.direction();
            const Vec3 d = random.direction();
            return ray(to_world(target) - 3.0 * d, d);
        });
        expect_intersectors_agree(c, n, 8000, instanced ? "instanced" : "world space");
    }
}
