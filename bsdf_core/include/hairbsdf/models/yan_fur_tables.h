// The medulla-scattered lobes of yan_fur (docs/models.md §7): far-field tables of the energy that
// leaves a smooth double cylinder after scattering at least once in the medulla, built by a Monte
// Carlo random walk in 3D (src/models/yan_fur_tables.cpp) and cached process-wide per parameter set.
//
// Geometry: a unit-radius cortex (IOR eta, RGB absorption sigma_ca per unit radius) around an
// index-matched medulla of radius kappa (no interface between them), scalar absorption sigma_ma
// and scattering sigma_ms per unit radius, Henyey-Greenstein phase g (0: isotropic). Rays from the
// view direction hit the fibre uniformly in h; exact 3D Fresnel and refraction at every cortex
// boundary hit (split: the transmitted part is tallied, the reflected part walks on); cortex
// absorption is a per-channel weight, the medulla is a free-flight random walk (weight *= albedo
// per scattering event). Paths that scattered at least once are tallied when they leave:
//   TTs:  no internal reflection at the cortex boundary after entering,
//   TRTs: every other scattered path.
// Cortex absorption acts along the whole path inside the fibre and the medulla's extinction on top
// of it inside the medulla (as in the unscattered lobes).
// Tables are over (theta_o node, sin theta_i bin, |phi| bin); the symmetries used are the
// fibre's mirror x -> -x (sin theta_o < 0: sin theta_i flips) and phi -> -phi (after the h average).
// The value stored is the energy per unit solid angle of the exit direction for unit energy
// entering from the view: the library's eval (cosine included, docs/conventions.md).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "hairbsdf/math.h"

namespace hairbsdf {

struct YanFurTableKey {
    double eta = 1.55;
    RGB cortex_absorption{0.64};  // sigma_ca per unit radius
    double medulla_ratio = 0.88;  // kappa
    double medulla_absorption = 0.17;
    double medulla_scattering = 1.69;
    double medulla_g = 0.0;
    bool operator==(const YanFurTableKey& o) const {
        return eta == o.eta && cortex_absorption.r == o.cortex_absorption.r &&
               cortex_absorption.g == o.cortex_absorption.g && cortex_absorption.b == o.cortex_absorption.b &&
               medulla_ratio == o.medulla_ratio && medulla_absorption == o.medulla_absorption &&
               medulla_scattering == o.medulla_scattering && medulla_g == o.medulla_g;
    }
};

class YanFurTable {
public:
    static constexpr int kLobes = 2;     // TTs, TRTs
    static constexpr int kNodes = 12;    // theta_o nodes, uniform in cos theta_o (node_cos)
    static constexpr int kTheta = 24;    // sin theta_i bins over [-1, 1]
    static constexpr int kPhi = 24;      // |phi| bins over [0, pi]
    static constexpr int kBins = kTheta * kPhi;
    static constexpr int kH = 24;        // chord bins of the scattered energy (chord_coordinate)
    static constexpr long kPathsPerNode = 110000;

    // `seed` changes the random streams (tests measure the table's noise with it); the cache uses
    // the default.
    static constexpr uint64_t kDefaultSeed = 0x5eed0000ull;
    explicit YanFurTable(const YanFurTableKey& key, uint64_t seed = kDefaultSeed, long paths_per_node = kPathsPerNode);

    const YanFurTableKey& key() const { return key_; }
    // Nodes uniform in cos theta_o from 1 to kMinCos (89.4 deg; steeper views clamp to it): near
    // grazing the Fresnel factors at cos theta_o cos gamma that trap light inside the fibre (and
    // so decide how much of it reaches the medulla) are close to linear in cos theta_o.
    static constexpr double kMinCos = 0.01;
    static double node_cos(int k) { return 1.0 - (1.0 - kMinCos) * k / (kNodes - 1); }
    static double node_sin(int k) { return cos_from_sin(node_cos(k)); }
    // Position of a view between the nodes: k + t.
    static double node_position(double cos_theta_o) {
        return clamp((1.0 - cos_theta_o) / (1.0 - kMinCos) * (kNodes - 1), 0.0, kNodes - 1.0);
    }
    static double bin_width_sin() { return 2.0 / kTheta; }
    static double bin_width_phi() { return kPi / kPhi; }
    // The bin of (sin theta_i, |phi|) (sin theta_i already mirrored for sin theta_o < 0).
    static int bin(double sin_theta_i, double abs_phi) {
        const int t = int(clamp(std::floor((sin_theta_i + 1.0) / bin_width_sin()), 0.0, kTheta - 1.0));
        const int p = int(clamp(std::floor(abs_phi / bin_width_phi()), 0.0, kPhi - 1.0));
        return t * kPhi + p;
    }

