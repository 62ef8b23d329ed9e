// Huang in float lanes (docs/simd.md), included once per instruction set by huang_lanes_<isa>.cpp inside its own
// namespace HAIRBSDF_BATCH_NS: the stochastic eval with one Simpson node per lane (run, run_r), and the
// deterministic eval's TRT rule and TT cubature with one point of a node per lane (run_trt, run_tt). Each lane
// follows HuangHair's double path (r_integrand; entry_state, tt_exit, trt_internal, trt_mis_point in
// models/huang_paths.cpp) step by step in float; where the double path returns early, a lane mask is cleared
// instead, and a lane adds its values only where its mask is set.
#pragma once

#include <xsimd/xsimd.hpp>

#include <cmath>
#include <cstdint>

#include "huang_lanes.h"

#ifndef HAIRBSDF_BATCH_INLINE
#define HAIRBSDF_BATCH_INLINE inline __attribute__((always_inline))
#endif

namespace hairbsdf {
namespace huang_lanes_detail {
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

    // The mesonormal at angle g (tilt sine sin_tilt), untilted (wm_), and sin, cos of g.
    HAIRBSDF_BATCH_INLINE void mesonormals_at(B g, float sin_tilt, B& sg, B& cg, V& wm, V& wm_) const {
        const auto sc = xsimd::sincos(g);
        sg = sc.first;
        cg = sc.second;
        B sn, cn;
        ellipse_normal(sg, cg, sn, cn);
        wm = tilted(sin_tilt, c.cos_tilt, sn, cn);
        wm_ = V{sn, B(0.0f), cn};
    }

    // HuangHair::EntryState in lanes: the path up to the second interface (entry_state); `ok` is cleared
    // where the double path returns false. Fields past `ok` are valid only where xsimd::any(ok).
    struct Entry {
        M ok;
        V wt, mwt, wmt, wmt_;
        B cos_mi1, cos_mo1, cos_mi2, phi_t_b, gmt, sgmt, cgmt, t1, scale2;
        B entry;  // t1 x scale1 x G2/G1 x cos_mi1 / cos_mo1: the factors TT and TRT share
        B a_t[3], one_minus_a_t[3];
    };
    HAIRBSDF_BATCH_INLINE Entry entry_state(M active, B gamma, B sg, B cg, B r1, B angle1, bool trt) const {
        const V Iv = vec(p.I);
        Entry e;
        B sn, cn;
        ellipse_normal(sg, cg, sn, cn);
        const V wmi = tilted(c.sin_tilt, c.cos_tilt, sn, cn);
        const V wmi_{sn, B(0.0f), cn};
        e.cos_mi1 = dot(Iv, wmi);
        e.ok = active & (e.cos_mi1 > B(0.0f)) & (dot(Iv, wmi_) > B(0.0f));
        V s1, t1v;
        orthonormals(wmi, s1, t1v);
        const V wh1 = vndf_sample(Iv, wmi, s1, t1v, r1, angle1);
        const B cos_hi1 = dot(Iv, wh1);
        B cos_t1;
        const B f1 = fresnel(cos_hi1, c.eta, &cos_t1);
        e.ok = e.ok & (cos_hi1 > B(0.0f)) & (f1 < B(1.0f));
        e.wt = sub(mul(xsimd::fma(B(c.inv_eta), cos_hi1, cos_t1), wh1), mul(B(c.inv_eta), Iv));
        e.mwt = neg(e.wt);
        e.cos_mo1 = dot(e.mwt, wmi);
        e.ok = e.ok & visible(Iv, wmi, wh1) & visible(e.mwt, wmi, wh1) & visible(Iv, wmi_, wh1) &
               visible(e.mwt, wmi_, wh1);
        if (!xsimd::any(e.ok)) return e;
        e.t1 = B(1.0f) - f1;
        const B scale1 = energy_scale(e.cos_mi1, c.energy_entering);
        e.phi_t_b = xsimd::atan2(B(c.b) * e.wt.x, e.wt.z);
        e.gmt = B(2.0f) * e.phi_t_b - gamma;
        mesonormals_at(e.gmt, -c.sin_tilt, e.sgmt, e.cgmt, e.wmt, e.wmt_);
        e.cos_mi2 = dot(e.mwt, e.wmt);
        const B g1o = g2_over_g1(e.cos_mi1, e.cos_mo1);
        const B ct_wt = xsimd::sqrt(xsimd::fma(e.wt.x, e.wt.x, e.wt.z * e.wt.z));
        // circular: -2 cos(gamma - phi_t), with phi_t's sine and cosine from wt; ellipse: the chord from
        // gamma to gmt + pi.
        const B path_t = c.circular ? B(-2.0f) * (cg * e.wt.z + sg * e.wt.x) / ct_wt
                                    : xsimd::sqrt(sqr(sg + e.sgmt) + sqr(B(c.b) * (cg + e.cgmt)));
        absorption(path_t, ct_wt, e.a_t, trt ? e.one_minus_a_t : nullptr);
        e.scale2 = energy_scale(e.cos_mi2, c.energy_leaving);
        e.entry = e.t1 * scale1 * g1o * e.cos_mi1 / e.cos_mo1;
        return e;
    }

