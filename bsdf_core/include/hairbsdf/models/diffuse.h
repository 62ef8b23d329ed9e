// Lambertian diffuse reflection, Cycles' Diffuse BSDF (the `diffuse` closure of
// docs/scene_desc.md): eval = cos(N, wi) / pi on N's side, zero below; the colour is the
// closure's weight. Sampled with a cosine-distributed direction about N (density = eval, so the
// sample weight is 1); as Cycles' sampler it also rejects a direction below the geometric
// normal Ng. N and Ng come from the shading context (shading_normal, geometric_normal); a zero
// N reads as wo, a zero Ng as N. Lobe slot R, label DIFFUSE REFLECT; not blurred, no
// transmission, deterministic.
#pragma once

#include "hairbsdf/closure.h"

namespace hairbsdf {

class DiffuseBsdf {
public:
    static uint8_t scatter_label(int) { return uint8_t(LabelDiffuse | LabelReflect); }
    static bool transmits() { return false; }
    static constexpr bool kHairLobes = false;  // not a share of the hair lobe passes

    std::array<double, 2> angular_scales() const { return {0.5, 0.5}; }

    struct ShadingPoint {
        Vec3 n{0, 0, 1};   // shading normal
        Vec3 ng{0, 0, 1};  // geometric normal
    };
    ShadingPoint prepare(const ShadingContext& ctx) const {
        ShadingPoint sp;
        sp.n = is_zero(ctx.shading_normal) ? ctx.wo : ctx.shading_normal;
        sp.ng = is_zero(ctx.geometric_normal) ? sp.n : ctx.geometric_normal;
        return sp;
    }

    // Cycles' diffuse eval tests only N.
    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const {
        BsdfEval out;
        const double c = dot(sp.n, wi);
        if (c > 0) {
            out.pdf = c / kPi;
            out.lobes[LobeR] = RGB(out.pdf);
        }
        return out;
    }
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const { return eval(prepare(ctx), wi); }
    double pdf(const ShadingPoint& sp, Vec3 wi) const { return eval(sp, wi).pdf; }

    // u0, u1: the direction; u2 unused.
    BsdfSample sample(const ShadingPoint& sp, const std::array<double, 3>& u) const {
        const Vec3 wi = sample_cos_hemisphere(sp.n, u[0], u[1]);
        if (!(dot(sp.n, wi) > 0) || !(dot(sp.ng, wi) > 0)) return {};
        return sample_from_eval(wi, eval(sp, wi), LobeR);
    }
    BsdfSample sample(const ShadingContext& ctx, const std::array<double, 3>& u) const {
        return sample(prepare(ctx), u);
    }

private:
    static bool is_zero(Vec3 v) { return v.x == 0 && v.y == 0 && v.z == 0; }
};

}  // namespace hairbsdf
