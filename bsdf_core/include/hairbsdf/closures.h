// The closure registry and weighted sums of closures. Adding a model means adding it to
// `HairModel` and its ShadingPoint to `PreparedModel` below; every model has prepare(ctx),
// eval(point, wi), sample(point, u), and the convenience forms taking a ShadingContext.
#pragma once

#include <array>
#include <optional>
#include <stdexcept>
#include <string>
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

// What the renderer takes from a sum at a hit (ClosureSum::render_eval): the value (sum of
// weight x eval, cosine included), the mixture pdf, and the hair closures' share of the value
// per lobe.
struct BsdfValue {
    RGB value;
    double pdf = 0;
    std::array<RGB, kLobeCount> lobes{};
};
// The renderer's sample of a sum (ClosureSum::render_sample): value and lobes as BsdfValue's
// at wi, the mixture pdf, the pdf Cycles' Filter Glossy sees (Huang reports 1) and the label.
struct BsdfScatter {
    Vec3 wi;
    RGB value;
    std::array<RGB, kLobeCount> lobes{};
    double pdf = 0;
    double blur_pdf = 0;
    uint8_t label = LabelNone;
};

// One closure of a sum prepared at a shading point: weight x model, and the model's shading
// point. The model is not owned (the ClosureSum's, or the renderer's model for the hit).
struct PreparedClosure {
    RGB weight{0.0};
    double sample_weight = 0;          // |average(weight)|, Cycles' pick share
    const HairModel* model = nullptr;
    PreparedModel point;               // model.prepare(ctx)
    bool transparent = false;          // the renderer's: a transparent closure here (Huang outside its ellipse)
    bool hair_lobes = true;            // its value is a share of the hair lobe passes
};

// Cycles adds a closure to a sum's eval only where its pdf is non-zero (surface_shader_bsdf_eval).
inline bool closure_counts(const BsdfEval& e) { return e.pdf != 0.0; }

// A weighted sum of closures, evaluated and sampled as Cycles does with several BSDFs:
// eval sums weight * value over the closures with a non-zero pdf, the pdf is the sample-weight
// mixture of the closures' pdfs, sample picks one closure by sample weight and combines it with
// the others at the sampled direction. The Python API and the renderer share the shading point
// below and its loops: the API prepares its own closures (prepare), the renderer adds the
// models of a hit (ShadingPoint::add_at_hit) and uses the render_ forms.
class ClosureSum {
public:
    static constexpr size_t kCapacity = 16;

    ClosureSum() = default;
    // Throws std::invalid_argument beyond kCapacity closures.
    explicit ClosureSum(std::vector<Closure> closures) : closures_(std::move(closures)) {
        if (closures_.size() > kCapacity)
            throw std::invalid_argument("a closure sum holds at most " + std::to_string(kCapacity) +
                                        " closures, got " + std::to_string(closures_.size()));
        for (const Closure& c : closures_) total_sample_weight_ += c.sample_weight();
    }
    const std::vector<Closure>& closures() const { return closures_; }

    // The closures prepared for one shading point: fixed capacity, no allocation of its own; the
    // view-dependent terms computed once and shared by every eval, pdf and sample there.
    struct ShadingPoint {
        std::array<PreparedClosure, kCapacity> closures;
        size_t count = 0;
        double total_sample_weight = 0;
        Vec3 wo{};

        // Empties the sum; the closures' shading points keep their storage.
        void clear(Vec3 view) {
            count = 0;
            total_sample_weight = 0;
            wo = view;
        }
        // Adds weight x model prepared at ctx (the model must outlive the point); false when full.
        bool add(const RGB& weight, const HairModel& model, const ShadingContext& ctx) {
            if (count == kCapacity) return false;
            PreparedClosure& c = closures[count++];
            c.weight = weight;
            c.sample_weight = std::fabs(average(weight));
            c.model = &model;
            prepare_model(model, ctx, c.point);
            c.transparent = false;
            c.hair_lobes = model_hair_lobes(model);
            total_sample_weight += c.sample_weight;
            return true;
        }
        // The same in the renderer, where a model may make the closure a transparent one here.
        bool add_at_hit(const RGB& weight, const HairModel& model, const ShadingContext& ctx) {
            if (!add(weight, model, ctx)) return false;
            PreparedClosure& c = closures[count - 1];
            c.transparent = model_transparent(model, c.point);
            return true;
        }
        bool empty() const { return count == 0 || !(total_sample_weight > 0); }
        // Cycles' SD_BSDF_HAS_TRANSMISSION: a closure whose model transmits.
        bool transmits() const {
            for (size_t i = 0; i < count; ++i)
                if (model_transmits(*closures[i].model)) return true;
            return false;
        }
        // The first model whose renderer eval is stochastic (it seeds the eval), or nullptr.
        const HairModel* stochastic_model() const {
            for (size_t i = 0; i < count; ++i)
                if (model_stochastic_eval(*closures[i].model)) return closures[i].model;
            return nullptr;
        }
    };
    ShadingPoint prepare(const ShadingContext& ctx) const {
        ShadingPoint sp;
        prepare(ctx, sp);
        return sp;
    }
    // Reuses `sp`'s storage (the models' shading points keep their alternative).
    void prepare(const ShadingContext& ctx, ShadingPoint& sp) const {
        sp.clear(ctx.wo);
        for (const Closure& c : closures_) sp.add(c.weight, c.model, ctx);
        sp.total_sample_weight = total_sample_weight_;
    }