    // HuangHair::trt_internal in lanes: the internal reflection on wh2 and the exit to O. trrt: where the
    // TRRT+ series counts (series); trt: where TRT does (v, before the eval's factors); wtr: the reflected
    // direction. trrt_only leaves trt clear.
    struct Internal {
        M trrt, trt;
        B series[3], v[3];
        V wtr;
    };
    HAIRBSDF_BATCH_INLINE Internal internal(const Entry& e, M active, B gamma, V wh2, bool trrt_only) const {
        const V O = vec(p.O);
        Internal out;
        const B cos_hi2 = dot(e.mwt, wh2);
        const M inner = active & e.ok & (cos_hi2 > B(0.0f));
        const B r2f = fresnel(cos_hi2, c.inv_eta);
        out.wtr = sub(mul(B(2.0f) * dot(e.wt, wh2), wh2), e.wt);  // -reflect(wt, wh2)
        const V wtr = out.wtr, mwtr = neg(wtr);
        // trrt_series(t1, r2f, a_t), its denominator 1 - x (1 - t_avg) written (1 - x) + x t_avg: at r2f = 1
        // (t_avg = 1e-5) float's 1 - (1 - 1e-5) is 0.14 % off.
        const B t_avg = xsimd::max(B(1.0f) - r2f, B(1e-5f));
        const B series_k = e.t1 * r2f * r2f * t_avg;
        for (int k = 0; k < 3; ++k)
            out.series[k] = series_k * e.a_t[k] * e.a_t[k] * e.a_t[k] / xsimd::fma(e.a_t[k], t_avg, e.one_minus_a_t[k]);
        const M exit_tir = dot(mwtr, O) < B(c.inv_eta - kTirEpsilonF);
        const M vis2 = visible(e.mwt, e.wmt, wh2) & visible(mwtr, e.wmt, wh2) & visible(e.mwt, e.wmt_, wh2) &
                       visible(mwtr, e.wmt_, wh2);
        out.trrt = inner & (exit_tir | vis2);
        out.trt = inner & ~exit_tir & vis2;
        if (trrt_only || !xsimd::any(out.trt)) {
            out.trt = M(false);
            return out;
        }
        const B phi_tr_b = xsimd::atan2(B(c.b) * wtr.x, wtr.z);
        const B gmtr = gamma - B(2.0f) * (e.phi_t_b - phi_tr_b) + B(kPiF);
        B sgmtr, cgmtr;
        V wmtr, wmtr_;
        mesonormals_at(gmtr, -c.sin_tilt, sgmtr, cgmtr, wmtr, wmtr_);
        const V wh3u = add(wtr, mul(B(c.inv_eta), O));
        const B len3 = xsimd::sqrt(dot(wh3u, wh3u));
        const B inv_len3 = B(1.0f) / len3;
        const V wh3 = mul(inv_len3, wh3u);
        const B cos_mh3 = dot(wmtr, wh3);
        const V mO = neg(O);
        out.trt = out.trt & (len3 > B(1e-7f)) & (cos_mh3 >= B(0.0f)) & visible(wtr, wmtr, wh3) &
                  visible(mO, wmtr, wh3) & visible(wtr, wmtr_, wh3) & visible(mO, wmtr_, wh3);
        const B cos_hi3 = dot(wh3, wtr), cos_ho3 = dot(wh3, mO), cos_mi3 = dot(wmtr, wtr);
        const B t3 = (B(1.0f) - fresnel(cos_hi3, c.inv_eta)) * energy_scale(cos_mi3, c.energy_leaving);
        const B ct_wtr = xsimd::sqrt(xsimd::fma(wtr.x, wtr.x, wtr.z * wtr.z));
        // circular: 2 |cos(phi_tr - gmt)|, phi_tr's sine and cosine from wtr; ellipse: the chord.
        const B path_tr = c.circular ? B(2.0f) * xsimd::abs(wtr.z * e.cgmt + wtr.x * e.sgmt) / ct_wtr
                                     : xsimd::sqrt(sqr(sgmtr - e.sgmt) + sqr(B(c.b) * (cgmtr - e.cgmt)));
        B a_tr[3];
        absorption(path_tr, ct_wtr, a_tr);
        const B cos_mo2 = dot(e.wmt, mwtr);
        const B scalar = e.entry * r2f * e.scale2 * t3 * ggx_d(cos_mh3) * g2_over_g1(e.cos_mi2, cos_mo2) *
                         g2(cos_mi3, dot(wmtr, mO)) / cos_mo2 * e.cos_mi2 * cos_hi3 * cos_ho3 * inv_len3 *
                         inv_len3 * arc_length(sgmtr);
        for (int k = 0; k < 3; ++k) out.v[k] = scalar * e.a_t[k] * a_tr[k];
        out.trt = out.trt & finite(out.v[0]) & finite(out.v[1]) & finite(out.v[2]);
        return out;
    }

