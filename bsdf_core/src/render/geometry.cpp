// Embree 3 scene of curves and triangles; see render/geometry.h.
#include "hairbsdf/render/geometry.h"

#include <embree3/rtcore.h>

#include "hairbsdf/render/curve_sweep.h"

#include <algorithm>
#include <cfloat>
#include <cstring>
#include <stdexcept>
#include <string>

namespace hairbsdf::render {

namespace {

// Embree's ray query context, extended with the primitive the ray must skip.
struct QueryContext {
    RTCIntersectContext rtc;
    SkipPrim skip;
    int light_triangle = -1;  // shadow rays towards an emissive triangle skip it (Cycles' light_prim)
    // A stream of rays with their own skips (the wavefront): indexed by the ray's id; null: the above.
    const SkipPrim* skips = nullptr;
    const int* light_triangles = nullptr;
    // The nearest hit accepted so far, by ray id (a single ray has id 0), starting at the ray's
    // tfar: the Sweep filter needs it, since Embree hands a filter the candidate's proxy
    // distance in tfar, not the distance of the hit it would replace. Both arrays are set up
    // only in a scene with Sweep curves; null otherwise.
    float* nearest = nullptr;
    // The proxy piece (global index + 1) whose last candidate the Sweep filter rejected, by ray
    // id: Embree offers a proxy's entry and exit separately.
    uint32_t* rejected_piece = nullptr;
};

// The Sweep filter's per-ray arrays for a stream of rays, kept per thread (they grow to the longest
// stream, then are reused); `attach` points the context at them for `count` rays, each ray's
// `nearest` still to be set to its tfar.
struct SweepStreamState {
    std::vector<float> nearest;
    std::vector<uint32_t> rejected_piece;
    void attach(QueryContext& ctx, size_t count) {
        nearest.resize(count);
        rejected_piece.assign(count, 0);
        ctx.nearest = nearest.data();
        ctx.rejected_piece = rejected_piece.data();
    }
};

// Every accepted hit lowers the ray's `nearest` (kept only in a scene with Sweep curves).
void note_accepted(const QueryContext* ctx, const RTCFilterFunctionNArguments* args, unsigned i) {
    if (ctx->nearest) ctx->nearest[RTCRayN_id(args->ray, args->N, i)] = RTCRayN_tfar(args->ray, args->N, i);
}

// The primitive ray `i` of a filter call skips, and the light triangle it aims at.
SkipPrim ray_skip(const QueryContext* ctx, const RTCFilterFunctionNArguments* args, unsigned i) {
    return ctx->skips ? ctx->skips[RTCRayN_id(args->ray, args->N, i)] : ctx->skip;
}
int ray_light_triangle(const QueryContext* ctx, const RTCFilterFunctionNArguments* args, unsigned i) {
    return ctx->light_triangles ? ctx->light_triangles[RTCRayN_id(args->ray, args->N, i)] : ctx->light_triangle;
}

struct MemoryCounter {
    std::atomic<long long> current{0};
    std::atomic<long long> peak{0};
};

bool memory_monitor(void* user, ssize_t bytes, bool /*post*/) {
    auto* m = static_cast<MemoryCounter*>(user);
    const long long now = m->current.fetch_add(bytes) + bytes;
    long long peak = m->peak.load();
    while (now > peak && !m->peak.compare_exchange_weak(peak, now)) {
    }
    return true;
}

// Filters shared by intersect and occluded queries: single rays (N = 1), and the packets of a
// coherent camera-ray stream (N = 4 to 16; every ray of a stream has the same context). The
// wavefront's streams give each ray its own skip, looked up by the ray's id.
template <bool kCullBackFaces>
void curve_filter(const RTCFilterFunctionNArguments* args) {
    const auto* ctx = reinterpret_cast<const QueryContext*>(args->context);
    // The geometry's user data: the curve of each of its segments (primID counts from the
    // geometry's first segment). For curves in object space, Embree passes the ray and Ng of
    // that space, so the back-face sign below is the world's.
    const auto* segment_curve = static_cast<const int32_t*>(args->geometryUserPtr);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] == 0) continue;
        const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
        const SkipPrim skip = ray_skip(ctx, args, i);
        if (skip.kind == PrimKind::Curve && segment_curve[prim] == skip.id) {
            args->valid[i] = 0;
            continue;
        }
        if (kCullBackFaces) {
            const float d = RTCRayN_dir_x(args->ray, args->N, i) * RTCHitN_Ng_x(args->hit, args->N, i) +
                            RTCRayN_dir_y(args->ray, args->N, i) * RTCHitN_Ng_y(args->hit, args->N, i) +
                            RTCRayN_dir_z(args->ray, args->N, i) * RTCHitN_Ng_z(args->hit, args->N, i);
            if (d > 0.0f) {
                args->valid[i] = 0;  // back face
                continue;
            }
        }
        note_accepted(ctx, args, i);
    }
}

