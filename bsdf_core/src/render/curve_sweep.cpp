// hairbsdf's ray test of a round Catmull-Rom curve (Embree's surface); see render/curve_sweep.h.
#include "hairbsdf/render/curve_sweep.h"

#include <algorithm>
#include <cmath>

#include "hairbsdf/math_simd.h"

namespace hairbsdf::render {

namespace {

// The centre line, the radius and their first two derivatives in u.
struct CentreLine {
    Vec3 c, dc, ddc;
    double r = 0, dr = 0, ddr = 0;
};

// The segment's Catmull-Rom cubic in the power basis (coefficient k of u^k; x, y, z, r side by
// side, so that the compiler evaluates the four axes together), with the derivatives' factors.
struct Cubic {
    alignas(32) double coefficient[4][4];  // [k][axis]
    alignas(32) double first[3][4];        // k + 1 times coefficient k + 1: c'(u)'s
    alignas(32) double second[2][4];       // c''(u)'s
    explicit Cubic(const std::array<float, 4>* cp) {
        for (int axis = 0; axis < 4; ++axis) {
            const double p0 = cp[0][axis], p1 = cp[1][axis], p2 = cp[2][axis], p3 = cp[3][axis];
            coefficient[0][axis] = p1;
            coefficient[1][axis] = 0.5 * (p2 - p0);
            coefficient[2][axis] = 0.5 * (2 * p0 - 5 * p1 + 4 * p2 - p3);
            coefficient[3][axis] = 0.5 * (-p0 + 3 * p1 - 3 * p2 + p3);
        }
        for (int axis = 0; axis < 4; ++axis) {
            first[0][axis] = coefficient[1][axis];
            first[1][axis] = 2 * coefficient[2][axis];
            first[2][axis] = 3 * coefficient[3][axis];
            second[0][axis] = 2 * coefficient[2][axis];
            second[1][axis] = 6 * coefficient[3][axis];
        }
    }
};

CentreLine centre_line(const Cubic& cp, double u) {
    alignas(32) double value[4], first[4], second[4];
    for (int axis = 0; axis < 4; ++axis) {
        value[axis] = cp.coefficient[0][axis] +
                      u * (cp.coefficient[1][axis] + u * (cp.coefficient[2][axis] + u * cp.coefficient[3][axis]));
        first[axis] = cp.first[0][axis] + u * (cp.first[1][axis] + u * cp.first[2][axis]);
        second[axis] = cp.second[0][axis] + u * cp.second[1][axis];
    }
    CentreLine out;
    out.c = {value[0], value[1], value[2]};
    out.dc = {first[0], first[1], first[2]};
    out.ddc = {second[0], second[1], second[2]};
    out.r = value[3];
    out.dr = first[3];
    out.ddr = second[3];
    return out;
}

// Newton's step from u (`at` = the centre line there) for the least excess |p - c(u)| - r(u):
// to where its slope vanishes where it curves upwards, else a quarter of the range downhill.
// False where p lies on the centre line.
bool excess_newton_step(Vec3 p, const CentreLine& at, double lo, double hi, double& step) {
    const Vec3 w = p - at.c;
    const double rho = length(w);
    if (!(rho > 0)) return false;
    const double along = dot(w, at.dc);
    const double slope = -along / rho - at.dr;
    const double curvature =
        (dot(at.dc, at.dc) - dot(w, at.ddc)) / rho - along * along / (rho * rho * rho) - at.ddr;
    step = curvature > 0 ? -slope / curvature : -0.25 * (hi - lo) * (slope > 0 ? 1 : -1);
    return true;
}

// The u in [lo, hi] nearest to p in the sweep's sense (least |p - c(u)| - r(u)) on a nearly
// straight piece, where the excess has one minimum: plain Newton's method from `u`; `at` is the
// centre line there.
double nearest_u_newton(const Cubic& cp, Vec3 p, double u, double lo, double hi, CentreLine& at) {
    for (int i = 0; i < 8; ++i) {
        at = centre_line(cp, u);
        double step;
        if (!excess_newton_step(p, at, lo, hi, step)) return u;
        const double next = std::clamp(u + step, lo, hi);
        const bool moved = std::fabs(next - u) > 1e-12;
        u = next;
        if (!moved) break;
    }
    at = centre_line(cp, u);
    return u;
}

// The same on any piece: with `scan`, the best of five points across the range and `u` first;
// then Newton's steps, each kept only where it lowers the excess (else halved, up to 4 times).
double nearest_u_guarded(const Cubic& cp, Vec3 p, double u, double lo, double hi, CentreLine& at, bool scan) {
    auto excess = [&](double v) {
        const CentreLine c = centre_line(cp, v);
        return length(p - c.c) - c.r;
    };
    double best = excess(u);
    for (int j = 0; j <= 4 && scan; ++j) {
        const double v = lo + (hi - lo) * j / 4.0, e = excess(v);
        if (e < best) {
            best = e;
            u = v;
        }
    }
    for (int i = 0; i < 8; ++i) {
        at = centre_line(cp, u);
        double step;
        if (!excess_newton_step(p, at, lo, hi, step)) return u;
        bool moved = false;
        for (int halving = 0; halving < 5 && !moved; ++halving, step *= 0.5) {
            const double next = std::clamp(u + step, lo, hi);
            if (next == u) break;
            const double e = excess(next);
            if (e <= best) {
                moved = std::fabs(next - u) > 1e-12;
                best = e;
                u = next;
            }
        }
        if (!moved) break;
    }
    at = centre_line(cp, u);
    return u;
}

// Newton's last step on Embree's equations, squared, in units of r^2: a step shorter than 1e-3 r is
// taken as the root (onto_normal_plane_tube). 1e-5 saved a little more but biased the hits measurably
// (test_curves_in_object_space).
constexpr double kLastStep2 = 1e-6;

// From a point of the sphere sweep, Newton's method on Embree's own definition of a round
// curve: the point q = org + t dir lies in the normal plane at u, f = (q - c(u)) . c'(u) = 0,
// at distance r(u) from the centre line there, h = |q - c|^2 - f^2 / |c'|^2 - r(u)^2 = 0. With
// a constant radius this is the sphere sweep; where the radius changes they part by about
// r |dr/dc|. (Both equations without square roots: one division for 1 / |c'|^2, one for the step.)
SweepHit onto_normal_plane_tube(const Cubic& cp, Vec3 org, Vec3 dir, double t, double u, double t_min,
                                double t_max, SweepHit* converged = nullptr, int iterations = 12) {
    const double dir2 = dot(dir, dir);
    for (int i = 0; i < iterations; ++i) {
        const CentreLine c = centre_line(cp, u);
        const Vec3 w = org + t * dir - c.c;
        const double speed2 = dot(c.dc, c.dc);
        if (!(speed2 > 0)) return {};
        const double inverse_speed2 = 1.0 / speed2;
        const double f = dot(w, c.dc), f_du = dot(w, c.ddc) - speed2, f_dt = dot(dir, c.dc);
        const double along2 = f * f * inverse_speed2;  // the square of q - c's part along c'
        const double h = dot(w, w) - along2 - c.r * c.r;
        const double radius2 = (std::fabs(c.r) + 1e-9) * (std::fabs(c.r) + 1e-9);
        // The root at (t_root, u_root), where q - c is w_root.
        auto root = [&](double t_root, double u_root, Vec3 w_root) {
            SweepHit out;
            out.hit = true;
            out.t = t_root;
            out.u = u_root;
            out.normal = normalize(w_root - (dot(w_root, c.dc) * inverse_speed2) * c.dc);
            out.front = dot(dir, out.normal) < 0;
            if (converged) *converged = out;
            if (!(u_root >= 0.0 && u_root <= 1.0 && t_root >= t_min && t_root <= t_max)) return SweepHit{};
            return out;
        };
        // |f| / |c'| and h / 2r: the distances off the normal plane and off the circle, within 1e-7 r.
        if (along2 <= 1e-14 * radius2 && std::fabs(h) <= 2e-7 * radius2) return root(t, u, w);
        const double speed2_du = 2 * dot(c.dc, c.ddc);
        const double h_du = -2 * f - (2 * f * f_du - along2 * speed2_du) * inverse_speed2 - 2 * c.r * c.dr;
        const double h_dt = 2 * dot(w, dir) - 2 * f * f_dt * inverse_speed2;
        const double det = f_du * h_dt - f_dt * h_du;
        if (!(std::fabs(det) > 0)) return {};
        const double inverse_det = 1.0 / det;
        const double du = (h_dt * f - f_dt * h) * inverse_det, dt = (f_du * h - h_du * f) * inverse_det;
        if (!std::isfinite(du + dt)) return {};
        // Within 1e-2 r of the surface, a step shorter than 1e-3 r (kLastStep2 = its square) lands within
        // about 1e-6 r of it (Newton's error squares): that root, with q - c moved to first order.
        if (along2 <= 1e-4 * radius2 && std::fabs(h) <= 2e-2 * radius2 && dt * dt * dir2 <= kLastStep2 * radius2 &&
            du * du * speed2 <= kLastStep2 * radius2)
            return root(t - dt, u - du, w - dt * dir + du * c.dc);
        u -= du;
        t -= dt;
    }
    return {};
}

// Embree's surface along the ray: at q = org + t dir, the foot u of q on the centre line
// (f = (q - c(u)) . c'(u) = 0, Newton's method from `u`) and G = |q - c(u)| - r(u) there;
// `foot`, if given, receives the centre line at u.
double tube_excess(const Cubic& cp, Vec3 org, Vec3 dir, double t, double& u, CentreLine* foot = nullptr) {
    const Vec3 q = org + t * dir;
    CentreLine c = centre_line(cp, u);
    for (int i = 0; i < 4; ++i) {
        const Vec3 w = q - c.c;
        const double f = dot(w, c.dc), f_du = -dot(c.dc, c.dc) + dot(w, c.ddc);
        if (!(f_du < 0)) break;
        const double step = -f / f_du;
        u += step;
        c = centre_line(cp, u);
        if (std::fabs(step) < 1e-10) break;
    }
    if (foot) *foot = c;
    return length(q - c.c) - c.r;
}

// The tube's entry between `outside` (G > 0) and `inside` (G < 0) along the ray, by
// regula falsi with the Illinois halving; then Newton's last steps on both equations.
SweepHit bracketed_entry(const Cubic& cp, Vec3 org, Vec3 dir, double outside, double g_outside,
                         double inside, double g_inside, double u, double t_min, double t_max,
                         SweepHit* converged = nullptr) {
    const double tolerance = 1e-5 * (std::fabs(centre_line(cp, std::clamp(u, 0.0, 1.0)).r) + 1e-9);
    int kept_side = 0;
    for (int i = 0; i < 40; ++i) {
        const double t = outside - g_outside * (inside - outside) / (g_inside - g_outside);
        const double g = tube_excess(cp, org, dir, t, u);
        if (!std::isfinite(g)) return {};
        if (std::fabs(g) <= tolerance) return onto_normal_plane_tube(cp, org, dir, t, u, t_min, t_max, converged);
        if (g > 0) {
            outside = t;
            g_outside = g;
            if (kept_side == -1) g_inside *= 0.5;
            kept_side = -1;
        } else {
            inside = t;
            g_inside = g;
            if (kept_side == 1) g_outside *= 0.5;
            kept_side = 1;
        }
    }
    return {};
}

double catmull_rom_radius(const Cubic& cp, double u) { return centre_line(cp, u).r; }

// The largest |c''| and |r''| over a piece, from its centre line at its ends a, b (both are linear in u).
struct SecondDerivativeMaxima {
    double centre, radius;
};
SecondDerivativeMaxima second_derivative_maxima(const CentreLine& a, const CentreLine& b) {
    return {std::max(length(a.ddc), length(b.ddc)), std::max(std::fabs(a.ddr), std::fabs(b.ddr))};
}

// The chord bound of a piece from its centre line at its ends a = c(u_begin), b = c(u_end).
double chord_distance_bound(const CentreLine& a, const CentreLine& b, double u_begin, double u_end) {
    const double du2 = (u_end - u_begin) * (u_end - u_begin);
    const SecondDerivativeMaxima m = second_derivative_maxima(a, b);
    return (m.centre + m.radius) * du2 / 8.0;
}

// A piece is nearly straight when its centre line stays within this share of its smaller end
// radius from its chord: |p - c(u)| - r(u) then has one minimum in u, and along a ray that
// misses, G has one minimum (the passes below rely on both).
constexpr double kNearlyStraight = 0.25;
bool nearly_straight_piece(const CentreLine& a, const CentreLine& b, double chord_bound) {
    return chord_bound < kNearlyStraight * std::min(a.r, b.r);
}

// Where the ray is inside the sphere about the chord's middle that holds the chord, the chord bound
// and the larger end radius (the piece's sweep lies in it): [t_low, t_high] narrowed to that; false
// if the ray misses it there.
bool ray_in_bounding_sphere(const CentreLine& a, const CentreLine& b, double chord_bound, Vec3 org, Vec3 dir,
                            double& t_low, double& t_high) {
    const Vec3 middle = 0.5 * (a.c + b.c);
    const double radius = 0.5 * length(b.c - a.c) + std::max(a.r, b.r) + chord_bound;
    const Vec3 to_middle = middle - org;
    const double dd = dot(dir, dir), along = dot(to_middle, dir) / dd;
    const double miss2 = dot(to_middle, to_middle) / dd - along * along;
    const double half2 = radius * radius / dd - miss2;
    if (!(half2 >= 0)) return false;
    const double half = std::sqrt(half2);
    t_low = std::max(t_low, along - half);
    t_high = std::min(t_high, along + half);
    return t_low <= t_high;
}

// The ray's pass by a nearly straight piece (within a quarter radius of its chord), between t_low and
// t_high where the ray is inside the piece's bounding sphere: along the ray, G (tube_excess) has one
// minimum there. Newton's method for it, kept inside a shrinking bracket, from the ray's nearest
// approach to the chord. Outside at the minimum: a miss. Inside: the entry lies between the last
// point outside before the minimum (or t_low) and there; inside at t_low too, the one root is the exit.
// `decided` is false where this cannot tell (a root past an open end, or no convergence): the careful
// search then goes on.
struct PassResult {
    bool decided = false;
    SweepHit hit;
};

PassResult pass_by_straight_piece(const Cubic& cp, const SweepPiece& piece, const CentreLine& end_lo,
                                  const CentreLine& end_hi, Vec3 org, Vec3 dir, double t_low, double t_high,
                                  double t_min, double t_max) {
    const double lo = piece.u_begin, hi = piece.u_end;
    // The nearest approach of the ray to the chord segment.
    const Vec3 chord = end_hi.c - end_lo.c, from_start = org - end_lo.c;
    const double dd = dot(dir, dir), de = dot(dir, chord), ee = dot(chord, chord);
    const double dw = dot(dir, from_start), ew = dot(chord, from_start);
    const double denominator = dd * ee - de * de;
    const double s = denominator > 1e-12 * dd * ee ? std::clamp((dd * ew - de * dw) / denominator, 0.0, 1.0) : 0.5;
    double t = std::clamp((s * de - dw) / dd, t_low, t_high), u = lo + s * (hi - lo);
    const double scale = std::fabs(t) + std::max(end_lo.r, end_hi.r);
    double below = t_low, above = t_high;  // the minimum lies between
    double g_below = 0;                    // G at `below`, once looked at (G > 0 there, before the entry)
    bool below_looked_at = false;
    for (int i = 0; i < 16; ++i) {
        CentreLine at;
        const double g = tube_excess(cp, org, dir, t, u, &at);
        if (!std::isfinite(g)) return {};
        if (g < 0) {
            // Where G's foot lies past an open end of the curve, G measures the cubic's
            // continuation, no part of the tube: the careful search decides.
            auto past_open_end = [&](double v) { return (v < 0 && piece.curve_begins) || (v > 1 && piece.curve_ends); };
            bool exit = false;
            double outside = below, g_outside = g_below;
            if (!below_looked_at) {
                double u_low = u;
                const double g_low = tube_excess(cp, org, dir, t_low, u_low);
                if (g_low > 0 && t > t_low) {
                    outside = t_low;  // the entry lies between
                    g_outside = g_low;
                } else {
                    // Inside at t_low too: an entry would lie in the bounding sphere, past t_low, so
                    // the piece holds none; its one root is the exit, if the ray leaves the tube
                    // before t_high (else that lies past the piece, or past the nearest hit).
                    if (past_open_end(u_low)) return {};
                    double u_high = u;
                    g_outside = tube_excess(cp, org, dir, t_high, u_high);
                    if (past_open_end(u_high)) return {};
                    if (!(g_outside > 0)) return {true, {}};
                    outside = t_high;
                    exit = true;
                }
            }
            SweepHit root;
            const SweepHit found = bracketed_entry(cp, org, dir, outside, g_outside, t, g, u, t_min, t_max, &root);
            if (found.hit && found.front != exit) return {true, found};
            // On the tube past a joined end (the neighbour's proxies hold it), or farther than
            // the nearest hit so far: a miss here.
            if (root.hit && ((root.u < 0 && !piece.curve_begins) || (root.u > 1 && !piece.curve_ends) || root.t > t_max))
                return {true, {}};
            return {};
        }
        // dG/dt at the foot (where (q - c) . c' = 0, so u moves with t by -f_t / f_u), and the
        // curvature of a straight tube's G.
        const Vec3 w = org + t * dir - at.c;
        const double rho = length(w);
        if (!(rho > 0)) return {};
        const double f_u = -dot(at.dc, at.dc) + dot(w, at.ddc);
        const double du_dt = f_u < 0 ? dot(dir, at.dc) / -f_u : 0.0;
        const double along = dot(dir, w) / rho;
        const double slope = along - at.dr * du_dt;
        const double curvature = (dd - along * along) / rho;
        if (slope < 0) {
            below = t;
            g_below = g;
            below_looked_at = true;
        } else {
            above = t;
        }
        // G > 0 all along the range: the minimum at an end of it, or G's tangent here (below G,
        // which is convex) still above zero across the bracket.
        if ((slope >= 0 && t <= t_low) || (slope <= 0 && t >= t_high) || above - below <= 1e-9 * scale ||
            g > std::fabs(slope) * (slope < 0 ? above - t : t - below))
            return {true, {}};
        double next = curvature > 0 ? t - slope / curvature : 0.5 * (below + above);
        if (!(next > below && next < above)) {
            // Past the bracket: to its end, if not yet looked at, else its middle.
            const double end = next <= below ? below : above;
            next = (end == t_low || end == t_high) && end != t ? end : 0.5 * (below + above);
        }
        if (std::fabs(next - t) <= 1e-9 * scale) return {true, {}};  // the minimum: outside
        t = next;
    }
    return {};
}

// intersect_sweep's body, built twice: for the baseline and, where the CPU has them, for AVX2 + FMA.
inline SweepHit intersect_sweep_body(const SweepPiece& piece, Vec3 org, Vec3 dir, double t_start, double u_start,
                                     double t_min, double t_max, int quick_steps) {
    const Cubic cp(piece.control_points);
    const double lo = piece.u_begin, hi = piece.u_end, dir_length = length(dir);
    if (!(dir_length > 0)) return {};
    auto at_open_end = [&](double v) {
        return (piece.curve_begins && lo == 0 && v <= 1e-9) || (piece.curve_ends && hi == 1 && v >= 1 - 1e-9);
    };
    // g(t) = |p(t) - c(u)| - r(u) at the minimising u: the signed distance to the piece's swept
    // solid, whose slope along the ray is dir . (p - c) / |p - c|.
    struct Sample {
        double u, g, slope, rho;
        Vec3 w;
    };
    bool nearly_straight = false;  // set below, once the quick path has failed
    bool first_sample = true;
    auto sample = [&](double t, double u) {
        Sample s;
        CentreLine at;
        const Vec3 p = org + t * dir;
        s.u = nearly_straight ? nearest_u_newton(cp, p, u, lo, hi, at)
                              : nearest_u_guarded(cp, p, u, lo, hi, at, first_sample);
        first_sample = false;
        s.w = p - at.c;
        s.rho = length(s.w);
        s.g = s.rho - at.r;
        s.slope = s.rho > 0 ? dot(dir, s.w) / s.rho : 0.0;
        return s;
    };
    // Most proxy hits lie just outside the tube, near the hit: Newton's method on Embree's
    // surface from there finds it at once. A ray that misses the tube, starts inside it or
    // lands on its far side takes the careful search below.
    if (quick_steps > 0) {
        SweepHit root;
        const SweepHit quick =
            onto_normal_plane_tube(cp, org, dir, t_start, std::clamp(u_start, lo, hi), t_min, t_max, &root, quick_steps);
        if (quick.hit && quick.front) return quick;
        if (root.hit) {
            // On the tube past this segment's end where the next segment joins: that
            // segment's proxies hold the point (the caller may test it there).
            if ((root.u < 0 && !piece.curve_begins) || (root.u > 1 && !piece.curve_ends)) {
                SweepHit past;
                past.t = root.t;
                past.u = root.u;
                past.past_joined_end = root.u < 0 ? -1 : 1;
                return past;
            }
            // An entry farther than the nearest hit so far.
            if (root.front && root.t > t_max) return {};
            // Newton's steps jumped to the far wall (a grazing ray): the entry lies before it,
            // and halfway there the ray is inside the tube.
            if (!root.front && root.t > t_start && root.u >= 0 && root.u <= 1) {
                double u = std::clamp(u_start, lo, hi), u_middle = root.u;
                const double g_start = tube_excess(cp, org, dir, t_start, u);
                const double middle = 0.5 * (t_start + root.t);
                const double g_middle = tube_excess(cp, org, dir, middle, u_middle);
                if (g_start > 0 && g_middle < 0) {
                    const SweepHit entry =
                        bracketed_entry(cp, org, dir, t_start, g_start, middle, g_middle, u_middle, t_min, t_max);
                    if (entry.hit && entry.front) return entry;
                }
            } else if (root.u >= 0 && root.u <= 1 && root.t >= t_min) {
                // The far wall before the proxy's hit: a ray that started inside the tube (strands
                // that cross), met by Embree on the proxy's far side; if so this is its hit.
                double u = root.u;
                if (!root.front && root.t <= t_start && tube_excess(cp, org, dir, t_min, u) < 0) return root;
            }
        }
    }
    // The centre line at the piece's ends and its chord bound, for the test below and the
    // bounding sphere of the careful search.
    const CentreLine end_lo = centre_line(cp, lo), end_hi = centre_line(cp, hi);
    const double chord_bound = chord_distance_bound(end_lo, end_hi, lo, hi);
    nearly_straight = nearly_straight_piece(end_lo, end_hi, chord_bound);
    const double tolerance = 1e-7 * (std::fabs(catmull_rom_radius(cp, 0.5 * (lo + hi))) + 1e-9);
    // The piece's sweep lies in the sphere about its chord's middle that holds the chord, the
    // chord bound and the larger end radius: the search stays where the ray is inside it.
    double t_low = t_min, t_high = t_max;
    if (!ray_in_bounding_sphere(end_lo, end_hi, chord_bound, org, dir, t_low, t_high)) return {};
    // A nearly straight piece: the ray's pass by it decides most candidates. A bent one: the
    // passes by its halves, thirds or quarters (the chord bound falls with the square of their
    // length), the nearest hit of any; if each is nearly straight and each pass decides.
    if (nearly_straight) {
        const PassResult pass = pass_by_straight_piece(cp, piece, end_lo, end_hi, org, dir, t_low, t_high, t_min, t_max);
        if (pass.decided) return pass.hit;
    } else if (const double r_min = std::min(end_lo.r, end_hi.r); r_min > 0 && chord_bound < 16 * kNearlyStraight * r_min) {
        const int parts = int(std::ceil(std::sqrt(chord_bound / (kNearlyStraight * r_min))));
        SweepHit nearest;
        bool decided = true;
        CentreLine part_lo = end_lo;
        for (int j = 0; j < parts && decided; ++j) {
            SweepPiece part = piece;
            part.u_begin = lo + (hi - lo) * j / parts;
            part.u_end = j + 1 == parts ? hi : lo + (hi - lo) * (j + 1) / parts;
            const CentreLine part_hi = j + 1 == parts ? end_hi : centre_line(cp, part.u_end);
            const double part_bound = chord_distance_bound(part_lo, part_hi, part.u_begin, part.u_end);
            const double part_t_max = nearest.hit ? std::min(t_max, nearest.t) : t_max;
            double part_low = t_low, part_high = std::min(t_high, part_t_max);
            if (!nearly_straight_piece(part_lo, part_hi, part_bound)) {
                decided = false;
            } else if (part_low <= part_high &&
                       ray_in_bounding_sphere(part_lo, part_hi, part_bound, org, dir, part_low, part_high)) {
                const PassResult pass =
                    pass_by_straight_piece(cp, part, part_lo, part_hi, org, dir, part_low, part_high, t_min, part_t_max);
                decided = pass.decided;
                if (pass.hit.hit && (!nearest.hit || pass.hit.t < nearest.t)) nearest = pass.hit;
            }
            part_lo = part_hi;
        }
        if (decided) return nearest;
    }
    double t = std::clamp(t_start, t_low, t_high);
    Sample at = sample(t, std::clamp(u_start, lo, hi));
    // A proxy hit past the ray's nearest approach to the sweep (the proxy's far side: the ray
    // started inside it): search from where the ray enters the bounding sphere instead.
    if (at.g > 0 && at.slope > 0 && t > t_low) {
        t = t_low;
        at = sample(t, at.u);
    }
    // Outside (g > 0) the search walks to the first root: Newton's step where g falls and the
    // step keeps the sign of g, else the safe step |g| / |dir| (g is a distance, so it cannot
    // pass the surface); inside (g < 0) it walks to the exit the same way.
    bool searching_exit = false;
    for (int i = 0; i < 96; ++i) {
        if (!(at.rho > 0)) return {};
        if (std::fabs(at.g) <= tolerance) {
            // On the sphere sweep: now onto Embree's surface nearby. Near a segment's end
            // Newton may leave for the cubic's continuation past it: then once more from a u
            // inside the segment.
            SweepHit out = onto_normal_plane_tube(cp, org, dir, t, at.u, t_min, t_max);
            if (!out.hit && !(at.u > 0.05 && at.u < 0.95))
                out = onto_normal_plane_tube(cp, org, dir, t, std::clamp(at.u, 0.05, 0.95), t_min, t_max);
            if (out.hit) return out;
            // Entering by the end sphere of an open end (no part of the tube), the ray may
            // still meet the tube's inner wall: go on from where it leaves that sphere.
            if (!at_open_end(at.u) || !(at.slope < 0) || searching_exit) return {};
            t += std::max(-2.0 * dot(dir, at.w) / (dir_length * dir_length), 1e-9 * (std::fabs(t) + 1.0));
            at = sample(t, at.u);
            searching_exit = true;
            if (t > t_high) return {};
            continue;
        }
        const bool outside = at.g > 0;
        // Outside a nearly straight piece and moving away: g has one minimum along the ray,
        // so the ray has passed the tube.
        if (outside && at.slope >= 0 && nearly_straight && !searching_exit) return {};
        const double safe = std::fabs(at.g) / dir_length;
        if ((outside && at.slope < 0) || (!outside && at.slope > 0)) {
            const double newton = -at.g / at.slope;
            const Sample next = sample(t + newton, at.u);
            if (std::fabs(next.g) <= tolerance || ((next.g > 0) == outside && next.g * next.slope < 0)) {
                t += newton;
                at = next;
                if (t > t_high) return {};
                continue;
            }
        }
        t += safe;
        if (t > t_high) return {};
        at = sample(t, at.u);
    }
    return {};
}

#if defined(__x86_64__) && defined(__GNUC__)
// The AVX2 + FMA build (math_simd.h, scalar_avx2): the body and everything it calls inlined here.
HAIRBSDF_SCALAR_AVX2 __attribute__((flatten)) SweepHit intersect_sweep_avx2(const SweepPiece& piece, Vec3 org,
                                                                           Vec3 dir, double t_start, double u_start,
                                                                           double t_min, double t_max, int quick_steps) {
    return intersect_sweep_body(piece, org, dir, t_start, u_start, t_min, t_max, quick_steps);
}
#endif

}  // namespace

SweepHit intersect_sweep(const SweepPiece& piece, Vec3 org, Vec3 dir, double t_start, double u_start, double t_min,
                         double t_max, int quick_steps) {
#if defined(__x86_64__) && defined(__GNUC__)
    if (scalar_avx2()) return intersect_sweep_avx2(piece, org, dir, t_start, u_start, t_min, t_max, quick_steps);
#endif
    return intersect_sweep_body(piece, org, dir, t_start, u_start, t_min, t_max, quick_steps);
}

SweepProxyCone sweep_proxy_cone(const SweepPiece& piece) {
    const Cubic cp(piece.control_points);
    const CentreLine a = centre_line(cp, piece.u_begin), b = centre_line(cp, piece.u_end);
    const double du2 = (piece.u_end - piece.u_begin) * (piece.u_end - piece.u_begin);
    const SecondDerivativeMaxima m = second_derivative_maxima(a, b);
    const double centre_stray = m.centre * du2 / 8.0, radius_stray = m.radius * du2 / 8.0;
    const double r_max = std::max(std::fabs(a.r), std::fabs(b.r));
    const double scale = std::fabs(a.c.x) + std::fabs(a.c.y) + std::fabs(a.c.z) + r_max;
    const double margin = 1e-3 * r_max + 1e-6 * scale;
    const Vec3 chord = b.c - a.c;
    const double run = length(chord);
    SweepProxyCone cone;
    if (!(run > 1e-3 * r_max + 1e-7 * scale)) {
        // A piece shorter than this: a cylinder about its ball (centre a, radius r + strays + run).
        const double reach = r_max + centre_stray + radius_stray + run + margin;
        const Vec3 axis = length(a.dc) > 0 ? normalize(a.dc) : Vec3{1, 0, 0};
        cone.begin = a.c - reach * axis;
        cone.end = a.c + reach * axis;
        cone.begin_radius = cone.end_radius = reach;
        return cone;
    }
    const Vec3 axis = (1.0 / run) * chord;
    const double sin_tilt = std::min(1.0, m.centre * du2 / run);
    const double extension = r_max * sin_tilt + centre_stray + margin;
    const double slope = (b.r - a.r) / run;
    const double widening = centre_stray + radius_stray + 2 * std::fabs(slope) * extension + margin;
    cone.begin = a.c - extension * axis;
    cone.end = b.c + extension * axis;
    cone.begin_radius = std::max(a.r - slope * extension, 0.0) + widening;
    cone.end_radius = std::max(b.r + slope * extension, 0.0) + widening;
    return cone;
}

}  // namespace hairbsdf::render