    // HuangHair::tt_exit in lanes: TT's rgb into v where the returned mask is set.
    HAIRBSDF_BATCH_INLINE M tt_exit(const Entry& e, B v[3]) const {
        const V O = vec(p.O);
        M tt = e.ok & (dot(O, e.wt) >= B(c.inv_eta - kTirEpsilonF));
        const V wh2u = add(e.mwt, mul(B(c.inv_eta), O));
        const B len = xsimd::sqrt(dot(wh2u, wh2u));
        tt = tt & (len > B(1e-7f));
        const B inv_len = B(1.0f) / len;
        const V wh2 = mul(inv_len, wh2u);
        const B cos_mh2 = dot(e.wmt, wh2), cos_hi2 = dot(e.mwt, wh2), cos_ho2 = -dot(O, wh2);
        tt = tt & (cos_mh2 >= B(0.0f)) & (cos_hi2 > B(0.0f)) & (cos_ho2 > B(0.0f));
        const B cos_mo2 = -dot(O, e.wmt);
        const B t2 = (B(1.0f) - fresnel(cos_hi2, c.inv_eta)) * e.scale2;
        const B scalar = e.entry * t2 * ggx_d(cos_mh2) * g2(e.cos_mi2, cos_mo2) * cos_hi2 * cos_ho2 * inv_len *
                         inv_len * arc_length(e.sgmt);
        for (int k = 0; k < 3; ++k) v[k] = scalar * e.a_t[k];
        return tt & finite(v[0]) & finite(v[1]) & finite(v[2]);
    }

