// Materials and the per-hit closure mixture; see render/shading.h.
#include "hairbsdf/render/shading.h"

#include <atomic>
#include <cstring>

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

uint64_t next_material_id() {
    static std::atomic<uint64_t> last{0};
    return ++last;
}

// Builds a Principled Hair closure's model for its (per-hit) inputs in `out`, in place.
const HairModel& build_principled_hair(const MaterialShader& material, const MaterialShader::MaterialClosure& m,
                                       const PrincipledHairInputs& in, std::optional<HairModel>& out) {
    if (m.huang)
        return out.emplace(std::in_place_type<HuangHair>,
                           render_huang_params(in, material.huang_sampler(), material.huang_glass_albedo_table()));
    return out.emplace(std::in_place_type<ChiangHair>,
                       chiang_params_from_principled(in, material.accuracy(), material.tilt()));
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
            case In::Strength:
            case In::Weight:
            case In::RoughnessU:
            case In::RoughnessV: break;
        }
    }
}

RGB MaterialShader::emission(const float* registers) const {
    RGB e = emission_;
    if (!registers) return e;
    for (const EmissionClosure& l : linked_emission_) {
        const RGB weight = l.weight_register >= 0 ? l.weight * register_rgb(registers, l.weight_register) : l.weight;
        const RGB color = l.color_register >= 0 ? register_rgb(registers, l.color_register) : l.model.color();
        const double strength =
            l.strength_register >= 0 ? register_value(registers, l.strength_register) : l.model.strength();
        e += Emission(color, strength).radiance(weight);
    }
    return e;
}

MaterialShader::MaterialShader(const MaterialDesc& desc, TiltConvention tilt, Accuracy accuracy,
                               HuangSampler huang_sampler, GlassAlbedoTable huang_glass_albedo_table)
    : id_(next_material_id()), program_(desc.program), tilt_(tilt), accuracy_(accuracy), huang_sampler_(huang_sampler),
      huang_glass_albedo_table_(huang_glass_albedo_table) {
    const bool with_program = !desc.program.empty();
    // The register of a closure's per-hit input (-1: none).
    auto linked = [with_program](const ClosureDesc& c, ClosureDesc::Input input) {
        if (with_program)
            for (const ClosureDesc::Link& l : c.links)
                if (l.input == input) return l.reg;
        return int32_t(-1);
    };
    // Below Cycles' cutoff: left out, unless the weight is computed per hit (checked there).
    auto negligible = [&](const ClosureDesc& c, const RGB& w) {
        return linked(c, ClosureDesc::Input::Weight) < 0 && std::fabs(average(w)) < kClosureWeightCutoff;
    };
    // The closures by kind, in the order the sum keeps them (the pick order: it changes the noise only).
    std::vector<MaterialClosure> hair, cycles_hair, diffuse, models;
    auto room = [&] {
        return hair.size() + cycles_hair.size() + diffuse.size() + models.size() < size_t(kMaxBsdfClosures);
    };
    for (const ClosureDesc& c : desc.closures) {
        switch (c.type) {
            case ClosureDesc::Type::PrincipledHair: {
                if (negligible(c, c.weight)) break;
                MaterialClosure h;
                h.weight = c.weight;
                h.weight_register = linked(c, ClosureDesc::Input::Weight);
                h.hair = c.hair;
                h.random_from_curve = c.random_from_curve;
                if (with_program) h.links = c.links;
                h.huang = c.hair_model == ClosureDesc::HairModel::Huang;
                const bool per_hit = (c.random_from_curve && hair_depends_on_random(c.hair)) || !h.links.empty();
                if (!per_hit) {
                    PrincipledHairInputs in = c.hair;
                    if (c.random_from_curve) in.random = 0.0;  // unused by the parameters
                    if (h.huang)
                        h.model = std::make_shared<const HairModel>(
                            std::in_place_type<HuangHair>, render_huang_params(in, huang_sampler, huang_glass_albedo_table));
                    else
                        h.model = std::make_shared<const HairModel>(std::in_place_type<ChiangHair>,
                                                                    chiang_params_from_principled(in, accuracy, tilt));
                }
                if (room()) hair.push_back(std::move(h));
                break;
            }
            case ClosureDesc::Type::CyclesHair: {
                const RGB w = c.weight * c.color;  // Cycles: the node's Color is the closure weight
                if (negligible(c, w)) break;
                CyclesHairParams p;
                p.component = c.transmission ? CyclesHairComponent::Transmission : CyclesHairComponent::Reflection;
                p.color = RGB(1.0);
                p.offset = c.offset;
                p.roughness_u = c.roughness_u;
                p.roughness_v = c.roughness_v;
                MaterialClosure m;
                m.weight = w;
                m.weight_register = linked(c, ClosureDesc::Input::Weight);
                m.model = std::make_shared<const HairModel>(std::in_place_type<CyclesHair>, p);
                if (room()) cycles_hair.push_back(std::move(m));
                break;
            }
            case ClosureDesc::Type::Diffuse: {
                MaterialClosure d;
                d.color_register = linked(c, ClosureDesc::Input::Color);
                d.weight_register = linked(c, ClosureDesc::Input::Weight);
                d.weight = d.color_register >= 0 ? c.weight : c.weight * c.color;
                if (negligible(c, d.weight)) break;
                d.model = std::make_shared<const HairModel>(std::in_place_type<DiffuseBsdf>);
                if (room()) diffuse.push_back(std::move(d));
                break;
            }
            case ClosureDesc::Type::Emission: {
                EmissionClosure l{c.weight, Emission(c.color, c.strength)};
                l.color_register = linked(c, ClosureDesc::Input::Color);
                l.strength_register = linked(c, ClosureDesc::Input::Strength);
                l.weight_register = linked(c, ClosureDesc::Input::Weight);
                if (l.color_register >= 0 || l.strength_register >= 0 || l.weight_register >= 0)
                    linked_emission_.push_back(l);
                else
                    emission_ += l.model.radiance(l.weight);
                break;
            }
            case ClosureDesc::Type::Model: {  // render/model_closure.h
                if (negligible(c, c.weight) || !room()) break;
                const ModelClosure built = build_model_closure(c, "material '" + desc.name + "'");
                MaterialClosure m;
                m.weight = built.weight;
                m.weight_register = linked(c, ClosureDesc::Input::Weight);
                m.model = built.model;
                models.push_back(std::move(m));
                break;
            }
        }
    }
    if (hair.size() == 1 && cycles_hair.empty() && diffuse.empty() && models.empty()) {
        const MaterialClosure& h = hair[0];
        if (!h.huang && h.links.empty() && h.weight_register < 0 && h.color_register < 0) {
            PrincipledHairInputs in = h.hair;
            const bool random_per_row = h.random_from_curve && hair_depends_on_random(in);
            if (h.random_from_curve) in.random = 0.0;  // per row where the model depends on it
            const HairModel model(std::in_place_type<ChiangHair>, chiang_params_from_principled(in, accuracy, tilt));
            batch_chiang_ = BatchChiangMaterial{chiang_batch_constants_principled(in, accuracy, tilt, h.weight),
                                                random_per_row, model_transmits(model)};
        }
    }
    for (std::vector<MaterialClosure>* kind : {&hair, &cycles_hair, &diffuse, &models})
        for (MaterialClosure& m : *kind) closures_.push_back(std::move(m));
}

