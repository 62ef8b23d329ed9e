// Globally adaptive cubature over a set of boxes (Genz & Malik 1980 degree-7 rule with an
// embedded degree-5 rule; the box with the largest error estimate is bisected along the axis
// with the largest fourth difference, as in hcubature). Several problems of different dimension
// share one priority queue, so the error budget goes where it is largest. Used by the Huang
// model's deterministic evaluation (docs/huang.md §4) and its E_glass tables.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <type_traits>
#include <utility>
#include <vector>

namespace hairbsdf::adaptive {

constexpr int kMaxDim = 5;
constexpr int kMaxValues = 9;

// Genz-Malik points and weights for dimension d on [-1, 1]^d (weights sum to 1).
struct GenzMalik {
    int dim = 0;
    std::vector<std::array<double, kMaxDim>> points;
    std::vector<double> w7, w5;
    // Indices of the +-lambda2 / +-lambda4 points per axis (for the split rule) and the centre.
    std::array<std::array<int, 4>, kMaxDim> axis_points{};

    explicit GenzMalik(int d = 1) : dim(d) {
        const double l2 = std::sqrt(9.0 / 70.0), l4 = std::sqrt(9.0 / 10.0), l5 = std::sqrt(9.0 / 19.0);
        const double dd = d;
        const double a1 = (12824.0 - 9120.0 * dd + 400.0 * dd * dd) / 19683.0, a2 = 980.0 / 6561.0;
        const double a3 = (1820.0 - 400.0 * dd) / 19683.0, a4 = 200.0 / 19683.0;
        const double a5 = 6859.0 / 19683.0 / double(1 << d);
        const double b1 = (729.0 - 950.0 * dd + 50.0 * dd * dd) / 729.0, b2 = 245.0 / 486.0;
        const double b3 = (265.0 - 100.0 * dd) / 1458.0, b4 = 25.0 / 729.0;
        auto add = [&](std::array<double, kMaxDim> p, double w7_, double w5_) {
            points.push_back(p);
            w7.push_back(w7_);
            w5.push_back(w5_);
            return int(points.size()) - 1;
        };
        add({}, a1, b1);
        for (int i = 0; i < d; ++i) {
            std::array<double, kMaxDim> p{};
            p[i] = l2;
            axis_points[i][0] = add(p, a2, b2);
            p[i] = -l2;
            axis_points[i][1] = add(p, a2, b2);
            p[i] = l4;
            axis_points[i][2] = add(p, a3, b3);
            p[i] = -l4;
            axis_points[i][3] = add(p, a3, b3);
        }
        for (int i = 0; i < d; ++i) {
            for (int j = i + 1; j < d; ++j) {
                for (int si = -1; si <= 1; si += 2) {
                    for (int sj = -1; sj <= 1; sj += 2) {
                        std::array<double, kMaxDim> p{};
                        p[i] = si * l4;
                        p[j] = sj * l4;
                        add(p, a4, b4);
                    }
                }
            }
        }
        for (int mask = 0; mask < (1 << d); ++mask) {
            std::array<double, kMaxDim> p{};
            for (int i = 0; i < d; ++i) p[i] = (mask >> i & 1) ? l5 : -l5;
            add(p, a5, 0.0);
        }
    }
};

inline const GenzMalik& rule(int dim) {
    static const std::array<GenzMalik, kMaxDim + 1> rules = {GenzMalik(1), GenzMalik(1), GenzMalik(2),
                                                            GenzMalik(3), GenzMalik(4), GenzMalik(5)};
    return rules[size_t(dim)];
}

struct Box {
    std::array<double, kMaxDim> center{}, half{};
    std::array<double, kMaxValues> value{};
    double error = 0;
    int split = 0;
    int problem = 0;
};

// Whether Problems has eval_points(p, xs, n, fs): the n points of one box at once (else eval, point by point).
template <class P, class = void>
struct HasEvalPoints : std::false_type {};
template <class P>
struct HasEvalPoints<P, std::void_t<decltype(std::declval<const P&>().eval_points(
                            0, static_cast<const std::array<double, kMaxDim>*>(nullptr), size_t(0),
                            static_cast<std::array<double, kMaxValues>*>(nullptr)))>> : std::true_type {};

// Integrand interface: `values` of problem p at point x (dimension dim(p)), written into out[0..n);
// optionally eval_points, the same for a box's points together (HasEvalPoints).
// `norm` turns a vector of values into the scalar whose error is controlled.
template <class Problems>
class Integrator {
public:
    explicit Integrator(Problems& problems) : problems_(problems) {}

