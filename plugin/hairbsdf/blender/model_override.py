"""The engine's hair model override (issues 7 and 8): a material's Principled Hair closures
rendered with a zoo model or a BSDF plugin, its parameters edited in the Material tab.

    mat.hairbsdf.override = "epic"                   # or "plugin" and mat.hairbsdf.plugin_path
    set_override(mat, "plugin", path="/x/kk.so", params={"specular": 0.2})

`material.hairbsdf` holds the choice, the plugin path and one item per parameter, filled from
the model's schema (hairbsdf.model_schema: the zoo's defaults from the model's C++ parameter table, or
the plugin's own schema). The exporter (export_materials.py) replaces each Principled Hair
closure of an overridden material with a `hair_model` closure of the same weight (the step after translating
it, override_closures)
(docs/scene_desc.md); other closures stay. Ranges are checked when the renderer builds the
model; the panel (ui.py) marks values out of range.

For the harness (hairbsdf compare --model): `override_materials` sets the override on every
material with a Principled Hair node, the parameters from a user mapping of the node's inputs
(`load_mapping`, docs/plugins.md "Compare it with Cycles")."""

from __future__ import annotations

import importlib.util
import json
import os
import struct

import bpy

from .._param_docs import BOOL, CHOICE, FLOAT, INT, PARAM_KINDS, RGB
from ..zoo import PLUGIN_MODEL, model_schema, zoo_models
from ._common import ExportReport
from .export_materials import MaterialTranslator, override_params, override_plugin_path

# Enum identifiers are the zoo's model names, with the titles of their tables (params/<model>.h);
# "NONE": no override.
OVERRIDES = (
    ("NONE", "None", "Render the material's own closures"),
    *zoo_models(),
    (PLUGIN_MODEL, "Plugin", "A hair BSDF plugin library (docs/plugins.md)"),
)
PRINCIPLED_HAIR_NODE = "ShaderNodeBsdfHairPrincipled"

_choice_items_cache = {}  # Blender needs the dynamic enum items kept alive


def _f32(x: float) -> float:
    return struct.unpack("f", struct.pack("f", x))[0]


def _exact(v: float, candidates) -> float:
    """Blender stores floats in single precision: a value that rounds like the schema's default
    or a bound is that double (so a default stays exact and a bound stays in range)."""
    for c in candidates:
        if _f32(c) == _f32(v):
            return float(c)
    return float(v)


def _choice_items(self, context):
    key = self.choices
    if key not in _choice_items_cache:
        _choice_items_cache[key] = [(c, c, "") for c in key.split(",") if c] or [("", "", "")]
    return _choice_items_cache[key]


