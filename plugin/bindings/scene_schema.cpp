// The scene format's table and its walker (scene_schema.h). No TBB, no Embree: compiled
// into _core (validate_scene, scene_schema) and _render (checked before reading).
#include "scene_schema.h"

#include <pybind11/numpy.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "hairbsdf/model_factory.h"

namespace py = pybind11;

namespace hairbsdf::bindings {

namespace {

using K = SceneKeyKind;

// Fluent rows for the table below.
struct Row {
    SceneKey k;
    Row(const char* path, K kind, const char* meaning) {
        k.path = path;
        k.kind = kind;
        k.meaning = meaning;
    }
    Row& required() { return k.required = true, *this; }
    Row& fallback(const char* value) { return k.default_value = value, *this; }
    Row& values(std::vector<const char*> v) { return k.allowed = std::move(v), *this; }
    Row& range(double lo, double hi) { return k.minimum = lo, k.maximum = hi, k.bounded = true, *this; }
    Row& array(const char* dtype, int columns) { return k.dtype = dtype, k.columns = columns, *this; }
    Row& columns(int n) { return k.columns = n, *this; }
    Row& only(const char* types) { return k.only_for = types, *this; }
    Row& linkable() { return k.register_link = true, *this; }
    Row& closed() { return k.closed = true, *this; }
    Row& socket(const char* name, const char* kind, const char* models) {
        return k.socket = name, k.socket_kind = kind, k.hair_models = models, *this;
    }
    operator SceneKey() const { return k; }  // NOLINT(google-explicit-constructor)
};

constexpr double kUnbounded = std::numeric_limits<double>::infinity();
constexpr const char* kHairTypes = "principled_hair";

std::vector<SceneKey> make_schema() {
    return {
        Row("version", K::Int, "the format's version").range(1, 1).fallback("1"),

        Row("curves", K::Dict, "all hair of all objects, concatenated"),
        Row("curves.points", K::Array, "x, y, z, radius (object space for curves with a curve_object >= 0)")
            .array("float32", 4).required(),
        Row("curves.curve_offsets", K::Array, "CSR: curve c owns points[curve_offsets[c]:curve_offsets[c+1]] (C + 1)")
            .array("int32", 0).required(),
        Row("curves.curve_random", K::Array, "Hair Info > Random per curve (C)").array("float32", 0).required(),
        Row("curves.curve_material", K::Array, "index into materials per curve (C)").array("int32", 0).required(),
        Row("curves.curve_intercept_total", K::Array, "curve length, for Hair Info > Length (C)").array("float32", 0),
        Row("curves.point_intercept", K::Array, "Hair Info > Intercept per key (P)").array("float32", 0),
        Row("curves.attributes", K::List, "the named curve attributes programs read"),
        Row("curves.attributes[]", K::Dict, "one attribute"),
        Row("curves.attributes[].name", K::String, "the attribute's name").required(),
        Row("curves.attributes[].domain", K::Enum, "one row per point or per curve").values({"POINT", "CURVE"})
            .required(),
        Row("curves.attributes[].data", K::Array, "RGBA rows (P or C)").array("float32", 4).required(),
        Row("curves.curve_object", K::Array, "-1: world space; k: the points are in object k's space (C)")
            .array("int32", 0),
        Row("curves.object_transforms", K::Array, "world from object k, row-major 3 x 4 (K); required with curve_object")
            .array("float64", 12),
        Row("curves.normals", K::Array, "curve normals per point: Huang's major axis (P)").array("float32", 3),
        Row("curve_shape", K::Enum, "scene.cycles_curves.shape").values({"RIBBONS", "THICK", "THICK_LINEAR"}).fallback("THICK"),
        Row("curve_subdivisions", K::Int, "scene.cycles_curves.subdivisions").range(0, kUnbounded).fallback("2"),
        Row("curve_backface_culling", K::Bool, "cull back faces of THICK curves (Cycles 3.x)").fallback("False"),

        Row("meshes", K::Dict, "all triangle meshes, concatenated"),
        Row("meshes.vertices", K::Array, "vertex positions (V)").array("float32", 3).required(),
        Row("meshes.triangles", K::Array, "vertex indices (T)").array("int32", 3).required(),
        Row("meshes.triangle_material", K::Array, "index into materials per triangle (T)").array("int32", 0).required(),
        Row("meshes.triangle_normals", K::Array, "corner normals for smooth shading (T); absent: flat")
            .array("float32", 9),
        Row("meshes.triangle_object", K::Array, "the object of each triangle, for the light tree (T)").array("int32", 0),
        Row("meshes.triangle_reversed", K::Array, "1 where the corners were reversed (a mirrored object), 0 elsewhere (T)")
            .array("int32", 0),
        Row("meshes.attributes", K::List, "the attributes programs read, at the corners; curves' names and order"),
        Row("meshes.attributes[]", K::Dict, "one attribute"),
        Row("meshes.attributes[].name", K::String, "the attribute's name (the curves' attribute at the same index)")
            .required(),
        Row("meshes.attributes[].data", K::Array, "RGBA of corners 0, 1, 2 (T)").array("float32", 12).required(),

        Row("materials", K::List, "one per Blender material slot used"),
        Row("materials[]", K::Dict, "one material"),
        Row("materials[].name", K::String, "the material's name (\"__default__\": no material)").fallback("''"),
        Row("materials[].program", K::Dict, "the node networks on closure inputs (docs/shading_vm.md)"),
        Row("materials[].program.code", K::Array, "instructions: opcode, then its arguments").array("int32", 0)
            .required(),
        Row("materials[].program.constants", K::Array, "registers 0..K-1 (read-only)").array("float32", 0).required(),
        Row("materials[].program.registers", K::Int, "R >= K float slots").range(0, 1 << 20).required(),
        Row("materials[].emission_sampling", K::Enum, "which sides of its emissive triangles NEE samples")
            .values({"AUTO", "NONE", "FRONT", "BACK", "FRONT_BACK"}).fallback("AUTO"),
        Row("materials[].closures", K::List, "a flat weighted sum of closures").required(),
        Row("materials[].closures[]", K::Dict, "one closure; its keys depend on its type"),
        Row("materials[].closures[].type", K::Enum, "the closure")
            .values({"principled_hair", "diffuse", "emission", "cycles_hair", "hair_model"}).required(),
        Row("materials[].closures[].weight", K::Vector, "RGB weight").columns(3).fallback("(1, 1, 1)"),
        Row("materials[].closures[].model", K::Enum, "Principled Hair's model").values({"CHIANG", "HUANG"})
            .fallback("CHIANG").only(kHairTypes),
        Row("materials[].closures[].parametrization", K::Enum, "Principled Hair's parametrization")
            .values({"COLOR", "MELANIN", "ABSORPTION"}).fallback("COLOR").only(kHairTypes),
        Row("materials[].closures[].inputs", K::Dict, "Principled Hair's socket values; missing: Blender 4.5's defaults")
            .fallback("{}").only(kHairTypes).closed(),
        Row("materials[].closures[].inputs.color", K::Vector, "Color").columns(3).linkable()
            .socket("Color", "color", "CHIANG HUANG"),
        Row("materials[].closures[].inputs.melanin", K::Real, "Melanin").linkable()
            .socket("Melanin", "float", "CHIANG HUANG"),
        Row("materials[].closures[].inputs.melanin_redness", K::Real, "Melanin Redness").linkable()
            .socket("Melanin Redness", "float", "CHIANG HUANG"),
        Row("materials[].closures[].inputs.tint", K::Vector, "Tint").columns(3).linkable()
            .socket("Tint", "color", "CHIANG HUANG"),
        Row("materials[].closures[].inputs.absorption_coefficient", K::Vector, "Absorption Coefficient").columns(3)
            .linkable()
            .socket("Absorption Coefficient", "vector", "CHIANG HUANG"),
        Row("materials[].closures[].inputs.roughness", K::Real, "Roughness").linkable()
            .socket("Roughness", "float", "CHIANG HUANG"),
        Row("materials[].closures[].inputs.radial_roughness", K::Real, "Radial Roughness (Chiang)").linkable()
            .socket("Radial Roughness", "float", "CHIANG"),
        Row("materials[].closures[].inputs.coat", K::Real, "Coat (Chiang)").linkable()
            .socket("Coat", "float", "CHIANG"),
        Row("materials[].closures[].inputs.ior", K::Real, "IOR").linkable()
            .socket("IOR", "float", "CHIANG HUANG"),
        Row("materials[].closures[].inputs.offset", K::Real, "Offset, radians").linkable()
            .socket("Offset", "float", "CHIANG HUANG"),
        Row("materials[].closures[].inputs.random_color", K::Real, "Random Color").linkable()
            .socket("Random Color", "float", "CHIANG HUANG"),
        Row("materials[].closures[].inputs.random_roughness", K::Real, "Random Roughness").linkable()
            .socket("Random Roughness", "float", "CHIANG HUANG"),
        Row("materials[].closures[].inputs.random", K::Real, "Random; None: the curve's curve_random").linkable()
            .socket("Random", "float", ""),
        Row("materials[].closures[].inputs.aspect_ratio", K::Real, "Aspect Ratio (Huang)").linkable()
            .socket("Aspect Ratio", "float", "HUANG"),
        Row("materials[].closures[].inputs.reflection", K::Real, "Reflection (Huang)").linkable()
            .socket("Reflection", "float", "HUANG"),
        Row("materials[].closures[].inputs.transmission", K::Real, "Transmission (Huang)").linkable()
            .socket("Transmission", "float", "HUANG"),
        Row("materials[].closures[].inputs.secondary_reflection", K::Real, "Secondary Reflection (Huang)").linkable()
            .socket("Secondary Reflection", "float", "HUANG"),
        Row("materials[].closures[].component", K::Enum, "the legacy Hair BSDF's component")
            .values({"REFLECTION", "TRANSMISSION"}).fallback("REFLECTION").only("cycles_hair"),
        Row("materials[].closures[].color", K::Vector, "the legacy Hair BSDF's colour").columns(3).fallback("(0.8, 0.8, 0.8)")
            .only("cycles_hair"),
        Row("materials[].closures[].offset", K::Real, "the legacy Hair BSDF's offset, radians").fallback("0")
            .only("cycles_hair"),
        Row("materials[].closures[].roughness_u", K::Real, "clamped to [0.001, 1]").fallback("0.1").only("cycles_hair"),
        Row("materials[].closures[].roughness_v", K::Real, "clamped to [0.001, 1]").fallback("1").only("cycles_hair"),
        Row("materials[].closures[].color", K::Vector, "the diffuse / emission colour").columns(3)
            .fallback("(0.8, 0.8, 0.8)").only("diffuse emission").linkable(),
        Row("materials[].closures[].strength", K::Real, "the emission strength").fallback("1").only("emission")
            .linkable(),
        Row("materials[].closures[].model", K::ModelName, "a zoo model's name or plugin (the model factory)")
            .required().only("hair_model"),
        Row("materials[].closures[].path", K::String, "the plugin library (docs/plugins.md); required for plugin")
            .only("hair_model"),
        Row("materials[].closures[].params", K::ModelParams, "the model's parameters (hairbsdf.model_schema)")
            .fallback("{}").only("hair_model"),

        Row("camera", K::Dict, "the render camera").required(),
        Row("camera.type", K::Enum, "perspective or orthographic").values({"PERSP", "ORTHO"}).required(),
        Row("camera.matrix_world", K::Matrix, "world from camera (looks down -Z, +Y up), scale removed").columns(4)
            .required(),
        Row("camera.resolution", K::IntPair, "(width, height) in pixels").range(1, 65536).required(),
        Row("camera.pixel_aspect", K::Real, "pixel_aspect_y / pixel_aspect_x").fallback("1"),
        Row("camera.sensor_fit", K::Enum, "the sensor fit").values({"AUTO", "HORIZONTAL", "VERTICAL"}).fallback("AUTO"),
        Row("camera.sensor_width", K::Real, "mm").fallback("36"),
        Row("camera.sensor_height", K::Real, "mm").fallback("24"),
        Row("camera.lens", K::Real, "focal length, mm (PERSP)").fallback("50"),
        Row("camera.ortho_scale", K::Real, "ORTHO").fallback("1"),
        Row("camera.shift_x", K::Real, "fractions of the larger image side").fallback("0"),
        Row("camera.shift_y", K::Real, "fractions of the larger image side").fallback("0"),
        Row("camera.clip_start", K::Real, "near clip").fallback("0.1"),
        Row("camera.clip_end", K::Real, "far clip").fallback("100"),

        Row("lights", K::List, "Blender's raw light values"),
        Row("lights[]", K::Dict, "one light; its keys depend on its type"),
        Row("lights[].type", K::Enum, "the light").values({"SUN", "POINT", "SPOT", "AREA"}).required(),
        Row("lights[].strength", K::Vector, "colour x energy (W; SUN: irradiance)").columns(3).required(),
        Row("lights[].normalize", K::Bool, "Light.normalize (4.x)").fallback("True"),
        Row("lights[].use_mis", K::Bool, "multiple importance sampling").fallback("True"),
        Row("lights[].visible_camera", K::Bool, "Object > Visibility > Camera").fallback("True"),
        Row("lights[].direction", K::Vector, "SUN: towards the light; SPOT: the spot axis").columns(3).required()
            .only("SUN SPOT"),
        Row("lights[].angle", K::Real, "the sun's angular diameter, radians").fallback("0").only("SUN"),
        Row("lights[].position", K::Vector, "the light's position").columns(3).required().only("POINT SPOT"),
        Row("lights[].radius", K::Real, "the light's radius").fallback("0").only("POINT SPOT"),
        Row("lights[].soft_falloff", K::Bool, "Light.use_soft_falloff (4.x)").fallback("True").only("POINT SPOT"),
        Row("lights[].spot_size", K::Real, "the cone's angle, radians").required().only("SPOT"),
        Row("lights[].spot_blend", K::Real, "the cone's smoothstep blend").required().only("SPOT"),
        Row("lights[].matrix_world", K::Matrix, "the spot's matrix (scale shapes the cone)").columns(4).only("SPOT"),
        Row("lights[].spot_cosine", K::Bool, "Cycles 3.x cone attenuation").fallback("False").only("SPOT"),
        Row("lights[].matrix_world", K::Matrix, "world from light (emits along local -Z)").columns(4).required()
            .only("AREA"),
        Row("lights[].shape", K::Enum, "the area's shape").values({"SQUARE", "RECTANGLE", "DISK", "ELLIPSE"}).required()
            .only("AREA"),
        Row("lights[].size_x", K::Real, "the area's size along local x").required().only("AREA"),
        Row("lights[].size_y", K::Real, "the area's size along local y").fallback("size_x").only("AREA"),
        Row("lights[].spread", K::Real, "the area's spread, radians").fallback("pi").only("AREA"),

        Row("world", K::Dict, "the background; absent: black"),
        Row("world.color", K::Vector, "uniform background radiance (colour x strength)").columns(3)
            .fallback("(0, 0, 0)"),
        Row("world.mis", K::Bool, "World > Settings > Sampling").fallback("True"),
        Row("world.map_resolution", K::Int, "the light tree's importance map, res x res/2; 0: automatic")
            .range(0, 65536).fallback("0"),
        Row("world.texture", K::Dict, "one equirectangular Environment Texture, added to the colour"),
        Row("world.texture.pixels", K::Image, "scene-linear RGB, row 0 the zenith").array("float32", 3).required(),
        Row("world.texture.weight", K::Vector, "Background strength x Mix / Add weights").columns(3).required(),
        Row("world.texture.interpolation", K::Enum, "the lookup").values({"LINEAR", "CLOSEST"}).fallback("LINEAR"),
        Row("world.texture.srgb_encoded", K::Bool, "pixels are sRGB-encoded, decoded after the lookup")
            .fallback("False"),
        Row("world.texture.matrix", K::Matrix, "lookup vector = M (direction, 1): a Mapping node").columns(3)
            .fallback("identity"),

        Row("images", K::List, "the images the programs' Image Texture nodes sample"),
        Row("images[]", K::Dict, "one image; index = the ImageTexture op's image index"),
        Row("images[].name", K::String, "the image's name").fallback("''"),
        Row("images[].pixels", K::Image, "RGBA, row 0 the image's top row").array("float32", 4).required(),

        Row("integrator", K::Dict, "the render settings").required(),
        Row("integrator.samples", K::Int, "samples per pixel").range(0, kUnbounded).required(),
        Row("integrator.seed", K::Int, "the seed (taken modulo 2^32)").fallback("0"),
        Row("integrator.max_bounces", K::Int, "bounce budget").range(0, kUnbounded).fallback("12"),
        Row("integrator.diffuse_bounces", K::Int, "bounce budget").range(0, kUnbounded).fallback("4"),
        Row("integrator.glossy_bounces", K::Int, "bounce budget").range(0, kUnbounded).fallback("4"),
        Row("integrator.transmission_bounces", K::Int, "bounce budget").range(0, kUnbounded).fallback("12"),
        Row("integrator.transparent_bounces", K::Int, "bounce budget").range(0, kUnbounded).fallback("8"),
        Row("integrator.min_light_bounces", K::Int, "bounces before Russian roulette").range(0, kUnbounded)
            .fallback("0"),
        Row("integrator.filter_type", K::Enum, "the pixel filter").values({"BLACKMAN_HARRIS", "GAUSSIAN", "BOX"})
            .fallback("BLACKMAN_HARRIS"),
        Row("integrator.filter_width", K::Real, "pixels").fallback("1.5"),
        Row("integrator.exposure", K::Real, "film exposure multiplier").fallback("1"),
        Row("integrator.film_transparent", K::Bool, "transparent film").fallback("False"),
        Row("integrator.light_sampling_threshold", K::Real, "ignored (Cycles' roulette is unbiased)").fallback("0"),
        Row("integrator.light_tree", K::Bool, "Cycles' light tree for NEE (4.x)").fallback("False"),
        Row("integrator.chiang_lcg", K::Bool, "Cycles < 3.6: Chiang's per-hit LCG").fallback("False"),
        Row("integrator.tilt", K::Enum, "Principled Hair tilt convention").values({"4.2", "3.4"}).fallback("4.2"),
        Row("integrator.filter_glossy", K::Real, "scene.cycles.blur_glossy").fallback("0"),
        Row("integrator.clamp_direct", K::Real, "sample clamp, 0: off").fallback("0"),
        Row("integrator.clamp_indirect", K::Real, "sample clamp, 0: off").fallback("0"),
        Row("integrator.accuracy", K::Enum, "Cycles' truncated Bessel series or exact functions")
            .values({"cycles", "exact"}).fallback("cycles"),
        Row("integrator.huang_sampler", K::Enum, "Huang's BSDF sampler (docs/huang.md)").values({"cycles", "mixture"})
            .fallback("cycles"),
        Row("integrator.huang_glass_albedo_table", K::Enum, "Huang's energy-compensation tables")
            .values({"4.x", "5.x"}).fallback("4.x"),
        Row("integrator.passes", K::EnumList, "extra images in the result (docs/engine.md)")
            .values({"hair_lobes", "depth", "normal", "variance"}).fallback("[]"),

        Row("source", K::Informational, "where the scene came from; not read"),
        Row("source.blender_version", K::Informational, "informational"),
        Row("source.scene", K::Informational, "informational"),
        Row("source.view_layer", K::Informational, "informational"),
        Row("source.frame", K::Informational, "informational"),
        Row("source.render", K::Informational, "informational (final-render export rules used)"),
    };
}

std::string leaf(const std::string& path) {
    const size_t dot = path.rfind('.');
    return dot == std::string::npos ? path : path.substr(dot + 1);
}

std::string parent(const std::string& path) {
    const size_t dot = path.rfind('.');
    return dot == std::string::npos ? std::string() : path.substr(0, dot);
}

std::string type_name(py::handle v) { return py::str(py::type::of(v).attr("__name__")); }

std::string repr_of(py::handle v) { return py::repr(v); }

std::string python_list(const std::vector<std::string>& names) {
    std::string s = "[";
    for (size_t i = 0; i < names.size(); ++i) s += (i ? ", '" : "'") + names[i] + "'";
    return s + "]";
}

[[noreturn]] void value_error(const std::string& key, const std::string& what) { throw py::value_error(key + ": " + what); }
[[noreturn]] void type_error(const std::string& key, const std::string& what) { throw py::type_error(key + ": " + what); }

std::string shape_text(py::handle array) { return py::str(array.attr("shape")); }

bool contains(const char* space_separated, const std::string& word) {
    std::istringstream in(space_separated);
    std::string w;
    while (in >> w)
        if (w == word) return true;
    return false;
}

std::string format_number(double x) {
    if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
    std::ostringstream s;
    s << x;
    return s.str();
}

class Walker {
public:
    Walker() : rows_(scene_schema()), np_(py::module_::import("numpy")), numbers_(py::module_::import("numbers")) {}

