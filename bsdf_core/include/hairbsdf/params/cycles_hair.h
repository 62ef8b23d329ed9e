// Cycles' legacy Hair BSDF's parameter table (param_table.h), beside CyclesHairParams
// (models/cycles_hair.h): the node's sockets with Blender's defaults, the struct's. Not in the zoo's
// menu; built by name (model_factory.h) for hairbsdf.cycles_hair_bsdf, and read by the Blender
// exporter for a socket it cannot read.
#pragma once

#include "hairbsdf/models/cycles_hair.h"
#include "hairbsdf/params/param_table.h"

namespace hairbsdf {

template <>
struct ParamTable<CyclesHairParams> {
    static constexpr const char* model = "cycles_hair";
    static constexpr const char* title = "Cycles Hair BSDF (legacy)";
    static constexpr const char* summary = "Cycles' legacy Hair BSDF node, one component (docs/models.md §6)";
    static const std::vector<ParamRow<CyclesHairParams>>& rows() {
        using P = CyclesHairParams;
        namespace r = param_rows;
        static const std::vector<ParamRow<P>> s = {
            r::choice<P, CyclesHairComponent>(
                "component", &P::component,
                {{"reflection", CyclesHairComponent::Reflection}, {"transmission", CyclesHairComponent::Transmission}},
                "the node's component: reflection (slot R) or transmission (slot TT)"),
            r::color<P>("color", &P::color, 0, 1e4, "the node's Color; eval / pdf is this colour"),
            r::number<P>("offset", &P::offset, -0.5 * kPi, 0.5 * kPi,
                         "the node's Offset (rad); Cycles stores minus it, the lobe peaks at theta_i = -theta_o - 2 offset"),
            r::number<P>("roughness_u", &P::roughness_u, 0, 1, "RoughnessU, longitudinal; Cycles clamps it to [0.001, 1]"),
            r::number<P>("roughness_v", &P::roughness_v, 0, 1, "RoughnessV, azimuthal; Cycles clamps it to [0.001, 1]"),
        };
        return s;
    }
};

}  // namespace hairbsdf
