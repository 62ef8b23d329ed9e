// ClosureSum's per-call cost (closures.h): no allocation in the scalar eval, pdf and sample
// nor in the prepared eval once the shading point has grown. Its own executable, because it
// replaces the global operator new to count calls.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <functional>
#include <new>

#include "hairbsdf/closures.h"
#include "hairbsdf/model_factory.h"
#include "hairbsdf/params/principled_hair.h"

namespace {
std::atomic<long> g_news{0};
}  // namespace

// GCC cannot see that these operator new and delete pair malloc with free.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t size) {
    ++g_news;
    if (void* p = std::malloc(size ? size : 1)) return p;
    throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

using namespace hairbsdf;

namespace {
// The registry's models, each in a one-closure and a two-closure sum. Left out: Huang and the
// plugin (their prepare allocates: the sampler mixture, the plugin's buffers) and yan_fur (its
// tables take seconds to build per process; it goes through the same visitors).
const std::vector<std::pair<std::string, HairModel>>& models() {
    static const std::vector<std::pair<std::string, HairModel>> all = [] {
        PrincipledHairInputs in;
        in.parametrization = Parametrization::Melanin;
        std::vector<std::pair<std::string, HairModel>> out{
            {"chiang", ChiangHair(chiang_params_from_principled(in, Accuracy::Cycles))},
            {"cycles_hair", CyclesHair(CyclesHairParams{})}};
        for (const std::string& name : zoo_model_names())
            if (name != "yan_fur") out.emplace_back(name, make_zoo_model(name, {}));
        return out;
    }();
    return all;
}

long news_during(const std::function<void()>& fn) {
    const long before = g_news.load();
    fn();
    return g_news.load() - before;
}
}  // namespace

TEST(ClosureSumAllocation, ScalarAndPreparedCallsAllocateNothing) {
    for (const auto& [name, model] : models()) {
        for (int count : {1, 2}) {
            std::vector<Closure> closures(size_t(count), Closure{RGB(0.5, 0.7, 0.9), model});
            const ClosureSum sum(closures);
            ShadingContext ctx;
            ctx.wo = normalize(Vec3{0.3, 0.1, 0.9});
            ctx.h = 0.3;
            ClosureSum::ShadingPoint point = sum.prepare(ctx);  // grows the storage once
            double sink = 0;
            const long news = news_during([&] {
                for (int i = 0; i < 40; ++i) {
                    const Vec3 wi = normalize(Vec3{-0.4 + 0.02 * i, 0.2, 0.8});
                    ctx.h = -0.9 + 0.045 * i;
                    sink += sum.eval(ctx, wi).pdf + sum.pdf(ctx, wi);
                    if (count == 1) sink += sum.sample(ctx, {0.3, 0.6, 0.025 * i}).pdf;
                    sum.prepare(ctx, point);
                    sink += sum.eval(point, wi).pdf;
                }
            });
            EXPECT_EQ(news, 0) << name << " x" << count << " (sink " << sink << ")";
        }
    }
}

// The scalar form of one closure is the model's own call, weighted: the values bit for bit.
TEST(ClosureSumAllocation, ScalarEvalIsTheModelsEval) {
    for (const auto& [name, model] : models()) {
        const RGB w(0.5, 0.7, 0.9);
        const ClosureSum sum({Closure{w, model}});
        ShadingContext ctx;
        ctx.wo = normalize(Vec3{0.3, 0.1, 0.9});
        ctx.h = 0.3;
        const Vec3 wi = normalize(Vec3{-0.4, 0.2, 0.8});
        const BsdfEval direct = std::visit([&](const auto& m) { return m.eval(m.prepare(ctx), wi); }, model);
        const BsdfEval e = sum.eval(ctx, wi);
        EXPECT_DOUBLE_EQ(e.pdf, direct.pdf) << name;  // (w x pdf) / w: within 4 ulp
        for (int p = 0; p < kLobeCount; ++p)
            for (int c = 0; c < 3; ++c) EXPECT_EQ(e.lobes[size_t(p)][c], (w * direct.lobes[size_t(p)])[c]) << name;
    }
}

// The renderer's forms of the sum (render_eval, render_sample) over a shading point filled per
// hit with add_at_hit, as render::Bsdf does: no allocation once the point has been used.
TEST(ClosureSumAllocation, RendererFormsAllocateNothing) {
    const HairModel diffuse{DiffuseBsdf{}};
    for (const auto& [name, model] : models()) {
        ShadingContext ctx;
        ctx.wo = normalize(Vec3{0.3, 0.1, 0.9});
        ctx.h = 0.3;
        ClosureSum::ShadingPoint point;
        auto fill = [&] {
            point.clear(ctx.wo);
            point.add_at_hit(RGB(0.5, 0.7, 0.9), model, ctx);
            point.add_at_hit(RGB(0.2, 0.1, 0.3), diffuse, ctx);
        };
        fill();  // the first use may set up the shading points' alternatives
        uint32_t rng_state = 1;
        double sink = 0;
        const long news = news_during([&] {
            for (int i = 0; i < 40; ++i) {
                ctx.h = -0.9 + 0.045 * i;
                fill();
                const Vec3 wi = normalize(Vec3{-0.4 + 0.02 * i, 0.2, 0.8});
                sink += ClosureSum::render_eval(point, wi, rng_state).pdf;
                sink += ClosureSum::render_sample(point, 0.3, 0.6, 0.025 * i, nullptr, rng_state, true).pdf;
            }
        });
        EXPECT_EQ(news, 0) << name << " (sink " << sink << ")";
    }
}