    py::dict scene(py::handle v) {
        root_ = py::dict();
        walk_dict("", v, "scene", root_);
        return root_;
    }

private:
    const std::vector<SceneKey>& rows_;
    py::module_ np_, numbers_;
    py::dict root_;

    bool is_real(py::handle v) const {
        return !py::isinstance<py::bool_>(v) && !py::isinstance(v, np_.attr("bool_")) &&
               py::isinstance(v, numbers_.attr("Real"));
    }
    bool is_integral(py::handle v) const {
        return !py::isinstance<py::bool_>(v) && !py::isinstance(v, np_.attr("bool_")) &&
               py::isinstance(v, numbers_.attr("Integral"));
    }

    const SceneKey& row(const std::string& path) const {
        for (const SceneKey& k : rows_)
            if (path == k.path) return k;
        throw std::logic_error("scene schema: no row " + path);
    }

    py::dict as_dict(py::handle v, const std::string& key) const {
        if (!py::isinstance<py::dict>(v)) type_error(key, "expected a dict, got " + type_name(v));
        return py::reinterpret_borrow<py::dict>(v);
    }

    py::list as_list(py::handle v, const std::string& key) const {
        if (!py::isinstance<py::list>(v) && !py::isinstance<py::tuple>(v))
            type_error(key, "expected a list, got " + type_name(v));
        return py::list(py::reinterpret_borrow<py::object>(v));
    }