// A Sweep geometry's user data: its segments' curves and keys (Geometry's arrays) and where
// its segments start; proxy piece p is piece p % k of segment first_segment + p / k.
struct SweepGeometry {
    const std::array<float, 4>* control_points;
    const uint32_t* segment_first;
    const int32_t* segment_curve;
    // bit 0: the curve's first segment, or one after a segment Embree's curves hold; bit 1: the last, or one before
    // such a segment (the tube stops there for Sweep); bit 2: Embree's curves hold this segment
    const uint8_t* segment_ends;
    uint32_t first_segment;
};

// Round Catmull-Rom curves by their proxies: each candidate proxy hit is replaced by the
// tube's own hit (render/curve_sweep.h), or rejected. The filter writes the tube's distance
// into tfar (Embree then culls by it), the segment's u and the surface normal into the hit.
template <bool kCullBackFaces>
void sweep_filter(const RTCFilterFunctionNArguments* args) {
    const auto* ctx = reinterpret_cast<const QueryContext*>(args->context);
    const auto* geometry = static_cast<const SweepGeometry*>(args->geometryUserPtr);
    constexpr int k = curve_proxy_pieces;
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] == 0) continue;
        const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
        const uint32_t segment = geometry->first_segment + prim / k;
        const int piece = int(prim % k);
        const SkipPrim skip = ray_skip(ctx, args, i);
        if (skip.kind == PrimKind::Curve && geometry->segment_curve[segment] == skip.id) {
            args->valid[i] = 0;
            continue;
        }
        const uint32_t global_piece = geometry->first_segment * k + prim + 1;
        uint32_t& rejected = ctx->rejected_piece[RTCRayN_id(args->ray, args->N, i)];
        if (rejected == global_piece) {
            args->valid[i] = 0;
            continue;
        }
        const uint8_t ends = geometry->segment_ends[segment];
        if (ends & 4) {  // Embree's own curve holds this segment (its proxies have no extent)
            args->valid[i] = 0;
            continue;
        }
        const SweepPiece sweep = proxy_piece(&geometry->control_points[geometry->segment_first[segment]], piece,
                                             (ends & 1) != 0, (ends & 2) != 0);
        RTCRayN* ray = args->ray;
        const unsigned n = args->N;
        const Vec3 org{RTCRayN_org_x(ray, n, i), RTCRayN_org_y(ray, n, i), RTCRayN_org_z(ray, n, i)};
        const Vec3 dir{RTCRayN_dir_x(ray, n, i), RTCRayN_dir_y(ray, n, i), RTCRayN_dir_z(ray, n, i)};
        const float nearest = ctx->nearest[RTCRayN_id(ray, n, i)];
        const double t_start = RTCRayN_tfar(ray, n, i), u_start = (piece + RTCHitN_u(args->hit, n, i)) / k;
        SweepHit hit = intersect_sweep(sweep, org, dir, t_start, u_start, RTCRayN_tnear(ray, n, i), nearest);
        unsigned hit_prim = prim;
        if (!hit.hit && hit.past_joined_end != 0) {
            // The root lies on the joined neighbour's tube, near its end: test the neighbour's
            // end piece from there. Its own proxy may never be offered (a proxy that holds the
            // ray's origin offers only its exit, which Embree culls once a nearer hit is taken).
            const uint32_t next_segment = segment + uint32_t(hit.past_joined_end);
            const int next_piece = hit.past_joined_end < 0 ? k - 1 : 0;
            const uint8_t next_ends = geometry->segment_ends[next_segment];
            const SweepPiece neighbour = proxy_piece(&geometry->control_points[geometry->segment_first[next_segment]],
                                                     next_piece, (next_ends & 1) != 0, (next_ends & 2) != 0);
            const SweepHit on_neighbour = intersect_sweep(neighbour, org, dir, hit.t, hit.u - double(hit.past_joined_end),
                                                          RTCRayN_tnear(ray, n, i), nearest);
            if (on_neighbour.hit) {
                hit = on_neighbour;
                hit_prim = (next_segment - geometry->first_segment) * uint32_t(k) + uint32_t(next_piece);
            } else {
                // None there: Newton's first steps left for the cubic's continuation past the
                // end, which is no tube. This piece's later steps decide (for rays from near the
                // strands they find far walls and joints' inner walls that the first steps miss).
                hit = intersect_sweep(sweep, org, dir, t_start, u_start, RTCRayN_tnear(ray, n, i), nearest, 0);
            }
        }
        const float t = float(hit.t);
        if (!hit.hit || !(t <= nearest) || (kCullBackFaces && !hit.front)) {
            if (!hit.hit) rejected = global_piece;
            args->valid[i] = 0;
            continue;
        }
        RTCRayN_tfar(ray, n, i) = t;
        RTCHitN_primID(args->hit, n, i) = hit_prim;
        RTCHitN_u(args->hit, n, i) = float(hit.u);
        RTCHitN_Ng_x(args->hit, n, i) = float(hit.normal.x);
        RTCHitN_Ng_y(args->hit, n, i) = float(hit.normal.y);
        RTCHitN_Ng_z(args->hit, n, i) = float(hit.normal.z);
        note_accepted(ctx, args, i);
    }
}

