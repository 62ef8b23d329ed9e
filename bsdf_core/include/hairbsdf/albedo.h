// Directional albedo by deterministic quadrature: the integral of eval (which includes
// the cosine) over the sphere of incident directions, for one view direction and h.
#pragma once

#include "hairbsdf/closures.h"

namespace hairbsdf {

struct QuadratureOptions {
    double panels_per_scale = 1.0;  // panels per narrowest lobe width, 6 Gauss-Legendre nodes each
    long max_nodes = 4'000'000;     // cap on theta x phi nodes
    // Huang closures (accuracy "cycles"): > 0 replaces their quadrature by huang_albedo_estimate to this
    // standard error relative to the albedo; < 0: each closure's own tolerance; 0 keeps the quadrature.
    double huang_tolerance = 0.0;
};

// Huang's directional albedo by Cycles' stochastic eval integrated along each path's own exit
// (HuangHair::albedo_sample; its expectation is the integral of the deterministic eval); randomized
// quasi-Monte Carlo, doubled until the standard error of the luminance (the larger of the shifted copies'
// spread and the per-sample error) is below 0.5 x tolerance x the estimate (at most max_samples). Returns
// false where it does not apply (accuracy "converged"): then use the quadrature.
bool huang_albedo_estimate(const HuangHair& model, const ShadingContext& ctx, double tolerance, long max_samples,
                           RGB& albedo);

// Composite 6-point Gauss-Legendre in theta_i (weight cos theta_i) and phi_i, with
// panels sized from the closures' narrowest lobes.
RGB directional_albedo(const ClosureSum& bsdf, const ShadingContext& ctx, const QuadratureOptions& options = {});

}  // namespace hairbsdf
