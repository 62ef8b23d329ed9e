// The scene format (docs/scene_desc.md), declared once: one row per key, walked by
// check_scene() in both Python modules (_core.validate_scene without TBB; _render before it
// reads the dict) and exported as _core.scene_schema() for the docs test.
//
// Adding a key: add its row to the table in scene_schema.cpp (path, kind, shape, required or
// default, allowed values or range, one-line meaning), read it in render.cpp's read_*, and
// document it in docs/scene_desc.md (plugin/tests/test_scene_schema.py fails until the doc's
// generated table matches: run `python scripts/scene_schema_doc.py --write`).
#pragma once

#include <pybind11/pybind11.h>

#include <string>
#include <vector>

namespace hairbsdf::bindings {

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
    ModelName,    // a zoo model's name or "plugin" (the model factory's names)
    ModelParams,  // {name: number | RGB triple | string | bool}, checked by the model factory
    Informational // not read
};

struct SceneKey {
    const char* path;       // "lights[].strength": dict keys joined by '.', a list's items as "[]"
    SceneKeyKind kind;
    const char* dtype = "";  // Array / Image: "float32", "int32" or "float64"
    int columns = 0;         // Array: 0 for (N,), else (N, columns); Vector: its length; Image: channels
    bool required = false;
    const char* default_value = "";  // the default the renderer uses when the key is absent (for the docs)
    std::vector<const char*> allowed = {};  // Enum / EnumList
    double minimum = 0, maximum = 0;        // Int / IntPair when minimum < maximum or `bounded`
    bool bounded = false;
    const char* only_for = "";  // space-separated values of the sibling "type": the key exists only for them
    bool register_link = false;  // may be {"register": k}: the material program's register k
    bool closed = false;         // Dict: an unknown key is an error (Principled Hair's inputs)
    // Principled Hair inputs: the Blender node's socket, its kind for the exporter ("float",
    // "color", "vector") and the models that read it ("CHIANG HUANG"; "" for Random, which the
    // exporter treats apart).
    const char* socket = "";
    const char* socket_kind = "";
    const char* hair_models = "";
    const char* meaning = "";
};

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

// The table as Python data: a list of dicts, one per row (keys as SceneKey's fields).
pybind11::list scene_schema_as_python();

}  // namespace hairbsdf::bindings
