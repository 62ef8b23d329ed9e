// Huang's parameter table (param_table.h), beside HuangHairParams (models/huang.h): the options
// principled_hair(model="huang") takes besides the node's inputs (those are the scene schema's
// Principled Hair rows). Each default is the struct's. Not a zoo model: the bindings apply the
// rows (module.cpp), hairbsdf.principled reads names, choices, defaults and ranges from them, and
// a test checks docs/huang.md's table against them.
#pragma once

#include <string>

#include "hairbsdf/models/huang.h"
#include "hairbsdf/params/param_table.h"

namespace hairbsdf {

template <>
struct ParamTable<HuangHairParams> {
    static constexpr const char* model = "huang";
    static constexpr const char* title = "Principled Hair (Huang)";
    static constexpr const char* summary = "Cycles' Huang 2022 hair: the numerical options (docs/huang.md §4)";
    static const std::vector<ParamRow<HuangHairParams>>& rows() {
        using P = HuangHairParams;
        namespace r = param_rows;
        static const std::string trt_points_meaning = "0: TRT / TRRT+ points set by tolerance; N >= " +
                                                      std::to_string(kMinFixedTrtPoints) +
                                                      ": N fixed quasi-Monte Carlo points per h node";
        static const std::vector<ParamRow<P>> s = {
            r::choice<P, HuangQuadrature>("accuracy", &P::quadrature,
                                          {{"cycles", HuangQuadrature::Cycles}, {"converged", HuangQuadrature::Converged}},
                                          "cycles: the expected value of Cycles' eval (its Simpson nodes in h); "
                                          "converged: the integral over h converged"),
            // Cycles' first: the scene's integrator.huang_sampler and the Blender setting list these
            // choices in this order (a .blend file saves the setting's position).
            r::choice<P, HuangSampler>("sampler", &P::sampler,
                                       {{"cycles", HuangSampler::Cycles}, {"mixture", HuangSampler::Mixture}},
                                       "cycles: Cycles' sampler (its weight, pdf reported as 1: no MIS); "
                                       "mixture: analytic lobe mixture, exact pdf"),
            r::number<P>("tolerance", &P::tolerance, 1e-6, 0.5,
                         "error target of eval and albedo relative to the row's total (R + TT + TRT + TRRT+)"),
            r::integer<P>("max_evaluations", &P::max_evaluations, 1000, r::kMaxInteger,
                          "cap on TT integrand evaluations (and on TRT points) per eval"),
            r::integer<P>("trt_points", &P::trt_points, 0, r::kMaxInteger, trt_points_meaning.c_str()),
            r::input_choice<P>("color_roughness", {"svm", "osl"},
                               "the roughness of the colour / tint conversion: Cycles' SVM or OSL"),
            r::choice<P, GlassAlbedoTable>("glass_albedo_table", &P::glass_albedo_table,
                                           {{"4.x", GlassAlbedoTable::Cycles4}, {"5.x", GlassAlbedoTable::Cycles5}},
                                           "the energy-compensation tables of Cycles 4.x or 5.x"),
        };
        return s;
    }
};

}  // namespace hairbsdf
