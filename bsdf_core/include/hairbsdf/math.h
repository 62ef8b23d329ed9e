// Math utilities shared by every model: vectors, RGB, the fibre frame and the
// special functions of the hair models. Frames and signs: docs/conventions.md.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace hairbsdf {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;
constexpr double kInvTwoPi = 1.0 / kTwoPi;
constexpr double kSqrtPiOver8 = 0.6266570686577501;  // sqrt(pi/8), cycles-hair-notes §2.4

struct Vec3 {
    double x = 0, y = 0, z = 0;
};
inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline Vec3 operator*(Vec3 a, double s) { return s * a; }
inline double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(Vec3 a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalize(Vec3 a) {
    const double l = length(a);
    return l > 0 ? (1.0 / l) * a : Vec3{};
}

// Linear RGB in the scene-linear working space.
struct RGB {
    double r = 0, g = 0, b = 0;
    constexpr RGB() = default;
    constexpr RGB(double r_, double g_, double b_) : r(r_), g(g_), b(b_) {}
    explicit constexpr RGB(double v) : r(v), g(v), b(v) {}
    double operator[](int i) const { return i == 0 ? r : (i == 1 ? g : b); }
};
inline RGB operator+(RGB a, RGB b) { return {a.r + b.r, a.g + b.g, a.b + b.b}; }
inline RGB operator-(RGB a, RGB b) { return {a.r - b.r, a.g - b.g, a.b - b.b}; }
inline RGB operator*(RGB a, RGB b) { return {a.r * b.r, a.g * b.g, a.b * b.b}; }
inline RGB operator*(double s, RGB a) { return {s * a.r, s * a.g, s * a.b}; }
inline RGB operator*(RGB a, double s) { return s * a; }
inline RGB& operator+=(RGB& a, RGB b) { return a = a + b; }
inline RGB exp(RGB a) { return {std::exp(a.r), std::exp(a.g), std::exp(a.b)}; }
inline double average(RGB a) { return (a.r + a.g + a.b) / 3.0; }
// Rec.709 luminance, Cycles' rgb_to_y for the default working space.
inline double luminance(RGB a) { return 0.2126 * a.r + 0.7152 * a.g + 0.0722 * a.b; }
inline bool isfinite(RGB a) { return std::isfinite(a.r) && std::isfinite(a.g) && std::isfinite(a.b); }
inline bool isfinite(Vec3 a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }

inline double sqr(double x) { return x * x; }
inline double clamp(double x, double lo, double hi) { return std::min(std::max(x, lo), hi); }
inline double safe_sqrt(double x) { return std::sqrt(std::max(x, 0.0)); }
inline double safe_asin(double x) { return std::asin(clamp(x, -1.0, 1.0)); }
inline double cos_from_sin(double s) { return safe_sqrt(1.0 - s * s); }

// Wraps an angle into [-pi, pi].
inline double wrap_angle(double a) {
    if (a >= -kPi && a <= kPi) return a;
    return a - kTwoPi * std::floor((a + kPi) / kTwoPi);
}

// Exact unpolarised Fresnel reflectance of a dielectric interface, for the cosine of
// the incident angle `cos_i` and relative IOR `eta`. Returns 1 under total internal reflection.
inline double fresnel_dielectric(double cos_i, double eta) {
    const double c = std::fabs(cos_i);
    const double g2 = eta * eta - 1.0 + c * c;
    if (!(g2 > 0.0)) return 1.0;  // total internal reflection
    const double g = std::sqrt(g2);
    const double a = (g - c) / (g + c);
    const double b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return 0.5 * a * a * (1.0 + b * b);
}

// Modified Bessel function I0 and its logarithm, to double precision. Below
// kBesselSeriesLimit the power series is used, above it the asymptotic expansion.
constexpr double kBesselSeriesLimit = 16.0;
double bessel_i0_series(double x);
double log_bessel_i0_asymptotic(double x);
inline double bessel_i0(double x) {
    x = std::fabs(x);
    return x < kBesselSeriesLimit ? bessel_i0_series(x) : std::exp(log_bessel_i0_asymptotic(x));
}
inline double log_bessel_i0(double x) {
    x = std::fabs(x);
    return x < kBesselSeriesLimit ? std::log(bessel_i0_series(x)) : log_bessel_i0_asymptotic(x);
}

// Cycles' approximations (cycles-hair-notes §4.3): the first 10 terms of the power series
// (k = 0..9; Cycles stops early only where a term no longer changes a float sum) and the
// asymptotic log branch above x = 12.
inline double cycles_bessel_i0(double x) {
    const double q = 0.25 * x * x;
    // sum_k q^k / (k!)^2 in Horner form.
    double sum = 1.0 / 131681894400.0;  // 1 / (9!)^2
    sum = sum * q + 1.0 / 1625702400.0;
    sum = sum * q + 1.0 / 25401600.0;
    sum = sum * q + 1.0 / 518400.0;
    sum = sum * q + 1.0 / 14400.0;
    sum = sum * q + 1.0 / 576.0;
    sum = sum * q + 1.0 / 36.0;
    sum = sum * q + 1.0 / 4.0;
    sum = sum * q + 1.0;
    return sum * q + 1.0;
}
inline double cycles_log_bessel_i0(double x) {
    if (x > 12.0) return x + 0.5 * (1.0 / (8.0 * x) - std::log(kTwoPi) - std::log(x));
    return std::log(cycles_bessel_i0(x));
}

// Logistic distribution with scale s, trimmed to [-pi, pi] (Chiang 2016 eq. 11).
inline double logistic(double x, double s) {
    const double e = std::exp(-std::fabs(x) / s);
    return e / (s * sqr(1.0 + e));
}
inline double logistic_cdf(double x, double s) {
    const double arg = -x / s;
    return arg > 88.0 ? 0.0 : 1.0 / (1.0 + std::exp(arg));
}
// Inverse CDF of the trimmed logistic; u in [0, 1].
inline double sample_trimmed_logistic(double u, double s) {
    const double cdf_minus_pi = logistic_cdf(-kPi, s);
    const double x = -s * std::log(1.0 / (u * (1.0 - 2.0 * cdf_minus_pi) + cdf_minus_pi) - 1.0);
    return clamp(x, -kPi, kPi);
}

// Bob Jenkins' lookup3 hash of two integers mapped to [0, 1]: Blender's per-curve
// "Hair Info > Random" is hash(curve_index, 0) / 0xFFFFFFFF (notes §2.2).
uint32_t lookup3_hash_uint2(uint32_t kx, uint32_t ky);
inline double cycles_curve_random(uint32_t curve_index) {
    // Cycles computes this in float32; round the same way so values match bit for bit.
    return double(float(lookup3_hash_uint2(curve_index, 0)) / float(0xFFFFFFFFu));
}

}  // namespace hairbsdf
