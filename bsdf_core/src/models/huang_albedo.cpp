// Huang hair: the directional albedo's estimator (docs/huang.md §6). The albedo is the integral over O of
// eval, whose value is the expectation of Cycles' stochastic eval: a sum over Simpson nodes of paths with
// random visible normals. Integrating each node's path over O with O drawn from that path's own exit
// (given its normals, the exit is one microfacet lobe) leaves only the variation between paths, so the
// estimate needs few samples at any roughness.
#include "huang_internal.h"

#include <algorithm>

namespace hairbsdf {

// Nodes are picked with probability 0.8 x (the node's share of a pilot estimate) + 0.2 / count. The pilot: the
// node's value by albedo_node at 8 fixed points (entry normals on a ring of the disk, the exits through
// their centres). Not by |weight| alone: d gamma / dh makes the end nodes heavy (up to 20x at h = +-0.999)
// where grazing paths carry little (and often leave by total internal reflection).
HuangHair::AlbedoNodes HuangHair::albedo_nodes(const ShadingPoint& sp) const {
    AlbedoNodes out;
    auto fill = [&](const std::vector<Node>& nodes, bool residual, std::vector<AlbedoNode>& into) {
        std::vector<double> weight, share;
        constexpr int kPilot = 8;
        for (const Node& n : nodes) {
            const double gamma = h_to_gamma(sp, n.h);
            const double sin_gamma = std::sin(gamma), cos_gamma = std::cos(gamma);
            const double w = n.weight * dgamma_dh_sc(sp.sin_phi_i, sp.cos_phi_i, sin_gamma, cos_gamma);
            if (!(w != 0.0) || !std::isfinite(w)) continue;
            const AlbedoNode node{gamma, sin_gamma, cos_gamma, w, 0.0};
            double pilot = 0.0;
            for (int k = 0; k < kPilot; ++k) {
                std::array<double, kAlbedoNumbers> u;
                u.fill(0.5);  // the lobes' own samplers (0.5 > kUniformProbability)
                u[1] = u[3] = 0.5;                                  // the normals' disk radius sqrt(0.5)
                u[2] = u[4] = (k + 0.5) / kPilot;                   // around the ring
                u[6] = u[9] = u[12] = u[16] = 0.0;                  // the exits through the centre
                std::array<RGB, kLobeCount> lobes{};
                albedo_node(sp, node, residual, u, lobes);
                for (const RGB& v : lobes) pilot += std::fabs(luminance(v));
            }
            into.push_back(node);
            weight.push_back(w);
            share.push_back(std::isfinite(pilot) ? pilot : 0.0);
        }
        double total = 0.0;
        for (double x : share) total += x;
        const double count = double(into.size());
        double cumulative = 0.0;
        for (size_t k = 0; k < into.size(); ++k) {
            const double probability = total > 0.0 ? 0.8 * share[k] / total + 0.2 / count : 1.0 / count;
            into[k].factor = weight[k] / probability;
            into[k].cumulative = (cumulative += probability);
        }
    };
    if (factors_[0] > 0.0) fill(sp.r_nodes, false, out.r);
    if (factors_[1] > 0.0 || factors_[2] > 0.0) fill(sp.residual_nodes, true, out.residual);
    return out;
}

namespace {
// Node k with its probability from u; the estimator's factor is the node's.
const HuangHair::AlbedoNode* pick_node(const std::vector<HuangHair::AlbedoNode>& nodes, double u) {
    if (nodes.empty()) return nullptr;
    const auto it = std::upper_bound(nodes.begin(), nodes.end(), u,
                                     [](double x, const HuangHair::AlbedoNode& n) { return x < n.cumulative; });
    return it == nodes.end() ? &nodes.back() : &*it;
}
}  // namespace

// Numbers: u[0] the nodes; u[1..2] the entry normal and u[3..4] the internal one (eval_cycles_stochastic's
// (a, b) and (c, d)); then per lobe (choice of the uniform part, two or three for the direction): TT u[5..7],
// TRT u[8..10], TRRT+ u[11..14], R u[15..17].
std::array<RGB, kLobeCount> HuangHair::albedo_sample(const ShadingPoint& sp, const AlbedoNodes& nodes,
                                                     const std::array<double, kAlbedoNumbers>& u) const {
    std::array<RGB, kLobeCount> lobes{};
    if (!sp.valid || sp.transparent) return lobes;
    if (const AlbedoNode* n = pick_node(nodes.r, u[0])) albedo_node(sp, *n, false, u, lobes);
    if (const AlbedoNode* n = pick_node(nodes.residual, u[0])) albedo_node(sp, *n, true, u, lobes);
    return lobes;
}

// One node's part of albedo_sample: R's (residual false: lobes[0]) or the residual's (lobes[1..3]).
void HuangHair::albedo_node(const ShadingPoint& sp, const AlbedoNode& node, bool residual,
                            const std::array<double, kAlbedoNumbers>& u, std::array<RGB, kLobeCount>& lobes) const {
    const Vec3 I = sp.I;
    const AlbedoNode* n = &node;
    // A direction from the lobe's sampler with probability 1 - kUniformProbability (when there is one), else
    // uniform; returns its density, 0 where none was drawn or the eval is 0 there.
    auto direction = [&](const double* v, const auto& lobe_sample, const auto& lobe_density, bool has_lobe,
                         Vec3& O) {
        const bool uniform = !has_lobe || v[0] < kUniformProbability;
        if (uniform)
            O = uniform_sphere_direction(v[1], v[2]);
        else if (!lobe_sample(v + 1, O))
            return 0.0;
        if (tilt_hides(O)) return 0.0;
        if (!has_lobe) return uniform_sphere_density(1.0);
        return (1.0 - kUniformProbability) * lobe_density(O) + uniform_sphere_density(kUniformProbability);
    };

    // R: reflection through the visible normals of I around the node's tilted mesonormal.
    if (!residual) {
        const Vec3 wm = mesonormal_sc(sin_tilt_, cos_tilt_, n->sin_gamma, n->cos_gamma);
        const bool has_lobe = dot(I, wm) > 1e-6;
        const Component c = has_lobe ? component(I, wm, 1.0) : Component{};
        Vec3 O;
        const double density = direction(
            &u[15],
            [&](const double* v, Vec3& out) {
                out = reflection_sample(c, std::sqrt(v[0]), kTwoPi * v[1]);
                return true;
            },
            [&](Vec3 o) { return reflection_density(I, o, &c, 1, 1.0); }, has_lobe, O);
        if (density > 0.0 && length(I + O) > 0.0) {
            const Vec3 wh = normalize(I + O);
            const double value = r_lobe(sp, wh, n->factor * r_integrand_sc(sp, O, wh, n->sin_gamma, n->cos_gamma));
            if (std::isfinite(value)) lobes[0] = RGB(value / density);
        }
        return;
    }

    const double factor = n->factor;
    EntryState e;
    if (!entry_state(sp, n->gamma, n->sin_gamma, n->cos_gamma, std::sqrt(u[1]), kTwoPi * u[2], e)) return;
    const double final_scale = sp.norm * inv_eta_ * inv_eta_;
    auto exit_direction = [&](const double* v, const Component& c, bool has_lobe, Vec3& O) {
        return direction(
            v, [&](const double* w, Vec3& out) { return exit_sample(c, std::sqrt(w[0]), kTwoPi * w[1], out); },
            [&](Vec3 o) { return exit_density(c, o); }, has_lobe, O);
    };
    // TT: refraction out through the visible normals of -wt around the exit mesonormal.
    if (factors_[1] > 0.0) {
        const bool has_lobe = e.cos_mi2 > 1e-6;
        const Component c = has_lobe ? component(e.mwt, e.wmt, 1.0) : Component{};
        Vec3 O;
        const double density = exit_direction(&u[5], c, has_lobe, O);
        if (density > 0.0) {
            const RGB v = (factor * factors_[1] * final_scale / density) * tt_exit(e, O);
            if (isfinite(v)) lobes[1] = v;
        }
    }
    if (!(factors_[2] > 0.0)) return;
    // The internal visible normal as eval_cycles_stochastic draws it.
    const Vec3 wh2 = internal_normal(e, std::sqrt(u[3]), kTwoPi * u[4]);
    // TRT: refraction out through the visible normals of the internally reflected direction around its exit's
    // mesonormal.
    {
        const Vec3 wtr = -1.0 * ggx::reflect(e.wt, wh2);
        const Vec3 wmtr = trt_exit_mesonormal(e, wtr);
        const bool has_lobe = dot(wtr, wmtr) > 1e-6;
        const Component c = has_lobe ? component(wtr, wmtr, 1.0) : Component{};
        Vec3 O;
        const double density = exit_direction(&u[8], c, has_lobe, O);
        if (density > 0.0) {
            RGB trrt;
            const RGB v = (factor * factors_[2] * final_scale / density) * trt_internal(e, wh2, O, trrt);
            if (isfinite(v)) lobes[2] = v;
        }
    }
    // TRRT+: O from its longitudinal lobe; the series (which depends on O only through total internal
    // reflection at the exit) over the internal normal with TRRT+'s shell (trrt_two_strategies).
    {
        Vec3 O;
        const double density = direction(
            &u[11],
            [&](const double* w, Vec3& out) {
                out = normalize(trrt_direction(I, w[0], w[1], w[2]));
                return true;
            },
            [&](Vec3 o) { return trrt_density(I, o, 1.0); }, true, O);
        if (density > 0.0) {
            RGB series;
            trt_internal(e, wh2, O, series, nullptr, true);
            series = trrt_two_strategies(e, component(e.mwt, e.wmt, 1.0), wh2, series, O, u[3], u[4], 1.0);
            const RGB v = (factor * trrt_scale_at(sp, O) / density) * series;
            if (isfinite(v)) lobes[3] = v;
        }
    }
}

}  // namespace hairbsdf
