// hairbsdf's own ray test of a round Catmull-Rom curve (Cycles' THICK curves), for
// SceneDesc::curve_intersector = Sweep (docs/engine.md, "Curve intersection").
//
// The surface is Embree's: points q = c(u) + r(u) n with n a unit normal of the centre line
// at u (q in the normal plane of c at u, |q - c(u)| = r(u)), u in [0, 1], open at the curve's
// ends; c and r are uniform Catmull-Rom in u (geometry.h). It lies inside the sweep of the
// spheres (c(u), r(u)), whose signed distance g(q) = min over u of |q - c(u)| - r(u) guides
// the careful search. Embree's BVH is built over capped cones (cone linear curves), one per
// piece, `curve_proxy_pieces` pieces per segment, each holding its piece of the tube
// (sweep_proxy_cone). A proxy hit starts Newton's method; its answer is the tube's own hit, or none.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "hairbsdf/math.h"

namespace hairbsdf::render {

// Straight pieces per curve segment in the Sweep intersector's proxies.
inline constexpr int curve_proxy_pieces = 4;

// A segment between two coinciding keys (a key repeated, as exported particle hair can have them) is no tube:
// its centre line leaves the key and comes back, or stays there, and where it stays (c' = 0) Embree's equations
// have a ball of radius r for their surface, which Cycles renders. Newton's method has no normal plane there, so
// Sweep leaves such segments to Embree's own round curves (geometry.cpp): keys within 1e-3 of the radius (and a
// float's step of the coordinates) of each other. Not finite: true.
inline bool sweep_leaves_to_embree(const std::array<float, 4>* segment_control_points) {
    const std::array<float, 4>& a = segment_control_points[1];
    const std::array<float, 4>& b = segment_control_points[2];
    const double dx = double(b[0]) - a[0], dy = double(b[1]) - a[1], dz = double(b[2]) - a[2];
    const double radius = std::max(double(a[3]), double(b[3]));
    const double scale = std::fabs(double(a[0])) + std::fabs(double(a[1])) + std::fabs(double(a[2])) + radius;
    const double apart = 1e-3 * radius + 1e-7 * scale;
    return !(dx * dx + dy * dy + dz * dz > apart * apart);
}

// A piece of one segment: its four Catmull-Rom control points and its range of u.
struct SweepPiece {
    const std::array<float, 4>* control_points;
    double u_begin, u_end;
    // The segment is its curve's first (last): the curve is open there (Embree's and Cycles'
    // round curves have no caps), so nothing past u = 0 (u = 1) is tube.
    bool curve_begins, curve_ends;
};

// Piece `piece` (0 .. curve_proxy_pieces - 1) of the segment whose four control points start at
// `segment_control_points`: u in [piece / k, (piece + 1) / k].
inline SweepPiece proxy_piece(const std::array<float, 4>* segment_control_points, int piece, bool curve_begins,
                              bool curve_ends) {
    constexpr double k = curve_proxy_pieces;
    return {segment_control_points, piece / k, (piece + 1) / k, curve_begins, curve_ends};
}

struct SweepHit {
    bool hit = false;
    double t = 0, u = 0;  // along the ray; in the segment
    Vec3 normal;          // unit, outwards from the centre line, in the normal plane
    bool front = true;    // the ray enters the tube here (false: it leaves, from inside)
    // With no hit: the first root found lies past a joined end of the segment, on the tube of
    // the previous (-1) or next (+1) segment, near t and u (this segment's u, below 0 or above 1).
    int past_joined_end = 0;
};

// The tube's first hit along org + t dir, t in [t_min, t_max], near the proxy's hit
// (t_start, u_start), for the piece's range of u (a hit may lie a little outside it, within
// the segment); none if the ray misses (docs/engine.md lists the steps). `quick_steps`: Newton's
// first steps from the proxy's hit (0 skips them, so that the later steps decide: for tests).
SweepHit intersect_sweep(const SweepPiece& piece, Vec3 org, Vec3 dir, double t_start, double u_start,
                         double t_min, double t_max, int quick_steps = 7);

// The proxy of a piece [u_begin, u_end] (proxy_piece): a capped cone (Embree's cone linear curve) that holds the
// piece's tube, every circle of radius r(u) about c(u) in the normal plane there. Its axis is the
// chord c(u_begin) -> c(u_end), of length L, extended by `extension` at both ends; its radii are the
// chord's, r(u_begin) and r(u_end) interpolated linearly along the axis, widened. The bounds, with
// dc = max |c''| du^2 / 8 and dr = max |r''| du^2 / 8 (how far the centre line and the radius stray
// from their chords; c'' and r'' are linear in u, so their largest norms sit at the piece's ends):
// a circle's centre lies within dc of the chord, and its plane is tilted from the axis by at most
// phi, sin phi <= max |c''| du^2 / L (c' differs from the chord's mean slope by at most max |c''|
// du), so its points lie within r sin phi + dc of the centre's place along the axis: that is the
// extension. Across the axis they lie within dc + r(u) <= dc + dr + the chord's radius at u, and
// since a point may sit `extension` along the axis from its circle's u, the radius's slope times
// that once more (twice, past the chord's ends). Plus 1e-3 r and a float margin.
struct SweepProxyCone {
    Vec3 begin, end;  // the extended axis
    double begin_radius = 0, end_radius = 0;
};
SweepProxyCone sweep_proxy_cone(const SweepPiece& piece);

}  // namespace hairbsdf::render