void Bsdf::prepare(const MaterialShader& material, const ShadingGeometry& g, double blur_roughness, bool lobes) {
    lobes_ = lobes;
    sum_.clear(g.wo);
    ShadingContext ctx;
    ctx.tangent = g.tangent;
    ctx.wo = g.wo;
    ctx.h = clamp(g.h, -1.0, 1.0);
    ctx.random = g.random;
    ctx.normal = g.curve_normal;
    ctx.pixel_coverage = g.pixel_coverage;
    ctx.near_field = g.near_field;
    ctx.shading_normal = g.n;
    ctx.geometric_normal = g.ng;
    for (size_t closure = 0; closure < material.closures().size(); ++closure) {
        const MaterialShader::MaterialClosure& m = material.closures()[closure];
        const size_t slot = sum_.count;
        RGB weight = m.weight;
        if (m.weight_register >= 0) weight = g.registers ? weight * register_rgb(g.registers, m.weight_register) : RGB(0.0);
        if (m.color_register >= 0) weight = g.registers ? weight * register_rgb(g.registers, m.color_register) : RGB(0.0);
        // Cycles' bsdf_alloc leaves out a closure below its cutoff at the hit
        if (m.weight_register >= 0 && std::fabs(average(weight)) < kClosureWeightCutoff) continue;
        const HairModel* model = m.model.get();
        if (!model && m.links.empty()) {  // Principled Hair whose only per-hit input is the curve's Random
            model = &curve_model(material, closure, slot, g.random);
        } else if (!model) {  // Principled Hair with inputs from the shading program
            PrincipledHairInputs in = m.hair;
            bool random_from_curve = m.random_from_curve;
            if (g.registers) apply_links(m.links, g.registers, in, random_from_curve);
            if (random_from_curve) in.random = g.random;
            model = &build_principled_hair(material, m, in, hit_models_[slot]);
        }
        if (blur_roughness > 0 && blur_model(*model, blur_roughness, hit_models_[slot])) model = &*hit_models_[slot];
        sum_.add_at_hit(weight, *model, ctx);
    }
}

const HairModel& Bsdf::curve_model(const MaterialShader& material, size_t closure, size_t slot, double random) {
    uint64_t bits;
    std::memcpy(&bits, &random, sizeof bits);
    // The entry: multiplicative hashing (the top bits of the product with 2^64 / golden ratio) of the
    // Random, the material and the closure, so that materials sharing a Random do not take turns in one entry.
    const uint64_t key = bits ^ (material.id() << 40) ^ (uint64_t(closure) << 56);
    const uint64_t entry = (key * 0x9e3779b97f4a7c15ull) >> (64 - kCurveModelBits);
    if (!curve_models_[slot]) curve_models_[slot] = std::make_unique<CurveModel[]>(kCurveModels);
    CurveModel& e = curve_models_[slot][entry];
    if (e.material != material.id() || e.closure != closure || e.random_bits != bits || !e.model) {
        const MaterialShader::MaterialClosure& m = material.closures()[closure];
        PrincipledHairInputs in = m.hair;
        if (m.random_from_curve) in.random = random;
        build_principled_hair(material, m, in, e.model);
        e.material = material.id();
        e.closure = closure;
        e.random_bits = bits;
    }
    return *e.model;
}

void Bsdf::set(const MaterialShader& material, const ShadingGeometry& g, double blur_roughness, Sampler& rng,
               bool lobes) {
    prepare(material, g, blur_roughness, lobes);
    const HairModel* stochastic = sum_.stochastic_model();
    eval_state_ = stochastic ? model_eval_seed(*stochastic, rng.next()) : 0u;
    if (sum_.empty()) sum_.count = 0;
}

void Bsdf::set_seeded(const MaterialShader& material, const ShadingGeometry& g, double blur_roughness,
                      uint32_t eval_state, bool lobes) {
    prepare(material, g, blur_roughness, lobes);
    eval_state_ = eval_state;
    if (sum_.empty()) sum_.count = 0;
}

}  // namespace hairbsdf::render