    // ---- The Python API: each model's own eval, pdf and sample. ----
    static BsdfEval eval(const ShadingPoint& sp, Vec3 wi) {
        BsdfEval out;
        if (!(sp.total_sample_weight > 0)) return out;
        out.pdf = sum_closures(sp, sp.count, 0.0,
                               [&](const PreparedClosure& c) { return eval_model(*c.model, c.point, wi); },
                               [&](const PreparedClosure& c, const BsdfEval& e) { add_lobes(out.lobes, c.weight, e); });
        out.pdf /= sp.total_sample_weight;
        return out;
    }
    // The scalar form: each closure's shading point lives on the stack for this one call. One
    // closure (the common case) is weighted in place, without the sum's accumulator; the same
    // values as the loop (0 + x is x).
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const {
        if (!(total_sample_weight_ > 0)) return {};
        if (closures_.size() == 1) {
            // The model's result is weighted where it was returned (no zeroed accumulator copied over).
            const Closure& c = closures_[0];
            const ChiangHair* chiang = std::get_if<ChiangHair>(&c.model);  // devirtualised for Chiang
            BsdfEval e = chiang ? chiang->eval(chiang->prepare(ctx), wi) : eval_model(c.model, ctx, wi);
            if (!closure_counts(e)) {
                e = BsdfEval{};
            } else {
                // Chiang leaves the lobes past its four at zero: only its own are weighted.
                const size_t lobes = chiang ? size_t(kChiangLobeCount) : size_t(kLobeCount);
                for (size_t p = 0; p < lobes; ++p) e.lobes[p] = c.weight * e.lobes[p];
                e.pdf = c.sample_weight() * e.pdf / total_sample_weight_;
            }
            return e;
        }
        BsdfEval out;
        for (const Closure& c : closures_) {
            const BsdfEval e = eval_model(c.model, ctx, wi);
            if (!closure_counts(e)) continue;
            add_lobes(out.lobes, c.weight, e);
            out.pdf += c.sample_weight() * e.pdf;
        }
        out.pdf /= total_sample_weight_;
        return out;
    }
    static double pdf(const ShadingPoint& sp, Vec3 wi) {
        if (!(sp.total_sample_weight > 0)) return 0.0;
        double pdf = 0.0;
        for (size_t i = 0; i < sp.count; ++i) {
            const PreparedClosure& c = sp.closures[i];
            pdf += c.sample_weight * pdf_model(*c.model, c.point, wi);
        }
        return pdf / sp.total_sample_weight;
    }
    double pdf(const ShadingContext& ctx, Vec3 wi) const {
        if (!(total_sample_weight_ > 0)) return 0.0;
        double pdf = 0.0;
        for (const Closure& c : closures_) pdf += c.sample_weight() * pdf_model(c.model, ctx, wi);
        return pdf / total_sample_weight_;
    }

    // u[2] picks the closure and is rescaled for the closure's own use.
    static BsdfSample sample(const ShadingPoint& sp, std::array<double, 3> u) {
        BsdfSample out;
        if (!(sp.total_sample_weight > 0)) return out;
        if (sp.count == 1) {
            const PreparedClosure& c = sp.closures[0];
            return weighted(c.weight, sample_model(*c.model, c.point, u));
        }
        const size_t picked = pick(sp, u[2]);
        const PreparedClosure& p = sp.closures[picked];
        const BsdfSample s = sample_model(*p.model, p.point, u);
        if (s.lobe < 0) return out;
        // Combine with the other closures' values and pdfs at the sampled direction.
        RGB value = p.weight * s.value;
        double pdf = sum_closures(
            sp, picked, p.sample_weight * s.pdf,
            [&](const PreparedClosure& c) { return eval_model(*c.model, c.point, s.wi); },
            [&](const PreparedClosure& c, const BsdfEval& e) { value += c.weight * e.value(); });
        pdf /= sp.total_sample_weight;
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
        return weighted(c.weight,
                        std::visit([&](const auto& model) { return model.sample(model.prepare(ctx), u); }, c.model));
    }