void triangle_filter(const RTCFilterFunctionNArguments* args) {
    const auto* ctx = reinterpret_cast<const QueryContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] == 0) continue;
        const int prim = int(RTCHitN_primID(args->hit, args->N, i));
        const SkipPrim skip = ray_skip(ctx, args, i);
        if ((skip.kind == PrimKind::Triangle && prim == skip.id) || prim == ray_light_triangle(ctx, args, i)) {
            args->valid[i] = 0;
            continue;
        }
        note_accepted(ctx, args, i);
    }
}

void setup_ray(const Ray& ray, RTCRay& r) {
    r.org_x = float(ray.org.x);
    r.org_y = float(ray.org.y);
    r.org_z = float(ray.org.z);
    r.dir_x = float(ray.dir.x);
    r.dir_y = float(ray.dir.y);
    r.dir_z = float(ray.dir.z);
    r.tnear = float(ray.tmin);
    r.tfar = ray.tmax >= double(FLT_MAX) ? FLT_MAX : float(ray.tmax);
    r.time = 0.0f;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
}

}  // namespace

struct Geometry::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    unsigned curve_geom = RTC_INVALID_GEOMETRY_ID;
    unsigned triangle_geom = RTC_INVALID_GEOMETRY_ID;
    // Curves in object space: one instanced scene per object; the first segment of each, by the
    // instance's geomID.
    std::vector<RTCScene> object_scenes;
    std::vector<uint32_t> first_segment_by_geom;
    MemoryCounter memory;
    size_t own_bytes = 0;
    // The Sweep intersector (THICK curves, uses_sweep): per segment whether it
    // starts or ends its curve; the proxies' vertices (each piece's capped cone, two of its own)
    // and index buffer; one user-data record per Embree geometry (reserved up front: Embree keeps
    // pointers to them).
    bool sweep = false;
    std::vector<uint8_t> segment_ends;  // bit 0: the curve begins (or Embree's segment precedes); bit 1: ends; bit 2: Embree's
    // The segments Sweep leaves to Embree's own round curves (sweep_leaves_to_embree), space by space: their first
    // control points (the index buffer), curves and segment numbers; per space's geometry its first entry.
    std::vector<uint32_t> embree_first;
    std::vector<int32_t> embree_curve;
    std::vector<uint32_t> embree_segment;
    unsigned embree_geom = RTC_INVALID_GEOMETRY_ID;      // in world space
    std::vector<uint32_t> embree_offset_by_instance;     // by the instance's geomID
    unsigned embree_geom_in_instance = RTC_INVALID_GEOMETRY_ID;
    std::vector<std::array<float, 4>> proxy_vertices;
    std::vector<uint32_t> proxy_first;
    std::vector<SweepGeometry> sweep_geometries;
};

static void check_device(RTCDevice device, const char* what) {
    const RTCError err = rtcGetDeviceError(device);
    if (err != RTC_ERROR_NONE) throw std::runtime_error(std::string("Embree error ") + std::to_string(int(err)) + " in " + what);
}

Geometry::Geometry(const SceneDesc& scene) : impl_(std::make_unique<Impl>()), shape_(scene.curve_shape) {
    build(scene, nullptr);
}

Geometry::Geometry(SceneDesc& scene, ReleaseCurvePoints) : impl_(std::make_unique<Impl>()), shape_(scene.curve_shape) {
    build(scene, &scene.curves.points);
}

