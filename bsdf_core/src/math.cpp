#include "hairbsdf/math.h"

namespace hairbsdf {

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

// log I0 from the asymptotic series
// I0(x) ~ e^x / sqrt(2 pi x) * sum_k ((2k-1)!!)^2 / (k! (8x)^k),
// accurate to ~e^{-2x} relative (1e-14 at the switch x = 16).
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
