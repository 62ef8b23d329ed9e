// The path tracer's stages over an explicit path state (docs/engine.md "A wavefront engine"). The
// per-pixel loop (trace_path) runs them for one path at a time; the wavefront (render/wavefront.h)
// runs each over all live paths of a tile. Both drivers call the same functions, so a path draws
// the same random numbers and adds the same contributions in the same order.
#pragma once

#include <array>
#include <limits>

#include "hairbsdf/render/integrator.h"

namespace hairbsdf::render::stages {

// Everything a path carries from one ray to the next (Cycles' path state).
struct PathState {
    explicit PathState(const Sampler& sampler) : rng(sampler) {}
    Sampler rng;  // the path's own stream, drawn in a fixed order
    Ray ray;      // the ray to trace next
    SkipPrim skip;
    Hit hit;      // its hit, once traced
    PathResult res;
    RGB throughput{1.0};
    int bounce = 0, diffuse = 0, glossy = 0, transmission = 0, transparent = 0;
    bool camera = true;            // no scatter yet: PATH_RAY_CAMERA and MIS_SKIP
    bool terminate_after = false;  // PATH_RAY_TERMINATE_AFTER_TRANSPARENT
    double mis_ray_pdf = 0.0;
    // Where the last BSDF ray left (Cycles' ray.P, mis_origin_n, PATH_RAY_MIS_HAD_TRANSMISSION):
    // the light tree's selection pdf for forward MIS is taken there.
    LightPickContext mis_origin;
    double min_ray_pdf = std::numeric_limits<double>::infinity();
    // Hair lobe passes: the lobe shares of the first hair hit's sampled direction, once chosen.
    bool split = false;
    std::array<RGB, kLobeCount> shares{};
    uint32_t lcg_path_seed = 0;  // Cycles < 3.6 (integrator.chiang_lcg): the per-path part of its LCG seed
};

// Position, frame, h and material of a hit (docs/cycles.md §3).
struct SurfacePoint {
    Vec3 p;
    ShadingGeometry g;
    int material = 0;
    SkipPrim self;
    Vec3 ng_triangle;  // triangles: geometric normal on the viewer's side (for ray offsets)
};

// A shaded hit, between the stages that share the thread's Bsdf (prepare_bsdf .. sample_bsdf).
struct HitShading {
    SurfacePoint sp;
    bool first_hair = false;  // the camera ray's first hair interaction (lobe passes)
    double blur = 0;          // Filter Glossy's roughness for this hit (0: none)
};

// The numbers of a BSDF sample, drawn from the path's sampler (draw_bsdf_numbers).
struct BsdfNumbers {
    double u0 = 0, u1 = 0, u2 = 0;
    LongitudinalNumbers lcg;  // Cycles < 3.6 (integrator.chiang_lcg)
    bool use_lcg = false;
};

// A light sample's contribution, added if its shadow ray is unoccluded (add_light_sample).
struct ShadowRay {
    Ray ray;
    SkipPrim self;
    int light_triangle = -1;  // an emissive triangle the ray aims at, not an occluder
    RGB contribution;
    int light_bounce = 0;  // the path's bounce when the light was sampled (clamping)
    bool split = false;    // the path's lobe split then (sample_bsdf may set it before the ray is traced)
    bool first_hair = false;
    std::array<RGB, kLobeCount> direct_shares{};  // first hair hit: the lobes' shares of the BSDF value
};

// The material of a hit (the wavefront groups hits by it before shading).
int hit_material(const PreparedScene& s, const Hit& hit);

// The path's first numbers after its camera ray: Cycles < 3.6's LCG seed.
void begin_path(const PreparedScene& s, PathState& st);
// After st.ray was traced into st.hit: counts the ray, adds the lights it crossed and, when it
// escaped, the suns, the world or the film's transparency. False: the path ended.
bool after_trace(const PreparedScene& s, PathState& st, PathCounters& counters);
// At st.hit: surface point, first-hit passes, Russian roulette, the material's program, emission
// with forward MIS, termination, Filter Glossy's roughness (h.blur). False: the path ended.
bool prepare_hit(const PreparedScene& s, PathState& st, PathScratch& scratch, PathCounters& counters, HitShading& h);
// The hit's Bsdf (scratch.bsdf) with Filter Glossy's roughness. False: no BSDF there (the path ended).
bool set_bsdf(const PreparedScene& s, PathState& st, PathScratch& scratch, const HitShading& h);
// prepare_hit, then set_bsdf. False: the path ended.
bool prepare_bsdf(const PreparedScene& s, PathState& st, PathScratch& scratch, PathCounters& counters, HitShading& h);
// Next-event estimation with scratch.bsdf: draw_light_sample, the BSDF's eval there, finish_light_sample.
// True when the contribution is non-zero and waits for `shadow`'s ray.
bool sample_light(const PreparedScene& s, PathState& st, PathScratch& scratch, const HitShading& h,
                  PathCounters& counters, ShadowRay& shadow);
// Its halves, around a BSDF eval done elsewhere (the wavefront's batch kernels). The light pick and the
// point on the light (`bsdf_transmits`: Cycles' SD_BSDF_HAS_TRANSMISSION); false: no light sample.
bool draw_light_sample(const PreparedScene& s, PathState& st, PathScratch& scratch, const HitShading& h,
                       bool bsdf_transmits, LightSample& ls);
// MIS, the contribution with the path's throughput and the shadow ray, from the BSDF's value at ls.wi.
bool finish_light_sample(const PreparedScene& s, PathState& st, const HitShading& h, const LightSample& ls,
                         const BsdfValue& b, PathCounters& counters, ShadowRay& shadow);
// Adds a light sample whose shadow ray was not occluded.
void add_light_sample(const PreparedScene& s, PathState& st, PathCounters& counters, const ShadowRay& shadow);
// The BSDF sample with scratch.bsdf: throughput, MIS state, bounce budgets, the next ray. False:
// the path ended.
bool sample_bsdf(const PreparedScene& s, PathState& st, PathScratch& scratch, const HitShading& h,
                 PathCounters& counters);
// Its halves, around a BSDF sample done elsewhere: the sample's numbers, then what follows the sample.
BsdfNumbers draw_bsdf_numbers(const PreparedScene& s, PathState& st);
bool finish_bsdf_sample(const PreparedScene& s, PathState& st, const HitShading& h, const BsdfScatter& sc,
                        bool bsdf_transmits, PathCounters& counters);

}  // namespace hairbsdf::render::stages
