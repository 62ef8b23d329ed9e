// The scalar batch calls of a ClosureSum over rows of plain arrays: a thread pool that splits the
// rows in contiguous chunks, the shading-point cache that reuses a row's prepared point when the
// next row has the same view, and the eval / pdf / sample / albedo loops. The Python bindings
// (plugin/bindings/module.cpp) only convert arrays and call these. Rows are in the fibre frame
// (tangent = +x, docs/conventions.md): wo, wi and u are (N, 3) row-major, h and the extras (N,).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <thread>
#include <vector>

#include "hairbsdf/albedo.h"
#include "hairbsdf/closures.h"

namespace hairbsdf {

// Threads of the batch calls: the hardware's unless set; at least 1.
int batch_threads();
void set_batch_threads(int threads);

// Runs fn(begin, end) over [0, n) in contiguous chunks of at least min_chunk rows, on up to
// batch_threads() threads (the calling thread alone when one chunk is all there is).
template <class Fn>
void parallel_for(size_t n, size_t min_chunk, Fn fn) {
    const size_t threads = std::min<size_t>(size_t(batch_threads()), (n + min_chunk - 1) / min_chunk);
    if (threads <= 1) {
        fn(size_t(0), n);
        return;
    }
    std::vector<std::thread> pool;
    const size_t chunk = (n + threads - 1) / threads;
    for (size_t t = 0; t < threads; ++t) {
        const size_t begin = t * chunk, end = std::min(n, begin + chunk);
        if (begin >= end) break;
        pool.emplace_back([=, &fn] { fn(begin, end); });
    }
    for (auto& th : pool) th.join();
}

inline Vec3 row_vec(const double* p, size_t i) { return {p[3 * i], p[3 * i + 1], p[3 * i + 2]}; }
inline void store_rgb(double* out, size_t i, RGB c) {
    out[3 * i] = c.r;
    out[3 * i + 1] = c.g;
    out[3 * i + 2] = c.b;
}
// Row i of a sample call's outputs: direction (N, 3), weight (N, 3), pdf (N,), lobe (N,).
inline void store_sample(const BsdfSample& s, size_t i, double* wi, double* weight, double* pdf, int32_t* lobe) {
    wi[3 * i] = s.wi.x;
    wi[3 * i + 1] = s.wi.y;
    wi[3 * i + 2] = s.wi.z;
    store_rgb(weight, i, s.weight);
    pdf[i] = s.pdf;
    lobe[i] = s.lobe;
}

// Optional per-row fields of the shading context; null: the field's default.
struct RowExtras {
    const double* normal = nullptr;          // (N, 3), Huang's and Marschner's major axis
    const double* pixel_coverage = nullptr;  // (N,)
    const double* near_field = nullptr;      // (N,) 0 / 1
    const double* random = nullptr;          // (N,) per-strand random (plugins)
    const double* shadow = nullptr;          // (N,) Epic's light visibility through the hair volume
};

// Row i's shading context in the fibre frame.
inline ShadingContext fibre_context(const double* wo, const double* h, size_t i, const RowExtras& x = {}) {
    ShadingContext ctx;
    ctx.tangent = {1, 0, 0};
    ctx.wo = row_vec(wo, i);
    ctx.h = h[i];
    if (x.normal) ctx.normal = row_vec(x.normal, i);
    if (x.pixel_coverage) ctx.pixel_coverage = x.pixel_coverage[i];
    if (x.near_field) ctx.near_field = x.near_field[i] != 0.0;
    if (x.random) ctx.random = x.random[i];
    if (x.shadow) ctx.shadow = x.shadow[i];
    return ctx;
}

// The fields fibre_context sets are equal.
inline bool same_row_context(const ShadingContext& a, const ShadingContext& b) {
    return a.wo.x == b.wo.x && a.wo.y == b.wo.y && a.wo.z == b.wo.z && a.h == b.h && a.normal.x == b.normal.x &&
           a.normal.y == b.normal.y && a.normal.z == b.normal.z && a.pixel_coverage == b.pixel_coverage &&
           a.near_field == b.near_field && a.random == b.random && a.shadow == b.shadow;
}

// Prepares the closures for row i, reusing the previous row's shading point when its context
// repeats (gonio sweeps: one wo, many wi). One per thread.
class PointCache {
public:
    explicit PointCache(const ClosureSum& bsdf, const RowExtras& extras = {}) : bsdf_(bsdf), extras_(extras) {}
    const ClosureSum::ShadingPoint& at(const double* wo, const double* h, size_t i) {
        const ShadingContext ctx = fibre_context(wo, h, i, extras_);
        if (!valid_ || !same_row_context(ctx, last_)) {
            bsdf_.prepare(ctx, point_);
            last_ = ctx;
            valid_ = true;
            ++prepared_;
        }
        return point_;
    }
    // How many rows needed a new shading point.
    size_t prepared() const { return prepared_; }

private:
    const ClosureSum& bsdf_;
    RowExtras extras_;
    ClosureSum::ShadingPoint point_;
    ShadingContext last_;
    bool valid_ = false;
    size_t prepared_ = 0;
};

// The lobe slots eval_lobes reports for this sum: R, TT, TRT, TRRT+, plus TTs and TRTs when a
// yan_fur closure is in it (docs/models.md §7).
int batch_lobe_count(const ClosureSum& bsdf);

// The loops, threaded. eval: value (N, 3), or with `lobes` per lobe (N, batch_lobe_count, 3).
void batch_eval(const ClosureSum& bsdf, size_t n, const double* wo, const double* wi, const double* h, bool lobes,
                const RowExtras& extras, double* out);
void batch_pdf(const ClosureSum& bsdf, size_t n, const double* wo, const double* wi, const double* h,
               const RowExtras& extras, double* out);
// sample: wi (N, 3), weight (N, 3), pdf (N,), lobe (N,) from u (N, 3).
void batch_sample(const ClosureSum& bsdf, size_t n, const double* wo, const double* h, const double* u,
                  const RowExtras& extras, double* wi, double* weight, double* pdf, int32_t* lobe);
// The directional albedo per row (N, 3).
void batch_albedo(const ClosureSum& bsdf, size_t n, const double* wo, const double* h, const QuadratureOptions& options,
                  double* out);

}  // namespace hairbsdf
