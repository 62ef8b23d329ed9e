// Zoo models and plugins by name: each model's parameter schema and a builder from named values,
// both derived from the model's parameter table (params/<model>.h beside its Params struct: the
// one place of its parameter names, defaults and ranges; docs/models.md).
// Used by the Python constructors (hairbsdf.zoo through _core.make_model), by the renderer's
// `hair_model` closure and, through the schema, by Blender's engine panel.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "hairbsdf/closures.h"
#include "hairbsdf/model_params.h"

namespace hairbsdf {

// "kajiya_kay", "epic", "scheuermann", "marschner", "deon", "yan_fur".
const std::vector<std::string>& zoo_model_names();
// The model name that builds the plugin library at a path (hairbsdf/plugin.h).
inline constexpr const char* kPluginModel = "plugin";
// Every name make_model builds: the zoo's, then "cycles_hair", then kPluginModel (the scene's
// hair_model closure allows the same list).
const std::vector<std::string>& model_names();
bool is_zoo_model(const std::string& model);
// Each zoo model's name with its title and one-line summary (Blender's override menu), in that order.
struct ZooModel {
    std::string name, title, summary;
};
const std::vector<ZooModel>& zoo_models();

// The schema of a zoo model, or of "cycles_hair" (Cycles' legacy Hair BSDF node, params/cycles_hair.h:
// built by name like a zoo model but not one of zoo_model_names); ModelError for an unknown name
// (the message lists the names).
const std::vector<ModelParamSpec>& zoo_model_schema(const std::string& model);
// A plugin's schema (hairbsdf/plugin.h) in the same form: FLOAT -> Float, RGB -> RGB.
std::vector<ModelParamSpec> plugin_model_schema(const PluginLibrary& library);
// The schema of `model` (kPluginModel: of the plugin at `path`, loaded if needed).
std::vector<ModelParamSpec> model_schema(const std::string& model, const std::string& path = "");

// A zoo model (or "cycles_hair") from named values; parameters not given take their defaults. ModelError names
// an unknown model or parameter, a value of the wrong type, or one out of range (and what is
// allowed).
HairModel make_zoo_model(const std::string& model, const ModelParams& params);
// A plugin instance from named values (PluginError when the library does not load or its
// create fails; ModelError for names, types and ranges).
HairModel make_plugin_model(const std::string& path, const ModelParams& params);
// kPluginModel -> make_plugin_model(path, params), else make_zoo_model(model, params).
HairModel make_model(const std::string& model, const std::string& path, const ModelParams& params);

}  // namespace hairbsdf
