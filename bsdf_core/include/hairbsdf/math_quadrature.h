// One-dimensional quadrature and quasi-Monte Carlo points shared by the models: Gauss-Legendre
// rules, adaptive Gauss-Kronrod over breakpoints, and Sobol' points with a digital shift.
// Multi-dimensional adaptive cubature: math_cubature.h.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

namespace hairbsdf {

// N-point Gauss-Legendre rule on [-1, 1]: nodes x ascending, weights w (summing to 2).
template <int N>
struct GaussLegendre;
template <>
struct GaussLegendre<3> {
    static constexpr double x[3] = {-0.7745966692414834, 0.0, 0.7745966692414834};
    static constexpr double w[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
};
template <>
struct GaussLegendre<4> {
    static constexpr double x[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526};
    static constexpr double w[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538};
};
template <>
struct GaussLegendre<6> {
    static constexpr double x[6] = {-0.9324695142031521, -0.6612093864662645, -0.2386191860831969,
                                    0.2386191860831969,  0.6612093864662645,  0.9324695142031521};
    static constexpr double w[6] = {0.1713244923791704, 0.3607615730481386, 0.4679139345726910,
                                    0.4679139345726910, 0.3607615730481386, 0.1713244923791704};
};
template <>
struct GaussLegendre<8> {
    static constexpr double x[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
                                    0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
    static constexpr double w[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873, 0.3626837833783620,
                                    0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
};

// Gauss-Kronrod 7-15 on [a, b] for a scalar function; returns the estimate and |K15 - G7|.
template <class F>
std::pair<double, double> gauss_kronrod(F f, double a, double b) {
    static constexpr double xk[8] = {0.991455371120812639, 0.949107912342758525, 0.864864423359769073,
                                     0.741531185599394440, 0.586087235467691130, 0.405845151377397167,
                                     0.207784955007898468, 0.0};
    static constexpr double wk[8] = {0.022935322010529225, 0.063092092629978553, 0.104790010322250184,
                                     0.140653259715525919, 0.169004726639267903, 0.190350578064785410,
                                     0.204432940075298892, 0.209482141084727828};
    static constexpr double wg[4] = {0.129484966168869693, 0.279705391489276668, 0.381830050505118945,
                                     0.417959183673469388};
    const double c = 0.5 * (a + b), hw = 0.5 * (b - a);
    const double fc = f(c);
    double k = wk[7] * fc, g = wg[3] * fc;
    for (int j = 0; j < 7; ++j) {
        const double fs = f(c - hw * xk[j]) + f(c + hw * xk[j]);
        k += wk[j] * fs;
        if (j % 2 == 1) g += wg[j / 2] * fs;
    }
    return {k * hw, std::fabs((k - g) * hw)};
}

// Adaptive Gauss-Kronrod (bisection of the worst interval) over the breakpoints.
template <class F>
double adaptive_gk(F f, const std::vector<double>& breaks, double rel_tol, int max_intervals) {
    struct Piece {
        double a, b, value, error;
    };
    std::vector<Piece> pieces;
    double total = 0, error = 0;
    for (size_t i = 0; i + 1 < breaks.size(); ++i) {
        if (!(breaks[i + 1] > breaks[i])) continue;
        const auto r = gauss_kronrod(f, breaks[i], breaks[i + 1]);
        pieces.push_back({breaks[i], breaks[i + 1], r.first, r.second});
        total += r.first;
        error += r.second;
    }
    auto worse = [](const Piece& a, const Piece& b) { return a.error < b.error; };
    std::make_heap(pieces.begin(), pieces.end(), worse);
    while (!pieces.empty() && error > rel_tol * std::fabs(total) + 1e-300 && int(pieces.size()) < max_intervals) {
        std::pop_heap(pieces.begin(), pieces.end(), worse);
        const Piece p = pieces.back();
        pieces.pop_back();
        total -= p.value;
        error -= p.error;
        const double m = 0.5 * (p.a + p.b);
        for (const auto& ab : {std::make_pair(p.a, m), std::make_pair(m, p.b)}) {
            const auto r = gauss_kronrod(f, ab.first, ab.second);
            pieces.push_back({ab.first, ab.second, r.first, r.second});
            std::push_heap(pieces.begin(), pieces.end(), worse);
            total += r.first;
            error += r.second;
        }
    }
    return total;
}

// Sobol' points (Joe-Kuo direction numbers, dimensions 1-5) with a digital shift.
struct Sobol {
    uint32_t v[5][32];
    Sobol() {
        const int s[5] = {0, 1, 2, 3, 3}, a[5] = {0, 0, 1, 1, 2};
        const uint32_t m[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 3, 0}, {1, 3, 1}, {1, 1, 1}};
        for (int k = 0; k < 32; ++k) v[0][k] = 1u << (31 - k);
        for (int d = 1; d < 5; ++d) {
            for (int k = 0; k < s[d]; ++k) v[d][k] = m[d][k] << (31 - k);
            for (int k = s[d]; k < 32; ++k) {
                uint32_t x = v[d][k - s[d]] ^ (v[d][k - s[d]] >> s[d]);
                for (int j = 1; j < s[d]; ++j)
                    if ((a[d] >> (s[d] - 1 - j)) & 1) x ^= v[d][k - j];
                v[d][k] = x;
            }
        }
    }
    // Point i (Gray-code free, direct) in dimension d.
    uint32_t point(uint32_t i, int d) const {
        uint32_t x = 0;
        for (int k = 0; i; ++k, i >>= 1)
            if (i & 1) x ^= v[d][k];
        return x;
    }
};
inline const Sobol& sobol() {
    static const Sobol s;
    return s;
}

}  // namespace hairbsdf
