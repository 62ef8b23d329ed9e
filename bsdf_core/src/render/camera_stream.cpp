// Camera rays as one coherent stream; see render/camera_stream.h.
#include "hairbsdf/render/camera_stream.h"

namespace hairbsdf::render {

void trace_row_stream(const PreparedScene& s, int row, int x0, int x1, int s0, int s1, PathScratch& scratch,
                      PathCounters& counters, const std::function<void(int, const PathResult&)>& emit) {
    const size_t count = size_t(x1 - x0) * size_t(s1 - s0);
    std::vector<Sampler>& samplers = scratch.stream_samplers;
    std::vector<Ray>& rays = scratch.stream_rays;
    std::vector<Hit>& hits = scratch.stream_hits;
    samplers.clear();
    rays.clear();
    hits.resize(count);
    for (int x = x0; x < x1; ++x)
        for (int k = s0; k < s1; ++k) {
            const CameraPathStart start = start_camera_path(s, x, row, uint32_t(k));
            samplers.push_back(start.rng);
            rays.push_back(start.ray);
        }
    s.geometry.intersect_stream(rays.data(), hits.data(), count);
    size_t i = 0;
    for (int x = x0; x < x1; ++x)
        for (int k = s0; k < s1; ++k, ++i) emit(x, trace_path(s, rays[i], samplers[i], scratch, counters, &hits[i]));
}

}  // namespace hairbsdf::render