    // ---- The renderer: each model's eval_at_hit / sample_at_hit (stochastic evals advance
    // `rng_state`, non-finite results count as none), transparent closures, per-lobe passes. ----
    static BsdfValue render_eval(const ShadingPoint& sp, Vec3 wi, uint32_t& rng_state) {
        BsdfValue out;
        out.pdf = sum_closures(sp, sp.count, 0.0,
                               [&](const PreparedClosure& c) { return eval_at_hit(*c.model, c.point, wi, rng_state); },
                               [&](const PreparedClosure& c, const BsdfEval& e) { add_pass(out.value, out.lobes, c, e); });
        out.pdf /= sp.total_sample_weight;
        return out;
    }
    // `longitudinal`: Cycles < 3.6's numbers for Chiang; `lobes`: fill the per-lobe values.
    static BsdfScatter render_sample(const ShadingPoint& sp, double u0, double u1, double u2,
                                     const LongitudinalNumbers* longitudinal, uint32_t& rng_state, bool lobes) {
        BsdfScatter out;
        if (sp.count == 0) return out;
        const size_t picked = sp.count > 1 ? pick(sp, u2) : 0;
        const PreparedClosure& p = sp.closures[picked];
        if (p.transparent) {
            // Cycles' transparent BSDF: straight on, value = weight, pdf = the pick probability.
            out.wi = -1.0 * sp.wo;
            out.value = p.weight;
            out.pdf = p.sample_weight / sp.total_sample_weight;
            out.blur_pdf = out.pdf;
            out.label = LabelTransparent;
            return out;
        }
        const ScatterSample s = sample_at_hit(*p.model, p.point, {u0, u1, u2}, longitudinal, rng_state, lobes);
        if (s.lobe < 0) return out;
        out.wi = s.wi;
        for (int k = 0; k < kLobeCount; ++k) out.lobes[size_t(k)] = p.weight * s.lobes[size_t(k)];
        RGB value = s.value_from_lobes ? sum_of_lobes(out.lobes) : p.weight * s.value;
        if (!p.hair_lobes) out.lobes = {};
        out.label = scatter_label(*p.model, s.lobe);
        // Combine with the other closures at the sampled direction.
        double pdf = sum_closures(
            sp, picked, p.sample_weight * s.pdf,
            [&](const PreparedClosure& c) { return eval_at_hit(*c.model, c.point, out.wi, rng_state); },
            [&](const PreparedClosure& c, const BsdfEval& e) { add_pass(value, out.lobes, c, e); });
        out.pdf = pdf / sp.total_sample_weight;
        out.blur_pdf = s.blur_pdf_one ? 1.0 : out.pdf;  // Cycles' Huang sampler reports pdf 1
        out.value = value;
        if (!(out.pdf > 0) || !std::isfinite(out.pdf)) out.label = LabelNone;
        return out;
    }

private:
    // Cycles' surface_shader_bsdf_eval over the closures but `skip`: `eval_one(c)` each, and
    // where it counts (closure_counts; a transparent closure never does) `add(c, e)`; returns
    // `pdf` plus the sample-weighted pdfs.
    template <class EvalOne, class Add>
    static double sum_closures(const ShadingPoint& sp, size_t skip, double pdf, EvalOne&& eval_one, Add&& add) {
        for (size_t i = 0; i < sp.count; ++i) {
            const PreparedClosure& c = sp.closures[i];
            if (i == skip || c.transparent) continue;
            const BsdfEval e = eval_one(c);
            if (!closure_counts(e)) continue;
            add(c, e);
            pdf += c.sample_weight * e.pdf;
        }
        return pdf;
    }
    static size_t pick(const ShadingPoint& sp, double& u) {
        return pick_closure(sp.count, sp.total_sample_weight, [&](size_t i) { return sp.closures[i].sample_weight; }, u);
    }
    static void add_lobes(std::array<RGB, kLobeCount>& lobes, const RGB& weight, const BsdfEval& e) {
        for (int p = 0; p < kLobeCount; ++p) lobes[size_t(p)] += weight * e.lobes[size_t(p)];
    }
    // The renderer's share of closure c: its weighted value, and its lobes where they are hair lobes.
    static void add_pass(RGB& value, std::array<RGB, kLobeCount>& lobes, const PreparedClosure& c, const BsdfEval& e) {
        std::array<RGB, kLobeCount> weighted_lobes;
        for (int k = 0; k < kLobeCount; ++k) weighted_lobes[size_t(k)] = c.weight * e.lobes[size_t(k)];
        value += sum_of_lobes(weighted_lobes);
        for (int k = 0; k < kLobeCount; ++k) lobes[size_t(k)] += c.hair_lobes ? weighted_lobes[size_t(k)] : RGB(0.0);
    }
    static BsdfSample weighted(const RGB& weight, BsdfSample s) {
        s.value = weight * s.value;
        s.weight = weight * s.weight;
        return s;
    }

    std::vector<Closure> closures_;
    double total_sample_weight_ = 0;
};

}  // namespace hairbsdf
