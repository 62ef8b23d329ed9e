// The `hair_model` closure; see render/model_closure.h.
#include "hairbsdf/render/model_closure.h"

namespace hairbsdf::render {

ModelClosure build_model_closure(const ClosureDesc& desc, const std::string& where) {
    try {
        return {desc.weight, std::make_shared<const HairModel>(make_model(desc.model_name, desc.model_path,
                                                                          desc.model_params))};
    } catch (const ModelError& e) {
        throw ModelError(where + ": " + e.what());
    } catch (const PluginError& e) {
        throw PluginError(where + ": " + e.what());
    }
}

}  // namespace hairbsdf::render
