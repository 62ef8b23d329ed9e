// The energy-bound tables' nodes, quadrature rules and process-wide cache (models/energy_bound.h).
#include "hairbsdf/models/energy_bound.h"

#include <algorithm>
#include <chrono>
#include <list>
#include <mutex>
#include <thread>

namespace hairbsdf {

int EnergyBoundTable::views_for_scale(double scale) {
    const double n = std::ceil(1.5 * kMaxTheta * 2.0 / std::max(scale, 1e-6)) + 1.0;
    return int(clamp(n, double(kMinViews), double(kMaxViews)));
}

double EnergyBoundTable::view_theta(int k, int views) {
    const double t = -1.0 + 2.0 * k / (views - 1);
    return kMaxTheta * t * (3.0 - t * t) / 2.0;
}

RGB EnergyBoundTable::albedo(double theta_o, int orientation) const {
    // Invert theta = K t (3 - t^2) / 2: t = 2 sin(asin(theta / K) / 3).
    const double y = clamp(theta_o / kMaxTheta, -1.0, 1.0);
    const double t = 2.0 * std::sin(std::asin(y) / 3.0);
    const double x = clamp(0.5 * (t + 1.0) * (views_ - 1), 0.0, views_ - 1.0);
    const int lo = std::min(int(x), views_ - 2);
    const double f = x - lo;
    return (1.0 - f) * node(orientation, lo) + f * node(orientation, lo + 1);
}

namespace {
// The positive half of the 8-point rule (nodes in pairs +-x).
constexpr const double* kGLNodes = GaussLegendre<8>::x + 4;
constexpr const double* kGLWeights = GaussLegendre<8>::w + 4;
}  // namespace

void append_gauss_legendre(QuadratureRule& rule, double lo, double hi, int panels) {
    if (!(hi > lo) || panels < 1) return;
    const double width = (hi - lo) / panels;
    for (int k = 0; k < panels; ++k) {
        const double mid = lo + (k + 0.5) * width, half = 0.5 * width;
        for (int i = 0; i < 4; ++i) {
            rule.x.push_back(mid - half * kGLNodes[i]);
            rule.w.push_back(half * kGLWeights[i]);
            rule.x.push_back(mid + half * kGLNodes[i]);
            rule.w.push_back(half * kGLWeights[i]);
        }
    }
}

QuadratureRule gauss_legendre_rule(double lo, double hi, int panels) {
    QuadratureRule r;
    append_gauss_legendre(r, lo, hi, panels);
    return r;
}

QuadratureRule graded_gauss_legendre_rule(double lo, double hi, int panels, bool fine_lo, bool fine_hi) {
    QuadratureRule r;
    if (!(hi > lo) || panels < 1) return r;
    const double width = (hi - lo) / panels;
    // A panel [a, b] split towards `end` (a or b): b - a shrinks 4x per level.
    auto graded = [&](double a, double b, bool towards_a) {
        double len = b - a;
        double edge = towards_a ? a : b;
        for (int level = 0; level < 4; ++level) {
            const double inner = 0.75 * len;  // the part kept at this level
            if (towards_a) {
                append_gauss_legendre(r, edge + len - inner, edge + len, 1);
            } else {
                append_gauss_legendre(r, edge - len, edge - len + inner, 1);
            }
            len -= inner;
        }
        append_gauss_legendre(r, towards_a ? edge : edge - len, towards_a ? edge + len : edge, 1);
    };
    for (int k = 0; k < panels; ++k) {
        const double a = lo + k * width, b = k + 1 == panels ? hi : lo + (k + 1) * width;
        if (k == 0 && fine_lo) {
            graded(a, b, true);
        } else if (k + 1 == panels && fine_hi) {
            graded(a, b, false);
        } else {
            append_gauss_legendre(r, a, b, 1);
        }
    }
    return r;
}

void for_each_view(int views, const std::function<void(int)>& fill) {
    const int threads = int(std::clamp(std::thread::hardware_concurrency(), 1u, 8u));
    if (threads <= 1) {
        for (int k = 0; k < views; ++k) fill(k);
        return;
    }
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t)
        pool.emplace_back([&, t] {
            for (int k = t; k < views; k += threads) fill(k);
        });
    for (std::thread& th : pool) th.join();
}

namespace {
struct CacheEntry {
    std::string model;
    std::vector<double> key;
    std::shared_ptr<const EnergyBoundTable> table;
};
std::mutex g_cache_mutex;
std::list<CacheEntry> g_cache;  // most recently used first
long g_built = 0;
}  // namespace

std::shared_ptr<const EnergyBoundTable> energy_bound_table(const std::string& model, const std::vector<double>& key,
                                                           const std::function<EnergyBoundTable()>& build) {
    std::lock_guard<std::mutex> lock(g_cache_mutex);
    for (auto it = g_cache.begin(); it != g_cache.end(); ++it) {
        if (it->model == model && it->key == key) {
            if (it != g_cache.begin()) g_cache.splice(g_cache.begin(), g_cache, it);
            return g_cache.front().table;
        }
    }
    const auto start = std::chrono::steady_clock::now();
    EnergyBoundTable table = build();
    table.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ++g_built;
    g_cache.push_front({model, key, std::make_shared<const EnergyBoundTable>(std::move(table))});
    while (g_cache.size() > kEnergyBoundCacheSize) g_cache.pop_back();
    return g_cache.front().table;
}

long energy_bound_tables_built() {
    std::lock_guard<std::mutex> lock(g_cache_mutex);
    return g_built;
}

}  // namespace hairbsdf
