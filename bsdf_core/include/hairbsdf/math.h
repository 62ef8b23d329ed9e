// Math utilities shared by every model: vectors, RGB, the fibre frame and the
// special functions of the hair models. Frames and signs: docs/conventions.md.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "hairbsdf/math_quadrature.h"

// Inlined at every call site, whatever the compiler's own estimate: for the small per-call helpers of
// the scalar models, which GCC otherwise keeps out of line once a translation unit has a second caller
// (ClosureSum's visitor beside a direct call), paying a call and its spills each time.
#define HAIRBSDF_ALWAYS_INLINE inline __attribute__((always_inline))

namespace hairbsdf {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;
constexpr double kInvTwoPi = 1.0 / kTwoPi;
constexpr double kSqrtPiOver8 = 0.6266570686577501;  // sqrt(pi/8), docs/cycles.md §2.4

struct SinCosPair {
    double sin, cos;
};

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
// An orthonormal pair completing the unit vector n, as Cycles builds it: a = normalize((1,1,1) x n),
// or normalize((-1,1,1) x n) when n.x == n.y == n.z; b = n x a.
inline void make_orthonormals(Vec3 n, Vec3& a, Vec3& b) {
    if (n.x != n.y || n.x != n.z) {
        a = Vec3{n.z - n.y, n.x - n.z, n.y - n.x};
    } else {
        a = Vec3{n.z - n.y, n.x + n.z, -n.y - n.x};
    }
    a = normalize(a);
    b = cross(n, a);
}

// Shirley-Chiu concentric map of (u0, u1) in [0, 1)^2 to the unit disk.
inline void sample_concentric_disk(double u0, double u1, double& x, double& y) {
    const double a = 2.0 * u0 - 1.0, b = 2.0 * u1 - 1.0;
    if (a == 0 && b == 0) {
        x = y = 0;
        return;
    }
    double r, phi;
    if (a * a > b * b) {
        r = a;
        phi = (kPi / 4) * (b / a);
    } else {
        r = b;
        phi = kPi / 2 - (kPi / 4) * (a / b);
    }
    x = r * std::cos(phi);
    y = r * std::sin(phi);
}
// A cosine-distributed direction about the unit vector n (density cos / pi).
inline Vec3 sample_cos_hemisphere(Vec3 n, double u0, double u1) {
    double x, y;
    sample_concentric_disk(u0, u1, x, y);
    const double z = std::sqrt(std::max(0.0, 1.0 - x * x - y * y));
    Vec3 a, b;
    make_orthonormals(n, a, b);
    return normalize(x * a + y * b + z * n);
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
// Luminance weights of linear Rec.709 (ITU-R BT.709, four digits): luminance() below, the Huang and
// SIMD Chiang kernels, and Python's metrics as _core.LUMINANCE_WEIGHTS. Blender's colour -> float
// conversion weighs by Cycles' rgb_to_y instead (more digits; hairbsdf/blender/_common.py).
inline constexpr double kLuminanceWeights[3] = {0.2126, 0.7152, 0.0722};
inline double luminance(RGB a) {
    return kLuminanceWeights[0] * a.r + kLuminanceWeights[1] * a.g + kLuminanceWeights[2] * a.b;
}
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
    // One turn off (the common case) without floor, as the general form below computes it.
    if (a > kPi && a < 3.0 * kPi) return a - kTwoPi;
    if (a < -kPi && a >= -3.0 * kPi) return a + kTwoPi;
    return a - kTwoPi * std::floor((a + kPi) / kTwoPi);
}

// Cycles' kernel computes its transcendentals in float. The scalar path of Chiang's
// Accuracy::Cycles computes its exp, asin, atan2 and the sampler's log, sin and cos to float accuracy or
// better too, through the *_in helpers below (inlined, good to 1e-8 relative or better; sin and cos to 2e-14
// so that sampled directions stay unit vectors), far cheaper than glibc's double functions; the rest of its
// arithmetic stays double. The double reference of
// the same formulas stays available process-wide (set_cycles_float_maths(false), Python's
// hairbsdf.set_scalar_maths("double")): the tests of the float32 SIMD kernels compare against it.
// Accuracy::Exact is always double.
inline std::atomic<bool> g_cycles_float_maths{true};
inline bool cycles_float_maths() { return g_cycles_float_maths.load(std::memory_order_relaxed); }
inline void set_cycles_float_maths(bool on) { g_cycles_float_maths.store(on, std::memory_order_relaxed); }
// 2^(j/32), j = 0..31: the table of exp_float_accuracy.
alignas(64) inline constexpr double kExp2ThirtySeconds[32] = {
    1.0, 1.0218971486541166, 1.0442737824274138, 1.0671404006768237,
    1.0905077326652577, 1.1143867425958924, 1.1387886347566916, 1.1637248587775775,
    1.189207115002721, 1.215247359980469, 1.241857812073484, 1.2690509571917332,
    1.2968395546510096, 1.3252366431597413, 1.3542555469368927, 1.383909881963832,
    1.4142135623730951, 1.4451808069770467, 1.4768261459394993, 1.5091644275934228,
    1.5422108254079407, 1.5759808451078865, 1.6104903319492543, 1.645755478153965,
    1.681792830507429, 1.718619298122478, 1.7562521603732995, 1.7947090750031072,
    1.8340080864093424, 1.8741676341103, 1.9152065613971474, 1.9571441241754002,
};
// exp to about 1e-10 relative (better than float), inlined: exp(x) = 2^(k/32) exp(r) with k the integer
// nearest 32 x / ln 2 and |r| <= ln(2) / 64; 2^(k/32) = 2^floor(k/32) times a table entry, exp(r) from
// its Taylor series to r^3 (error <= r^4 / 4! < 6e-10). 0 below -708, +inf above 709; NaN stays NaN.
inline double exp_float_accuracy(double x) {
    if (!(x > -708.0 && x < 709.0)) return x != x ? x : (x > 0.0 ? HUGE_VAL : 0.0);
    constexpr double kRound = 6755399441055744.0;  // 1.5 * 2^52: adding it rounds to an integer
    const double k = (x * 46.16624130844683 + kRound) - kRound;  // 32 x / ln 2, rounded
    const double r = (x - k * 0.02166084938653512) - k * 5.9631716539705866e-12;  // ln 2 / 32 = hi + lo
    const int64_t ki = int64_t(k);
    // The table entry's bits plus floor(k / 32) in the exponent field.
    uint64_t bits;
    std::memcpy(&bits, &kExp2ThirtySeconds[ki & 31], sizeof bits);
    bits += uint64_t(ki >> 5) << 52;
    double scale;
    std::memcpy(&scale, &bits, sizeof scale);
    return scale + scale * (r * (1.0 + r * (0.5 + r * (1.0 / 6.0))));
}
// Two doubles in one SSE2 register (GCC/Clang vector extension): the scalar paths' lobe pairs.
typedef double Double2 __attribute__((vector_size(16)));
typedef uint64_t UInt2 __attribute__((vector_size(16)));
typedef int64_t Int2 __attribute__((vector_size(16)));
// Whether every lane of a comparison's mask is set (one movmskpd where SSE2 is there).
inline bool all_lanes(Int2 mask) {
#if defined(__SSE2__)
    return __builtin_ia32_movmskpd(Double2(mask)) == 3;
#else
    return mask[0] && mask[1];
#endif
}
// sqrt of both lanes (one sqrtpd where SSE2 is there; correctly rounded, as std::sqrt).
inline Double2 sqrt2(Double2 x) {
#if defined(__SSE2__)
    return __builtin_ia32_sqrtpd(x);
#else
    return Double2{std::sqrt(x[0]), std::sqrt(x[1])};
#endif
}
// exp_float_accuracy on both lanes at once; lanes outside (-708, 709) or NaN take the scalar form.
HAIRBSDF_ALWAYS_INLINE Double2 exp_float_accuracy(Double2 x) {
    if (!all_lanes((x > -708.0) & (x < 709.0))) return Double2{exp_float_accuracy(x[0]), exp_float_accuracy(x[1])};
    constexpr double kRound = 6755399441055744.0;
    const Double2 shifted = x * 46.16624130844683 + kRound;  // its low bits hold k
    const Double2 k = shifted - kRound;
    const Double2 r = (x - k * 0.02166084938653512) - k * 5.9631716539705866e-12;
    UInt2 kbits;
    std::memcpy(&kbits, &shifted, sizeof kbits);
    Double2 scale = {kExp2ThirtySeconds[kbits[0] & 31], kExp2ThirtySeconds[kbits[1] & 31]};
    UInt2 bits;
    std::memcpy(&bits, &scale, sizeof bits);
    bits += (kbits >> 5) << 52;  // floor(k / 32) into the exponent field, modulo 2^12 as the carry leaves
    std::memcpy(&scale, &bits, sizeof scale);
    return scale + scale * (r * (1.0 + r * (0.5 + r * (1.0 / 6.0))));
}
// asin on [-1, 1] to about 1e-9 relative, inlined: odd polynomial on |x| <= 1/2 (least-squares fit
// of asin(x) / x in x^2, our own), beyond it asin(x) = pi/2 - 2 asin(sqrt((1 - x) / 2)).
inline double asin_float_accuracy(double x) {
    const double ax = std::fabs(x);
    const bool outer = ax > 0.5;
    const double t = outer ? std::sqrt(0.5 * (1.0 - ax)) : ax;
    const double z = t * t;
    double p = 0.033805387066399885;
    p = p * z + 0.01707810772821376;
    p = p * z + 0.03111609434873313;
    p = p * z + 0.044598039020755036;
    p = p * z + 0.07500098732409591;
    p = p * z + 0.1666666631714249;
    double a = t + t * z * p;
    if (outer) a = 0.5 * kPi - 2.0 * a;
    return std::copysign(a, x);
}
// atan2 to about 3e-12 relative (sample's directions must give back their own pdf in eval), inlined: the ratio of the smaller to the larger |component| in
// [0, 1], above tan(pi/8) mapped by (t - 1) / (t + 1) to [-tan(pi/8), 0] plus pi/4, then an odd
// polynomial (least-squares fit of atan(t) / t in t^2, our own); quadrants as std::atan2.
inline double atan2_float_accuracy(double y, double x) {
    const double ax = std::fabs(x), ay = std::fabs(y);
    const bool swap = ay > ax;
    const double num = swap ? ax : ay, den = swap ? ay : ax;
    if (!(den > 0.0)) return std::atan2(y, x);  // both zero, or NaN
    double t = num / den, base = 0.0;
    if (t > 0.41421356237309503) {  // tan(pi/8)
        t = (t - 1.0) / (t + 1.0);
        base = 0.25 * kPi;
    }
    const double z = t * t;
    double p = -0.04050278985429021;
    p = p * z + 0.07139050976280181;
    p = p * z + -0.09029728811783594;
    p = p * z + 0.1110756504568841;
    p = p * z + -0.14285615579336844;
    p = p * z + 0.1999999897105977;
    p = p * z + -0.3333333333167031;
    double a = base + (t + t * z * p);
    if (swap) a = 0.5 * kPi - a;
    if (x < 0.0) a = kPi - a;
    return std::signbit(y) ? -a : a;
}
// log of x > 0 to about 1e-10 relative, inlined: x = 2^e m with m in [sqrt(1/2), sqrt(2)) read from the
// bits, log m = 2 atanh(t) with t = (m - 1) / (m + 1), |t| <= 0.172, from atanh's series to t^11 (error
// below t^13 / 13). Zero, negative, subnormal, infinite and NaN arguments go to std::log.
inline double log_float_accuracy(double x) {
    if (!(x >= 2.2250738585072014e-308 && x <= 1.7976931348623157e308)) return std::log(x);
    uint64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    // Exponent relative to sqrt(1/2) (bits 0x3FE6A09E667F3BCD), so that the mantissa lands in [sqrt(1/2), sqrt(2)).
    const int64_t e = int64_t(bits - 0x3FE6A09E667F3BCDull) >> 52;
    bits -= uint64_t(e) << 52;
    double m;
    std::memcpy(&m, &bits, sizeof m);
    const double t = (m - 1.0) / (m + 1.0), z = t * t;
    double p = 1.0 / 11.0;
    p = p * z + 1.0 / 9.0;
    p = p * z + 1.0 / 7.0;
    p = p * z + 1.0 / 5.0;
    p = p * z + 1.0 / 3.0;
    return double(e) * 0.6931471805599453 + 2.0 * (t + t * z * p);
}
// sin r and cos r for |r| <= pi/4 from their Taylor series to r^13 and r^14 (Horner in z = r^2), for a double
// or per lane of a Double2 (the same operations, so the lanes equal the scalar form bit for bit).
template <class T>
HAIRBSDF_ALWAYS_INLINE void sincos_taylor(T r, T& sin_r, T& cos_r) {
    const T z = r * r;
    T ps = z * (-1.0 / 6227020800.0) + 1.0 / 39916800.0;
    ps = ps * z - 1.0 / 362880.0;
    ps = ps * z + 1.0 / 5040.0;
    ps = ps * z - 1.0 / 120.0;
    ps = ps * z + 1.0 / 6.0;
    sin_r = r - r * z * ps;
    T pc = z * (1.0 / 87178291200.0) - 1.0 / 479001600.0;
    pc = pc * z + 1.0 / 3628800.0;
    pc = pc * z - 1.0 / 40320.0;
    pc = pc * z + 1.0 / 720.0;
    pc = pc * z - 1.0 / 24.0;
    pc = pc * z + 0.5;
    cos_r = 1.0 - z * pc;
}
// sin and cos of x together to about 1e-15 absolute for |x| up to a few turns, inlined (the sampled
// direction must stay a unit vector to 1e-12): x = n pi/2 + r with |r| <= pi/4 (pi/2 in two parts), sin r
// and cos r from their Taylor series to r^13 and r^14, then the quadrant n mod 4.
inline SinCosPair sincos_accurate(double x) {
    constexpr double kRound = 6755399441055744.0;  // 1.5 * 2^52: adding it rounds to an integer
    const double n = (x * 0.6366197723675814 + kRound) - kRound;  // x / (pi/2), rounded
    const double r = (x - n * 1.5707963267948966) - n * 6.123233995736766e-17;
    double sin_r, cos_r;
    sincos_taylor(r, sin_r, cos_r);
    switch (int64_t(n) & 3) {
        case 0: return {sin_r, cos_r};
        case 1: return {cos_r, -sin_r};
        case 2: return {-sin_r, -cos_r};
        default: return {-cos_r, sin_r};
    }
}
// Two-lane forms of log and sincos above (Double2): per lane the same operations in the same order as the
// scalar functions, so each lane equals the scalar result bit for bit. For the sampler's independent pairs
// (its two logs and two sin/cos).
inline Double2 log_float_accuracy(Double2 x) {
    if (!all_lanes((x >= 2.2250738585072014e-308) & (x <= 1.7976931348623157e308)))
        return Double2{log_float_accuracy(x[0]), log_float_accuracy(x[1])};
    UInt2 bits;
    std::memcpy(&bits, &x, sizeof bits);
    // The exponent relative to sqrt(1/2) plus 1023, from a logical shift (e + 1023 >= 1 for normal x).
    const UInt2 biased_e = (bits + (0x3FF0000000000000ull - 0x3FE6A09E667F3BCDull)) >> 52;
    bits -= (biased_e - 1023) << 52;
    Double2 m;
    std::memcpy(&m, &bits, sizeof m);
    // double(e): the integer in the mantissa of 2^52, minus 2^52 + 1023 (exact).
    const UInt2 e_bits = biased_e | 0x4330000000000000ull;
    Double2 e;
    std::memcpy(&e, &e_bits, sizeof e);
    e = e - (4503599627370496.0 + 1023.0);
    const Double2 t = (m - 1.0) / (m + 1.0), z = t * t;
    Double2 p = z * (1.0 / 11.0) + 1.0 / 9.0;
    p = p * z + 1.0 / 7.0;
    p = p * z + 1.0 / 5.0;
    p = p * z + 1.0 / 3.0;
    return e * 0.6931471805599453 + 2.0 * (t + t * z * p);
}
struct SinCosPair2 {
    Double2 sin, cos;
};
inline SinCosPair2 sincos_accurate(Double2 x) {
    constexpr double kRound = 6755399441055744.0;
    const Double2 shifted = x * 0.6366197723675814 + kRound;  // its low bits hold n
    const Double2 n = shifted - kRound;
    const Double2 r = (x - n * 1.5707963267948966) - n * 6.123233995736766e-17;
    Double2 sin_r, cos_r;
    sincos_taylor(r, sin_r, cos_r);
    // The quadrant n mod 4: odd swaps sin and cos; sin is negated for n = 2, 3, cos for n = 1, 2.
    UInt2 q;
    std::memcpy(&q, &shifted, sizeof q);
    const Int2 odd = Int2(q & 1) != 0;
    Double2 s = odd ? cos_r : sin_r, c = odd ? sin_r : cos_r;
    UInt2 sb, cb;
    std::memcpy(&sb, &s, sizeof sb);
    std::memcpy(&cb, &c, sizeof cb);
    sb ^= (q & 2) << 62;
    cb ^= ((q + 1) & 2) << 62;
    std::memcpy(&s, &sb, sizeof s);
    std::memcpy(&c, &cb, sizeof c);
    return {s, c};
}
// exp, asin (clamped to [-1, 1]) and atan2 to float accuracy or better where `in_float` (the inlined
// forms above), else glibc's double functions.
inline double exp_in(bool in_float, double x) { return in_float ? exp_float_accuracy(x) : std::exp(x); }
inline double asin_in(bool in_float, double x) {
    x = std::min(std::max(x, -1.0), 1.0);
    return in_float ? asin_float_accuracy(x) : std::asin(x);
}
inline double atan2_in(bool in_float, double y, double x) {
    return in_float ? atan2_float_accuracy(y, x) : std::atan2(y, x);
}
inline double log_in(bool in_float, double x) { return in_float ? log_float_accuracy(x) : std::log(x); }
inline SinCosPair sincos_in(bool in_float, double x) {
    return in_float ? sincos_accurate(x) : SinCosPair{std::sin(x), std::cos(x)};
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

// Cycles' approximations (docs/cycles.md §4.3): the first 10 terms of the power series
// (k = 0..9; Cycles stops early only where a term no longer changes a float sum) and the
// asymptotic log branch above x = 12.
// The series in q = x^2 / 4: sum_k q^k / (k!)^2 in Horner form, for double or Double2 lanes.
template <class Real>
HAIRBSDF_ALWAYS_INLINE Real cycles_bessel_i0_of_quarter_square(Real q) {
    Real sum = q * (1.0 / 131681894400.0) + 1.0 / 1625702400.0;  // 1 / (9!)^2, 1 / (8!)^2
    sum = sum * q + 1.0 / 25401600.0;
    sum = sum * q + 1.0 / 518400.0;
    sum = sum * q + 1.0 / 14400.0;
    sum = sum * q + 1.0 / 576.0;
    sum = sum * q + 1.0 / 36.0;
    sum = sum * q + 1.0 / 4.0;
    sum = sum * q + 1.0;
    return sum * q + 1.0;
}
inline double cycles_bessel_i0(double x) { return cycles_bessel_i0_of_quarter_square(0.25 * x * x); }
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

// Cycles' linear congruential generator: one step of the state, and the new state mapped to [0, 1]
// in float as Cycles rounds it.
inline uint32_t lcg_step(uint32_t& state) { return state = 1103515245u * state + 12345u; }
inline double lcg_step_float(uint32_t& state) { return double(float(lcg_step(state)) * (1.0f / float(0xFFFFFFFFu))); }

// Bob Jenkins' lookup3 hash of two integers mapped to [0, 1]: Blender's per-curve
// "Hair Info > Random" is hash(curve_index, 0) / 0xFFFFFFFF (docs/cycles.md §2.2).
uint32_t lookup3_hash_uint2(uint32_t kx, uint32_t ky);
inline double cycles_curve_random(uint32_t curve_index) {
    // Cycles computes this in float32; round the same way so values match bit for bit.
    return double(float(lookup3_hash_uint2(curve_index, 0)) / float(0xFFFFFFFFu));
}


// ---------------------------------------------------------------------------------------------
// Sampling helpers of the model zoo (docs/models.md).

// Standard normal CDF and its inverse (Acklam's rational approximation refined by one Halley
// step on erfc: relative error ~1e-15 over (0, 1)).
inline double normal_cdf(double z) { return 0.5 * std::erfc(-z * 0.7071067811865476); }
inline double inverse_normal_cdf(double p) {
    if (!(p > 0.0)) return -40.0;
    if (!(p < 1.0)) return 40.0;
    static const double a[6] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                                1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
    static const double b[5] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                                6.680131188771972e+01,  -1.328068155288572e+01};
    static const double c[6] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
    static const double d[4] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                                3.754408661907416e+00};
    double x;
    if (p < 0.02425) {
        const double q = std::sqrt(-2.0 * std::log(p));
        x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
            ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
    } else if (p > 1.0 - 0.02425) {
        const double q = std::sqrt(-2.0 * std::log1p(-p));
        x = -(((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
            ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
    } else {
        const double q = p - 0.5, r = q * q;
        x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
            (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
    }
    const double e = normal_cdf(x) - p;
    const double u = e * 2.5066282746310002 * std::exp(0.5 * x * x);
    return x - u / (1.0 + 0.5 * x * u);
}

// A normal distribution (mean, sd) truncated to [lo, hi]: exact density and inverse-CDF sampler.
// Works in the tail nearer to the interval so that far-tail intervals keep their precision;
// mass() == 0 when the interval carries no representable probability (then nothing is sampled).
class TruncatedNormal {
public:
    TruncatedNormal() = default;
    TruncatedNormal(double mean, double sd, double lo, double hi) : mean_(mean), sd_(sd), lo_(lo), hi_(hi) {
        const double za = (lo - mean) / sd, zb = (hi - mean) / sd;
        upper_ = za > 0.0;  // interval right of the mean: use the upper tail Q(z) = Phi(-z)
        ca_ = upper_ ? normal_cdf(-za) : normal_cdf(za);
        cb_ = upper_ ? normal_cdf(-zb) : normal_cdf(zb);
        mass_ = std::fabs(cb_ - ca_);
    }
    double mass() const { return mass_; }
    // Density on [lo, hi] (0 outside).
    double pdf(double x) const {
        if (!(mass_ > 0.0) || x < lo_ || x > hi_) return 0.0;
        const double z = (x - mean_) / sd_;
        return std::exp(-0.5 * z * z) / (sd_ * 2.5066282746310002 * mass_);
    }
    double sample(double u) const {
        const double p = ca_ + clamp(u, 0.0, 1.0) * (cb_ - ca_);
        const double z = upper_ ? -inverse_normal_cdf(p) : inverse_normal_cdf(p);
        return clamp(mean_ + sd_ * z, lo_, hi_);
    }

private:
    double mean_ = 0, sd_ = 1, lo_ = -1, hi_ = 1;
    double ca_ = 0, cb_ = 0, mass_ = 0;
    bool upper_ = false;
};

// A piecewise-constant density on [lo, hi] with `bins` equal bins, each bin's weight the integral
// of f over it (4-point Gauss-Legendre). Exact density and inverse-CDF sampling, also restricted
// to a sub-interval [a, b] (the density is then renormalised by mass(a, b)).
class PiecewiseConstant1D {
public:
    PiecewiseConstant1D() = default;
    template <class F>
    PiecewiseConstant1D(F f, double lo, double hi, int bins) : lo_(lo), hi_(hi), width_((hi - lo) / bins) {
        const double* gx = GaussLegendre<4>::x;
        const double* gw = GaussLegendre<4>::w;
        density_.resize(size_t(bins));
        cdf_.assign(size_t(bins) + 1, 0.0);
        for (int k = 0; k < bins; ++k) {
            const double mid = lo + (k + 0.5) * width_;
            double s = 0;
            for (int j = 0; j < 4; ++j) s += gw[j] * std::max(0.0, f(mid + 0.5 * width_ * gx[j]));
            cdf_[size_t(k) + 1] = cdf_[size_t(k)] + 0.5 * width_ * s;
        }
        const double total = cdf_.back();
        for (int k = 0; k < bins; ++k)
            density_[size_t(k)] = total > 0 ? (cdf_[size_t(k) + 1] - cdf_[size_t(k)]) / (total * width_) : 0.0;
        for (double& c : cdf_) c = total > 0 ? c / total : 0.0;
        cdf_.back() = total > 0 ? 1.0 : 0.0;
        integral_ = total;
    }
    double integral() const { return integral_; }  // integral of f over [lo, hi] (bin quadrature)
    double pdf(double x) const {
        if (density_.empty() || x < lo_ || x > hi_) return 0.0;
        return density_[bin(x)];
    }
    double cdf(double x) const {
        if (density_.empty() || x <= lo_) return 0.0;
        if (x >= hi_) return 1.0;
        const size_t k = bin(x);
        return cdf_[k] + density_[k] * (x - (lo_ + double(k) * width_));
    }
    double mass(double a, double b) const { return std::max(0.0, cdf(b) - cdf(a)); }
    // Inverse CDF restricted to [a, b].
    double sample(double u, double a, double b) const {
        const double ca = cdf(a), cb = cdf(b);
        const double target = ca + clamp(u, 0.0, 1.0) * (cb - ca);
        size_t k = size_t(std::upper_bound(cdf_.begin(), cdf_.end(), target) - cdf_.begin());
        k = k == 0 ? 0 : k - 1;
        // skip empty bins so the sample lands where the density is positive
        while (k + 1 < cdf_.size() && density_[std::min(k, density_.size() - 1)] <= 0.0) ++k;
        k = std::min(k, density_.size() - 1);
        const double x = lo_ + double(k) * width_ + (density_[k] > 0 ? (target - cdf_[k]) / density_[k] : 0.0);
        return clamp(x, std::max(a, lo_ + double(k) * width_), std::min(b, lo_ + double(k + 1) * width_));
    }

private:
    size_t bin(double x) const {
        const double t = (x - lo_) / width_;
        return size_t(clamp(std::floor(t), 0.0, double(density_.size() - 1)));
    }
    double lo_ = 0, hi_ = 1, width_ = 1, integral_ = 0;
    std::vector<double> density_, cdf_;
};

}  // namespace hairbsdf
