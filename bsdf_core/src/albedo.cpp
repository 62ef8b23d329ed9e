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

bool huang_albedo_estimate(const HuangHair& model, const ShadingContext& ctx, double tolerance, long max_samples,
                           RGB& albedo) {
    if (model.params().quadrature != HuangQuadrature::Cycles) return false;
    albedo = RGB(0.0);
    const HuangHair::ShadingPoint sp = model.prepare(ctx);
    if (sp.transparent || !sp.valid) return true;
    const HuangHair::AlbedoNodes nodes = model.albedo_nodes(sp);
    // Randomized quasi-Monte Carlo: 4 copies of one Sobol' set (its 5 dimensions: the nodes and the
    // normals), each with its own digital shifts; the lobes' directions from hashed numbers.
    constexpr int kReplicates = 4;
    constexpr int kSobolDimensions = 5;
    const Sobol& so = sobol();
    uint32_t shift[kReplicates][kSobolDimensions];
    uint32_t seed = 0x6C8E9CF5u;
    for (auto& row : shift)
        for (uint32_t& sh : row) sh = seed = lookup3_hash_uint2(seed, 0x9E3779B9u);
    std::array<RGB, kReplicates> sums{};
    double lum_sum = 0.0, lum_squares = 0.0;  // over all samples: the plain Monte Carlo error
    uint32_t points = 0;  // per replicate
    std::array<double, HuangHair::kAlbedoNumbers> u;
    auto add = [&](uint32_t from, uint32_t to) {
        for (int r = 0; r < kReplicates; ++r) {
            for (uint32_t i = from; i < to; ++i) {
                for (int d = 0; d < kSobolDimensions; ++d) u[size_t(d)] = double(so.point(i, d) ^ shift[r][d]) * 0x1p-32;
                uint32_t key = lookup3_hash_uint2(i, uint32_t(r) + 0x85EBCA6Bu);
                for (size_t d = kSobolDimensions; d < u.size(); ++d) u[d] = double(key = lookup3_hash_uint2(key, uint32_t(d))) * 0x1p-32;
                const auto lobes = model.albedo_sample(sp, nodes, u);
                const RGB f = lobes[0] + lobes[1] + lobes[2] + lobes[3];
                if (!isfinite(f)) continue;
                sums[size_t(r)] += f;
                lum_sum += luminance(f);
                lum_squares += luminance(f) * luminance(f);
            }
        }
        points = to;
    };
    const uint32_t cap = uint32_t(std::max(256L, max_samples / kReplicates));
    add(0, 256);
    for (;;) {
        double mean = 0.0, var = 0.0, lum[kReplicates];
        for (int r = 0; r < kReplicates; ++r) mean += (lum[r] = luminance(sums[size_t(r)]) / points) / kReplicates;
        for (double l : lum) var += (l - mean) * (l - mean);
        // The copies' spread (3 degrees of freedom) can miss rare large values; the per-sample variance
        // (an upper bound for the quasi-Monte Carlo error) does not.
        const double n = double(points) * kReplicates;
        const double sample_variance = std::max(lum_squares / n - sqr(lum_sum / n), 0.0) * n / (n - 1.0);
        const double standard_error = std::max(std::sqrt(var / ((kReplicates - 1) * kReplicates)),
                                               std::sqrt(sample_variance / n));
        if (!(standard_error > 0.5 * tolerance * std::fabs(mean)) || 2 * points > cap) break;
        add(points, 2 * points);
    }
    for (const RGB& s : sums) albedo += (1.0 / (double(points) * kReplicates)) * s;
    return true;
}

RGB directional_albedo(const ClosureSum& bsdf, const ShadingContext& ctx, const QuadratureOptions& options) {
    if (options.huang_tolerance != 0.0) {
        // Huang closures by their estimator, the rest by the quadrature below (the albedo is linear).
        std::vector<Closure> rest;
        RGB sum;
        for (const Closure& c : bsdf.closures()) {
            RGB a;
            const HuangHair* huang = std::get_if<HuangHair>(&c.model);
            const double tolerance = options.huang_tolerance > 0.0 || !huang ? options.huang_tolerance : huang->params().tolerance;
            if (huang && huang_albedo_estimate(*huang, ctx, tolerance, options.max_nodes, a))
                sum += c.weight * a;
            else
                rest.push_back(c);
        }
        if (rest.size() == bsdf.closures().size()) return directional_albedo(bsdf, ctx, QuadratureOptions{options.panels_per_scale, options.max_nodes, 0.0});
        if (!rest.empty()) sum += directional_albedo(ClosureSum(rest), ctx, QuadratureOptions{options.panels_per_scale, options.max_nodes, 0.0});
        return sum;
    }
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
