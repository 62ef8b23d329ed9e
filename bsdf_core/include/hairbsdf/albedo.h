// Directional albedo by deterministic quadrature: the integral of eval (which includes
// the cosine) over the sphere of incident directions, for one view direction and h.
#pragma once

#include "hairbsdf/closures.h"

namespace hairbsdf {

struct QuadratureOptions {
    double panels_per_scale = 1.0;  // panels per narrowest lobe width, 6 Gauss-Legendre nodes each
    long max_nodes = 4'000'000;     // cap on theta x phi nodes
};

// Composite 6-point Gauss-Legendre in theta_i (weight cos theta_i) and phi_i, with
// panels sized from the closures' narrowest lobes.
RGB directional_albedo(const ClosureSum& bsdf, const ShadingContext& ctx, const QuadratureOptions& options = {});

}  // namespace hairbsdf