    void walk_dict(const std::string& path, py::handle v, const std::string& key, py::dict& out) {
        const py::dict d = as_dict(v, key);
        std::string type;
        std::vector<std::string> names;
        for (const SceneKey& k : rows_) {
            const std::string p = k.path;
            if (parent(p) != path || p.back() == ']') continue;
            if (path.empty() && p.find('[') != std::string::npos) continue;
            const std::string name = leaf(p);
            if (*k.only_for && !contains(k.only_for, type)) continue;
            names.push_back(name);
            if (k.kind == K::Informational) continue;
            const std::string child_key = key + "['" + name + "']";
            if (!d.contains(name.c_str()) || d[name.c_str()].is_none()) {
                if (k.required) value_error(child_key, "missing (required, see docs/scene_desc.md)");
                continue;
            }
            out[name.c_str()] = convert(k, d[name.c_str()], child_key);
            if (name == "type") type = py::str(out["type"]);
        }
        if (!path.empty() && row(path).closed) {
            for (const auto& item : d) {
                const std::string name = py::str(item.first);
                if (std::find(names.begin(), names.end(), name) == names.end())
                    value_error(key + "['" + name + "']", "unknown input; allowed: " + python_list(names));
            }
        }
        check_rules(path, out, key);
    }

    py::object link(py::handle v, const std::string& key) {
        const py::dict d = py::reinterpret_borrow<py::dict>(v);
        std::vector<std::string> keys;
        for (const auto& item : d) keys.push_back(py::str(item.first));
        std::sort(keys.begin(), keys.end());
        if (keys != std::vector<std::string>{"register"})
            value_error(key, "expected a number or {'register': slot}, got keys " + python_list(keys));
        py::dict out;
        out["register"] = integer(d["register"], key + "['register']", 0, kUnbounded);
        return out;
    }

