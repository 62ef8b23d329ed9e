// Materials and the per-hit closure mixture; see render/shading.h.
#include "hairbsdf/render/shading.h"

#include "hairbsdf/render/lights.h"

namespace hairbsdf::render {

namespace {

// Huang in the renderer: Cycles' sampler (Cycles' estimator), or the coarse sampling mixture
// (exact pdf, fewer components than the API's: noise only).
HuangHairParams render_huang_params(const PrincipledHairInputs& in, HuangSampler sampler, GlassAlbedoTable table) {
    HuangHairParams p = huang_params_from_principled(in);
    p.glass_albedo_table = table;
    p.sampler = sampler;
    p.mixture_detail = sampler == HuangSampler::Cycles ? HuangHairParams::MixtureDetail::None
                                                       : HuangHairParams::MixtureDetail::Coarse;
    return p;
}

bool hair_depends_on_random(const PrincipledHairInputs& in) {
    if (in.random_roughness != 0.0) return true;
    return in.parametrization == Parametrization::Melanin && in.random_color != 0.0;
}

}  // namespace

double register_value(const float* registers, int32_t reg) {
    const float v = registers[reg];
    return std::isfinite(v) ? double(v) : 0.0;
}

RGB register_rgb(const float* registers, int32_t reg) {
    return RGB(register_value(registers, reg), register_value(registers, reg + 1), register_value(registers, reg + 2));
}

void apply_links(const std::vector<ClosureDesc::Link>& links, const float* r, PrincipledHairInputs& in,
                 bool& random_from_curve) {
    using In = ClosureDesc::Input;
    for (const ClosureDesc::Link& l : links) {
        switch (l.input) {
            case In::Color: in.color = register_rgb(r, l.reg); break;
            case In::Melanin: in.melanin = register_value(r, l.reg); break;
            case In::MelaninRedness: in.melanin_redness = register_value(r, l.reg); break;
            case In::Tint: in.tint = register_rgb(r, l.reg); break;
            case In::AbsorptionCoefficient: in.absorption_coefficient = register_rgb(r, l.reg); break;
            case In::Roughness: in.roughness = register_value(r, l.reg); break;
            case In::RadialRoughness: in.radial_roughness = register_value(r, l.reg); break;
            case In::Coat: in.coat = register_value(r, l.reg); break;
            case In::Ior: in.ior = register_value(r, l.reg); break;
            case In::Offset: in.offset = register_value(r, l.reg); break;
            case In::RandomColor: in.random_color = register_value(r, l.reg); break;
            case In::RandomRoughness: in.random_roughness = register_value(r, l.reg); break;
            case In::Random:
                in.random = register_value(r, l.reg);
                random_from_curve = false;
                break;
            case In::AspectRatio: in.aspect_ratio = register_value(r, l.reg); break;
            case In::Reflection: in.reflection = register_value(r, l.reg); break;
            case In::Transmission: in.transmission = register_value(r, l.reg); break;
            case In::SecondaryReflection: in.secondary_reflection = register_value(r, l.reg); break;
            case In::Strength: break;
        }
    }
}

RGB MaterialShader::emission(const float* registers) const {
    RGB e = emission_;
    if (!registers) return e;
    for (const LinkedEmission& l : linked_emission_) {
        const RGB color = l.color_register >= 0 ? register_rgb(registers, l.color_register) : l.color;
        const double strength = l.strength_register >= 0 ? register_value(registers, l.strength_register) : l.strength;
        e += strength * (l.weight * color);
    }
    return e;
}

MaterialShader::MaterialShader(const MaterialDesc& desc, TiltConvention tilt, Accuracy accuracy,
                               HuangSampler huang_sampler, GlassAlbedoTable huang_glass_albedo_table)
    : program_(desc.program), tilt_(tilt), accuracy_(accuracy), huang_sampler_(huang_sampler),
      huang_glass_albedo_table_(huang_glass_albedo_table) {
    const bool with_program = !desc.program.empty();
    for (const ClosureDesc& c : desc.closures) {
        switch (c.type) {
            case ClosureDesc::Type::PrincipledHair: {
                if (std::fabs(average(c.weight)) < kClosureWeightCutoff) break;
                HairClosure h;
                h.weight = c.weight;
                h.inputs = c.hair;
                h.random_from_curve = c.random_from_curve;
                if (with_program) h.links = c.links;
                h.depends_on_random = (c.random_from_curve && hair_depends_on_random(c.hair)) || !h.links.empty();
                h.huang = c.hair_model == ClosureDesc::HairModel::Huang;
                has_huang_ = has_huang_ || h.huang;
                if (!h.depends_on_random) {
                    PrincipledHairInputs in = c.hair;
                    if (c.random_from_curve) in.random = 0.0;  // unused by the parameters
                    if (h.huang)
                        h.fixed_huang.emplace(render_huang_params(in, huang_sampler, huang_glass_albedo_table));
                    else
                        h.fixed.emplace(chiang_params_from_principled(in, accuracy, tilt));
                }
                if (closure_count() < size_t(kMaxBsdfClosures)) hair_.push_back(std::move(h));
                break;
            }
            case ClosureDesc::Type::CyclesHair: {
                const RGB w = c.weight * c.color;  // Cycles: the node's Color is the closure weight
                if (std::fabs(average(w)) < kClosureWeightCutoff) break;
                CyclesHairParams p;
                p.component = c.transmission ? CyclesHairComponent::Transmission : CyclesHairComponent::Reflection;
                p.color = RGB(1.0);
                p.offset = c.offset;
                p.roughness_u = c.roughness_u;
                p.roughness_v = c.roughness_v;
                if (closure_count() < size_t(kMaxBsdfClosures)) cycles_hair_.push_back({w, CyclesHair(p)});
                break;
            }
            case ClosureDesc::Type::Diffuse: {
                int32_t color_register = -1;
                if (with_program)
                    for (const ClosureDesc::Link& l : c.links)
                        if (l.input == ClosureDesc::Input::Color) color_register = l.reg;
                if (color_register >= 0) {
                    if (std::fabs(average(c.weight)) < kClosureWeightCutoff) break;
                    if (closure_count() < size_t(kMaxBsdfClosures))
                        diffuse_.push_back({c.weight, color_register});
                    break;
                }
                const RGB w = c.weight * c.color;
                if (std::fabs(average(w)) < kClosureWeightCutoff) break;
                if (closure_count() < size_t(kMaxBsdfClosures)) diffuse_.push_back({w});
                break;
            }
            case ClosureDesc::Type::Emission: {
                LinkedEmission l{c.weight, c.color, c.strength};
                if (with_program)
                    for (const ClosureDesc::Link& k : c.links) {
                        if (k.input == ClosureDesc::Input::Color) l.color_register = k.reg;
                        if (k.input == ClosureDesc::Input::Strength) l.strength_register = k.reg;
                    }
                if (l.color_register >= 0 || l.strength_register >= 0)
                    linked_emission_.push_back(l);
                else
                    emission_ += c.strength * (c.weight * c.color);
                break;
            }
            case ClosureDesc::Type::Model:  // render/model_closure.h
                if (std::fabs(average(c.weight)) < kClosureWeightCutoff) break;
                if (closure_count() < size_t(kMaxBsdfClosures))
                    models_.push_back(build_model_closure(c, "material '" + desc.name + "'"));
                break;
        }
    }
}

namespace {
// A per-hit closure's Principled Hair inputs: the curve's random and the program's values.
PrincipledHairInputs hit_inputs(const MaterialShader::HairClosure& h, const ShadingGeometry& g) {
    PrincipledHairInputs in = h.inputs;
    bool random_from_curve = h.random_from_curve;
    if (g.registers) apply_links(h.links, g.registers, in, random_from_curve);
    if (random_from_curve) in.random = g.random;
    return in;
}
}  // namespace

void Bsdf::set(const MaterialShader& material, const ShadingGeometry& g, double blur_roughness, uint32_t seed,
               bool lobes) {
    count_ = 0;
    lobes_ = lobes;
    huang_rng_ = seed;
    total_sample_weight_ = 0;
    hair_ctx_.tangent = g.tangent;
    hair_ctx_.wo = g.wo;
    hair_ctx_.h = clamp(g.h, -1.0, 1.0);
    n_ = g.n;
    ng_ = g.ng;
    for (const MaterialShader::HairClosure& h : material.hair()) {
        const int slot = count_;
        if (h.huang) {
            const HuangHair* model = nullptr;
            if (h.fixed_huang && !(blur_roughness > 0)) {
                model = &*h.fixed_huang;
            } else if (h.fixed_huang) {
                huang_storage_[size_t(slot)].emplace(h.fixed_huang->blurred(blur_roughness));
                model = &*huang_storage_[size_t(slot)];
            } else {
                const HuangHairParams params = render_huang_params(hit_inputs(h, g), material.huang_sampler(),
                                                                   material.huang_glass_albedo_table());
                if (blur_roughness > 0)
                    huang_storage_[size_t(slot)].emplace(HuangHair(params).blurred(blur_roughness));
                else
                    huang_storage_[size_t(slot)].emplace(params);
                model = &*huang_storage_[size_t(slot)];
            }
            ShadingContext ctx = hair_ctx_;
            ctx.normal = g.curve_normal;
            ctx.pixel_coverage = g.pixel_coverage;
            ctx.near_field = g.near_field;
            huang_points_[size_t(slot)] = model->prepare(ctx);
            const bool transparent = huang_points_[size_t(slot)].transparent;
            entries_[size_t(slot)] = {transparent ? Entry::Kind::Transparent : Entry::Kind::Huang, h.weight,
                                      std::fabs(average(h.weight)), nullptr, model};
            total_sample_weight_ += entries_[size_t(slot)].sample_weight;
            ++count_;
            continue;
        }
        const ChiangHair* model = nullptr;
        if (h.fixed && !(blur_roughness > 0)) {
            model = &*h.fixed;
        } else if (h.fixed) {
            storage_[size_t(slot)].emplace(h.fixed->blurred(blur_roughness));
            model = &*storage_[size_t(slot)];
        } else {
            const ChiangHairParams params =
                chiang_params_from_principled(hit_inputs(h, g), material.accuracy(), material.tilt());
            if (blur_roughness > 0)
                storage_[size_t(slot)].emplace(ChiangHair(params).blurred(blur_roughness));
            else
                storage_[size_t(slot)].emplace(params);
            model = &*storage_[size_t(slot)];
        }
        points_[size_t(slot)].emplace(model->prepare(hair_ctx_));
        entries_[size_t(slot)] = {Entry::Kind::Hair, h.weight, std::fabs(average(h.weight)), model, nullptr};
        total_sample_weight_ += entries_[size_t(slot)].sample_weight;
        ++count_;
    }
    for (const MaterialShader::CyclesHairClosure& c : material.cycles_hair()) {
        legacy_points_[size_t(count_)].emplace(c.model.prepare(hair_ctx_));
        legacy_points_[size_t(count_)]->normal = g.n;  // Cycles' N test uses the hit's shading normal
        entries_[size_t(count_)] = {Entry::Kind::Legacy, c.weight, std::fabs(average(c.weight)), nullptr, nullptr,
                                    &c.model};
        total_sample_weight_ += entries_[size_t(count_)].sample_weight;
        ++count_;
    }
    for (const MaterialShader::DiffuseClosure& d : material.diffuse()) {
        RGB w = d.weight;
        if (d.color_register >= 0) w = g.registers ? w * register_rgb(g.registers, d.color_register) : RGB(0.0);
        entries_[size_t(count_)] = {Entry::Kind::Diffuse, w, std::fabs(average(w)), nullptr, nullptr};
        total_sample_weight_ += entries_[size_t(count_)].sample_weight;
        ++count_;
    }
    for (const ModelClosure& m : material.models()) {  // hair_model closures (render/model_closure.h)
        if (count_ >= kMaxBsdfClosures) break;
        ShadingContext ctx = hair_ctx_;
        ctx.random = g.random;
        ctx.normal = g.curve_normal;
        model_points_[size_t(count_)].prepare(m, ctx);
        entries_[size_t(count_)] = {Entry::Kind::Model, m.weight, std::fabs(average(m.weight)), nullptr, nullptr};
        total_sample_weight_ += entries_[size_t(count_)].sample_weight;
        ++count_;
    }
    if (!(total_sample_weight_ > 0)) count_ = 0;
}

std::array<RGB, kLobeCount> Bsdf::eval_huang(int i, Vec3 wi) const {
    const Entry& e = entries_[size_t(i)];
    const HuangHair::ShadingPoint& sp = huang_points_[size_t(i)];
    std::array<RGB, kLobeCount> lobes = e.huang->eval_cycles_stochastic(sp, e.huang->to_local(sp, wi), huang_rng_);
    for (RGB& l : lobes) l = e.weight * l;
    return lobes;
}

BsdfValue Bsdf::eval_entry(int i, Vec3 wi) const {
    const Entry& e = entries_[size_t(i)];
    BsdfValue out;
    if (e.kind == Entry::Kind::Transparent) return out;  // a delta: no value in any sampled direction
    if (e.kind == Entry::Kind::Model) {
        const BsdfEval r = model_points_[size_t(i)].eval(wi);
        for (int k = 0; k < kLobeCount; ++k) out.lobes[size_t(k)] = e.weight * r.lobes[size_t(k)];
        out.value = sum_of_lobes(out.lobes);
        out.pdf = r.pdf;
        return out;
    }
    if (e.kind == Entry::Kind::Huang) {
        const HuangHair::ShadingPoint& sp = huang_points_[size_t(i)];
        out.pdf = e.huang->pdf(sp, wi);
        if (out.pdf > 0) {
            out.lobes = eval_huang(i, wi);
            out.value = sum_of_lobes(out.lobes);
        }
        return out;
    }
    if (e.kind == Entry::Kind::Hair || e.kind == Entry::Kind::Legacy) {
        const BsdfEval r = e.kind == Entry::Kind::Hair ? e.hair->eval(*points_[size_t(i)], wi)
                                                       : e.legacy->eval(*legacy_points_[size_t(i)], wi);
        for (int k = 0; k < kLobeCount; ++k) out.lobes[size_t(k)] = e.weight * r.lobes[size_t(k)];
        out.value = sum_of_lobes(out.lobes);
        out.pdf = r.pdf;
    } else {
        // Cycles' diffuse eval tests only N; its sampler also requires Ng . wi > 0.
        const double c = dot(n_, wi);
        if (c > 0) {
            out.pdf = c / kPi;
            out.value = out.pdf * e.weight;
        }
    }
    return out;
}

bool Bsdf::has_transmission() const {
    for (int i = 0; i < count_; ++i) {
        const Entry& e = entries_[size_t(i)];
        switch (e.kind) {
            case Entry::Kind::Hair:
            case Entry::Kind::Huang:
            case Entry::Kind::Transparent:  // a Huang closure outside its ellipse
            case Entry::Kind::Model:
                return true;
            case Entry::Kind::Legacy:
                if (!e.legacy->reflection()) return true;
                break;
            case Entry::Kind::Diffuse:
                break;
        }
    }
    return false;
}

BsdfValue Bsdf::eval(Vec3 wi) const {
    BsdfValue out;
    for (int i = 0; i < count_; ++i) {
        const Entry& e = entries_[size_t(i)];
        const BsdfValue v = eval_entry(i, wi);
        if (v.pdf != 0.0) {  // Cycles accumulates a closure only where its pdf is non-zero
            out.value += v.value;
            out.pdf += e.sample_weight * v.pdf;
            for (int k = 0; k < kLobeCount; ++k) out.lobes[size_t(k)] += v.lobes[size_t(k)];
        }
    }
    out.pdf /= total_sample_weight_;
    return out;
}

BsdfScatter Bsdf::sample(double u0, double u1, double u2, const LongitudinalNumbers* chiang_longitudinal) const {
    BsdfScatter out;
    if (count_ == 0) return out;
    // Pick a closure with u2 and rescale it (Cycles' surface_shader_bsdf_bssrdf_pick).
    int picked = count_ - 1;
    if (count_ > 1) {
        double r = u2 * total_sample_weight_;
        for (int i = 0; i < count_; ++i) {
            const double w = entries_[size_t(i)].sample_weight;
            if (r < w || i + 1 == count_) {
                picked = i;
                u2 = w > 0 ? clamp(r / w, 0.0, 1.0) : 0.5;
                break;
            }
            r -= w;
        }
    }
    const Entry& e = entries_[size_t(picked)];
    BsdfValue own;
    if (e.kind == Entry::Kind::Transparent) {
        // Cycles' transparent BSDF: straight on, value = weight, pdf = the pick probability.
        out.wi = -1.0 * hair_ctx_.wo;
        out.value = e.weight;
        out.pdf = e.sample_weight / total_sample_weight_;
        out.blur_pdf = out.pdf;
        out.label = LabelTransparent;
        return out;
    }
    if (e.kind == Entry::Kind::Huang) {
        const HuangHair::ShadingPoint& sp = huang_points_[size_t(picked)];
        int lobe;
        if (e.huang->params().sampler == HuangSampler::Cycles) {
            // Cycles' estimator: the traced path's energy estimate as the value, pdf 1.
            const BsdfSample s = e.huang->sample(sp, {u0, u1, u2});
            lobe = s.lobe;
            if (s.lobe < 0) return out;
            out.wi = s.wi;
            own.pdf = 1.0;
            own.value = e.weight * s.value;
            own.lobes[size_t(std::min(s.lobe, kLobeCount - 1))] = own.value;
        } else {
            Vec3 local;
            lobe = e.huang->sample_direction(sp, {u0, u1, u2}, local);
            if (lobe < 0) return out;
            out.wi = e.huang->to_world(sp, local);
            own.pdf = e.huang->pdf_local(sp, local);
            if (!(own.pdf > 0)) return out;
            own.lobes = eval_huang(picked, out.wi);
            own.value = sum_of_lobes(own.lobes);
        }
        out.label = HuangHair::scatter_label(lobe);
    } else if (e.kind == Entry::Kind::Hair || e.kind == Entry::Kind::Legacy) {
        const BsdfSample s = e.kind == Entry::Kind::Hair ? e.hair->sample(*points_[size_t(picked)], {u0, u1, u2},
                                                                          chiang_longitudinal)
                                                         : e.legacy->sample(*legacy_points_[size_t(picked)], {u0, u1, u2});
        if (s.lobe < 0 || !(s.pdf > 0)) return out;
        out.wi = s.wi;
        own.value = e.weight * s.value;
        own.pdf = s.pdf;
        if (lobes_) {
            // The sampled value per lobe (Cycles' legacy sampler value is not its eval).
            own.lobes[size_t(s.lobe)] = own.value;
            if (e.kind == Entry::Kind::Hair) {
                const BsdfEval r = e.hair->eval(*points_[size_t(picked)], s.wi);
                for (int k = 0; k < kLobeCount; ++k) own.lobes[size_t(k)] = e.weight * r.lobes[size_t(k)];
            }
        }
        out.label = e.kind == Entry::Kind::Hair ? ChiangHair::scatter_label(s.lobe) : e.legacy->scatter_label(s.lobe);
    } else if (e.kind == Entry::Kind::Model) {
        const PreparedModelClosure& m = model_points_[size_t(picked)];
        const BsdfSample s = m.sample({u0, u1, u2});
        if (s.lobe < 0) return out;
        out.wi = s.wi;
        own.value = e.weight * s.value;
        own.pdf = s.pdf;
        if (lobes_) {
            const BsdfEval r = m.eval(s.wi);
            for (int k = 0; k < kLobeCount; ++k) own.lobes[size_t(k)] = e.weight * r.lobes[size_t(k)];
        }
        out.label = m.scatter_label(s.lobe);
    } else {
        out.wi = sample_cos_hemisphere(n_, u0, u1);
        const double c = dot(n_, out.wi);
        if (!(c > 0) || !(dot(ng_, out.wi) > 0)) return out;
        own.pdf = c / kPi;
        own.value = own.pdf * e.weight;
        out.label = uint8_t(LabelDiffuse | LabelReflect);
    }
    // Combine with the other closures at the sampled direction.
    RGB value = own.value;
    double pdf = e.sample_weight * own.pdf;
    out.lobes = own.lobes;
    for (int i = 0; i < count_; ++i) {
        if (i == picked) continue;
        const BsdfValue v = eval_entry(i, out.wi);
        if (v.pdf != 0.0) {
            value += v.value;
            pdf += entries_[size_t(i)].sample_weight * v.pdf;
            for (int k = 0; k < kLobeCount; ++k) out.lobes[size_t(k)] += v.lobes[size_t(k)];
        }
    }
    out.pdf = pdf / total_sample_weight_;
    out.blur_pdf = e.kind == Entry::Kind::Huang ? 1.0 : out.pdf;  // Cycles' Huang sampler reports pdf 1
    out.value = value;
    if (!(out.pdf > 0) || !std::isfinite(out.pdf)) out.label = LabelNone;
    return out;
}

}  // namespace hairbsdf::render