void Geometry::build(const SceneDesc& scene, std::vector<std::array<float, 4>>* release_points) {
    Impl& im = *impl_;
    im.device = rtcNewDevice("verbose=0");
    if (!im.device) throw std::runtime_error("Embree: rtcNewDevice failed");
    rtcSetDeviceMemoryMonitorFunction(im.device, memory_monitor, &im.memory);
    im.scene = rtcNewScene(im.device);
    rtcSetSceneFlags(im.scene, RTCSceneFlags(RTC_SCENE_FLAG_COMPACT | RTC_SCENE_FLAG_ROBUST));
    rtcSetSceneBuildQuality(im.scene, RTC_BUILD_QUALITY_MEDIUM);

    // Curves: per curve n + 2 control points (end keys duplicated), one index per segment.
    // Segments are laid out by space: world-space curves first, then each object's, so that
    // every space is one range of the index buffer and one Embree geometry.
    const CurveData& cd = scene.curves;
    const size_t n_curves = cd.curve_count();
    const bool by_object = cd.object.size() == n_curves && !cd.object_transforms.empty();
    const size_t n_spaces = 1 + (by_object ? cd.object_transforms.size() : 0);
    auto space_of = [&](size_t c) { return by_object && cd.object[c] >= 0 ? size_t(cd.object[c]) + 1 : size_t(0); };
    size_t n_segments = 0, n_cp = 0;
    for (size_t c = 0; c < n_curves; ++c) {
        const size_t n = size_t(cd.offsets[c + 1] - cd.offsets[c]);
        if (n < 2) continue;
        n_segments += n - 1;
        n_cp += n + 2;
    }
    if (n_segments > 0) {
        const bool with_normals = cd.normals.size() == cd.points.size() && !cd.normals.empty();
        control_points_.reserve(n_cp);
        if (with_normals) normals_.reserve(n_cp);
        segment_first_.reserve(n_segments);
        segment_curve_.reserve(n_segments);
        std::vector<size_t> space_first_segment(n_spaces + 1, 0);
        for (size_t space = 0; space < n_spaces; ++space) {
            space_first_segment[space] = segment_first_.size();
            for (size_t c = 0; c < n_curves; ++c) {
                const size_t b = size_t(cd.offsets[c]), e = size_t(cd.offsets[c + 1]);
                if (e - b < 2 || space_of(c) != space) continue;
                const uint32_t base = uint32_t(control_points_.size());
                control_points_.push_back(cd.points[b]);
                for (size_t k = b; k < e; ++k) control_points_.push_back(cd.points[k]);
                control_points_.push_back(cd.points[e - 1]);
                if (with_normals) {
                    normals_.push_back(cd.normals[b]);
                    for (size_t k = b; k < e; ++k) normals_.push_back(cd.normals[k]);
                    normals_.push_back(cd.normals[e - 1]);
                }
                for (size_t s = 0; s + 1 < e - b; ++s) {
                    segment_first_.push_back(base + uint32_t(s));
                    segment_curve_.push_back(int32_t(c));
                }
            }
        }
        space_first_segment[n_spaces] = segment_first_.size();
        if (by_object) {
            curve_object_ = cd.object;
            for (const auto& m : cd.object_transforms) object_spaces_.emplace_back(m);
        }
        if (release_points) std::vector<std::array<float, 4>>().swap(*release_points);
        im.sweep = uses_sweep(scene.curve_shape, scene.curve_intersector, segment_first_.size(),
                              space_first_segment[n_spaces] > space_first_segment[1]);
        if (im.sweep) build_sweep_proxies(im);
        const bool linear = scene.curve_shape == CurveShape::ThickLinear;
        const bool round = linear || scene.curve_shape == CurveShape::Thick;
        const bool cull = round && scene.cull_curve_back_faces;
        const int subdivisions = std::max(0, std::min(scene.curve_subdivisions, 4));
        // A linear segment starts at the segment's second control point (the first key is
        // duplicated for Catmull-Rom): its Embree vertex buffer starts one point later, so the
        // same index buffer serves. Segments of one curve stay consecutive there, so Embree joins
        // them, and those of different curves never do.
        const size_t vertex_skip = linear ? 1 : 0;
        im.sweep_geometries.reserve(n_spaces);
        // Embree's own curves of the scene's shape over `count` segments whose first control points are `index`
        // (segment_first_, or the part of it Sweep leaves to Embree), prim i of curve curve_of_prim[i] (the
        // filter's user data). Committed, not attached.
        auto embree_curves = [&](const uint32_t* index, size_t count, int32_t* curve_of_prim) {
            RTCGeometry g = rtcNewGeometry(im.device, linear  ? RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE
                                                      : round ? RTC_GEOMETRY_TYPE_ROUND_CATMULL_ROM_CURVE
                                                              : RTC_GEOMETRY_TYPE_FLAT_CATMULL_ROM_CURVE);
            if (!linear) rtcSetGeometryTessellationRate(g, float(std::min(1 << subdivisions, 16) + 1));
            rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, control_points_.data(),
                                       vertex_skip * sizeof(float) * 4, sizeof(float) * 4,
                                       control_points_.size() - vertex_skip);
            rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, index, 0, sizeof(uint32_t), count);
            rtcSetGeometryUserData(g, curve_of_prim);
            rtcSetGeometryIntersectFilterFunction(g, cull ? curve_filter<true> : curve_filter<false>);
            rtcSetGeometryOccludedFilterFunction(g, cull ? curve_filter<true> : curve_filter<false>);
            rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_MEDIUM);
            rtcCommitGeometry(g);
            return g;
        };
        // The proxies are capped cones (Embree's cone linear curves) in world space. In an object's space they are
        // round linear curves on the same vertices (the cones with spherical caps, so they hold the tube too):
        // Embree 3.13's cone intersector takes the ray's direction to be a unit vector, which an instance's scale
        // or shear makes it not (in an instance scaled by 1.3 it finds 793 of 10 895 hits on a thin cone, and too
        // many at 0.7); its round linear curves do not (docs/engine.md, "Curve intersection").
        auto sweep_geometry = [&](size_t first, size_t count, bool in_object_space) {
            constexpr size_t k = curve_proxy_pieces;
            RTCGeometry g = rtcNewGeometry(im.device, in_object_space ? RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE
                                                                      : RTC_GEOMETRY_TYPE_CONE_LINEAR_CURVE);
            rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, im.proxy_vertices.data(), 0,
                                       sizeof(float) * 4, im.proxy_vertices.size());
            rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, im.proxy_first.data() + first * k, 0,
                                       sizeof(uint32_t), count * k);
            im.sweep_geometries.push_back({control_points_.data(), segment_first_.data(), segment_curve_.data(),
                                           im.segment_ends.data(), uint32_t(first)});
            rtcSetGeometryUserData(g, &im.sweep_geometries.back());
            rtcSetGeometryIntersectFilterFunction(g, cull ? sweep_filter<true> : sweep_filter<false>);
            rtcSetGeometryOccludedFilterFunction(g, cull ? sweep_filter<true> : sweep_filter<false>);
            rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_MEDIUM);
            rtcCommitGeometry(g);
            return g;
        };
        // The segments of [first, first + count) that Sweep leaves to Embree (sweep_leaves_to_embree) as Embree's
        // round Catmull-Rom curves, attached to `scene`; their first entry in im.embree_* is `offset`. Returns the
        // geomID, or RTC_INVALID_GEOMETRY_ID when the space has none.
        auto attach_embree_segments = [&](RTCScene target, size_t first, size_t count, uint32_t& offset) {
            offset = uint32_t(im.embree_first.size());
            for (size_t s = first; s < first + count; ++s)
                if (im.segment_ends[s] & 4) {
                    im.embree_first.push_back(segment_first_[s]);
                    im.embree_curve.push_back(segment_curve_[s]);
                    im.embree_segment.push_back(uint32_t(s));
                }
            const size_t n = im.embree_first.size() - offset;
            if (n == 0) return RTC_INVALID_GEOMETRY_ID;
            RTCGeometry g = embree_curves(im.embree_first.data() + offset, n, im.embree_curve.data() + offset);
            const unsigned id = rtcAttachGeometry(target, g);
            rtcReleaseGeometry(g);
            return id;
        };
        if (im.sweep) {  // reserved: the geometries keep pointers into them
            size_t n_embree = 0;
            for (uint8_t e : im.segment_ends) n_embree += (e & 4) != 0;
            im.embree_first.reserve(n_embree);
            im.embree_curve.reserve(n_embree);
            im.embree_segment.reserve(n_embree);
        }
        auto curve_geometry = [&](size_t first, size_t count, bool in_object_space) {
            if (im.sweep) return sweep_geometry(first, count, in_object_space);
            return embree_curves(segment_first_.data() + first, count, segment_curve_.data() + first);
        };
        for (size_t space = 0; space < n_spaces; ++space) {
            const size_t first = space_first_segment[space], count = space_first_segment[space + 1] - first;
            if (count == 0) continue;
            RTCGeometry g = curve_geometry(first, count, space != 0);
            uint32_t embree_offset = 0;
            if (space == 0) {
                im.curve_geom = rtcAttachGeometry(im.scene, g);
                rtcReleaseGeometry(g);
                if (im.sweep) im.embree_geom = attach_embree_segments(im.scene, first, count, embree_offset);
                continue;
            }
            RTCScene object_scene = rtcNewScene(im.device);
            rtcSetSceneFlags(object_scene, RTCSceneFlags(RTC_SCENE_FLAG_COMPACT | RTC_SCENE_FLAG_ROBUST));
            rtcSetSceneBuildQuality(object_scene, RTC_BUILD_QUALITY_MEDIUM);
            rtcAttachGeometry(object_scene, g);  // geomID 0 in its scene
            rtcReleaseGeometry(g);
            if (im.sweep) {
                const unsigned id = attach_embree_segments(object_scene, first, count, embree_offset);
                if (id != RTC_INVALID_GEOMETRY_ID) im.embree_geom_in_instance = id;  // 1 in every object's scene
            }
            rtcCommitScene(object_scene);
            im.object_scenes.push_back(object_scene);
            RTCGeometry inst = rtcNewGeometry(im.device, RTC_GEOMETRY_TYPE_INSTANCE);
            rtcSetGeometryInstancedScene(inst, object_scene);
            const auto& m = cd.object_transforms[space - 1];
            float xfm[12];
            for (int i = 0; i < 12; ++i) xfm[i] = float(m[size_t(i)]);
            rtcSetGeometryTransform(inst, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, xfm);
            rtcCommitGeometry(inst);
            const unsigned geom = rtcAttachGeometry(im.scene, inst);
            if (im.first_segment_by_geom.size() <= geom) im.first_segment_by_geom.resize(geom + 1, 0);
            im.first_segment_by_geom[geom] = uint32_t(first);
            if (im.sweep) {
                if (im.embree_offset_by_instance.size() <= geom) im.embree_offset_by_instance.resize(geom + 1, 0);
                im.embree_offset_by_instance[geom] = embree_offset;
            }
            rtcReleaseGeometry(inst);
        }
        has_curves_ = true;
    }

    const MeshData& md = scene.meshes;
    if (!md.triangles.empty()) {
        RTCGeometry g = rtcNewGeometry(im.device, RTC_GEOMETRY_TYPE_TRIANGLE);
        // Embree reads vertex buffers with 16-byte loads: copy with one float of padding.
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                              sizeof(float) * 4, md.vertices.size()));
        for (size_t i = 0; i < md.vertices.size(); ++i) {
            v[4 * i] = md.vertices[i][0];
            v[4 * i + 1] = md.vertices[i][1];
            v[4 * i + 2] = md.vertices[i][2];
            v[4 * i + 3] = 0.0f;
        }
        auto* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                   sizeof(uint32_t) * 3, md.triangles.size()));
        std::memcpy(idx, md.triangles.data(), md.triangles.size() * sizeof(uint32_t) * 3);
        rtcSetGeometryIntersectFilterFunction(g, triangle_filter);
        rtcSetGeometryOccludedFilterFunction(g, triangle_filter);
        rtcCommitGeometry(g);
        im.triangle_geom = rtcAttachGeometry(im.scene, g);
        rtcReleaseGeometry(g);
        has_triangles_ = true;
    }
    rtcCommitScene(im.scene);
    check_device(im.device, "scene build");
    im.own_bytes = control_points_.capacity() * sizeof(control_points_[0]) + normals_.capacity() * sizeof(normals_[0]) +
                   segment_first_.capacity() * sizeof(uint32_t) + segment_curve_.capacity() * sizeof(int32_t) +
                   curve_object_.capacity() * sizeof(int32_t) + im.segment_ends.capacity() +
                   im.proxy_vertices.capacity() * sizeof(im.proxy_vertices[0]) +
                   im.proxy_first.capacity() * sizeof(uint32_t) +
                   (im.embree_first.capacity() + im.embree_segment.capacity()) * sizeof(uint32_t) +
                   im.embree_curve.capacity() * sizeof(int32_t);
}

