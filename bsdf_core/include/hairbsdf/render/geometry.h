// Ray tracing of curves and triangles with Embree 3, with Cycles' curve semantics
// (docs/cycles.md §3): uniform Catmull-Rom strands through the keys with duplicated
// end keys, radius interpolated the same way; THICK = Embree's round curves, open at the
// ends, whose inside is hit too: Cycles' CPU build sets Embree's BACKFACE_CULLING_CURVES,
// but Embree applies it only to round *linear* curves, not to the Catmull-Rom sweep (a
// shadow ray entering a tube through its open end is blocked by the far wall in Cycles 4.5
// renders). SceneDesc::cull_curve_back_faces = true emulates culling with an intersection
// filter that rejects hits whose geometric normal faces along the ray (Debian's Embree
// 3.13 has no culling option); RIBBONS = Embree's ray-facing flat curves
// (Embree itself ignores flat-curve hits closer than 2 r, as Cycles' build does) with
// tessellation rate 2^subdivisions + 1 as Cycles passes it; THICK_LINEAR (Blender 5.x's
// Linear 3D Curves) = Embree's round linear curves through the keys, whose neighbour flags
// Embree derives from the index buffer as in Cycles' build. A ray leaving a primitive
// skips it: all of a curve, or one triangle. THICK with SceneDesc::curve_intersector = Sweep
// (or Auto, below): the same surface, found by our own test over Embree's capped-cone proxies
// (curve_sweep.h).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "hairbsdf/render/scene.h"

struct RTCRayHit;  // Embree's ray and hit (embree3/rtcore_ray.h)

namespace hairbsdf::render {

// CurveIntersector::Auto takes Sweep for THICK curves of at most this many segments, all in world
// space. Sweep's proxies take about 310 bytes a segment more than Embree's own curves (100 000
// strands of 12 keys: 447 MB against 105 MB, docs/benchmarks.md "Engine IX"), so at this bound
// about 620 MB more; larger grooms keep Embree's memory (1M strands x 16 keys: docs/benchmarks.md).
// Curves in an object's space (a non-uniform transform) keep Embree's own curves: there Embree's
// round curves reach past a strand's end, as in Cycles, and Sweep's stop at it (docs/engine.md,
// "Curve intersection").
inline constexpr size_t sweep_auto_max_segments = 2'000'000;
// Whether THICK curves of `segments` segments are intersected by Sweep.
inline bool uses_sweep(CurveShape shape, CurveIntersector intersector, size_t segments, bool curves_in_object_space) {
    if (shape != CurveShape::Thick) return false;
    return intersector == CurveIntersector::Sweep ||
           (intersector == CurveIntersector::Auto && segments <= sweep_auto_max_segments && !curves_in_object_space);
}

struct Ray {
    Vec3 org, dir;  // dir is a unit vector
    double tmin = 0, tmax = 1e30;
    // Compact ray differentials (Cycles' differential_make_compact): the footprint of one
    // pixel at the origin (dP) and its growth per unit distance (dD). Camera rays only.
    double dP = 0, dD = 0;
};

enum class PrimKind : uint8_t { None, Curve, Triangle };

// The primitive a ray leaves; its hits are ignored (Cycles' self-intersection skip).
struct SkipPrim {
    PrimKind kind = PrimKind::None;
    int id = -1;  // curve index or triangle index
};

struct Hit {
    PrimKind kind = PrimKind::None;
    double t = 0;
    int prim = -1;     // curve index or triangle index
    int segment = -1;  // global curve segment index (curves)
    double u = 0, v = 0;  // Embree's: segment parameter and (flat curves) v in [-1, 1]; barycentrics (triangles)
    Vec3 ng;           // Embree's geometric normal, not normalised
    explicit operator bool() const { return kind != PrimKind::None; }
};

// An object's space for curves kept there (CurveData::object): world-from-object and its
// inverse, row-major 3 x 4.
struct ObjectSpace {
    std::array<double, 12> to_world{}, to_object{};
    explicit ObjectSpace(const std::array<double, 12>& world_from_object);
    Vec3 point_to_object(Vec3 p) const;
    Vec3 point_to_world(Vec3 p) const;
    Vec3 direction_to_object(Vec3 d) const;
    Vec3 direction_to_world(Vec3 d) const;
    Vec3 normal_to_world(Vec3 n) const;  // by the inverse transpose, not normalised
};

// A point on a curve's centre line: position, radius and their derivatives in u.
struct CurvePoint {
    Vec3 p, dp;
    double r = 0, dr = 0;
};

class Geometry {
public:
    // Builds the Embree scene (inside the caller's TBB arena). Throws std::runtime_error
    // if Embree fails. BVH settings are Cycles' defaults (Embree build quality MEDIUM:
    // spatial splits off; compact, robust scene).
    explicit Geometry(const SceneDesc& scene);
    // The same, but frees scene.curves.points once the keys are copied into Embree's vertex
    // buffer and before the BVH build, so that the keys are held once, not twice, at the
    // memory peak (the renderer uses only the per-curve arrays of the SceneDesc afterwards).
    struct ReleaseCurvePoints {};
    Geometry(SceneDesc& scene, ReleaseCurvePoints);
    ~Geometry();
    Geometry(const Geometry&) = delete;
    Geometry& operator=(const Geometry&) = delete;

