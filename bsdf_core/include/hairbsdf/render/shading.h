// Materials at a hit: the flat weighted closure sum of scene_desc.md turned into a BSDF the
// integrator can evaluate and sample, with Cycles' one-sample closure mixture:
// a closure is picked with probability |average(weight)| / sum, its sample is combined with
// the other closures' values and pdfs (surface_shader.h). Closures:
//   principled_hair -> ChiangHair (params/principled_hair.h, `cycles` accuracy): label GLOSSY,
//     REFLECT for lobe R, TRANSMIT for TT/TRT/TRRT+ (docs/cycles.md §6);
//   principled_hair, model Huang -> HuangHair (docs/huang.md §10): every lobe GLOSSY REFLECT;
//     eval is Cycles' stochastic estimator (one random microfacet normal per Simpson node,
//     unbiased for the model's value and microseconds instead of milliseconds), the pdf is
//     the mixture sampler's exact density; near field for camera rays; a hit outside the
//     projected ellipse makes the closure a transparent one (label TRANSPARENT);
//   cycles_hair -> CyclesHair (models/cycles_hair.h), Cycles' legacy Hair BSDF: label GLOSSY
//     REFLECT (reflection) or GLOSSY TRANSMIT (transmission); the closure weight includes the
//     node's Color as in Cycles (it sets the pick probability); its N test uses the hit's
//     shading normal; not blurred by Filter Glossy (Cycles' bsdf_blur skips it);
//   diffuse -> DiffuseBsdf (models/diffuse.h), Lambert, cosine-sampled, label DIFFUSE REFLECT;
//   emission -> Emission (models/emission.h): radiance color x strength x weight, two-sided;
//   hair_model -> a zoo model or a plugin (render/model_closure.h): label GLOSSY, REFLECT for
//     lobe R, TRANSMIT for the others, as Chiang's; Filter Glossy does not blur it.
// Inputs linked to the material's shading program (render/shading_vm.h) take the program's
// registers at the hit (ShadingGeometry::registers); a non-finite register value reads as 0.
// So do closure weights (Mix Shader factors that depend on the hit, as Cycles' SVM mixes them).
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "hairbsdf/batch/chiang_batch.h"
#include "hairbsdf/closures.h"
#include "hairbsdf/render/model_closure.h"
#include "hairbsdf/render/sampler.h"
#include "hairbsdf/render/scene.h"

