// The closure registry and weighted sums of closures. Adding a model means adding it to
// `HairModel` and its ShadingPoint to `PreparedModel` below; every model has prepare(ctx),
// eval(point, wi), sample(point, u), and the convenience forms taking a ShadingContext.
#pragma once

#include <utility>
#include <variant>
#include <vector>

#include "hairbsdf/models/chiang.h"
#include "hairbsdf/models/cycles_hair.h"
#include "hairbsdf/models/deon.h"
#include "hairbsdf/models/epic.h"
#include "hairbsdf/models/huang.h"
#include "hairbsdf/models/kajiya_kay.h"
#include "hairbsdf/models/marschner.h"
#include "hairbsdf/models/plugin_hair.h"
#include "hairbsdf/models/scheuermann.h"
#include "hairbsdf/models/yan_fur.h"

namespace hairbsdf {

using HairModel = std::variant<ChiangHair, HuangHair, KajiyaKayHair, EpicHair, ScheuermannHair, MarschnerHair, DeonHair,
                               PluginHair, CyclesHair, YanFurHair>;
// Per-shading-point state of each model (its `ShadingPoint`), from model.prepare(ctx).
using PreparedModel = std::variant<std::monostate, ChiangHair::ShadingPoint, HuangHair::ShadingPoint,
                                   KajiyaKayHair::ShadingPoint, EpicHair::ShadingPoint,
                                   ScheuermannHair::ShadingPoint, MarschnerHair::ShadingPoint,
                                   DeonHair::ShadingPoint, PluginHair::ShadingPoint, CyclesHair::ShadingPoint,
                                   YanFurHair::ShadingPoint>;

// A closure is a weight times a model (OSL's `weight * closure`).
struct Closure {
    RGB weight{1.0};
    HairModel model;
    // Cycles picks a closure with probability proportional to |average(weight)|.
    double sample_weight() const { return std::fabs(average(weight)); }
};

inline PreparedModel prepare_model(const HairModel& m, const ShadingContext& ctx) {
    return std::visit([&](const auto& model) { return PreparedModel(model.prepare(ctx)); }, m);
}
inline BsdfEval eval_model(const HairModel& m, const PreparedModel& point, Vec3 wi) {
    return std::visit(
        [&](const auto& model) {
            using Point = typename std::decay_t<decltype(model)>::ShadingPoint;
            return model.eval(std::get<Point>(point), wi);
        },
        m);
}
// The density `sample` reports, without evaluating the BSDF where the model can (Huang).
template <class M>
double model_pdf(const M& model, const typename M::ShadingPoint& point, Vec3 wi) {
    return model.eval(point, wi).pdf;
}
inline double model_pdf(const HuangHair& model, const HuangHair::ShadingPoint& point, Vec3 wi) {
    return model.pdf(point, wi);
}
inline double model_pdf(const PluginHair& model, const PluginHair::ShadingPoint& point, Vec3 wi) {
    return model.pdf(point, wi);
}
inline double pdf_model(const HairModel& m, const PreparedModel& point, Vec3 wi) {
    return std::visit(
        [&](const auto& model) {
            using Point = typename std::decay_t<decltype(model)>::ShadingPoint;
            return model_pdf(model, std::get<Point>(point), wi);
        },
        m);
}
inline BsdfSample sample_model(const HairModel& m, const PreparedModel& point, const std::array<double, 3>& u) {
    return std::visit(
        [&](const auto& model) {
            using Point = typename std::decay_t<decltype(model)>::ShadingPoint;
            return model.sample(std::get<Point>(point), u);
        },
        m);
}

// A weighted sum of closures, evaluated and sampled as Cycles does with several BSDFs:
// eval sums weight * value, the pdf is the sample-weight mixture of the closures' pdfs.
class ClosureSum {
public:
    ClosureSum() = default;
    explicit ClosureSum(std::vector<Closure> closures) : closures_(std::move(closures)) {
        for (const Closure& c : closures_) total_sample_weight_ += c.sample_weight();
    }
    const std::vector<Closure>& closures() const { return closures_; }

