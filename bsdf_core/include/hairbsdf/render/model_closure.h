// The `hair_model` closure (docs/scene_desc.md): a zoo model or a plugin in place of a
// material's hair closure, built once per material by the model factory
// (model_factory.h); at a hit it is one closure of render::Bsdf, evaluated and sampled
// through closures.h (eval_at_hit and sample_at_hit: a non-finite result, e.g. a failed
// plugin call, is no value and no sample, so it never reaches the image).
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

}  // namespace hairbsdf::render
