// Huang's stochastic eval in float lanes over the Simpson nodes (docs/simd.md), included once per
// instruction set by huang_lanes_<isa>.cpp inside its own namespace HAIRBSDF_BATCH_NS. Each lane is one
// node and follows HuangHair's double path (r_integrand; add_residual_node: entry_state, tt_exit,
// trt_from_entry, trt_internal in models/huang_paths.cpp) step by step in float; where the double path returns early, a
// lane mask is cleared instead, and a lane adds its values only where its mask is set.
#pragma once

#include <xsimd/xsimd.hpp>

#include <cmath>
#include <cstdint>

#include "huang_lanes.h"

#ifndef HAIRBSDF_BATCH_INLINE
#define HAIRBSDF_BATCH_INLINE inline __attribute__((always_inline))
#endif

namespace hairbsdf {
namespace batch_detail {
namespace HAIRBSDF_BATCH_NS {

template <class Arch>
struct HuangLanes {
    using B = xsimd::batch<float, Arch>;
    using M = xsimd::batch_bool<float, Arch>;
    using I = xsimd::batch<int32_t, Arch>;
    static constexpr size_t W = B::size;
    static constexpr float kPiF = 3.14159265358979323846f;
    static constexpr float kTwoPiF = 6.28318530717958647692f;
    static constexpr float kTirEpsilonF = 1e-5f;  // huang_internal.h's kTirEpsilon

    const HuangLaneConstants& c;
    const HuangLanePoint& p;

