// The scene format's table and its walker (scene_schema.h). No TBB, no Embree: compiled
// into _core (validate_scene, scene_schema) and _render (checked before reading).
#include "scene_schema.h"

#include <pybind11/numpy.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>
#include <type_traits>

#include "hairbsdf/model_factory.h"
#include "hairbsdf/params/huang.h"
#include "hairbsdf/render/geometry.h"
#include "hairbsdf/render/scene.h"
#include "render_passes.h"

namespace py = pybind11;

namespace hairbsdf::bindings {

namespace {

using K = SceneKeyKind;
namespace R = hairbsdf::render;
using In = R::ClosureDesc::Input;

std::string format_number(double x) {
    if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
    if (x == std::floor(x) && std::fabs(x) < 1e15) return std::to_string(static_cast<long long>(x));  // no 1e+06
    std::ostringstream s;
    s << x;
    return s.str();
}

// ----- a bound field: its value from a checked Python value, its initial value as text -----

// The index of `name` in a bound Enum's allowed names -> its C++ value (its index where the
// row lists no values).
long enum_value(const SceneKey& k, const std::string& name) {
    for (size_t i = 0; i < k.allowed.size(); ++i)
        if (name == k.allowed[i]) return k.allowed_values.empty() ? long(i) : k.allowed_values[i];
    throw std::logic_error("scene schema: " + std::string(k.path) + " has no value " + name);
}

std::string enum_name(const SceneKey& k, long value) {
    for (size_t i = 0; i < k.allowed.size(); ++i)
        if ((k.allowed_values.empty() ? long(i) : k.allowed_values[i]) == value) return k.allowed[i];
    throw std::logic_error("scene schema: " + std::string(k.path) + " names no value " + std::to_string(value));
}

void assign(const SceneKey&, double& dst, py::handle v) { dst = v.cast<double>(); }
void assign(const SceneKey&, int& dst, py::handle v) {
    const long long x = v.cast<long long>();
    dst = int(std::clamp<long long>(x, std::numeric_limits<int>::min(), std::numeric_limits<int>::max()));
}
void assign(const SceneKey&, uint32_t& dst, py::handle v) { dst = v.cast<uint32_t>(); }  // the walker took it mod 2^32
void assign(const SceneKey& k, bool& dst, py::handle v) {
    dst = k.kind == K::Enum ? enum_value(k, py::str(v)) != 0 : v.cast<bool>();
}
void assign(const SceneKey&, std::string& dst, py::handle v) { dst = v.cast<std::string>(); }
void assign(const SceneKey&, RGB& dst, py::handle v) {
    const py::tuple t = py::reinterpret_borrow<py::tuple>(v);  // Vector: the walker's tuple of 3 floats
    dst = RGB{t[0].cast<double>(), t[1].cast<double>(), t[2].cast<double>()};
}
template <size_t N>
void assign(const SceneKey& k, std::array<double, N>& dst, py::handle v) {
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(v);
    if (!a || size_t(a.size()) != N)
        throw std::logic_error("scene schema: " + std::string(k.path) + " does not hold " + std::to_string(N) + " numbers");
    std::copy(a.data(), a.data() + N, dst.begin());
}
template <class E, std::enable_if_t<std::is_enum_v<E>, int> = 0>
void assign(const SceneKey& k, E& dst, py::handle v) {
    dst = E(enum_value(k, py::str(v)));
}

// An Array row's value: a vector of numbers (columns 0) or of rows of `columns` numbers, copied
// from the walker's contiguous array of the row's dtype, each number converted to the field's.
template <class E>
struct ArrayElement {
    using type = E;
    static constexpr int width = 1;
    static E& at(E& e, int) { return e; }
};
template <class T, size_t N>
struct ArrayElement<std::array<T, N>> {
    using type = T;
    static constexpr int width = int(N);
    static T& at(std::array<T, N>& e, int i) { return e[size_t(i)]; }
};

template <class Src, class E>
void copy_array(py::handle v, std::vector<E>& dst) {
    using A = ArrayElement<E>;
    const auto a = py::array_t<Src, py::array::c_style | py::array::forcecast>::ensure(v);
    const Src* src = a.data();
    dst.resize(size_t(a.size()) / A::width);
    for (E& e : dst)
        for (int i = 0; i < A::width; ++i) A::at(e, i) = typename A::type(*src++);
}

template <class E>
void assign(const SceneKey& k, std::vector<E>& dst, py::handle v) {
    if (k.kind != K::Array || std::max(k.columns, 1) != ArrayElement<E>::width)
        throw std::logic_error("scene schema: " + k.path + " is not an array of rows of " +
                               std::to_string(ArrayElement<E>::width));
    const std::string dtype = k.dtype;
    if (dtype == "float32") copy_array<float>(v, dst);
    else if (dtype == "int32") copy_array<int32_t>(v, dst);
    else if (dtype == "float64") copy_array<double>(v, dst);
    else throw std::logic_error("scene schema: " + k.path + " has no dtype");
}

std::string text_of(const SceneKey&, double x) { return std::fabs(x - kPi) < 1e-12 ? "pi" : format_number(x); }
std::string text_of(const SceneKey&, int x) { return std::to_string(x); }
std::string text_of(const SceneKey&, uint32_t x) { return std::to_string(x); }
std::string text_of(const SceneKey& k, bool b) {
    return k.kind == K::Enum ? enum_name(k, long(b)) : (b ? "True" : "False");
}
std::string text_of(const SceneKey&, const std::string& s) { return "'" + s + "'"; }
std::string text_of(const SceneKey&, const RGB& c) {
    return "(" + format_number(c.r) + ", " + format_number(c.g) + ", " + format_number(c.b) + ")";
}
template <size_t N>
std::string text_of(const SceneKey&, const std::array<double, N>& m) {
    bool identity = N % 4 == 0;
    for (size_t i = 0; i < N; ++i) identity = identity && m[i] == (i % 4 == i / 4 ? 1.0 : 0.0);
    if (identity) return "identity";
    std::string s = "(";
    for (size_t i = 0; i < N; ++i) s += (i ? ", " : "") + format_number(m[i]);
    return s + ")";
}
template <class E, std::enable_if_t<std::is_enum_v<E>, int> = 0>
std::string text_of(const SceneKey& k, E value) {
    return enum_name(k, long(value));
}

template <class E>
std::string text_of(const SceneKey&, const std::vector<E>&) {
    return "";  // an absent array is empty: no default to write
}

py::object value_of(const SceneKey&, double x) { return py::float_(x); }
py::object value_of(const SceneKey&, int x) { return py::int_(x); }
py::object value_of(const SceneKey&, uint32_t x) { return py::int_(x); }
py::object value_of(const SceneKey& k, bool b) {
    return k.kind == K::Enum ? py::object(py::str(enum_name(k, long(b)))) : py::object(py::bool_(b));
}
py::object value_of(const SceneKey&, const std::string& s) { return py::str(s); }
py::object value_of(const SceneKey&, const RGB& c) { return py::make_tuple(c.r, c.g, c.b); }
template <size_t N>
py::object value_of(const SceneKey&, const std::array<double, N>& m) {
    py::tuple t(N);
    for (size_t i = 0; i < N; ++i) t[i] = py::float_(m[i]);
    return std::move(t);
}
template <class E, std::enable_if_t<std::is_enum_v<E>, int> = 0>
py::object value_of(const SceneKey& k, E value) {
    return py::str(enum_name(k, long(value)));
}

template <class E>
py::object value_of(const SceneKey& k, const std::vector<E>& values) {
    using A = ArrayElement<E>;
    std::vector<py::ssize_t> shape{py::ssize_t(values.size())};
    if (k.columns != 0) shape.push_back(A::width);
    py::array_t<typename A::type> out(shape);
    auto* dst = out.mutable_data();
    for (E e : values)
        for (int i = 0; i < A::width; ++i) *dst++ = A::at(e, i);
    return std::move(out);
}

// AUTO's bound comes from the renderer (geometry.h), so the text is built once.
const char* curve_intersector_meaning() {
    static const std::string text =
        "THICK curves: EMBREE, Embree 3's round Catmull-Rom curves; SWEEP, hairbsdf's exact test of the same "
        "surface over Embree's capped-cone proxies (faster, about 4x the memory); AUTO, SWEEP up to " +
        std::to_string(R::sweep_auto_max_segments) + " segments all in world space, else EMBREE";
    return text.c_str();
}

// Fluent rows for the table below.
struct Row {
    SceneKey k;
    Row(std::string path, K kind, const char* meaning) {
        k.path = std::move(path);
        k.kind = kind;
        k.meaning = meaning;
    }
    Row& required() { return k.required = true, *this; }
    // A default that is not a bound field's value: a rule ("size_x") or a key read by hand.
    Row& fallback(const char* value) { return k.default_value = value, *this; }
    Row& values(std::vector<std::string> v) { return k.allowed = std::move(v), *this; }
    // A bound Enum's names with the C++ value each one reads as.
    template <class E>
    Row& choices(std::initializer_list<std::pair<const char*, E>> named) {
        for (const auto& [name, value] : named) {
            k.allowed.push_back(name);
            k.allowed_values.push_back(long(value));
        }
        return *this;
    }
    // A bound Enum named as the choice row `param` of P's parameter table (params/<model>.h):
    // its names, in the table's order, each reading as the value that row sets `field` to.
    template <class P, class E>
    Row& choices_of(const char* param, E P::*field) {
        for (const ParamRow<P>& row : ParamTable<P>::rows()) {
            if (row.spec.name != param) continue;
            for (size_t i = 0; i < row.spec.choices.size(); ++i) {
                P named{};
                row.set(named, ParamValue{double(i), double(i), double(i)});
                k.allowed.push_back(row.spec.choices[i]);
                k.allowed_values.push_back(long(named.*field));
            }
            return *this;
        }
        throw std::logic_error("scene schema: " + k.path + ": " + ParamTable<P>::model + "'s table has no row " +
                               param);
    }
    Row& range(double lo, double hi) { return k.minimum = lo, k.maximum = hi, k.bounded = true, *this; }
    Row& array(const char* dtype, int columns) { return k.dtype = dtype, k.columns = columns, *this; }
    Row& columns(int n) { return k.columns = n, *this; }
    Row& only(const char* types) { return k.only_for = types, *this; }
    Row& linkable(In input) { return k.register_link = true, k.link_input = int(input), *this; }
    Row& closed() { return k.closed = true, *this; }
    Row& socket(const char* name, const char* kind, const char* models) {
        return k.socket = name, k.socket_kind = kind, k.hair_models = models, *this;
    }
    // Binds the row to S's field that get(S&) returns: read_fields copies the key into it, and
    // the key's default is the field's initial value in S{}.
    template <class S, class Get>
    Row& bind(Get get) {
        k.field.owner = typeid(S);
        k.field.assign = [get](const SceneKey& row, void* owner, py::handle v) {
            assign(row, get(*static_cast<S*>(owner)), v);
        };
        k.field.value = [get](const SceneKey& row, const void* owner) {
            return value_of(row, get(*static_cast<S*>(const_cast<void*>(owner))));
        };
        k.field.default_text = [get](const SceneKey& row) {
            S initial{};
            return text_of(row, get(initial));
        };
        return *this;
    }
    template <class S, class T>
    Row& field(T S::*member) {
        return bind<S>([member](S& s) -> T& { return s.*member; });
    }
    // An Image row bound to S's pixels and their size: read_fields copies the (H, W, columns) array.
    template <class S>
    Row& image_field(std::vector<float> S::*pixels, int S::*width, int S::*height) {
        k.field.owner = typeid(S);
        k.field.assign = [=](const SceneKey&, void* owner, py::handle v) {
            S& s = *static_cast<S*>(owner);
            const auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(v);
            s.*height = int(a.shape(0));
            s.*width = int(a.shape(1));
            (s.*pixels).assign(a.data(), a.data() + a.size());
        };
        k.field.value = [=](const SceneKey& row, const void* owner) -> py::object {
            const S& s = *static_cast<const S*>(owner);
            py::array_t<float> out({py::ssize_t(s.*height), py::ssize_t(s.*width), py::ssize_t(row.columns)});
            std::copy((s.*pixels).begin(), (s.*pixels).end(), out.mutable_data());
            return std::move(out);
        };
        k.field.default_text = [](const SceneKey&) { return std::string(); };
        return *this;
    }
    // Array lengths (SceneKey::defines ...): the count this row's length is, or is the CSR
    // offsets into (and then it is the number of curves + 1); the count it has one `item` per;
    // the count whose rows its values index (`none`, meaning `none_text`, allowed too).
    Row& defines(SceneCount c) { return k.defines = c, *this; }
    Row& offsets_into(SceneCount c) { return k.defines = SceneCount::Curve, k.offsets_into = c, *this; }
    Row& per(SceneCount c, const char* item) { return k.per = c, k.per_item = item, *this; }
    Row& index_into(SceneCount c, int none, const char* none_text) {
        return k.index_into = c, k.index_none = none, k.index_none_text = none_text, *this;
    }
    Row& affine() { return k.affine = true, *this; }
    Row& at_least(SceneCount c) { return k.at_least = c, *this; }
    Row& domains(std::vector<SceneCount> counts) { return k.domains = std::move(counts), *this; }
    operator SceneKey() const { return k; }  // NOLINT(google-explicit-constructor)
};

constexpr double kUnbounded = std::numeric_limits<double>::infinity();
// The engine's limits on the integrator's counts (Cycles' own sample limit is 2^24).
constexpr double kMaxSamples = 1 << 24;
constexpr double kMaxBounces = 1 << 20;
constexpr const char* kHairTypes = "principled_hair";
using Closure = R::ClosureDesc;
using Camera = R::CameraDesc;
using Light = R::LightDesc;
using Settings = R::IntegratorSettings;

// A shading program's rows under `prefix`: one layout for a material's and the world's.
std::vector<SceneKey> program_rows(const std::string& prefix, const char* meaning) {
    return {
        Row(prefix, K::Dict, meaning),
        Row(prefix + ".code", K::Array, "instructions: opcode, then its arguments").array("int32", 0).required()
            .field(&R::ShadingProgram::code),
        Row(prefix + ".constants", K::Array, "registers 0..K-1 (read-only)").array("float32", 0).required()
            .defines(SceneCount::Constant).field(&R::ShadingProgram::constants),
        Row(prefix + ".registers", K::Int, "R >= K float slots").range(0, 1 << 20).required()
            .at_least(SceneCount::Constant).field(&R::ShadingProgram::register_count),
    };
}

std::vector<SceneKey> joined(std::initializer_list<std::vector<SceneKey>> parts) {
    std::vector<SceneKey> out;
    for (const std::vector<SceneKey>& part : parts) out.insert(out.end(), part.begin(), part.end());
    return out;
}

constexpr int kSceneFormatVersion = 1;  // the format's version; the exporter reads it from this row (maximum)

std::vector<SceneKey> make_schema() {
    return joined({{
        Row("version", K::Int, "the format's version")
            .range(kSceneFormatVersion, kSceneFormatVersion)
            .fallback(std::to_string(kSceneFormatVersion).c_str()),

        Row("curves", K::Dict, "all hair of all objects, concatenated"),
        Row("curves.points", K::Array, "x, y, z, radius (object space for curves with a curve_object >= 0)")
            .array("float32", 4).required().defines(SceneCount::Point).field(&R::CurveData::points),
        Row("curves.curve_offsets", K::Array, "CSR: curve c owns points[curve_offsets[c]:curve_offsets[c+1]]")
            .array("int32", 0).required().offsets_into(SceneCount::Point).field(&R::CurveData::offsets),
        Row("curves.curve_random", K::Array, "Hair Info > Random").array("float32", 0).required()
            .per(SceneCount::Curve, "one value").field(&R::CurveData::random),
        Row("curves.curve_material", K::Array, "index into materials").array("int32", 0).required()
            .per(SceneCount::Curve, "one value").field(&R::CurveData::material),
        Row("curves.curve_intercept_total", K::Array, "curve length, for Hair Info > Length").array("float32", 0)
            .per(SceneCount::Curve, "one value").field(&R::CurveData::length),
        Row("curves.point_intercept", K::Array, "Hair Info > Intercept").array("float32", 0)
            .per(SceneCount::Point, "one value").field(&R::CurveData::intercept),
        Row("curves.attributes", K::List, "the named curve attributes programs read"),
        Row("curves.attributes[]", K::Dict, "one attribute"),
        Row("curves.attributes[].name", K::String, "the attribute's name").required()
            .field(&R::CurveData::Attribute::name),
        Row("curves.attributes[].domain", K::Enum, "one row per point or per curve")
            .choices<bool>({{"POINT", true}, {"CURVE", false}}).domains({SceneCount::Point, SceneCount::Curve})
            .required().field(&R::CurveData::Attribute::point_domain),
        Row("curves.attributes[].data", K::Array, "RGBA rows").array("float32", 4).required()
            .per(SceneCount::ByDomain, "one RGBA row").field(&R::CurveData::Attribute::rgba),
        Row("curves.curve_object", K::Array, "-1: world space; k: the points are in object k's space")
            .array("int32", 0).per(SceneCount::Curve, "one value").index_into(SceneCount::Object, -1, "world space")
            .field(&R::CurveData::object),
        Row("curves.object_transforms", K::Array, "world from object k, row-major 3 x 4")
            .array("float64", 12).defines(SceneCount::Object).affine().field(&R::CurveData::object_transforms),
        Row("curves.normals", K::Array, "curve normals: Huang's major axis").array("float32", 3)
            .per(SceneCount::Point, "one normal").field(&R::CurveData::normals),
        Row("curve_shape", K::Enum, "scene.cycles_curves.shape")
            .choices<R::CurveShape>({{"RIBBONS", R::CurveShape::Ribbons}, {"THICK", R::CurveShape::Thick},
                                     {"THICK_LINEAR", R::CurveShape::ThickLinear}})
            .field(&R::SceneDesc::curve_shape),
        Row("curve_subdivisions", K::Int, "scene.cycles_curves.subdivisions").range(0, kUnbounded)
            .field(&R::SceneDesc::curve_subdivisions),
        Row("curve_backface_culling", K::Bool, "cull back faces of THICK curves (Cycles 3.x)")
            .field(&R::SceneDesc::cull_curve_back_faces),
        Row("curve_intersector", K::Enum, curve_intersector_meaning())
            .choices<R::CurveIntersector>({{"EMBREE", R::CurveIntersector::Embree}, {"SWEEP", R::CurveIntersector::Sweep},
                                           {"AUTO", R::CurveIntersector::Auto}})  // appended: a .blend saves positions
            .field(&R::SceneDesc::curve_intersector),

        Row("meshes", K::Dict, "all triangle meshes, concatenated"),
        Row("meshes.vertices", K::Array, "vertex positions").array("float32", 3).required()
            .defines(SceneCount::Vertex).field(&R::MeshData::vertices),
        Row("meshes.triangles", K::Array, "vertex indices").array("int32", 3).required()
            .defines(SceneCount::Triangle).field(&R::MeshData::triangles),
        Row("meshes.triangle_material", K::Array, "index into materials").array("int32", 0).required()
            .per(SceneCount::Triangle, "one value").field(&R::MeshData::material),
        Row("meshes.triangle_normals", K::Array, "corner normals for smooth shading; absent: flat")
            .array("float32", 9).per(SceneCount::Triangle, "one row of 3 corner normals").field(&R::MeshData::normals),
        Row("meshes.triangle_object", K::Array, "the object, for the light tree").array("int32", 0)
            .per(SceneCount::Triangle, "one object id").field(&R::MeshData::object),
        Row("meshes.triangle_reversed", K::Array, "1 where the corners were reversed (a mirrored object), 0 elsewhere")
            .array("int32", 0).per(SceneCount::Triangle, "one flag").field(&R::MeshData::reversed),
        Row("meshes.attributes", K::List, "the attributes programs read, at the corners; curves' names and order"),
        Row("meshes.attributes[]", K::Dict, "one attribute"),
        Row("meshes.attributes[].name", K::String, "the attribute's name (the curves' attribute at the same index)")
            .required().field(&R::MeshData::CornerAttribute::name),
        Row("meshes.attributes[].data", K::Array, "RGBA of corners 0, 1, 2").array("float32", 12).required()
            .per(SceneCount::Triangle, "one row of 3 RGBA corners").field(&R::MeshData::CornerAttribute::corners),

        Row("materials", K::List, "one per Blender material slot used"),
        Row("materials[]", K::Dict, "one material"),
        Row("materials[].name", K::String, "the material's name (\"__default__\": no material)")
            .field(&R::MaterialDesc::name),
    }, program_rows("materials[].program", "the node networks on closure inputs (docs/shading_vm.md)"), {
        Row("materials[].emission_sampling", K::Enum, "which sides of its emissive triangles NEE samples")
            .choices<R::EmissionSampling>({{"AUTO", R::EmissionSampling::Auto}, {"NONE", R::EmissionSampling::None},
                                           {"FRONT", R::EmissionSampling::Front}, {"BACK", R::EmissionSampling::Back},
                                           {"FRONT_BACK", R::EmissionSampling::FrontBack}})
            .field(&R::MaterialDesc::emission_sampling),
        Row("materials[].closures", K::List, "a flat weighted sum of closures").required(),
        Row("materials[].closures[]", K::Dict, "one closure; its keys depend on its type"),
        Row("materials[].closures[].type", K::Enum, "the closure")
            .choices<Closure::Type>({{"principled_hair", Closure::Type::PrincipledHair},
                                     {"diffuse", Closure::Type::Diffuse},
                                     {"emission", Closure::Type::Emission},
                                     {"cycles_hair", Closure::Type::CyclesHair},
                                     {"hair_model", Closure::Type::Model}})
            .required().field(&Closure::type),
        Row("materials[].closures[].weight", K::Vector, "RGB weight (Mix Shader factors)").columns(3)
            .linkable(In::Weight).field(&Closure::weight),
        Row("materials[].closures[].model", K::Enum, "Principled Hair's model")
            .choices<Closure::HairModel>({{"CHIANG", Closure::HairModel::Chiang}, {"HUANG", Closure::HairModel::Huang}})
            .only(kHairTypes).field(&Closure::hair_model),
        Row("materials[].closures[].parametrization", K::Enum, "Principled Hair's parametrization")
            .choices<Parametrization>({{"COLOR", Parametrization::Color}, {"MELANIN", Parametrization::Melanin},
                                       {"ABSORPTION", Parametrization::Absorption}})
            .only(kHairTypes)
            .bind<Closure>([](Closure& c) -> Parametrization& { return c.hair.parametrization; }),
        Row("materials[].closures[].inputs", K::Dict, "Principled Hair's socket values; missing: Blender 4.5's defaults")
            .fallback("{}").only(kHairTypes).closed(),
        Row("materials[].closures[].inputs.color", K::Vector, "Color").columns(3).linkable(In::Color)
            .socket("Color", "color", "CHIANG HUANG")
            .field(&PrincipledHairInputs::color),
        Row("materials[].closures[].inputs.melanin", K::Real, "Melanin")
            .linkable(In::Melanin).socket("Melanin", "float", "CHIANG HUANG")
            .field(&PrincipledHairInputs::melanin),
        Row("materials[].closures[].inputs.melanin_redness", K::Real, "Melanin Redness")
            .linkable(In::MelaninRedness).socket("Melanin Redness", "float", "CHIANG HUANG")
            .field(&PrincipledHairInputs::melanin_redness),
        Row("materials[].closures[].inputs.tint", K::Vector, "Tint").columns(3).linkable(In::Tint)
            .socket("Tint", "color", "CHIANG HUANG")
            .field(&PrincipledHairInputs::tint),
        Row("materials[].closures[].inputs.absorption_coefficient", K::Vector, "Absorption Coefficient").columns(3)
            .linkable(In::AbsorptionCoefficient)
            .socket("Absorption Coefficient", "vector", "CHIANG HUANG")
            .field(&PrincipledHairInputs::absorption_coefficient),
        Row("materials[].closures[].inputs.roughness", K::Real, "Roughness")
            .linkable(In::Roughness).socket("Roughness", "float", "CHIANG HUANG")
            .field(&PrincipledHairInputs::roughness),
        Row("materials[].closures[].inputs.radial_roughness", K::Real, "Radial Roughness (Chiang)")
            .linkable(In::RadialRoughness).socket("Radial Roughness", "float", "CHIANG")
            .field(&PrincipledHairInputs::radial_roughness),
        Row("materials[].closures[].inputs.coat", K::Real, "Coat (Chiang)")
            .linkable(In::Coat).socket("Coat", "float", "CHIANG")
            .field(&PrincipledHairInputs::coat),
        Row("materials[].closures[].inputs.ior", K::Real, "IOR")
            .linkable(In::Ior).socket("IOR", "float", "CHIANG HUANG")
            .field(&PrincipledHairInputs::ior),
        Row("materials[].closures[].inputs.offset", K::Real, "Offset, radians")
            .linkable(In::Offset).socket("Offset", "float", "CHIANG HUANG")
            .field(&PrincipledHairInputs::offset),
        Row("materials[].closures[].inputs.random_color", K::Real, "Random Color")
            .linkable(In::RandomColor).socket("Random Color", "float", "CHIANG HUANG")
            .field(&PrincipledHairInputs::random_color),
        Row("materials[].closures[].inputs.random_roughness", K::Real, "Random Roughness")
            .linkable(In::RandomRoughness).socket("Random Roughness", "float", "CHIANG HUANG")
            .field(&PrincipledHairInputs::random_roughness),
        Row("materials[].closures[].inputs.random", K::Real, "Random; None: the curve's curve_random")
            .fallback("curve_random")
            .linkable(In::Random).socket("Random", "float", "")
            .field(&PrincipledHairInputs::random),
        Row("materials[].closures[].inputs.aspect_ratio", K::Real, "Aspect Ratio (Huang)")
            .linkable(In::AspectRatio).socket("Aspect Ratio", "float", "HUANG")
            .field(&PrincipledHairInputs::aspect_ratio),
        Row("materials[].closures[].inputs.reflection", K::Real, "Reflection (Huang)")
            .linkable(In::Reflection).socket("Reflection", "float", "HUANG")
            .field(&PrincipledHairInputs::reflection),
        Row("materials[].closures[].inputs.transmission", K::Real, "Transmission (Huang)")
            .linkable(In::Transmission).socket("Transmission", "float", "HUANG")
            .field(&PrincipledHairInputs::transmission),
        Row("materials[].closures[].inputs.secondary_reflection", K::Real, "Secondary Reflection (Huang)")
            .linkable(In::SecondaryReflection).socket("Secondary Reflection", "float", "HUANG")
            .field(&PrincipledHairInputs::secondary_reflection),
        Row("materials[].closures[].component", K::Enum, "the legacy Hair BSDF's component")
            .choices<bool>({{"REFLECTION", false}, {"TRANSMISSION", true}})
            .only("cycles_hair").field(&Closure::transmission),
        Row("materials[].closures[].color", K::Vector, "the legacy Hair BSDF's colour").columns(3)
            .only("cycles_hair").linkable(In::Color).socket("Color", "color", "").field(&Closure::color),
        Row("materials[].closures[].offset", K::Real, "the legacy Hair BSDF's offset, radians")
            .only("cycles_hair").linkable(In::Offset).socket("Offset", "float", "").field(&Closure::offset),
        Row("materials[].closures[].roughness_u", K::Real, "clamped to [0.001, 1]").only("cycles_hair")
            .linkable(In::RoughnessU).socket("RoughnessU", "float", "").field(&Closure::roughness_u),
        Row("materials[].closures[].roughness_v", K::Real, "clamped to [0.001, 1]").only("cycles_hair")
            .linkable(In::RoughnessV).socket("RoughnessV", "float", "").field(&Closure::roughness_v),
        Row("materials[].closures[].color", K::Vector, "the diffuse / emission colour").columns(3)
            .only("diffuse emission").linkable(In::Color).field(&Closure::color),
        Row("materials[].closures[].strength", K::Real, "the emission strength").only("emission")
            .linkable(In::Strength).field(&Closure::strength),
        Row("materials[].closures[].model", K::ModelName, "a name the model factory builds (_core.model_names())")
            .required().only("hair_model").field(&Closure::model_name),
        Row("materials[].closures[].path", K::String, "the plugin library (docs/plugins.md); required for plugin")
            .only("hair_model").field(&Closure::model_path),
        Row("materials[].closures[].params", K::ModelParams, "the model's parameters (hairbsdf.model_schema)")
            .fallback("{}").only("hair_model"),

        Row("camera", K::Dict, "the render camera").required(),
        Row("camera.type", K::Enum, "perspective or orthographic")
            .choices<R::CameraType>({{"PERSP", R::CameraType::Perspective}, {"ORTHO", R::CameraType::Orthographic}})
            .required().field(&Camera::type),
        Row("camera.matrix_world", K::Matrix, "world from camera (looks down -Z, +Y up), scale removed").columns(4)
            .required().field(&Camera::matrix_world),
        Row("camera.resolution", K::IntPair, "(width, height) in pixels").range(1, 65536).required(),
        Row("camera.pixel_aspect", K::Real, "pixel_aspect_y / pixel_aspect_x").field(&Camera::pixel_aspect),
        Row("camera.sensor_fit", K::Enum, "the sensor fit")
            .choices<R::SensorFit>({{"AUTO", R::SensorFit::Auto}, {"HORIZONTAL", R::SensorFit::Horizontal},
                                    {"VERTICAL", R::SensorFit::Vertical}})
            .field(&Camera::sensor_fit),
        Row("camera.sensor_width", K::Real, "mm").field(&Camera::sensor_width),
        Row("camera.sensor_height", K::Real, "mm").field(&Camera::sensor_height),
        Row("camera.lens", K::Real, "focal length, mm (PERSP)").field(&Camera::lens),
        Row("camera.ortho_scale", K::Real, "ORTHO").field(&Camera::ortho_scale),
        Row("camera.shift_x", K::Real, "fractions of the larger image side").field(&Camera::shift_x),
        Row("camera.shift_y", K::Real, "fractions of the larger image side").field(&Camera::shift_y),
        Row("camera.clip_start", K::Real, "near clip").field(&Camera::clip_start),
        Row("camera.clip_end", K::Real, "far clip").field(&Camera::clip_end),

        Row("lights", K::List, "Blender's raw light values"),
        Row("lights[]", K::Dict, "one light; its keys depend on its type"),
        Row("lights[].type", K::Enum, "the light")
            .choices<R::LightType>({{"SUN", R::LightType::Sun}, {"POINT", R::LightType::Point},
                                    {"SPOT", R::LightType::Spot}, {"AREA", R::LightType::Area}})
            .required().field(&Light::type),
        Row("lights[].strength", K::Vector, "colour x energy (W; SUN: irradiance)").columns(3).required()
            .field(&Light::strength),
        Row("lights[].normalize", K::Bool, "Light.normalize (4.x)").field(&Light::normalize),
        Row("lights[].use_mis", K::Bool, "multiple importance sampling").field(&Light::use_mis),
        Row("lights[].visible_camera", K::Bool, "Object > Visibility > Camera").field(&Light::visible_camera),
        Row("lights[].direction", K::Vector, "SUN: towards the light; SPOT: the spot axis").columns(3).required()
            .only("SUN SPOT").field(&Light::direction),
        Row("lights[].angle", K::Real, "the sun's angular diameter, radians").only("SUN").field(&Light::angle),
        Row("lights[].position", K::Vector, "the light's position").columns(3).required().only("POINT SPOT")
            .field(&Light::position),
        Row("lights[].radius", K::Real, "the light's radius").only("POINT SPOT").field(&Light::radius),
        Row("lights[].soft_falloff", K::Bool, "Light.use_soft_falloff (4.x)").only("POINT SPOT")
            .field(&Light::soft_falloff),
        Row("lights[].spot_size", K::Real, "the cone's angle, radians").required().only("SPOT")
            .field(&Light::spot_size),
        Row("lights[].spot_blend", K::Real, "the cone's smoothstep blend").required().only("SPOT")
            .field(&Light::spot_blend),
        Row("lights[].matrix_world", K::Matrix, "the spot's matrix (scale shapes the cone)").columns(4).only("SPOT"),
        Row("lights[].spot_cosine", K::Bool, "Cycles 3.x cone attenuation").only("SPOT").field(&Light::spot_cosine),
        Row("lights[].matrix_world", K::Matrix, "world from light (emits along local -Z)").columns(4).required()
            .only("AREA"),
        Row("lights[].shape", K::Enum, "the area's shape")
            .choices<R::AreaShape>({{"SQUARE", R::AreaShape::Square}, {"RECTANGLE", R::AreaShape::Rectangle},
                                    {"DISK", R::AreaShape::Disk}, {"ELLIPSE", R::AreaShape::Ellipse}})
            .required().only("AREA").field(&Light::shape),
        Row("lights[].size_x", K::Real, "the area's size along local x").required().only("AREA").field(&Light::size_x),
        Row("lights[].size_y", K::Real, "the area's size along local y").fallback("size_x").only("AREA"),
        Row("lights[].spread", K::Real, "the area's spread, radians").only("AREA").field(&Light::spread),

        Row("world", K::Dict, "the background; absent: black"),
        Row("world.color", K::Vector, "uniform background radiance (colour x strength)").columns(3)
            .linkable(In::Color).field(&R::SceneDesc::world),
    }, program_rows("world.program", "nodes computing the world's inputs, run once (docs/shading_vm.md)"), {
        Row("world.mis", K::Bool, "World > Settings > Sampling").field(&R::SceneDesc::world_mis),
        Row("world.map_resolution", K::Int, "the light tree's importance map, res x res/2; 0: automatic")
            .range(0, 65536).field(&R::SceneDesc::world_map_resolution),
        Row("world.texture", K::Dict, "one equirectangular Environment Texture, added to the colour"),
        Row("world.texture.pixels", K::Image, "scene-linear RGB, row 0 the zenith").array("float32", 3).required()
            .image_field(&R::EnvironmentDesc::pixels, &R::EnvironmentDesc::width, &R::EnvironmentDesc::height),
        Row("world.texture.weight", K::Vector, "Background strength x Mix / Add weights").columns(3).required()
            .linkable(In::Weight).field(&R::EnvironmentDesc::weight),
        Row("world.texture.interpolation", K::Enum, "the lookup").choices<bool>({{"LINEAR", false}, {"CLOSEST", true}})
            .field(&R::EnvironmentDesc::closest),
        Row("world.texture.srgb_encoded", K::Bool, "pixels are sRGB-encoded, decoded after the lookup")
            .field(&R::EnvironmentDesc::srgb_encoded),
        Row("world.texture.matrix", K::Matrix, "lookup vector = M (direction, 1): a Mapping node").columns(3)
            .field(&R::EnvironmentDesc::matrix),

        Row("images", K::List, "the images the programs' Image Texture nodes sample"),
        Row("images[]", K::Dict, "one image; index = the ImageTexture op's image index"),
        Row("images[].name", K::String, "the image's name").field(&R::ImageDesc::name),
        Row("images[].pixels", K::Image, "RGBA, row 0 the image's top row").array("float32", 4).required()
            .image_field(&R::ImageDesc::pixels, &R::ImageDesc::width, &R::ImageDesc::height),

        Row("integrator", K::Dict, "the render settings").required(),
        Row("integrator.samples", K::Int, "samples per pixel").range(0, kMaxSamples).required()
            .field(&Settings::samples),
        Row("integrator.seed", K::Int, "the seed (taken modulo 2^32)").field(&Settings::seed),
        Row("integrator.max_bounces", K::Int, "bounce budget").range(0, kMaxBounces).field(&Settings::max_bounces),
        Row("integrator.diffuse_bounces", K::Int, "bounce budget").range(0, kMaxBounces)
            .field(&Settings::diffuse_bounces),
        Row("integrator.glossy_bounces", K::Int, "bounce budget").range(0, kMaxBounces)
            .field(&Settings::glossy_bounces),
        Row("integrator.transmission_bounces", K::Int, "bounce budget").range(0, kMaxBounces)
            .field(&Settings::transmission_bounces),
        Row("integrator.transparent_bounces", K::Int, "bounce budget").range(0, kMaxBounces)
            .field(&Settings::transparent_bounces),
        Row("integrator.min_light_bounces", K::Int, "bounces before Russian roulette").range(0, kMaxBounces)
            .field(&Settings::min_light_bounces),
        Row("integrator.filter_type", K::Enum, "the pixel filter")
            .choices<Settings::Filter>({{"BLACKMAN_HARRIS", Settings::Filter::BlackmanHarris},
                                        {"GAUSSIAN", Settings::Filter::Gaussian}, {"BOX", Settings::Filter::Box}})
            .field(&Settings::filter),
        Row("integrator.filter_width", K::Real, "pixels").field(&Settings::filter_width),
        Row("integrator.exposure", K::Real, "film exposure multiplier").field(&Settings::exposure),
        Row("integrator.film_transparent", K::Bool, "transparent film").field(&Settings::film_transparent),
        Row("integrator.light_sampling_threshold", K::Real, "ignored (Cycles' roulette is unbiased)")
            .field(&Settings::light_sampling_threshold),
        Row("integrator.light_tree", K::Bool, "Cycles' light tree for NEE (4.x)").field(&Settings::light_tree),
        Row("integrator.chiang_lcg", K::Bool, "Cycles < 3.6: Chiang's per-hit LCG").field(&Settings::chiang_lcg),
        Row("integrator.camera_ray_stream", K::Bool, "camera rays as one coherent Embree stream per tile (same image at float rounding)")
            .field(&Settings::camera_ray_stream),
        Row("integrator.wavefront", K::Bool, "wavefront path tracer: a tile's rays as Embree streams, hits shaded by material (each path the per-pixel one to float precision)")
            .field(&Settings::wavefront),
        Row("integrator.wavefront_streams", K::Bool, "the wavefront's bounce and shadow rays as Embree streams; off: one by one (bit-identical image)")
            .field(&Settings::wavefront_streams),
        Row("integrator.wavefront_kernels", K::Bool, "the wavefront shades one-closure Chiang materials through the float32 batch kernels; off: the scalar double path (the per-pixel image)")
            .field(&Settings::wavefront_kernels),
        Row("integrator.tilt", K::Enum, "Principled Hair tilt convention")
            .choices<TiltConvention>({{"4.2", TiltConvention::Blender42}, {"3.4", TiltConvention::Blender34}})
            .field(&Settings::tilt),
        Row("integrator.filter_glossy", K::Real, "scene.cycles.blur_glossy").field(&Settings::filter_glossy),
        Row("integrator.clamp_direct", K::Real, "sample clamp, 0: off").field(&Settings::clamp_direct),
        Row("integrator.clamp_indirect", K::Real, "sample clamp, 0: off").field(&Settings::clamp_indirect),
        Row("integrator.accuracy", K::Enum, "Cycles' truncated Bessel series or exact functions")
            .choices<Accuracy>({{"cycles", Accuracy::Cycles}, {"exact", Accuracy::Exact}})
            .field(&Settings::accuracy),
        Row("integrator.huang_sampler", K::Enum, "Huang's BSDF sampler (docs/huang.md)")
            .choices_of("sampler", &HuangHairParams::sampler).field(&Settings::huang_sampler),
        Row("integrator.huang_glass_albedo_table", K::Enum, "Huang's energy-compensation tables")
            .choices_of("glass_albedo_table", &HuangHairParams::glass_albedo_table)
            .field(&Settings::huang_glass_albedo_table),
        Row("integrator.passes", K::EnumList, "extra images in the result (docs/engine.md)")
            .values(render_pass_names()).fallback("[]"),

        Row("source", K::Informational, "where the scene came from; not read"),
        Row("source.blender_version", K::Informational, "informational"),
        Row("source.scene", K::Informational, "informational"),
        Row("source.view_layer", K::Informational, "informational"),
        Row("source.frame", K::Informational, "informational"),
        Row("source.render", K::Informational, "informational (final-render export rules used)"),
    }});
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

// Row k is a key of the dict at `path` whose "type" is `type` ("" where it has none yet).
bool is_key_of(const SceneKey& k, const std::string& path, const std::string& type) {
    const std::string p = k.path;
    if (parent(p) != path || p.back() == ']') return false;
    if (path.empty() && p.find('[') != std::string::npos) return false;
    return !*k.only_for || contains(k.only_for, type);
}

class Walker {
public:
    Walker() : rows_(scene_schema()), np_(py::module_::import("numpy")), numbers_(py::module_::import("numbers")) {}

    py::dict scene(py::handle v) {
        root_ = py::dict();
        walk_dict("", v, "scene", root_);
        return root_;
    }

    py::object value(const std::string& path, py::handle v, const std::string& key) {
        root_ = py::dict();
        return convert(row(path), v, key);
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
            if (!is_key_of(k, path, type)) continue;
            const std::string name = leaf(k.path);
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
        if (k.kind == K::ModelName) out = model_names();  // those the factory builds
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

    static long rows_of(const py::dict& d, const std::string& name) {
        return d.contains(name.c_str()) ? long(py::len(d[name.c_str()])) : -1;
    }

    void check_rules(const std::string& path, py::dict& out, const std::string& key) {
        if (path == "meshes") check_attribute_names(out, key);
        check_counts(path, out, key);
        if (path == "materials[].closures[]") check_hair_model(out, key);
    }

    // The counts the rows under `path` define (SceneKey::defines: -1 where absent), and the rows
    // defining them.
    struct Counts {
        std::array<long, size_t(SceneCount::ByDomain)> n;
        std::array<const SceneKey*, size_t(SceneCount::ByDomain)> row{};
        Counts() { n.fill(-1); }
        long& of(SceneCount c) { return n[size_t(c)]; }
        const SceneKey* defining(SceneCount c) const {
            if (!row[size_t(c)])
                throw std::logic_error(std::string("scene schema: no sibling row defines the number of ") +
                                       count_name(c) + "s");
            return row[size_t(c)];
        }
    };

    // The length rules of the arrays of the dict at `path` and of its lists' items, from the rows:
    // offsets, one row per count item, indices into a count, counts an Int must reach.
    void check_counts(const std::string& path, const py::dict& d, const std::string& key) {
        static const std::set<std::string> counted = [] {  // the dicts whose rows define a count
            std::set<std::string> paths;
            for (const SceneKey& k : scene_schema())
                if (k.defines != SceneCount::None) paths.insert(parent(k.path));
            return paths;
        }();
        if (!counted.count(path)) return;
        const std::vector<const SceneKey*> rows = rows_under(path, "");
        Counts counts;
        for (const SceneKey* k : rows) {
            if (k->defines == SceneCount::None) continue;
            counts.row[size_t(k->defines)] = k;
            const long n = rows_of(d, leaf(k->path));
            counts.of(k->defines) = k->offsets_into == SceneCount::None || n < 0 ? n : std::max(n - 1, 0L);
        }
        for (const SceneKey* k : rows) {
            if (k->offsets_into != SceneCount::None) check_offsets(*k, d, key, counts);
            if (k->index_into != SceneCount::None && d.contains(leaf(k->path).c_str())) {
                const SceneKey& target = *counts.defining(k->index_into);
                if (!d.contains(leaf(target.path).c_str()))
                    value_error(key + "['" + leaf(target.path) + "']", "missing (required with " + leaf(k->path) + ")");
            }
        }
        for (const SceneKey* k : rows) {
            const std::string name = leaf(k->path);
            if (!d.contains(name.c_str())) continue;
            if (k->per != SceneCount::None) count(d, *k, k->per, counts, key);
            if (k->index_into != SceneCount::None) check_indices(*k, d, key, counts);
            if (k->at_least != SceneCount::None) {
                const long least = counts.of(k->at_least);
                if (d[name.c_str()].cast<long>() < least)
                    value_error(key + "['" + name + "']", "must be >= " + std::to_string(least) + " (the " +
                                                              leaf(counts.defining(k->at_least)->path) + "), got " +
                                                              std::string(py::str(d[name.c_str()])));
            }
            if (k->kind != K::List) continue;
            const std::vector<const SceneKey*> item_rows = rows_under(k->path + "[]", "");
            size_t i = 0;
            for (py::handle h : py::list(d[name.c_str()])) {
                const py::dict item = py::reinterpret_borrow<py::dict>(h);
                const std::string item_key = key + "['" + name + "'][" + std::to_string(i++) + "]";
                for (const SceneKey* r : item_rows)
                    if (r->per != SceneCount::None && item.contains(leaf(r->path).c_str()))
                        count(item, *r, domain_of(item_rows, item, r->per), counts, item_key);
            }
        }
    }

    // SceneCount::ByDomain: the count the item's Enum row with domains() names.
    static SceneCount domain_of(const std::vector<const SceneKey*>& rows, const py::dict& item, SceneCount per) {
        if (per != SceneCount::ByDomain) return per;
        for (const SceneKey* r : rows) {
            if (r->domains.empty()) continue;
            const std::string value = py::str(item[leaf(r->path).c_str()]);
            for (size_t i = 0; i < r->allowed.size(); ++i)
                if (r->allowed[i] == value) return r->domains[i];
        }
        throw std::logic_error("scene schema: no domain row beside a per-domain array");
    }

    static void count(const py::dict& d, const SceneKey& k, SceneCount per, Counts& counts, const std::string& key) {
        const std::string name = leaf(k.path);
        const long n = rows_of(d, name), want = counts.of(per);
        counts.defining(per);  // a table without the row defining it is a logic_error
        if (n >= 0 && n != want)
            value_error(key + "['" + name + "']", "expected " + std::string(k.per_item) + " per " + count_name(per) +
                                                      " (" + std::to_string(want) + "), got " + std::to_string(n));
    }

    // CSR offsets into a count: C + 1 non-decreasing entries from 0 to that count.
    static void check_offsets(const SceneKey& k, const py::dict& d, const std::string& key, Counts& counts) {
        const std::string name = leaf(k.path), rk = key + "['" + name + "']";
        const long n_into = counts.of(k.offsets_into);
        const auto offsets = py::array_t<int32_t>::ensure(d[name.c_str()]);
        const long n_offsets = long(offsets.size());
        if (n_offsets == 0 && n_into > 0)
            value_error(rk, "expected C + 1 entries for " + std::to_string(n_into) + " " + count_name(k.offsets_into) + "s");
        if (n_offsets == 0) return;
        const int32_t* o = offsets.data();
        if (o[0] != 0 || o[n_offsets - 1] != n_into)
            value_error(rk, "must start at 0 and end at len(" + leaf(counts.defining(k.offsets_into)->path) +
                                ") = " + std::to_string(n_into));
        for (long i = 0; i + 1 < n_offsets; ++i)
            if (o[i + 1] < o[i]) value_error(rk, "must be non-decreasing");
    }

    // Indices into a count's rows (index_none allowed); that count's rows checked first when affine.
    static void check_indices(const SceneKey& k, const py::dict& d, const std::string& key, Counts& counts) {
        const SceneKey& target = *counts.defining(k.index_into);
        const std::string target_name = leaf(target.path);
        const long n_target = counts.of(k.index_into);
        if (target.affine) {
            const auto m = py::array_t<double>::ensure(d[target_name.c_str()]);
            for (long j = 0; j < n_target; ++j) {
                std::array<double, 12> r;
                std::copy(m.data() + 12 * j, m.data() + 12 * (j + 1), r.begin());
                bool finite = true;
                for (double x : r) finite = finite && std::isfinite(x);
                if (!finite || R::linear_determinant(r) == 0.0)
                    value_error(key + "['" + target_name + "'][" + std::to_string(j) + "]",
                                std::string("expected a finite, invertible row-major 3x4 matrix (world from ") +
                                    count_name(k.index_into) + ")");
            }
        }
        const std::string name = leaf(k.path);
        const auto values = py::array_t<int32_t>::ensure(d[name.c_str()]);
        for (long i = 0; i < long(values.size()); ++i)
            if (values.data()[i] < k.index_none || values.data()[i] >= n_target)
                value_error(key + "['" + name + "']", "expected " + std::to_string(k.index_none) + " (" +
                                                          k.index_none_text + ") or an index into " + target_name +
                                                          " (0 to " + std::to_string(n_target - 1) + ")");
    }

    // Mesh attribute i is the curves' attribute i (one list of names for the programs).
    void check_attribute_names(py::dict& m, const std::string& key) {
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
            ++i;
        }
    }

    static void check_hair_model(py::dict& c, const std::string& key) {
        if (std::string(py::str(c["type"])) == "hair_model" && std::string(py::str(c["model"])) == kPluginModel &&
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

const char* count_name(SceneCount count) {
    switch (count) {
        case SceneCount::Curve: return "curve";
        case SceneCount::Point: return "point";
        case SceneCount::Triangle: return "triangle";
        case SceneCount::Object: return "object";
        case SceneCount::Vertex: return "vertex";
        case SceneCount::Constant: return "constant";
        case SceneCount::None:
        case SceneCount::ByDomain: break;
    }
    return "";
}

const char* count_letter(SceneCount count) {
    switch (count) {
        case SceneCount::Curve: return "C";
        case SceneCount::Point: return "P";
        case SceneCount::Triangle: return "T";
        case SceneCount::Object: return "K";
        case SceneCount::Vertex: return "V";
        case SceneCount::Constant: return "K";
        case SceneCount::None:
        case SceneCount::ByDomain: break;
    }
    return "";
}

namespace {

// An Array row's number of rows as the docs write its shape: "C", "C + 1" (offsets), "P or C"
// (per domain), "" where no count is declared.
std::string rows_text(const SceneKey& k) {
    if (k.offsets_into != SceneCount::None) return std::string(count_letter(k.defines)) + " + 1";
    if (k.defines != SceneCount::None) return count_letter(k.defines);
    if (k.per != SceneCount::ByDomain) return count_letter(k.per);
    std::string text;
    for (const SceneKey& sibling : scene_schema())
        if (parent(sibling.path) == parent(k.path))
            for (SceneCount c : sibling.domains) text += (text.empty() ? "" : " or ") + std::string(count_letter(c));
    return text;
}

}  // namespace

const std::vector<SceneKey>& scene_schema() {
    static const std::vector<SceneKey> rows = [] {
        std::vector<SceneKey> table = make_schema();
        for (SceneKey& k : table)
            if (k.field && !k.required && k.default_value.empty()) k.default_value = k.field.default_text(k);
        return table;
    }();
    return rows;
}

std::vector<const SceneKey*> rows_under(const std::string& path, const std::string& type) {
    std::vector<const SceneKey*> out;
    for (const SceneKey& k : scene_schema())
        if (is_key_of(k, path, type)) out.push_back(&k);
    return out;
}

void read_fields(const std::string& path, const py::dict& checked, std::type_index owner, void* target,
                 const std::function<void(int input, int reg)>& link) {
    if (!path.empty()) scene_key(path);  // throws for a path with no row (a misspelt reader)
    const std::string type = checked.contains("type") ? std::string(py::str(checked["type"])) : std::string();
    for (const SceneKey* k : rows_under(path, type)) {
        if (!k->field) continue;
        if (k->field.owner != owner)
            throw std::logic_error("scene schema: " + std::string(k->path) + " is bound to a field of another struct");
        const std::string name = leaf(k->path);
        if (!checked.contains(name.c_str())) continue;  // check_scene dropped None
        const py::object v = checked[name.c_str()];
        if (k->register_link && py::isinstance<py::dict>(v)) {
            if (!link) throw std::logic_error("scene schema: " + std::string(k->path) + " read without its links");
            link(k->link_input, int32_t(v[py::str("register")].cast<long long>()));
        } else {
            k->field.assign(*k, target, v);
        }
    }
}

py::dict fields_as_python(const std::string& path, const std::string& type, std::type_index owner, const void* source) {
    py::dict out;
    for (const SceneKey* k : rows_under(path, type))
        if (k->field && k->field.owner == owner) out[leaf(k->path).c_str()] = k->field.value(*k, source);
    return out;
}

py::object check_value(const std::string& path, py::handle value, const std::string& key) {
    return Walker().value(path, value, key);
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
        d["rows"] = k.kind == K::Array ? rows_text(k) : std::string();
        d["required"] = k.required;
        d["default"] = k.default_value;
        py::list allowed;
        for (const std::string& a : k.allowed) allowed.append(a);
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
