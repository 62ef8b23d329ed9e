// Camera rays traced as one coherent Embree stream (integrator.camera_ray_stream; issue 29's first
// wavefront step, docs/engine.md "A wavefront engine"). Off by default.
#pragma once

#include <functional>

#include "hairbsdf/render/integrator.h"

namespace hairbsdf::render {

// Pixels [x0, x1) of row `row`, samples [s0, s1): every camera ray first (each from its own
// sample's Sampler, which the path then continues), one rtcIntersect1M over them, then each path
// from its hit. `emit(x, path)` is called in the per-pixel loop's order (x, then sample). The image
// is the per-pixel path's at float rounding: Embree's packets return some hits a rounding step away
// from rtcIntersect1's (plugin/tests/test_camera_ray_stream.py).
void trace_row_stream(const PreparedScene& scene, int row, int x0, int x1, int s0, int s1, PathScratch& scratch,
                      PathCounters& counters, const std::function<void(int, const PathResult&)>& emit);

}  // namespace hairbsdf::render