    py::object integer(py::handle v, const std::string& key, double lo, double hi) {
        if (!is_integral(v)) type_error(key, "expected an integer, got " + type_name(v));
        py::int_ i(py::reinterpret_borrow<py::object>(v));
        const double x = i.cast<double>();
        if (x < lo) value_error(key, "must be >= " + format_number(lo) + ", got " + repr_of(i));
        if (x > hi) value_error(key, "must be <= " + format_number(hi) + ", got " + repr_of(i));
        return std::move(i);
    }

    py::object choice(py::handle v, const std::string& key, const std::vector<std::string>& allowed) {
        if (!py::isinstance<py::str>(v)) type_error(key, "expected a string, one of " + python_list(allowed));
        const std::string s = py::str(v);
        if (std::find(allowed.begin(), allowed.end(), s) == allowed.end())
            value_error(key, repr_of(v) + " is not allowed; use one of " + python_list(allowed));
        return py::str(s);
    }

    py::object vector(py::handle v, const std::string& key, int n, const char* what = "numbers") {
        py::object a;
        try {
            a = np_.attr("asarray")(v, "float64");
        } catch (py::error_already_set&) {
            type_error(key, "expected " + std::to_string(n) + " " + what);
        }
        if (py::len(a.attr("shape")) != 1 || a.attr("shape")[py::int_(0)].cast<int>() != n)
            value_error(key, "expected " + std::to_string(n) + " " + what + ", got shape " + shape_text(a));
        py::tuple t(n);
        for (int i = 0; i < n; ++i) t[size_t(i)] = py::float_(a[py::int_(i)]);
        return std::move(t);
    }