Geometry::~Geometry() {
    if (impl_) {
        if (impl_->scene) rtcReleaseScene(impl_->scene);
        for (RTCScene object_scene : impl_->object_scenes) rtcReleaseScene(object_scene);
        if (impl_->device) rtcReleaseDevice(impl_->device);
    }
}

size_t Geometry::peak_memory_bytes() const {
    return size_t(std::max(0LL, impl_->memory.peak.load())) + impl_->own_bytes;
}

bool Geometry::sweep_curves() const { return impl_->sweep; }

// A Sweep geometry's primitives are its proxy pieces (their hits already carry the segment's u).
uint32_t Geometry::segment_of_prim(uint32_t prim) const {
    return impl_->sweep ? prim / uint32_t(curve_proxy_pieces) : prim;
}

void Geometry::build_sweep_proxies(Impl& im) {
    constexpr int k = curve_proxy_pieces;
    const size_t n_segments = segment_first_.size();
    im.segment_ends.assign(n_segments, 0);
    for (size_t s = 0; s < n_segments; ++s) {
        if (s == 0 || segment_curve_[s - 1] != segment_curve_[s] || segment_first_[s - 1] + 1 != segment_first_[s])
            im.segment_ends[s] |= 1;
        if (s + 1 == n_segments || segment_curve_[s + 1] != segment_curve_[s] ||
            segment_first_[s] + 1 != segment_first_[s + 1])
            im.segment_ends[s] |= 2;
    }
    // Segments between coinciding keys go to Embree's own curves; for Sweep their neighbours' tubes stop there.
    for (size_t s = 0; s < n_segments; ++s) {
        if (!sweep_leaves_to_embree(&control_points_[segment_first_[s]])) continue;
        im.segment_ends[s] |= 4;
        if (!(im.segment_ends[s] & 1)) im.segment_ends[s - 1] |= 2;
        if (!(im.segment_ends[s] & 2)) im.segment_ends[s + 1] |= 1;
    }
    // Per piece its capped cone (sweep_proxy_cone): two vertices of its own; none for Embree's segments (a point).
    im.proxy_vertices.resize(n_segments * k * 2);
    im.proxy_first.resize(n_segments * k);
    for (size_t s = 0; s < n_segments; ++s) {
        const auto* cp = &control_points_[segment_first_[s]];
        if (im.segment_ends[s] & 4) {
            for (int j = 0; j < k; ++j) {
                const size_t piece = s * k + size_t(j);
                im.proxy_first[piece] = uint32_t(2 * piece);
                im.proxy_vertices[2 * piece] = im.proxy_vertices[2 * piece + 1] = {cp[1][0], cp[1][1], cp[1][2], 0.0f};
            }
            continue;
        }
        for (int j = 0; j < k; ++j) {
            const SweepProxyCone cone =
                sweep_proxy_cone(proxy_piece(cp, j, (im.segment_ends[s] & 1) != 0, (im.segment_ends[s] & 2) != 0));
            const size_t piece = s * k + size_t(j);
            im.proxy_first[piece] = uint32_t(2 * piece);
            im.proxy_vertices[2 * piece] = {float(cone.begin.x), float(cone.begin.y), float(cone.begin.z),
                                            float(cone.begin_radius)};
            im.proxy_vertices[2 * piece + 1] = {float(cone.end.x), float(cone.end.y), float(cone.end.z),
                                                float(cone.end_radius)};
        }
    }
}

