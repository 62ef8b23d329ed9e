// The wavefront path tracer (integrator.wavefront; issue 29, docs/engine.md "A wavefront engine").
// Off by default.
#pragma once

#include <functional>

#include "hairbsdf/render/integrator.h"

namespace hairbsdf::render {

// Every path of pixels [x0, x1) x [y0, y1), samples [s0, s1), traced together: each bounce's rays
// as one Embree stream (the camera rays a coherent one with integrator.camera_ray_stream, else an
// incoherent one), the hits shaded grouped by material, then the light samples' shadow rays as one
// stream. Each path keeps its own Sampler and runs the per-pixel loop's stages (path_stages.h) in
// the same order, so its result is trace_pixel_sample's: bit for bit when the rays are traced one by
// one (integrator.wavefront_streams off), at float rounding with Embree's streams. `emit(x, y, path)` is
// called in the per-pixel loop's order (row, column, sample). A tile with more than a few hundred paths
// is traced a group of rows at a time.
void trace_tile_wavefront(const PreparedScene& scene, int x0, int y0, int x1, int y1, int s0, int s1,
                          PathScratch& scratch, PathCounters& counters,
                          const std::function<void(int, int, const PathResult&)>& emit);

}  // namespace hairbsdf::render