    py::object matrix(py::handle v, const std::string& key, bool three_or_four_rows) {
        const std::string what = three_or_four_rows ? "a 3x4 or 4x4 matrix" : "a 4x4 matrix";
        py::object a;
        try {
            a = np_.attr("asarray")(v, "float64");
        } catch (py::error_already_set&) {
            type_error(key, "expected " + what);
        }
        const py::tuple shape = a.attr("shape");
        const bool ok = shape.size() == 2 && shape[1].cast<long>() == 4 &&
                        (shape[0].cast<long>() == 4 || (three_or_four_rows && shape[0].cast<long>() == 3));
        if (!ok) value_error(key, "expected " + what + ", got shape " + shape_text(a));
        if (three_or_four_rows) a = a[py::slice(0, 3, 1)];
        return np_.attr("ascontiguousarray")(a);
    }

    // (N,) or (N, columns) in dtype; integer dtypes need integral values within int32.
    py::object array(py::handle v, const std::string& key, const std::string& dtype, int columns) {
        py::object a;
        if (py::isinstance(v, np_.attr("ndarray"))) {
            a = py::reinterpret_borrow<py::object>(v);
        } else {
            try {
                a = np_.attr("asarray")(v);
            } catch (py::error_already_set&) {
                type_error(key, "expected an array");
            }
        }
        if (a.attr("size").cast<long>() == 0) {
            a = columns == 0 ? a.attr("reshape")(py::make_tuple(0)) : a.attr("reshape")(py::make_tuple(0, columns));
            a = a.attr("astype")(dtype);
        }
        const py::object kind = a.attr("dtype").attr("kind");
        const std::string k = py::str(kind);
        if (k != "f" && k != "i" && k != "u" && k != "b" && k != "c")
            type_error(key, "dtype " + std::string(py::str(a.attr("dtype"))) + " is not allowed; pass numbers");
        const int ndim = a.attr("ndim").cast<int>();
        const py::tuple shape = a.attr("shape");
        if (ndim != (columns == 0 ? 1 : 2) || (columns != 0 && shape[1].cast<int>() != columns))
            value_error(key, "expected shape " + std::string(columns == 0 ? "(N,)" : "(N, " + std::to_string(columns) + ")") +
                                 ", got " + shape_text(a));
        if (dtype == "int32") {
            if (k != "i" && k != "u") {
                const bool integral = np_.attr("all")(np_.attr("isfinite")(a)).cast<bool>() &&
                                      np_.attr("all")(a.attr("__eq__")(np_.attr("round")(a))).cast<bool>();
                if (!integral) type_error(key, "expected integers");
            }
            if (a.attr("size").cast<long>() > 0 &&
                (a.attr("min")().cast<double>() < -2147483648.0 || a.attr("max")().cast<double>() > 2147483647.0))
                value_error(key, "values outside the int32 range");
        }
        return np_.attr("ascontiguousarray")(a, dtype);
    }

