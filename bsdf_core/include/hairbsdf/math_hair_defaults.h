// Blender's Principled Hair BSDF node defaults (Blender 4.5) that more than one model starts
// from: written once here, read by PrincipledHairInputs (params/principled_hair.h) and by the
// Params structs whose defaults are Blender's. A model whose default is its own paper's value
// keeps that value beside its source, even where the number coincides.
#pragma once

#include "hairbsdf/math.h"

namespace hairbsdf::blender_hair {

constexpr RGB kColor{0.017513, 0.005763, 0.002059};           // Color
constexpr RGB kAbsorptionCoefficient{0.245531, 0.52, 1.365};  // Absorption Coefficient
constexpr double kMelanin = 0.8;                              // Melanin
constexpr double kMelaninRedness = 1.0;                       // Melanin Redness
constexpr double kIor = 1.55;                                 // IOR
constexpr double kOffset = 0.0349066;                         // Offset: 2 degrees, in radians

}  // namespace hairbsdf::blender_hair
