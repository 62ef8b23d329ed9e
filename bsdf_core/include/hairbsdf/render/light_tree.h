// Cycles 4.5's light tree: which light next-event estimation picks, and the probability of
// that pick for MIS on BSDF hits. Written from a reading of Cycles'
// scene/light_tree.cpp and kernel/light/tree.h, paraphrased below; no Cycles code is copied.
//
// Design
// * Why: the hair closures' reported pdfs are not their sampling densities, so with MIS the
//   expected image depends on the selection probabilities; matching Cycles' image needs
//   Cycles' probabilities, not only an unbiased estimator.
// * Emitters are the lights of LightSet (same indices): point, spot, area, sun, the world
//   when it is light-sampled (an environment texture with MIS on) and emissive triangles.
//   As in Cycles 4.5, the triangles of each mesh object get their own subtree (built like the
//   top level, bit trail from 0), and the object enters the top level as one "mesh" emitter
//   whose measure is the subtree root's and whose centroid is the object's bounding-box centre;
//   its importance is that node's, and picking it continues the walk in its subtree. Meshes are
//   world space here (Cycles applies the transform of a mesh used once), so no instance
//   transforms. Curves are never emitters in Cycles either.
// * Each emitter has a measure (bbox, bounding cone, energy E). The tree root is
//   an inner node: left = a SAOH-built subtree over the local lights (point, spot, area),
//   right = one "distant" leaf holding the suns and the world (§1.5).
// * The build follows should_split literally (12 buckets, <= 8 emitters per leaf, the
//   same-x quirk, nth_element partitioning with libstdc++), because the cone merge is not
//   associative and the order of merges changes the node measures (§1.3, §1.4).
// * Traversal (§2): at an inner node the left child is taken with
//   pL = (pmax + pmin) / 2 from the children's (I_max, I_min) importances; in a leaf an
//   emitter is taken with (Imax_i / sum Imax + Imin_i / sum Imin) / 2. The random number is
//   rescaled as Cycles does (this only changes which sample maps to which light).
// * pdf(light) follows the light's bit trail from the root and multiplies the same factors:
//   it equals the NEE selection probability at the same (P, N, has_transmission).
// * Importances use std:: trigonometry (Cycles uses fast_* approximations; the difference is
//   ~1e-7 relative, irrelevant for the expected image), with the same function on both sides
//   of the I_min threshold comparison.
// * Not modelled: light linking, volumes (in_volume_segment), mesh lights.
//
// Status and known gaps (see also docs/engine.md):
// * The centroid box, bucket indices, cone merges, energy sums and SAOH costs are single
//   precision as in Cycles (evenly spaced lights sit on bucket boundaries, and symmetric layouts
//   give split costs that tie up to rounding): each reads the measures' double fields rounded to
//   float. Emitter measures are computed in double where Cycles computes them in float (inputs
//   may differ by one float ulp), and importances stay double.
// * World energy: Cycles' importance-map average (the world at the texel centres of the
//   texture's size, or World > Map Resolution; render/lights.cpp), in double where Cycles sums
//   in float; no Nishita sky, so no 0.8 / 0.2 sun blend. The emission estimate is
//   avg(EnvironmentDesc::weight), which is Cycles' rule for one Background node but not for
//   every Mix / Add network.
// * Emitter order: the scene's light order (the exporter's depsgraph order, which Cycles'
//   object order follows), then the mesh emitters in order of their first triangle (Cycles:
//   local lights, then mesh lights, each in object order).
// * has_transmission for a Huang closure outside its ellipse (Entry::Kind::Transparent) is
//   taken as set; unchecked against Cycles (it only matters when mixed with an eval closure).
#pragma once

#include <cstdint>
#include <vector>

#include "hairbsdf/math.h"