    py::object image(py::handle v, const std::string& key, int channels) {
        py::object a;
        try {
            a = np_.attr("asarray")(v, "float32");
        } catch (py::error_already_set&) {
            type_error(key, "expected an array of numbers");
        }
        const py::tuple shape = a.attr("shape");
        if (shape.size() != 3 || shape[2].cast<long>() != channels || shape[0].cast<long>() < 1 ||
            shape[1].cast<long>() < 1)
            value_error(key, "expected shape (height, width, " + std::to_string(channels) +
                                 ") with height, width >= 1, got " + shape_text(a));
        return np_.attr("ascontiguousarray")(a);
    }

    // A hair_model parameter: a bool, a number, a string (a choice) or an RGB triple.
    py::object model_param(py::handle v, const std::string& key) {
        if (py::isinstance<py::bool_>(v) || py::isinstance(v, np_.attr("bool_"))) return py::bool_(v.cast<bool>());
        if (py::isinstance<py::str>(v)) return py::reinterpret_borrow<py::object>(v);
        if (is_real(v)) return py::float_(py::reinterpret_borrow<py::object>(v));
        if (v.is_none() || py::isinstance<py::dict>(v) || !py::hasattr(v, "__len__"))
            type_error(key, "expected a number, an RGB triple, a string or a bool, got " + type_name(v));
        return vector(v, key, 3, "numbers (r, g, b)");
    }

    std::vector<std::string> allowed(const SceneKey& k) const {
        std::vector<std::string> out(k.allowed.begin(), k.allowed.end());
        if (k.kind == K::ModelName) {
            out = zoo_model_names();
            out.push_back("plugin");
        }
        return out;
    }

