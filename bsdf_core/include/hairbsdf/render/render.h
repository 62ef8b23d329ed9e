// Rendering a whole image: TBB over tiles, samples in passes, cancellable.
//
//   RenderJob job(std::move(scene), threads);   // repairs the scene (job.warnings())
//   std::thread t([&] { job.run(); });          // blocking; any thread
//   ... job.progress(), job.cancel() from another thread ...
//   t.join();  RenderOutput out = job.output();
//
// Each pass renders a number of samples for every tile (16 x 16 px, smaller for tiny
// images); a pixel's samples are always added in sample order from its own random
// stream, so the image is the same for any thread count. `cancel()` is checked before
// every pixel sample: the workers stop within one path.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "hairbsdf/render/film.h"
#include "hairbsdf/render/scene.h"

namespace hairbsdf::render {

struct RenderStats {
    int samples = 0;           // samples per pixel completed by every pixel
    double seconds = 0;        // wall time of run(), scene build included
    double build_seconds = 0;  // BVH and scene preparation
    uint64_t rays = 0;         // camera, bounce and shadow rays traced
    size_t peak_memory_bytes = 0;
    uint64_t nan_count = 0;    // non-finite contributions zeroed
    uint64_t kernel_hits = 0;  // hits shaded through the batch kernels (integrator.wavefront_kernels)
    bool sweep_curves = false; // THICK curves intersected by Sweep (curve_intersector, geometry.h)
    bool cancelled = false;
};

struct RenderOutput {
    int width = 0, height = 0;
    std::vector<float> rgba;  // (height, width, 4), row 0 at the top
    Film::Passes passes;      // the enabled extra passes (film.h)
    RenderStats stats;
    std::vector<std::string> warnings;
};

class RenderJob {
public:
    // threads <= 0: all cores.
    RenderJob(SceneDesc scene, int threads);
    ~RenderJob();
    const std::vector<std::string>& warnings() const { return warnings_; }

    void run();  // throws std::runtime_error on failure (e.g. Embree)
    void cancel() { cancel_.store(true, std::memory_order_relaxed); }
    bool cancelled() const { return cancel_.load(std::memory_order_relaxed); }
    double progress() const { return progress_.load(std::memory_order_relaxed); }
    RenderOutput output() const;

private:
    SceneDesc scene_;
    int threads_;
    std::vector<std::string> warnings_;
    std::atomic<bool> cancel_{false};
    std::atomic<double> progress_{0.0};
    struct State;
    std::unique_ptr<State> state_;
};

// Convenience: render synchronously on the calling thread.
RenderOutput render_scene(SceneDesc scene, int threads = 0);

}  // namespace hairbsdf::render
