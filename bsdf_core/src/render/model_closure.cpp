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

void PreparedModelClosure::prepare(const ModelClosure& closure, const ShadingContext& ctx) {
    model_ = closure.model.get();
    point_ = prepare_model(*model_, ctx);
}

BsdfEval PreparedModelClosure::eval(Vec3 wi) const {
    const BsdfEval e = eval_model(*model_, point_, wi);
    bool finite = std::isfinite(e.pdf) && e.pdf >= 0;
    for (const RGB& l : e.lobes) finite = finite && isfinite(l);
    return finite ? e : BsdfEval{};
}

BsdfSample PreparedModelClosure::sample(const std::array<double, 3>& u) const {
    const BsdfSample s = sample_model(*model_, point_, u);
    if (s.lobe < 0 || !(s.pdf > 0) || !std::isfinite(s.pdf) || !isfinite(s.value) || !isfinite(s.wi)) return {};
    return s;
}

}  // namespace hairbsdf::render
