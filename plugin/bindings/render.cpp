// pybind11 bindings: hairbsdf._render, the path tracer (Embree + TBB). A separate module
// from _core so that `import hairbsdf` never loads TBB / Embree: the Python wrapper
// (hairbsdf/render.py) imports it lazily at render time.
//
// render(scene: dict, progress=None, cancel=None, threads=0) -> {"combined": (H, W, 4)
// float32, "stats": {...}}. The scene dict follows docs/scene_desc.md; conversion errors
// name the key. The render runs on a worker thread with the GIL released; the calling
// thread re-acquires it every 50 ms to poll cancel() (and Ctrl-C) and every 250 ms to
// report progress(fraction).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <exception>
#include <memory>
#include <optional>
#include <thread>

#include "hairbsdf/render/render.h"
#include "hairbsdf/render/shading.h"
#include "model_params.h"
#include "scene_schema.h"

namespace py = pybind11;
using namespace hairbsdf;
using namespace hairbsdf::render;

namespace {

[[noreturn]] void fail(const std::string& key, const std::string& what) {
    throw py::value_error("scene" + key + ": " + what);
}

std::string sub(const std::string& key, const char* name) { return key + "['" + name + "']"; }

py::dict as_dict(py::handle h, const std::string& key) {
    if (!py::isinstance<py::dict>(h)) throw py::type_error("scene" + key + ": expected a dict");
    return py::reinterpret_borrow<py::dict>(h);
}

py::object get(const py::dict& d, const std::string& key, const char* name) {
    if (!d.contains(name)) fail(sub(key, name), "missing");
    return d[name];
}

std::optional<py::object> get_optional(const py::dict& d, const char* name) {
    if (!d.contains(name)) return std::nullopt;
    py::object o = d[name];
    if (o.is_none()) return std::nullopt;
    return o;
}

double as_real(py::handle h, const std::string& key) {
    if (py::isinstance<py::bool_>(h) || !(py::isinstance<py::float_>(h) || py::isinstance<py::int_>(h) ||
                                          py::hasattr(h, "__float__"))) {
        throw py::type_error("scene" + key + ": expected a number");
    }
    return py::float_(py::reinterpret_borrow<py::object>(h)).cast<double>();
}

long as_int(py::handle h, const std::string& key) {
    if (py::isinstance<py::bool_>(h) || !(py::isinstance<py::int_>(h) || py::hasattr(h, "__index__"))) {
        throw py::type_error("scene" + key + ": expected an integer");
    }
    return py::int_(py::reinterpret_borrow<py::object>(h)).cast<long>();
}

bool as_bool(py::handle h, const std::string& key) {
    if (!(py::isinstance<py::bool_>(h) || py::isinstance<py::int_>(h) || py::hasattr(h, "__bool__"))) {
        throw py::type_error("scene" + key + ": expected a bool");
    }
    return py::bool_(py::reinterpret_borrow<py::object>(h)).cast<bool>();
}

std::string as_str(py::handle h, const std::string& key) {
    if (!py::isinstance<py::str>(h)) throw py::type_error("scene" + key + ": expected a string");
    return h.cast<std::string>();
}

template <class T>
py::array_t<T, py::array::c_style | py::array::forcecast> as_array(py::handle h, const std::string& key) {
    try {
        return py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(h);
    } catch (const py::error_already_set&) {
    }
    throw py::type_error("scene" + key + ": expected an array of numbers");
}

template <class T>
py::array_t<T, py::array::c_style | py::array::forcecast> array_shape(py::handle h, const std::string& key, int cols) {
    auto a = as_array<T>(h, key);
    if (!a) throw py::type_error("scene" + key + ": expected an array of numbers");
    if (cols == 0 ? a.ndim() != 1 : (a.ndim() != 2 || a.shape(1) != cols)) {
        fail(key, cols == 0 ? "expected a 1-D array" : "expected shape (N, " + std::to_string(cols) + ")");
    }
    return a;
}

RGB as_rgb(py::handle h, const std::string& key) {
    auto a = as_array<double>(h, key);
    if (!a || a.ndim() != 1 || (a.shape(0) != 3 && a.shape(0) != 4)) fail(key, "expected 3 numbers (r, g, b)");
    return {a.at(0), a.at(1), a.at(2)};
}

std::array<double, 3> as_vec3(py::handle h, const std::string& key) {
    auto a = as_array<double>(h, key);
    if (!a || a.ndim() != 1 || a.shape(0) != 3) fail(key, "expected 3 numbers");
    return {a.at(0), a.at(1), a.at(2)};
}

std::array<double, 16> as_mat4(py::handle h, const std::string& key) {
    auto a = as_array<double>(h, key);
    if (!a || a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4) fail(key, "expected a 4x4 matrix");
    std::array<double, 16> m;
    for (int i = 0; i < 16; ++i) m[size_t(i)] = a.data()[i];
    return m;
}

// The schema path of a key: "['lights'][0]['type']" -> "lights[].type".
std::string schema_path(const std::string& key) {
    std::string path;
    for (size_t i = 0; i < key.size();) {
        if (key.compare(i, 2, "['") == 0) {
            const size_t end = key.find("']", i);
            path += (path.empty() ? "" : ".") + key.substr(i + 2, end - i - 2);
            i = end + 2;
        } else {
            const size_t end = key.find(']', i);
            path += "[]";
            i = end + 1;
        }
    }
    return path;
}

// A name check_scene accepted -> the C++ value at its position in the schema row's `allowed`
// (scene_schema.cpp): `values` are in that order.
template <class E>
E as_enum(py::handle h, const std::string& key, std::initializer_list<E> values) {
    const bindings::SceneKey& row = bindings::scene_key(schema_path(key));
    if (row.allowed.size() != values.size())
        throw std::logic_error("scene schema: " + schema_path(key) + " has " + std::to_string(row.allowed.size()) +
                               " values, the reader maps " + std::to_string(values.size()));
    const std::string s = as_str(h, key);
    for (size_t i = 0; i < row.allowed.size(); ++i)
        if (s == row.allowed[i]) return values.begin()[i];
    fail(key, "'" + s + "' is not allowed");
}

void read_environment(py::handle h, EnvironmentDesc& env) {
    const std::string key = "['world']['texture']";
    const py::dict t = as_dict(h, key);
    auto px = as_array<float>(get(t, key, "pixels"), sub(key, "pixels"));
    if (!px || px.ndim() != 3 || px.shape(2) != 3 || px.shape(0) < 1 || px.shape(1) < 1)
        fail(sub(key, "pixels"), "expected shape (height, width, 3) with height, width >= 1");
    env.height = int(px.shape(0));
    env.width = int(px.shape(1));
    env.pixels.assign(px.data(), px.data() + px.size());
    env.weight = as_rgb(get(t, key, "weight"), sub(key, "weight"));
    if (auto o = get_optional(t, "interpolation"))
        env.closest = as_enum<bool>(*o, sub(key, "interpolation"), {false, true});
    if (auto o = get_optional(t, "srgb_encoded")) env.srgb_encoded = as_bool(*o, sub(key, "srgb_encoded"));
    if (auto o = get_optional(t, "matrix")) {
        auto m = as_array<double>(*o, sub(key, "matrix"));
        if (!m || m.ndim() != 2 || (m.shape(0) != 3 && m.shape(0) != 4) || m.shape(1) != 4)
            fail(sub(key, "matrix"), "expected a 3x4 or 4x4 matrix");
        for (int i = 0; i < 12; ++i) env.matrix[size_t(i)] = m.data()[i];
    }
}

void read_curves(const py::dict& scene, SceneDesc& out) {
    if (!scene.contains("curves") || scene["curves"].is_none()) return;
    const std::string key = "['curves']";
    const py::dict c = as_dict(scene["curves"], key);
    auto pts = array_shape<float>(get(c, key, "points"), sub(key, "points"), 4);
    auto off = array_shape<int32_t>(get(c, key, "curve_offsets"), sub(key, "curve_offsets"), 0);
    const size_t n_points = size_t(pts.shape(0));
    const size_t n_off = size_t(off.shape(0));
    if (n_off == 0) {
        if (n_points != 0) fail(sub(key, "curve_offsets"), "must have C + 1 entries");
        return;
    }
    const size_t n_curves = n_off - 1;
    const int32_t* po = off.data();
    if (po[0] != 0 || size_t(po[n_off - 1]) != n_points) {
        fail(sub(key, "curve_offsets"), "must start at 0 and end at len(points)");
    }
    for (size_t i = 0; i + 1 < n_off; ++i)
        if (po[i + 1] < po[i]) fail(sub(key, "curve_offsets"), "must be non-decreasing");
    auto rnd = array_shape<float>(get(c, key, "curve_random"), sub(key, "curve_random"), 0);
    auto mat = array_shape<int32_t>(get(c, key, "curve_material"), sub(key, "curve_material"), 0);
    if (size_t(rnd.shape(0)) != n_curves) fail(sub(key, "curve_random"), "expected one value per curve");
    if (size_t(mat.shape(0)) != n_curves) fail(sub(key, "curve_material"), "expected one value per curve");
    CurveData& cd = out.curves;
    cd.points.resize(n_points);
    std::memcpy(cd.points.data(), pts.data(), n_points * sizeof(float) * 4);
    cd.offsets.assign(po, po + n_off);
    cd.random.assign(rnd.data(), rnd.data() + n_curves);
    cd.material.assign(mat.data(), mat.data() + n_curves);
    if (auto nrm = get_optional(c, "normals")) {
        auto na = array_shape<float>(*nrm, sub(key, "normals"), 3);
        if (size_t(na.shape(0)) != n_points) fail(sub(key, "normals"), "expected one normal per point");
        cd.normals.resize(n_points);
        std::memcpy(cd.normals.data(), na.data(), n_points * sizeof(float) * 3);
    }
    if (auto o = get_optional(c, "point_intercept")) {
        auto a = array_shape<float>(*o, sub(key, "point_intercept"), 0);
        if (size_t(a.shape(0)) != n_points) fail(sub(key, "point_intercept"), "expected one value per point");
        cd.intercept.assign(a.data(), a.data() + n_points);
    }
    if (auto o = get_optional(c, "curve_intercept_total")) {
        auto a = array_shape<float>(*o, sub(key, "curve_intercept_total"), 0);
        if (size_t(a.shape(0)) != n_curves) fail(sub(key, "curve_intercept_total"), "expected one value per curve");
        cd.length.assign(a.data(), a.data() + n_curves);
    }
    if (auto o = get_optional(c, "curve_object")) {
        auto a = array_shape<int32_t>(*o, sub(key, "curve_object"), 0);
        if (size_t(a.shape(0)) != n_curves) fail(sub(key, "curve_object"), "expected one value per curve");
        auto t = get_optional(c, "object_transforms");
        if (!t) fail(sub(key, "object_transforms"), "missing (required with curve_object)");
        auto m = array_shape<double>(*t, sub(key, "object_transforms"), 12);
        const size_t n_objects = size_t(m.shape(0));
        for (size_t k = 0; k < n_objects; ++k) {
            std::array<double, 12> r;
            std::copy(m.data() + 12 * k, m.data() + 12 * (k + 1), r.begin());
            bool finite = true;
            for (double x : r) finite = finite && std::isfinite(x);
            if (!finite || !(std::fabs(linear_determinant(r)) > 0))
                fail(sub(key, "object_transforms") + "[" + std::to_string(k) + "]",
                     "expected a finite, invertible row-major 3x4 matrix (world from object)");
            cd.object_transforms.push_back(r);
        }
        for (size_t i = 0; i < n_curves; ++i)
            if (a.data()[i] < -1 || a.data()[i] >= int32_t(n_objects))
                fail(sub(key, "curve_object"), "expected -1 (world space) or an index into object_transforms (0 to " +
                                                   std::to_string(int64_t(n_objects) - 1) + "), got " +
                                                   std::to_string(a.data()[i]));
        cd.object.assign(a.data(), a.data() + n_curves);
    }
    if (auto o = get_optional(c, "attributes")) {
        if (!py::isinstance<py::list>(*o) && !py::isinstance<py::tuple>(*o))
            throw py::type_error("scene" + sub(key, "attributes") + ": expected a list");
        size_t i = 0;
        for (py::handle ah : *o) {
            const std::string ak = sub(key, "attributes") + "[" + std::to_string(i++) + "]";
            const py::dict ad = as_dict(ah, ak);
            CurveData::Attribute attr;
            attr.name = as_str(get(ad, ak, "name"), sub(ak, "name"));
            attr.point_domain = as_enum<bool>(get(ad, ak, "domain"), sub(ak, "domain"), {true, false});
            auto data = array_shape<float>(get(ad, ak, "data"), sub(ak, "data"), 4);
            const size_t want = attr.point_domain ? n_points : n_curves;
            if (size_t(data.shape(0)) != want)
                fail(sub(ak, "data"), std::string("expected one RGBA row per ") + (attr.point_domain ? "point" : "curve"));
            attr.rgba.resize(want);
            std::memcpy(attr.rgba.data(), data.data(), want * sizeof(float) * 4);
            cd.attributes.push_back(std::move(attr));
        }
    }
}

// `images`: the list of images the shading programs sample, (H, W, 4) float32 RGBA each.
ImageDesc read_image(py::handle h, const std::string& key) {
    ImageDesc im;
    const py::dict d = as_dict(h, key);
    im.name = as_str(get(d, key, "name"), sub(key, "name"));
    auto a = as_array<float>(get(d, key, "pixels"), sub(key, "pixels"));
    if (!a || a.ndim() != 3 || a.shape(2) != 4 || a.shape(0) < 1 || a.shape(1) < 1)
        fail(sub(key, "pixels"), "expected shape (height, width, 4) with height, width >= 1");
    im.height = int(a.shape(0));
    im.width = int(a.shape(1));
    im.pixels.assign(a.data(), a.data() + size_t(a.size()));
    return im;
}

void read_images(const py::dict& scene, SceneDesc& out) {
    auto o = get_optional(scene, "images");
    if (!o) return;
    if (!py::isinstance<py::list>(*o) && !py::isinstance<py::tuple>(*o))
        throw py::type_error("scene['images']: expected a list");
    size_t i = 0;
    for (py::handle h : *o) out.images.push_back(read_image(h, "['images'][" + std::to_string(i++) + "]"));
}

// A closure input given as {"register": k}: the value comes from the material's program.
std::optional<int32_t> as_register(py::handle h, const std::string& key) {
    if (!py::isinstance<py::dict>(h)) return std::nullopt;
    const py::dict d = py::reinterpret_borrow<py::dict>(h);
    return int32_t(as_int(get(d, key, "register"), sub(key, "register")));
}

ShadingProgram read_program(py::handle h, const std::string& key) {
    const py::dict d = as_dict(h, key);
    ShadingProgram p;
    auto code = array_shape<int32_t>(get(d, key, "code"), sub(key, "code"), 0);
    auto constants = array_shape<float>(get(d, key, "constants"), sub(key, "constants"), 0);
    p.code.assign(code.data(), code.data() + code.shape(0));
    p.constants.assign(constants.data(), constants.data() + constants.shape(0));
    const long regs = as_int(get(d, key, "registers"), sub(key, "registers"));
    if (regs < 0 || regs > (1 << 20)) fail(sub(key, "registers"), "expected 0..1048576");
    p.register_count = int32_t(regs);
    return p;
}

void read_meshes(const py::dict& scene, SceneDesc& out) {
    if (!scene.contains("meshes") || scene["meshes"].is_none()) return;
    const std::string key = "['meshes']";
    const py::dict m = as_dict(scene["meshes"], key);
    auto v = array_shape<float>(get(m, key, "vertices"), sub(key, "vertices"), 3);
    auto t = array_shape<int32_t>(get(m, key, "triangles"), sub(key, "triangles"), 3);
    auto tm = array_shape<int32_t>(get(m, key, "triangle_material"), sub(key, "triangle_material"), 0);
    if (tm.shape(0) != t.shape(0)) fail(sub(key, "triangle_material"), "expected one value per triangle");
    MeshData& md = out.meshes;
    md.vertices.resize(size_t(v.shape(0)));
    std::memcpy(md.vertices.data(), v.data(), md.vertices.size() * sizeof(float) * 3);
    md.triangles.resize(size_t(t.shape(0)));
    std::memcpy(md.triangles.data(), t.data(), md.triangles.size() * sizeof(int32_t) * 3);
    md.material.assign(tm.data(), tm.data() + tm.shape(0));
    if (m.contains("triangle_normals") && !m["triangle_normals"].is_none()) {
        auto n = array_shape<float>(m["triangle_normals"], sub(key, "triangle_normals"), 9);
        if (n.shape(0) != t.shape(0)) fail(sub(key, "triangle_normals"), "expected one row of 3 corner normals per triangle");
        md.normals.resize(size_t(n.shape(0)));
        std::memcpy(md.normals.data(), n.data(), md.normals.size() * sizeof(float) * 9);
    }
    if (m.contains("triangle_object") && !m["triangle_object"].is_none()) {
        auto to = array_shape<int32_t>(m["triangle_object"], sub(key, "triangle_object"), 0);
        if (to.shape(0) != t.shape(0)) fail(sub(key, "triangle_object"), "expected one object id per triangle");
        md.object.assign(to.data(), to.data() + to.shape(0));
    }
    if (m.contains("triangle_reversed") && !m["triangle_reversed"].is_none()) {
        auto r = array_shape<int32_t>(m["triangle_reversed"], sub(key, "triangle_reversed"), 0);
        md.reversed.resize(size_t(r.shape(0)));
        for (size_t i = 0; i < md.reversed.size(); ++i) md.reversed[i] = r.data()[i] != 0;
    }
    if (auto o = get_optional(m, "attributes")) {
        if (!py::isinstance<py::list>(*o) && !py::isinstance<py::tuple>(*o))
            throw py::type_error("scene" + sub(key, "attributes") + ": expected a list");
        size_t i = 0;
        for (py::handle item : *o) {
            const std::string ak = sub(key, "attributes") + "[" + std::to_string(i++) + "]";
            const py::dict a = as_dict(item, ak);
            MeshData::CornerAttribute attr;
            attr.name = as_str(get(a, ak, "name"), sub(ak, "name"));
            auto data = array_shape<float>(get(a, ak, "data"), sub(ak, "data"), 12);
            if (data.shape(0) != t.shape(0)) fail(sub(ak, "data"), "expected one row of 3 RGBA corners per triangle");
            attr.corners.resize(size_t(data.shape(0)));
            std::memcpy(attr.corners.data(), data.data(), attr.corners.size() * sizeof(float) * 12);
            md.attributes.push_back(std::move(attr));
        }
        const auto& curve_attributes = out.curves.attributes;
        for (size_t k = 0; k < std::min(curve_attributes.size(), md.attributes.size()); ++k)
            if (curve_attributes[k].name != md.attributes[k].name)
                fail(sub(key, "attributes") + "[" + std::to_string(k) + "]['name']",
                     "expected '" + curve_attributes[k].name + "', the curves' attribute " + std::to_string(k) +
                         " (one attribute list for both, in the programs' order)");
    }
}

PrincipledHairInputs read_hair_inputs(const py::dict& in, const std::string& key, bool& random_from_curve,
                                      std::vector<ClosureDesc::Link>& links) {
    using In = ClosureDesc::Input;
    PrincipledHairInputs h;
    auto real = [&](const char* name, double& dst, In input) {
        if (!in.contains(name)) return;
        if (auto reg = as_register(in[name], sub(key, name)))
            links.push_back({input, *reg});
        else
            dst = as_real(in[name], sub(key, name));
    };
    auto rgb = [&](const char* name, RGB& dst, In input) {
        if (!in.contains(name)) return;
        if (auto reg = as_register(in[name], sub(key, name)))
            links.push_back({input, *reg});
        else
            dst = as_rgb(in[name], sub(key, name));
    };
    rgb("color", h.color, In::Color);
    real("melanin", h.melanin, In::Melanin);
    real("melanin_redness", h.melanin_redness, In::MelaninRedness);
    rgb("tint", h.tint, In::Tint);
    rgb("absorption_coefficient", h.absorption_coefficient, In::AbsorptionCoefficient);
    real("roughness", h.roughness, In::Roughness);
    real("radial_roughness", h.radial_roughness, In::RadialRoughness);
    real("coat", h.coat, In::Coat);
    real("ior", h.ior, In::Ior);
    real("offset", h.offset, In::Offset);
    real("random_color", h.random_color, In::RandomColor);
    real("random_roughness", h.random_roughness, In::RandomRoughness);
    real("aspect_ratio", h.aspect_ratio, In::AspectRatio);
    real("reflection", h.reflection, In::Reflection);
    real("transmission", h.transmission, In::Transmission);
    real("secondary_reflection", h.secondary_reflection, In::SecondaryReflection);
    random_from_curve = true;
    if (in.contains("random") && !in["random"].is_none()) {
        if (auto reg = as_register(in["random"], sub(key, "random")))
            links.push_back({In::Random, *reg});
        else
            h.random = as_real(in["random"], sub(key, "random"));
        random_from_curve = false;
    }
    return h;
}

void read_materials(const py::dict& scene, SceneDesc& out) {
    if (!scene.contains("materials") || scene["materials"].is_none()) return;
    py::object mats = scene["materials"];
    if (!py::isinstance<py::list>(mats) && !py::isinstance<py::tuple>(mats))
        throw py::type_error("scene['materials']: expected a list");
    size_t i = 0;
    for (py::handle mh : mats) {
        const std::string key = "['materials'][" + std::to_string(i++) + "]";
        const py::dict m = as_dict(mh, key);
        MaterialDesc md;
        if (m.contains("name") && !m["name"].is_none()) md.name = as_str(m["name"], sub(key, "name"));
        if (auto prog = get_optional(m, "program")) md.program = read_program(*prog, sub(key, "program"));
        if (m.contains("emission_sampling") && !m["emission_sampling"].is_none()) {
            md.emission_sampling = as_enum<EmissionSampling>(
                m["emission_sampling"], sub(key, "emission_sampling"),
                {EmissionSampling::Auto, EmissionSampling::None, EmissionSampling::Front, EmissionSampling::Back,
                 EmissionSampling::FrontBack});
        }
        py::object closures = get(m, key, "closures");
        if (!py::isinstance<py::list>(closures) && !py::isinstance<py::tuple>(closures))
            throw py::type_error("scene" + sub(key, "closures") + ": expected a list");
        size_t j = 0;
        for (py::handle ch : closures) {
            const std::string ck = sub(key, "closures") + "[" + std::to_string(j++) + "]";
            const py::dict c = as_dict(ch, ck);
            ClosureDesc cd;
            cd.type = as_enum<ClosureDesc::Type>(get(c, ck, "type"), sub(ck, "type"),
                                                 {ClosureDesc::Type::PrincipledHair, ClosureDesc::Type::Diffuse,
                                                  ClosureDesc::Type::Emission, ClosureDesc::Type::CyclesHair,
                                                  ClosureDesc::Type::Model});
            cd.weight = c.contains("weight") ? as_rgb(c["weight"], sub(ck, "weight")) : RGB(1.0);
            if (cd.type == ClosureDesc::Type::PrincipledHair) {
                if (c.contains("model")) {
                    cd.hair_model = as_enum<ClosureDesc::HairModel>(
                        c["model"], sub(ck, "model"),
                        {ClosureDesc::HairModel::Chiang, ClosureDesc::HairModel::Huang});
                }
                if (c.contains("parametrization")) {
                    cd.hair.parametrization = as_enum<Parametrization>(
                        c["parametrization"], sub(ck, "parametrization"),
                        {Parametrization::Color, Parametrization::Melanin, Parametrization::Absorption});
                }
                const Parametrization param = cd.hair.parametrization;
                const py::dict inputs = c.contains("inputs") ? as_dict(c["inputs"], sub(ck, "inputs")) : py::dict();
                cd.hair = read_hair_inputs(inputs, sub(ck, "inputs"), cd.random_from_curve, cd.links);
                cd.hair.parametrization = param;
            } else if (cd.type == ClosureDesc::Type::Model) {  // checked and built by model_factory.h
                cd.model_name = as_str(get(c, ck, "model"), sub(ck, "model"));
                if (c.contains("path") && !c["path"].is_none()) cd.model_path = as_str(c["path"], sub(ck, "path"));
                if (c.contains("params")) {
                    const std::string pk = sub(ck, "params");
                    cd.model_params = bindings::model_params_from_dict(
                        as_dict(c["params"], pk), [&](const std::string& n) { return "scene" + pk + "['" + n + "']"; });
                }
            } else if (cd.type == ClosureDesc::Type::CyclesHair) {
                // The legacy Hair BSDF node (docs/scene_desc.md): Cycles clamps the roughnesses.
                if (c.contains("component")) {
                    cd.transmission = as_enum<bool>(c["component"], sub(ck, "component"),
                                                    {false, true});
                }
                if (c.contains("color")) cd.color = as_rgb(c["color"], sub(ck, "color"));
                if (c.contains("offset")) cd.offset = as_real(c["offset"], sub(ck, "offset"));
                if (c.contains("roughness_u")) cd.roughness_u = as_real(c["roughness_u"], sub(ck, "roughness_u"));
                if (c.contains("roughness_v")) cd.roughness_v = as_real(c["roughness_v"], sub(ck, "roughness_v"));
            } else {
                if (c.contains("color")) {
                    if (auto reg = as_register(c["color"], sub(ck, "color")))
                        cd.links.push_back({ClosureDesc::Input::Color, *reg});
                    else
                        cd.color = as_rgb(c["color"], sub(ck, "color"));
                }
                if (cd.type == ClosureDesc::Type::Emission && c.contains("strength")) {
                    if (auto reg = as_register(c["strength"], sub(ck, "strength")))
                        cd.links.push_back({ClosureDesc::Input::Strength, *reg});
                    else
                        cd.strength = as_real(c["strength"], sub(ck, "strength"));
                }
            }
            md.closures.push_back(cd);
        }
        out.materials.push_back(std::move(md));
    }
}

void read_camera(const py::dict& scene, SceneDesc& out) {
    const std::string key = "['camera']";
    const py::dict c = as_dict(get(scene, "", "camera"), key);
    CameraDesc& cam = out.camera;
    cam.type = as_enum<CameraType>(get(c, key, "type"), sub(key, "type"),
                                   {CameraType::Perspective, CameraType::Orthographic});
    cam.matrix_world = as_mat4(get(c, key, "matrix_world"), sub(key, "matrix_world"));
    py::object res = get(c, key, "resolution");
    auto r = as_array<double>(res, sub(key, "resolution"));
    if (!r || r.ndim() != 1 || r.shape(0) != 2) fail(sub(key, "resolution"), "expected (width, height)");
    const double w = r.at(0), h = r.at(1);
    if (!(w >= 1 && h >= 1 && w <= 65536 && h <= 65536 && w == std::floor(w) && h == std::floor(h)))
        fail(sub(key, "resolution"), "width and height must be integers in [1, 65536]");
    cam.width = int(w);
    cam.height = int(h);
    if (auto o = get_optional(c, "pixel_aspect")) cam.pixel_aspect = as_real(*o, sub(key, "pixel_aspect"));
    if (auto o = get_optional(c, "sensor_fit"))
        cam.sensor_fit = as_enum<SensorFit>(*o, sub(key, "sensor_fit"),
                                            {SensorFit::Auto, SensorFit::Horizontal, SensorFit::Vertical});
    auto real = [&](const char* name, double& dst) {
        if (auto o = get_optional(c, name)) dst = as_real(*o, sub(key, name));
    };
    real("sensor_width", cam.sensor_width);
    real("sensor_height", cam.sensor_height);
    real("lens", cam.lens);
    real("ortho_scale", cam.ortho_scale);
    real("shift_x", cam.shift_x);
    real("shift_y", cam.shift_y);
    real("clip_start", cam.clip_start);
    real("clip_end", cam.clip_end);
}

void read_lights(const py::dict& scene, SceneDesc& out) {
    if (!scene.contains("lights") || scene["lights"].is_none()) return;
    py::object lights = scene["lights"];
    if (!py::isinstance<py::list>(lights) && !py::isinstance<py::tuple>(lights))
        throw py::type_error("scene['lights']: expected a list");
    size_t i = 0;
    for (py::handle lh : lights) {
        const std::string key = "['lights'][" + std::to_string(i++) + "]";
        const py::dict l = as_dict(lh, key);
        LightDesc d;
        d.type = as_enum<LightType>(get(l, key, "type"), sub(key, "type"),
                                    {LightType::Sun, LightType::Point, LightType::Spot, LightType::Area});
        d.strength = as_rgb(get(l, key, "strength"), sub(key, "strength"));
        auto real = [&](const char* name, double& dst) {
            if (auto o = get_optional(l, name)) dst = as_real(*o, sub(key, name));
        };
        auto flag = [&](const char* name, bool& dst) {
            if (auto o = get_optional(l, name)) dst = as_bool(*o, sub(key, name));
        };
        flag("normalize", d.normalize);
        flag("use_mis", d.use_mis);
        flag("visible_camera", d.visible_camera);
        switch (d.type) {
            case LightType::Sun:
                d.direction = as_vec3(get(l, key, "direction"), sub(key, "direction"));
                real("angle", d.angle);
                break;
            case LightType::Point:
            case LightType::Spot:
                d.position = as_vec3(get(l, key, "position"), sub(key, "position"));
                real("radius", d.radius);
                flag("soft_falloff", d.soft_falloff);
                if (d.type == LightType::Spot) {
                    d.direction = as_vec3(get(l, key, "direction"), sub(key, "direction"));
                    real("spot_size", d.spot_size);
                    real("spot_blend", d.spot_blend);
                    flag("spot_cosine", d.spot_cosine);
                    if (auto o = get_optional(l, "matrix_world")) {
                        d.matrix_world = as_mat4(*o, sub(key, "matrix_world"));
                        d.has_matrix = true;
                    }
                }
                break;
            case LightType::Area:
                d.matrix_world = as_mat4(get(l, key, "matrix_world"), sub(key, "matrix_world"));
                d.has_matrix = true;
                d.shape = as_enum<AreaShape>(get(l, key, "shape"), sub(key, "shape"),
                                             {AreaShape::Square, AreaShape::Rectangle, AreaShape::Disk, AreaShape::Ellipse});
                d.size_x = as_real(get(l, key, "size_x"), sub(key, "size_x"));
                d.size_y = d.size_x;
                real("size_y", d.size_y);
                real("spread", d.spread);
                break;
        }
        out.lights.push_back(d);
    }
}

void read_integrator(const py::dict& scene, SceneDesc& out) {
    const std::string key = "['integrator']";
    const py::dict in = as_dict(get(scene, "", "integrator"), key);
    IntegratorSettings& s = out.integrator;
    s.samples = int(std::clamp(as_int(get(in, key, "samples"), sub(key, "samples")), 0L, 1L << 24));
    if (auto o = get_optional(in, "seed")) s.seed = uint32_t(as_int(*o, sub(key, "seed")));
    auto integer = [&](const char* name, int& dst) {
        if (auto o = get_optional(in, name)) {
            const long v = as_int(*o, sub(key, name));
            if (v < 0) fail(sub(key, name), "must be >= 0");
            dst = int(std::min(v, 1L << 20));
        }
    };
    integer("max_bounces", s.max_bounces);
    integer("diffuse_bounces", s.diffuse_bounces);
    integer("glossy_bounces", s.glossy_bounces);
    integer("transmission_bounces", s.transmission_bounces);
    integer("transparent_bounces", s.transparent_bounces);
    integer("min_light_bounces", s.min_light_bounces);
    if (auto o = get_optional(in, "filter_type"))
        s.filter = as_enum<IntegratorSettings::Filter>(*o, sub(key, "filter_type"),
                                                       {IntegratorSettings::Filter::BlackmanHarris,
                                                        IntegratorSettings::Filter::Gaussian, IntegratorSettings::Filter::Box});
    auto real = [&](const char* name, double& dst) {
        if (auto o = get_optional(in, name)) dst = as_real(*o, sub(key, name));
    };
    real("filter_width", s.filter_width);
    real("exposure", s.exposure);
    real("light_sampling_threshold", s.light_sampling_threshold);
    real("filter_glossy", s.filter_glossy);
    real("clamp_direct", s.clamp_direct);
    real("clamp_indirect", s.clamp_indirect);
    if (auto o = get_optional(in, "film_transparent")) s.film_transparent = as_bool(*o, sub(key, "film_transparent"));
    if (auto o = get_optional(in, "light_tree")) s.light_tree = as_bool(*o, sub(key, "light_tree"));
    if (auto o = get_optional(in, "chiang_lcg")) s.chiang_lcg = as_bool(*o, sub(key, "chiang_lcg"));
    if (auto o = get_optional(in, "tilt"))
        s.tilt = as_enum<TiltConvention>(*o, sub(key, "tilt"),
                                         {TiltConvention::Blender42, TiltConvention::Blender34});
    if (auto o = get_optional(in, "accuracy"))
        s.accuracy = as_enum<Accuracy>(*o, sub(key, "accuracy"), {Accuracy::Cycles, Accuracy::Exact});
    if (auto o = get_optional(in, "huang_sampler"))
        s.huang_sampler = as_enum<HuangSampler>(*o, sub(key, "huang_sampler"),
                                                {HuangSampler::Cycles, HuangSampler::Mixture});
    if (auto o = get_optional(in, "huang_glass_albedo_table"))
        s.huang_glass_albedo_table = as_enum<GlassAlbedoTable>(
            *o, sub(key, "huang_glass_albedo_table"), {GlassAlbedoTable::Cycles4, GlassAlbedoTable::Cycles5});
    if (auto o = get_optional(in, "passes")) {
        if (!py::isinstance<py::list>(*o) && !py::isinstance<py::tuple>(*o))
            fail(sub(key, "passes"), "expected a list of pass names");
        size_t i = 0;
        for (py::handle name : *o)
            *as_enum<bool*>(name, sub(key, "passes") + "[" + std::to_string(i++) + "]",
                            {&s.pass_hair_lobes, &s.pass_depth, &s.pass_normal, &s.pass_variance}) = true;
    }
}

// The scene dict -> SceneDesc: check_scene (scene_schema.h) validates and normalises it
// against the schema; the readers above copy the checked values.
SceneDesc scene_from_dict(py::handle scene_dict) {
    const py::dict scene = bindings::check_scene(scene_dict);
    SceneDesc out;
    read_curves(scene, out);
    if (auto o = get_optional(scene, "curve_shape"))
        out.curve_shape = as_enum<CurveShape>(*o, "['curve_shape']",
                                              {CurveShape::Ribbons, CurveShape::Thick, CurveShape::ThickLinear});
    if (auto o = get_optional(scene, "curve_subdivisions")) out.curve_subdivisions = int(as_int(*o, "['curve_subdivisions']"));
    if (auto o = get_optional(scene, "curve_backface_culling"))
        out.cull_curve_back_faces = as_bool(*o, "['curve_backface_culling']");
    read_meshes(scene, out);
    read_materials(scene, out);
    read_images(scene, out);
    read_camera(scene, out);
    read_lights(scene, out);
    if (auto w = get_optional(scene, "world")) {
        const py::dict wd = as_dict(*w, "['world']");
        if (auto c = get_optional(wd, "color")) out.world = as_rgb(*c, "['world']['color']");
        if (auto t = get_optional(wd, "texture")) read_environment(*t, out.world_texture);
        if (auto m = get_optional(wd, "mis")) out.world_mis = as_bool(*m, "['world']['mis']");
        if (auto r = get_optional(wd, "map_resolution")) {
            const long res = as_int(*r, "['world']['map_resolution']");
            if (res < 0 || res > 65536) fail("['world']['map_resolution']", "expected 0 (automatic) to 65536");
            out.world_map_resolution = int(res);
        }
    }
    read_integrator(scene, out);
    return out;
}

py::dict py_render(py::handle scene_dict, py::object progress, py::object cancel, int threads) {
    SceneDesc scene = scene_from_dict(scene_dict);
    if (!progress.is_none() && !PyCallable_Check(progress.ptr())) throw py::type_error("progress: expected a callable or None");
    if (!cancel.is_none() && !PyCallable_Check(cancel.ptr())) throw py::type_error("cancel: expected a callable or None");
    if (threads < 0) throw py::value_error("threads: must be >= 0 (0 = all cores)");

    std::unique_ptr<RenderJob> job_ptr;
    std::exception_ptr worker_error;
    std::optional<py::error_already_set> callback_error;
    {
        py::gil_scoped_release release;
        job_ptr = std::make_unique<RenderJob>(std::move(scene), threads);  // scene repair, no GIL
        RenderJob& job = *job_ptr;
        std::atomic<bool> done{false};
        std::thread worker([&] {
            try {
                job.run();
            } catch (...) {
                worker_error = std::current_exception();
            }
            done.store(true);
        });
        using clock = std::chrono::steady_clock;
        auto last_cancel = clock::now(), last_progress = clock::now();
        while (!done.load()) {
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
            const auto now = clock::now();
            const bool poll_cancel = now - last_cancel >= std::chrono::milliseconds(50);
            const bool poll_progress = !progress.is_none() && now - last_progress >= std::chrono::milliseconds(250);
            if (!(poll_cancel || poll_progress) || job.cancelled()) continue;
            py::gil_scoped_acquire acquire;
            try {
                // Progress first: on a loaded machine one wake-up may be due for both, and a
                // cancelled render still reports how far it got.
                if (poll_progress) {
                    last_progress = now;
                    progress(job.progress());
                }
                if (poll_cancel) {
                    last_cancel = now;
                    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
                    if (!cancel.is_none() && py::bool_(cancel())) job.cancel();
                }
            } catch (py::error_already_set& e) {
                callback_error.emplace(std::move(e));
                job.cancel();
            }
        }
        worker.join();
    }
    if (callback_error) throw *callback_error;
    if (worker_error) std::rethrow_exception(worker_error);

    const RenderOutput out = job_ptr->output();
    if (!progress.is_none() && !out.stats.cancelled) progress(1.0);
    py::array_t<float> combined({py::ssize_t(out.height), py::ssize_t(out.width), py::ssize_t(4)});
    std::memcpy(combined.mutable_data(), out.rgba.data(), out.rgba.size() * sizeof(float));
    py::dict stats;
    stats["samples"] = out.stats.samples;
    stats["seconds"] = out.stats.seconds;
    stats["build_seconds"] = out.stats.build_seconds;
    stats["rays"] = out.stats.rays;
    stats["peak_memory_bytes"] = out.stats.peak_memory_bytes;
    stats["nan_count"] = out.stats.nan_count;
    stats["cancelled"] = out.stats.cancelled;
    stats["warnings"] = out.warnings;
    py::dict result;
    result["combined"] = combined;
    result["stats"] = stats;
    const py::ssize_t h = out.height, w = out.width;
    auto image = [&](const std::vector<float>& data, std::vector<py::ssize_t> shape, size_t offset, size_t stride,
                     size_t channels) {
        py::array_t<float> a(shape);
        float* dst = a.mutable_data();
        const size_t n = size_t(h) * size_t(w);
        for (size_t i = 0; i < n; ++i)
            for (size_t c = 0; c < channels; ++c) dst[i * channels + c] = data[i * stride + offset + c];
        return a;
    };
    const Film::Passes& passes = out.passes;
    if (!passes.hair_lobes.empty()) {
        const char* names[kLobeCount] = {"hair_r", "hair_tt", "hair_trt", "hair_trrt", "hair_tts", "hair_trts"};
        for (size_t k = 0; k < size_t(kLobeCount); ++k)
            result[names[k]] = image(passes.hair_lobes, {h, w, 3}, 3 * k, 3 * kLobeCount, 3);
    }
    if (!passes.depth.empty()) result["depth"] = image(passes.depth, {h, w}, 0, 1, 1);
    if (!passes.normal.empty()) result["normal"] = image(passes.normal, {h, w, 3}, 0, 3, 3);
    if (!passes.variance.empty()) result["variance"] = image(passes.variance, {h, w, 3}, 0, 3, 3);
    return result;
}

// eval_program(program, random, intercept, length, is_strand, attributes=None, images=None) -> (M, registers)
// float32: the program run once per row of the context arrays (M values each, or scalars).
py::array_t<float> py_eval_program(py::handle program, py::handle random, py::handle intercept, py::handle length,
                                   py::handle is_strand, py::handle attributes, py::handle images) {
    const ShadingProgram p = read_program(program, "['program']");
    auto column = [](py::handle h, const char* name) {
        auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(h);
        if (!a || a.ndim() > 1) throw py::value_error(std::string(name) + ": expected a number or a 1-D array");
        return a;
    };
    const auto r = column(random, "random"), i = column(intercept, "intercept"), l = column(length, "length"),
               s = column(is_strand, "is_strand");
    size_t m = 1;
    for (const auto* a : {&r, &i, &l, &s})
        if (a->ndim() == 1) m = std::max(m, size_t(a->shape(0)));
    auto at = [&](const py::array_t<float, py::array::c_style | py::array::forcecast>& a, size_t k, const char* name) {
        if (a.ndim() == 0) return a.data()[0];
        if (size_t(a.shape(0)) != m) throw py::value_error(std::string(name) + ": expected " + std::to_string(m) + " values");
        return a.data()[k];
    };
    int n_attr = 0;
    py::array_t<float, py::array::c_style | py::array::forcecast> attr;
    if (!attributes.is_none()) {
        attr = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(attributes);
        if (!attr || attr.ndim() != 3 || size_t(attr.shape(0)) != m || attr.shape(2) != 4)
            throw py::value_error("attributes: expected shape (M, attribute count, 4)");
        n_attr = int(attr.shape(1));
    }
    std::vector<ImageDesc> image_descs;
    std::vector<ShadingImage> image_views;
    if (!images.is_none()) {
        size_t j = 0;
        for (py::handle h : images) image_descs.push_back(read_image(h, "images[" + std::to_string(j++) + "]"));
        for (const ImageDesc& im : image_descs) image_views.push_back({im.width, im.height, im.pixels.data()});
    }
    try {
        validate_program(p, n_attr, int(image_views.size()));
    } catch (const std::invalid_argument& e) {
        throw py::value_error(e.what());
    }
    py::array_t<float> out({py::ssize_t(m), py::ssize_t(p.register_count)});
    float* dst = out.mutable_data();
    for (size_t k = 0; k < m; ++k) {
        ShadingHitContext ctx;
        ctx.random = at(r, k, "random");
        ctx.intercept = at(i, k, "intercept");
        ctx.length = at(l, k, "length");
        ctx.is_strand = at(s, k, "is_strand");
        if (n_attr > 0) {
            ctx.attributes = attr.data() + k * size_t(n_attr) * 4;
            ctx.attribute_count = n_attr;
        }
        ctx.images = image_views.data();
        ctx.image_count = int(image_views.size());
        run_program(p, ctx, dst + k * size_t(p.register_count));
    }
    return out;
}

// eval_hit_bsdf(scene, material, wo, wi, h, normal, random, seed, blur) -> (value (N, 3), pdf (N,),
// lobes (N, 6, 3)): the engine's BSDF at N hits on a fibre along +x (the fibre frame of the Python
// API), set up and evaluated by the integrator's own code (render::Bsdf). Row i seeds a stochastic
// eval with lookup3_hash_uint2(i, seed), as Closure.cycles_estimate does; `normal` (N, 3) is the
// hit's shading normal (diffuse, the legacy Hair BSDF's N test), wo where None.
py::tuple py_eval_hit_bsdf(py::handle scene_dict, int material, py::handle wo_h, py::handle wi_h, py::handle h_h,
                           py::handle normal_h, double random, uint32_t seed, double blur) {
    const SceneDesc scene = scene_from_dict(scene_dict);
    if (material < 0 || size_t(material) >= scene.materials.size()) throw py::value_error("material: no such index");
    const IntegratorSettings& is = scene.integrator;
    const MaterialShader shader(scene.materials[size_t(material)], is.tilt, is.accuracy, is.huang_sampler);
    const auto wo = array_shape<double>(wo_h, "wo", 3), wi = array_shape<double>(wi_h, "wi", 3);
    const auto h = as_array<double>(h_h, "h");
    const size_t n = size_t(wo.shape(0));
    if (size_t(wi.shape(0)) != n || size_t(h.size()) != n) throw py::value_error("wo, wi, h: expected N rows each");
    py::array_t<double, py::array::c_style | py::array::forcecast> normal;
    if (!normal_h.is_none()) {
        normal = array_shape<double>(normal_h, "normal", 3);
        if (size_t(normal.shape(0)) != n) throw py::value_error("normal: expected N rows");
    }
    py::array_t<double> value({py::ssize_t(n), py::ssize_t(3)}), pdf({py::ssize_t(n)});
    py::array_t<double> lobes({py::ssize_t(n), py::ssize_t(kLobeCount), py::ssize_t(3)});
    auto row = [](const double* p, size_t i) { return Vec3{p[3 * i], p[3 * i + 1], p[3 * i + 2]}; };
    double *ov = value.mutable_data(), *op = pdf.mutable_data(), *ol = lobes.mutable_data();
    Bsdf bsdf;
    for (size_t i = 0; i < n; ++i) {
        ShadingGeometry g;
        g.wo = row(wo.data(), i);
        g.n = normal.size() ? row(normal.data(), i) : g.wo;
        g.ng = g.n;
        g.tangent = Vec3{1, 0, 0};
        g.h = h.data()[i];
        g.random = random;
        bsdf.set_seeded(shader, g, blur, lookup3_hash_uint2(uint32_t(i), seed), true);
        const BsdfValue b = bsdf.empty() ? BsdfValue{} : bsdf.eval(row(wi.data(), i));
        for (int c = 0; c < 3; ++c) {
            ov[3 * i + size_t(c)] = b.value[c];
            for (int k = 0; k < kLobeCount; ++k) ol[(i * kLobeCount + size_t(k)) * 3 + size_t(c)] = b.lobes[size_t(k)][c];
        }
        op[i] = b.pdf;
    }
    return py::make_tuple(value, pdf, lobes);
}

// shading_vm_instruction_set() -> {"ops": {name: opcode}, "argument_counts": {name: n}, enum name: {name: value}}
py::dict py_shading_vm_instruction_set() {
    const ShadingInstructionSet& set = shading_instruction_set();
    py::dict ops, counts, out;
    for (const ShadingOpInfo& op : set.ops) {
        ops[op.name] = int32_t(op.op);
        counts[op.name] = op.argument_count;
    }
    out["ops"] = ops;
    out["argument_counts"] = counts;
    for (const auto& [table, entries] : set.enums) {
        py::dict d;
        for (const ShadingNamedValue& e : entries) d[e.name] = e.value;
        out[table.c_str()] = d;
    }
    return out;
}

}  // namespace