    Hit intersect(const Ray& ray, SkipPrim skip) const;
    // Camera rays as one coherent stream (rtcIntersect1M; integrator.camera_ray_stream): the
    // same hits as intersect(rays[i], {}) each, traced as Embree packets.
    void intersect_stream(const Ray* rays, Hit* hits, size_t count) const;
    // Rays that each skip their own primitive, as one incoherent stream (rtcIntersect1M; the
    // wavefront's bounce rays): hits[i] = intersect(rays[i], skips[i]) at float rounding (Embree's
    // stream code may return a hit one rounding step away). Null skips: the coherent stream above.
    void intersect_stream(const Ray* rays, const SkipPrim* skips, Hit* hits, size_t count) const;
    // `light_triangle`: a triangle the ray aims at (an emissive-triangle light sample), ignored.
    bool occluded(const Ray& ray, SkipPrim skip, int light_triangle = -1) const;
    // Shadow rays as one stream (rtcOccluded1M; the wavefront):
    // occluded[i] = occluded(rays[i], skips[i], light_triangles[i]).
    void occluded_stream(const Ray* rays, const SkipPrim* skips, const int* light_triangles, uint8_t* occluded,
                         size_t count) const;

    CurveShape curve_shape() const { return shape_; }
    // THICK curves intersected by Sweep (CurveIntersector::Sweep, or Auto's choice).
    bool sweep_curves() const;
    int segment_curve(int segment) const { return segment_curve_[size_t(segment)]; }
    // Index into the scene's points of the segment's first key (every curve of a repaired
    // scene has at least 2 keys, so curve c's control points start at offsets[c] + 2 c).
    int segment_key(int segment) const {
        return int(segment_first_[size_t(segment)]) - 2 * segment_curve_[size_t(segment)];
    }
    // In the curve's own space: world space, or its object's space when curve_object_space
    // is not null.
    CurvePoint curve_point(int segment, double u) const;
    const ObjectSpace* curve_object_space(int curve) const {
        return curve_object_.empty() || curve_object_[size_t(curve)] < 0
                   ? nullptr
                   : &object_spaces_[size_t(curve_object_[size_t(curve)])];
    }
    // The key radius interpolated linearly in u (what Cycles' Huang near field uses).
    double curve_radius_linear(int segment, double u) const;
    // The curve normal interpolated linearly in u; zero when the scene has no normals.
    Vec3 curve_normal(int segment, double u) const;

    // Bytes Embree allocated, at most, while this scene existed; plus our own buffers.
    size_t peak_memory_bytes() const;
    bool empty() const { return !has_curves_ && !has_triangles_; }

private:
    void build(const SceneDesc& scene, std::vector<std::array<float, 4>>* release_points);
    Hit to_hit(const RTCRayHit& rh) const;  // Embree's answer to one ray as our Hit
    struct Impl;
    void build_sweep_proxies(Impl& im);
    uint32_t segment_of_prim(uint32_t prim) const;
    std::unique_ptr<Impl> impl_;
    CurveShape shape_ = CurveShape::Thick;
    bool has_curves_ = false, has_triangles_ = false;
    std::vector<std::array<float, 4>> control_points_;  // Embree's vertex buffer: per curve n + 2 points
    std::vector<uint32_t> segment_first_;               // Embree's index buffer: first control point
    std::vector<int32_t> segment_curve_;                // curve of each segment
    std::vector<std::array<float, 3>> normals_;         // per control point, when the scene has normals
    std::vector<int32_t> curve_object_;                 // per curve (CurveData::object), or empty
    std::vector<ObjectSpace> object_spaces_;
};

// Uniform Catmull-Rom through four control points (position and radius in xyz/w).
CurvePoint catmull_rom(const std::array<float, 4>* cp, double u);
// The straight segment from cp[1] to cp[2] (Linear 3D Curves), with the same four control points.
CurvePoint linear_segment(const std::array<float, 4>* cp, double u);

// Cycles-style origin offset for rays leaving a triangle: pushes `p` along the geometric
// normal `ng` (pointing to the side the ray leaves on) by a few float ULPs of p.
Vec3 offset_ray_origin(Vec3 p, Vec3 ng);

}  // namespace hairbsdf::render