    py::object convert(const SceneKey& k, py::handle v, const std::string& key) {
        if (k.register_link && py::isinstance<py::dict>(v)) return link(v, key);
        switch (k.kind) {
            case K::Dict: {
                py::dict out;
                walk_dict(k.path, v, key, out);
                return std::move(out);
            }
            case K::List: {
                const SceneKey& item = row(std::string(k.path) + "[]");
                py::list out;
                size_t i = 0;
                for (py::handle x : as_list(v, key)) out.append(convert(item, x, key + "[" + std::to_string(i++) + "]"));
                return std::move(out);
            }
            case K::Real:
                if (!is_real(v)) type_error(key, "expected a number, got " + type_name(v));
                return py::float_(py::reinterpret_borrow<py::object>(v));
            case K::Int: {
                py::object i = integer(v, key, k.bounded ? k.minimum : -kUnbounded, k.bounded ? k.maximum : kUnbounded);
                if (std::string(k.path) == "integrator.seed") i = i.attr("__and__")(py::int_(0xFFFFFFFFu));
                return i;
            }
            case K::Bool:
                if (!py::isinstance<py::bool_>(v) && !py::isinstance(v, np_.attr("bool_")))
                    type_error(key, "expected a bool, got " + type_name(v));
                return py::bool_(v.cast<bool>());
            case K::String:
                if (!py::isinstance<py::str>(v)) type_error(key, "expected a string");
                return py::reinterpret_borrow<py::object>(v);
            case K::Enum:
            case K::ModelName:
                return choice(v, key, allowed(k));
            case K::EnumList: {
                py::list out;
                size_t i = 0;
                for (py::handle x : as_list(v, key)) out.append(choice(x, key + "[" + std::to_string(i++) + "]", allowed(k)));
                return std::move(out);
            }
            case K::Vector:
                return vector(v, key, k.columns);
            case K::IntPair: {
                if (!(py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v) ||
                      py::isinstance(v, np_.attr("ndarray"))) ||
                    py::len(v) != 2)
                    value_error(key, "expected (width, height)");
                const py::object seq = py::reinterpret_borrow<py::object>(v);
                return py::make_tuple(integer(seq[py::int_(0)], key + "[0]", k.minimum, k.maximum),
                                      integer(seq[py::int_(1)], key + "[1]", k.minimum, k.maximum));
            }
            case K::Matrix:
                return matrix(v, key, k.columns == 3);
            case K::Array:
                return array(v, key, k.dtype, k.columns);
            case K::Image:
                return image(v, key, k.columns);
            case K::ModelParams: {
                py::dict out;
                for (const auto& item : as_dict(v, key)) {
                    if (!py::isinstance<py::str>(item.first))
                        type_error(key, "parameter names must be strings, got " + repr_of(item.first));
                    const std::string name = py::str(item.first);
                    out[item.first] = model_param(item.second, key + "['" + name + "']");
                }
                return std::move(out);
            }
            case K::Informational:
                break;
        }
        return py::none();
    }

    // ----- rules that relate keys to one another -----

    static long rows_of(const py::dict& d, const char* name) {
        return d.contains(name) ? py::len(d[name]) : -1;
    }

    void check_rules(const std::string& path, py::dict& out, const std::string& key) {
        if (path == "curves") check_curves(out, key);
        else if (path == "meshes") check_meshes(out, key);
        else if (path == "materials[].program") check_program(out, key);
        else if (path == "materials[].closures[]") check_hair_model(out, key);
    }

    static void count(const py::dict& d, const char* name, long want, const std::string& key, const std::string& what) {
        const long n = rows_of(d, name);
        if (n >= 0 && n != want)
            value_error(key + "['" + name + "']", "expected " + what + " (" + std::to_string(want) + "), got " + std::to_string(n));
    }

    void check_curves(py::dict& c, const std::string& key) {
        const long n_points = rows_of(c, "points");
        const auto offsets = py::array_t<int32_t>::ensure(c["curve_offsets"]);
        const long n_offsets = long(offsets.size());
        const long n_curves = std::max(n_offsets - 1, 0L);
        if (n_offsets == 0 && n_points > 0)
            value_error(key + "['curve_offsets']", "expected C + 1 entries for " + std::to_string(n_points) + " points");
        if (n_offsets > 0) {
            const int32_t* o = offsets.data();
            if (o[0] != 0 || o[n_offsets - 1] != n_points)
                value_error(key + "['curve_offsets']",
                            "must start at 0 and end at len(points) = " + std::to_string(n_points));
            for (long i = 0; i + 1 < n_offsets; ++i)
                if (o[i + 1] < o[i]) value_error(key + "['curve_offsets']", "must be non-decreasing");
        }
        count(c, "curve_random", n_curves, key, "one value per curve");
        count(c, "curve_material", n_curves, key, "one value per curve");
        count(c, "curve_intercept_total", n_curves, key, "one value per curve");
        count(c, "point_intercept", n_points, key, "one value per point");
        count(c, "normals", n_points, key, "one normal per point");
        if (c.contains("curve_object")) {
            count(c, "curve_object", n_curves, key, "one value per curve");
            if (!c.contains("object_transforms"))
                value_error(key + "['object_transforms']", "missing (required with curve_object)");
            const auto m = py::array_t<double>::ensure(c["object_transforms"]);
            const long n_objects = long(m.shape(0));
            for (long k = 0; k < n_objects; ++k) {
                const double* r = m.data() + 12 * k;
                bool finite = true;
                for (int i = 0; i < 12; ++i) finite = finite && std::isfinite(r[i]);
                const double det = r[0] * (r[5] * r[10] - r[6] * r[9]) - r[1] * (r[4] * r[10] - r[6] * r[8]) +
                                   r[2] * (r[4] * r[9] - r[5] * r[8]);
                if (!finite || det == 0.0)
                    value_error(key + "['object_transforms'][" + std::to_string(k) + "]",
                                "expected a finite, invertible row-major 3x4 matrix (world from object)");
            }
            const auto objects = py::array_t<int32_t>::ensure(c["curve_object"]);
            for (long i = 0; i < long(objects.size()); ++i)
                if (objects.data()[i] < -1 || objects.data()[i] >= n_objects)
                    value_error(key + "['curve_object']", "expected -1 (world space) or an index into object_transforms (0 to " +
                                                              std::to_string(n_objects - 1) + ")");
        }
        if (c.contains("attributes")) {
            size_t i = 0;
            for (py::handle a : py::list(c["attributes"])) {
                const py::dict attr = py::reinterpret_borrow<py::dict>(a);
                const bool point = std::string(py::str(attr["domain"])) == "POINT";
                count(attr, "data", point ? n_points : n_curves, key + "['attributes'][" + std::to_string(i++) + "]",
                      point ? "one RGBA row per point" : "one RGBA row per curve");
            }
        }
    }