    // W residual nodes from arrays holding at least W numbers from there.
    HAIRBSDF_BATCH_INLINE void nodes(M active, const float* h_in, const float* weight_in, const float* u1a,
                                     const float* u1b, const float* u2a, const float* u2b, B acc[9]) const {
        B gamma, sg, cg, weight;
        node_gamma(h_in, weight_in, gamma, sg, cg, weight);
        const B r1 = xsimd::sqrt(B::load_unaligned(u1a)), angle1 = B(kTwoPiF) * B::load_unaligned(u1b);
        const Entry e = entry_state(active, gamma, sg, cg, r1, angle1, p.trt);
        if (!xsimd::any(e.ok)) return;

        if (p.tt) {
            B v[3];
            const M tt = tt_exit(e, v);
            const B w = weight * B(p.tt_scale);
            for (int k = 0; k < 3; ++k) acc[k] = xsimd::select(tt, xsimd::fma(w, v[k], acc[k]), acc[k]);
        }
        if (!p.trt) return;
        // trt_from_entry and trt_internal
        V s2, t2v;
        orthonormals(e.wmt, s2, t2v);
        const B r2 = xsimd::sqrt(B::load_unaligned(u2a)), angle2 = B(kTwoPiF) * B::load_unaligned(u2b);
        const V wh2 = vndf_sample(e.mwt, e.wmt, s2, t2v, r2, angle2);
        const Internal in = internal(e, e.ok, gamma, wh2, false);
        const B wtrt = weight * B(p.trrt_scale);
        {
            const B t[3] = {wtrt * in.series[0], wtrt * in.series[1], wtrt * in.series[2]};
            const M trrt = in.trrt & finite(t[0]) & finite(t[1]) & finite(t[2]);
            for (int k = 0; k < 3; ++k) acc[6 + k] = xsimd::select(trrt, acc[6 + k] + t[k], acc[6 + k]);
        }
        const B w = weight * B(p.trt_scale);
        for (int k = 0; k < 3; ++k)
            acc[3 + k] = xsimd::select(in.trt, xsimd::fma(w, in.v[k], acc[3 + k]), acc[3 + k]);
    }

    // --- the deterministic eval's TRT rule (HuangHair::trt_mis_point), W Sobol' points of one node ---

    // vndf_density (huang_internal.h): the visible-normal density of h for v around m, 0 outside its support.
    HAIRBSDF_BATCH_INLINE B vndf_density(V v, V m, B inv_norm, V h) const {
        const B hm = dot(h, m), vh = dot(v, h);
        return xsimd::select((hm > B(0.0f)) & (vh > B(0.0f)), ggx_d(hm) * vh * inv_norm, B(0.0f));
    }
    // 1 / (cos (1 + Lambda(cos))) where on, else 0: a visible-normal density's normalisation.
    HAIRBSDF_BATCH_INLINE B vndf_inv_norm(M on, B cos_vm) const {
        const B safe = xsimd::select(on, cos_vm, B(1.0f));
        return xsimd::select(on, B(1.0f) / (safe * (B(1.0f) + lambda(safe))), B(0.0f));
    }
    // shell_azimuth_scale (huang_paths.cpp).
    HAIRBSDF_BATCH_INLINE B shell_scale(B cos_beta, B sin_beta, B cs, B sn) const {
        const B sin_d = sn * cos_beta - cs * sin_beta;
        const B s = xsimd::sqrt(xsimd::fma(sin_d, sin_d, B(c.alpha2))) / xsimd::max(sn, B(1e-6f));
        return xsimd::min(xsimd::max(s, B(1e-6f)), B(50.0f));
    }
    // trrt_shell_frame.
    struct Shell {
        V a, s, t;
        B cos_beta, sin_beta;
    };
    HAIRBSDF_BATCH_INLINE Shell shell_frame(const Entry& e) const {
        Shell f;
        f.a = e.mwt;
        f.cos_beta = xsimd::min(xsimd::max(e.cos_mi2, B(-1.0f)), B(1.0f));
        const V across = sub(e.wmt, mul(f.cos_beta, f.a));
        f.sin_beta = xsimd::sqrt(dot(across, across));
        const M wide = f.sin_beta > B(1e-9f);
        V s0, t0;
        orthonormals(f.a, s0, t0);
        const V s1 = mul(B(1.0f) / xsimd::select(wide, f.sin_beta, B(1.0f)), across);
        f.s = select(wide, s1, s0);
        f.t = select(wide, cross(f.a, s1), t0);
        return f;
    }
    // trrt_shell_sample.
    HAIRBSDF_BATCH_INLINE V shell_sample(const Shell& f, B u2, B u3) const {
        const B cs = xsimd::fma(u2, B(c.shell_hi - c.shell_lo), B(c.shell_lo));
        const B sn = safe_sqrt(B(1.0f) - cs * cs);
        // Wrapped Cauchy by inversion: psi = 2 atan(x), x = tanh(scale / 2) tan(pi (u3 - 1/2)).
        const B x = xsimd::tanh(B(0.5f) * shell_scale(f.cos_beta, f.sin_beta, cs, sn)) *
                    xsimd::tan(B(kPiF) * (u3 - B(0.5f)));
        const B inv = B(1.0f) / (B(1.0f) + x * x);
        const B cos_psi = (B(1.0f) - x * x) * inv, sin_psi = B(2.0f) * x * inv;
        return add(add(mul(sn * cos_psi, f.s), mul(sn * sin_psi, f.t)), mul(cs, f.a));
    }
    // trrt_shell_density (solid angle), 0 outside the band.
    HAIRBSDF_BATCH_INLINE B shell_density(const Shell& f, V h) const {
        const B cs = dot(f.a, h);
        const M in = (cs > B(c.shell_lo)) & (cs < B(c.shell_hi));
        const B sn = safe_sqrt(B(1.0f) - cs * cs);
        const B cos_psi = xsimd::min(xsimd::max(dot(h, f.s) / sn, B(-1.0f)), B(1.0f));
        const B rho = xsimd::exp(-shell_scale(f.cos_beta, f.sin_beta, cs, sn));
        const B azimuth = (B(1.0f) - rho * rho) / (B(kTwoPiF) * (B(1.0f) + rho * rho - B(2.0f) * rho * cos_psi));
        return xsimd::select(in, azimuth * B(1.0f / (c.shell_hi - c.shell_lo)), B(0.0f));
    }

