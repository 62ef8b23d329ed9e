// The scene format (docs/scene_desc.md), declared once: one row per key, walked by
// check_scene() in both Python modules (_core.validate_scene without TBB; _render before it
// reads the dict) and exported as _core.scene_schema() for the docs test.
//
// Adding a key: add its row to the table in scene_schema.cpp (path, kind, shape, required,
// allowed values or range, one-line meaning). A key that is a plain value of a SceneDesc
// struct (hairbsdf/render/scene.h) binds its field with .field(&Struct::member): render.cpp's
// read_fields copies it, and its default is the field's initial value, written there only.
// An Array or Image binds its std::vector the same way (.field / .image_field) and says which
// count its length defines or matches (.defines, .offsets_into, .per, .index_into): the walker's
// length checks and the docs' shapes ("(C,)") come from those. Keys with rules of their own are
// read by hand in render.cpp. Then document it in docs/scene_desc.md
// (plugin/tests/test_scene_schema.py fails until the doc's key table matches and prints the rows
// it expects).
#pragma once

#include <pybind11/pybind11.h>

#include <functional>
#include <string>
#include <typeindex>
#include <vector>

namespace hairbsdf::bindings {

struct SceneKey;

// A row bound to the C++ field the renderer reads it into (scene_schema.cpp's .field()).
struct SceneField {
    std::type_index owner = typeid(void);  // the struct that holds the field
    // Copies a value check_scene accepted into the field of *owner (an S*).
    std::function<void(const SceneKey&, void* owner, pybind11::handle value)> assign;
    // The field's value in *owner (an S*) as check_scene writes it (a number, a tuple, an enum's name).
    std::function<pybind11::object(const SceneKey&, const void* owner)> value;
    // The field's initial value in a default-constructed S, as the docs write it.
    std::function<std::string(const SceneKey&)> default_text;
    explicit operator bool() const { return bool(assign); }
};

// The counts an Array's length is checked against (check_scene): a row .defines one (its length),
// or is the CSR offsets of one (Curve = its length - 1); other rows match one .per item.
enum class SceneCount {
    None,
    Curve,
    Point,
    Triangle,
    Object,
    Vertex,
    Constant,  // a shading program's constants
    ByDomain,  // the count the item's sibling Enum with .domains() selects
};

enum class SceneKeyKind {
    Dict,         // a dict of the rows below it
    List,         // a list; its items are the row "<path>[]"
    Real,         // a number
    Int,          // an integer, within [minimum, maximum]
    Bool,         // True / False (NumPy bools too)
    String,       // any string
    Enum,         // one of `allowed`
    EnumList,     // a list of names from `allowed`
    Vector,       // `columns` numbers (an RGB triple, a direction)
    IntPair,      // 2 integers within [minimum, maximum]
    Matrix,       // a float64 matrix: columns 4 for 4x4, 3 for 3x4 or 4x4 (kept as 3x4)
    Array,        // a NumPy array (N,) or (N, columns) of `dtype`
    Image,        // a float32 (H, W, columns) array, H, W >= 1
    ModelName,    // one of the model factory's model_names()
    ModelParams,  // {name: number | RGB triple | string | bool}, checked by the model factory
    Informational // not read
};

struct SceneKey {
    std::string path;       // "lights[].strength": dict keys joined by '.', a list's items as "[]"
    SceneKeyKind kind;
    const char* dtype = "";  // Array / Image: "float32", "int32" or "float64"
    int columns = 0;         // Array: 0 for (N,), else (N, columns); Vector: its length; Image: channels
    bool required = false;
    // The default the renderer uses when the key is absent, for the docs: the bound field's
    // initial value, or a rule where the default is not a value ("size_x").
    std::string default_value = "";
    std::vector<std::string> allowed = {};  // Enum / EnumList
    std::vector<long> allowed_values = {};  // a bound Enum: the C++ value of each allowed name
    double minimum = 0, maximum = 0;        // Int / IntPair when minimum < maximum or `bounded`
    bool bounded = false;
    const char* only_for = "";  // space-separated values of the sibling "type": the key exists only for them
    bool register_link = false;  // may be {"register": k}: the material program's register k
    int link_input = -1;         // then the ClosureDesc::Input that register drives
    bool closed = false;         // Dict: an unknown key is an error (Principled Hair's inputs)
    // Principled Hair inputs and the legacy Hair BSDF's keys: the Blender node's socket, its kind
    // for the exporter ("float", "color", "vector") and the Principled Hair models that read it
    // ("CHIANG HUANG"; "" for Random, which the exporter treats apart, and for the Hair BSDF).
    const char* socket = "";
    const char* socket_kind = "";
    const char* hair_models = "";
    const char* meaning = "";
    SceneField field = {};
    // Array: the count its length defines, or (`offsets_into`) the count its entries are CSR
    // offsets into, when it defines SceneCount::Curve as its length - 1; `per`: the count its
    // length matches, `per_item` (+ " per curve") what each row is; `index_into`: its values
    // index that count's rows, `index_none` (meaning `index_none_text`) allowed too, and the
    // row defining that count is then required; `affine`: rows of row-major 3x4 matrices that must
    // be finite and invertible. Int: `at_least`, a count it must be >= to. Enum: `domains`, the
    // count each allowed value selects for its siblings' SceneCount::ByDomain.
    SceneCount defines = SceneCount::None;
    SceneCount offsets_into = SceneCount::None;
    SceneCount per = SceneCount::None;
    const char* per_item = "";
    SceneCount index_into = SceneCount::None;
    int index_none = -1;
    const char* index_none_text = "";
    bool affine = false;
    SceneCount at_least = SceneCount::None;
    std::vector<SceneCount> domains = {};
};

// The singular name of a count ("curve", "point", ...) for errors, and its letter in the docs'
// shapes ("C", "P", ...); "" for None and ByDomain.
const char* count_name(SceneCount count);
const char* count_letter(SceneCount count);

// The paths the readers (render.cpp, module.cpp) walk, each a row of the table; read_fields and
// read_list throw std::logic_error for a path with no row, so a misspelling fails at once.
inline constexpr const char* kMaterialsPath = "materials[]";
inline constexpr const char* kMaterialProgramPath = "materials[].program";
inline constexpr const char* kClosuresPath = "materials[].closures[]";
inline constexpr const char* kPrincipledHairInputsPath = "materials[].closures[].inputs";  // _core.PRINCIPLED_HAIR_INPUTS
inline constexpr const char* kImagesPath = "images";

// The table, in the docs' order.
const std::vector<SceneKey>& scene_schema();

// The row of a path ("lights[].type"; "integrator.passes[]" is the row "integrator.passes"):
// the first with allowed values where rows share a path (keys that depend on the type).
const SceneKey& scene_key(const std::string& path);

// Validates a scene dict against the table (and the cross-key rules: counts per curve, CSR
// offsets, object transforms, attribute names, program registers) and returns a normalised
// copy: declared keys only, arrays contiguous in their dtype. Errors name the key path,
// e.g. "scene['lights'][0]['strength']: expected 3 numbers" (TypeError / ValueError).
pybind11::dict check_scene(pybind11::handle scene);

// The same walk for one value at a schema path ("materials[].program" for eval_program);
// errors start with `key`.
pybind11::object check_value(const std::string& path, pybind11::handle value, const std::string& key);

// The rows of the keys of the dict at `path` ("" for the scene, "lights[]" for a light) that
// apply to a dict of this "type" ("" where it has none), in the table's order.
std::vector<const SceneKey*> rows_under(const std::string& path, const std::string& type);

// Copies the bound keys of `checked` (the dict at `path` in check_scene's output) into the
// fields of `target`, an `owner`; a key given as {"register": k} calls link(row.link_input, k)
// instead. Keys absent keep the field's initial value. A `path` with no row ("" is the scene), or
// a row under it bound to a field of another struct, is a std::logic_error (the table and the
// reader disagree).
void read_fields(const std::string& path, const pybind11::dict& checked, std::type_index owner, void* target,
                 const std::function<void(int input, int reg)>& link = {});

template <class S>
void read_fields(const std::string& path, const pybind11::dict& checked, S& target,
                 const std::function<void(int input, int reg)>& link = {}) {
    read_fields(path, checked, typeid(S), &target, link);
}

// Reads the list at `path` ("images", "curves.attributes") of `checked` (the dict holding it), one
// item per read_fields(path + "[]"); absent: `items` is left as it is. A `path` with no row is a
// std::logic_error, whether the list is there or not.
template <class Item>
void read_list(const std::string& path, const pybind11::dict& checked, std::vector<Item>& items) {
    scene_key(path);  // throws for a path with no row
    const std::string name = path.substr(path.rfind('.') + 1);  // npos + 1 = 0
    if (!checked.contains(name.c_str())) return;
    for (pybind11::handle h : pybind11::reinterpret_borrow<pybind11::list>(checked[name.c_str()])) {
        items.emplace_back();
        read_fields(path + "[]", pybind11::reinterpret_borrow<pybind11::dict>(h), items.back());
    }
}

// The bound keys of the dict at `path` for this "type", read back from `source` (an `owner`): the
// inverse of read_fields, for what the loader made of a scene (hairbsdf._render.folded_material).
pybind11::dict fields_as_python(const std::string& path, const std::string& type, std::type_index owner,
                                const void* source);

// The table as Python data: a list of dicts, one per row (keys as SceneKey's fields).
pybind11::list scene_schema_as_python();

}  // namespace hairbsdf::bindings
