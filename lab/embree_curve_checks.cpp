// Two behaviours of Debian's Embree 3.13 that SWEEP's proxies depend on (docs/engine.md, "Curve intersection"):
//
//   instances  a thin curve piece (length 1) in an instance scaled by 1, 1.3 and 0.7, hit by 20 000 rays in random
//              directions aimed at it: hits of a cone linear curve and of a round linear curve on the same two
//              vertices. The cone intersector takes the ray's direction to be a unit vector; in a scaled instance
//              it is not, and the cone loses (or invents) hits. SWEEP's proxies in object spaces are round.
//   ends       a straight round Catmull-Rom strand (radius 0.02, ends at x = +-0.075), rays from the side near its
//              end: how far past the end Embree reports hits, per instruction set (rtcNewDevice("isa=...")).
//
//   build/cpp/lab/embree_curve_checks [instances|ends]   (both without an argument)
#include <embree3/rtcore.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <initializer_list>
#include <vector>

namespace {

struct Random {  // a small LCG, the same everywhere
    unsigned state = 12345;
    float next() {
        state = state * 1664525u + 1013904223u;
        return float(state >> 8) / float(1u << 24);
    }
};

RTCRayHit ray_hit(float ox, float oy, float oz, float dx, float dy, float dz) {
    RTCRayHit rh{};
    rh.ray.org_x = ox;
    rh.ray.org_y = oy;
    rh.ray.org_z = oz;
    rh.ray.dir_x = dx;
    rh.ray.dir_y = dy;
    rh.ray.dir_z = dz;
    rh.ray.tfar = 1e30f;
    rh.ray.mask = ~0u;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

// Hits of a piece from (-0.5, 0, 0) to (0.5, 0, 0), radius r, of `type`, in an instance scaled by s.
int piece_hits(RTCDevice device, RTCGeometryType type, float s, float r) {
    RTCScene inner = rtcNewScene(device);
    rtcSetSceneFlags(inner, RTCSceneFlags(RTC_SCENE_FLAG_COMPACT | RTC_SCENE_FLAG_ROBUST));
    RTCGeometry g = rtcNewGeometry(device, type);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 16, 2));
    const float points[8] = {-0.5f, 0, 0, r, 0.5f, 0, 0, r};
    std::memcpy(v, points, sizeof points);
    auto* index = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, 4, 1));
    index[0] = 0;
    rtcCommitGeometry(g);
    rtcAttachGeometry(inner, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(inner);
    RTCScene outer = rtcNewScene(device);
    RTCGeometry instance = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(instance, inner);
    const float world_from_object[12] = {s, 0, 0, 0, 0, s, 0, 0, 0, 0, s, 0};
    rtcSetGeometryTransform(instance, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, world_from_object);
    rtcCommitGeometry(instance);
    rtcAttachGeometry(outer, instance);
    rtcReleaseGeometry(instance);
    rtcCommitScene(outer);
    Random random;
    int hits = 0;
    for (int i = 0; i < 20000; ++i) {
        const float ct = 2 * random.next() - 1, phi = 6.2831853f * random.next(), st = std::sqrt(1 - ct * ct);
        const float dx = st * std::cos(phi), dy = st * std::sin(phi), dz = ct;
        const float tx = s * (0.8f * random.next() - 0.4f), ty = s * r * (4 * random.next() - 2),
                    tz = s * r * (4 * random.next() - 2);
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        RTCRayHit rh = ray_hit(tx - 3 * dx, ty - 3 * dy, tz - 3 * dz, dx, dy, dz);
        rtcIntersect1(outer, &context, &rh);
        hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
    rtcReleaseScene(outer);
    rtcReleaseScene(inner);
    return hits;
}

void instances() {
    RTCDevice device = rtcNewDevice("verbose=0");
    std::printf("hits of 20 000 random rays on a piece in an instance scaled by s: cone linear / round linear\n");
    for (float r : {0.04f, 0.004f})
        for (float s : {1.0f, 1.3f, 0.7f})
            std::printf("  radius %.3f, s %.1f: %6d / %6d\n", r, s, piece_hits(device, RTC_GEOMETRY_TYPE_CONE_LINEAR_CURVE, s, r),
                        piece_hits(device, RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE, s, r));
    rtcReleaseDevice(device);
}

void ends() {
    std::printf("a round Catmull-Rom strand, radius 0.02, ends at x = +-0.075; rays down -z over x in [0.06, 0.09]\n");
    for (const char* config : {"isa=sse4.2", "isa=avx", "isa=avx2", "isa=avx512"}) {
        RTCDevice device = rtcNewDevice(config);
        RTCScene scene = rtcNewScene(device);
        rtcSetSceneFlags(scene, RTCSceneFlags(RTC_SCENE_FLAG_COMPACT | RTC_SCENE_FLAG_ROBUST));
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_ROUND_CATMULL_ROM_CURVE);
        const int keys = 9;
        std::vector<float> points;  // the keys, the end keys doubled (as the renderer holds them)
        for (int i = -1; i <= keys; ++i) {
            const int k = i < 0 ? 0 : (i >= keys ? keys - 1 : i);
            points.insert(points.end(), {-0.075f + 0.15f * float(k) / (keys - 1), 0.f, 0.f, 0.02f});
        }
        auto* v = static_cast<float*>(
            rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 16, points.size() / 4));
        std::memcpy(v, points.data(), points.size() * sizeof(float));
        auto* index =
            static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, 4, keys - 1));
        for (int s = 0; s < keys - 1; ++s) index[s] = unsigned(s);
        rtcSetGeometryTessellationRate(g, 5.f);
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
        rtcCommitScene(scene);
        int beyond = 0;
        float farthest = 0.075f;
        for (int ix = 0; ix < 200; ++ix)
            for (int iy = 0; iy < 200; ++iy) {
                const float x = 0.06f + 0.03f * float(ix) / 199.f, y = -0.025f + 0.05f * float(iy) / 199.f;
                RTCIntersectContext context;
                rtcInitIntersectContext(&context);
                RTCRayHit rh = ray_hit(x, y, 1, 0, 0, -1);
                rtcIntersect1(scene, &context, &rh);
                if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID && x > 0.075f) {
                    ++beyond;
                    if (x > farthest) farthest = x;
                }
            }
        std::printf("  %-11s rays hitting past the end: %5d, the farthest %.4f past it (%.2f r)\n", config, beyond,
                    farthest - 0.075f, (farthest - 0.075f) / 0.02f);
        rtcReleaseScene(scene);
        rtcReleaseDevice(device);
    }
}

}  // namespace

int main(int argc, char** argv) {
    const char* what = argc > 1 ? argv[1] : "";
    if (argc > 2 || (*what && std::strcmp(what, "instances") != 0 && std::strcmp(what, "ends") != 0)) {
        std::fprintf(stderr, "usage: embree_curve_checks [instances|ends]\n");
        return 2;
    }
    if (!*what || std::strcmp(what, "instances") == 0) instances();
    if (!*what || std::strcmp(what, "ends") == 0) ends();
    return 0;
}