Hit Geometry::to_hit(const RTCRayHit& rh) const {
    Hit hit;
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return hit;
    hit.t = rh.ray.tfar;
    hit.u = rh.hit.u;
    hit.v = rh.hit.v;
    hit.ng = {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z};
    const Impl& im = *impl_;
    if (rh.hit.instID[0] != RTC_INVALID_GEOMETRY_ID) {  // a curve in its object's space
        const unsigned instance = rh.hit.instID[0];
        hit.kind = PrimKind::Curve;
        hit.segment = rh.hit.geomID == im.embree_geom_in_instance
                          ? int(im.embree_segment[im.embree_offset_by_instance[instance] + rh.hit.primID])
                          : int(im.first_segment_by_geom[instance] + segment_of_prim(rh.hit.primID));
        hit.prim = segment_curve_[size_t(hit.segment)];
    } else if (rh.hit.geomID == im.curve_geom) {
        hit.kind = PrimKind::Curve;
        hit.segment = int(segment_of_prim(rh.hit.primID));
        hit.prim = segment_curve_[size_t(hit.segment)];
    } else if (rh.hit.geomID == im.embree_geom) {  // a world-space segment Sweep leaves to Embree
        hit.kind = PrimKind::Curve;
        hit.segment = int(im.embree_segment[rh.hit.primID]);
        hit.prim = segment_curve_[size_t(hit.segment)];
    } else {
        hit.kind = PrimKind::Triangle;
        hit.prim = int(rh.hit.primID);
    }
    return hit;
}

