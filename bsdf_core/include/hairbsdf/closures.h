// The closure registry and weighted sums of closures. Adding a model means adding it to
// `HairModel` and its ShadingPoint to `PreparedModel` below; every model has prepare(ctx),
// eval(point, wi), sample(point, u), and the convenience forms taking a ShadingContext.
#pragma once

#include <optional>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "hairbsdf/models/chiang.h"
#include "hairbsdf/models/cycles_hair.h"
#include "hairbsdf/models/deon.h"
#include "hairbsdf/models/diffuse.h"
#include "hairbsdf/models/emission.h"
#include "hairbsdf/models/epic.h"
#include "hairbsdf/models/huang.h"
#include "hairbsdf/models/kajiya_kay.h"
#include "hairbsdf/models/marschner.h"
#include "hairbsdf/models/plugin_hair.h"
#include "hairbsdf/models/scheuermann.h"
#include "hairbsdf/models/yan_fur.h"

namespace hairbsdf {

using HairModel = std::variant<ChiangHair, HuangHair, KajiyaKayHair, EpicHair, ScheuermannHair, MarschnerHair, DeonHair,
                               PluginHair, CyclesHair, YanFurHair, DiffuseBsdf>;
// Per-shading-point state of each model (its `ShadingPoint`), from model.prepare(ctx).
using PreparedModel = std::variant<std::monostate, ChiangHair::ShadingPoint, HuangHair::ShadingPoint,
                                   KajiyaKayHair::ShadingPoint, EpicHair::ShadingPoint,
                                   ScheuermannHair::ShadingPoint, MarschnerHair::ShadingPoint,
                                   DeonHair::ShadingPoint, PluginHair::ShadingPoint, CyclesHair::ShadingPoint,
                                   YanFurHair::ShadingPoint, DiffuseBsdf::ShadingPoint>;

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

// ---- What the renderer needs from a model. render/ reaches models through these alone. ----
// Each is the model's own member where it has one, else the default named here.
template <class M, class = void>
struct has_blurred : std::false_type {};  // Filter Glossy: model.blurred(roughness); default: not blurred
template <class M>
struct has_blurred<M, std::void_t<decltype(std::declval<const M&>().blurred(0.5))>> : std::true_type {};
template <class M, class = void>
struct has_stochastic_eval : std::false_type {};  // M::kStochasticEval; default: deterministic
template <class M>
struct has_stochastic_eval<M, std::void_t<decltype(M::kStochasticEval)>> : std::bool_constant<M::kStochasticEval> {};
template <class M, class = void>
struct has_transmits : std::false_type {};
template <class M>
struct has_transmits<M, std::void_t<decltype(std::declval<const M&>().transmits())>> : std::true_type {};
template <class M, class = void>
struct has_transparent : std::false_type {};
template <class M>
struct has_transparent<M, std::void_t<decltype(M::transparent(std::declval<const typename M::ShadingPoint&>()))>>
    : std::true_type {};
template <class M, class = void>
struct sample_value_is_eval : std::true_type {};  // M::kSampleValueIsEval; default: yes
template <class M>
struct sample_value_is_eval<M, std::void_t<decltype(M::kSampleValueIsEval)>> : std::bool_constant<M::kSampleValueIsEval> {};
template <class M, class = void>
struct has_hair_lobes : std::true_type {};  // M::kHairLobes: its value is a share of the hair lobe passes
template <class M>
struct has_hair_lobes<M, std::void_t<decltype(M::kHairLobes)>> : std::bool_constant<M::kHairLobes> {};

// Filter Glossy applied to a model (Cycles' bsdf_blur): `out` holds the blurred model, or is
// left alone and false returned where the model is not blurred.
inline bool blur_model(const HairModel& m, double roughness, std::optional<HairModel>& out) {
    return std::visit(
        [&](const auto& model) {
            using M = std::decay_t<decltype(model)>;
            if constexpr (has_blurred<M>::value) {
                out.emplace(std::in_place_type<M>, model.blurred(roughness));
                return true;
            } else {
                return false;
            }
        },
        m);
}
// Cycles' SD_BSDF_HAS_TRANSMISSION: model.transmits(), M::kTransmits; default (hair) yes.
inline bool model_transmits(const HairModel& m) {
    return std::visit(
        [](const auto& model) {
            using M = std::decay_t<decltype(model)>;
            if constexpr (has_transmits<M>::value)
                return bool(model.transmits());
            else
                return true;
        },
        m);
}
inline bool model_hair_lobes(const HairModel& m) {
    return std::visit([](const auto& model) { return has_hair_lobes<std::decay_t<decltype(model)>>::value; }, m);
}
// Whether the renderer's eval is stochastic; then `eval_seed` turns one uniform number of the
// path's sampler into the state that eval_at_hit and sample_at_hit advance.
inline bool model_stochastic_eval(const HairModel& m) {
    return std::visit([](const auto& model) { return has_stochastic_eval<std::decay_t<decltype(model)>>::value; }, m);
}
inline uint32_t model_eval_seed(const HairModel& m, double u) {
    return std::visit(
        [&](const auto& model) -> uint32_t {
            using M = std::decay_t<decltype(model)>;
            if constexpr (has_stochastic_eval<M>::value)
                return M::eval_seed(u);
            else
                return 0u;
        },
        m);
}
// A closure replaced by a transparent one at this point (straight on, no value in any direction).
inline bool model_transparent(const HairModel& m, const PreparedModel& point) {
    return std::visit(
        [&](const auto& model) {
            using M = std::decay_t<decltype(model)>;
            if constexpr (has_transparent<M>::value)
                return M::transparent(std::get<typename M::ShadingPoint>(point));
            else
                return false;
        },
        m);
}
// The renderer's eval: the stochastic estimate where the model's eval is stochastic; no value
// and pdf 0 where anything is not finite (a failed plugin call never reaches the image).
inline BsdfEval eval_at_hit(const HairModel& m, const PreparedModel& point, Vec3 wi, uint32_t& rng_state) {
    const BsdfEval e = std::visit(
        [&](const auto& model) {
            using M = std::decay_t<decltype(model)>;
            const auto& sp = std::get<typename M::ShadingPoint>(point);
            if constexpr (has_stochastic_eval<M>::value)
                return model.eval_estimate(sp, wi, rng_state);
            else
                return model.eval(sp, wi);
        },
        m);
    if (!(e.pdf >= 0) || !std::isfinite(e.pdf) || !isfinite(e.value())) return {};
    return e;
}
// The renderer's sample. `longitudinal`: Cycles < 3.6's numbers for Chiang; `lobes`: fill the
// per-lobe values at the sampled direction (the model's eval there, or the sampled value in
// the sampled lobe where the sampler's value is not its eval).
inline ScatterSample sample_at_hit(const HairModel& m, const PreparedModel& point, const std::array<double, 3>& u,
                                   const LongitudinalNumbers* longitudinal, uint32_t& rng_state, bool lobes) {
    return std::visit(
        [&](const auto& model) {
            using M = std::decay_t<decltype(model)>;
            const auto& sp = std::get<typename M::ShadingPoint>(point);
            ScatterSample out;
            if constexpr (has_stochastic_eval<M>::value) {
                return model.sample_estimate(sp, u, rng_state);
            } else {
                BsdfSample s;
                if constexpr (std::is_same_v<M, ChiangHair>)
                    s = model.sample(sp, u, longitudinal);
                else
                    s = model.sample(sp, u);
                if (s.lobe < 0 || !(s.pdf > 0) || !isfinite(s.value) || !isfinite(s.wi)) return out;
                out.wi = s.wi;
                out.value = s.value;
                out.pdf = s.pdf;
                out.lobe = s.lobe;
                if (lobes) {
                    if constexpr (sample_value_is_eval<M>::value) {
                        const BsdfEval e = model.eval(sp, s.wi);
                        if (std::isfinite(e.pdf) && isfinite(e.value())) out.lobes = e.lobes;
                    } else {
                        out.lobes[size_t(s.lobe)] = s.value;
                    }
                }
                return out;
            }
        },
        m);
}

// Cycles' closure pick (surface_shader_bsdf_bssrdf_pick): closure i of `count` with probability
// sample_weight(i) / total, and `u` rescaled to [0, 1] within the picked closure's share.
template <class SampleWeight>
size_t pick_closure(size_t count, double total, const SampleWeight& sample_weight, double& u) {
    double r = u * total;
    for (size_t i = 0; i < count; ++i) {
        const double w = sample_weight(i);
        if (r < w || i + 1 == count) {
            u = w > 0 ? clamp(r / w, 0.0, 1.0) : 0.5;
            return i;
        }
        r -= w;
    }
    return count - 1;
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
        const size_t picked = pick_closure(
            closures_.size(), total_sample_weight_, [&](size_t i) { return closures_[i].sample_weight(); }, u[2]);
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
