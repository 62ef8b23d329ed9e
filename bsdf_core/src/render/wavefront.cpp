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
    // A material's hits shaded through the batch kernels (shade_with_kernels): each hit's state between
    // the numbers drawn and the kernels' results, and the kernels' rows (float32, the fibre frame).
    struct KernelHit {
        uint32_t path = 0;
        stages::HitShading h;
        bool has_light = false;
        LightSample light;
        stages::BsdfNumbers numbers;
        Vec3 b1, b2;  // with the tangent, the hit's right-handed frame (the kernels' x is the tangent)
    };
    std::vector<KernelHit> kernel_hits;
    std::vector<float> wo, h, random, u, sampled_wi, weight, sample_pdf;
    std::vector<int32_t> lobe;
    std::vector<float> light_wo, light_wi, light_h, light_random, value, eval_pdf;  // the light samples' rows
};

namespace {

// At most this many paths at once (about 0.8 kB of state each with their light samples, so that they
// stay in a core's L2 cache): a tile's rows are traced in groups of rows below it.
constexpr size_t kMaxPaths = 512;

// Two unit vectors completing a unit tangent t to a right-handed orthonormal frame (t, b1, b2).
void complete_frame(Vec3 t, Vec3& b1, Vec3& b2) {
    const Vec3 a = std::fabs(t.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    b1 = normalize(cross(t, a));
    b2 = cross(t, b1);
}

// v in the frame (t, b1, b2), as float32 into a row of 3.
void put_local(Vec3 v, Vec3 t, Vec3 b1, Vec3 b2, float* row) {
    row[0] = float(dot(v, t));
    row[1] = float(dot(v, b1));
    row[2] = float(dot(v, b2));
}

// A hit on the scalar path once its Bsdf is set: its light sample (queued for the shadow stream) and its
// BSDF sample (the path goes on if it gives a next ray).
void shade_on_scalar_path(const PreparedScene& s, uint32_t i, const stages::HitShading& h, PathScratch& scratch,
                          PathCounters& counters, stages::ShadowRay& shadow) {
    WavefrontStorage& w = *scratch.wavefront;
    stages::PathState& st = w.paths[i];
    if (stages::sample_light(s, st, scratch, h, counters, shadow)) {
        w.shadows.push_back(shadow);
        w.shadow_path.push_back(i);
    }
    if (stages::sample_bsdf(s, st, scratch, h, counters)) w.next_live.push_back(i);
}

// The hits [begin, end) of w.shading, all of one material that the batch kernels can shade
// (MaterialShader::batch_chiang): each path's stages up to its numbers, one kernel call for the light
// samples' evals and one for the BSDF samples, then each path's stages after them, in the path's own
// order (light sample, then BSDF sample), so that every path draws its numbers as the scalar path does
// (a Chiang Bsdf draws none of its own). Hits the kernels do not take (Filter Glossy's blurred ones, the
// lobe passes' first hits) go the scalar way.
void shade_with_kernels(const PreparedScene& s, const BatchChiangMaterial& batch, size_t begin, size_t end,
                        PathScratch& scratch, PathCounters& counters) {
    using namespace stages;
    WavefrontStorage& w = *scratch.wavefront;
    w.kernel_hits.clear();
    ShadowRay shadow;  // each hit's light sample, written by sample_light / finish_light_sample
    size_t n = 0;      // the hits in w.kernel_hits[0, n), each written in place (no copies)
    for (size_t j = begin; j < end; ++j) {
        const uint32_t i = w.shading[j].second;
        PathState& st = w.paths[i];
        if (w.kernel_hits.size() == n) w.kernel_hits.emplace_back();
        WavefrontStorage::KernelHit& k = w.kernel_hits[n];
        k.path = i;
        if (!prepare_hit(s, st, scratch, counters, k.h)) continue;
        if (k.h.first_hair || k.h.blur > 0) {  // the scalar way
            if (set_bsdf(s, st, scratch, k.h)) shade_on_scalar_path(s, i, k.h, scratch, counters, shadow);
            continue;
        }
        k.has_light = draw_light_sample(s, st, scratch, k.h, batch.transmits, k.light);
        k.numbers = draw_bsdf_numbers(s, st);
        complete_frame(k.h.sp.g.tangent, k.b1, k.b2);
        ++n;
    }
    if (n == 0) return;
    counters.kernel_hits += n;

    // The rows: every hit samples; those with a light sample evaluate too.
    w.wo.resize(3 * n), w.h.resize(n), w.random.resize(n), w.u.resize(3 * n);
    w.light_wo.resize(3 * n), w.light_wi.resize(3 * n), w.light_h.resize(n), w.light_random.resize(n);
    size_t m = 0;  // the light samples' rows
    for (size_t j = 0; j < n; ++j) {
        const WavefrontStorage::KernelHit& k = w.kernel_hits[j];
        const ShadingGeometry& g = k.h.sp.g;
        put_local(g.wo, g.tangent, k.b1, k.b2, &w.wo[3 * j]);
        w.h[j] = float(clamp(g.h, -1.0, 1.0));
        w.random[j] = float(g.random);
        w.u[3 * j] = float(k.numbers.u0);
        w.u[3 * j + 1] = float(k.numbers.u1);
        w.u[3 * j + 2] = float(k.numbers.u2);
        if (k.has_light) {
            put_local(k.light.wi, g.tangent, k.b1, k.b2, &w.light_wi[3 * m]);
            for (int c = 0; c < 3; ++c) w.light_wo[3 * m + c] = w.wo[3 * j + c];
            w.light_h[m] = w.h[j];
            w.light_random[m] = w.random[j];
            ++m;
        }
    }
    w.value.resize(3 * m), w.eval_pdf.resize(m);
    if (m > 0) {
        ChiangBatchRows rows;
        rows.wo = w.light_wo.data();
        rows.wi = w.light_wi.data();
        rows.h = w.light_h.data();
        if (batch.random_per_row) rows.inputs.random = w.light_random.data();
        ChiangBatchOutput out;
        out.value = w.value.data();
        out.pdf = w.eval_pdf.data();
        chiang_batch_run(batch.constants, ChiangBatchOp::Eval, rows, out, 0, m);
    }
    w.sampled_wi.resize(3 * n), w.weight.resize(3 * n), w.sample_pdf.resize(n), w.lobe.resize(n);
    {
        ChiangBatchRows rows;
        rows.wo = w.wo.data();
        rows.h = w.h.data();
        rows.u = w.u.data();
        if (batch.random_per_row) rows.inputs.random = w.random.data();
        ChiangBatchOutput out;
        out.wi = w.sampled_wi.data();
        out.weight = w.weight.data();
        out.pdf = w.sample_pdf.data();
        out.lobe = w.lobe.data();
        chiang_batch_run(batch.constants, ChiangBatchOp::Sample, rows, out, 0, n);
    }

    // Each path's stages after its numbers, as the scalar path runs them (render_eval, render_sample).
    // (b and sc are set up once: their per-lobe arrays stay 0, the lobe passes' hits being the scalar path's.)
    size_t light_row = 0;
    BsdfValue b;
    BsdfScatter sc;
    for (size_t j = 0; j < n; ++j) {
        const WavefrontStorage::KernelHit& k = w.kernel_hits[j];
        PathState& st = w.paths[k.path];
        const Vec3 t = k.h.sp.g.tangent;
        if (k.has_light) {
            const size_t r = light_row++;
            b.pdf = double(w.eval_pdf[r]);
            // A closure counts where its pdf is not 0 (closure_counts); non-finite results count as none.
            const RGB value(w.value[3 * r], w.value[3 * r + 1], w.value[3 * r + 2]);
            if (b.pdf != 0.0 && std::isfinite(b.pdf) && isfinite(value)) {
                b.value = value;
            } else {
                b.value = RGB(0.0);
                b.pdf = 0.0;
            }
            if (finish_light_sample(s, st, k.h, k.light, b, counters, shadow)) {
                w.shadows.push_back(shadow);
                w.shadow_path.push_back(k.path);
            }
        }
        const double pdf = double(w.sample_pdf[j]);
        sc.label = LabelNone;
        if (w.lobe[j] >= 0 && pdf > 0 && std::isfinite(pdf)) {
            const float* d = &w.sampled_wi[3 * j];
            sc.wi = normalize(double(d[0]) * t + double(d[1]) * k.b1 + double(d[2]) * k.b2);
            sc.value = pdf * RGB(w.weight[3 * j], w.weight[3 * j + 1], w.weight[3 * j + 2]);
            sc.pdf = pdf;
            sc.blur_pdf = pdf;
            sc.label = ChiangHair::scatter_label(w.lobe[j]);
        }
        if (finish_bsdf_sample(s, st, k.h, sc, batch.transmits, counters)) w.next_live.push_back(k.path);
    }
}

// Rows [y0, y1) of a tile: the wavefront proper.
void trace_rows(const PreparedScene& s, int x0, int y0, int x1, int y1, int s0, int s1, bool streams,
                PathScratch& scratch, PathCounters& counters,
                const std::function<void(int, int, const PathResult&)>& emit) {
    using namespace stages;
    const IntegratorSettings& is = s.desc.integrator;
    WavefrontStorage& w = *scratch.wavefront;
    // Cycles < 3.6's LCG numbers are the scalar path's alone.
    const bool kernels = is.wavefront_kernels && !is.chiang_lcg;

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
        for (size_t begin = 0, end; begin < w.shading.size(); begin = end) {
            const int material = w.shading[begin].first;
            for (end = begin + 1; end < w.shading.size() && w.shading[end].first == material; ++end) {
            }
            const std::optional<BatchChiangMaterial>& batch = s.materials[size_t(material)].batch_chiang();
            if (kernels && batch) {
                shade_with_kernels(s, *batch, begin, end, scratch, counters);
                continue;
            }
            for (size_t j = begin; j < end; ++j) {
                const uint32_t i = w.shading[j].second;
                if (prepare_bsdf(s, w.paths[i], scratch, counters, h))
                    shade_on_scalar_path(s, i, h, scratch, counters, shadow);
            }
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