Hit Geometry::intersect(const Ray& ray, SkipPrim skip) const {
    if (empty()) return Hit{};
    QueryContext ctx;
    rtcInitIntersectContext(&ctx.rtc);
    ctx.skip = skip;
    RTCRayHit rh;
    setup_ray(ray, rh.ray);
    float nearest = rh.ray.tfar;
    uint32_t rejected_piece = 0;
    if (impl_->sweep) {
        ctx.nearest = &nearest;
        ctx.rejected_piece = &rejected_piece;
    }
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(impl_->scene, &ctx.rtc, &rh);
    return to_hit(rh);
}

void Geometry::intersect_stream(const Ray* rays, Hit* hits, size_t count) const {
    intersect_stream(rays, nullptr, hits, count);
}

void Geometry::intersect_stream(const Ray* rays, const SkipPrim* skips, Hit* hits, size_t count) const {
    if (empty()) {
        std::fill(hits, hits + count, Hit{});
        return;
    }
    QueryContext ctx;
    rtcInitIntersectContext(&ctx.rtc);
    // Camera rays (no skips) start together and go the same way: Embree traces them as packets.
    if (!skips) ctx.rtc.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    ctx.skips = skips;
    thread_local std::vector<RTCRayHit> stream;  // grows to the longest stream, then is reused
    thread_local SweepStreamState sweep_state;
    stream.resize(count);
    if (impl_->sweep) sweep_state.attach(ctx, count);
    for (size_t i = 0; i < count; ++i) {
        setup_ray(rays[i], stream[i].ray);
        if (ctx.nearest) ctx.nearest[i] = stream[i].ray.tfar;
        stream[i].ray.id = unsigned(i);
        stream[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
        stream[i].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect1M(impl_->scene, &ctx.rtc, stream.data(), unsigned(count), sizeof(RTCRayHit));
    for (size_t i = 0; i < count; ++i) hits[i] = to_hit(stream[i]);
}

void Geometry::occluded_stream(const Ray* rays, const SkipPrim* skips, const int* light_triangles, uint8_t* occluded,
                               size_t count) const {
    if (empty()) {
        std::fill(occluded, occluded + count, uint8_t(0));
        return;
    }
    QueryContext ctx;
    rtcInitIntersectContext(&ctx.rtc);
    ctx.skips = skips;
    ctx.light_triangles = light_triangles;
    thread_local std::vector<RTCRay> stream;
    thread_local SweepStreamState sweep_state;
    stream.resize(count);
    if (impl_->sweep) sweep_state.attach(ctx, count);
    for (size_t i = 0; i < count; ++i) {
        setup_ray(rays[i], stream[i]);
        if (ctx.nearest) ctx.nearest[i] = stream[i].tfar;
        stream[i].id = unsigned(i);
    }
    rtcOccluded1M(impl_->scene, &ctx.rtc, stream.data(), unsigned(count), sizeof(RTCRay));
    for (size_t i = 0; i < count; ++i) occluded[i] = stream[i].tfar < 0.0f ? 1 : 0;  // tfar = -inf on a hit
}

bool Geometry::occluded(const Ray& ray, SkipPrim skip, int light_triangle) const {
    if (empty()) return false;
    QueryContext ctx;
    rtcInitIntersectContext(&ctx.rtc);
    ctx.skip = skip;
    ctx.light_triangle = light_triangle;
    RTCRay r;
    setup_ray(ray, r);
    float nearest = r.tfar;
    uint32_t rejected_piece = 0;
    if (impl_->sweep) {
        ctx.nearest = &nearest;
        ctx.rejected_piece = &rejected_piece;
    }
    rtcOccluded1(impl_->scene, &ctx.rtc, &r);
    return r.tfar < 0.0f;  // Embree sets tfar = -inf on a hit
}

ObjectSpace::ObjectSpace(const std::array<double, 12>& world_from_object) : to_world(world_from_object) {
    const auto& m = world_from_object;
    // Inverse of the 3 x 3 part by cofactors, then the translation.
    const double c00 = m[5] * m[10] - m[6] * m[9], c01 = m[6] * m[8] - m[4] * m[10], c02 = m[4] * m[9] - m[5] * m[8];
    const double det = linear_determinant(m);
    const double inv[9] = {c00 / det,
                           (m[2] * m[9] - m[1] * m[10]) / det,
                           (m[1] * m[6] - m[2] * m[5]) / det,
                           c01 / det,
                           (m[0] * m[10] - m[2] * m[8]) / det,
                           (m[2] * m[4] - m[0] * m[6]) / det,
                           c02 / det,
                           (m[1] * m[8] - m[0] * m[9]) / det,
                           (m[0] * m[5] - m[1] * m[4]) / det};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) to_object[size_t(4 * r + c)] = inv[3 * r + c];
        to_object[size_t(4 * r + 3)] = -(inv[3 * r] * m[3] + inv[3 * r + 1] * m[7] + inv[3 * r + 2] * m[11]);
    }
}