    void check_meshes(py::dict& m, const std::string& key) {
        const long n = rows_of(m, "triangles");
        count(m, "triangle_material", n, key, "one value per triangle");
        count(m, "triangle_normals", n, key, "one row of 3 corner normals per triangle");
        count(m, "triangle_object", n, key, "one object id per triangle");
        count(m, "triangle_reversed", n, key, "one flag per triangle");
        if (!m.contains("attributes")) return;
        std::vector<py::object> curve_names;
        if (root_.contains("curves")) {
            const py::dict curves = root_["curves"];
            if (curves.contains("attributes"))
                for (py::handle a : py::list(curves["attributes"]))
                    curve_names.push_back(py::reinterpret_borrow<py::dict>(a)["name"]);
        }
        size_t i = 0;
        for (py::handle a : py::list(m["attributes"])) {
            const py::dict attr = py::reinterpret_borrow<py::dict>(a);
            const std::string ak = key + "['attributes'][" + std::to_string(i) + "]";
            if (i < curve_names.size() && !py::object(attr["name"]).equal(curve_names[i]))
                value_error(ak + "['name']", "expected " + repr_of(curve_names[i]) + ", the curves' attribute " +
                                                 std::to_string(i) +
                                                 " (one attribute list for both, in the programs' order)");
            count(attr, "data", n, ak, "one row of 3 RGBA corners per triangle");
            ++i;
        }
    }

    static void check_program(py::dict& p, const std::string& key) {
        const long constants = rows_of(p, "constants");
        if (p["registers"].cast<long>() < constants)
            value_error(key + "['registers']", "must be >= " + std::to_string(constants) + " (the constants), got " +
                                                   std::string(py::str(p["registers"])));
    }

    static void check_hair_model(py::dict& c, const std::string& key) {
        if (std::string(py::str(c["type"])) == "hair_model" && std::string(py::str(c["model"])) == "plugin" &&
            !c.contains("path"))
            value_error(key + "['path']", "missing (required, see docs/scene_desc.md)");
    }
};

const char* kind_name(K kind) {
    switch (kind) {
        case K::Dict: return "dict";
        case K::List: return "list";
        case K::Real: return "float";
        case K::Int: return "int";
        case K::Bool: return "bool";
        case K::String: return "str";
        case K::Enum: return "enum";
        case K::EnumList: return "list of enum";
        case K::Vector: return "vector";
        case K::IntPair: return "int pair";
        case K::Matrix: return "matrix";
        case K::Array: return "array";
        case K::Image: return "image";
        case K::ModelName: return "model name";
        case K::ModelParams: return "model params";
        case K::Informational: return "informational";
    }
    return "";
}

}  // namespace

const std::vector<SceneKey>& scene_schema() {
    static const std::vector<SceneKey> rows = make_schema();
    return rows;
}

const SceneKey& scene_key(const std::string& path) {
    const SceneKey* found = nullptr;
    for (const SceneKey& k : scene_schema())
        if (path == k.path && (!found || (found->allowed.empty() && !k.allowed.empty()))) found = &k;
    if (found) return *found;
    if (path.size() > 2 && path.compare(path.size() - 2, 2, "[]") == 0) return scene_key(path.substr(0, path.size() - 2));
    throw std::logic_error("scene schema: no row " + path);
}

py::dict check_scene(py::handle scene) { return Walker().scene(scene); }

py::list scene_schema_as_python() {
    py::list out;
    for (const SceneKey& k : scene_schema()) {
        py::dict d;
        d["path"] = k.path;
        d["kind"] = kind_name(k.kind);
        d["dtype"] = k.dtype;
        d["columns"] = k.columns;
        d["required"] = k.required;
        d["default"] = k.default_value;
        py::list allowed;
        for (const char* a : k.allowed) allowed.append(a);
        d["allowed"] = allowed;
        d["minimum"] = k.bounded ? py::object(py::float_(k.minimum)) : py::object(py::none());
        d["maximum"] = k.bounded ? py::object(py::float_(k.maximum)) : py::object(py::none());
        d["only_for"] = k.only_for;
        d["register_link"] = k.register_link;
        d["closed"] = k.closed;
        d["socket"] = k.socket;
        d["socket_kind"] = k.socket_kind;
        d["hair_models"] = k.hair_models;
        d["meaning"] = k.meaning;
        out.append(d);
    }
    return out;
}

}  // namespace hairbsdf::bindings
