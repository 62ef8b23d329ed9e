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
//   diffuse -> Lambert, cosine-sampled, label DIFFUSE REFLECT;
//   emission -> radiance color x strength x weight, two-sided (Cycles' emissive closure);
//   hair_model -> a zoo model or a plugin (render/model_closure.h): label GLOSSY, REFLECT for
//     lobe R, TRANSMIT for the others, as Chiang's; Filter Glossy does not blur it.
// Inputs linked to the material's shading program (render/shading_vm.h) take the program's
// registers at the hit (ShadingGeometry::registers); a non-finite register value reads as 0.
#pragma once

#include <optional>
#include <vector>

#include "hairbsdf/closures.h"
#include "hairbsdf/render/model_closure.h"
#include "hairbsdf/render/scene.h"

namespace hairbsdf::render {

constexpr int kMaxBsdfClosures = 8;
constexpr double kClosureWeightCutoff = 1e-5;  // Cycles' CLOSURE_WEIGHT_CUTOFF

// One material, prepared once per render.
class MaterialShader {
public:
    MaterialShader(const MaterialDesc& desc, TiltConvention tilt, Accuracy accuracy = Accuracy::Cycles,
                   HuangSampler huang_sampler = HuangSampler::Cycles,
                   GlassAlbedoTable huang_glass_albedo_table = GlassAlbedoTable::Cycles4);
    struct HairClosure {
        RGB weight;
        PrincipledHairInputs inputs;
        bool random_from_curve = true;
        bool depends_on_random = false;
        bool huang = false;               // the Huang model (else Chiang)
        std::vector<ClosureDesc::Link> links;  // inputs from the shading program
        std::optional<ChiangHair> fixed;  // when the parameters do not depend on the curve
        std::optional<HuangHair> fixed_huang;
    };
    struct DiffuseClosure {
        RGB weight;  // weight x color (weight alone when the colour is linked)
        int32_t color_register = -1;  // the colour from the shading program
    };
    struct LinkedEmission {
        RGB weight;
        RGB color;
        double strength = 1;
        int32_t color_register = -1, strength_register = -1;
    };
    struct CyclesHairClosure {
        RGB weight;        // weight x Color (Cycles' closure weight)
        CyclesHair model;  // with colour 1
    };
    const std::vector<HairClosure>& hair() const { return hair_; }
    const std::vector<DiffuseClosure>& diffuse() const { return diffuse_; }
    const std::vector<CyclesHairClosure>& cycles_hair() const { return cycles_hair_; }
    const std::vector<ModelClosure>& models() const { return models_; }  // hair_model closures
    // Emission at a hit; `registers`: the program's registers there (nullptr without a program).
    RGB emission(const float* registers = nullptr) const;
    const ShadingProgram& program() const { return program_; }
    bool has_bsdf() const { return !hair_.empty() || !diffuse_.empty() || !cycles_hair_.empty() || !models_.empty(); }
    bool has_huang() const { return has_huang_; }
    TiltConvention tilt() const { return tilt_; }
    Accuracy accuracy() const { return accuracy_; }
    HuangSampler huang_sampler() const { return huang_sampler_; }
    GlassAlbedoTable huang_glass_albedo_table() const { return huang_glass_albedo_table_; }

private:
    size_t closure_count() const { return hair_.size() + diffuse_.size() + cycles_hair_.size() + models_.size(); }
    std::vector<HairClosure> hair_;
    std::vector<DiffuseClosure> diffuse_;
    std::vector<ModelClosure> models_;
    std::vector<CyclesHairClosure> cycles_hair_;
    RGB emission_{0.0};
    std::vector<LinkedEmission> linked_emission_;
    ShadingProgram program_;
    bool has_huang_ = false;
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

struct BsdfValue {
    RGB value;       // sum of weight x eval (cosine included)
    double pdf = 0;  // mixture density
    std::array<RGB, kLobeCount> lobes{};  // the hair closures' share of value per lobe (when asked)
};

struct BsdfScatter {
    Vec3 wi;
    RGB value;
    std::array<RGB, kLobeCount> lobes{};  // the hair closures' share of value per lobe (when asked)
    double pdf = 0;
    double blur_pdf = 0;  // the pdf Cycles' Filter Glossy sees (Huang reports 1)
    uint8_t label = LabelNone;
};

// The BSDF at one hit. Reused per thread: set() does not allocate.
class Bsdf {
public:
    // blur_roughness > 0 applies Cycles' Filter Glossy to the hair closures. `seed` drives
    // the random microfacet normals of Huang's stochastic eval at this hit. `lobes`: fill
    // the per-lobe values of eval and sample (costs an extra eval per sample).
    void set(const MaterialShader& material, const ShadingGeometry& geometry, double blur_roughness,
             uint32_t seed = 0, bool lobes = false);
    bool empty() const { return count_ == 0; }
    // Cycles' SD_BSDF_HAS_TRANSMISSION: a closure that transmits (Principled Hair, Hair BSDF
    // Transmission, hair_model closures); the light tree then ignores the side of N.
    bool has_transmission() const;
    BsdfValue eval(Vec3 wi) const;
    // `chiang_longitudinal`: Cycles < 3.6's LCG numbers for Principled Hair (Chiang) closures.
    BsdfScatter sample(double u0, double u1, double u2, const LongitudinalNumbers* chiang_longitudinal = nullptr) const;

private:
    struct Entry {
        enum class Kind : uint8_t { Hair, Huang, Transparent, Diffuse, Legacy, Model } kind;
        RGB weight;
        double sample_weight;
        const ChiangHair* hair;
        const HuangHair* huang;
        const CyclesHair* legacy = nullptr;
    };
    BsdfValue eval_entry(int i, Vec3 wi) const;
    std::array<RGB, kLobeCount> eval_huang(int i, Vec3 wi) const;
    std::array<Entry, kMaxBsdfClosures> entries_{};
    std::array<std::optional<ChiangHair>, kMaxBsdfClosures> storage_;
    std::array<std::optional<ChiangHair::ShadingPoint>, kMaxBsdfClosures> points_;  // view terms, once per hit
    std::array<std::optional<HuangHair>, kMaxBsdfClosures> huang_storage_;
    std::array<HuangHair::ShadingPoint, kMaxBsdfClosures> huang_points_;
    std::array<PreparedModelClosure, kMaxBsdfClosures> model_points_;  // hair_model closures at this hit
    std::array<std::optional<CyclesHair::ShadingPoint>, kMaxBsdfClosures> legacy_points_;
    mutable uint32_t huang_rng_ = 0;  // Cycles-style LCG state of the stochastic eval
    int count_ = 0;
    bool lobes_ = false;
    double total_sample_weight_ = 0;
    ShadingContext hair_ctx_;
    Vec3 n_, ng_;
};

// Reads register `reg` (3 for a colour) as an input value; non-finite values read as 0.
double register_value(const float* registers, int32_t reg);
RGB register_rgb(const float* registers, int32_t reg);
// Applies a closure's program-linked inputs to its Principled Hair inputs.
void apply_links(const std::vector<ClosureDesc::Link>& links, const float* registers, PrincipledHairInputs& in,
                 bool& random_from_curve);

}  // namespace hairbsdf::render