namespace {
Vec3 linear(const std::array<double, 12>& m, Vec3 v) {
    return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[4] * v.x + m[5] * v.y + m[6] * v.z,
            m[8] * v.x + m[9] * v.y + m[10] * v.z};
}
}  // namespace

Vec3 ObjectSpace::point_to_object(Vec3 p) const {
    return linear(to_object, p) + Vec3{to_object[3], to_object[7], to_object[11]};
}
Vec3 ObjectSpace::point_to_world(Vec3 p) const { return linear(to_world, p) + Vec3{to_world[3], to_world[7], to_world[11]}; }
Vec3 ObjectSpace::direction_to_object(Vec3 d) const { return linear(to_object, d); }
Vec3 ObjectSpace::direction_to_world(Vec3 d) const { return linear(to_world, d); }
Vec3 ObjectSpace::normal_to_world(Vec3 n) const {
    const auto& m = to_object;  // the inverse's transpose
    return {m[0] * n.x + m[4] * n.y + m[8] * n.z, m[1] * n.x + m[5] * n.y + m[9] * n.z,
            m[2] * n.x + m[6] * n.y + m[10] * n.z};
}

CurvePoint catmull_rom(const std::array<float, 4>* cp, double u) {
    const double t = u, t2 = t * t, t3 = t2 * t;
    // Uniform Catmull-Rom basis and its derivative (Embree's and Cycles' convention).
    const double b[4] = {0.5 * (-t3 + 2 * t2 - t), 0.5 * (3 * t3 - 5 * t2 + 2), 0.5 * (-3 * t3 + 4 * t2 + t),
                         0.5 * (t3 - t2)};
    const double d[4] = {0.5 * (-3 * t2 + 4 * t - 1), 0.5 * (9 * t2 - 10 * t), 0.5 * (-9 * t2 + 8 * t + 1),
                         0.5 * (3 * t2 - 2 * t)};
    CurvePoint out;
    for (int i = 0; i < 4; ++i) {
        const Vec3 p{cp[i][0], cp[i][1], cp[i][2]};
        out.p = out.p + b[i] * p;
        out.dp = out.dp + d[i] * p;
        out.r += b[i] * cp[i][3];
        out.dr += d[i] * cp[i][3];
    }
    return out;
}

CurvePoint linear_segment(const std::array<float, 4>* cp, double u) {
    const Vec3 p1{cp[1][0], cp[1][1], cp[1][2]}, p2{cp[2][0], cp[2][1], cp[2][2]};
    CurvePoint out;
    out.p = (1.0 - u) * p1 + u * p2;
    out.dp = p2 - p1;
    out.r = (1.0 - u) * double(cp[1][3]) + u * double(cp[2][3]);
    out.dr = double(cp[2][3]) - double(cp[1][3]);
    return out;
}

CurvePoint Geometry::curve_point(int segment, double u) const {
    const auto* cp = &control_points_[segment_first_[size_t(segment)]];
    return shape_ == CurveShape::ThickLinear ? linear_segment(cp, u) : catmull_rom(cp, u);
}

double Geometry::curve_radius_linear(int segment, double u) const {
    const auto* cp = &control_points_[segment_first_[size_t(segment)]];
    return (1.0 - u) * double(cp[1][3]) + u * double(cp[2][3]);
}

Vec3 Geometry::curve_normal(int segment, double u) const {
    if (normals_.empty()) return {0, 0, 0};
    const auto* n = &normals_[segment_first_[size_t(segment)]];
    return {(1.0 - u) * n[1][0] + u * n[2][0], (1.0 - u) * n[1][1] + u * n[2][1], (1.0 - u) * n[1][2] + u * n[2][2]};
}

Vec3 offset_ray_origin(Vec3 p, Vec3 ng) {
    // Integer-ULP offset along the normal (Wächter and Binder, Ray Tracing Gems ch. 6),
    // the scheme Cycles' ray_offset follows.
    constexpr float kOrigin = 1.0f / 32.0f, kFloatScale = 1.0f / 65536.0f, kIntScale = 256.0f;
    const float n[3] = {float(ng.x), float(ng.y), float(ng.z)};
    const float pf[3] = {float(p.x), float(p.y), float(p.z)};
    float out[3];
    for (int i = 0; i < 3; ++i) {
        const int of = int(kIntScale * n[i]);
        int32_t bits;
        std::memcpy(&bits, &pf[i], 4);
        bits += (pf[i] < 0) ? -of : of;
        float pi;
        std::memcpy(&pi, &bits, 4);
        out[i] = std::fabs(pf[i]) < kOrigin ? pf[i] + kFloatScale * n[i] : pi;
    }
    return {out[0], out[1], out[2]};
}

}  // namespace hairbsdf::render
