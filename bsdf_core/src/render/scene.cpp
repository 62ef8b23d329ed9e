// Scene repair: see render/scene.h.
#include "hairbsdf/render/scene.h"

#include "hairbsdf/render/shading.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace hairbsdf::render {

namespace {

bool finite3(const float* p) { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

template <class T>
bool finite_array(const T& a) {
    for (double v : a)
        if (!std::isfinite(v)) return false;
    return true;
}

std::string plural(size_t n, const char* what) { return std::to_string(n) + " " + what + (n == 1 ? "" : "s"); }

// Materials: a default surface for out-of-range indices (Cycles' default, a diffuse of kDefaultSurfaceColor), added
// to the scene the first time a curve or triangle needs it.
struct DefaultSurface {
    SceneDesc& s;
    int index = -1;
    int operator()() {
        if (index < 0) {
            MaterialDesc m;
            m.name = "__default_surface__";
            ClosureDesc c;
            c.type = ClosureDesc::Type::Diffuse;
            c.weight = RGB(1.0);
            m.closures.push_back(c);
            index = int(s.materials.size());
            s.materials.push_back(m);
        }
        return index;
    }
};

// Non-finite closure values make the closure black.
void repair_closures(SceneDesc& s, std::vector<std::string>& warnings) {
    size_t bad_closures = 0;
    for (MaterialDesc& m : s.materials) {
        for (ClosureDesc& c : m.closures) {
            const PrincipledHairInputs& h = c.hair;
            bool ok = isfinite(c.weight) && isfinite(c.color) && std::isfinite(c.strength);
            if (c.type == ClosureDesc::Type::PrincipledHair) {
                ok = ok && isfinite(h.color) && isfinite(h.tint) && isfinite(h.absorption_coefficient) &&
                     std::isfinite(h.melanin) && std::isfinite(h.melanin_redness) && std::isfinite(h.roughness) &&
                     std::isfinite(h.radial_roughness) && std::isfinite(h.coat) && std::isfinite(h.ior) &&
                     std::isfinite(h.offset) && std::isfinite(h.random_color) && std::isfinite(h.random_roughness) &&
                     std::isfinite(h.random);
            }
            if (!ok) {
                c.weight = RGB(0.0);
                c.color = RGB(0.0);
                c.strength = 0.0;
                ++bad_closures;
            }
        }
    }
    if (bad_closures) warnings.push_back("materials: " + plural(bad_closures, "closure") + " with NaN/Inf values set to black");
}

int link_width(const ClosureDesc::Link& l) {
    using In = ClosureDesc::Input;
    return (l.input == In::Color || l.input == In::Tint || l.input == In::AbsorptionCoefficient ||
            l.input == In::Weight)
               ? 3
               : 1;
}

// The inputs a closure reads once per render, not per hit: the legacy Hair BSDF's (its model is
// built once). A link on one must fold; a hit-dependent one takes its value at the zero hit.
bool input_varies_per_hit(const ClosureDesc& c, const ClosureDesc::Link& l) {
    return c.type != ClosureDesc::Type::CyclesHair || l.input == ClosureDesc::Input::Weight;
}

// A closure input whose register does not depend on the hit takes its value, as a hit would
// read it (shading.h's register_value: a non-finite value reads 0).
void set_folded_input(ClosureDesc& c, const ClosureDesc::Link& l, const float* values) {
    using In = ClosureDesc::Input;
    if (l.input == In::Weight)
        c.weight = register_rgb(values, l.reg);
    else if (c.type == ClosureDesc::Type::PrincipledHair)
        apply_links({l}, values, c.hair, c.random_from_curve);
    else if (l.input == In::Color)
        c.color = register_rgb(values, l.reg);
    else if (l.input == In::Strength)
        c.strength = register_value(values, l.reg);
    else if (l.input == In::Offset)
        c.offset = register_value(values, l.reg);
    else if (l.input == In::RoughnessU)
        c.roughness_u = register_value(values, l.reg);
    else if (l.input == In::RoughnessV)
        c.roughness_v = register_value(values, l.reg);
}

bool is_zero(const RGB& w) { return w.r == 0 && w.g == 0 && w.b == 0; }

// A zero-hit context: Hair Info and attributes 0, the scene's images.
struct ZeroHit {
    std::vector<float> attributes;
    ShadingHitContext ctx;
    ZeroHit(int attribute_count, const std::vector<ShadingImage>& images)
        : attributes(size_t(std::max(attribute_count, 1)) * 4, 0.0f) {
        ctx.is_strand = 1.0f;
        ctx.attributes = attributes.data();
        ctx.attribute_count = attribute_count;
        ctx.images = images.data();
        ctx.image_count = int(images.size());
    }
};

// Constant folding (docs/shading_vm.md), the one place it happens: the program runs once with a
// zero hit; inputs that do not depend on the hit become constants, the program keeps the
// instructions the others need, and a material left with none has no program (the renderer then
// builds its closures once). A closure whose weight folds to 0 is dropped, as the exporter drops
// one with a constant weight of 0.
void fold_material_program(MaterialDesc& m, const std::vector<ShadingImage>& images, int attribute_count,
                           std::vector<std::string>& warnings) {
    std::vector<std::pair<int32_t, int32_t>> outputs;
    for (const ClosureDesc& c : m.closures)
        for (const ClosureDesc::Link& l : c.links) outputs.push_back({l.reg, link_width(l)});
    const ZeroHit zero_hit(attribute_count, images);
    FoldedProgram folded = fold_program(m.program, zero_hit.ctx, outputs);
    if (!folded.folded) return;
    std::vector<ClosureDesc> closures;
    size_t fixed = 0;
    for (ClosureDesc& c : m.closures) {
        std::vector<ClosureDesc::Link> kept;
        bool weight_folded = false;
        for (ClosureDesc::Link l : c.links) {
            const auto first = folded.dynamic.begin() + l.reg;
            const bool dynamic = std::any_of(first, first + link_width(l), [](char d) { return d; });
            if (dynamic && input_varies_per_hit(c, l)) {
                l.reg = folded.slot[size_t(l.reg)];
                kept.push_back(l);
            } else {
                fixed += dynamic;
                set_folded_input(c, l, folded.values.data());
                weight_folded |= l.input == ClosureDesc::Input::Weight;
            }
        }
        c.links = std::move(kept);
        if (!(weight_folded && is_zero(c.weight))) closures.push_back(std::move(c));
    }
    if (fixed)
        warnings.push_back("materials: '" + m.name + "': " + plural(fixed, "legacy Hair BSDF input") +
                           " depending on the hit read at a zero hit (they are read once per render)");
    m.closures = std::move(closures);
    bool any_link = false;
    for (const ClosureDesc& c : m.closures) any_link |= !c.links.empty();
    // The program keeps what the kept links read; with none left it has nothing to do.
    m.program = any_link ? std::move(folded.program) : ShadingProgram{};
}

// The world's program (its colour and texture weight computed by nodes) runs once, at a zero hit;
// the world has no attributes (they read 0) and no per-hit inputs.
void fold_world_program(SceneDesc& s, const std::vector<ShadingImage>& images, std::vector<std::string>& warnings) {
    if (s.world_program.empty() && s.world_color_register < 0 && s.world_texture_weight_register < 0) return;
    std::vector<std::pair<int32_t, int32_t>> outputs;
    std::string problem;
    for (int32_t reg : {s.world_color_register, s.world_texture_weight_register})
        if (reg >= 0) {
            outputs.push_back({reg, 3});
            if (reg + 3 > s.world_program.register_count)
                problem = "an input names register " + std::to_string(reg) + " outside the program's " +
                          std::to_string(s.world_program.register_count) + " registers";
        }
    try {
        validate_program(s.world_program, std::numeric_limits<int>::max(), int(images.size()));
    } catch (const std::invalid_argument& e) {
        problem = e.what();
    }
    if (!problem.empty()) {
        warnings.push_back("world: " + problem + "; the program is ignored (black)");
        if (s.world_color_register >= 0) s.world = RGB(0.0);
        if (s.world_texture_weight_register >= 0) s.world_texture.weight = RGB(0.0);
    } else {
        ShadingHitContext zero_hit;
        zero_hit.is_strand = 1.0f;
        zero_hit.images = images.data();
        zero_hit.image_count = int(images.size());
        const FoldedProgram folded = fold_program(s.world_program, zero_hit, outputs);
        std::vector<float> values = folded.values;
        if (!folded.folded) {  // not one the exporter writes: run it as it is
            values.assign(size_t(s.world_program.register_count), 0.0f);
            run_program(s.world_program, zero_hit, values.data());
        } else {
            for (const auto& [reg, width] : outputs)
                if (std::any_of(folded.dynamic.begin() + reg, folded.dynamic.begin() + reg + width, [](char d) { return d; }))
                    problem = "an input depends on the hit; its value at a zero hit is used";
            if (!problem.empty()) warnings.push_back("world: " + problem);
        }
        if (s.world_color_register >= 0) s.world = register_rgb(values.data(), s.world_color_register);
        if (s.world_texture_weight_register >= 0)
            s.world_texture.weight = register_rgb(values.data(), s.world_texture_weight_register);
    }
    // A texture whose weight folds to 0 adds nothing (the exporter leaves out one of constant weight 0).
    if (s.world_texture_weight_register >= 0 && is_zero(s.world_texture.weight)) s.world_texture = EnvironmentDesc{};
    s.world_program = ShadingProgram{};
    s.world_color_register = s.world_texture_weight_register = -1;
}

// Images: a bad size empties the image (it reads 0), NaN/Inf texels read 0.
void repair_images(SceneDesc& s, std::vector<std::string>& warnings) {
    size_t bad_image_values = 0;
    for (ImageDesc& im : s.images) {
        if (!im.valid()) {
            warnings.push_back("images: '" + im.name + "' has a bad size; it reads 0");
            im.width = im.height = 0;
            im.pixels.clear();
        }
        for (float& v : im.pixels)
            if (!std::isfinite(v)) {
                v = 0.0f;
                ++bad_image_values;
            }
    }
    if (bad_image_values) warnings.push_back("images: " + plural(bad_image_values, "NaN/Inf value") + " set to 0");
}

// Curves: strands with NaN/Inf keys, too few keys, no length or no radius are dropped, in place;
// bad materials, randoms, transforms and per-point arrays are fixed or ignored.
void repair_curves(SceneDesc& s, std::vector<std::string>& warnings, DefaultSurface& fallback_material) {
    CurveData& cd = s.curves;
    const size_t n_curves = cd.curve_count();
    if (n_curves > 0) {
        size_t dropped_nonfinite = 0, dropped_short = 0, dropped_length = 0, dropped_radius = 0, fixed_radius = 0,
               bad_material = 0, bad_random = 0, dropped_transform = 0;
        // Compacted in place (kept curves move towards the front; write <= read), so that
        // 1M strands never hold a second copy of their keys.
        size_t kept_points = 0, kept_curves = 0;
        cd.random.resize(n_curves, 0.0f);   // missing entries: random 0, default material
        cd.material.resize(n_curves, -1);
        int32_t next_begin = cd.offsets[0];  // offsets[c] before compaction overwrote it
        const bool with_normals = !cd.normals.empty();
        if (with_normals && cd.normals.size() != cd.points.size()) {
            cd.normals.clear();
            warnings.push_back("curves: normals ignored (expected one per point)");
        }
        if (!cd.intercept.empty() && cd.intercept.size() != cd.points.size()) {
            cd.intercept.clear();
            warnings.push_back("curves: point_intercept ignored (expected one per point)");
        }
        if (!cd.object.empty() && cd.object.size() != n_curves) {
            cd.object.clear();
            cd.object_transforms.clear();
            warnings.push_back("curves: curve_object ignored (expected one per curve); all curves read as world space");
        }
        std::vector<char> usable_transform(cd.object_transforms.size());
        for (size_t k = 0; k < cd.object_transforms.size(); ++k) {
            const auto& m = cd.object_transforms[k];
            bool finite = true;
            for (double x : m) finite = finite && std::isfinite(x);
            const double det = linear_determinant(m);
            usable_transform[k] = finite && std::isfinite(det) && det != 0.0;
        }
        if (!cd.length.empty() && cd.length.size() != n_curves) {
            cd.length.clear();
            warnings.push_back("curves: curve_intercept_total ignored (expected one per curve)");
        }
        for (auto& attr : cd.attributes) {
            const size_t want = attr.point_domain ? cd.points.size() : n_curves;
            if (attr.rgba.size() != want) {
                attr.rgba.assign(want, {0.0f, 0.0f, 0.0f, 0.0f});
                warnings.push_back("curves: attribute '" + attr.name + "' has the wrong length; read as 0");
            }
            for (auto& v : attr.rgba)
                for (float& x : v)
                    if (!std::isfinite(x)) x = 0.0f;
        }
        for (size_t c = 0; c < n_curves; ++c) {
            const int32_t b = next_begin, e = cd.offsets[c + 1];
            next_begin = e;
            if (b < 0 || e < b || size_t(e) > cd.points.size()) {
                ++dropped_short;
                continue;
            }
            if (e - b < 2) {
                ++dropped_short;
                continue;
            }
            const int32_t object = cd.object.empty() ? -1 : cd.object[c];
            if (object < -1 || (object >= 0 && (size_t(object) >= usable_transform.size() ||
                                                 !usable_transform[size_t(object)]))) {
                ++dropped_transform;
                continue;
            }
            bool finite = true;
            for (int32_t k = b; k < e && finite; ++k) finite = finite3(cd.points[size_t(k)].data());
            if (!finite) {
                ++dropped_nonfinite;
                continue;
            }
            double len = 0, rmax = 0;
            for (int32_t k = b; k < e; ++k) {
                float& r = cd.points[size_t(k)][3];
                if (!std::isfinite(r) || r < 0) {
                    r = 0.0f;
                    ++fixed_radius;
                }
                rmax = std::max(rmax, double(r));
                if (k > b) {
                    const auto& p = cd.points[size_t(k)];
                    const auto& q = cd.points[size_t(k) - 1];
                    len += std::sqrt(sqr(p[0] - q[0]) + sqr(p[1] - q[1]) + sqr(p[2] - q[2]));
                }
            }
            if (!(len > 0)) {
                ++dropped_length;
                continue;
            }
            if (!(rmax > 0)) {
                ++dropped_radius;
                continue;
            }
            if (size_t(b) != kept_points) {
                std::copy(cd.points.begin() + b, cd.points.begin() + e, cd.points.begin() + std::ptrdiff_t(kept_points));
                if (!cd.intercept.empty())
                    std::copy(cd.intercept.begin() + b, cd.intercept.begin() + e,
                              cd.intercept.begin() + std::ptrdiff_t(kept_points));
                for (auto& attr : cd.attributes)
                    if (attr.point_domain)
                        std::copy(attr.rgba.begin() + b, attr.rgba.begin() + e,
                                  attr.rgba.begin() + std::ptrdiff_t(kept_points));
                if (!cd.normals.empty())
                    std::copy(cd.normals.begin() + b, cd.normals.begin() + e,
                              cd.normals.begin() + std::ptrdiff_t(kept_points));
            }
            for (int32_t k = 0; k < e - b && !cd.normals.empty(); ++k) {  // non-finite normal: the fallback frame
                auto& n = cd.normals[kept_points + size_t(k)];
                if (!finite3(n.data())) n = {0.0f, 0.0f, 0.0f};
            }
            kept_points += size_t(e - b);
            float rnd = cd.random[c];
            if (!std::isfinite(rnd)) {
                rnd = 0.0f;
                ++bad_random;
            }
            cd.random[kept_curves] = rnd;
            int32_t mat = cd.material[c];
            if (mat < 0 || size_t(mat) >= s.materials.size()) {
                ++bad_material;
                mat = fallback_material();
            }
            cd.material[kept_curves] = mat;
            if (!cd.length.empty()) cd.length[kept_curves] = cd.length[c];
            if (!cd.object.empty()) cd.object[kept_curves] = object;
            for (auto& attr : cd.attributes)
                if (!attr.point_domain) attr.rgba[kept_curves] = attr.rgba[c];
            cd.offsets[kept_curves + 1] = int32_t(kept_points);
            ++kept_curves;
        }
        cd.offsets[0] = 0;
        if (dropped_nonfinite) warnings.push_back("curves: dropped " + plural(dropped_nonfinite, "curve") + " with NaN/Inf coordinates");
        if (dropped_short) warnings.push_back("curves: dropped " + plural(dropped_short, "curve") + " with fewer than 2 points");
        if (dropped_length) warnings.push_back("curves: dropped " + plural(dropped_length, "zero-length curve"));
        if (dropped_transform)
            warnings.push_back("curves: dropped " + plural(dropped_transform, "curve") +
                               " whose curve_object names no transform, or a singular or non-finite one");
        if (dropped_radius) warnings.push_back("curves: dropped " + plural(dropped_radius, "curve") + " with zero radius");
        if (fixed_radius) warnings.push_back("curves: " + plural(fixed_radius, "negative or NaN radius") + " set to 0");
        if (bad_random) warnings.push_back("curves: " + plural(bad_random, "NaN curve_random value") + " set to 0");
        if (bad_material) warnings.push_back("curves: " + plural(bad_material, "curve") + " with a material index outside materials use the default surface");
        cd.points.resize(kept_points);
        if (!cd.normals.empty()) cd.normals.resize(kept_points);
        cd.offsets.resize(kept_curves + 1);
        cd.random.resize(kept_curves);
        cd.material.resize(kept_curves);
        if (!cd.intercept.empty()) cd.intercept.resize(kept_points);
        if (!cd.length.empty()) cd.length.resize(kept_curves);
        if (!cd.object.empty()) cd.object.resize(kept_curves);
        for (auto& attr : cd.attributes) attr.rgba.resize(attr.point_domain ? kept_points : kept_curves);
        if (kept_curves == 0) cd = CurveData{};
    } else {
        cd = CurveData{};
    }
}

// Triangles: bad indices, NaN/Inf vertices or no area are dropped; bad materials use the default
// surface; attributes follow the kept triangles.
void repair_meshes(SceneDesc& s, std::vector<std::string>& warnings, DefaultSurface& fallback_material) {
    MeshData& md = s.meshes;
    if (!md.triangles.empty()) {
        size_t dropped = 0, bad_material = 0;
        MeshData out;
        out.vertices = md.vertices;
        std::vector<size_t> kept;
        for (size_t t = 0; t < md.triangles.size(); ++t) {
            const auto& tri = md.triangles[t];
            bool ok = true;
            for (int k = 0; k < 3 && ok; ++k) {
                ok = tri[size_t(k)] >= 0 && size_t(tri[size_t(k)]) < md.vertices.size() &&
                     finite3(md.vertices[size_t(tri[size_t(k)])].data());
            }
            if (ok) {
                const auto& a = md.vertices[size_t(tri[0])];
                const auto& b = md.vertices[size_t(tri[1])];
                const auto& c = md.vertices[size_t(tri[2])];
                const Vec3 e1{double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
                const Vec3 e2{double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
                ok = length(cross(e1, e2)) > 0;
            }
            if (!ok) {
                ++dropped;
                continue;
            }
            out.triangles.push_back(tri);
            int32_t mat = t < md.material.size() ? md.material[t] : -1;
            if (mat < 0 || size_t(mat) >= s.materials.size()) {
                ++bad_material;
                mat = fallback_material();
            }
            out.material.push_back(mat);
            if (t < md.normals.size()) out.normals.push_back(md.normals[t]);
            if (md.object.size() == md.triangles.size()) out.object.push_back(md.object[t]);
            if (md.reversed.size() == md.triangles.size()) out.reversed.push_back(md.reversed[t]);
            kept.push_back(t);
        }
        for (auto& attr : md.attributes) {  // the kept triangles' rows; a wrong length reads 0
            MeshData::CornerAttribute a{attr.name, {}};
            const bool sized = attr.corners.size() == md.triangles.size();
            if (!sized) warnings.push_back("meshes: attribute '" + attr.name + "' has the wrong length; read as 0");
            for (size_t t : kept) {
                std::array<float, 12> row{};
                if (sized)
                    for (size_t k = 0; k < 12; ++k) row[k] = std::isfinite(attr.corners[t][k]) ? attr.corners[t][k] : 0.0f;
                a.corners.push_back(row);
            }
            out.attributes.push_back(std::move(a));
        }
        if (out.normals.size() != out.triangles.size()) out.normals.clear();  // all or none
        if (dropped) warnings.push_back("meshes: dropped " + plural(dropped, "triangle") + " with bad indices, NaN/Inf vertices or no area");
        if (bad_material) warnings.push_back("meshes: " + plural(bad_material, "triangle") + " with a material index outside materials use the default surface");
        md = std::move(out);
    }
}

// Lights with NaN/Inf or zero-length values are removed; the world's colour and texture repaired.
void repair_lights_and_world(SceneDesc& s, std::vector<std::string>& warnings) {
    std::vector<LightDesc> lights;
    size_t bad_lights = 0;
    for (const LightDesc& l : s.lights) {
        const bool ok = isfinite(l.strength) && finite_array(l.position) && finite_array(l.direction) &&
                        finite_array(l.matrix_world) && std::isfinite(l.angle) && std::isfinite(l.radius) &&
                        std::isfinite(l.spot_size) && std::isfinite(l.spot_blend) && std::isfinite(l.size_x) &&
                        std::isfinite(l.size_y) && std::isfinite(l.spread);
        const bool dir_ok = (l.type != LightType::Sun && l.type != LightType::Spot) ||
                            (l.type == LightType::Spot && l.has_matrix) ||
                            (sqr(l.direction[0]) + sqr(l.direction[1]) + sqr(l.direction[2]) > 0);
        if (!ok || !dir_ok) {
            ++bad_lights;
            continue;
        }
        lights.push_back(l);
    }
    if (bad_lights) warnings.push_back("lights: removed " + plural(bad_lights, "light") + " with NaN/Inf or zero-length values");
    s.lights = std::move(lights);
    if (!isfinite(s.world)) {
        s.world = RGB(0.0);
        warnings.push_back("world: NaN/Inf color set to black");
    }
    EnvironmentDesc& env = s.world_texture;
    if (env.width > 0 || env.height > 0 || !env.pixels.empty()) {
        bool ok = env.has_texture() && isfinite(env.weight);
        for (double m : env.matrix) ok = ok && std::isfinite(m);
        size_t bad_texels = 0;
        for (float& v : env.pixels) {
            if (!std::isfinite(v) || v < 0) {
                v = 0;
                ++bad_texels;
            }
        }
        if (bad_texels) warnings.push_back("world: " + plural(bad_texels, "texture value") + " NaN/Inf or negative set to 0");
        if (!ok) {
            env = EnvironmentDesc{};
            warnings.push_back("world: environment texture with a bad size, weight or matrix removed");
        }
    }
}

// Warnings for a scene that renders black or empty.
void warn_nothing_to_render(const SceneDesc& s, std::vector<std::string>& warnings) {
    const EnvironmentDesc& env = s.world_texture;
    bool any_emission = !(s.world.r == 0 && s.world.g == 0 && s.world.b == 0) ||
                        (env.has_texture() && !(env.weight.r == 0 && env.weight.g == 0 && env.weight.b == 0));
    for (const LightDesc& l : s.lights) any_emission = any_emission || !(l.strength.r == 0 && l.strength.g == 0 && l.strength.b == 0);
    for (const MaterialDesc& m : s.materials)
        for (const ClosureDesc& c : m.closures)
            any_emission = any_emission || (c.type == ClosureDesc::Type::Emission && c.strength != 0);
    if (!any_emission) warnings.push_back("scene: no lights, no emission and a black world; the image is black");
    if (s.curves.curve_count() == 0 && s.meshes.triangles.empty()) warnings.push_back("scene: no geometry");
}

// The camera: NaN/Inf or non-positive settings take defaults.
void repair_camera(SceneDesc& s, std::vector<std::string>& warnings) {
    CameraDesc& cam = s.camera;
    const CameraDesc defaults{};  // the fallbacks are CameraDesc's member initialisers
    if (!finite_array(cam.matrix_world)) {
        cam.matrix_world = defaults.matrix_world;
        warnings.push_back("camera: NaN/Inf matrix_world replaced by the default (the identity)");
    }
    auto positive = [&](double& v, double fallback, const char* key) {
        if (!(std::isfinite(v) && v > 0)) {
            warnings.push_back(std::string("camera: ") + key + " must be > 0; using " + std::to_string(fallback));
            v = fallback;
        }
    };
    positive(cam.pixel_aspect, defaults.pixel_aspect, "pixel_aspect");
    positive(cam.sensor_width, defaults.sensor_width, "sensor_width");
    positive(cam.sensor_height, defaults.sensor_height, "sensor_height");
    positive(cam.lens, defaults.lens, "lens");
    positive(cam.ortho_scale, defaults.ortho_scale, "ortho_scale");
    if (!std::isfinite(cam.shift_x)) cam.shift_x = 0;
    if (!std::isfinite(cam.shift_y)) cam.shift_y = 0;
    if (!(std::isfinite(cam.clip_start) && cam.clip_start >= 0)) cam.clip_start = 0;
    if (!(cam.clip_end > cam.clip_start)) {
        warnings.push_back("camera: clip_end must exceed clip_start; using clip_start + 1e6");
        cam.clip_end = cam.clip_start + 1e6;
    }
}

// The integrator: NaN/Inf or out-of-range settings take defaults.
void repair_integrator(SceneDesc& s, std::vector<std::string>& warnings) {
    IntegratorSettings& in = s.integrator;
    const IntegratorSettings defaults{};  // the fallbacks are IntegratorSettings' member initialisers
    if (!(std::isfinite(in.filter_width) && in.filter_width > 0)) {
        warnings.push_back("integrator: filter_width must be > 0; using " + std::to_string(defaults.filter_width));
        in.filter_width = defaults.filter_width;
    }
    if (!std::isfinite(in.exposure)) in.exposure = defaults.exposure;
    if (!(std::isfinite(in.filter_glossy) && in.filter_glossy >= 0)) in.filter_glossy = 0.0;
    if (!(std::isfinite(in.clamp_direct) && in.clamp_direct >= 0)) in.clamp_direct = 0.0;
    if (!(std::isfinite(in.clamp_indirect) && in.clamp_indirect >= 0)) in.clamp_indirect = 0.0;
}

}  // namespace

// Shading programs: an invalid one (or a link outside its registers) is dropped, so the inputs
// keep their constant values; a valid one is folded (fold_material_program).
void repair_programs(SceneDesc& s, std::vector<std::string>& warnings) {
    const int attribute_count = int(std::max(s.curves.attributes.size(), s.meshes.attributes.size()));
    std::vector<ShadingImage> images;
    for (const ImageDesc& im : s.images)  // a bad size reads 0, as repair_images makes it
        images.push_back(im.valid() ? ShadingImage{im.width, im.height, im.pixels.data()} : ShadingImage{});
    for (MaterialDesc& m : s.materials) {
        std::string problem;
        try {
            if (!m.program.empty()) validate_program(m.program, attribute_count, int(s.images.size()));
        } catch (const std::invalid_argument& e) {
            problem = e.what();
        }
        for (const ClosureDesc& c : m.closures)
            for (const ClosureDesc::Link& l : c.links) {
                if (problem.empty() && (l.reg < 0 || l.reg + link_width(l) > m.program.register_count))
                    problem = "a closure input names register " + std::to_string(l.reg) + " outside the program's " +
                              std::to_string(m.program.register_count) + " registers";
            }
        if (!problem.empty()) {
            warnings.push_back("materials: '" + m.name + "': " + problem + "; the program is ignored");
            m.program = ShadingProgram{};
            for (ClosureDesc& c : m.closures) c.links.clear();
        } else if (!m.program.empty()) {
            fold_material_program(m, images, attribute_count, warnings);
        }
    }
    fold_world_program(s, images, warnings);
}

std::vector<std::string> repair_scene(SceneDesc& s) {
    std::vector<std::string> warnings;
    DefaultSurface fallback_material{s};
    repair_closures(s, warnings);
    repair_images(s, warnings);
    repair_programs(s, warnings);
    repair_curves(s, warnings, fallback_material);
    repair_meshes(s, warnings, fallback_material);
    repair_lights_and_world(s, warnings);
    warn_nothing_to_render(s, warnings);
    repair_camera(s, warnings);
    repair_integrator(s, warnings);
    return warnings;
}

}  // namespace hairbsdf::render
