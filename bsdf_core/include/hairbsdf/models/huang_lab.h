// Measurement switches of the Huang model, for lab/huang_measure.cpp only: they change what the
// model computes away from Cycles' semantics, so they stay out of HuangHairParams.
#pragma once

#include <algorithm>

#include "hairbsdf/models/huang.h"

namespace hairbsdf {

struct HuangLab {
    // The model with Cycles' Simpson steps over h (prepare() and eval_cycles_stochastic) divided
    // by `refinement` (>= 1; 1 is the plain model).
    static HuangHair with_simpson_refinement(const HuangHairParams& params, int refinement) {
        HuangHair model(params);
        model.simpson_refinement_ = std::max(refinement, 1);
        return model;
    }
};

}  // namespace hairbsdf
