// The scalar batch machinery (batch/batch_rows.h): the thread pool covers every row once, the point
// cache prepares a row only when its context changes, and the threaded loops give what
// ClosureSum gives row by row, for any thread count.
#include <gtest/gtest.h>

#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "hairbsdf/batch/batch_rows.h"
#include "hairbsdf/params/principled_hair.h"

using namespace hairbsdf;

namespace {

// Restores the thread count after a test.
struct ThreadCount {
    int saved = batch_threads();
    ~ThreadCount() { set_batch_threads(saved); }
};

ClosureSum chiang() {
    PrincipledHairInputs in;
    in.roughness = 0.25;
    return ClosureSum({Closure{RGB(0.8, 0.9, 1.0), ChiangHair(chiang_params_from_principled(in))}});
}

// n rows: wo repeats in runs of `run` rows, wi and u differ per row.
struct Rows {
    std::vector<double> wo, wi, h, u;
    explicit Rows(size_t n, size_t run = 1) {
        for (size_t i = 0; i < n; ++i) {
            const double k = double(i / run);
            const Vec3 o = normalize(Vec3{std::sin(0.7 * k), 0.4 * std::cos(1.3 * k), 0.9});
            const Vec3 w = normalize(Vec3{std::cos(0.37 * double(i)), std::sin(0.91 * double(i)), -0.5});
            wo.insert(wo.end(), {o.x, o.y, o.z});
            wi.insert(wi.end(), {w.x, w.y, w.z});
            h.push_back(std::sin(0.3 * k));
            u.insert(u.end(), {std::fmod(0.123 * double(i), 1.0), std::fmod(0.457 * double(i), 1.0), std::fmod(0.789 * double(i), 1.0)});
        }
    }
};

}  // namespace

TEST(BatchRows, ParallelForCoversEveryRowOnceOnAtMostTheSetThreads) {
    ThreadCount restore;
    for (int threads : {1, 2, 3, 8}) {
        set_batch_threads(threads);
        for (size_t n : {size_t(0), size_t(1), size_t(7), size_t(1000), size_t(1001)}) {
            for (size_t min_chunk : {size_t(1), size_t(64), size_t(4096)}) {
                std::vector<int> seen(n, 0);
                std::set<std::thread::id> ids;
                std::mutex lock;
                parallel_for(n, min_chunk, [&](size_t b, size_t e) {
                    if (n > 0) {  // n = 0: one empty call
                        EXPECT_LT(b, e);
                    }
                    for (size_t i = b; i < e; ++i) ++seen[i];  // chunks are disjoint: no race
                    std::lock_guard<std::mutex> g(lock);
                    ids.insert(std::this_thread::get_id());
                });
                for (size_t i = 0; i < n; ++i) EXPECT_EQ(seen[i], 1) << "row " << i << " of " << n;
                EXPECT_LE(ids.size(), size_t(threads));
                EXPECT_LE(ids.size(), std::max<size_t>(1, (n + min_chunk - 1) / min_chunk));
            }
        }
    }
    set_batch_threads(0);
    EXPECT_EQ(batch_threads(), 1);  // at least one
}

