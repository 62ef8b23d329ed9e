// The wavefront path tracer; see render/wavefront.h.
#include "hairbsdf/render/wavefront.h"

#include <algorithm>

#include "path_stages.h"

namespace hairbsdf::render {

// A tile's paths and the streams of one bounce, kept per thread so that tiles reuse the storage.
struct WavefrontStorage {
    std::vector<stages::PathState> paths;   // in the per-pixel loop's order
    std::vector<uint32_t> live, next_live;  // paths with a ray to trace
    std::vector<Ray> rays;
    std::vector<SkipPrim> skips;
    std::vector<Hit> hits;
    std::vector<std::pair<int, uint32_t>> shading;  // (material, path) of the hits to shade
    std::vector<stages::ShadowRay> shadows;
    std::vector<uint32_t> shadow_path;
    std::vector<Ray> shadow_rays;
    std::vector<SkipPrim> shadow_skips;
    std::vector<int> shadow_light_triangles;
    std::vector<uint8_t> occluded;
};

namespace {

// At most this many paths at once (about 0.8 kB of state each with their light samples, so that they
// stay in a core's L2 cache): a tile's rows are traced in groups of rows below it.
constexpr size_t kMaxPaths = 512;

// Rows [y0, y1) of a tile: the wavefront proper.
void trace_rows(const PreparedScene& s, int x0, int y0, int x1, int y1, int s0, int s1, bool streams,
                PathScratch& scratch, PathCounters& counters,
                const std::function<void(int, int, const PathResult&)>& emit) {
    using namespace stages;
    const IntegratorSettings& is = s.desc.integrator;
    WavefrontStorage& w = *scratch.wavefront;

    // Camera rays, each from its own sample's Sampler, which the path keeps.
    w.paths.clear();
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x)
            for (int k = s0; k < s1; ++k) {
                const CameraPathStart start = start_camera_path(s, x, y, uint32_t(k));
                PathState& st = w.paths.emplace_back(start.rng);
                st.ray = start.ray;
                begin_path(s, st);
            }
    w.live.resize(w.paths.size());
    for (size_t i = 0; i < w.live.size(); ++i) w.live[i] = uint32_t(i);

    for (bool camera_rays = true; !w.live.empty(); camera_rays = false) {
        // The live paths' rays as one stream.
        const size_t n = w.live.size();
        w.rays.resize(n);
        w.skips.resize(n);
        w.hits.resize(n);
        for (size_t j = 0; j < n; ++j) {
            w.rays[j] = w.paths[w.live[j]].ray;
            w.skips[j] = w.paths[w.live[j]].skip;
        }
        if (camera_rays && is.camera_ray_stream) {
            s.geometry.intersect_stream(w.rays.data(), w.hits.data(), n);  // coherent packets
        } else if (streams) {
            s.geometry.intersect_stream(w.rays.data(), w.skips.data(), w.hits.data(), n);
        } else {
            for (size_t j = 0; j < n; ++j) w.hits[j] = s.geometry.intersect(w.rays[j], w.skips[j]);
        }

        // Lights crossed and escaped rays; the surface hits grouped by material.
        w.shading.clear();
        for (size_t j = 0; j < n; ++j) {
            PathState& st = w.paths[w.live[j]];
            st.hit = w.hits[j];
            if (after_trace(s, st, counters)) w.shading.emplace_back(hit_material(s, st.hit), w.live[j]);
        }
        std::sort(w.shading.begin(), w.shading.end());

        // Shading: each path's Bsdf stages back to back (they share the thread's Bsdf); the light
        // samples wait for their shadow rays.
        w.shadows.clear();
        w.shadow_path.clear();
        w.next_live.clear();
        HitShading h;      // each hit's, written by prepare_bsdf
        ShadowRay shadow;  // each hit's light sample, written by sample_light
        for (const auto& [material, i] : w.shading) {
            PathState& st = w.paths[i];
            if (!prepare_bsdf(s, st, scratch, counters, h)) continue;
            if (sample_light(s, st, scratch, h, counters, shadow)) {
                w.shadows.push_back(shadow);
                w.shadow_path.push_back(i);
            }
            if (sample_bsdf(s, st, scratch, h, counters)) w.next_live.push_back(i);
        }

        // The shadow rays as one stream; each unoccluded light sample to its own path, before
        // the path's next contributions.
        const size_t m = w.shadows.size();
        w.shadow_rays.resize(m);
        w.shadow_skips.resize(m);
        w.shadow_light_triangles.resize(m);
        w.occluded.resize(m);
        for (size_t j = 0; j < m; ++j) {
            w.shadow_rays[j] = w.shadows[j].ray;
            w.shadow_skips[j] = w.shadows[j].self;
            w.shadow_light_triangles[j] = w.shadows[j].light_triangle;
        }
        if (streams) {
            s.geometry.occluded_stream(w.shadow_rays.data(), w.shadow_skips.data(), w.shadow_light_triangles.data(),
                                       w.occluded.data(), m);
        } else {
            for (size_t j = 0; j < m; ++j)
                w.occluded[j] = s.geometry.occluded(w.shadow_rays[j], w.shadow_skips[j], w.shadow_light_triangles[j]);
        }
        for (size_t j = 0; j < m; ++j)
            if (!w.occluded[j]) add_light_sample(s, w.paths[w.shadow_path[j]], counters, w.shadows[j]);

        std::sort(w.next_live.begin(), w.next_live.end());  // neighbouring pixels' rays together
        w.live.swap(w.next_live);
    }

    size_t i = 0;
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x)
            for (int k = s0; k < s1; ++k, ++i) emit(x, y, w.paths[i].res);
}

}  // namespace

void trace_tile_wavefront(const PreparedScene& s, int x0, int y0, int x1, int y1, int s0, int s1, bool streams,
                          PathScratch& scratch, PathCounters& counters,
                          const std::function<void(int, int, const PathResult&)>& emit) {
    if (!scratch.wavefront) scratch.wavefront = std::make_shared<WavefrontStorage>();
    const size_t row_paths = std::max<size_t>(1, size_t(x1 - x0) * size_t(s1 - s0));
    const int rows = int(std::max<size_t>(1, kMaxPaths / row_paths));
    for (int y = y0; y < y1; y += rows)
        trace_rows(s, x0, y, x1, std::min(y + rows, y1), s0, s1, streams, scratch, counters, emit);
}

}  // namespace hairbsdf::render