    // TRT and TRRT+ of W points at one node (trt_mis_point step by step): trt / trrt get each lane's values
    // times its weight, 0 where the double path adds nothing.
    HAIRBSDF_BATCH_INLINE void trt_points(M active, B gamma, B sg, B cg, B weight, B u0, B u1, B u2, B u3,
                                          bool shell_on, B trt[3], B trrt[3]) const {
        for (int k = 0; k < 3; ++k) trt[k] = trrt[k] = B(0.0f);
        const V O = vec(p.O);
        const Entry e = entry_state(active, gamma, sg, cg, u0, B(kTwoPiF) * u1, true);
        if (!xsimd::any(e.ok)) return;
        const B r2 = xsimd::sqrt(u2), angle2 = B(kTwoPiF) * u3;
        // Component a: the internal visible normals of -wt around the internal mesonormal.
        const B cos_vm = e.cos_mi2;
        const M see_m = cos_vm > B(0.0f);
        V sa, ta;
        orthonormals(e.wmt, sa, ta);
        const B inv_norm_a = vndf_inv_norm(see_m, cos_vm);
        auto qa = [&](V wtr) {  // density of wtr = -reflect(wt, h), h ~ visible normals of -wt
            V h = normalize(add(e.wt, wtr));
            h = select(dot(e.mwt, h) < B(0.0f), neg(h), h);
            const B cs = dot(e.mwt, h);
            return xsimd::select(cs > B(0.0f), vndf_density(e.mwt, e.wmt, inv_norm_a, h) / (B(4.0f) * cs), B(0.0f));
        };
        // Component b: visible normals of O around the mesonormal where the specular internal reflection leaves.
        const V wtr0 = sub(mul(B(2.0f) * dot(e.wt, e.wmt), e.wmt), e.wt);  // -reflect(wt, wmt)
        const B phi_tr0_b = xsimd::atan2(B(c.b) * wtr0.x, wtr0.z);
        B sg0, cg0;
        V out_m, out_m_;
        mesonormals_at(gamma - B(2.0f) * (e.phi_t_b - phi_tr0_b) + B(kPiF), -c.sin_tilt, sg0, cg0, out_m, out_m_);
        const V out_normal = neg(out_m);
        V sb, tb;
        orthonormals(out_normal, sb, tb);
        const B ob = dot(O, out_normal);
        const M use_b = e.ok & (ob > B(1e-6f));
        const B inv_norm_b = vndf_inv_norm(use_b, ob);
        const B eta(c.eta);
        auto qb = [&](V wtr) {  // density of wtr = refraction of O through h ~ visible normals of O
            const V hu = neg(add(O, mul(eta, wtr)));
            const B len = xsimd::sqrt(dot(hu, hu));
            const M lok = use_b & (len > B(0.0f));
            const V h = mul(B(1.0f) / xsimd::select(lok, len, B(1.0f)), hu);
            const B oh = dot(O, h), th = dot(wtr, h);
            const B d = xsimd::fma(eta, th, oh);
            const B q = vndf_density(O, out_normal, inv_norm_b, h) * eta * eta * xsimd::abs(th) / (d * d);
            return xsimd::select(lok & (oh > B(0.0f)) & (th < B(0.0f)), q, B(0.0f));
        };
        // TRRT+'s shell (strategy C) where -wt sees the internal mesonormal and the band is not empty.
        const M shell = e.ok & see_m & M(shell_on && c.shell_hi > c.shell_lo);
        const bool any_shell = xsimd::any(shell);
        Shell frame;
        if (any_shell) frame = shell_frame(e);
        auto trrt_weight = [&](V h) {  // pa / (pa + pc), 1 where pc is 0
            const B pcs = xsimd::select(shell, shell_density(frame, h), B(0.0f));
            const B pa = vndf_density(e.mwt, e.wmt, inv_norm_a, h);
            return xsimd::select(pcs > B(0.0f), pa / (pa + pcs), B(1.0f));
        };
        // Strategy A: the internal visible normal.
        {
            const V wh2 = vndf_sample(e.mwt, e.wmt, sa, ta, r2, angle2);
            const Internal in = internal(e, e.ok, gamma, wh2, false);
            const B wt_a = any_shell ? weight * trrt_weight(wh2) : weight;
            for (int k = 0; k < 3; ++k) trrt[k] = xsimd::select(in.trrt, wt_a * in.series[k], B(0.0f));
            if (xsimd::any(in.trt)) {
                const B a = qa(in.wtr), b = qb(in.wtr);
                const M on = in.trt & (a > B(0.0f));
                const B w = weight * a / (a + b);
                for (int k = 0; k < 3; ++k) trt[k] = xsimd::select(on, w * in.v[k], B(0.0f));
            }
        }
        // Strategy C (TRRT+ only): the shell proposal.
        if (any_shell) {
            const V h = shell_sample(frame, u2, u3);
            const Internal in = internal(e, shell, gamma, h, true);
            const B w = weight * trrt_weight(h);
            for (int k = 0; k < 3; ++k) trrt[k] = xsimd::select(in.trrt, xsimd::fma(w, in.series[k], trrt[k]), trrt[k]);
        }
        // Strategy B: refraction of O into the fibre.
        if (xsimd::any(use_b)) {
            const V h = vndf_sample(O, out_normal, sb, tb, r2, angle2);
            const B cos_oh = dot(O, h);
            B cos_t;
            const B f = fresnel(cos_oh, c.eta, &cos_t);
            const M refr = use_b & (f < B(1.0f)) & (cos_oh > B(0.0f));
            const V wtr = sub(mul(xsimd::fma(B(c.inv_eta), cos_oh, cos_t), h), mul(B(c.inv_eta), O));
            V wh2 = normalize(add(e.wt, wtr));
            wh2 = select(dot(e.mwt, wh2) < B(0.0f), neg(wh2), wh2);
            const B a = qa(wtr), b = qb(wtr);
            const M on = refr & (a > B(0.0f)) & (b > B(0.0f));
            if (xsimd::any(on)) {
                const Internal in = internal(e, on, gamma, wh2, false);
                const B w = weight * a / (a + b);
                for (int k = 0; k < 3; ++k) trt[k] = xsimd::select(in.trt, xsimd::fma(w, in.v[k], trt[k]), trt[k]);
            }
        }
    }