    // The closures prepared for one shading point: view-dependent terms computed once and
    // shared by every eval, pdf and sample at that point.
    struct ShadingPoint {
        std::vector<PreparedModel> models;
    };
    ShadingPoint prepare(const ShadingContext& ctx) const {
        ShadingPoint sp;
        prepare(ctx, sp);
        return sp;
    }
    // Reuses `sp`'s storage (no allocation once it has grown to the closure count).
    void prepare(const ShadingContext& ctx, ShadingPoint& sp) const {
        sp.models.resize(closures_.size());
        for (size_t i = 0; i < closures_.size(); ++i) sp.models[i] = prepare_model(closures_[i].model, ctx);
    }

    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const {
        BsdfEval out;
        if (!(total_sample_weight_ > 0)) return out;
        for (size_t i = 0; i < closures_.size(); ++i) {
            const Closure& c = closures_[i];
            const BsdfEval e = eval_model(c.model, sp.models[i], wi);
            for (int p = 0; p < kLobeCount; ++p) out.lobes[p] += c.weight * e.lobes[p];
            out.pdf += c.sample_weight() * e.pdf;
        }
        out.pdf /= total_sample_weight_;
        return out;
    }
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const { return eval(prepare(ctx), wi); }
    double pdf(const ShadingPoint& sp, Vec3 wi) const {
        if (!(total_sample_weight_ > 0)) return 0.0;
        double pdf = 0.0;
        for (size_t i = 0; i < closures_.size(); ++i)
            pdf += closures_[i].sample_weight() * pdf_model(closures_[i].model, sp.models[i], wi);
        return pdf / total_sample_weight_;
    }
    double pdf(const ShadingContext& ctx, Vec3 wi) const { return pdf(prepare(ctx), wi); }

    // u[2] picks the closure and is rescaled for the closure's own use.
    BsdfSample sample(const ShadingPoint& sp, std::array<double, 3> u) const {
        BsdfSample out;
        if (!(total_sample_weight_ > 0)) return out;
        if (closures_.size() == 1) {
            out = sample_model(closures_[0].model, sp.models[0], u);
            out.value = closures_[0].weight * out.value;
            out.weight = closures_[0].weight * out.weight;
            return out;
        }
        double r = u[2] * total_sample_weight_;
        size_t picked = closures_.size() - 1;
        for (size_t i = 0; i < closures_.size(); ++i) {
            const double w = closures_[i].sample_weight();
            if (r < w || i + 1 == closures_.size()) {
                picked = i;
                u[2] = w > 0 ? clamp(r / w, 0.0, 1.0) : 0.5;
                break;
            }
            r -= w;
        }
        const BsdfSample s = sample_model(closures_[picked].model, sp.models[picked], u);
        if (s.lobe < 0) return out;
        // Combine with the other closures' values and pdfs at the sampled direction.
        RGB value = closures_[picked].weight * s.value;
        double pdf = closures_[picked].sample_weight() * s.pdf;
        for (size_t i = 0; i < closures_.size(); ++i) {
            if (i == picked) continue;
            const BsdfEval e = eval_model(closures_[i].model, sp.models[i], s.wi);
            value += closures_[i].weight * e.value();
            pdf += closures_[i].sample_weight() * e.pdf;
        }
        pdf /= total_sample_weight_;
        const RGB weight = (1.0 / pdf) * value;
        if (!(pdf > 0) || !isfinite(weight)) return out;
        out.wi = s.wi;
        out.value = value;
        out.pdf = pdf;
        out.weight = weight;
        out.lobe = s.lobe;
        return out;
    }
    BsdfSample sample(const ShadingContext& ctx, std::array<double, 3> u) const { return sample(prepare(ctx), u); }

private:
    std::vector<Closure> closures_;
    double total_sample_weight_ = 0;
};

}  // namespace hairbsdf