namespace hairbsdf::render {

struct LightTreeBBox {
    Vec3 min{1e300, 1e300, 1e300}, max{-1e300, -1e300, -1e300};
    bool valid() const { return min.x <= max.x && min.y <= max.y && min.z <= max.z; }
    void grow(Vec3 p);
    void grow(const LightTreeBBox& b);
    Vec3 center() const { return 0.5 * (min + max); }
    Vec3 size() const { return max - min; }
};

struct LightTreeCone {
    Vec3 axis{0, 0, 0};  // zero: empty cone
    double theta_o = 0, theta_e = 0;
    bool empty() const { return axis.x == 0 && axis.y == 0 && axis.z == 0; }
};

// Cycles' cone merge (not associative; `a` first), in float as Cycles.
LightTreeCone merge_cones(const LightTreeCone& a, const LightTreeCone& b);

struct LightTreeMeasure {
    LightTreeBBox bbox;
    LightTreeCone cone;
    double energy = 0;
    void add(const LightTreeMeasure& other);
    // SAOH cost E * A * M_omega, in float as Cycles (a near tie of two splits then breaks the same way).
    float cost() const;
};

// One light as the tree sees it. Built by LightSet from the scene light (lights.cpp).
struct LightTreeEmitter {
    // Triangle: an emissive mesh triangle. Mesh: one emissive object (made by LightTree from
    // its triangles): its measure is its subtree's, and picking it continues into the subtree.
    enum class Kind { Point, Spot, Area, Sun, World, Triangle, Mesh } kind = Kind::Point;
    LightTreeMeasure measure;
    Vec3 centroid;          // splitting position (local lights)
    // point / spot
    Vec3 position;
    double radius = 0;
    bool sphere = false;    // soft falloff off and radius > 0
    Vec3 spot_dir;          // spot: unit axis the light points along
    double spot_smooth = 0;  // 1 / ((1 - cos(spot_size / 2)) blend)
    // area: centre `position`, facing `normal`, full edge vectors
    Vec3 normal, extent_u, extent_v;
    // sun: unit direction towards the sun (Cycles' ptc)
    Vec3 to_sun;
    // triangle: world-space vertices; triangle / mesh: the object; mesh: its subtree's root node
    Vec3 tri_v[3];
    int object = 0;
    int subtree = -1;
    double energy() const { return measure.energy; }
    bool distant() const { return kind == Kind::Sun || kind == Kind::World; }
};

struct LightTreeImportance {
    double max = 0, min = 0;
};

// Cycles' light_tree_importance (surface version): bounds of a cluster's contribution.
LightTreeImportance light_tree_importance(Vec3 N, bool has_transmission, Vec3 ptc, double cos_theta_u,
                                          const LightTreeCone& cone, double d_max, double d_min, double energy);

class LightTree {
public:
    struct Node {
        LightTreeMeasure measure;
        int left = -1, right = -1;  // children (inner nodes)
        int first = 0, count = -1;  // emitters order_[first, first + count) (leaves; count = -1 inner)
        bool distant = false;
        uint64_t bit_trail = 0;
        int depth = 0;
        bool leaf() const { return count >= 0; }
    };

    // `object_centers`: each mesh object's bounding-box centre (the mesh lights' centroids).
    explicit LightTree(std::vector<LightTreeEmitter> emitters,
                       const std::vector<std::pair<int, Vec3>>& object_centers = {});

    // Picks an emitter (index into the constructor's vector) at shading point P with normal N;
    // -1 when no light has importance. `pdf` = the selection probability.
    int sample(Vec3 P, Vec3 N, bool has_transmission, double u, double& pdf) const;
    // The probability that sample() picks `emitter` at (P, N, has_transmission).
    double pdf(Vec3 P, Vec3 N, bool has_transmission, int emitter) const;

    // Introspection (tests).
    const std::vector<Node>& nodes() const { return nodes_; }
    const std::vector<int>& order() const { return order_; }
    const LightTreeEmitter& emitter(int i) const { return emitters_[size_t(i)]; }
    LightTreeImportance emitter_importance(Vec3 P, Vec3 N, bool has_transmission, int emitter) const;
    LightTreeImportance node_importance(Vec3 P, Vec3 N, bool has_transmission, const Node& node) const;

private:
    int build(int start, int end, uint64_t bit_trail, int depth);
    bool should_split(int start, int end, LightTreeMeasure& measure, int& middle);
    LightTreeImportance child_importance(Vec3 P, Vec3 N, bool t, const Node& node) const;
    // The probability of reaching `target` (an emitter of the subtree at `node`) from `node`;
    // `trail` is the bit trail of the target's leaf within that subtree.
    double subtree_pdf(int node, uint64_t trail, Vec3 P, Vec3 N, bool t, int target) const;
    // Left probability at an inner node; < 0 when both children have zero importance.
    double left_probability(Vec3 P, Vec3 N, bool t, const Node& node) const;

    std::vector<LightTreeEmitter> emitters_;
    std::vector<int> order_;        // emitter indices in leaf order
    std::vector<Node> nodes_;       // nodes_[0] = root
    std::vector<int> leaf_of_;      // emitter -> leaf node
    std::vector<int> mesh_of_;      // triangle emitter -> its object's mesh emitter (-1 for others)
    size_t public_count_ = 0;       // emitters given to the constructor (meshes follow)
};

}  // namespace hairbsdf::render
