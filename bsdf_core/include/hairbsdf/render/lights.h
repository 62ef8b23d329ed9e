// Lights with Cycles' units and normalisation (scene/light.cpp, kernel/light/*.h, 4.5).
//
// `strength` is Blender's color x energy. Radiance = strength x eval_fac, with
//   POINT / SPOT: eval_fac = 1 / (pi * area), area = 4 pi r^2 (4 when r = 0), so a light of
//     P watts has intensity P / (4 pi) W/sr. soft_falloff (Blender's default) makes it a
//     disk of radius r facing the shading point; otherwise (r > 0) a sphere. SPOT multiplies
//     by smoothstep((cos_angle - cos(spot_size / 2)) / ((1 - cos(spot_size / 2)) spot_blend)),
//     the angle measured in the light's local frame (object scale included); with
//     spot_cosine (Cycles < 4.0, set by the exporter for Blender 3.x, which also drops the
//     scale) times the cosine of the angle to the axis.
//   SUN: eval_fac = 1 / (pi sin^2(angle / 2)) on a cone of half-angle angle / 2, so the
//     irradiance at normal incidence equals strength; a delta light for angle 0.
//   AREA: eval_fac = 1 / (pi * area), area = |u| |v| (x pi/4 for DISK / ELLIPSE), one-sided
//     along the light's -Z; spread < pi attenuates by max((tan(spread/2) - tan a) N, 0)
//     with Cycles' normalisation N. Squares and rectangles are sampled uniformly in the
//     solid angle they subtend (Urena et al. 2013), as Cycles samples them: the light pdf
//     enters the MIS weights, and area sampling has heavy tails near the light. With spread
//     < pi the rectangle is first clipped to the square around the disk that can light the
//     point (Cycles too). Disks and ellipses are sampled by area (Cycles too).
//   WORLD: uniform radiance plus an optional environment texture (render/environment.h).
// `normalize = false` drops the 1 / area factor, as Cycles does.
//
// Next-event estimation picks a light with Cycles' light distribution (Cycles 3.x, and 4.x with
// the tree off: lamps equally likely, emissive triangles by area, half each when both exist) or
// (integrator `light_tree`, Cycles 4.x's default) with Cycles' light tree (render/light_tree.h).
// Picks with other pdfs would have the same expectation only where the closures' reported pdfs
// are their sampling densities, which the hair closures' are not: hence Cycles' own picks.
// Emissive mesh triangles (Cycles' mesh lights) follow the lamps in the light list; the
// integrator evaluates their material's emission at the sampled point. A light takes part in MIS (Cycles' SHADER_USE_MIS) when it can be
// hit by BSDF rays: POINT / SPOT with r > 0, SUN with angle > 0, AREA with spread > 0, the
// world; and use_mis is set. Lights are not in the BVH: rays pass through them (Cycles
// counts each as a transparent bounce) and they cast no shadows.
// The world is a light (sampled by NEE, MIS on BSDF rays) only when it varies with direction
// (an environment texture) and its MIS setting is on, Cycles' rule for the background light;
// a uniform world is reached by BSDF rays alone, at full weight. The estimators differ only
// where a closure's reported pdf is not its sampling density (Chiang's Coat and truncated
// series, Huang's pdf of 1): there Cycles' result depends on it.
#pragma once

#include <memory>
#include <vector>

#include "hairbsdf/render/environment.h"
#include "hairbsdf/render/geometry.h"
#include "hairbsdf/render/light_tree.h"