PYBIND11_MODULE(_render, m) {
    m.doc() = "hairbsdf path tracer (Embree + TBB); use hairbsdf.render.render, not this module";
    m.def("render", &py_render, py::arg("scene"), py::arg("progress") = py::none(), py::arg("cancel") = py::none(),
          py::arg("threads") = 0,
          "Renders a scene_desc dict (docs/scene_desc.md). Returns {'combined': (H, W, 4) float32 RGBA, "
          "'stats': {samples, seconds, build_seconds, rays, peak_memory_bytes, nan_count, cancelled, warnings}} "
          "plus the passes asked for in integrator['passes']: 'hair_r', 'hair_tt', 'hair_trt', 'hair_trrt', 'hair_tts', 'hair_trts' (yan_fur's medulla lobes, 0 for other models), "
          "'normal', 'variance' (H, W, 3) and 'depth' (H, W).");
    m.def("eval_program", &py_eval_program, py::arg("program"), py::arg("random") = 0.0f,
          py::arg("intercept") = 0.0f, py::arg("length") = 0.0f, py::arg("is_strand") = 1.0f,
          py::arg("attributes") = py::none(), py::arg("images") = py::none(),
          "Runs a material's shading program (docs/shading_vm.md) for M hit contexts (numbers or (M,) arrays; "
          "attributes (M, A, 4) RGBA; images: the scene's `images` list). Returns the registers, "
          "(M, program['registers']) float32.");
    m.def("shading_vm_instruction_set", &py_shading_vm_instruction_set,
          "The shading VM's opcodes, their argument counts and its enums under Blender's identifiers "
          "(render/shading_vm.h); the exporter's compiler derives its numbers from this.");
    m.def("eval_hit_bsdf", &py_eval_hit_bsdf, py::arg("scene"), py::arg("material"), py::arg("wo"), py::arg("wi"),
          py::arg("h"), py::arg("normal") = py::none(), py::arg("random") = 0.0, py::arg("seed") = 0u,
          py::arg("blur") = 0.0,
          "The engine's BSDF at N hits on a fibre along +x, for tests: scene['materials'][material] set up and "
          "evaluated by the integrator's code. Returns (value (N, 3), pdf (N,), lobes (N, 6, 3)).");
}
