// Path tracing with next-event estimation and MIS, following Cycles' estimator
// (kernel/integrator/*.h, 4.5) where it changes the expected value:
//  * Per surface hit: emission (weight 1: curves and, here, meshes are not light-sampled),
//    Russian roulette, one light sample (power-heuristic MIS with the BSDF pdf for lights
//    that BSDF rays can hit), one BSDF sample.
//  * Russian roulette at a hit after `bounce` scatters, when bounce > min_light_bounces + 1:
//    survive with q = min(sqrt(max |throughput|), 1), then throughput /= q. Emission of the
//    hit itself is added before the decision.
//  * Bounce budgets as path_state.h: after a scatter, bounce (and the diffuse / glossy /
//    transmission counter of its label) is incremented; reaching budget + 1 marks the path
//    to end at the next surface, after its emission and after lights / background the ray
//    meets on the way (so max_bounces 0 is direct lighting). Chiang R counts as glossy,
//    TT / TRT / TRRT+ as transmission.
//  * Lights are transparent to rays: each crossed light adds its MIS-weighted radiance and
//    counts as a transparent bounce (the path ends past transparent_bounces).
//  * Camera rays see the world and the lights visible to the camera (visible_camera; off
//    for new Blender lights) with weight 1; with a transparent film a camera ray that
//    escapes adds average(throughput) to the transparency instead of the world.
//  * Pixel filter: sample 0 of every pixel is the pixel centre (Cycles' rand_filter = 0.5
//    for sample 0), later samples importance-sample the filter.
//  * Filter Glossy: at a non-camera hit with min_ray_pdf / filter_glossy < 1 the hair
//    closures are blurred with roughness sqrt(1 - that) / 2.
//  * Clamp: per contribution, |r| + |g| + |b| limited to 3 x clamp_direct (light reaching
//    the camera after at most one scatter) or 3 x clamp_indirect; non-finite components
//    are zeroed and counted (Cycles' ensure_finite).
//  * Self-intersection: rays leave curves from the hit point skipping the whole curve;
//    triangles skip themselves and offset the origin by a few ULPs.
//  * Hair lobe passes: light leaving the camera ray's first hair hit is split by lobe of that
//    hit. The light sample there by the lobes' shares of the BSDF value towards the light;
//    everything the sampled path brings back by the lobes' shares of the value in the sampled
//    direction (per channel). The four passes add up to that part of Combined, and each has
//    the expectation of its lobe alone.
#pragma once

#include <memory>
#include <vector>

#include "hairbsdf/render/camera.h"
#include "hairbsdf/render/film.h"
#include "hairbsdf/render/lights.h"
#include "hairbsdf/render/sampler.h"
#include "hairbsdf/render/shading.h"

namespace hairbsdf::render {

// Everything a path needs, built once per render from a repaired SceneDesc. The scene's
// curve keys (scene.curves.points) move into the geometry and are freed in the SceneDesc.
struct PreparedScene {
    explicit PreparedScene(SceneDesc& scene);
    const SceneDesc& desc;
    Geometry geometry;
    Camera camera;
    LightSet lights;
    std::vector<MaterialShader> materials;
    FilterTable filter;
    std::vector<ShadingImage> images;  // views of desc.images for the shading programs
};

struct PathCounters {
    uint64_t rays = 0;
    uint64_t nan = 0;
    uint64_t kernel_hits = 0;  // hits shaded through the batch kernels (the wavefront's)
};

struct PathResult {
    RGB radiance;
    double transparent = 0;  // background transparency of a transparent film
    // Passes (filled when the settings ask for them):
    std::array<RGB, kLobeCount> lobes{};  // radiance leaving the first hair hit, per lobe of that hit
    bool hit = false;        // the camera ray hit a surface (depth and normal are set)
    double depth = 0;        // camera-space depth of the first hit
    Vec3 normal;             // world-space shading normal of the first hit
};

struct WavefrontStorage;  // render/wavefront.h's per-thread paths and streams

// Per-thread scratch state of the integrator (no allocation per sample).
struct PathScratch {
    Bsdf bsdf;
    std::vector<float> registers;   // the hit material's shading program
    std::vector<float> light_registers;  // an emissive triangle's program at a light sample
    std::vector<float> attributes;  // RGBA of each curve attribute at the hit
    std::shared_ptr<WavefrontStorage> wavefront;  // integrator.wavefront: a tile's paths, kept for the next tile
};

// The camera sample of pixel (column, row), row 0 at the top: filter offsets, camera ray, path.
PathResult trace_pixel_sample(const PreparedScene& scene, int column, int row, uint32_t sample, PathScratch& scratch,
                              PathCounters& counters);

// Where the path of pixel (column, row)'s sample starts: its sampler (the sample's own stream),
// after the camera ray has drawn the filter offsets from its first numbers, and that ray. Every
// driver (trace_pixel_sample, the camera-ray stream, the wavefront) starts its paths here.
struct CameraPathStart {
    Sampler rng;
    Ray ray;
};
CameraPathStart start_camera_path(const PreparedScene& scene, int column, int row, uint32_t sample);

// One path from a given primary ray, one ray at a time (the wavefront runs the same stages over many).
PathResult trace_path(const PreparedScene& scene, Ray ray, Sampler& rng, PathScratch& scratch,
                      PathCounters& counters);

}  // namespace hairbsdf::render
