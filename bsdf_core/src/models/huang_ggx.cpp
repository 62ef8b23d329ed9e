// Directional albedo of the GGX glass BSDF (the E_glass table of Huang hair): docs/huang.md §3.
#include "hairbsdf/models/huang_ggx.h"

#include "hairbsdf/math_cubature.h"

namespace hairbsdf::ggx {

namespace {
constexpr const double* kGl8x = GaussLegendre<8>::x;
constexpr const double* kGl8w = GaussLegendre<8>::w;
constexpr double kSingularRoughnessSq = 2e-10;  // Cycles' BSDF_ROUGHNESS_SQ_THRESH

// eval / pdf of one sample of Cycles' glass sampler, averaged over its reflect/refract choice.
double glass_weight(Vec3 v, Vec3 h, double alpha2, double eta, bool reject_upward_refraction) {
    const double cos_hi = dot(h, v);
    double cos_ho = 0.0;
    const double f = fresnel(cos_hi, eta, &cos_ho);
    const double li = lambda(alpha2, v.z);
    double value = 0.0;
    const Vec3 wr = (2.0 * cos_hi) * h - v;
    if (wr.z > 0.0) value += f * (1.0 + li) / (1.0 + li + lambda(alpha2, wr.z));
    if (f < 1.0) {
        // Cycles 4.x's tables did not check the side the refraction leaves on (it matters only for
        // eta < 1 at grazing incidence; measured against shader.tables, docs/huang.md §3); 5.x's do.
        const Vec3 wt = refract(v, h, cos_ho, 1.0 / eta);
        if (reject_upward_refraction && !(wt.z < 0.0)) return value;
        // Refraction with an IOR this close to 1 is treated as specular: weight 1.
        const double g = std::fabs(eta - 1.0) < 1e-4 ? 1.0 : (1.0 + li) / (1.0 + li + lambda(alpha2, wt.z));
        value += (1.0 - f) * g;
    }
    return value;
}
}  // namespace

namespace {
// The albedo as an integral over the microfacet normal m = (sin t cos p, sin t sin p, cos t) with
// D(m) cos t dw = du dp / (2 pi) for tan^2 t = alpha^2 u / (1 - u): the integrand
// (v.m)+ G1(v) / (mu cos t) x weight(m) is bounded; its discontinuities (reflection / refraction
// leaving the valid hemisphere, total internal reflection) are handled by the adaptive cubature.
struct GlassAlbedo {
    Vec3 v;
    double alpha, alpha2, mu, eta, g1;
    bool reject_upward_refraction;
    int dim(int) const { return 2; }
    int values(int) const { return 1; }
    double norm(int, const std::array<double, adaptive::kMaxValues>& f) const { return f[0]; }
    void eval(int, const std::array<double, adaptive::kMaxDim>& x, std::array<double, adaptive::kMaxValues>& f) const {
        f[0] = 0.0;
        const double u = x[0], p = x[1];
        if (!(u < 1.0)) return;
        const double tan2 = alpha2 * u / (1.0 - u);
        const double ct = 1.0 / std::sqrt(1.0 + tan2), st = std::sqrt(std::max(1.0 - ct * ct, 0.0));
        const Vec3 m{st * std::cos(p), st * std::sin(p), ct};
        const double vm = dot(v, m);
        if (!(vm > 0.0)) return;
        // Over p in [0, pi] (symmetry), measure du dp / pi.
        f[0] = g1 * vm / (mu * ct) * glass_weight(v, m, alpha2, eta, reject_upward_refraction) / kPi;
    }
};
}  // namespace

double ggx_glass_albedo(double alpha, double mu, double eta, bool reject_upward_refraction, double tolerance) {
    const double alpha2 = alpha * alpha;
    if (alpha2 <= kSingularRoughnessSq) return 1.0;  // a mirror / clear interface: eval / pdf = 1
    GlassAlbedo problem{Vec3{safe_sqrt(1.0 - mu * mu), 0.0, mu}, alpha, alpha2, mu, eta, 0.0, reject_upward_refraction};
    problem.g1 = 1.0 / (1.0 + lambda(alpha2, mu));
    adaptive::Integrator<GlassAlbedo> integ(problem);
    // Initial boxes: finer towards grazing microfacets (u -> 1).
    const double edges[] = {0.0, 0.5, 0.9, 0.99, 0.999, 0.9999, 0.99999, 1.0};
    for (int i = 0; i + 1 < 8; ++i)
        for (int j = 0; j < 4; ++j) integ.add(0, {edges[i], kPi * j / 4}, {edges[i + 1], kPi * (j + 1) / 4});
    integ.refine([&](const std::array<double, adaptive::kMaxValues>& t) { return tolerance * std::fabs(t[0]); },
                 4'000'000);
    return clamp(integ.totals()[0], 0.0, 1.0);
}

}  // namespace hairbsdf::ggx
