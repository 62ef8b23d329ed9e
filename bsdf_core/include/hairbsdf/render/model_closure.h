// The `hair_model` closure (docs/scene_desc.md): a zoo model or a plugin in place of a
// material's hair closure, built once per material by the model factory
// (model_factory.h) and prepared once per hit; eval and sample go through the
// HairModel visitors of closures.h. A non-finite result (e.g. a failed plugin call) is no
// value and no sample, so it never reaches the image. The renderer labels the lobes with the
// model's scatter_label (closures.h; Principled Hair's unless the model has its own).
#pragma once

#include <array>
#include <memory>
#include <string>

#include "hairbsdf/model_factory.h"
#include "hairbsdf/render/scene.h"

namespace hairbsdf::render {

// One material's model closure.
struct ModelClosure {
    RGB weight{1.0};
    std::shared_ptr<const HairModel> model;
};

// The closure for `desc` (type Model); ModelError / PluginError say which material and closure.
ModelClosure build_model_closure(const ClosureDesc& desc, const std::string& where);

// A model closure at one hit. Reused per thread: prepare() does not allocate.
class PreparedModelClosure {
public:
    void prepare(const ModelClosure& closure, const ShadingContext& ctx);
    BsdfEval eval(Vec3 wi) const;                              // zero with pdf 0 where not finite
    BsdfSample sample(const std::array<double, 3>& u) const;  // lobe -1 where not finite
    uint8_t scatter_label(int lobe) const { return hairbsdf::scatter_label(*model_, lobe); }

private:
    const HairModel* model_ = nullptr;
    PreparedModel point_;
};

}  // namespace hairbsdf::render