    // The TT cubature's points of one node (HuangTtPoints), W at a time: tt_exit's rgb per point into out.
    void run_tt(const HuangTtPoints& n, double* out) const {
        const B gamma(n.gamma), sg(n.sin_gamma), cg(n.cos_gamma);
        alignas(64) float buf[2][W], on[W], v_out[3][W];
        for (size_t k = 0; k < n.count; k += W) {
            for (size_t j = 0; j < W; ++j) {
                const bool in = k + j < n.count;
                buf[0][j] = in ? n.u1a[k + j] : 0.0f;
                buf[1][j] = in ? n.u1b[k + j] : 0.0f;
                on[j] = in ? 1.0f : 0.0f;
            }
            const M active = B::load_aligned(on) != B(0.0f);
            const Entry e = entry_state(active, gamma, sg, cg, B::load_aligned(buf[0]), B(kTwoPiF) * B::load_aligned(buf[1]),
                                        false);
            B v[3] = {B(0.0f), B(0.0f), B(0.0f)};
            const M tt = xsimd::any(e.ok) ? tt_exit(e, v) : M(false);
            for (int j = 0; j < 3; ++j) xsimd::select(tt, v[j], B(0.0f)).store_aligned(v_out[j]);
            for (size_t j = 0; j < W && k + j < n.count; ++j)
                for (int ch = 0; ch < 3; ++ch) out[3 * (k + j) + size_t(ch)] = double(v_out[ch][j]);
        }
    }

