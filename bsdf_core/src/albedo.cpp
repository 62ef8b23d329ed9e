#include "hairbsdf/albedo.h"

#include <vector>

namespace hairbsdf {

namespace {
// 6-point Gauss-Legendre rule on [-1, 1].
constexpr const double* kNodes = GaussLegendre<6>::x;
constexpr const double* kWeights = GaussLegendre<6>::w;

struct Rule {
    std::vector<double> x, w;
};
Rule composite_rule(double lo, double hi, long panels) {
    Rule r;
    const double width = (hi - lo) / double(panels);
    for (long k = 0; k < panels; ++k) {
        const double mid = lo + (k + 0.5) * width;
        for (int i = 0; i < 6; ++i) {
            r.x.push_back(mid + 0.5 * width * kNodes[i]);
            r.w.push_back(0.5 * width * kWeights[i]);
        }
    }
    return r;
}

std::array<double, 2> closure_scales(const ClosureSum& bsdf) {
    double theta = 1.0, phi = 1.0;
    for (const Closure& c : bsdf.closures()) {
        const auto s = std::visit([](const auto& m) { return m.angular_scales(); }, c.model);
        theta = std::min(theta, s[0]);
        phi = std::min(phi, s[1]);
    }
    return {std::max(theta, 1e-4), std::max(phi, 1e-4)};
}
}  // namespace

RGB directional_albedo(const ClosureSum& bsdf, const ShadingContext& ctx, const QuadratureOptions& options) {
    const auto scales = closure_scales(bsdf);
    long n_theta = long(std::ceil(kPi / scales[0] * options.panels_per_scale));
    long n_phi = long(std::ceil(kTwoPi / scales[1] * options.panels_per_scale));
    n_theta = std::max(n_theta, 8L);
    n_phi = std::max(n_phi, 16L);
    const double excess = double(n_theta) * double(n_phi) * 36.0 / double(options.max_nodes);
    if (excess > 1.0) {
        const double shrink = std::sqrt(excess);
        n_theta = std::max(8L, long(n_theta / shrink));
        n_phi = std::max(16L, long(n_phi / shrink));
    }
    const Rule theta = composite_rule(-0.5 * kPi, 0.5 * kPi, n_theta);
    const Rule phi = composite_rule(-kPi, kPi, n_phi);
    const FibreFrame frame(ctx.tangent, ctx.wo);
    const ClosureSum::ShadingPoint point = bsdf.prepare(ctx);
    RGB sum;
    for (size_t i = 0; i < theta.x.size(); ++i) {
        const double sin_t = std::sin(theta.x[i]), cos_t = std::cos(theta.x[i]);
        RGB row;
        for (size_t j = 0; j < phi.x.size(); ++j) {
            const Vec3 wi = frame.direction(sin_t, cos_t, phi.x[j]);
            row += phi.w[j] * bsdf.eval(point, wi).value();
        }
        sum += (theta.w[i] * cos_t) * row;
    }
    return sum;
}

}  // namespace hairbsdf