    struct V {
        B x, y, z;
    };
    static HAIRBSDF_BATCH_INLINE V add(V a, V b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
    static HAIRBSDF_BATCH_INLINE V sub(V a, V b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
    static HAIRBSDF_BATCH_INLINE V mul(B s, V a) { return {s * a.x, s * a.y, s * a.z}; }
    static HAIRBSDF_BATCH_INLINE V neg(V a) { return {-a.x, -a.y, -a.z}; }
    static HAIRBSDF_BATCH_INLINE B dot(V a, V b) { return xsimd::fma(a.x, b.x, xsimd::fma(a.y, b.y, a.z * b.z)); }
    static HAIRBSDF_BATCH_INLINE V cross(V a, V b) {
        return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
    }
    static HAIRBSDF_BATCH_INLINE V normalize(V a) { return mul(B(1.0f) / xsimd::sqrt(dot(a, a)), a); }
    static HAIRBSDF_BATCH_INLINE V select(M m, V a, V b) {
        return {xsimd::select(m, a.x, b.x), xsimd::select(m, a.y, b.y), xsimd::select(m, a.z, b.z)};
    }
    static HAIRBSDF_BATCH_INLINE B safe_sqrt(B x) { return xsimd::sqrt(xsimd::max(x, B(0.0f))); }
    static HAIRBSDF_BATCH_INLINE B sqr(B x) { return x * x; }
    static HAIRBSDF_BATCH_INLINE M finite(B x) { return xsimd::abs(x) < B(INFINITY); }  // false for NaN
    // dot(v, h) > 0 and dot(v, m) > 0 (huang_internal.h's visible).
    static HAIRBSDF_BATCH_INLINE M visible(V v, V m, V h) { return (dot(v, h) > B(0.0f)) & (dot(v, m) > B(0.0f)); }
    HAIRBSDF_BATCH_INLINE V vec(const float* a) const { return {B(a[0]), B(a[1]), B(a[2])}; }

    // The mesonormal at (sin, cos) of gamma with the tilt's (sin, cos); for an ellipse (sin, cos) are first
    // replaced by the normal's direction in the cross-section (mesonormal_sc), returned in sn, cn.
    HAIRBSDF_BATCH_INLINE void ellipse_normal(B sg, B cg, B& sn, B& cn) const {
        if (c.circular) {
            sn = sg;
            cn = cg;
            return;
        }
        const B b(c.b);
        const B inv_n = B(1.0f) / xsimd::sqrt(xsimd::fma(cg, cg, b * b * sg * sg));
        const M use = xsimd::abs(cg) >= B(1e-6f);
        sn = xsimd::select(use, b * sg * inv_n, sg);
        cn = xsimd::select(use, cg * inv_n, cg);
    }
    static HAIRBSDF_BATCH_INLINE V tilted(float sin_tilt, float cos_tilt, B sn, B cn) {
        return {sn * B(cos_tilt), B(sin_tilt), cn * B(cos_tilt)};
    }

    // math.h's make_orthonormals.
    static HAIRBSDF_BATCH_INLINE void orthonormals(V n, V& a, V& b) {
        const M general = (n.x != n.y) | (n.x != n.z);
        a = normalize(select(general, V{n.z - n.y, n.x - n.z, n.y - n.x}, V{n.z - n.y, n.x + n.z, -n.y - n.x}));
        b = cross(n, a);
    }
    // huang_ggx.h's vndf_from_disk on the frame (s, t, m), disk point at radius r and angle.
    HAIRBSDF_BATCH_INLINE V vndf_sample(V v, V m, V s, V t, B r, B angle) const {
        const B alpha(c.alpha);
        const V vl{dot(v, s), dot(v, t), dot(v, m)};
        const auto sc = xsimd::sincos(angle);
        const B d1 = r * sc.second;
        B d2 = r * sc.first;
        const V vh = normalize(V{alpha * vl.x, alpha * vl.y, vl.z});
        const B lensq = xsimd::fma(vh.x, vh.x, vh.y * vh.y);
        const M wide = lensq > B(1e-14f);
        const B inv_len = B(1.0f) / xsimd::sqrt(xsimd::select(wide, lensq, B(1.0f)));
        const V t1{xsimd::select(wide, -vh.y * inv_len, B(1.0f)), xsimd::select(wide, vh.x * inv_len, B(0.0f)),
                   B(0.0f)};
        const V t2 = cross(vh, t1);
        const B sh = B(0.5f) * (B(1.0f) + vh.z);
        d2 = (B(1.0f) - sh) * safe_sqrt(B(1.0f) - d1 * d1) + sh * d2;
        const B d3 = safe_sqrt(B(1.0f) - d1 * d1 - d2 * d2);
        const V nh = add(add(mul(d1, t1), mul(d2, t2)), mul(d3, vh));
        const V hl = normalize(V{alpha * nh.x, alpha * nh.y, xsimd::max(nh.z, B(0.0f))});
        return add(add(mul(hl.x, s), mul(hl.y, t)), mul(hl.z, m));
    }
    // huang_ggx.h's fresnel; cos_t is the (negative) refracted cosine; total internal reflection gives 1.
    static HAIRBSDF_BATCH_INLINE B fresnel(B cos_i, float eta, B* cos_t = nullptr) {
        const B e(eta);
        const B g = e * e - (B(1.0f) - cos_i * cos_i);
        const M tir = g <= B(0.0f);
        const B cabs = xsimd::abs(cos_i);
        const B ct = -safe_sqrt(g) / e;
        if (cos_t) *cos_t = xsimd::select(tir, B(0.0f), ct);
        const B rs = (cabs + e * ct) / (cabs - e * ct);
        const B rp = (ct + e * cabs) / (e * cabs - ct);
        return xsimd::select(tir, B(1.0f), B(0.5f) * (rs * rs + rp * rp));
    }
    HAIRBSDF_BATCH_INLINE B ggx_d(B cos_nh) const {
        const B a2(c.alpha2);
        const B c2 = xsimd::min(cos_nh * cos_nh, B(1.0f));
        return a2 / (B(kPiF) * sqr(B(1.0f) - c2 + a2 * c2));
    }
    HAIRBSDF_BATCH_INLINE B lambda(B cos_n) const {
        const B c2 = cos_n * cos_n;
        const B t2 = xsimd::select(c2 > B(0.0f), xsimd::max(B(1.0f) / c2 - B(1.0f), B(0.0f)), B(INFINITY));
        return B(0.5f) * (xsimd::sqrt(B(1.0f) + B(c.alpha2) * t2) - B(1.0f));
    }
    HAIRBSDF_BATCH_INLINE B g2(B cos_i, B cos_o) const { return B(1.0f) / (B(1.0f) + lambda(cos_i) + lambda(cos_o)); }
    HAIRBSDF_BATCH_INLINE B g2_over_g1(B cos_i, B cos_o) const {
        const B li = lambda(cos_i);
        return (B(1.0f) + li) / (B(1.0f) + li + lambda(cos_o));
    }
    // 1 / E_glass at mu: the model's row over the table's mu axis (HuangLaneConstants), linear in mu.
    HAIRBSDF_BATCH_INLINE B energy_scale(B mu, const float* row) const {
        const float last = float(c.row_size - 1);
        B y = c.sqrt_mu ? safe_sqrt(mu) : mu;
        y = xsimd::select(y > B(0.0f), xsimd::min(y, B(1.0f)), B(0.0f)) * B(last);  // NaN -> 0
        const I i0 = xsimd::min(xsimd::to_int(y), I(c.row_size - 1));
        const I i1 = xsimd::min(i0 + I(1), I(c.row_size - 1));
        const B f = y - xsimd::to_float(i0);
        const B e0 = B::gather(row, i0), e1 = B::gather(row, i1);
        return B(1.0f) / ((B(1.0f) - f) * e0 + f * e1);
    }
    HAIRBSDF_BATCH_INLINE B arc_length(B sg) const {
        return c.e2 == 0.0f ? B(1.0f) : xsimd::sqrt(B(1.0f) - B(c.e2) * sg * sg);
    }
    // exp(-sigma path / cos_t) per channel (1 where sigma is 0); one_minus (when given) gets 1 - exp(...)
    // from expm1, which keeps its digits where the absorption is weak.
    HAIRBSDF_BATCH_INLINE void absorption(B path, B cos_t, B out[3], B* one_minus = nullptr) const {
        const B x = path / cos_t;
        for (int k = 0; k < 3; ++k) {
            if (c.sigma_a[k] == 0.0f) {
                out[k] = B(1.0f);
                if (one_minus) one_minus[k] = B(0.0f);
            } else if (one_minus) {
                one_minus[k] = -xsimd::expm1(B(-c.sigma_a[k]) * x);
                out[k] = B(1.0f) - one_minus[k];
            } else {
                out[k] = xsimd::exp(B(-c.sigma_a[k]) * x);
            }
        }
    }

    // h_to_gamma and the Simpson weight times d gamma / dh (ShadingPoint's gamma_base), one sine and cosine
    // of gamma per node.
    HAIRBSDF_BATCH_INLINE void node_gamma(const float* h_in, const float* weight_in, B& gamma, B& sg, B& cg,
                                          B& weight) const {
        const B h = B::load_unaligned(h_in);
        gamma = c.circular ? -xsimd::asin(xsimd::max(xsimd::min(h, B(1.0f)), B(-1.0f)))
                           : B(p.gamma_base) - xsimd::acos(xsimd::max(xsimd::min(-h, B(1.0f)), B(-1.0f)));
        const auto scg = xsimd::sincos(gamma);
        sg = scg.first;
        cg = scg.second;
        const B dd = c.circular ? cg : xsimd::fma(B(p.cos_phi_i), cg, B(c.b * p.sin_phi_i) * sg);
        weight = xsimd::select(dd != B(0.0f), B::load_unaligned(weight_in) / dd, B(0.0f));
    }

    // R's Simpson sum (HuangHair::r_integrand times the node's weight) over W nodes, added to acc.
    HAIRBSDF_BATCH_INLINE void r_nodes(M active, const float* h_in, const float* weight_in, B& acc) const {
        const V Iv = vec(p.I), O = vec(p.O), wh = vec(p.wh);
        B gamma, sg, cg, weight;
        node_gamma(h_in, weight_in, gamma, sg, cg, weight);
        B sn, cn;
        ellipse_normal(sg, cg, sn, cn);
        const V wm = tilted(c.sin_tilt, c.cos_tilt, sn, cn);
        const V macro{wm.x, B(0.0f), wm.z};
        const M ok = active & visible(Iv, macro, wh) & visible(O, macro, wh);
        const B cos_mi = dot(wm, Iv);
        const B v = ggx_d(dot(wm, wh)) * g2(cos_mi, dot(wm, O)) * arc_length(sg) *
                    energy_scale(cos_mi, c.energy_entering);
        acc = xsimd::select(ok, xsimd::fma(weight, v, acc), acc);
    }

    // W residual nodes from arrays holding at least W numbers from there.
    HAIRBSDF_BATCH_INLINE void nodes(M active, const float* h_in, const float* weight_in, const float* u1a,
                                     const float* u1b, const float* u2a, const float* u2b, B acc[9]) const {
        const V Iv = vec(p.I), O = vec(p.O);
        B gamma, sg, cg, weight;
        node_gamma(h_in, weight_in, gamma, sg, cg, weight);

        // entry_state
        B sn, cn;
        ellipse_normal(sg, cg, sn, cn);
        const V wmi = tilted(c.sin_tilt, c.cos_tilt, sn, cn);
        const V wmi_{sn, B(0.0f), cn};
        const B cos_mi1 = dot(Iv, wmi);
        M ok = active & (cos_mi1 > B(0.0f)) & (dot(Iv, wmi_) > B(0.0f));
        V s1, t1v;
        orthonormals(wmi, s1, t1v);
        const B r1 = xsimd::sqrt(B::load_unaligned(u1a)), angle1 = B(kTwoPiF) * B::load_unaligned(u1b);
        const V wh1 = vndf_sample(Iv, wmi, s1, t1v, r1, angle1);
        const B cos_hi1 = dot(Iv, wh1);
        B cos_t1;
        const B f1 = fresnel(cos_hi1, c.eta, &cos_t1);
        ok = ok & (cos_hi1 > B(0.0f)) & (f1 < B(1.0f));
        const V wt = sub(mul(xsimd::fma(B(c.inv_eta), cos_hi1, cos_t1), wh1), mul(B(c.inv_eta), Iv));
        const V mwt = neg(wt);
        const B cos_mo1 = dot(mwt, wmi);
        ok = ok & visible(Iv, wmi, wh1) & visible(mwt, wmi, wh1) & visible(Iv, wmi_, wh1) & visible(mwt, wmi_, wh1);
        if (!xsimd::any(ok)) return;
        const B t1 = B(1.0f) - f1;
        const B scale1 = energy_scale(cos_mi1, c.energy_entering);
        const B phi_t_b = xsimd::atan2(B(c.b) * wt.x, wt.z);
        const B gmt = B(2.0f) * phi_t_b - gamma;
        const auto scmt = xsimd::sincos(gmt);
        const B sgmt = scmt.first, cgmt = scmt.second;
        B snt, cnt;
        ellipse_normal(sgmt, cgmt, snt, cnt);
        const V wmt = tilted(-c.sin_tilt, c.cos_tilt, snt, cnt);
        const V wmt_{snt, B(0.0f), cnt};
        const B cos_mi2 = dot(mwt, wmt);
        const B g1o = g2_over_g1(cos_mi1, cos_mo1);
        const B ct_wt = xsimd::sqrt(xsimd::fma(wt.x, wt.x, wt.z * wt.z));
        // circular: -2 cos(gamma - phi_t), with phi_t's sine and cosine from wt; ellipse: the chord from
        // gamma to gmt + pi.
        const B path_t = c.circular ? B(-2.0f) * (cg * wt.z + sg * wt.x) / ct_wt
                                    : xsimd::sqrt(sqr(sg + sgmt) + sqr(B(c.b) * (cg + cgmt)));
        B a_t[3], one_minus_a_t[3];
        absorption(path_t, ct_wt, a_t, p.trt ? one_minus_a_t : nullptr);
        const B scale2 = energy_scale(cos_mi2, c.energy_leaving);
        const B entry = t1 * scale1 * g1o * cos_mi1 / cos_mo1;  // the factors TT and TRT share

        if (p.tt) {  // tt_exit
            M tt = ok & (dot(O, wt) >= B(c.inv_eta - kTirEpsilonF));
            const V wh2u = add(mwt, mul(B(c.inv_eta), O));
            const B len = xsimd::sqrt(dot(wh2u, wh2u));
            tt = tt & (len > B(1e-7f));
            const B inv_len = B(1.0f) / len;
            const V wh2 = mul(inv_len, wh2u);
            const B cos_mh2 = dot(wmt, wh2), cos_hi2 = dot(mwt, wh2), cos_ho2 = -dot(O, wh2);
            tt = tt & (cos_mh2 >= B(0.0f)) & (cos_hi2 > B(0.0f)) & (cos_ho2 > B(0.0f));
            const B cos_mo2 = -dot(O, wmt);
            const B t2 = (B(1.0f) - fresnel(cos_hi2, c.inv_eta)) * scale2;
            const B scalar = entry * t2 * ggx_d(cos_mh2) * g2(cos_mi2, cos_mo2) * cos_hi2 * cos_ho2 * inv_len *
                             inv_len * arc_length(sgmt);
            const B v[3] = {scalar * a_t[0], scalar * a_t[1], scalar * a_t[2]};
            tt = tt & finite(v[0]) & finite(v[1]) & finite(v[2]);
            const B w = weight * B(p.tt_scale);
            for (int k = 0; k < 3; ++k) acc[k] = xsimd::select(tt, xsimd::fma(w, v[k], acc[k]), acc[k]);
        }
        if (!p.trt) return;
        // trt_from_entry and trt_internal
        V s2, t2v;
        orthonormals(wmt, s2, t2v);
        const B r2 = xsimd::sqrt(B::load_unaligned(u2a)), angle2 = B(kTwoPiF) * B::load_unaligned(u2b);
        const V wh2 = vndf_sample(mwt, wmt, s2, t2v, r2, angle2);
        const B cos_hi2 = dot(mwt, wh2);
        M inner = ok & (cos_hi2 > B(0.0f));
        const B r2f = fresnel(cos_hi2, c.inv_eta);
        const V wtr = sub(mul(B(2.0f) * dot(wt, wh2), wh2), wt);  // -reflect(wt, wh2)
        const V mwtr = neg(wtr);
        // trrt_series(t1, r2f, a_t), its denominator 1 - x (1 - t_avg) written (1 - x) + x t_avg: at r2f = 1
        // (t_avg = 1e-5) float's 1 - (1 - 1e-5) is 0.14 % off.
        const B t_avg = xsimd::max(B(1.0f) - r2f, B(1e-5f));
        const B series_k = t1 * r2f * r2f * t_avg;
        B series[3];
        for (int k = 0; k < 3; ++k)
            series[k] = series_k * a_t[k] * a_t[k] * a_t[k] / xsimd::fma(a_t[k], t_avg, one_minus_a_t[k]);
        const M exit_tir = dot(mwtr, O) < B(c.inv_eta - kTirEpsilonF);
        const M vis2 = visible(mwt, wmt, wh2) & visible(mwtr, wmt, wh2) & visible(mwt, wmt_, wh2) &
                       visible(mwtr, wmt_, wh2);
        M trrt = inner & (exit_tir | vis2);
        M trt = inner & ~exit_tir & vis2;
        const B wtrt = weight * B(p.trrt_scale);
        {
            const B t[3] = {wtrt * series[0], wtrt * series[1], wtrt * series[2]};
            trrt = trrt & finite(t[0]) & finite(t[1]) & finite(t[2]);
            for (int k = 0; k < 3; ++k) acc[6 + k] = xsimd::select(trrt, acc[6 + k] + t[k], acc[6 + k]);
        }
        if (!xsimd::any(trt)) return;
        const B phi_tr_b = xsimd::atan2(B(c.b) * wtr.x, wtr.z);
        const B gmtr = gamma - B(2.0f) * (phi_t_b - phi_tr_b) + B(kPiF);
        const auto scmtr = xsimd::sincos(gmtr);
        const B sgmtr = scmtr.first, cgmtr = scmtr.second;
        B snr, cnr;
        ellipse_normal(sgmtr, cgmtr, snr, cnr);
        const V wmtr = tilted(-c.sin_tilt, c.cos_tilt, snr, cnr);
        const V wmtr_{snr, B(0.0f), cnr};
        const V wh3u = add(wtr, mul(B(c.inv_eta), O));
        const B len3 = xsimd::sqrt(dot(wh3u, wh3u));
        const B inv_len3 = B(1.0f) / len3;
        const V wh3 = mul(inv_len3, wh3u);
        const B cos_mh3 = dot(wmtr, wh3);
        const V mO = neg(O);
        trt = trt & (len3 > B(1e-7f)) & (cos_mh3 >= B(0.0f)) & visible(wtr, wmtr, wh3) & visible(mO, wmtr, wh3) &
              visible(wtr, wmtr_, wh3) & visible(mO, wmtr_, wh3);
        const B cos_hi3 = dot(wh3, wtr), cos_ho3 = dot(wh3, mO), cos_mi3 = dot(wmtr, wtr);
        const B t3 = (B(1.0f) - fresnel(cos_hi3, c.inv_eta)) * energy_scale(cos_mi3, c.energy_leaving);
        const B ct_wtr = xsimd::sqrt(xsimd::fma(wtr.x, wtr.x, wtr.z * wtr.z));
        // circular: 2 |cos(phi_tr - gmt)|, phi_tr's sine and cosine from wtr; ellipse: the chord.
        const B path_tr = c.circular ? B(2.0f) * xsimd::abs(wtr.z * cgmt + wtr.x * sgmt) / ct_wtr
                                     : xsimd::sqrt(sqr(sgmtr - sgmt) + sqr(B(c.b) * (cgmtr - cgmt)));
        B a_tr[3];
        absorption(path_tr, ct_wtr, a_tr);
        const B cos_mo2 = dot(wmt, mwtr);
        const B scalar = entry * r2f * scale2 * t3 * ggx_d(cos_mh3) * g2_over_g1(cos_mi2, cos_mo2) *
                         g2(cos_mi3, dot(wmtr, mO)) / cos_mo2 * cos_mi2 * cos_hi3 * cos_ho3 * inv_len3 * inv_len3 *
                         arc_length(sgmtr);
        const B v[3] = {scalar * a_t[0] * a_tr[0], scalar * a_t[1] * a_tr[1], scalar * a_t[2] * a_tr[2]};
        trt = trt & finite(v[0]) & finite(v[1]) & finite(v[2]);
        const B w = weight * B(p.trt_scale);
        for (int k = 0; k < 3; ++k) acc[3 + k] = xsimd::select(trt, xsimd::fma(w, v[k], acc[3 + k]), acc[3 + k]);
    }

    void run(const HuangLaneNodes& n, double* out) const {
        B acc[9];
        for (B& a : acc) a = B(0.0f);
        size_t k = 0;
        for (; k + W <= n.count; k += W) {
            nodes(B(0.0f) == B(0.0f), n.h + k, n.weight + k, n.u1a + k, n.u1b + k, p.trt ? n.u2a + k : n.u1a + k,
                  p.trt ? n.u2b + k : n.u1b + k, acc);
        }
        if (k < n.count) {  // the last nodes, padded with inactive lanes (h 0, weight 0, the disk's centre)
            alignas(64) float buf[6][W];
            const float* src[6] = {n.h, n.weight, n.u1a, n.u1b, p.trt ? n.u2a : n.u1a, p.trt ? n.u2b : n.u1b};
            alignas(64) float lane[W];
            for (size_t j = 0; j < W; ++j) {
                const bool in = k + j < n.count;
                for (int a = 0; a < 6; ++a) buf[a][j] = in ? src[a][k + j] : 0.0f;
                lane[j] = in ? 1.0f : 0.0f;
            }
            nodes(B::load_aligned(lane) != B(0.0f), buf[0], buf[1], buf[2], buf[3], buf[4], buf[5], acc);
        }
        for (int j = 0; j < 9; ++j) out[j] += double(xsimd::hadd(acc[j]));
    }

    double run_r(const HuangLaneNodes& n) const {
        B acc(0.0f);
        size_t k = 0;
        for (; k + W <= n.count; k += W) r_nodes(B(0.0f) == B(0.0f), n.h + k, n.weight + k, acc);
        if (k < n.count) {
            alignas(64) float h[W], weight[W], lane[W];
            for (size_t j = 0; j < W; ++j) {
                const bool in = k + j < n.count;
                h[j] = in ? n.h[k + j] : 0.0f;
                weight[j] = in ? n.weight[k + j] : 0.0f;
                lane[j] = in ? 1.0f : 0.0f;
            }
            r_nodes(B::load_aligned(lane) != B(0.0f), h, weight, acc);
        }
        return double(xsimd::hadd(acc));
    }
};

}  // namespace HAIRBSDF_BATCH_NS
}  // namespace batch_detail
}  // namespace hairbsdf