    // The Sobol' points [0, count) of one node and copy (HuangTrtPoints), in W-wide groups; adds each lane's TRT
    // and TRRT+ into double accumulators and their sums into out[0..5].
    void run_trt(const HuangTrtPoints& n, double* out) const {
        const B gamma(n.gamma), sg(n.sin_gamma), cg(n.cos_gamma), node_weight(n.weight);
        double acc[6][W] = {};
        alignas(64) float lanes[6][W];
        alignas(64) uint32_t tail[4][W];
        for (size_t k = 0; k < n.count; k += W) {
            const bool full = k + W <= n.count;
            B u[4];
            for (int d = 0; d < 4; ++d) {
                const uint32_t* src = n.sobol[d] + k;
                if (!full) {
                    for (size_t j = 0; j < W; ++j) tail[d][j] = k + j < n.count ? src[j] : 0u;
                    src = tail[d];
                }
                // u = (x ^ shift) / 2^32 truncated to 24 bits: exact in float and below 1.
                const I x = (I::load_unaligned(reinterpret_cast<const int32_t*>(src)) ^ I(int32_t(n.shift[d])));
                u[d] = xsimd::to_float((x >> 8) & I(0x00FFFFFF)) * B(0x1p-24f);
            }
            M active = B(0.0f) == B(0.0f);
            if (!full) {
                alignas(64) float on[W];
                for (size_t j = 0; j < W; ++j) on[j] = k + j < n.count ? 1.0f : 0.0f;
                active = B::load_aligned(on) != B(0.0f);
            }
            B trt[3], trrt[3];
            trt_points(active, gamma, sg, cg, B(2.0f) * u[0] * node_weight, u[0], u[1], u[2], u[3], n.trrt_shell,
                       trt, trrt);
            for (int j = 0; j < 3; ++j) {
                trt[j].store_aligned(lanes[j]);
                trrt[j].store_aligned(lanes[3 + j]);
            }
            // Each lane's point adds its TRT and its TRRT+ where they are finite (trt_by_tolerance's check).
            for (size_t l = 0; l < W; ++l) {
                const float t[2][3] = {{lanes[0][l], lanes[1][l], lanes[2][l]}, {lanes[3][l], lanes[4][l], lanes[5][l]}};
                for (int g = 0; g < 2; ++g)
                    if (std::isfinite(t[g][0]) && std::isfinite(t[g][1]) && std::isfinite(t[g][2]))
                        for (int j = 0; j < 3; ++j) acc[3 * g + j][l] += double(t[g][j]);
            }
        }
        for (int j = 0; j < 6; ++j)
            for (size_t l = 0; l < W; ++l) out[j] += acc[j][l];
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
}  // namespace huang_lanes_detail
}  // namespace hairbsdf
