// The wavefront path tracer (integrator.wavefront; issue 29, docs/engine.md "A wavefront engine").
// Off by default.
#pragma once

#include <functional>

#include "hairbsdf/render/integrator.h"

namespace hairbsdf::render {

// Every path of pixels [x0, x1) x [y0, y1), samples [s0, s1), traced together: the camera rays as one
// coherent Embree stream with integrator.camera_ray_stream; each bounce's rays, then the light samples'
// shadow rays, as one incoherent stream when `streams` (else one by one); the hits shaded grouped by
// material. Each path keeps its own Sampler and runs the per-pixel loop's stages (path_stages.h) in the
// same order, so its result is trace_pixel_sample's: bit for bit when every ray is traced one by one,
// at float rounding with Embree's streams. `emit(x, y, path)` is called in the per-pixel loop's order
// (row, column, sample). A tile with more than a few hundred paths is traced a group of rows at a time.
// The renderer calls it with integrator.wavefront (streams: integrator.wavefront_streams) and for
// integrator.camera_ray_stream alone (streams off: only the camera rays go as a stream).
void trace_tile_wavefront(const PreparedScene& scene, int x0, int y0, int x1, int y1, int s0, int s1,
                          bool streams, PathScratch& scratch, PathCounters& counters,
                          const std::function<void(int, int, const PathResult&)>& emit);

}  // namespace hairbsdf::render