class HairbsdfModelParam(bpy.types.PropertyGroup):
    """One model parameter (`name` is the parameter's name)."""

    kind: bpy.props.EnumProperty(items=tuple((k, k, "") for k in PARAM_KINDS))  # the schema's "type"
    value: bpy.props.FloatProperty(name="Value", precision=4)
    number: bpy.props.IntProperty(name="Value")  # INT
    color: bpy.props.FloatVectorProperty(name="Color", size=3, subtype="COLOR", min=0.0, soft_max=1.0)
    vector: bpy.props.FloatVectorProperty(name="Value", size=3, precision=4)  # RGB beyond [0, 1] (absorption)
    choice: bpy.props.EnumProperty(name="Choice", items=_choice_items)
    flag: bpy.props.BoolProperty(name="Value")
    choices: bpy.props.StringProperty()  # CHOICE: the allowed names, comma-separated
    optional: bpy.props.BoolProperty()   # derived from others unless `use` is on (d'Eon's sigma_a)
    use: bpy.props.BoolProperty(name="Use", description="Give this parameter (else it is derived from the others)")
    min: bpy.props.FloatProperty()
    max: bpy.props.FloatProperty()
    description: bpy.props.StringProperty()
    exact: bpy.props.StringProperty()  # JSON [min, max, default...] in double precision (_exact)

    def current(self):
        exact = json.loads(self.exact) if self.exact else []
        if self.kind == FLOAT:
            return _exact(self.value, exact)
        if self.kind == RGB:
            return tuple(_exact(c, exact) for c in (self.color if self.max <= 1.0 else self.vector))
        if self.kind == CHOICE:
            return self.choice
        if self.kind == INT:
            return int(self.number)
        return bool(self.flag)

    def assign(self, v):
        if self.kind == FLOAT:
            self.value = float(v)
        elif self.kind == INT:
            if isinstance(v, bool) or not float(v).is_integer():
                raise ValueError(f"parameter '{self.name}': expected a whole number, got {v!r}")
            self.number = int(v)
        elif self.kind == RGB:
            rgb = (float(v),) * 3 if isinstance(v, (int, float)) else tuple(float(c) for c in v)
            if len(rgb) != 3:
                raise ValueError(f"parameter '{self.name}': expected an RGB triple, got {v!r}")
            if self.max <= 1.0:
                self.color = rgb
            else:
                self.vector = rgb
        elif self.kind == CHOICE:
            allowed = self.choices.split(",")
            if v not in allowed:
                raise ValueError(f"parameter '{self.name}': {v!r} is not allowed; choose one of {allowed}")
            self.choice = v
        else:
            self.flag = bool(v)
        if self.optional:
            self.use = True

    def in_range(self) -> bool:
        if self.kind == FLOAT:
            return self.min <= self.value <= self.max
        if self.kind == INT:
            return self.min <= self.number <= self.max
        if self.kind == RGB:
            return all(self.min <= c <= self.max for c in self.current())
        return True


def _refill(self, context):
    fill_params(self)


class HairbsdfMaterialSettings(bpy.types.PropertyGroup):
    override: bpy.props.EnumProperty(
        name="Hair Model", items=OVERRIDES, default="NONE", update=_refill,
        description="Render this material's Principled Hair closures with another hair model")
    plugin_path: bpy.props.StringProperty(
        name="Plugin", subtype="FILE_PATH", update=_refill,
        description="Shared library of a hair BSDF plugin (hairbsdf/plugin.h, docs/plugins.md)")
    params: bpy.props.CollectionProperty(type=HairbsdfModelParam)
    schema_error: bpy.props.StringProperty()  # why the schema could not be read (a plugin that does not load)


def fill_params(settings, keep=True) -> None:
    """One item per schema parameter with its default; with `keep`, items of the same name and
    kind keep their values (switching between builds of one plugin)."""
    model = settings.override
    path = override_plugin_path(settings) if model == PLUGIN_MODEL else ""
    old = {p.name: (p.kind, p.current(), p.use) for p in settings.params} if keep else {}
    settings.params.clear()
    settings.schema_error = ""
    if model == "NONE" or (model == PLUGIN_MODEL and not path):
        return
    try:
        schema = model_schema(model, path or None)
    except Exception as exc:  # a plugin that does not load: say why in the panel
        settings.schema_error = f"{type(exc).__name__}: {exc}"
        return
    for spec in schema:
        item = settings.params.add()
        item.name = spec["name"]
        item.kind = spec["type"]
        item.min, item.max = spec["min"], spec["max"]
        if item.kind in (FLOAT, RGB):
            default = spec["default"] if item.kind == RGB else [spec["default"]]
            item.exact = json.dumps([spec["min"], spec["max"], *default])
        item.description = spec.get("description") or ""
        item.optional = bool(spec.get("optional"))
        if item.kind == CHOICE:
            item.choices = ",".join(spec["choices"])
        item.assign(spec["default"])
        item.use = False
        if item.name in old and old[item.name][0] == item.kind:
            item.assign(old[item.name][1])
            item.use = old[item.name][2]


