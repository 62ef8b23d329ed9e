// hairbsdf's own ray test of a round Catmull-Rom curve (Cycles' THICK curves), for
// SceneDesc::curve_intersector = Sweep (docs/engine.md, "Curve intersection").
//
// The surface is Embree's: points q = c(u) + r(u) n with n a unit normal of the centre line
// at u (q in the normal plane of c at u, |q - c(u)| = r(u)), u in [0, 1], open at the curve's
// ends; c and r are uniform Catmull-Rom in u (geometry.h). It lies inside the sweep of the
// spheres (c(u), r(u)), whose signed distance g(q) = min over u of |q - c(u)| - r(u) guides
// the careful search. Embree's BVH is built over round *linear* proxies, `curve_proxy_pieces`
// straight pieces per segment whose radii are widened by a bound on the piece's distance from
// its chord, so every point of the sweep lies inside some proxy. A proxy hit starts Newton's
// method; its answer is the tube's own hit, or none.
#pragma once

#include <array>
#include <cstdint>

#include "hairbsdf/math.h"

namespace hairbsdf::render {

// Straight pieces per curve segment in the Sweep intersector's proxies.
inline constexpr int curve_proxy_pieces = 4;

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

// How much a proxy's radii grow so that it holds its piece [u_begin, u_end] of the sweep: how
// far the piece's centre line and radius may stray from their chords, max |c''| du^2 / 8 +
// max |r''| du^2 / 8 (c'' and r'' are linear in u, so their largest norms sit at the piece's
// ends), plus r s^2 / 2 for the slope s = dr / dx of its radius (a sphere of the sweep bulges
// past a cone through the circles by up to that much). One evaluation of the cubic at each end.
double sweep_proxy_widening(const std::array<float, 4>* control_points, double u_begin, double u_end);

}  // namespace hairbsdf::render
