// The path tracer; see render/integrator.h for the Cycles behaviour it follows.
#include "hairbsdf/render/integrator.h"

#include "path_stages.h"

#include <algorithm>
#include <cfloat>
#include <limits>

namespace hairbsdf::render {

namespace {

constexpr int kMaxLightHits = 8;

std::vector<MaterialShader> build_materials(const SceneDesc& scene) {
    std::vector<MaterialShader> out;
    out.reserve(scene.materials.size());
    for (const MaterialDesc& m : scene.materials) out.emplace_back(m, scene.integrator.tilt, scene.integrator.accuracy, scene.integrator.huang_sampler,
                                                             scene.integrator.huang_glass_albedo_table);
    return out;
}

double max_abs(RGB c) { return std::max(std::fabs(c.r), std::max(std::fabs(c.g), std::fabs(c.b))); }

// Each lobe's share of `value`, per channel (0 where the value is 0).
std::array<RGB, kLobeCount> lobe_shares(const std::array<RGB, kLobeCount>& lobes, RGB value) {
    auto share = [](double part, double whole) { return whole != 0 ? part / whole : 0.0; };
    std::array<RGB, kLobeCount> out;
    for (size_t k = 0; k < out.size(); ++k)
        out[k] = RGB(share(lobes[k].r, value.r), share(lobes[k].g, value.g), share(lobes[k].b, value.b));
    return out;
}

using stages::SurfacePoint;

// Hit -> position, frame, h and material (docs/cycles.md §3, geom/curve.h), written into `sp`.
void surface_point(const PreparedScene& s, const Ray& ray, const Hit& hit, SurfacePoint& sp) {
    sp = SurfacePoint{};
    sp.g.wo = -1.0 * ray.dir;
    if (hit.kind == PrimKind::Curve) {
        const CurveData& cd = s.desc.curves;
        const int curve = hit.prim;
        sp.material = cd.material[size_t(curve)];
        sp.g.random = cd.random[size_t(curve)];
        sp.self = {PrimKind::Curve, curve};
        sp.p = ray.org + hit.t * ray.dir;
        const CurvePoint cp = s.geometry.curve_point(hit.segment, hit.u);
        // A curve in its object's space (Cycles' untransformed curves): the frame is built there
        // from the ray taken into that space, then the normal goes back by the inverse transpose
        // and the tangent as a direction (geom/curve_intersect.h's curve_shader_setup).
        const ObjectSpace* space = s.geometry.curve_object_space(curve);
        const Vec3 p_local = space ? space->point_to_object(sp.p) : sp.p;
        const Vec3 wo_local = space ? -1.0 * normalize(space->direction_to_object(ray.dir)) : sp.g.wo;
        auto normal_to_world = [&](Vec3 n) { return space ? normalize(space->normal_to_world(n)) : n; };
        Vec3 x = normalize(cp.dp);
        if (!(dot(x, x) > 0)) x = normalize(cross(wo_local, std::fabs(wo_local.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0}));
        const Vec3 x_local = x;
        if (space) x = normalize(space->direction_to_world(x));
        sp.g.tangent = x;
        sp.g.curve_normal = s.geometry.curve_normal(hit.segment, hit.u);
        // Huang's pixel coverage for camera rays: half the ray footprint at the hit over the
        // linearly interpolated key radius (Cycles' 0.5 dP / r).
        const double r_lin = s.geometry.curve_radius_linear(hit.segment, hit.u);
        const double footprint = ray.dP + hit.t * ray.dD;
        if (footprint > 0 && r_lin > 0) sp.g.pixel_coverage = 0.5 * footprint / r_lin;
        auto bitangent = [](Vec3 t, Vec3 w) {  // normalize(cross(t, w)), or any normal of t
            const Vec3 b = cross(t, w);
            const double lb = length(b);
            return lb > 1e-12 ? (1.0 / lb) * b : normalize(cross(t, std::fabs(t.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0}));
        };
        const Vec3 y = bitangent(x, sp.g.wo);
        if (s.geometry.curve_shape() != CurveShape::Ribbons) {  // a tube (Cycles 5.x tests the shape exactly)
            const Vec3 d = p_local - cp.p;
            const Vec3 n = dot(d, d) > 0 ? normal_to_world(normalize(d)) : sp.g.wo;
            sp.g.n = n;
            sp.g.ng = n;
            sp.g.h = -dot(n, y);  // = dot(cross(N, X), Z) of Cycles' frame
            if (dot(n, sp.g.wo) < 0) {
                // The inner wall of a tube, hit by a ray that started inside it (not culled
                // since Blender 3.6). Cycles' shader_setup_from_ray flips Ng, N and dPdu of
                // every back-facing hit, curves included: the fibre tangent reverses, h stays
                // (dot(cross(-N, -X), Z) with Z unchanged), so theta and the azimuth change sign.
                sp.g.tangent = -1.0 * x;
                sp.g.n = -1.0 * n;
                sp.g.ng = sp.g.n;
            }
        } else {
            const double sine = clamp(hit.v, -1.0, 1.0);
            sp.g.h = -sine;
            const Vec3 y_local = space ? bitangent(x_local, wo_local) : y;
            sp.g.n = normal_to_world(
                normalize(sine * y_local - cos_from_sin(sine) * normalize(cross(x_local, y_local))));
            sp.g.ng = sp.g.wo;
        }
    } else {
        const MeshData& md = s.desc.meshes;
        const auto& tri = md.triangles[size_t(hit.prim)];
        const auto& a = md.vertices[size_t(tri[0])];
        const auto& b = md.vertices[size_t(tri[1])];
        const auto& c = md.vertices[size_t(tri[2])];
        const Vec3 v0{a[0], a[1], a[2]}, v1{b[0], b[1], b[2]}, v2{c[0], c[1], c[2]};
        sp.material = md.material[size_t(hit.prim)];
        sp.self = {PrimKind::Triangle, hit.prim};
        sp.p = (1.0 - hit.u - hit.v) * v0 + hit.u * v1 + hit.v * v2;
        Vec3 ng = normalize(cross(v1 - v0, v2 - v0));
        Vec3 n = ng;
        if (!md.normals.empty()) {
            // Smooth shading: N interpolated from the corner normals (Cycles' triangle_smooth_normal).
            const auto& c = md.normals[size_t(hit.prim)];
            const double w = 1.0 - hit.u - hit.v;
            const Vec3 ns = w * Vec3{c[0], c[1], c[2]} + hit.u * Vec3{c[3], c[4], c[5]} + hit.v * Vec3{c[6], c[7], c[8]};
            const double len = length(ns);
            if (len > 0 && std::isfinite(len)) n = (1.0 / len) * ns;
        }
        const bool back_face = dot(ng, sp.g.wo) < 0;
        if (back_face) {  // Cycles flips N, Ng and dP/du
            ng = -1.0 * ng;
            n = -1.0 * n;
        }
        sp.g.n = n;
        sp.g.ng = ng;
        sp.ng_triangle = ng;
        // A hair closure on a mesh: Cycles' frame from dP/du = v1 - v0 of the triangle in Blender's
        // corner order (v1 - v2 of a reversed triangle), negated on back faces as Cycles negates it.
        const bool reversed = !md.reversed.empty() && md.reversed[size_t(hit.prim)];
        Vec3 x = normalize(reversed ? v1 - v2 : v1 - v0);
        if (!(dot(x, x) > 0)) x = Vec3{1, 0, 0};
        sp.g.tangent = back_face ? -1.0 * x : x;
        const Vec3 y = normalize(cross(sp.g.tangent, sp.g.wo));
        const Vec3 z = normalize(cross(sp.g.tangent, y));
        sp.g.h = clamp(dot(cross(ng, sp.g.tangent), z), -1.0, 1.0);
        sp.g.random = 0.0;
    }
}

// Runs the material's shading program at a hit with Hair Info and the curve attributes there
// (point-domain values linear in the segment's u, as Cycles interpolates curve keys).
const float* run_material_program(const PreparedScene& s, const Hit& hit, const SurfacePoint& sp,
                                  const ShadingProgram& program, PathScratch& scratch,
                                  std::vector<float>& registers) {
    const CurveData& cd = s.desc.curves;
    const MeshData& md = s.desc.meshes;
    const size_t attribute_count = std::max(cd.attributes.size(), md.attributes.size());
    ShadingHitContext ctx;
    if (scratch.attributes.size() < 4 * attribute_count) scratch.attributes.resize(4 * attribute_count);
    std::fill(scratch.attributes.begin(), scratch.attributes.end(), 0.0f);
    ctx.attributes = scratch.attributes.data();
    ctx.attribute_count = int(attribute_count);
    ctx.images = s.images.data();
    ctx.image_count = int(s.images.size());
    if (hit.kind == PrimKind::Curve) {
        const int curve = hit.prim;
        const size_t k0 = size_t(s.geometry.segment_key(hit.segment));
        const float u = float(hit.u);
        auto along = [&](float a, float b) { return (1.0f - u) * a + u * b; };
        ctx.random = float(sp.g.random);
        ctx.is_strand = 1.0f;
        if (!cd.length.empty()) ctx.length = cd.length[size_t(curve)];
        if (!cd.intercept.empty()) ctx.intercept = along(cd.intercept[k0], cd.intercept[k0 + 1]);
        for (size_t i = 0; i < cd.attributes.size(); ++i) {
            const CurveData::Attribute& attr = cd.attributes[i];
            for (int c = 0; c < 4; ++c)
                scratch.attributes[4 * i + size_t(c)] =
                    attr.point_domain ? along(attr.rgba[k0][size_t(c)], attr.rgba[k0 + 1][size_t(c)])
                                      : attr.rgba[size_t(curve)][size_t(c)];
        }
    } else if (hit.kind == PrimKind::Triangle) {
        // Corner attributes (UV maps) at the hit: barycentric weights of corners 0, 1, 2 as in
        // surface_point's position.
        const float w[3] = {float(1.0 - hit.u - hit.v), float(hit.u), float(hit.v)};
        for (size_t i = 0; i < md.attributes.size(); ++i) {
            const auto& row = md.attributes[i].corners[size_t(hit.prim)];
            for (size_t c = 0; c < 4; ++c)
                scratch.attributes[4 * i + c] = w[0] * row[c] + w[1] * row[4 + c] + w[2] * row[8 + c];
        }
    }
    if (registers.size() < size_t(program.register_count)) registers.resize(size_t(program.register_count));
    run_program(program, ctx, registers.data());
    return registers.data();
}

Ray leaving_ray(const SurfacePoint& sp, Vec3 dir, double tmax) {
    Ray r;
    r.dir = dir;
    r.tmin = 0.0;
    r.tmax = tmax;
    if (sp.self.kind == PrimKind::Triangle) {
        r.org = offset_ray_origin(sp.p, dot(sp.ng_triangle, dir) >= 0 ? sp.ng_triangle : -1.0 * sp.ng_triangle);
    } else {
        r.org = sp.p;  // curves: no offset (the whole curve is skipped)
    }
    return r;
}

}  // namespace

PreparedScene::PreparedScene(SceneDesc& scene)
    : desc(scene),
      geometry(scene, Geometry::ReleaseCurvePoints{}),
      camera(scene.camera),
      lights(scene),
      materials(build_materials(scene)),
      filter(scene.integrator.filter, scene.integrator.filter_width) {
    for (const ImageDesc& im : scene.images) images.push_back({im.width, im.height, im.pixels.data()});
}

namespace stages {

namespace {

// Adds a contribution; `light_bounce` < 1 counts as direct light for clamping; `split`: also
// to the lobe passes by the path's shares. Returns the contribution as added (clamped, finite).
RGB add(const IntegratorSettings& is, PathState& st, PathCounters& counters, RGB c, int light_bounce, bool split) {
    if (!isfinite(c)) {
        ++counters.nan;
        c = RGB(std::isfinite(c.r) ? c.r : 0.0, std::isfinite(c.g) ? c.g : 0.0, std::isfinite(c.b) ? c.b : 0.0);
    }
    const double clamp_direct = is.clamp_direct > 0 ? 3.0 * is.clamp_direct : 0.0;
    const double clamp_indirect = is.clamp_indirect > 0 ? 3.0 * is.clamp_indirect : 0.0;
    const double limit = light_bounce > 0 ? clamp_indirect : clamp_direct;
    if (limit > 0) {
        const double sum = std::fabs(c.r) + std::fabs(c.g) + std::fabs(c.b);
        if (sum > limit) c = (limit / sum) * c;
    }
    st.res.radiance += c;
    if (split)
        for (size_t k = 0; k < st.shares.size(); ++k) st.res.lobes[k] += st.shares[k] * c;
    return c;
}

// Light reached along the path's last ray: weight 1 for camera rays, else the power heuristic
// against the light's pdf (with the light tree's selection pdf at the ray's origin).
double forward_mis(const PathState& st, double light_pdf) {
    return st.camera ? 1.0 : power_heuristic(st.mis_ray_pdf, light_pdf);
}
double selection(const PreparedScene& s, const PathState& st, int light) {
    return st.camera ? 0.0 : s.lights.selection_pdf(light, st.mis_origin);
}

}  // namespace

int hit_material(const PreparedScene& s, const Hit& hit) {
    return hit.kind == PrimKind::Curve ? s.desc.curves.material[size_t(hit.prim)]
                                       : s.desc.meshes.material[size_t(hit.prim)];
}

void begin_path(const PreparedScene& s, PathState& st) {
    if (s.desc.integrator.chiang_lcg) st.lcg_path_seed = uint32_t(st.rng.next() * 4294967296.0);
}

bool after_trace(const PreparedScene& s, PathState& st, PathCounters& counters) {
    const IntegratorSettings& is = s.desc.integrator;
    const Ray& ray = st.ray;
    const Hit& hit = st.hit;
    ++counters.rays;
    const double t_end = hit ? hit.t : ray.tmax;

    // Lights crossed before the surface (transparent to rays, Cycles' shade_light).
    if (s.lights.has_finite_mis_lights(st.camera)) {
        LightHit lh[kMaxLightHits];
        const int n = s.lights.intersect(ray, t_end, st.camera, lh, kMaxLightHits);
        for (int k = 0; k < n; ++k) {
            const double mis = forward_mis(st, lh[k].pdf * selection(s, st, lh[k].light));
            add(is, st, counters, mis * (st.throughput * lh[k].radiance), st.bounce - 1, st.split);
            if (++st.transparent >= is.transparent_bounces + 1) return false;
        }
    }

    if (!hit) {
        LightHit sh[kMaxLightHits];
        const int n = s.lights.eval_suns(ray.dir, st.camera, sh, kMaxLightHits);
        for (int k = 0; k < n; ++k) {
            const double mis = forward_mis(st, sh[k].pdf * selection(s, st, sh[k].light));
            add(is, st, counters, mis * (st.throughput * sh[k].radiance), st.bounce - 1, st.split);
        }
        if (st.camera && is.film_transparent) {
            st.res.transparent += average(st.throughput);
        } else if (const Light* world = s.lights.world()) {
            LightHit wh;
            world->eval_direction(ray.dir, wh);
            const double mis =
                world->use_mis() ? forward_mis(st, wh.pdf * selection(s, st, s.lights.world_index())) : 1.0;
            add(is, st, counters, mis * (st.throughput * wh.radiance), st.bounce - 1, st.split);
        }
        return false;
    }
    return true;
}

static inline bool prepare_hit_inline(const PreparedScene& s, PathState& st, PathScratch& scratch,
                                      PathCounters& counters, HitShading& h) {
    const IntegratorSettings& is = s.desc.integrator;
    const Ray& ray = st.ray;
    const Hit& hit = st.hit;
    SurfacePoint& sp = h.sp;
    surface_point(s, ray, hit, sp);
    const MaterialShader& material = s.materials[size_t(sp.material)];
    if (st.camera && !st.res.hit) {
        st.res.hit = true;
        st.res.depth = s.camera.depth(sp.p);
        st.res.normal = sp.g.n;
    }
    // The camera ray's first hair interaction (a transparent Huang hit keeps `camera`).
    h.first_hair = is.pass_hair_lobes && st.camera && hit.kind == PrimKind::Curve;

    // Russian roulette (decided before shading, applied after the emission).
    double q = 1.0;
    if (st.bounce > is.min_light_bounces + 1) q = std::min(std::sqrt(max_abs(st.throughput)), 1.0);
    const bool killed = q < 1.0 && (q == 0.0 || st.rng.next() >= q);

    if (!material.program().empty())
        sp.g.registers = run_material_program(s, hit, sp, material.program(), scratch, scratch.registers);
    const RGB emission = material.emission(sp.g.registers);
    if (emission.r != 0 || emission.g != 0 || emission.b != 0) {
        // A light-sampled emissive triangle hit by a BSDF ray: MIS against next-event
        // estimation on the sides it samples (Cycles' SD_MIS_FRONT / SD_MIS_BACK).
        double mis = 1.0;
        const int tri_light = hit.kind == PrimKind::Triangle ? s.lights.triangle_light(hit.prim) : -1;
        if (tri_light >= 0 && !st.camera) {
            const Light& l = s.lights.light(size_t(tri_light));
            const auto& tri = s.desc.meshes.triangles[size_t(hit.prim)];
            const auto& v0 = s.desc.meshes.vertices[size_t(tri[0])];
            const auto& v1 = s.desc.meshes.vertices[size_t(tri[1])];
            const auto& v2 = s.desc.meshes.vertices[size_t(tri[2])];
            const Vec3 a{v0[0], v0[1], v0[2]}, b{v1[0], v1[1], v1[2]}, c{v2[0], v2[1], v2[2]};
            const bool back = dot(cross(b - a, c - a), ray.dir) > 0;
            if (l.samples_side(back))
                mis = forward_mis(st, l.triangle_pdf(st.mis_origin.p, sp.p) * selection(s, st, tri_light));
        }
        add(is, st, counters, mis * (st.throughput * emission), st.bounce - 1, st.split);
    }
    if (killed || st.terminate_after || !material.has_bsdf()) return false;
    if (q != 1.0) st.throughput = (1.0 / q) * st.throughput;

    h.blur = 0.0;
    if (is.filter_glossy > 0 && !st.camera) {
        const double blur_pdf = st.min_ray_pdf / is.filter_glossy;
        if (blur_pdf < 1.0) h.blur = 0.5 * std::sqrt(1.0 - blur_pdf);
    }
    sp.g.near_field = st.camera && hit.kind == PrimKind::Curve;
    return true;
}

static inline bool set_bsdf_inline(const PreparedScene& s, PathState& st, PathScratch& scratch, const HitShading& h) {
    Bsdf& bsdf = scratch.bsdf;
    bsdf.set(s.materials[size_t(h.sp.material)], h.sp.g, h.blur, st.rng, h.first_hair);  // draws a stochastic eval's seed
    return !bsdf.empty();
}

bool prepare_bsdf(const PreparedScene& s, PathState& st, PathScratch& scratch, PathCounters& counters, HitShading& h) {
    return prepare_hit_inline(s, st, scratch, counters, h) && set_bsdf_inline(s, st, scratch, h);
}

static inline bool draw_light_sample_inline(const PreparedScene& s, PathState& st, PathScratch& scratch,
                                            const HitShading& h, bool bsdf_transmits, LightSample& ls) {
    if (s.lights.size() == 0) return false;
    const SurfacePoint& sp = h.sp;
    const double u_sel = st.rng.next(), u0 = st.rng.next(), u1 = st.rng.next();
    const LightPickContext at{sp.p, sp.g.n, s.lights.uses_tree() && bsdf_transmits};
    if (!s.lights.sample(at, u_sel, u0, u1, ls)) return false;
    if (ls.triangle >= 0) {
        // An emissive triangle: its material's emission at the sampled point.
        Hit on_light;
        on_light.kind = PrimKind::Triangle;
        on_light.prim = ls.triangle;
        on_light.u = ls.u;
        on_light.v = ls.v;
        const MaterialShader& emitter = s.materials[size_t(s.desc.meshes.material[size_t(ls.triangle)])];
        const float* regs = emitter.program().empty()
                                ? nullptr
                                : run_material_program(s, on_light, SurfacePoint{}, emitter.program(), scratch,
                                                       scratch.light_registers);
        ls.radiance = emitter.emission(regs);
    }
    return true;
}

static inline bool finish_light_sample_inline(const PreparedScene& /*s*/, PathState& st, const HitShading& h,
                                              const LightSample& ls, const BsdfValue& b, PathCounters& counters,
                                              ShadowRay& shadow) {
    const SurfacePoint& sp = h.sp;
    const double bsdf_pdf = ls.use_mis ? b.pdf : 0.0;
    const RGB c = (power_heuristic(ls.pdf, bsdf_pdf) / ls.pdf) * (st.throughput * b.value * ls.radiance);
    if (c.r == 0 && c.g == 0 && c.b == 0) return false;
    const double tmax = std::isfinite(ls.distance) ? ls.distance : 1e30;
    shadow.ray = leaving_ray(sp, ls.wi, tmax);
    shadow.self = sp.self;
    shadow.light_triangle = ls.triangle;
    shadow.contribution = c;
    shadow.light_bounce = st.bounce;
    shadow.split = st.split;
    shadow.first_hair = h.first_hair;
    if (h.first_hair) shadow.direct_shares = lobe_shares(b.lobes, b.value);
    ++counters.rays;
    return true;
}

bool sample_light(const PreparedScene& s, PathState& st, PathScratch& scratch, const HitShading& h,
                  PathCounters& counters, ShadowRay& shadow) {
    const Bsdf& bsdf = scratch.bsdf;
    LightSample ls;
    if (!draw_light_sample_inline(s, st, scratch, h, bsdf.has_transmission(), ls)) return false;
    return finish_light_sample_inline(s, st, h, ls, bsdf.eval(ls.wi), counters, shadow);
}

void add_light_sample(const PreparedScene& s, PathState& st, PathCounters& counters, const ShadowRay& shadow) {
    const RGB added = add(s.desc.integrator, st, counters, shadow.contribution, shadow.light_bounce, shadow.split);
    if (shadow.first_hair)
        for (size_t k = 0; k < shadow.direct_shares.size(); ++k) st.res.lobes[k] += shadow.direct_shares[k] * added;
}

static inline BsdfNumbers draw_bsdf_numbers_inline(const PreparedScene& s, PathState& st) {
    BsdfNumbers n;
    n.u0 = st.rng.next();
    n.u1 = st.rng.next();
    n.u2 = st.rng.next();
    if (s.desc.integrator.chiang_lcg) {
        // Cycles' rng_offset grows by 16 at every path_state_next: each scatter and each
        // transparent step (lights crossed, transparent closures).
        n.lcg = LongitudinalNumbers::from_cycles_lcg(st.lcg_path_seed + 16u * uint32_t(st.bounce + st.transparent));
        n.use_lcg = true;
    }
    return n;
}

static inline bool finish_bsdf_sample_inline(const PreparedScene& s, PathState& st, const HitShading& h,
                                             const BsdfScatter& sc, bool bsdf_transmits, PathCounters& counters) {
    const IntegratorSettings& is = s.desc.integrator;
    const SurfacePoint& sp = h.sp;
    if (sc.label == LabelNone) return false;
    st.throughput = st.throughput * ((1.0 / sc.pdf) * sc.value);
    if (!isfinite(st.throughput)) {
        ++counters.nan;
        return false;
    }
    if (sc.label & LabelTransparent) {
        // Straight on (Huang outside the projected ellipse): as Cycles, the same ray goes on
        // past the hit (tmin moved, the skipped primitive kept, so the tube's far wall can be
        // hit); the path keeps its camera state, MIS pdfs and bounce counts.
        if (++st.transparent >= is.transparent_bounces) st.terminate_after = true;
        st.ray.tmin = std::nextafter(float(st.hit.t), std::numeric_limits<float>::infinity());
        st.mis_origin.p = sp.p;  // Cycles moves ray.P to the hit; N and the flag stay
        return true;
    }
    if (h.first_hair) {
        st.shares = lobe_shares(sc.lobes, sc.value);
        st.split = true;
    }
    st.mis_ray_pdf = sc.pdf;
    st.mis_origin = {sp.p, sp.g.n, s.lights.uses_tree() && bsdf_transmits};
    st.min_ray_pdf = std::min(st.min_ray_pdf, sc.blur_pdf);
    if (++st.bounce >= is.max_bounces + 1) st.terminate_after = true;
    if (sc.label & LabelReflect) {
        if (sc.label & LabelDiffuse) {
            if (++st.diffuse >= is.diffuse_bounces + 1) st.terminate_after = true;
        } else if (++st.glossy >= is.glossy_bounces + 1) {
            st.terminate_after = true;
        }
    } else if (++st.transmission >= is.transmission_bounces + 1) {
        st.terminate_after = true;
    }
    st.camera = false;
    st.ray = leaving_ray(sp, sc.wi, 1e30);
    st.skip = sp.self;
    return true;
}

bool sample_bsdf(const PreparedScene& s, PathState& st, PathScratch& scratch, const HitShading& h,
                 PathCounters& counters) {
    const Bsdf& bsdf = scratch.bsdf;
    const BsdfNumbers n = draw_bsdf_numbers_inline(s, st);
    const BsdfScatter sc = bsdf.sample(n.u0, n.u1, n.u2, n.use_lcg ? &n.lcg : nullptr);
    return finish_bsdf_sample_inline(s, st, h, sc, bsdf.has_transmission(), counters);
}

// The halves on their own, for the wavefront (the whole stages above inline them).
bool prepare_hit(const PreparedScene& s, PathState& st, PathScratch& scratch, PathCounters& counters, HitShading& h) {
    return prepare_hit_inline(s, st, scratch, counters, h);
}

bool set_bsdf(const PreparedScene& s, PathState& st, PathScratch& scratch, const HitShading& h) {
    return set_bsdf_inline(s, st, scratch, h);
}

bool draw_light_sample(const PreparedScene& s, PathState& st, PathScratch& scratch, const HitShading& h,
                       bool bsdf_transmits, LightSample& ls) {
    return draw_light_sample_inline(s, st, scratch, h, bsdf_transmits, ls);
}

bool finish_light_sample(const PreparedScene& s, PathState& st, const HitShading& h, const LightSample& ls,
                         const BsdfValue& b, PathCounters& counters, ShadowRay& shadow) {
    return finish_light_sample_inline(s, st, h, ls, b, counters, shadow);
}

BsdfNumbers draw_bsdf_numbers(const PreparedScene& s, PathState& st) { return draw_bsdf_numbers_inline(s, st); }

bool finish_bsdf_sample(const PreparedScene& s, PathState& st, const HitShading& h, const BsdfScatter& sc,
                        bool bsdf_transmits, PathCounters& counters) {
    return finish_bsdf_sample_inline(s, st, h, sc, bsdf_transmits, counters);
}

}  // namespace stages

PathResult trace_path(const PreparedScene& s, Ray ray, Sampler& rng, PathScratch& scratch, PathCounters& counters) {
    using namespace stages;
    PathState st(rng);
    st.ray = ray;
    begin_path(s, st);
    HitShading h;  // each hit's, written by prepare_bsdf
    ShadowRay shadow;  // each hit's light sample, written by sample_light
    for (;;) {
        st.hit = s.geometry.intersect(st.ray, st.skip);
        if (!after_trace(s, st, counters)) break;
        if (!prepare_bsdf(s, st, scratch, counters, h)) break;
        if (sample_light(s, st, scratch, h, counters, shadow) &&
            !s.geometry.occluded(shadow.ray, shadow.self, shadow.light_triangle))
            add_light_sample(s, st, counters, shadow);
        if (!sample_bsdf(s, st, scratch, h, counters)) break;
    }
    rng = st.rng;
    return st.res;
}

namespace {

// The camera ray of pixel (column, row)'s sample, its filter offsets drawn from `rng`.
Ray camera_ray(const PreparedScene& s, int column, int row, uint32_t sample, Sampler& rng) {
    const Camera& cam = s.camera;
    // Cycles (integrate_camera_sample, 3.0+): sample 0 of every pixel uses the filter random
    // numbers (0.5, 0.5), i.e. the pixel centre; later samples are importance-sampled offsets.
    // At 1 spp with a narrow filter this makes a pixel one exact point sample (fibre-gonio).
    const double u_x = rng.next(), u_y = rng.next();
    const double ox = s.filter.sample(sample == 0 ? 0.5 : u_x);
    const double oy = s.filter.sample(sample == 0 ? 0.5 : u_y);
    const double x = double(column) + ox, y = double(cam.pixel_row_to_raster_y(row)) + oy;
    Ray ray = cam.generate(x, y);
    // Compact differentials from the neighbouring pixels (only Huang's near field uses them).
    const Ray rx = cam.generate(x + 1.0, y), ry = cam.generate(x, y + 1.0);
    ray.dP = 0.5 * (length(rx.org - ray.org) + length(ry.org - ray.org));
    ray.dD = 0.5 * (length(rx.dir - ray.dir) + length(ry.dir - ray.dir));
    return ray;
}

}  // namespace

CameraPathStart start_camera_path(const PreparedScene& s, int column, int row, uint32_t sample) {
    const uint64_t pixel = uint64_t(row) * uint64_t(s.camera.width()) + uint64_t(column);
    CameraPathStart start{Sampler(pixel, sample, s.desc.integrator.seed), Ray{}};
    start.ray = camera_ray(s, column, row, sample, start.rng);
    return start;
}

PathResult trace_pixel_sample(const PreparedScene& s, int column, int row, uint32_t sample, PathScratch& scratch,
                              PathCounters& counters) {
    CameraPathStart start = start_camera_path(s, column, row, sample);
    return trace_path(s, start.ray, start.rng, scratch, counters);
}

}  // namespace hairbsdf::render
