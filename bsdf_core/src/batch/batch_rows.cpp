// The scalar batch loops; see batch/batch_rows.h.
#include "hairbsdf/batch/batch_rows.h"

#include <atomic>

namespace hairbsdf {

namespace {

std::atomic<int> g_batch_threads{int(std::max(1u, std::thread::hardware_concurrency()))};

bool has_huang(const ClosureSum& bsdf) {
    for (const Closure& c : bsdf.closures())
        if (std::holds_alternative<HuangHair>(c.model)) return true;
    return false;
}
// Rows per thread: Huang evaluations cost microseconds to milliseconds, so split finely.
size_t grain(const ClosureSum& bsdf, size_t chiang_grain) { return has_huang(bsdf) ? 1 : chiang_grain; }

}  // namespace

int batch_threads() { return g_batch_threads.load(); }
void set_batch_threads(int threads) { g_batch_threads = std::max(1, threads); }

int batch_lobe_count(const ClosureSum& bsdf) {
    for (const Closure& c : bsdf.closures())
        if (std::holds_alternative<YanFurHair>(c.model)) return kLobeCount;
    return kChiangLobeCount;
}

void batch_eval(const ClosureSum& bsdf, size_t n, const double* wo, const double* wi, const double* h, bool lobes,
                const RowExtras& extras, double* out) {
    const int count = batch_lobe_count(bsdf);
    parallel_for(n, grain(bsdf, 4096), [&](size_t b, size_t e) {
        PointCache cache(bsdf, extras);
        for (size_t i = b; i < e; ++i) {
            const BsdfEval r = bsdf.eval(cache.at(wo, h, i), row_vec(wi, i));
            if (lobes) {
                for (int p = 0; p < count; ++p) store_rgb(out + 3 * count * i, size_t(p), r.lobes[p]);
            } else {
                store_rgb(out, i, r.value());
            }
        }
    });
}

void batch_pdf(const ClosureSum& bsdf, size_t n, const double* wo, const double* wi, const double* h,
               const RowExtras& extras, double* out) {
    parallel_for(n, grain(bsdf, 4096), [&](size_t b, size_t e) {
        PointCache cache(bsdf, extras);
        for (size_t i = b; i < e; ++i) out[i] = bsdf.pdf(cache.at(wo, h, i), row_vec(wi, i));
    });
}

void batch_sample(const ClosureSum& bsdf, size_t n, const double* wo, const double* h, const double* u,
                  const RowExtras& extras, double* wi, double* weight, double* pdf, int32_t* lobe) {
    parallel_for(n, grain(bsdf, 2048), [&](size_t b, size_t e) {
        PointCache cache(bsdf, extras);
        for (size_t i = b; i < e; ++i)
            store_sample(bsdf.sample(cache.at(wo, h, i), {u[3 * i], u[3 * i + 1], u[3 * i + 2]}), i, wi, weight, pdf, lobe);
    });
}

void batch_albedo(const ClosureSum& bsdf, size_t n, const double* wo, const double* h, const QuadratureOptions& options,
                  double* out) {
    parallel_for(n, 1, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) store_rgb(out, i, directional_albedo(bsdf, fibre_context(wo, h, i), options));
    });
}

}  // namespace hairbsdf
