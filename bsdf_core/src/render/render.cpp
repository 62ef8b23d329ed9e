// Image rendering over tiles with TBB; see render/render.h.
#include "hairbsdf/render/render.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <cmath>

#include "hairbsdf/render/integrator.h"
#include "hairbsdf/render/wavefront.h"

namespace hairbsdf::render {

namespace {

struct Tile {
    int x0, y0, x1, y1;
};

std::vector<Tile> make_tiles(int width, int height, int threads) {
    int size = 16;
    auto count = [&](int s) { return size_t((width + s - 1) / s) * size_t((height + s - 1) / s); };
    while (size > 4 && count(size) < size_t(8 * threads)) size /= 2;
    std::vector<Tile> tiles;
    for (int y = 0; y < height; y += size)
        for (int x = 0; x < width; x += size) tiles.push_back({x, y, std::min(x + size, width), std::min(y + size, height)});
    return tiles;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

struct RenderJob::State {
    RenderOutput out;
};

RenderJob::RenderJob(SceneDesc scene, int threads) : scene_(std::move(scene)), threads_(threads) {
    warnings_ = repair_scene(scene_);
    state_ = std::make_unique<State>();
}

RenderJob::~RenderJob() = default;

void RenderJob::run() {
    const auto t0 = std::chrono::steady_clock::now();
    RenderOutput& out = state_->out;
    const int width = std::max(0, scene_.camera.width), height = std::max(0, scene_.camera.height);
    out.width = width;
    out.height = height;
    out.rgba.assign(size_t(width) * size_t(height) * 4, 0.0f);
    out.warnings = warnings_;
    const int total_samples = std::max(0, scene_.integrator.samples);
    if (width == 0 || height == 0 || total_samples == 0) {
        progress_.store(1.0);
        out.stats.seconds = seconds_since(t0);
        return;
    }

    const int threads = threads_ > 0 ? threads_ : tbb::this_task_arena::max_concurrency();
    tbb::task_arena arena(threads);
    arena.execute([&] {
        const PreparedScene prepared(scene_);
        out.stats.build_seconds = seconds_since(t0);
        Film film(width, height);
        film.enable_passes(scene_.integrator);
        const IntegratorSettings& st = scene_.integrator;
        const bool any_pass = st.pass_hair_lobes || st.pass_depth || st.pass_normal || st.pass_variance;
        const std::vector<Tile> tiles = make_tiles(width, height, threads);
        tbb::enumerable_thread_specific<PathScratch> scratch;
        tbb::enumerable_thread_specific<PathCounters> counters;
        const double total_work = double(width) * double(height) * double(total_samples);
        std::atomic<uint64_t> done_work{0};

        int done_samples = 0, pass_samples = 1;
        while (done_samples < total_samples && !cancelled()) {
            const int s0 = done_samples, s1 = std::min(total_samples, done_samples + pass_samples);
            const auto pass_start = std::chrono::steady_clock::now();
            auto tile_done = [&](const Tile& t) {  // progress: the tile's samples of this pass
                const uint64_t work = uint64_t(t.x1 - t.x0) * uint64_t(t.y1 - t.y0) * uint64_t(s1 - s0);
                const uint64_t done = done_work.fetch_add(work) + work;
                progress_.store(std::min(1.0, double(done) / total_work), std::memory_order_relaxed);
            };
            tbb::parallel_for(tbb::blocked_range<size_t>(0, tiles.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
                PathScratch& sc = scratch.local();
                PathCounters& pc = counters.local();
                for (size_t i = r.begin(); i != r.end(); ++i) {
                    const Tile& t = tiles[i];
                    auto to_film = [&](int x, int y, const PathResult& p) {
                        const size_t pixel = size_t(y) * size_t(width) + size_t(x);
                        film.add(pixel, p.radiance, p.transparent);
                        if (any_pass) film.add_passes(pixel, p.lobes, p.hit, p.depth, p.normal, p.radiance);
                    };
                    // The tile's paths together (the wavefront, or only the camera rays as a stream);
                    // the film in the per-pixel order.
                    if (st.wavefront || st.camera_ray_stream) {
                        if (cancelled()) return;
                        trace_tile_wavefront(prepared, t.x0, t.y0, t.x1, t.y1, s0, s1,
                                             st.wavefront && st.wavefront_streams, sc, pc, to_film);
                        tile_done(t);
                        continue;
                    }
                    for (int y = t.y0; y < t.y1; ++y) {
                        for (int x = t.x0; x < t.x1; ++x) {
                            for (int s = s0; s < s1; ++s) {
                                if (cancelled()) return;
                                to_film(x, y, trace_pixel_sample(prepared, x, y, uint32_t(s), sc, pc));
                            }
                        }
                    }
                    tile_done(t);
                }
            });
            if (cancelled()) break;
            done_samples = s1;
            // Grow passes while they are short: fewer synchronisation points, same image.
            if (seconds_since(pass_start) < 0.1) pass_samples = std::min(pass_samples * 2, 64);
        }
        out.stats.samples = done_samples;
        out.stats.cancelled = cancelled();
        film.resolve(out.rgba.data(), scene_.integrator.exposure, scene_.integrator.film_transparent);
        out.passes = film.resolve_passes(scene_.integrator.exposure);
        for (const PathCounters& c : counters) {
            out.stats.rays += c.rays;
            out.stats.nan_count += c.nan;
            out.stats.kernel_hits += c.kernel_hits;
        }
        for (float& v : out.rgba) {
            if (!std::isfinite(v)) {
                v = 0.0f;
                ++out.stats.nan_count;
            }
        }
        size_t scene_bytes = scene_.curves.points.size() * sizeof(scene_.curves.points[0]) +
                             scene_.curves.offsets.size() * 12 + scene_.meshes.vertices.size() * 12 +
                             scene_.meshes.triangles.size() * 16;
        out.stats.sweep_curves = prepared.geometry.sweep_curves();
        out.stats.peak_memory_bytes = prepared.geometry.peak_memory_bytes() + film.memory_bytes() +
                                      out.rgba.size() * sizeof(float) + scene_bytes;
    });
    if (!cancelled()) progress_.store(1.0);
    out.stats.seconds = seconds_since(t0);
}

RenderOutput RenderJob::output() const { return state_->out; }

RenderOutput render_scene(SceneDesc scene, int threads) {
    RenderJob job(std::move(scene), threads);
    job.run();
    return job.output();
}

}  // namespace hairbsdf::render