namespace hairbsdf::render {

struct LightSample {
    Vec3 wi;            // unit direction from the shading point towards the light
    double distance = 0;  // to the sampled point; infinity for sun and world
    RGB radiance;       // strength x eval_fac x attenuation
    double pdf = 0;     // solid-angle density of this light's sampler (selection excluded)
    bool use_mis = false;
    // An emissive triangle: the triangle and the sampled point's barycentrics (Embree's u, v:
    // point = (1 - u - v) v0 + u v1 + v v2). `radiance` is left 0: the integrator evaluates the
    // triangle's material there.
    int triangle = -1;
    double u = 0, v = 0;
};

// An emissive mesh triangle as a light (Cycles' mesh lights): world-space vertices, the sides
// next-event estimation samples (EmissionSampling), the emission estimate for the light tree.
struct TriangleLightDesc {
    Vec3 v0, v1, v2;
    int prim = -1, object = 0;
    bool front = true, back = true;
    double estimate = 0;  // average |emission estimate| (Cycles' shader->emission_estimate)
};

// A light hit by a ray: where, what it emits towards the ray origin, and the density
// with which next-event estimation would have sampled this direction.
struct LightHit {
    double t = 0;
    RGB radiance;
    double pdf = 0;
    int light = -1;
};

struct SphericalRectangle;  // lights.cpp
struct RectangleView;       // lights.cpp: an optional SphericalRectangle and `unreachable`

class Light {
public:
    Light(const LightDesc& desc);       // scene light
    // The world: uniform radiance plus the environment texture, if any. `map_resolution`: the light
    // tree's importance map (SceneDesc::world_map_resolution); `tree_energy` false skips that map.
    Light(RGB world_radiance, const EnvironmentDesc& texture, bool world_mis = true, int map_resolution = 0,
          bool tree_energy = true);
    explicit Light(const TriangleLightDesc& triangle);  // an emissive triangle
    bool is_world() const { return world_; }
    int triangle() const { return triangle_; }  // the mesh triangle, or -1
    double triangle_area() const { return area_; }
    // Whether next-event estimation samples the triangle's back side (true) / front side (false):
    // Cycles' SD_MIS_BACK / SD_MIS_FRONT, which also decide MIS on BSDF hits of that side.
    bool samples_side(bool back) const { return back ? tri_back_ : tri_front_; }
    // Emissive triangle: the solid-angle density with which sample() from `origin` picks the
    // point `on_light` (Cycles' triangle_light_pdf, selection excluded).
    double triangle_pdf(Vec3 origin, Vec3 on_light) const;
    bool is_distant() const { return world_ || type_ == LightType::Sun; }
    bool use_mis() const { return use_mis_; }
    bool visible_camera() const { return visible_camera_; }
    bool has_contribution() const { return contributes_; }
    // The light's measure and traversal data for the light tree.
    const LightTreeEmitter& tree_emitter() const { return tree_; }

    bool sample(Vec3 p, double u0, double u1, LightSample& out) const;
    // Finite lights (point, spot, area): the hit along `ray` in (tmin, tmax), if any.
    bool intersect(const Ray& ray, double tmax, LightHit& out) const;
    // Sun and world: radiance arriving from direction `dir` (towards the light).
    bool eval_direction(Vec3 dir, LightHit& out) const;

private:
    double spot_attenuation(Vec3 from_light) const;
    double spread_attenuation(Vec3 to_light) const;
    // Rectangles are sampled uniformly in solid angle, as Cycles does: the rectangle as seen from
    // p, clipped for a spread < 180 deg to the square around the disk that can light p. No
    // rectangle for ellipses and rectangles too small to measure from p, which are sampled
    // uniformly over their area; `unreachable` when no part of a narrowed spread reaches p.
    RectangleView solid_angle_rectangle(Vec3 p) const;

    void make_tree_emitter(const LightDesc* desc, int map_resolution = 0, bool tree_energy = true);
    bool sample_triangle(Vec3 p, double u0, double u1, LightSample& out) const;
    // Cycles' choice between solid-angle and area sampling of a triangle seen from p.
    bool triangle_uses_solid_angle(Vec3 p) const;

