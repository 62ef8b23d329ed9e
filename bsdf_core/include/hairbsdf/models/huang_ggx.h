// GGX microfacet pieces shared by the Huang hair model and its table generator: the
// distribution, Smith masking, Fresnel with the refracted cosine, refraction, the
// visible-normal sampler, and the directional albedo of the GGX glass BSDF ("E_glass",
// the energy-compensation table of Huang hair, docs/huang.md §3).
#pragma once

#include "hairbsdf/math.h"

namespace hairbsdf::ggx {

// GGX normal distribution for alpha^2 and cos(n, h); even in cos_nh, as Cycles' bsdf_D.
inline double D(double alpha2, double cos_nh) {
    const double c2 = std::min(cos_nh * cos_nh, 1.0);
    return alpha2 / (kPi * sqr(1.0 - c2 + alpha2 * c2));
}
// Smith Lambda for GGX; even in cos_n.
inline double lambda(double alpha2, double cos_n) {
    const double c2 = cos_n * cos_n;
    const double t2 = c2 > 0 ? std::max(1.0 / c2 - 1.0, 0.0) : INFINITY;
    return 0.5 * (std::sqrt(1.0 + alpha2 * t2) - 1.0);
}
// Height-correlated G2 and G2 / G1(i).
inline double G2(double alpha2, double cos_i, double cos_o) {
    return 1.0 / (1.0 + lambda(alpha2, cos_i) + lambda(alpha2, cos_o));
}
inline double G2_over_G1(double alpha2, double cos_i, double cos_o) {
    const double li = lambda(alpha2, cos_i);
    return (1.0 + li) / (1.0 + li + lambda(alpha2, cos_o));
}

// Unpolarised dielectric Fresnel for the incident cosine and relative IOR eta (outside / inside
// the surface the normal points out of). Sets cos_t to the refracted cosine relative to the
// normal (negative) unless there is total internal reflection, where it returns 1.
inline double fresnel(double cos_i, double eta, double* cos_t = nullptr) {
    const double g = eta * eta - (1.0 - cos_i * cos_i);
    if (g <= 0.0) {
        if (cos_t) *cos_t = 0.0;
        return 1.0;
    }
    const double c = std::fabs(cos_i);
    const double ct = -std::sqrt(g) / eta;
    if (cos_t) *cos_t = ct;
    const double rs = (c + eta * ct) / (c - eta * ct);
    const double rp = (ct + eta * c) / (eta * c - ct);
    return 0.5 * (rs * rs + rp * rp);
}

// Refraction of an incident direction (pointing away from the surface) through the unit normal
// n, given the (negative) refracted cosine and 1/eta.
inline Vec3 refract(Vec3 incident, Vec3 n, double cos_t, double inv_eta) {
    return (inv_eta * dot(n, incident) + cos_t) * n - inv_eta * incident;
}
// GLSL-style reflect: incident - 2 n (incident . n).
inline Vec3 reflect(Vec3 incident, Vec3 n) { return incident - (2.0 * dot(incident, n)) * n; }

// Heitz 2018 visible-normal sample for the direction v (local frame, normal +z) from a point of
// the unit disk (d1, d2) (uniform disk point = uniform visible normal).
inline Vec3 vndf_from_disk(Vec3 v, double alpha, double d1, double d2) {
    const Vec3 vh = normalize(Vec3{alpha * v.x, alpha * v.y, v.z});
    const double lensq = vh.x * vh.x + vh.y * vh.y;
    Vec3 t1 = lensq > 1e-14 ? (1.0 / std::sqrt(lensq)) * Vec3{-vh.y, vh.x, 0.0} : Vec3{1.0, 0.0, 0.0};
    const Vec3 t2 = cross(vh, t1);
    const double s = 0.5 * (1.0 + vh.z);
    d2 = (1.0 - s) * safe_sqrt(1.0 - d1 * d1) + s * d2;
    const double d3 = safe_sqrt(1.0 - d1 * d1 - d2 * d2);
    const Vec3 nh = d1 * t1 + d2 * t2 + d3 * vh;
    return normalize(Vec3{alpha * nh.x, alpha * nh.y, std::max(nh.z, 0.0)});
}

// Directional albedo of Cycles' GGX glass BSDF as its sampler estimates it (its precompute
// program averages eval / pdf over visible normals): the mean over visible normals of
// F G2/G1 (reflection, when the reflected ray stays above) + (1 - F) G2/G1 (refraction), with
// Cycles' singular cases (alpha^2 <= 2e-10: mirror; |eta - 1| < 1e-4: refraction treated as
// specular). `reject_upward_refraction`: a refraction that leaves on the incident side counts 0
// (Cycles 5.x's tables, made with its current sampler) or counts like any other (the tables
// Cycles 4.x ships). Adaptive cubature over the microfacet normal to the relative `tolerance`.
// Clamped to [0, 1] like the stored tables.
double ggx_glass_albedo(double alpha, double mu, double eta, bool reject_upward_refraction, double tolerance = 1e-8);

}  // namespace hairbsdf::ggx
