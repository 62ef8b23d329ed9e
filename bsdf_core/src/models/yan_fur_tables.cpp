// The Monte Carlo random walk behind yan_fur's scattered lobes (models/yan_fur_tables.h,
// docs/models.md §7) and the process-wide table cache.
#include "hairbsdf/models/yan_fur_tables.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <list>
#include <mutex>
#include <thread>

namespace hairbsdf {

namespace {

// xoshiro256+ seeded by splitmix64: fast, and the stream per table node is fixed by its seed.
class Rng {
public:
    explicit Rng(uint64_t seed) {
        for (uint64_t& s : s_) {
            seed += 0x9e3779b97f4a7c15ull;
            uint64_t z = seed;
            z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
            z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
            s = z ^ (z >> 31);
        }
    }
    double next() {  // [0, 1)
        const uint64_t result = s_[0] + s_[3];
        const uint64_t t = s_[1] << 17;
        s_[2] ^= s_[0];
        s_[3] ^= s_[1];
        s_[1] ^= s_[2];
        s_[0] ^= s_[3];
        s_[2] ^= t;
        s_[3] = (s_[3] << 45) | (s_[3] >> 19);
        return double(result >> 11) * 0x1.0p-53;
    }

private:
    uint64_t s_[4];
};

// A direction from the Henyey-Greenstein phase function about `d` (isotropic for g = 0).
Vec3 sample_phase(Vec3 d, double g, double u1, double u2) {
    double cos_t;
    if (std::fabs(g) < 1e-4) {  // isotropic: a uniform direction, no basis needed
        const double z = 1.0 - 2.0 * u1, r = cos_from_sin(z), phi = kTwoPi * u2;
        return {z, r * std::cos(phi), r * std::sin(phi)};
    } else {
        const double s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u1);
        cos_t = clamp((1.0 + g * g - s * s) / (2.0 * g), -1.0, 1.0);
    }
    const double sin_t = cos_from_sin(cos_t), phi = kTwoPi * u2;
    // An orthonormal basis about d.
    const Vec3 a = std::fabs(d.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    const Vec3 b1 = normalize(cross(d, a));
    const Vec3 b2 = cross(d, b1);
    return normalize(cos_t * d + (sin_t * std::cos(phi)) * b1 + (sin_t * std::sin(phi)) * b2);
}

struct NodeTally {
    std::array<std::vector<RGB>, YanFurTable::kLobes> bins;
    std::array<std::array<RGB, YanFurTable::kH>, YanFurTable::kLobes> h_energy{};  // per chord bin, / prefactor
    std::array<long, YanFurTable::kH> h_paths{};
    NodeTally() {
        for (auto& b : bins) b.assign(YanFurTable::kBins, RGB(0.0));
    }
};

// Random walks for light entering from the view at |sin theta_o| = sin_o, phi_o = 0, uniformly in
// h in [0, 1) (stratified; h < 0 mirrors phi, which the |phi| table folds). Cortex absorption acts
// along the whole path inside the fibre, the medulla's extinction on top of it inside the medulla
// (the convention of the unscattered lobes, models/yan_fur.h).
void walk_node(const YanFurTableKey& key, double sin_o, long paths, uint64_t seed, NodeTally& tally) {
    Rng rng(seed);
    const double eta = key.eta, kappa = key.medulla_ratio, kappa2 = kappa * kappa;
    const double sigma_t = key.medulla_absorption + key.medulla_scattering;
    const double medulla_albedo = sigma_t > 0 ? key.medulla_scattering / sigma_t : 0.0;
    const RGB sigma_c = key.cortex_absorption;
    const bool grey = sigma_c.r == sigma_c.g && sigma_c.g == sigma_c.b;
    const double cos_o = cos_from_sin(sin_o);
    const Vec3 d_in{-sin_o, -cos_o, 0.0};  // travelling towards the fibre from the view at +y
    // Distance of the refracted chord from the axis per unit h (sin gamma_t / h, Bravais).
    const double chord_per_h = cos_o / std::sqrt(eta * eta - sin_o * sin_o);
    // Quasi-random points for h (stratified) and the first collision (position, two direction
    // coordinates): the additive recurrence of the generalised golden ratio in 4D (a rank-1
    // lattice with h = i / N), with a random shift per node (unbiased, Cranley-Patterson). The
    // first scattering direction decides most of TTs; this lowers the table noise ~2-3x.
    const double phi4 = 1.1673039782614187;
    const double alpha[3] = {1.0 / (phi4 * phi4), 1.0 / (phi4 * phi4 * phi4), 1.0 / (phi4 * phi4 * phi4 * phi4)};
    const double shift[4] = {rng.next(), rng.next(), rng.next(), rng.next()};
    for (long i = 0; i < paths; ++i) {
        double q[3];
        for (int j = 0; j < 3; ++j) {
            const double x = shift[j + 1] + double(i) * alpha[j];
            q[j] = x - std::floor(x);
        }
        double hq = (double(i) + shift[0]) / double(paths);
        const double h = hq - std::floor(hq);
        const int h_bin = YanFurTable::chord_bin(h * chord_per_h, kappa);
        if (h_bin < 0) continue;  // the chord misses the medulla: nothing scatters
        // Entry on the unit circle; outward normal n = (0, y, z).
        double y = cos_from_sin(h), z = h;
        Vec3 n{0.0, y, z};
        double cos_i = -dot(d_in, n);
        if (!(cos_i > 0)) continue;
        const double f_in = fresnel_dielectric(cos_i, eta);
        ++tally.h_paths[size_t(h_bin)];
        // Per-path normalisation of the tally: entering energy times the analytic prefactor.
        const double sin_gamma_t = h * chord_per_h, cos_gamma_t = cos_from_sin(sin_gamma_t);
        const double cos_theta_t = cos_from_sin(sin_o / eta);
        const RGB cortex_pass = exp((-2.0 * cos_gamma_t / cos_theta_t) * sigma_c);
        const double medulla_pass = std::exp(-sigma_t * 2.0 * safe_sqrt(kappa2 - sqr(sin_gamma_t)) / cos_theta_t);
        const RGB prefactor = (1.0 - f_in) * YanFurTable::scattering_prefactor(f_in, cortex_pass, medulla_pass);
        const RGB inv_prefactor(prefactor.r > 0 ? 1.0 / prefactor.r : 0.0, prefactor.g > 0 ? 1.0 / prefactor.g : 0.0,
                                prefactor.b > 0 ? 1.0 / prefactor.b : 0.0);
        RGB w(1.0 - f_in);
        const double cos_t_in = safe_sqrt(1.0 - (1.0 - cos_i * cos_i) / (eta * eta));
        Vec3 d = normalize((1.0 / eta) * d_in + (cos_i / eta - cos_t_in) * n);
        bool in_medulla = false, scattered = false;
        int reflections = 0;
        // Forced first collision: an unscattered path crossing the medulla (chord t_exit) splits
        // into a part that scatters in it (weight 1 - exp(-sigma_t t_exit), the position from the
        // truncated exponential) and an unscattered part that crosses it; the latter is saved here
        // and resumed when the scattered part ends. Unscattered light is not tallied (it is the
        // analytic R/TT/TRT/TRRT+), so every crossing feeds the tables.
        struct Saved {
            double y, z;
            Vec3 d;
            RGB w;
            int reflections;
        };
        Saved saved{};
        bool has_saved = false, resumed = false;
        auto resume = [&] {
            if (!has_saved) return false;
            resumed = true;
            y = saved.y, z = saved.z, d = saved.d, w = saved.w, reflections = saved.reflections;
            in_medulla = false, scattered = false, has_saved = false;
            return true;
        };
        for (int step = 0; step < 100000; ++step) {
            const double a = d.y * d.y + d.z * d.z;
            const double b = y * d.y + z * d.z;
            const double c = y * y + z * z;
            if (in_medulla && !scattered && sigma_t > 0 && a > 1e-300) {
                const double t_exit = (-b + safe_sqrt(b * b - a * (c - kappa2))) / a;
                const double pass = std::exp(-sigma_t * t_exit);
                const RGB cortex = grey ? RGB(std::exp(-t_exit * sigma_c.r)) : exp((-t_exit) * sigma_c);
                saved = {y + t_exit * d.y, z + t_exit * d.z, d, pass * (w * cortex), reflections};
                has_saved = true;
                const double s = -std::log1p(-(reflections == 0 && !resumed ? q[0] : rng.next()) * (1.0 - pass)) / sigma_t;
                y += s * d.y;
                z += s * d.z;
                w = (medulla_albedo * (1.0 - pass)) * (grey ? std::exp(-s * sigma_c.r) * w : w * exp((-s) * sigma_c));
                scattered = true;
                // The first collision of the entering path takes its position and direction from
                // the path's quasi-random point (below); later ones from the stream.
                const bool first = reflections == 0 && !resumed;
                d = sample_phase(d, key.medulla_g, first ? q[1] : rng.next(), first ? q[2] : rng.next());
                continue;
            }
            if (in_medulla) {
                double t_exit = 1e300;
                if (a > 1e-300) t_exit = (-b + safe_sqrt(b * b - a * (c - kappa2))) / a;
                const double s = sigma_t > 0 ? -std::log(1.0 - rng.next()) / sigma_t : 1e300;
                if (s < t_exit) {
                    y += s * d.y;
                    z += s * d.z;
                    w = medulla_albedo * (grey ? std::exp(-s * sigma_c.r) * w : w * exp((-s) * sigma_c));
                    scattered = true;
                    d = sample_phase(d, key.medulla_g, rng.next(), rng.next());
                    continue;
                }
                if (t_exit >= 1e300) {  // along the axis with no extinction: never leaves
                    if (!resume()) break;
                    continue;
                }
                w = grey ? std::exp(-t_exit * sigma_c.r) * w : w * exp((-t_exit) * sigma_c);
                y += t_exit * d.y;
                z += t_exit * d.z;
                in_medulla = false;
                continue;
            }
            if (!(a > 1e-300)) {  // along the axis in the cortex: absorbed (or never leaves)
                if (!resume()) break;
                continue;
            }
            const double t_out = (-b + safe_sqrt(b * b - a * (c - 1.0))) / a;
            if (kappa > 0) {
                const double disc = b * b - a * (c - kappa2);
                if (disc > 0) {
                    const double t1 = (-b - std::sqrt(disc)) / a;
                    if (t1 > 1e-12 && t1 < t_out) {
                        w = grey ? std::exp(-t1 * sigma_c.r) * w : w * exp((-t1) * sigma_c);
                        y += t1 * d.y;
                        z += t1 * d.z;
                        in_medulla = true;
                        continue;
                    }
                }
            }
            w = grey ? std::exp(-t_out * sigma_c.r) * w : w * exp((-t_out) * sigma_c);
            y += t_out * d.y;
            z += t_out * d.z;
            const double r = std::sqrt(y * y + z * z);
            y /= r;
            z /= r;
            n = Vec3{0.0, y, z};
            const double cos_b = clamp(dot(d, n), 0.0, 1.0);
            const double f = fresnel_dielectric(cos_b, 1.0 / eta);
            if (scattered && f < 1.0) {
                const double sin2_t = eta * eta * (1.0 - cos_b * cos_b);
                const double cos_t = safe_sqrt(1.0 - sin2_t);
                const Vec3 out = normalize(eta * d + (cos_t - eta * cos_b) * n);
                const int lobe = reflections == 0 ? 0 : 1;
                const RGB e = (1.0 - f) * w;
                const double abs_phi = std::fabs(std::atan2(out.z, out.y));
                tally.bins[size_t(lobe)][size_t(YanFurTable::bin(clamp(out.x, -1.0, 1.0), abs_phi))] += e;
                tally.h_energy[size_t(lobe)][size_t(h_bin)] += inv_prefactor * e;
            }
            w = f * w;
            ++reflections;
            d = normalize(d - (2.0 * cos_b) * n);
            // Total internal reflection on a chord that misses the medulla repeats forever: the
            // light is guided along the fibre and never leaves (nor scatters again).
            bool end = f >= 1.0 && !(sqr(y * d.z - z * d.y) / (d.y * d.y + d.z * d.z) < kappa2);
            // Russian roulette below 1 % of the path's energy (unbiased).
            if (!end && std::max(w.r, std::max(w.g, w.b)) < 0.01) {
                if (rng.next() < 0.5) end = true;
                else w = 2.0 * w;
            }
            if (end && !resume()) break;
        }
    }
}

}  // namespace

YanFurTable::YanFurTable(const YanFurTableKey& key, uint64_t seed, long paths_per_node) : key_(key) {
    const auto start = std::chrono::steady_clock::now();
    std::vector<NodeTally> tallies(kNodes);
    const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
    const int threads = int(std::min<unsigned>(hw, kNodes));
    std::atomic<int> next{0};
    auto worker = [&] {
        for (int k; (k = next.fetch_add(1)) < kNodes;)
            walk_node(key_, node_sin(k), paths_per_node, seed + uint64_t(k) * 7919ull, tallies[size_t(k)]);
    };
    if (threads <= 1) {
        worker();
    } else {
        std::vector<std::thread> pool;
        for (int t = 0; t < threads; ++t) pool.emplace_back(worker);
        for (std::thread& t : pool) t.join();
    }

    const double bin_solid_angle = 2.0 * bin_width_sin() * bin_width_phi();  // both signs of phi
    density_.assign(size_t(kLobes) * kNodes * kBins, RGB(0.0));
    sampling_density_.assign(size_t(kLobes) * kNodes * kBins, 0.0);
    cdf_.assign(size_t(kLobes) * kNodes * (kBins + 1), 0.0);
    energy_.assign(size_t(kLobes) * kNodes, RGB(0.0));
    h_energy_.assign(size_t(kLobes) * kNodes * kH, RGB(0.0));
    for (int lobe = 0; lobe < kLobes; ++lobe) {
        for (int k = 0; k < kNodes; ++k) {
            const size_t i = index(lobe, k);
            const NodeTally& t = tallies[size_t(k)];
            RGB total(0.0);
            for (int b = 0; b < kBins; ++b) {
                const RGB e = (1.0 / double(paths_per_node)) * t.bins[size_t(lobe)][size_t(b)];
                density_[i * kBins + size_t(b)] = (1.0 / bin_solid_angle) * e;
                total += e;
            }
            energy_[i] = total;
            const double lum = luminance(total);
            double* cdf = &cdf_[i * (kBins + 1)];
            for (int b = 0; b < kBins; ++b) {
                const double p = lum > 0 ? luminance(density_[i * kBins + size_t(b)]) / lum : 0.0;
                sampling_density_[i * kBins + size_t(b)] = p;
                cdf[b + 1] = cdf[b] + p * bin_solid_angle;
            }
            if (lum > 0) {
                for (int b = 0; b <= kBins; ++b) cdf[b] /= cdf[kBins];
                cdf[kBins] = 1.0;
            }
            // Scattered energy per unit of entering energy x prefactor, per chord bin; bins no path
            // reached (outside this view's range of chords) take the nearest reached bin's value.
            RGB* g = &h_energy_[i * kH];
            int first = -1;
            for (int j = 0; j < kH; ++j) {
                const long n = t.h_paths[size_t(j)];
                if (n > 0) {
                    g[j] = (1.0 / double(n)) * t.h_energy[size_t(lobe)][size_t(j)];
                    if (first < 0) first = j;
                }
            }
            if (first >= 0) {
                for (int j = 0; j < first; ++j) g[j] = g[first];
                for (int j = first + 1; j < kH; ++j)
                    if (t.h_paths[size_t(j)] == 0) g[j] = g[j - 1];
            }
        }
    }
    build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

RGB YanFurTable::scattered_per_entering(int lobe, int node, double sin_gamma_t) const {
    const double kappa = key_.medulla_ratio;
    if (!(std::fabs(sin_gamma_t) < kappa)) return RGB(0.0);
    const RGB* he = &h_energy_[index(lobe, node) * kH];
    const double x = chord_coordinate(sin_gamma_t, kappa) * kH - 0.5;  // bin centres at j + 1/2
    if (x <= 0) return he[0];
    if (x >= kH - 1) return he[kH - 1];
    const int j = int(x);
    const double t = x - j;
    return (1.0 - t) * he[j] + t * he[j + 1];
}

int YanFurTable::sample_bin(int lobe, int node, double u, double& u_rest) const {
    const double* cdf = &cdf_[index(lobe, node) * (kBins + 1)];
    int b = int(std::upper_bound(cdf, cdf + kBins + 1, u) - cdf) - 1;
    b = std::max(0, std::min(b, kBins - 1));
    while (b < kBins - 1 && !(cdf[b + 1] > cdf[b])) ++b;  // skip empty bins
    while (b > 0 && !(cdf[b + 1] > cdf[b])) --b;
    const double width = cdf[b + 1] - cdf[b];
    u_rest = width > 0 ? clamp((u - cdf[b]) / width, 0.0, 1.0 - 1e-16) : 0.5;
    return b;
}

namespace {
std::mutex g_cache_mutex;
std::list<std::shared_ptr<const YanFurTable>> g_cache;  // most recently used first
std::atomic<long> g_built{0};
}  // namespace

std::shared_ptr<const YanFurTable> yan_fur_table(const YanFurTableKey& key) {
    std::lock_guard<std::mutex> lock(g_cache_mutex);
    for (auto it = g_cache.begin(); it != g_cache.end(); ++it) {
        if ((*it)->key() == key) {
            if (it != g_cache.begin()) g_cache.splice(g_cache.begin(), g_cache, it);
            return g_cache.front();
        }
    }
    auto table = std::make_shared<const YanFurTable>(key);
    ++g_built;
    g_cache.push_front(table);
    while (g_cache.size() > kYanFurCacheSize) g_cache.pop_back();
    return table;
}

long yan_fur_tables_built() { return g_built.load(); }

}  // namespace hairbsdf
