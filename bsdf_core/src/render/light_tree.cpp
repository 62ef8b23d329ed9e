// Cycles 4.5's light tree; see render/light_tree.h and docs/engine.md.
#include "hairbsdf/render/light_tree.h"

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <limits>

namespace hairbsdf::render {

namespace {

constexpr int kBuckets = 12;
constexpr int kMaxLeaf = 8;

double safe_sqrt_one_minus_sq(double x) { return std::sqrt(std::max(0.0, 1.0 - x * x)); }
double clamp01(double u) { return std::min(std::max(u, 0.0), 1.0); }
Vec3 vabs(Vec3 a) { return {std::fabs(a.x), std::fabs(a.y), std::fabs(a.z)}; }
double comp(Vec3 a, int d) { return d == 0 ? a.x : (d == 1 ? a.y : a.z); }

Vec3 normalize_len(Vec3 v, double& len) {
    len = length(v);
    return len > 0 ? (1.0 / len) * v : Vec3{0, 0, 1};
}

// Some unit vector orthogonal to unit `a`.
Vec3 any_orthogonal(Vec3 a) {
    const Vec3 t = std::fabs(a.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    return normalize(cross(a, t));
}

double smoothstep01(double x) {
    if (!(x > 0)) return 0.0;
    if (x >= 1) return 1.0;
    return x * x * (3.0 - 2.0 * x);
}

}  // namespace

void LightTreeBBox::grow(Vec3 p) {
    min = {std::min(min.x, p.x), std::min(min.y, p.y), std::min(min.z, p.z)};
    max = {std::max(max.x, p.x), std::max(max.y, p.y), std::max(max.z, p.z)};
}

void LightTreeBBox::grow(const LightTreeBBox& b) {
    if (!b.valid()) return;
    grow(b.min);
    grow(b.max);
}

// In single precision throughout, as Cycles merges its float cones: the merged angles feed the
// SAOH costs, where float rounding decides near ties.
LightTreeCone merge_cones(const LightTreeCone& first, const LightTreeCone& second) {
    if (first.empty()) return second;
    if (second.empty()) return first;
    const bool swap = second.theta_o > first.theta_o;  // ties keep `first` as a
    const LightTreeCone& a = swap ? second : first;
    const LightTreeCone& b = swap ? first : second;
    const float ax = float(a.axis.x), ay = float(a.axis.y), az = float(a.axis.z);
    const float bx = float(b.axis.x), by = float(b.axis.y), bz = float(b.axis.z);
    const float a_theta_o = float(a.theta_o), b_theta_o = float(b.theta_o);
    const float cos_ab = ax * bx + ay * by + az * bz;
    const float theta_d = std::acos(std::min(std::max(cos_ab, -1.0f), 1.0f));
    const double theta_e = std::max(float(a.theta_e), float(b.theta_e));
    const float pi = float(kPi);
    if (a_theta_o + 5e-4f >= std::min(pi, theta_d + b_theta_o)) return {a.axis, a.theta_o, theta_e};
    const float theta_o = (theta_d + a_theta_o + b_theta_o) * 0.5f;
    if (theta_o >= pi) return {a.axis, double(pi), theta_e};
    const float theta_r = theta_o - a_theta_o;
    float ox, oy, oz;
    if (cos_ab < -0.9995f) {
        const Vec3 o = any_orthogonal(a.axis);
        ox = float(o.x), oy = float(o.y), oz = float(o.z);
    } else {
        ox = bx - cos_ab * ax, oy = by - cos_ab * ay, oz = bz - cos_ab * az;
        const float inv_len = 1.0f / std::sqrt(ox * ox + oy * oy + oz * oz);
        ox *= inv_len, oy *= inv_len, oz *= inv_len;
    }
    const float c = std::cos(theta_r), s = std::sin(theta_r);
    const Vec3 axis{double(c * ax + s * ox), double(c * ay + s * oy), double(c * az + s * oz)};
    return {axis, double(theta_o), theta_e};
}

void LightTreeMeasure::add(const LightTreeMeasure& o) {
    if (o.energy == 0) return;
    bbox.grow(o.bbox);
    cone = merge_cones(cone, o.cone);
    energy = double(float(energy) + float(o.energy));
}

// The SAOH measure E * A * M_omega in single precision, in Cycles' order of operations.
float LightTreeMeasure::cost() const {
    if (energy == 0) return 0.0f;
    float area = 0.0f;
    if (bbox.valid()) {
        const float dx = float(bbox.max.x) - float(bbox.min.x), dy = float(bbox.max.y) - float(bbox.min.y),
                    dz = float(bbox.max.z) - float(bbox.min.z);
        area = (dx * dz + dy * dz + dx * dy) * 2.0f;
        if (area == 0.0f) area = std::sqrt(dx * dx + dy * dy + dz * dz);
    }
    float m_omega = 0.0f;
    if (!cone.empty()) {
        const float pi = float(kPi), to = float(cone.theta_o);
        const float tw = std::min(pi, to + float(cone.theta_e));
        const float so = std::sin(to), co = std::cos(to);
        m_omega = 2.0f * pi * (1.0f - co) + 0.5f * pi * (2.0f * tw * so - std::cos(to - 2.0f * tw) - 2.0f * to * so + co);
    }
    return float(energy) * area * m_omega;
}

LightTreeImportance light_tree_importance(Vec3 N, bool has_transmission, Vec3 ptc, double cos_theta_u,
                                          const LightTreeCone& cone, double d_max, double d_min, double energy) {
    LightTreeImportance out;
    const double sin_theta_u = safe_sqrt_one_minus_sq(cos_theta_u);
    // incidence
    double ci = dot(ptc, N);
    if (has_transmission) ci = std::fabs(ci);
    const double si = safe_sqrt_one_minus_sq(ci);
    const double cos_min_i = ci >= cos_theta_u ? 1.0 : ci * cos_theta_u + si * sin_theta_u;
    if (!has_transmission && cos_min_i < 0) return out;
    const double cos_max_i = std::max(0.0, ci * cos_theta_u - si * sin_theta_u);
    // outgoing
    double ct, st;
    if (cone.axis.x == -ptc.x && cone.axis.y == -ptc.y && cone.axis.z == -ptc.z) {
        ct = 1.0;
        st = 0.0;
    } else {
        ct = dot(cone.axis, -1.0 * ptc);
        st = safe_sqrt_one_minus_sq(ct);
    }
    const double c_minus = ct * cos_theta_u + st * sin_theta_u;  // cos(theta - theta_u)
    const double so = std::sin(cone.theta_o), co = std::cos(cone.theta_o);
    double cos_min_o;
    if (ct >= cos_theta_u || c_minus >= co) {
        cos_min_o = 1.0;
    } else if (cone.theta_o + cone.theta_e > kPi || c_minus > std::cos(cone.theta_o + cone.theta_e)) {
        cos_min_o = c_minus * co + safe_sqrt_one_minus_sq(c_minus) * so;
    } else {
        return out;
    }
    out.max = std::fabs(cos_min_i * energy * cos_min_o / (d_min * d_min));
    if (cone.theta_e - cone.theta_o < 0 || ct < 0 || cos_theta_u < 0) return out;
    const double c_plus = ct * cos_theta_u - st * sin_theta_u;  // cos(theta + theta_u)
    if (c_plus < std::cos(cone.theta_e - cone.theta_o)) return out;
    const double cos_max_o = c_plus * co - safe_sqrt_one_minus_sq(c_plus) * so;
    out.min = std::fabs(cos_max_i * energy * cos_max_o / (d_max * d_max));
    return out;
}

// ---------------------------------------------------------------------------------------
// Build

LightTree::LightTree(std::vector<LightTreeEmitter> emitters, const std::vector<std::pair<int, Vec3>>& object_centers)
    : emitters_(std::move(emitters)) {
    public_count_ = emitters_.size();
    std::vector<int> local, distant;
    std::vector<std::pair<int, std::vector<int>>> meshes;  // object -> its triangle emitters
    for (size_t i = 0; i < public_count_; ++i) {
        const LightTreeEmitter& e = emitters_[i];
        if (e.kind == LightTreeEmitter::Kind::Triangle) {
            auto it = std::find_if(meshes.begin(), meshes.end(), [&](const auto& m) { return m.first == e.object; });
            if (it == meshes.end()) {
                meshes.push_back({e.object, {}});
                it = meshes.end() - 1;
            }
            it->second.push_back(int(i));
        } else {
            (e.distant() ? distant : local).push_back(int(i));
        }
    }
    // Order: triangles (mesh by mesh), local lights, mesh emitters, distant lights (Cycles' layout).
    order_.clear();
    for (const auto& m : meshes) order_.insert(order_.end(), m.second.begin(), m.second.end());
    const int triangles = int(order_.size());
    leaf_of_.assign(public_count_ + meshes.size(), -1);
    mesh_of_.assign(public_count_ + meshes.size(), -1);
    nodes_.push_back(Node{});  // root
    nodes_[0].count = -1;
    int start = 0;
    for (const auto& m : meshes) {
        const int end = start + int(m.second.size());
        LightTreeEmitter mesh;
        mesh.kind = LightTreeEmitter::Kind::Mesh;
        mesh.object = m.first;
        mesh.subtree = build(start, end, 0, 0);
        mesh.measure = nodes_[size_t(mesh.subtree)].measure;
        mesh.centroid = mesh.measure.bbox.center();
        for (const auto& c : object_centers)
            if (c.first == m.first) mesh.centroid = c.second;
        const int index = int(emitters_.size());
        for (int k = start; k < end; ++k) mesh_of_[size_t(order_[size_t(k)])] = index;
        emitters_.push_back(mesh);
        start = end;
    }
    order_.insert(order_.end(), local.begin(), local.end());
    for (size_t k = 0; k < meshes.size(); ++k) order_.push_back(int(public_count_ + k));
    const int local_end = int(order_.size());
    order_.insert(order_.end(), distant.begin(), distant.end());
    const int left = build(triangles, local_end, 0, 1);
    Node d;
    d.distant = true;
    d.first = local_end;
    d.count = int(distant.size());
    d.bit_trail = 1;
    d.depth = 1;
    for (int k = d.first; k < d.first + d.count; ++k) d.measure.add(emitters_[size_t(order_[size_t(k)])].measure);
    const int right = int(nodes_.size());
    nodes_.push_back(d);
    for (int k = d.first; k < d.first + d.count; ++k) leaf_of_[size_t(order_[size_t(k)])] = right;
    nodes_[0].left = left;
    nodes_[0].right = right;
    nodes_[0].measure = nodes_[size_t(left)].measure;
    nodes_[0].measure.add(d.measure);
}

bool LightTree::should_split(int start, int end, LightTreeMeasure& measure, int& middle) {
    middle = (start + end) / 2;
    const int n = end - start;
    if (n < 2) {
        measure = n == 1 ? emitters_[size_t(order_[size_t(start)])].measure : LightTreeMeasure{};
        return false;
    }
    // The centroid box, extents and bucket indices in single precision as Cycles computes them
    // (evenly spaced lights put centroids on bucket boundaries, where rounding decides).
    std::array<float, 3> cmin{FLT_MAX, FLT_MAX, FLT_MAX}, cmax{-FLT_MAX, -FLT_MAX, -FLT_MAX}, extf{};
    for (int k = start; k < end; ++k) {
        const Vec3 c = emitters_[size_t(order_[size_t(k)])].centroid;
        for (int d = 0; d < 3; ++d) {
            cmin[size_t(d)] = std::min(cmin[size_t(d)], float(comp(c, d)));
            cmax[size_t(d)] = std::max(cmax[size_t(d)], float(comp(c, d)));
        }
    }
    for (int d = 0; d < 3; ++d) extf[size_t(d)] = cmax[size_t(d)] - cmin[size_t(d)];
    const float max_extent = std::max(std::max(extf[0], extf[1]), std::max(extf[2], 0.0f));
    auto bucket_of = [&](const LightTreeEmitter& e, int dim) {
        const float inv_extent = 1.0f / extf[size_t(dim)];
        const int b = int(float(kBuckets) * (float(comp(e.centroid, dim)) - cmin[size_t(dim)]) * inv_extent);
        return std::min(std::max(b, 0), kBuckets - 1);
    };
    float total_cost = 0.0f, best = FLT_MAX;
    int best_dim = -1, best_bucket = -1;
    for (int dim = 0; dim < 3; ++dim) {
        const float ext = extf[size_t(dim)];
        if (ext == 0 && dim != 0) continue;
        std::array<LightTreeMeasure, kBuckets> bucket{};
        for (int k = start; k < end; ++k) {
            const LightTreeEmitter& e = emitters_[size_t(order_[size_t(k)])];
            bucket[size_t(ext != 0 ? bucket_of(e, dim) : 0)].add(e.measure);
        }
        std::array<LightTreeMeasure, kBuckets - 1> left{}, right{};  // right[i]: buckets i+1..11
        left[0] = bucket[0];
        for (int i = 1; i < kBuckets - 1; ++i) {
            left[size_t(i)] = left[size_t(i - 1)];
            left[size_t(i)].add(bucket[size_t(i)]);
        }
        right[kBuckets - 2] = bucket[kBuckets - 1];
        for (int i = kBuckets - 3; i >= 0; --i) {
            right[size_t(i)] = right[size_t(i + 1)];
            right[size_t(i)].add(bucket[size_t(i + 1)]);
        }
        if (dim == 0) {
            measure = left[kBuckets - 2];
            measure.add(bucket[kBuckets - 1]);
            if (ext == 0) continue;  // quirk (a): total_cost stays 0, so no SAOH split at all
            total_cost = measure.cost();
            if (total_cost == 0) break;  // quirk (c)
        }
        const float regularization = max_extent * (1.0f / ext);
        for (int i = 0; i < kBuckets - 1; ++i) {
            const float c = regularization * (left[size_t(i)].cost() + right[size_t(i)].cost());
            if (c < total_cost && c < best) {
                best = c;
                best_dim = dim;
                best_bucket = i;
            }
        }
    }
    if (best_dim >= 0 && best < total_cost) {
        // The emitters in buckets 0..best_bucket go first.
        int count = 0;
        for (int k = start; k < end; ++k)
            if (bucket_of(emitters_[size_t(order_[size_t(k)])], best_dim) <= best_bucket) ++count;
        middle = start + count;
        const int dim = best_dim;
        std::nth_element(order_.begin() + start, order_.begin() + middle, order_.begin() + end, [&](int a, int b) {
            return float(comp(emitters_[size_t(a)].centroid, dim)) < float(comp(emitters_[size_t(b)].centroid, dim));
        });
        return true;
    }
    return n > kMaxLeaf;
}

int LightTree::build(int start, int end, uint64_t bit_trail, int depth) {
    const int index = int(nodes_.size());
    nodes_.push_back(Node{});
    LightTreeMeasure measure;
    int middle = 0;
    const bool split = should_split(start, end, measure, middle);
    nodes_[size_t(index)].measure = measure;
    nodes_[size_t(index)].bit_trail = bit_trail;
    nodes_[size_t(index)].depth = depth;
    if (!split) {
        nodes_[size_t(index)].first = start;
        nodes_[size_t(index)].count = end - start;
        for (int k = start; k < end; ++k) leaf_of_[size_t(order_[size_t(k)])] = index;
        return index;
    }
    const int l = build(start, middle, bit_trail, depth + 1);
    const int r = build(middle, end, bit_trail | (uint64_t(1) << depth), depth + 1);
    nodes_[size_t(index)].left = l;
    nodes_[size_t(index)].right = r;
    nodes_[size_t(index)].count = -1;
    return index;
}

// ---------------------------------------------------------------------------------------
// Importance

LightTreeImportance LightTree::emitter_importance(Vec3 P, Vec3 N, bool t, int index) const {
    const LightTreeEmitter& e = emitters_[size_t(index)];
    if (e.kind == LightTreeEmitter::Kind::Mesh) return node_importance(P, N, t, nodes_[size_t(e.subtree)]);
    double energy = e.energy();
    LightTreeCone cone = e.measure.cone;
    Vec3 ptc;
    double cos_u = 1, d_max = 1, d_min = 1;
    bool visible = true;
    switch (e.kind) {
        case LightTreeEmitter::Kind::Point:
        case LightTreeEmitter::Kind::Spot: {
            double d;
            ptc = normalize_len(e.position - P, d);
            const double r = e.radius;
            if (e.sphere) {
                if (d > r) {
                    cos_u = std::sqrt(std::max(0.0, 1.0 - sqr(r / d)));
                    d_max = d / cos_u;
                    d_min = d;
                } else {
                    cos_u = -1.0;
                    d_max = d_min = r / std::sqrt(2.0);
                }
            } else {
                const double h = std::sqrt(r * r + d * d);
                cos_u = d / h;
                d_max = h;
                d_min = d;
            }
            if (e.kind == LightTreeEmitter::Kind::Point) {
                cone = {-1.0 * ptc, 0.0, kPi / 2};  // axis = normalize(P - c): cos theta = 1
            } else {
                cone = {e.spot_dir, 0.0, e.measure.cone.theta_e};
                const double a = std::acos(std::min(std::max(dot(e.spot_dir, -1.0 * ptc), -1.0), 1.0));
                const double u = std::acos(std::min(std::max(cos_u, -1.0), 1.0));
                energy *= smoothstep01((std::cos(std::max(0.0, a - u)) - std::cos(cone.theta_e)) * e.spot_smooth);
            }
            break;
        }
        case LightTreeEmitter::Kind::Area: {
            double d;
            ptc = normalize_len(e.position - P, d);
            cone = {e.normal, 0.0, e.measure.cone.theta_e};
            cos_u = 1.0;
            d_max = d;
            d_min = d;
            for (int i = 0; i < 4; ++i) {
                const Vec3 corner = e.position + ((i & 1) ? 0.5 : -0.5) * e.extent_u + ((i & 2) ? 0.5 : -0.5) * e.extent_v;
                double dc;
                const Vec3 w = normalize_len(corner - P, dc);
                cos_u = std::min(cos_u, dot(ptc, w));
                d_max = std::max(d_max, dc);
            }
            const bool front = dot(e.normal, ptc) < 0;
            const bool above = dot(N, e.position - P) + std::fabs(dot(N, e.extent_u)) + std::fabs(dot(N, e.extent_v)) > 0;
            visible = front && above;
            break;
        }
        case LightTreeEmitter::Kind::Sun: {
            ptc = e.to_sun;
            cone = {-1.0 * e.to_sun, 0.0, e.measure.cone.theta_e};
            cos_u = std::cos(cone.theta_e);
            d_max = 1.0 / cos_u;
            d_min = 1.0;
            break;
        }
        case LightTreeEmitter::Kind::World: {
            ptc = {0, 0, -1};
            cone = {{0, 0, -1}, kPi, 0.0};
            cos_u = -1.0;
            break;
        }
        case LightTreeEmitter::Kind::Triangle: {
            // Cycles' triangle_light_tree_parameters: distances from the centroid and the
            // corners, the widest corner angle; visible when the emitting side faces P (or
            // two-sided) and a corner is above the surface.
            double d;
            ptc = normalize_len(e.centroid - P, d);
            d_min = d;
            d_max = d;
            cos_u = 1e300;
            bool above = false;
            for (int i = 0; i < 3; ++i) {
                double dc;
                const Vec3 w = normalize_len(e.tri_v[i] - P, dc);
                cos_u = std::min(cos_u, dot(ptc, w));
                above = above || dot(w, N) > 0;
                d_max = std::max(d_max, dc);
            }
            const bool front = cone.theta_o != 0 || dot(cone.axis, ptc) < 0;
            visible = front && above;
            break;
        }
        case LightTreeEmitter::Kind::Mesh:
            return {};  // handled above
    }
    visible = visible || t;
    if (!visible) return {};
    return light_tree_importance(N, t, ptc, cos_u, cone, d_max, d_min, energy);
}

LightTreeImportance LightTree::node_importance(Vec3 P, Vec3 N, bool t, const Node& node) const {
    const LightTreeMeasure& m = node.measure;
    if (node.distant) {
        const Vec3 ptc = -1.0 * m.cone.axis;
        return light_tree_importance(N, t, ptc, std::cos(m.cone.theta_o + m.cone.theta_e), m.cone, 1.0, 1.0,
                                     m.energy);
    }
    if (!m.bbox.valid() || m.energy == 0) return {};
    const Vec3 c = m.bbox.center();
    const Vec3 half = vabs(m.bbox.max - c);
    if (!t && dot(N, c - P) + dot(vabs(N), half) <= 0) return {};
    double d;
    const Vec3 ptc = normalize_len(c - P, d);
    const double r2 = dot(m.bbox.max - c, m.bbox.max - c);
    const double dist2 = dot(P - c, P - c);
    const double cos_u = dist2 <= r2 ? -1.0 : std::sqrt(1.0 - r2 / dist2);
    d = std::max(d, 0.5 * std::sqrt(r2));
    return light_tree_importance(N, t, ptc, cos_u, m.cone, d, d, m.energy);
}

LightTreeImportance LightTree::child_importance(Vec3 P, Vec3 N, bool t, const Node& node) const {
    if (node.count == 0) return {};
    if (node.count == 1) return emitter_importance(P, N, t, order_[size_t(node.first)]);
    return node_importance(P, N, t, node);
}

double LightTree::left_probability(Vec3 P, Vec3 N, bool t, const Node& node) const {
    const LightTreeImportance L = child_importance(P, N, t, nodes_[size_t(node.left)]);
    const LightTreeImportance R = child_importance(P, N, t, nodes_[size_t(node.right)]);
    if (!(L.max + R.max > 0)) return -1.0;
    const double p_max = L.max / (L.max + R.max);
    const double p_min = L.min + R.min > 0 ? L.min / (L.min + R.min)
                                           : 0.5 * (double(L.max > 0) + double(R.max == 0));
    return 0.5 * (p_max + p_min);
}

// ---------------------------------------------------------------------------------------
// Traversal

int LightTree::sample(Vec3 P, Vec3 N, bool t, double u, double& pdf) const {
    pdf = 0.0;
    if (emitters_.empty()) return -1;
    double p = 1.0;
    int node = 0;
    for (;;) {  // the top level, then (a mesh emitter picked) its subtree
    while (!nodes_[size_t(node)].leaf()) {
        const Node& n = nodes_[size_t(node)];
        const double pl = left_probability(P, N, t, n);
        if (pl < 0) return -1;
        const double pr = 1.0 - pl;
        if (pr > 0 && u <= pr) {
            node = n.right;
            p *= pr;
            u = clamp01(u / pr);
        } else {
            node = n.left;
            p *= pl;
            if (pr > 0) u = clamp01((u - pr) / (1.0 - pr));
        }
    }
    const Node& leaf = nodes_[size_t(node)];
    if (leaf.count <= 0) return -1;
    const bool use_max = u > 0.5;
    if (leaf.count > 1) u = 2.0 * u - (use_max ? 1.0 : 0.0);
    double sum_max = 0, sum_min = 0;
    int positive = 0;
    std::array<LightTreeImportance, 64> small{};
    std::vector<LightTreeImportance> big;
    LightTreeImportance* imp = small.data();
    if (leaf.count > int(small.size())) {
        big.resize(size_t(leaf.count));
        imp = big.data();
    }
    for (int k = 0; k < leaf.count; ++k) {
        imp[k] = emitter_importance(P, N, t, order_[size_t(leaf.first + k)]);
        sum_max += imp[k].max;
        sum_min += imp[k].min;
        if (imp[k].max > 0) ++positive;
    }
    if (positive == 0) return -1;
    const bool uniform = !(sum_min > 0);
    // Weighted reservoir over the leaf (Cycles' order and rescaling).
    int chosen = -1;
    double total = 0;
    for (int k = 0; k < leaf.count; ++k) {
        const double w = use_max ? imp[k].max : (uniform ? (imp[k].max > 0 ? 1.0 : 0.0) : imp[k].min);
        if (!(w > 0)) continue;
        total += w;
        if (chosen < 0) {
            chosen = k;
            continue;
        }
        const double th = w / total;
        if (u <= th) {
            chosen = k;
            u = clamp01(u / th);
        } else {
            u = clamp01((u - th) / (1.0 - th));
        }
    }
    if (chosen < 0) return -1;
    const double pe = 0.5 * (imp[chosen].max / sum_max + (uniform ? 1.0 / positive : imp[chosen].min / sum_min));
    p *= pe;
    const int picked = order_[size_t(leaf.first + chosen)];
    if (emitters_[size_t(picked)].kind == LightTreeEmitter::Kind::Mesh) {
        node = emitters_[size_t(picked)].subtree;  // continue in the object's subtree
        continue;
    }
    pdf = p;
    return picked;
    }
}

double LightTree::pdf(Vec3 P, Vec3 N, bool t, int emitter) const {
    if (emitter < 0 || size_t(emitter) >= public_count_) return 0.0;
    const int mesh = mesh_of_[size_t(emitter)];
    const int top_target = mesh >= 0 ? mesh : emitter;
    double p = subtree_pdf(0, nodes_[size_t(leaf_of_[size_t(top_target)])].bit_trail, P, N, t, top_target);
    if (mesh < 0 || !(p > 0)) return p;
    // A triangle: then from its object's subtree root, by its leaf's trail there.
    return p * subtree_pdf(emitters_[size_t(mesh)].subtree, nodes_[size_t(leaf_of_[size_t(emitter)])].bit_trail, P, N,
                           t, emitter);
}

double LightTree::subtree_pdf(int node, uint64_t trail, Vec3 P, Vec3 N, bool t, int emitter) const {
    double p = 1.0;
    int depth = 0;
    while (!nodes_[size_t(node)].leaf()) {
        const Node& n = nodes_[size_t(node)];
        const double pl = left_probability(P, N, t, n);
        if (pl < 0) return 0.0;
        if ((trail >> depth) & 1) {
            p *= 1.0 - pl;
            node = n.right;
        } else {
            p *= pl;
            node = n.left;
        }
        ++depth;
    }
    const Node& leaf = nodes_[size_t(node)];
    double sum_max = 0, sum_min = 0, t_max = 0, t_min = 0;
    int positive = 0;
    for (int k = 0; k < leaf.count; ++k) {
        const int e = order_[size_t(leaf.first + k)];
        const LightTreeImportance imp = emitter_importance(P, N, t, e);
        sum_max += imp.max;
        sum_min += imp.min;
        if (imp.max > 0) ++positive;
        if (e == emitter) {
            t_max = imp.max;
            t_min = imp.min;
        }
    }
    if (!(t_max > 0)) return 0.0;
    if (leaf.count == 1) return p;
    return p * 0.5 * (t_max / sum_max + (sum_min > 0 ? t_min / sum_min : 1.0 / positive));
}

}  // namespace hairbsdf::render
