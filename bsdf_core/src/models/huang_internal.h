// Helpers shared by the Huang model's source files (huang_model, huang_paths, huang_eval,
// huang_sample, huang_albedo): constants of Cycles' rules and the visible-normal pieces. Private to bsdf_core.
#pragma once

#include "hairbsdf/models/huang.h"

namespace hairbsdf {
namespace {

constexpr double kHClamp = 0.999;
constexpr double kRStep = 0.7;
constexpr double kResidualStep = 0.8;
constexpr double kTirEpsilon = 1e-5;
constexpr double kTrrtShellFresnel = 0.25;  // TRRT+'s shell: internal Fresnel factor from this to 1
constexpr double kUniformProbability = 0.02;  // defensive uniform component of the mixture

inline double sin_theta(Vec3 w) { return w.y; }
inline double cos_theta(Vec3 w) { return safe_sqrt(w.x * w.x + w.z * w.z); }
inline double dir_phi(Vec3 w) { return std::atan2(w.x, w.z); }
inline double luminance3(const double* v) { return luminance(RGB{v[0], v[1], v[2]}); }
inline bool is_zero(RGB c) { return c.r == 0.0 && c.g == 0.0 && c.b == 0.0; }

// A direction uniform on the sphere from (a, b) in [0,1]^2: y = 1 - 2a, azimuth 2 pi b. Its density
// (solid angle) times `probability`.
inline Vec3 uniform_sphere_direction(double a, double b) {
    const double y = 1.0 - 2.0 * a, ct = cos_from_sin(y), phi = kTwoPi * b;
    return {std::sin(phi) * ct, y, std::cos(phi) * ct};
}
inline double uniform_sphere_density(double probability) { return probability / (4.0 * kPi); }

inline bool visible(Vec3 v, Vec3 m, Vec3 h) { return dot(v, h) > 0.0 && dot(v, m) > 0.0; }
inline bool visible(Vec3 a, Vec3 b, Vec3 m, Vec3 h) { return visible(a, m, h) && visible(b, m, h); }

// Visible-normal sample for direction v around the unit normal m from u in [0,1]^2, with the
// disk radius linear in u[0] (the caller multiplies by the weight 2 u[0]); frame (s, t, m).
inline Vec3 vndf_sample(Vec3 v, Vec3 m, Vec3 s, Vec3 t, double alpha, double r, double angle) {
    const Vec3 vl{dot(v, s), dot(v, t), dot(v, m)};
    const Vec3 hl = ggx::vndf_from_disk(vl, alpha, r * std::cos(angle), r * std::sin(angle));
    return hl.x * s + hl.y * t + hl.z * m;
}

// Density of the visible normal h for v around m (solid angle), 0 outside the support.
inline double vndf_density(const HuangHair::Component& c, Vec3 h, double alpha2) {
    const double hm = dot(h, c.m);
    const double vh = dot(c.v, h);
    if (!(hm > 0.0) || !(vh > 0.0)) return 0.0;
    return ggx::D(alpha2, hm) * vh * c.inv_norm;
}


}  // namespace
}  // namespace hairbsdf