TEST(BatchRows, PointCachePreparesOnlyWhenTheContextChanges) {
    const ClosureSum bsdf = chiang();
    const Rows rows(40, 10);  // 4 runs of one view
    PointCache cache(bsdf);
    for (size_t i = 0; i < 40; ++i) {
        const BsdfEval cached = bsdf.eval(cache.at(rows.wo.data(), rows.h.data(), i), row_vec(rows.wi.data(), i));
        ClosureSum::ShadingPoint fresh;
        bsdf.prepare(fibre_context(rows.wo.data(), rows.h.data(), i), fresh);
        const BsdfEval direct = bsdf.eval(fresh, row_vec(rows.wi.data(), i));
        EXPECT_EQ(cached.value().r, direct.value().r) << i;
        EXPECT_EQ(cached.value().b, direct.value().b) << i;
    }
    EXPECT_EQ(cache.prepared(), 4u);
    // a new h under the same view is a new context
    std::vector<double> h(40);
    for (size_t i = 0; i < 40; ++i) h[i] = 0.1 * double(i % 3);
    const std::vector<double> one_view(rows.wo.begin(), rows.wo.begin() + 3);
    std::vector<double> wo;
    for (size_t i = 0; i < 40; ++i) wo.insert(wo.end(), one_view.begin(), one_view.end());
    PointCache per_h(bsdf);
    for (size_t i = 0; i < 40; ++i) {
        const BsdfEval cached = bsdf.eval(per_h.at(wo.data(), h.data(), i), row_vec(rows.wi.data(), i));
        ClosureSum::ShadingPoint fresh;
        bsdf.prepare(fibre_context(wo.data(), h.data(), i), fresh);
        EXPECT_EQ(cached.value().g, bsdf.eval(fresh, row_vec(rows.wi.data(), i)).value().g) << i;
    }
    EXPECT_EQ(per_h.prepared(), 40u);
    // a per-row extra that changes is a new context
    std::vector<double> random(40);
    for (size_t i = 0; i < 40; ++i) random[i] = double(i % 2);
    RowExtras extras;
    extras.random = random.data();
    PointCache per_row(bsdf, extras);
    for (size_t i = 0; i < 40; ++i) per_row.at(rows.wo.data(), rows.h.data(), i);
    EXPECT_EQ(per_row.prepared(), 40u);
}

TEST(BatchRows, ThreadedLoopsEqualTheClosureSumRowByRow) {
    ThreadCount restore;
    const ClosureSum bsdf = chiang();
    const size_t n = 10000;
    const Rows rows(n, 3);
    std::vector<double> want_value(3 * n), want_pdf(n), want_wi(3 * n), want_weight(3 * n), want_spdf(n);
    std::vector<int32_t> want_lobe(n);
    for (size_t i = 0; i < n; ++i) {
        ClosureSum::ShadingPoint point;
        bsdf.prepare(fibre_context(rows.wo.data(), rows.h.data(), i), point);
        store_rgb(want_value.data(), i, bsdf.eval(point, row_vec(rows.wi.data(), i)).value());
        want_pdf[i] = bsdf.pdf(point, row_vec(rows.wi.data(), i));
        store_sample(bsdf.sample(point, {rows.u[3 * i], rows.u[3 * i + 1], rows.u[3 * i + 2]}), i, want_wi.data(),
                     want_weight.data(), want_spdf.data(), want_lobe.data());
    }
    for (int threads : {1, 3}) {
        set_batch_threads(threads);
        std::vector<double> value(3 * n), lobes(3 * size_t(batch_lobe_count(bsdf)) * n), pdf(n), wi(3 * n), weight(3 * n),
            spdf(n);
        std::vector<int32_t> lobe(n);
        batch_eval(bsdf, n, rows.wo.data(), rows.wi.data(), rows.h.data(), false, {}, value.data());
        batch_eval(bsdf, n, rows.wo.data(), rows.wi.data(), rows.h.data(), true, {}, lobes.data());
        batch_pdf(bsdf, n, rows.wo.data(), rows.wi.data(), rows.h.data(), {}, pdf.data());
        batch_sample(bsdf, n, rows.wo.data(), rows.h.data(), rows.u.data(), {}, wi.data(), weight.data(), spdf.data(),
                     lobe.data());
        EXPECT_EQ(value, want_value) << threads << " threads";
        EXPECT_EQ(pdf, want_pdf) << threads << " threads";
        EXPECT_EQ(wi, want_wi) << threads << " threads";
        EXPECT_EQ(weight, want_weight) << threads << " threads";
        EXPECT_EQ(spdf, want_spdf) << threads << " threads";
        EXPECT_EQ(lobe, want_lobe) << threads << " threads";
        for (size_t i = 0; i < n; i += 997) {  // the lobes sum to the value
            double sum = 0;
            for (int p = 0; p < batch_lobe_count(bsdf); ++p) sum += lobes[3 * (size_t(batch_lobe_count(bsdf)) * i + size_t(p))];
            EXPECT_NEAR(sum, value[3 * i], 1e-12 * std::max(1.0, value[3 * i])) << i;
        }
    }
}