    bool world_ = false;
    int triangle_ = -1;
    Vec3 tri_v_[3];
    bool tri_front_ = true, tri_back_ = true;
    LightTreeEmitter tree_;
    std::shared_ptr<const EnvironmentMap> environment_;  // world texture, or null
    bool contributes_ = true;
    bool use_mis_ = true;
    bool visible_camera_ = true;
    LightType type_ = LightType::Point;
    RGB radiance_;  // strength x eval_fac (before attenuation)
    Vec3 co_;       // position, or direction towards the sun
    // point / spot
    double radius_ = 0;
    bool sphere_ = false;
    Vec3 spot_dir_;                   // unit spot axis
    std::array<double, 9> spot_inv_{};  // inverse of the light's 3x3 matrix
    double cos_half_spot_ = 0, spot_smooth_ = 0, cos_half_larger_spread_ = 1;
    bool spot_cosine_ = false;        // Cycles < 4.0: attenuation also x cos(angle to the axis)
    // sun
    double half_angle_ = 0, one_minus_cos_ = 0, sun_pdf_ = 1;
    // area
    Vec3 axis_u_, axis_v_, normal_;
    double len_u_ = 0, len_v_ = 0, area_ = 0;
    bool ellipse_ = false;
    double tan_half_spread_ = 0, normalize_spread_ = 0;
    bool full_spread_ = true;
};

// Where a light is picked: the shading point, its shading normal (Cycles' sd->N; the radial
// normal on curves) and whether a closure transmits (SD_BSDF_HAS_TRANSMISSION; hair does).
struct LightPickContext {
    Vec3 p, n;
    bool transmission = false;
};

class LightSet {
public:
    LightSet(const SceneDesc& scene);
    size_t size() const { return lights_.size(); }
    // Lights before this index are lamps (and the world); the rest are emissive triangles.
    size_t lamp_count() const { return lamps_; }
    // The light of mesh triangle `prim`, or -1 when it is not light-sampled.
    int triangle_light(int prim) const {
        return prim >= 0 && size_t(prim) < triangle_light_.size() ? triangle_light_[size_t(prim)] : -1;
    }
    const Light& light(size_t i) const { return lights_[i]; }
    bool uses_tree() const { return tree_ != nullptr; }
    const LightTree* tree() const { return tree_.get(); }
    // The probability that sample() picks light `i` at `at`. Without the tree, Cycles 3.x's
    // light distribution: lamps (the world counting as one) equally likely, triangles by area,
    // each group half the probability when both exist.
    double selection_pdf(int i, const LightPickContext& at) const {
        if (lights_.empty() || i < 0) return 0.0;
        if (tree_) return tree_->pdf(at.p, at.n, at.transmission, i);
        if (size_t(i) < lamps_) return lamp_share_ / double(lamps_);
        return (1.0 - lamp_share_) * lights_[size_t(i)].triangle_area() / triangle_area_total_;
    }
    bool has_finite_mis_lights(bool camera) const { return camera ? has_finite_camera_ : has_finite_mis_; }

    // Picks a light with u_select and samples it; out.pdf includes the selection probability.
    bool sample(const LightPickContext& at, double u_select, double u0, double u1, LightSample& out) const;
    // The world's index in lights(), or -1 when it is not sampled.
    int world_index() const { return world_; }

    // Finite lights crossed by `ray` before `tmax`, sorted by distance. Camera rays see the
    // lights with a surface that are visible to the camera (visible_camera); other rays only
    // MIS lights. Returns the number written (<= 8).
    int intersect(const Ray& ray, double tmax, bool camera_ray, LightHit* hits, int max_hits) const;
    // Sun discs crossed by an escaping ray. Same visibility rule. Returns the number written.
    int eval_suns(Vec3 dir, bool camera_ray, LightHit* hits, int max_hits) const;
    // The world, if any: in lights() when it is sampled (use_mis), kept aside otherwise.
    const Light* world() const { return world_ >= 0 ? &lights_[size_t(world_)] : background_.get(); }

private:
    void add_triangle_lights(const SceneDesc& scene);
    std::vector<Light> lights_;  // the lights NEE picks from: lamps, the world, emissive triangles
    size_t lamps_ = 0;
    double lamp_share_ = 1.0;               // distribution: the lamps' total probability
    double triangle_area_total_ = 0.0;
    std::vector<double> triangle_cdf_;      // distribution: cumulative triangle areas
    std::vector<int> triangle_light_;       // mesh triangle -> light index, -1
    int world_ = -1;
    std::shared_ptr<const Light> background_;  // a world that is not a light (not sampled)
    std::shared_ptr<const LightTree> tree_;     // integrator.light_tree; null: uniform pick
    bool has_finite_camera_ = false, has_finite_mis_ = false;
};

// A material's resolved Emission Sampling (Auto by Cycles' rule) and its emission estimate
// (average of |colour x strength| over the Emission closures; Cycles' shader emission_estimate).
EmissionSampling resolved_emission_sampling(const MaterialDesc& material, double& estimate);
// Each mesh object's bounding-box centre (MeshData::object; one object 0 without it), in order
// of first appearance: the light tree's mesh-light centroids.
std::vector<std::pair<int, Vec3>> mesh_object_centers(const MeshData& meshes);

// Cycles' MIS weight (power heuristic).
inline double power_heuristic(double a, double b) {
    const double a2 = a * a, b2 = b * b;
    return a2 + b2 > 0 ? a2 / (a2 + b2) : 0.0;
}

// Sampling helpers shared with the integrator.
Vec3 sample_uniform_cone(Vec3 axis, double one_minus_cos, double u0, double u1);

}  // namespace hairbsdf::render
