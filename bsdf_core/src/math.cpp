#include "hairbsdf/math.h"

namespace hairbsdf {

double fresnel_dielectric(double cos_i, double eta) {
    const double c = std::fabs(cos_i);
    const double g2 = eta * eta - 1.0 + c * c;
    if (!(g2 > 0.0)) return 1.0;  // total internal reflection
    const double g = std::sqrt(g2);
    const double a = (g - c) / (g + c);
    const double b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return 0.5 * a * a * (1.0 + b * b);
}

namespace {
// Power series sum_k (x^2/4)^k / (k!)^2, summed until the terms stop mattering.
double bessel_i0_series(double x) {
    const double q = 0.25 * x * x;
    double term = 1.0, sum = 1.0;
    for (int k = 1; k < 200; ++k) {
        term *= q / (double(k) * double(k));
        sum += term;
        if (term < 1e-17 * sum) break;
    }
    return sum;
}

// log I0 for large x from the asymptotic series
// I0(x) ~ e^x / sqrt(2 pi x) * sum_k ((2k-1)!!)^2 / (k! (8x)^k).
double log_bessel_i0_asymptotic(double x) {
    double term = 1.0, sum = 1.0;
    for (int k = 1; k < 60; ++k) {
        const double next = term * sqr(2.0 * k - 1.0) / (8.0 * k * x);
        if (next > term) break;  // the series is asymptotic: stop at its smallest term
        term = next;
        sum += term;
        if (term < 1e-17 * sum) break;
    }
    return x - 0.5 * std::log(kTwoPi * x) + std::log(sum);
}
constexpr double kSeriesLimit = 25.0;
}  // namespace

double bessel_i0(double x) {
    x = std::fabs(x);
    return x <= kSeriesLimit ? bessel_i0_series(x) : std::exp(log_bessel_i0_asymptotic(x));
}

double log_bessel_i0(double x) {
    x = std::fabs(x);
    return x <= kSeriesLimit ? std::log(bessel_i0_series(x)) : log_bessel_i0_asymptotic(x);
}

double cycles_bessel_i0(double x) {
    // Terms k = 0..9 of the power series, stopping when a term no longer changes the sum.
    const double x2 = x * x;
    double sum = 1.0 + 0.25 * x2;
    double x_pow = x2 * x2;
    double factorial_sq = 1.0;
    double four_pow = 16.0;
    for (int k = 2; k < 10; ++k) {
        factorial_sq *= double(k) * double(k);
        const double next = sum + x_pow / (four_pow * factorial_sq);
        if (next == sum) break;
        sum = next;
        x_pow *= x2;
        four_pow *= 4.0;
    }
    return sum;
}

double cycles_log_bessel_i0(double x) {
    if (x > 12.0) return x + 0.5 * (1.0 / (8.0 * x) - std::log(kTwoPi) - std::log(x));
    return std::log(cycles_bessel_i0(x));
}

namespace {
inline uint32_t rotl(uint32_t x, int k) { return (x << k) | (x >> (32 - k)); }
}  // namespace

uint32_t lookup3_hash_uint2(uint32_t kx, uint32_t ky) {
    // Bob Jenkins' lookup3 (public domain): initialisation for two words, then final().
    uint32_t a, b, c;
    a = b = c = 0xdeadbeefu + (2u << 2) + 13u;
    b += ky;
    a += kx;
    c ^= b; c -= rotl(b, 14);
    a ^= c; a -= rotl(c, 11);
    b ^= a; b -= rotl(a, 25);
    c ^= b; c -= rotl(b, 16);
    a ^= c; a -= rotl(c, 4);
    b ^= a; b -= rotl(a, 14);
    c ^= b; c -= rotl(b, 24);
    return c;
}

}  // namespace hairbsdf
