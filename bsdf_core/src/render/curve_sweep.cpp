// hairbsdf's ray test of a round Catmull-Rom curve (Embree's surface); see render/curve_sweep.h.
#include "hairbsdf/render/curve_sweep.h"

#include <algorithm>
#include <cmath>

namespace hairbsdf::render {

namespace {

// The centre line, the radius and their first two derivatives in u.
struct CentreLine {
    Vec3 c, dc, ddc;
    double r = 0, dr = 0, ddr = 0;
};

// The segment's Catmull-Rom cubic in the power basis (x, y, z, r; coefficient k of u^k), so that
// each evaluation is a few multiply-adds.
struct Cubic {
    double coefficient[4][4];
    explicit Cubic(const std::array<float, 4>* cp) {
        for (int axis = 0; axis < 4; ++axis) {
            const double p0 = cp[0][axis], p1 = cp[1][axis], p2 = cp[2][axis], p3 = cp[3][axis];
            coefficient[axis][0] = p1;
            coefficient[axis][1] = 0.5 * (p2 - p0);
            coefficient[axis][2] = 0.5 * (2 * p0 - 5 * p1 + 4 * p2 - p3);
            coefficient[axis][3] = 0.5 * (-p0 + 3 * p1 - 3 * p2 + p3);
        }
    }
};

CentreLine centre_line(const Cubic& cp, double u) {
    double value[4], first[4], second[4];
    for (int axis = 0; axis < 4; ++axis) {
        const double* k = cp.coefficient[axis];
        value[axis] = k[0] + u * (k[1] + u * (k[2] + u * k[3]));
        first[axis] = k[1] + u * (2 * k[2] + u * 3 * k[3]);
        second[axis] = 2 * k[2] + u * 6 * k[3];
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

// From a point of the sphere sweep, Newton's method on Embree's own definition of a round
// curve: the point q = org + t dir lies in the normal plane at u, f = (q - c(u)) . T(u) = 0,
// at distance r(u) from the centre line there, |q - c|^2 - f^2 = r(u)^2. With a constant
// radius the two surfaces are one; where the radius changes they part by about r |dr/dc|.
SweepHit onto_normal_plane_tube(const Cubic& cp, Vec3 org, Vec3 dir, double t, double u, double t_min,
                                double t_max, SweepHit* converged = nullptr) {
    for (int i = 0; i < 12; ++i) {
        const CentreLine c = centre_line(cp, u);
        const Vec3 q = org + t * dir, w = q - c.c;
        const double speed = length(c.dc);
        if (!(speed > 0)) return {};
        const Vec3 tangent = (1.0 / speed) * c.dc;
        const Vec3 tangent_du = (1.0 / speed) * (c.ddc - dot(tangent, c.ddc) * tangent);
        const double f = dot(w, tangent);
        const double f_du = -speed + dot(w, tangent_du), f_dt = dot(dir, tangent);
        const double k = dot(w, w) - f * f;
        if (!(k > 0)) return {};
        const double root_k = std::sqrt(k);
        const double g = root_k - c.r;
        const double g_du = (-dot(w, c.dc) - f * f_du) / root_k - c.dr, g_dt = (dot(w, dir) - f * f_dt) / root_k;
        const double tolerance = 1e-7 * (std::fabs(c.r) + 1e-9);
        if (std::fabs(f) <= tolerance && std::fabs(g) <= tolerance) {
            SweepHit out;
            out.hit = true;
            out.t = t;
            out.u = u;
            out.normal = normalize(w - f * tangent);
            out.front = dot(dir, out.normal) < 0;
            if (converged) *converged = out;
            if (!(u >= 0.0 && u <= 1.0 && t >= t_min && t <= t_max)) return {};
            return out;
        }
        const double det = f_du * g_dt - f_dt * g_du;
        if (!(std::fabs(det) > 0)) return {};
        u -= (g_dt * f - f_dt * g) / det;
        t -= (f_du * g - g_du * f) / det;
        if (!std::isfinite(u) || !std::isfinite(t)) return {};
    }
    return {};
}

// Embree's surface along the ray: at q = org + t dir, the foot u of q on the centre line
// (f = (q - c(u)) . c'(u) = 0, Newton's method from `u`) and G = |q - c(u)| - r(u) there.
double tube_excess(const Cubic& cp, Vec3 org, Vec3 dir, double t, double& u) {
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
    return length(q - c.c) - c.r;
}

// The tube's entry between `outside` (G > 0) and `inside` (G < 0) along the ray, by
// regula falsi with the Illinois halving; then Newton's last steps on both equations.
SweepHit bracketed_entry(const Cubic& cp, Vec3 org, Vec3 dir, double outside, double g_outside,
                         double inside, double g_inside, double u, double t_min, double t_max) {
    const double tolerance = 1e-5 * (std::fabs(centre_line(cp, std::clamp(u, 0.0, 1.0)).r) + 1e-9);
    int kept_side = 0;
    for (int i = 0; i < 40; ++i) {
        const double t = outside - g_outside * (inside - outside) / (g_inside - g_outside);
        const double g = tube_excess(cp, org, dir, t, u);
        if (!std::isfinite(g)) return {};
        if (std::fabs(g) <= tolerance) return onto_normal_plane_tube(cp, org, dir, t, u, t_min, t_max);
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

// The chord bound of a piece from its centre line at its ends a = c(u_begin), b = c(u_end).
double chord_distance_bound(const CentreLine& a, const CentreLine& b, double u_begin, double u_end) {
    const double du2 = (u_end - u_begin) * (u_end - u_begin);
    return (std::max(length(a.ddc), length(b.ddc)) + std::max(std::fabs(a.ddr), std::fabs(b.ddr))) * du2 / 8.0;
}

}  // namespace

SweepHit intersect_sweep(const SweepPiece& piece, Vec3 org, Vec3 dir, double t_start, double u_start, double t_min,
                         double t_max) {
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
    {
        SweepHit root;
        const SweepHit quick =
            onto_normal_plane_tube(cp, org, dir, t_start, std::clamp(u_start, lo, hi), t_min, t_max, &root);
        if (quick.hit && quick.front) return quick;
        if (root.hit) {
            // On the tube past this segment's end where the next segment joins: that
            // segment's proxies hold the point.
            if ((root.u < 0 && !piece.curve_begins) || (root.u > 1 && !piece.curve_ends)) return {};
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
    // A piece within a quarter radius of its chord: |p - c(u)| - r(u) has one minimum in u, and
    // along a ray that misses, g has one minimum.
    nearly_straight = chord_bound < 0.25 * std::min(end_lo.r, end_hi.r);
    // A nearly straight piece and a ray outside it: Newton's method for the ray's nearest approach
    // to the tube (where G stops falling). Not inside there: a miss. Inside: the entry lies
    // between the start and there.
    if (nearly_straight) {
        double u = std::clamp(u_start, lo, hi);
        const double g_start = tube_excess(cp, org, dir, t_start, u);
        if (g_start > 0) {
            double t = t_start, g = g_start;
            bool nearest_found = false;
            for (int i = 0; i < 8 && !nearest_found; ++i) {
                const CentreLine c = centre_line(cp, u);
                const Vec3 w = org + t * dir - c.c;
                const double rho = length(w);
                if (!(rho > 0)) break;
                const double slope = dot(dir, w) / rho;
                const double curvature = (dot(dir, dir) - slope * slope) / rho;
                if (!(curvature > 0)) break;
                const double next = t - slope / curvature;
                nearest_found = std::fabs(next - t) <= 1e-9 * (std::fabs(t) + c.r);
                if (!(next >= t_min && next <= t_max)) break;
                t = next;
                g = tube_excess(cp, org, dir, t, u);
                if (g < 0) return bracketed_entry(cp, org, dir, t_start, g_start, t, g, u, t_min, t_max);
            }
            if (nearest_found && g > 0) return {};
        }
    }
    const double tolerance = 1e-7 * (std::fabs(catmull_rom_radius(cp, 0.5 * (lo + hi))) + 1e-9);
    // The piece's sweep lies in the sphere about its chord's middle that holds the chord, the
    // chord bound and the larger end radius: the search stays where the ray is inside it.
    double t_low = t_min, t_high = t_max;
    {
        const Vec3 middle = 0.5 * (end_lo.c + end_hi.c);
        const double radius = 0.5 * length(end_hi.c - end_lo.c) + std::max(end_lo.r, end_hi.r) + chord_bound;
        const Vec3 to_middle = middle - org;
        const double dd = dir_length * dir_length, along = dot(to_middle, dir) / dd;
        const double miss2 = dot(to_middle, to_middle) / dd - along * along;
        const double half2 = radius * radius / dd - miss2;
        if (!(half2 >= 0)) return {};
        const double half = std::sqrt(half2);
        t_low = std::max(t_min, along - half);
        t_high = std::min(t_max, along + half);
        if (!(t_low <= t_high)) return {};
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

double sweep_proxy_widening(const std::array<float, 4>* control_points, double u_begin, double u_end) {
    const Cubic cp(control_points);
    const CentreLine a = centre_line(cp, u_begin), b = centre_line(cp, u_end);
    const double run = length(b.c - a.c), rise = std::fabs(b.r - a.r);
    const double slope_squared = run > 0 ? std::min(1.0, (rise / run) * (rise / run)) : 1.0;
    return chord_distance_bound(a, b, u_begin, u_end) + 0.5 * slope_squared * std::max(a.r, b.r);
}

}  // namespace hairbsdf::render