    // Adds a box of problem p and evaluates it.
    void add(int p, const std::array<double, kMaxDim>& lo, const std::array<double, kMaxDim>& hi) {
        Box b;
        b.problem = p;
        const int d = problems_.dim(p);
        for (int i = 0; i < d; ++i) {
            b.center[i] = 0.5 * (lo[i] + hi[i]);
            b.half[i] = 0.5 * (hi[i] - lo[i]);
        }
        evaluate(b);
        push(b);
    }

    // Refines until the summed error is <= tolerance(total) or the evaluation budget is spent.
    template <class Tolerance>
    void refine(Tolerance tolerance, long max_evaluations) {
        while (!heap_.empty()) {
            if (total_error() <= tolerance(totals_) || evaluations_ >= max_evaluations) break;
            std::pop_heap(heap_.begin(), heap_.end(), by_error);
            Box b = heap_.back();
            heap_.pop_back();
            remove(b);
            Box c = b;
            b.half[b.split] *= 0.5;
            c.half[c.split] *= 0.5;
            b.center[b.split] -= b.half[b.split];
            c.center[c.split] += c.half[c.split];
            evaluate(b);
            evaluate(c);
            push(b);
            push(c);
        }
    }

    double total_error() const { return std::max(error_sum_, 0.0); }
    const std::array<double, kMaxValues>& totals() const { return totals_; }
    long evaluations() const { return evaluations_; }

private:
    static bool by_error(const Box& a, const Box& b) { return a.error < b.error; }

    void evaluate(Box& b) {
        const GenzMalik& r = rule(problems_.dim(b.problem));
        const int d = r.dim;
        double volume = 1;
        for (int i = 0; i < d; ++i) volume *= 2.0 * b.half[i];
        std::array<double, kMaxValues> i7{}, i5{};
        const size_t n = r.points.size();
        fvals_.resize(n);
        const int nv = problems_.values(b.problem);
        const auto point = [&](size_t k) {
            std::array<double, kMaxDim> x{};
            for (int i = 0; i < d; ++i) x[i] = b.center[i] + b.half[i] * r.points[k][i];
            return x;
        };
        const auto add_value = [&](size_t k, const std::array<double, kMaxValues>& f) {
            fvals_[k] = problems_.norm(b.problem, f);
            for (int j = 0; j < nv; ++j) {
                i7[j] += r.w7[k] * f[j];
                i5[j] += r.w5[k] * f[j];
            }
        };
        if constexpr (HasEvalPoints<Problems>::value) {  // the box's points together, through xs_ and fs_
            xs_.resize(n);
            fs_.assign(n, std::array<double, kMaxValues>{});
            for (size_t k = 0; k < n; ++k) xs_[k] = point(k);
            problems_.eval_points(b.problem, xs_.data(), n, fs_.data());
            for (size_t k = 0; k < n; ++k) add_value(k, fs_[k]);
        } else {  // point by point, without the buffers
            for (size_t k = 0; k < n; ++k) {
                std::array<double, kMaxValues> f{};
                problems_.eval(b.problem, point(k), f);
                add_value(k, f);
            }
        }
        evaluations_ += long(r.points.size());
        std::array<double, kMaxValues> diff{};
        for (int j = 0; j < nv; ++j) {
            b.value[j] = volume * i7[j];
            diff[j] = volume * (i7[j] - i5[j]);
        }
        b.error = std::fabs(problems_.norm(b.problem, diff));
        // Split along the axis with the largest fourth difference.
        const double ratio = (9.0 / 70.0) / (9.0 / 10.0);
        double best = -1;
        b.split = 0;
        for (int i = 0; i < d; ++i) {
            const auto& a = r.axis_points[i];
            const double f0 = fvals_[0];
            const double fd = std::fabs(fvals_[a[0]] + fvals_[a[1]] - 2 * f0 - ratio * (fvals_[a[2]] + fvals_[a[3]] - 2 * f0));
            if (fd > best + 1e-14 * std::fabs(best) || (std::fabs(fd - best) <= 1e-14 * std::fabs(best) && b.half[i] > b.half[b.split])) {
                best = fd;
                b.split = i;
            }
        }
    }
    void push(const Box& b) {
        heap_.push_back(b);
        std::push_heap(heap_.begin(), heap_.end(), by_error);
        for (int k = 0; k < kMaxValues; ++k) totals_[k] += b.value[k];
        error_sum_ += b.error;
    }
    void remove(const Box& b) {
        for (int k = 0; k < kMaxValues; ++k) totals_[k] -= b.value[k];
        error_sum_ -= b.error;
    }

    Problems& problems_;
    std::vector<Box> heap_;
    std::vector<double> fvals_;
    std::vector<std::array<double, kMaxDim>> xs_;     // a box's points and values, for eval_points only
    std::vector<std::array<double, kMaxValues>> fs_;
    std::array<double, kMaxValues> totals_{};
    double error_sum_ = 0;
    long evaluations_ = 0;
};

}  // namespace hairbsdf::adaptive
