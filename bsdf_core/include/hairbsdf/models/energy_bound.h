// The energy bound of the zoo's non-energy-conserving models (Epic, Marschner; docs/models.md §2,
// §4): with energy = "bounded" a model's eval is divided per channel by max(1, E_c(theta_o)),
// E_c the model's own directional albedo (the integral of eval over the sphere of omega_i) for
// its actual parameters at that view. A view and channel that would create energy is scaled to an
// albedo of 1; everything else is left as published.
//
// E is tabulated at construction: 65 to 1025 nodes in theta_o (more for narrower lobes; dense near
// grazing, where Marschner's 1 / cos^2 theta_d makes it steep), linear in between, times a few
// "orientation" nodes for a model whose albedo also depends on something else (Marschner: the
// cross-section's axis). Each node is a deterministic quadrature of each lobe around its own peak
// (src/models/epic_energy.cpp, marschner_energy.cpp). Tables are cached process-wide, keyed by the
// model name and its parameter values. The scale depends on the view, so a bounded model is not
// reciprocal where it scales.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "hairbsdf/math.h"

namespace hairbsdf {

// The `energy` parameter of Epic and Marschner: "bounded" (the default) or "published".
enum class EnergyMode { Bounded, Published };
inline const char* energy_mode_name(EnergyMode mode) { return mode == EnergyMode::Bounded ? "bounded" : "published"; }

class EnergyBoundTable {
public:
    // Views closer to the fibre axis than this use the end nodes (the frame degenerates there).
    static constexpr double kMaxTheta = 0.5 * kPi - 1e-3;
    static constexpr int kMinViews = 65, kMaxViews = 1025;
    // The number of view nodes for lobes whose albedo changes over `scale` radians of theta_o
    // (the narrowest lobe width): nodes about `scale` apart at theta_o = 0, 65 to 1025.
    static int views_for_scale(double scale);
    // Node k of n: t in [-1, 1] uniform, theta = kMaxTheta t (3 - t^2) / 2 (4.7 / (n - 1) rad apart
    // at theta_o = 0, denser towards grazing, where Marschner's 1 / cos^2 theta_d makes E steep).
    static double view_theta(int k, int views);

    // E per [orientation][view] node, RGB; build_seconds is set by the cache.
    explicit EnergyBoundTable(int views = kMinViews, int orientations = 1)
        : views_(views), orientations_(orientations), albedo_(size_t(orientations) * size_t(views)) {}
    int views() const { return views_; }
    int orientations() const { return orientations_; }
    double view_theta(int k) const { return view_theta(k, views_); }
    RGB& node(int orientation, int view) { return albedo_[size_t(orientation) * size_t(views_) + size_t(view)]; }
    const RGB& node(int orientation, int view) const {
        return albedo_[size_t(orientation) * size_t(views_) + size_t(view)];
    }
    // E at theta_o for one orientation node, linear between the view nodes.
    RGB albedo(double theta_o, int orientation = 0) const;
    // 1 / max(1, E) per channel.
    static RGB bound_scale(RGB e) {
        return {1.0 / std::max(1.0, e.r), 1.0 / std::max(1.0, e.g), 1.0 / std::max(1.0, e.b)};
    }

    double build_seconds = 0;

private:
    int views_, orientations_;
    std::vector<RGB> albedo_;  // [orientation][view]
};

// A composite 8-point Gauss-Legendre rule on [lo, hi] with `panels` equal panels.
struct QuadratureRule {
    std::vector<double> x, w;
};
QuadratureRule gauss_legendre_rule(double lo, double hi, int panels);
// The same rule appended to `rule` (piecewise rules with breakpoints).
void append_gauss_legendre(QuadratureRule& rule, double lo, double hi, int panels);
// `panels` equal panels, the first / last one replaced by panels shrinking geometrically (4x, 4
// levels) towards lo / hi where fine_lo / fine_hi: for integrands steep at a clipped end.
QuadratureRule graded_gauss_legendre_rule(double lo, double hi, int panels, bool fine_lo, bool fine_hi);

// fill(k) for k in [0, views), on a few threads (each call writes its own node only).
void for_each_view(int views, const std::function<void(int)>& fill);

// The table for (model, key), built by `build` on first use and shared: a process-wide cache (mutex;
// the kEnergyBoundCacheSize most recently used parameter sets are kept).
std::shared_ptr<const EnergyBoundTable> energy_bound_table(const std::string& model, const std::vector<double>& key,
                                                           const std::function<EnergyBoundTable()>& build);
constexpr size_t kEnergyBoundCacheSize = 32;
// Number of tables built so far in this process (tests: the cache returns built tables).
long energy_bound_tables_built();

}  // namespace hairbsdf