namespace hairbsdf::render {

constexpr int kMaxBsdfClosures = 8;
constexpr double kClosureWeightCutoff = 1e-5;  // Cycles' CLOSURE_WEIGHT_CUTOFF

// A material the wavefront can shade through the float32 batch kernels (docs/simd.md, render/wavefront.h):
// a single Principled Hair closure with the Chiang model whose inputs are all the material's own (none
// from the shading program, a constant weight). Its kernel constants (the closure weight included);
// `random_per_row`: the model depends on the curve's Random, which goes to the kernels per row.
struct BatchChiangMaterial {
    ChiangBatchConstants constants;
    bool random_per_row = false;
    bool transmits = true;  // Cycles' SD_BSDF_HAS_TRANSMISSION, from the model
};

// One material, prepared once per render: its BSDF closures (a weight and a model each, in the
// order principled_hair, cycles_hair, diffuse, hair_model) and its emission closures.
class MaterialShader {
public:
    MaterialShader(const MaterialDesc& desc, TiltConvention tilt, Accuracy accuracy = Accuracy::Cycles,
                   HuangSampler huang_sampler = HuangSampler::Cycles,
                   GlassAlbedoTable huang_glass_albedo_table = GlassAlbedoTable::Cycles4);
    struct MaterialClosure {
        RGB weight;
        // The model when it does not depend on the hit; nullptr: a Principled Hair model built
        // per hit from `hair` (the curve's random, the shading program's values).
        std::shared_ptr<const HairModel> model;
        bool huang = false;  // the per-hit model: Huang (else Chiang)
        PrincipledHairInputs hair;
        bool random_from_curve = true;
        std::vector<ClosureDesc::Link> links;  // inputs from the shading program
        int32_t color_register = -1;           // diffuse: weight x the program's colour
        // The weight computed per hit (a Mix Shader factor that depends on the hit): weight x
        // the program's colour there; a closure below Cycles' weight cutoff at a hit is left out.
        int32_t weight_register = -1;
    };
    struct EmissionClosure {
        RGB weight;
        Emission model;
        int32_t color_register = -1, strength_register = -1, weight_register = -1;  // from the program
    };
    const std::vector<MaterialClosure>& closures() const { return closures_; }
    // Emission at a hit; `registers`: the program's registers there (nullptr without a program).
    RGB emission(const float* registers = nullptr) const;
    const ShadingProgram& program() const { return program_; }
    bool has_bsdf() const { return !closures_.empty(); }
    TiltConvention tilt() const { return tilt_; }
    Accuracy accuracy() const { return accuracy_; }
    HuangSampler huang_sampler() const { return huang_sampler_; }
    GlassAlbedoTable huang_glass_albedo_table() const { return huang_glass_albedo_table_; }
    // Unique to this material's closures (copies share it): the key of the per-hit models Bsdf keeps.
    uint64_t id() const { return id_; }
    // Set where the material is one the batch kernels can shade (BatchChiangMaterial).
    const std::optional<BatchChiangMaterial>& batch_chiang() const { return batch_chiang_; }

private:
    uint64_t id_;
    std::optional<BatchChiangMaterial> batch_chiang_;
    std::vector<MaterialClosure> closures_;
    RGB emission_{0.0};                          // the emission closures without program inputs
    std::vector<EmissionClosure> linked_emission_;  // those with
    ShadingProgram program_;
    TiltConvention tilt_;
    Accuracy accuracy_;
    HuangSampler huang_sampler_;
    GlassAlbedoTable huang_glass_albedo_table_;
};

// The local geometry a BSDF needs.
struct ShadingGeometry {
    Vec3 wo;        // towards the viewer (-ray direction)
    Vec3 n;         // shading normal, on the viewer's side for triangles
    Vec3 ng;        // geometric normal, on the viewer's side (wo for ribbons)
    Vec3 tangent;   // hair: normalize(dP/du), root to tip
    double h = 0;   // hair offset, docs/conventions.md
    double random = 0;  // Hair Info > Random of the curve (0 on meshes)
    Vec3 curve_normal{0, 0, 0};  // Huang: the ellipse's major axis (zero: fallback frame)
    double pixel_coverage = 1;   // Huang near field: 0.5 dP / r of a camera ray
    bool near_field = false;     // Huang: camera ray on a curve
    const float* registers = nullptr;  // the material's shading program evaluated at this hit
};

// The BSDF at one hit: a ClosureSum shading point (closures.h) holding the material's closures,
// each a weight and a model prepared for the hit, evaluated and sampled by the sum's renderer
// forms (render_eval, render_sample) with Cycles' one-sample mixture. Bsdf adds only what a hit
// needs around it: the models built or blurred for this hit and the stochastic eval's state.
// Reused per thread: set() does not allocate for models that do not (Huang's shading point does).
class Bsdf {
public:
    static_assert(size_t(kMaxBsdfClosures) <= ClosureSum::kCapacity);
    // blur_roughness > 0 applies Cycles' Filter Glossy to the models that blur. Where a closure's
    // eval is stochastic, set() draws its seed from the path's sampler `rng` (one number per
    // hit). `lobes`: fill the per-lobe values of eval and sample (costs an extra eval per sample).
    void set(const MaterialShader& material, const ShadingGeometry& geometry, double blur_roughness, Sampler& rng,
             bool lobes = false);
    // The same with the stochastic eval's state given (the test hook eval_hit_bsdf).
    void set_seeded(const MaterialShader& material, const ShadingGeometry& geometry, double blur_roughness,
                    uint32_t eval_state, bool lobes = false);
    bool empty() const { return sum_.count == 0; }
    // Cycles' SD_BSDF_HAS_TRANSMISSION: a closure whose model transmits; the light tree then
    // ignores the side of N.
    bool has_transmission() const { return sum_.transmits(); }
    BsdfValue eval(Vec3 wi) const { return ClosureSum::render_eval(sum_, wi, eval_state_); }
    // `chiang_longitudinal`: Cycles < 3.6's LCG numbers for Principled Hair (Chiang) closures.
    BsdfScatter sample(double u0, double u1, double u2, const LongitudinalNumbers* chiang_longitudinal = nullptr) const {
        return ClosureSum::render_sample(sum_, u0, u1, u2, chiang_longitudinal, eval_state_, lobes_);
    }

private:
    // Fills the sum with the material's closures at this hit.
    void prepare(const MaterialShader& material, const ShadingGeometry& geometry, double blur_roughness, bool lobes);
    // The Principled Hair model of closure `closure` of `material` for a curve's Random (a closure
    // without program inputs): built on the first hit, kept for the next hits with the same Random
    // (the same model, so the same numbers); `slot`'s own entries, so the sum's models stay put.
    const HairModel& curve_model(const MaterialShader& material, size_t closure, size_t slot, double random);
    ClosureSum::ShadingPoint sum_;
    std::array<std::optional<HairModel>, kMaxBsdfClosures> hit_models_;  // models built or blurred for this hit
    struct CurveModel {
        uint64_t material = 0;  // MaterialShader::id(); 0: empty
        size_t closure = 0;
        uint64_t random_bits = 0;
        std::optional<HairModel> model;
    };
    // Entries per slot (about 0.85 MB), indexed by a hash of the material, the closure and the Random.
    static constexpr int kCurveModelBits = 10;
    static constexpr size_t kCurveModels = size_t(1) << kCurveModelBits;
    std::array<std::unique_ptr<CurveModel[]>, kMaxBsdfClosures> curve_models_;  // a slot's on its first use
    mutable uint32_t eval_state_ = 0;  // the stochastic evals' random state, advanced by each eval
    bool lobes_ = false;
};

// Reads register `reg` (3 for a colour) as an input value; non-finite values read as 0.
double register_value(const float* registers, int32_t reg);
RGB register_rgb(const float* registers, int32_t reg);
// Applies a closure's program-linked inputs to its Principled Hair inputs.
void apply_links(const std::vector<ClosureDesc::Link>& links, const float* registers, PrincipledHairInputs& in,
                 bool& random_from_curve);

}  // namespace hairbsdf::render