def set_override(material, model: str, path: str | None = None, params: dict | None = None) -> dict:
    """Sets the override of `material` (model "NONE" removes it) and the given parameter
    values by name. Returns the parameters the exporter will write. ValueError for an
    unknown model or parameter, or a plugin whose schema cannot be read."""
    names = [o[0] for o in OVERRIDES]
    if model not in names:
        raise ValueError(f"model {model!r} is not allowed; use one of {names}")
    s = material.hairbsdf
    if model == PLUGIN_MODEL:
        if not path:
            raise ValueError("the plugin override needs the path of the plugin library")
        s.plugin_path = path
    s.override = model
    fill_params(s, keep=False)  # also when the enum did not change (no update call)
    if s.schema_error:
        raise ValueError(f"material '{material.name}': {s.schema_error}")
    by_name = {p.name: p for p in s.params}
    for name, value in (params or {}).items():
        if name not in by_name:
            raise ValueError(f"material '{material.name}': model {model!r} has no parameter {name!r}; "
                             f"allowed: {', '.join(by_name)}")
        by_name[name].assign(value)
    return override_params(s)


# ---------------------------------------------------------------------------- harness

def load_mapping(path: str):
    """`map_inputs(inputs: dict) -> dict` from the user's mapping.py (docs/plugins.md)."""
    spec = importlib.util.spec_from_file_location("hairbsdf_user_mapping", path)
    if spec is None or spec.loader is None:
        raise ValueError(f"mapping {path!r}: not a Python file")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    fn = getattr(module, "map_inputs", None)
    if not callable(fn):
        raise ValueError(f"mapping {path!r}: defines no function map_inputs(inputs: dict) -> dict")
    return fn


def principled_inputs(material):
    """The first Principled Hair closure's inputs as the scene loader reads them (the keys of
    docs/scene_desc.md's principled_hair `inputs` for its model, colours as tuples, `random` None when
    the per-strand Hair Info > Random is used) plus `model` and `parametrization`; None without one.
    Inputs computed by nodes are the loader's folded numbers (`_render.folded_material`); one that
    depends on the hit stays {"register": k}."""
    from hairbsdf import _render  # the loader (it loads Embree and TBB): only when asked

    translator = MaterialTranslator(ExportReport())
    desc = translator.translate(material)  # the node's closures: the override is a later step
    exported = {c["model"]: list(c["inputs"]) for c in reversed(desc["closures"]) if c.get("type") == "principled_hair"}
    if not exported:
        return None
    folded = _render.folded_material(desc, attribute_count=len(translator.attributes.names),
                                     images=translator.attributes.images.images)
    for c in folded["closures"]:
        if c.get("type") == "principled_hair":  # the keys the exporter wrote (the node's sockets)
            inputs = {k: c["inputs"][k] for k in exported[c["model"]]}
            return dict(inputs, model=c["model"], parametrization=c["parametrization"])
    return None


def override_materials(materials, model: str, path: str | None = None, map_inputs=None) -> dict:
    """Sets the override on every material with a Principled Hair node; the parameters are
    map_inputs(inputs) of its first Principled Hair closure (principled_inputs), or the
    model's defaults without a mapping. Returns {material name: parameters}."""
    done = {}
    for mat in materials:
        nt = mat.node_tree if getattr(mat, "use_nodes", False) else None
        if nt is None or not any(n.bl_idname == PRINCIPLED_HAIR_NODE for n in nt.nodes):
            continue
        mat.hairbsdf.override = "NONE"  # read the node's own inputs
        params = {}
        if map_inputs is not None:
            inputs = principled_inputs(mat)
            if inputs is not None:
                params = map_inputs(dict(inputs))
                if not isinstance(params, dict):
                    raise TypeError(f"map_inputs returned {type(params).__name__} for material '{mat.name}'; "
                                    "expected a dict of model parameters")
        done[mat.name] = set_override(mat, model, path, params)
    return done


classes = (HairbsdfModelParam, HairbsdfMaterialSettings)  # the panel and its operator live in ui.py


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Material.hairbsdf = bpy.props.PointerProperty(type=HairbsdfMaterialSettings)


def unregister():
    if hasattr(bpy.types.Material, "hairbsdf"):
        del bpy.types.Material.hairbsdf
    for cls in reversed(classes):
        try:
            bpy.utils.unregister_class(cls)
        except RuntimeError:  # pragma: no cover
            pass
