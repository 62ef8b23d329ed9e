// The closure registry and weighted sums of closures. Adding a model means adding it to
// `HairModel` and its ShadingPoint to `PreparedModel` below; every model has prepare(ctx),
// eval(point, wi), sample(point, u), and the convenience forms taking a ShadingContext.
#pragma once

#include <type_traits>
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

// The renderer's label for a sampled lobe: the model's own `scatter_label`, else Principled
// Hair's (hair_lobe_label).
template <class M, class = void>
struct has_scatter_label : std::false_type {};
template <class M>
struct has_scatter_label<M, std::void_t<decltype(std::declval<const M&>().scatter_label(0))>> : std::true_type {};
template <class M>
uint8_t model_scatter_label(const M& model, int lobe) {
    if constexpr (has_scatter_label<M>::value)
        return model.scatter_label(lobe);
    else
        return hair_lobe_label(lobe);
}
inline uint8_t scatter_label(const HairModel& m, int lobe) {
    return std::visit([&](const auto& model) { return model_scatter_label(model, lobe); }, m);
}

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
// Prepares `m` into `point` in place: the variant's alternative is kept when it already holds
// the model's ShadingPoint (no variant move).
inline void prepare_model(const HairModel& m, const ShadingContext& ctx, PreparedModel& point) {
    std::visit(
        [&](const auto& model) {
            using Point = typename std::decay_t<decltype(model)>::ShadingPoint;
            if (Point* p = std::get_if<Point>(&point))
                *p = model.prepare(ctx);
            else
                point.template emplace<Point>(model.prepare(ctx));
        },
        m);
}
// One model's value at ctx, its shading point kept on the stack (no allocation, no variant).
inline BsdfEval eval_model(const HairModel& m, const ShadingContext& ctx, Vec3 wi) {
    return std::visit([&](const auto& model) { return model.eval(model.prepare(ctx), wi); }, m);
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
inline double pdf_model(const HairModel& m, const ShadingContext& ctx, Vec3 wi) {
    return std::visit([&](const auto& model) { return model_pdf(model, model.prepare(ctx), wi); }, m);
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
        for (size_t i = 0; i < closures_.size(); ++i) prepare_model(closures_[i].model, ctx, sp.models[i]);
    }

    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const {
        BsdfEval out;
        if (!(total_sample_weight_ > 0)) return out;
        for (size_t i = 0; i < closures_.size(); ++i) add(out, closures_[i], eval_model(closures_[i].model, sp.models[i], wi));
        out.pdf /= total_sample_weight_;
        return out;
    }
    // The scalar form: each closure's shading point lives on the stack for this one call.
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const {
        BsdfEval out;
        if (!(total_sample_weight_ > 0)) return out;
        for (const Closure& c : closures_) add(out, c, eval_model(c.model, ctx, wi));
        out.pdf /= total_sample_weight_;
        return out;
    }
    double pdf(const ShadingPoint& sp, Vec3 wi) const {
        if (!(total_sample_weight_ > 0)) return 0.0;
        double pdf = 0.0;
        for (size_t i = 0; i < closures_.size(); ++i)
            pdf += closures_[i].sample_weight() * pdf_model(closures_[i].model, sp.models[i], wi);
        return pdf / total_sample_weight_;
    }
    double pdf(const ShadingContext& ctx, Vec3 wi) const {
        if (!(total_sample_weight_ > 0)) return 0.0;
        double pdf = 0.0;
        for (const Closure& c : closures_) pdf += c.sample_weight() * pdf_model(c.model, ctx, wi);
        return pdf / total_sample_weight_;
    }

    // u[2] picks the closure and is rescaled for the closure's own use.
    BsdfSample sample(const ShadingPoint& sp, std::array<double, 3> u) const {
        BsdfSample out;
        if (!(total_sample_weight_ > 0)) return out;
        if (closures_.size() == 1) return weighted(closures_[0], sample_model(closures_[0].model, sp.models[0], u));
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
    // The scalar form; one closure needs no prepared sum (several combine at the sampled direction).
    BsdfSample sample(const ShadingContext& ctx, std::array<double, 3> u) const {
        if (closures_.size() != 1) return sample(prepare(ctx), u);
        if (!(total_sample_weight_ > 0)) return {};
        const Closure& c = closures_[0];
        return weighted(c, std::visit([&](const auto& model) { return model.sample(model.prepare(ctx), u); }, c.model));
    }

private:
    // Adds closure c's share of an eval: weight x lobes, sample weight x pdf.
    static void add(BsdfEval& out, const Closure& c, const BsdfEval& e) {
        for (int p = 0; p < kLobeCount; ++p) out.lobes[p] += c.weight * e.lobes[p];
        out.pdf += c.sample_weight() * e.pdf;
    }
    static BsdfSample weighted(const Closure& c, BsdfSample s) {
        s.value = c.weight * s.value;
        s.weight = c.weight * s.weight;
        return s;
    }

    std::vector<Closure> closures_;
    double total_sample_weight_ = 0;
};

}  // namespace hairbsdf