    // Energy per unit solid angle of the exit direction (RGB) in one bin.
    RGB density(int lobe, int node, int bin) const { return density_[index(lobe, node) * kBins + size_t(bin)]; }
    // Its luminance divided by the luminance of the lobe's energy: the sampling density of the
    // lobe at this node (integrates to 1 over the sphere), 0 where the lobe has no energy.
    double sampling_density(int lobe, int node, int bin) const {
        return sampling_density_[index(lobe, node) * kBins + size_t(bin)];
    }
    // Total energy of the lobe at this node (RGB, fraction of the energy entering from the view)
    // and its luminance.
    RGB energy(int lobe, int node) const { return energy_[index(lobe, node)]; }
    double energy_luminance(int lobe, int node) const { return luminance(energy_[index(lobe, node)]); }
    // The refracted ray's 2D chord lies at distance |sin gamma_t| = |h| / eta' from the axis on
    // every internal pass; it crosses the medulla iff that is < kappa, along the half chord
    // sqrt(kappa^2 - sin^2 gamma_t). The scattered energy is tabulated over
    // c = sqrt(1 - (sin gamma_t / kappa)^2) in [0, 1] (smooth in c; it has a square-root kink
    // in h where the chord leaves the medulla, at a theta_o-dependent h = kappa eta').
    static double chord_coordinate(double sin_gamma_t, double kappa) {
        return safe_sqrt(1.0 - sqr(sin_gamma_t / kappa));
    }
    // The chord bin of a path, or -1 where the chord misses the medulla.
    static int chord_bin(double sin_gamma_t, double kappa) {
        if (!(std::fabs(sin_gamma_t) < kappa)) return -1;
        return std::min(kH - 1, int(chord_coordinate(sin_gamma_t, kappa) * kH));
    }
    // The energy that scatters in the medulla per unit energy entering the fibre, counting the
    // unscattered passes as the analytic lobes do: (1 - T_m) / (1 - f T_c T_m), with f the Fresnel
    // factor at cos theta_o cos gamma_o, T_c = exp(-sigma_ca 2 cos gamma_t / cos theta_t) and
    // T_m = exp(-sigma_mt L_m) one pass's cortex and medulla transmittances (RGB; 0 where the
    // chord misses the medulla). It carries the steep dependence on the view (light trapped by
    // Fresnel near grazing); the table stores the rest.
    static RGB scattering_prefactor(double f, RGB cortex_pass, double medulla_pass) {
        const RGB tf = (f * medulla_pass) * cortex_pass;
        const double m = 1.0 - medulla_pass;
        return RGB(m / (1.0 - tf.r), m / (1.0 - tf.g), m / (1.0 - tf.b));
    }
    // The lobe's energy leaving the fibre per unit of scattering_prefactor times the energy that
    // entered (after the entry Fresnel), for the chord at |sin gamma_t|: per chord bin, linear
    // between the bin centres (RGB), 0 where the chord misses the medulla. (Without absorption
    // TTs + TRTs is about 1: all scattered light leaves.)
    RGB scattered_per_entering(int lobe, int node, double sin_gamma_t) const;
    // A bin drawn from sampling_density (u in [0, 1)) and u rescaled within the bin.
    int sample_bin(int lobe, int node, double u, double& u_rest) const;

    double build_seconds() const { return build_seconds_; }

private:
    static size_t index(int lobe, int node) { return size_t(lobe) * kNodes + size_t(node); }
    YanFurTableKey key_;
    std::vector<RGB> density_;              // [lobe][node][bin]
    std::vector<double> sampling_density_;  // [lobe][node][bin]
    std::vector<double> cdf_;               // [lobe][node][bin + 1]
    std::vector<RGB> energy_;               // [lobe][node]
    std::vector<RGB> h_energy_;             // [lobe][node][chord bin], per entering energy and prefactor
    double build_seconds_ = 0;
};

// The table for `key`, built on first use and shared: a process-wide cache (mutex; the
// kYanFurCacheSize most recently used parameter sets are kept). Deterministic (fixed seeds).
std::shared_ptr<const YanFurTable> yan_fur_table(const YanFurTableKey& key);
constexpr size_t kYanFurCacheSize = 16;
// Number of tables built so far in this process (tests: the cache returns built tables).
long yan_fur_tables_built();

}  // namespace hairbsdf
