"""MaterialX hair: the `chiang_hair_bsdf` closure, its support nodes, the `simple_hair_default`
node graph, and the MDL `SimpleHairBase` material of the MaterialX proposal.

Names and defaults are MaterialX 1.39's nodedefs (checked against the `materialx` wheel by
the tests). Semantics follow the specification; docs/materialx.md lists where the GLSL,
OSL and MDL backends differ and the slips in the proposal's MDL text.
"""

from __future__ import annotations

import functools
import inspect
import math
from typing import NamedTuple

import numpy as np

from . import _core
from . import _validate as check
from ._param_docs import FLOAT, VECTOR2, with_parameters
from .closure import Closure


_TABLES = "bsdf_core/include/hairbsdf/params/materialx.h"


def _table_defaults(node: str) -> dict:
    """A node's input names and nodedef defaults, from its C++ table (params/materialx.h)."""
    return {p["name"]: p["default"] for p in _core.materialx_schema(node)}


def _table_parameters(node: str):
    """Appends the node's generated Parameters block to the function's docstring."""
    return with_parameters(_core.materialx_schema(node), _TABLES)


# Roughness pairs: (longitudinal variance v, azimuthal scale s).
CHIANG_HAIR_BSDF_DEFAULTS = _table_defaults("chiang_hair_bsdf")
CHIANG_HAIR_ROUGHNESS_DEFAULTS = _table_defaults("chiang_hair_roughness")
CHIANG_HAIR_ABSORPTION_FROM_COLOR_DEFAULTS = _table_defaults("chiang_hair_absorption_from_color")
DEON_HAIR_ABSORPTION_FROM_MELANIN_DEFAULTS = _table_defaults("deon_hair_absorption_from_melanin")


def _pair(name, value, lowest):
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected a vector2 (v, s) of numbers, got {value!r}") from exc
    if arr.shape != (2,):
        raise ValueError(f"{name}: expected a vector2 (v, s), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: must be finite")
    if np.any(arr < lowest):
        raise ValueError(f"{name}: (v, s) must be >= {lowest:g} (MaterialX range [{lowest:g}, inf))")
    return (float(arr[0]), float(arr[1]))


def _checked(row: dict, value):
    """An input's value checked by its table row's kind: a vector2 (v, s) above the row's lower bound, a number or
    an RGB colour."""
    if row["type"] == VECTOR2:
        return _pair(row["name"], value, row["min"])
    if row["type"] == FLOAT:
        return check.real(row["name"], value)
    return check.color(row["name"], value)


def _from_table(node: str):
    """Turns `body`, a function of the node's checked inputs (a dict), into MaterialX `node`'s function: its
    signature is the node's table (params/materialx.h; an inspect.Signature with the table's defaults), each
    argument is checked by its row's kind, and the docstring gets the generated Parameters block."""
    schema = _core.materialx_schema(node)
    parameters = [inspect.Parameter(row["name"], inspect.Parameter.POSITIONAL_OR_KEYWORD, default=row["default"])
                  for row in schema]

    def decorate(body):
        signature = inspect.Signature(parameters, return_annotation=inspect.signature(body).return_annotation)

        @functools.wraps(body)
        def function(*args, **given):
            bound = signature.bind(*args, **given)
            bound.apply_defaults()
            return body({row["name"]: _checked(row, bound.arguments[row["name"]]) for row in schema})

        function.__signature__ = signature
        return with_parameters(schema, _TABLES)(function)
    return decorate


_BSDF_ROWS = {row["name"]: row for row in _core.materialx_schema("chiang_hair_bsdf")}


@_table_parameters("chiang_hair_bsdf")
def chiang_hair_bsdf(*, glsl_compat: bool = False, **inputs) -> Closure:
    """MaterialX `chiang_hair_bsdf`: sum over R, TT, TRT, TRRT+ of tint * A_p * M_p * N_p.

    Keywords are the nodedef's input names, listed below: the roughness pairs are vector2 (v, s)
    with s without sqrt(pi/8); cuticle_angle is normalised (mapped to (c - 0.5) * pi radians).
    `normal` and `curve_direction` come from the fibre frame (`h` and `x`). `glsl_compat=True`
    multiplies by the GLSL backend's extra 1/pi.
    """
    check.keywords("chiang_hair_bsdf", inputs, _BSDF_ROWS)
    v = dict(CHIANG_HAIR_BSDF_DEFAULTS)
    for key, value in inputs.items():
        v[key] = _checked(_BSDF_ROWS[key], value)
    core = _core.materialx_chiang(v)
    shown = ", ".join(f"{k}={val!r}" for k, val in inputs.items())
    closure = Closure(core, f"chiang_hair_bsdf({shown})")
    return closure * (1.0 / math.pi) if glsl_compat else closure


# help() shows the inputs (the table's rows) as keywords; the call takes them as **inputs.
chiang_hair_bsdf.__signature__ = inspect.Signature(
    [inspect.Parameter("glsl_compat", inspect.Parameter.KEYWORD_ONLY, default=False),
     *(inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=row["default"])
       for name, row in _BSDF_ROWS.items())], return_annotation=Closure)


class ChiangHairRoughness(NamedTuple):
    roughness_R: tuple
    roughness_TT: tuple
    roughness_TRT: tuple


@_from_table("chiang_hair_roughness")
def chiang_hair_roughness(inputs: dict) -> ChiangHairRoughness:
    """MaterialX `chiang_hair_roughness`: (v, s) per lobe from artist roughness (Chiang 2016
    eqs. 7-8, s without sqrt(pi/8)); TT and TRT scale only v, by scale**2."""
    return ChiangHairRoughness(*(tuple(x) for x in _core.materialx_roughness(inputs)))


@_from_table("chiang_hair_absorption_from_color")
def chiang_hair_absorption_from_color(inputs: dict) -> np.ndarray:
    """MaterialX `chiang_hair_absorption_from_color`: Chiang 2016 eq. 9 on the clamped colour."""
    return np.array(_core.materialx_absorption_from_color(inputs))


@_from_table("deon_hair_absorption_from_melanin")
def deon_hair_absorption_from_melanin(inputs: dict) -> np.ndarray:
    """MaterialX `deon_hair_absorption_from_melanin`: q = -ln(max(1 - c, 1e-4)),
    sigma = max(q(1 - r)(-ln E) + q r (-ln P), 0) with d'Eon's pigment colours E and P."""
    return np.array(_core.materialx_absorption_from_melanin(inputs))


# Interface of the `simple_hair` node graph (resources/Materials/Examples/SimpleHair): a graph of the
# nodes above with no C++ counterpart, so its interface defaults are written here only (as are
# simple_hair_base's, the MDL proposal's, in its signature).
SIMPLE_HAIR_DEFAULTS = {
    "melaninConcentration": 0.5,
    "melaninRedness": 0.5,
    "melaninMix": 1.0,
    "baseColor": (1.0, 1.0, 1.0),
    "longitudinalRoughness": 0.1,
    "azimuthalRoughness": 0.1,
    "cuticleAngle": 0.5,
    "tint_R": (1.0, 1.0, 1.0),
    "tint_TT": (1.0, 1.0, 1.0),
    "tint_TRT": (1.0, 1.0, 1.0),
    "ior": 1.55,
}


def simple_hair_default(**inputs) -> Closure:
    """The MaterialX `simple_hair_default` material: melanin and colour absorptions blended
    by melaninMix, `chiang_hair_roughness` feeding all three lobes, no diffuse. As in the
    graph, the colour helper keeps its default azimuthal roughness 0.2 (it is not wired)."""
    check.keywords("simple_hair_default", inputs, SIMPLE_HAIR_DEFAULTS)
    v = dict(SIMPLE_HAIR_DEFAULTS)
    v.update(inputs)
    melanin = deon_hair_absorption_from_melanin(v["melaninConcentration"], v["melaninRedness"])
    color = chiang_hair_absorption_from_color(v["baseColor"])
    mix = check.real("melaninMix", v["melaninMix"])
    absorption = mix * melanin + (1.0 - mix) * color
    r = chiang_hair_roughness(v["longitudinalRoughness"], v["azimuthalRoughness"])
    return chiang_hair_bsdf(tint_R=v["tint_R"], tint_TT=v["tint_TT"], tint_TRT=v["tint_TRT"], ior=v["ior"],
                            roughness_R=r.roughness_R, roughness_TT=r.roughness_TT, roughness_TRT=r.roughness_TRT,
                            cuticle_angle=v["cuticleAngle"], absorption_coefficient=tuple(absorption))


def simple_hair_base(*, base_color_weight: float = 1.0, base_color=(1.0, 1.0, 1.0),
                     melanin_concentration: float = 1.0, melanin_redness: float = 0.5,
                     specular_reflection_roughness: float = 0.1,
                     specular_reflection_anisotropic_roughness: bool = False,
                     specular_reflection_azimuthal_roughness: float = 0.2, specular_reflection_ior: float = 1.55,
                     specular_reflection_shift: float = 0.5, tint_R=(1.0, 1.0, 1.0), tint_TT=(1.0, 1.0, 1.0),
                     tint_TRT=(1.0, 1.0, 1.0)) -> Closure:
    """The MDL `SimpleHairBase` material of the MaterialX hair proposal, as it was meant
    (docs/materialx.md §7 lists the slips in its text and how each is read here):
    s comes from the azimuthal fit of the (isotropic or azimuthal) roughness, TT/TRT scale
    only v (by 1/4 and 4), the shift maps to (shift - 0.5) * pi, the melanin absorption is
    used when base_color is white with weight 1 (else the colour absorption), and the IOR
    is kept above 1 + 1e-5. Defaults are the proposal's."""
    roughness = check.real("specular_reflection_roughness", specular_reflection_roughness)
    azimuthal = (check.real("specular_reflection_azimuthal_roughness", specular_reflection_azimuthal_roughness)
                 if specular_reflection_anisotropic_roughness else roughness)
    r = chiang_hair_roughness(roughness, azimuthal, 0.5, 2.0)
    color = check.color("base_color", base_color)
    weight = check.real("base_color_weight", base_color_weight)
    if color == (1.0, 1.0, 1.0) and weight == 1.0:
        absorption = deon_hair_absorption_from_melanin(melanin_concentration, melanin_redness)
    else:
        absorption = chiang_hair_absorption_from_color(tuple(weight * c for c in color), azimuthal)
    return chiang_hair_bsdf(tint_R=tint_R, tint_TT=tint_TT, tint_TRT=tint_TRT,
                            ior=max(check.real("specular_reflection_ior", specular_reflection_ior), 1.0 + 1e-5),
                            roughness_R=r.roughness_R, roughness_TT=r.roughness_TT, roughness_TRT=r.roughness_TRT,
                            cuticle_angle=check.real("specular_reflection_shift", specular_reflection_shift),
                            absorption_coefficient=tuple(absorption))


# --- .mtlx documents: load and export -----------------------------------------------------------
# load() evaluates the graph that feeds a `chiang_hair_bsdf` node, with the hair support nodes and
# a few arithmetic nodes, inside nodegraphs (interface inputs, nodedef implementations and their
# instance nodes) or at document level. Values are parsed from their strings in double precision
# (MaterialX's own Value type holds float32). export() writes the equivalent chiang_hair_bsdf
# document for Principled Hair parameters. docs/plugins.md has an example of each.

class MaterialXLoadError(ValueError):
    """A .mtlx document that load() cannot turn into a closure; the message says where."""


_SUPPORTED_NODES = ("chiang_hair_bsdf", "chiang_hair_roughness", "chiang_hair_absorption_from_color",
                    "deon_hair_absorption_from_melanin", "constant", "dot", "convert", "mix", "add", "subtract",
                    "multiply", "divide")
_STDLIB = None


def _mx():
    try:
        import MaterialX as mx
    except ImportError as exc:  # pragma: no cover - materialx is a dependency
        raise ImportError("hairbsdf.materialx.load/export need the `materialx` package (pip install materialx)") from exc
    return mx


def _stdlib():
    """MaterialX's standard libraries (nodedef defaults), loaded once."""
    global _STDLIB
    if _STDLIB is None:
        mx = _mx()
        lib = mx.createDocument()
        mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
        _STDLIB = lib
    return _STDLIB


def _parse(value_string: str, type_name: str, where: str):
    """A MaterialX value string -> float or tuple of floats, in double precision."""
    try:
        parts = [float(p) for p in value_string.replace(",", " ").split()]
    except ValueError as exc:
        raise MaterialXLoadError(f"{where}: cannot read {value_string!r} as {type_name}") from exc
    sizes = {"float": 1, "integer": 1, "boolean": 1, "vector2": 2, "color3": 3, "vector3": 3, "color4": 4,
             "vector4": 4}
    if type_name not in sizes:
        raise MaterialXLoadError(f"{where}: type {type_name!r} is not supported (float, vector2, vector3, color3)")
    if len(parts) != sizes[type_name]:
        raise MaterialXLoadError(f"{where}: {value_string!r} has {len(parts)} numbers; {type_name} needs "
                                 f"{sizes[type_name]}")
    return parts[0] if sizes[type_name] == 1 else tuple(parts)


def _arr(x):
    return np.asarray(x, dtype=np.float64)


def _out(x):
    a = np.asarray(x, dtype=np.float64)
    return float(a) if a.ndim == 0 else tuple(float(v) for v in a)


class _Evaluator:
    """Evaluates node outputs; `interface` resolves interfacename inputs of the current graph."""

    def __init__(self, doc):
        self.doc = doc
        self.stack: list[str] = []

    def node_outputs(self, node, interface) -> dict:
        path = node.getNamePath()
        if path in self.stack:
            raise MaterialXLoadError(f"node '{path}': the graph has a cycle through it")
        self.stack.append(path)
        try:
            return self._evaluate(node, interface)
        finally:
            self.stack.pop()

    def input_value(self, node, name: str, interface):
        """The value of input `name` of `node`: connected, from the interface, set, or the nodedef's default."""
        where = f"node '{node.getNamePath()}' ({node.getCategory()}) input '{name}'"
        inp = node.getInput(name)
        if inp is not None:
            if inp.getNodeName() or inp.getNodeGraphString():
                return self.connection(inp, node, where, interface)
            if inp.getInterfaceName():
                return interface(inp.getInterfaceName(), where)
            if inp.getValueString():
                return _parse(inp.getValueString(), inp.getType(), where)
        return self.default(node, name, where)

    def default(self, node, name: str, where: str):
        nodedef = self.nodedef(node)
        d = nodedef.getActiveInput(name) if nodedef is not None else None
        if d is None or not d.getValueString():
            raise MaterialXLoadError(f"{where}: not set and its nodedef has no default")
        return _parse(d.getValueString(), d.getType(), where)

    def nodedef(self, node):
        nd = self.doc.getNodeDef(node.getNodeDefString()) if node.getNodeDefString() else None
        if nd is None:
            for candidate in _stdlib().getMatchingNodeDefs(node.getCategory()) + \
                    self.doc.getMatchingNodeDefs(node.getCategory()):
                if candidate.getType() == node.getType() or node.getType() in ("", "multioutput"):
                    if all(candidate.getActiveInput(i.getName()) is None or
                           candidate.getActiveInput(i.getName()).getType() == i.getType() for i in node.getInputs()):
                        return candidate
        return nd

    def connection(self, inp, node, where: str, interface):
        output = inp.getOutputString()
        if inp.getNodeGraphString():
            graph = self.doc.getNodeGraph(inp.getNodeGraphString())
            if graph is None:
                raise MaterialXLoadError(f"{where}: nodegraph '{inp.getNodeGraphString()}' not found")
            out = graph.getOutput(output) if output else (graph.getOutputs()[0] if graph.getOutputs() else None)
            if out is None:
                raise MaterialXLoadError(f"{where}: nodegraph '{graph.getName()}' has no output {output!r}")
            return self.graph_output(graph, out, self.graph_interface(graph, None))
        parent = inp.getParent().getParent()  # the graph (or document) that holds `node`
        upstream = parent.getNode(inp.getNodeName())
        if upstream is None:
            raise MaterialXLoadError(f"{where}: connected node '{inp.getNodeName()}' not found")
        outputs = self.node_outputs(upstream, interface)
        if output:
            if output not in outputs:
                raise MaterialXLoadError(f"{where}: node '{upstream.getName()}' has no output {output!r}; it has "
                                         f"{', '.join(outputs)}")
            return outputs[output]
        return next(iter(outputs.values()))

    def graph_output(self, graph, out, interface):
        where = f"nodegraph '{graph.getName()}' output '{out.getName()}'"
        if out.getNodeName():
            node = graph.getNode(out.getNodeName())
            if node is None:
                raise MaterialXLoadError(f"{where}: node '{out.getNodeName()}' not found")
            outputs = self.node_outputs(node, interface)
            return outputs[out.getOutputString()] if out.getOutputString() else next(iter(outputs.values()))
        if out.getInterfaceName():
            return interface(out.getInterfaceName(), where)
        raise MaterialXLoadError(f"{where}: not connected")

    def graph_interface(self, graph, instance):
        """Resolver for interfacename inputs of `graph`: the instance node's inputs, then the graph's or
        its nodedef's declared values."""
        nodedef = self.doc.getNodeDef(graph.getNodeDefString()) if graph.getNodeDefString() else None

        def resolve(name, where):
            if instance is not None and instance.getInput(name) is not None:
                return self.input_value(instance, name, self.outer_interface)
            for owner in (graph, nodedef):
                decl = owner.getInput(name) if owner is not None else None
                if decl is not None:
                    if decl.getNodeName() or decl.getNodeGraphString():
                        return self.connection(decl, owner, where, self.outer_interface)
                    if decl.getValueString():
                        return _parse(decl.getValueString(), decl.getType(), f"{where} (interface '{name}')")
            raise MaterialXLoadError(f"{where}: interface input '{name}' is not declared on nodegraph "
                                     f"'{graph.getName()}' or its nodedef, or has no value")
        return resolve

    @staticmethod
    def outer_interface(name, where):
        raise MaterialXLoadError(f"{where}: interfacename '{name}' used outside a nodegraph")

    def _evaluate(self, node, interface) -> dict:
        cat = node.getCategory()
        get = lambda name: self.input_value(node, name, interface)  # noqa: E731
        if cat == "chiang_hair_roughness":
            r = chiang_hair_roughness(get("longitudinal"), get("azimuthal"), get("scale_TT"), get("scale_TRT"))
            return {"roughness_R": r.roughness_R, "roughness_TT": r.roughness_TT, "roughness_TRT": r.roughness_TRT}
        if cat == "chiang_hair_absorption_from_color":
            return {"absorption": _out(chiang_hair_absorption_from_color(get("color"), get("azimuthal_roughness")))}
        if cat == "deon_hair_absorption_from_melanin":
            return {"absorption": _out(deon_hair_absorption_from_melanin(
                get("melanin_concentration"), get("melanin_redness"), get("eumelanin_color"),
                get("pheomelanin_color")))}
        if cat in ("constant", "dot"):
            return {"out": get("value" if cat == "constant" else "in")}
        if cat == "convert":
            value = _arr(get("in"))
            size = {"float": 1, "vector2": 2, "vector3": 3, "color3": 3}.get(node.getType())
            if size is None:
                raise MaterialXLoadError(f"node '{node.getNamePath()}': convert to {node.getType()!r} is not supported")
            return {"out": _out(np.broadcast_to(value, (size,))[0] if size == 1 else np.broadcast_to(value, (size,)))}
        if cat == "mix":
            fg, bg, t = _arr(get("fg")), _arr(get("bg")), _arr(get("mix"))
            return {"out": _out(t * fg + (1.0 - t) * bg)}
        if cat in ("add", "subtract", "multiply", "divide"):
            a, b = _arr(get("in1")), _arr(get("in2"))
            ops = {"add": np.add, "subtract": np.subtract, "multiply": np.multiply, "divide": np.divide}
            return {"out": _out(ops[cat](a, b))}
        if cat == "chiang_hair_bsdf":
            return {"out": {k: get(k) for k in CHIANG_HAIR_BSDF_DEFAULTS}}
        raise MaterialXLoadError(f"node '{node.getNamePath()}' of category '{cat}' is not supported; supported: "
                                 f"{', '.join(_SUPPORTED_NODES)}")


def _hair_nodes(doc) -> list:
    return [e for e in doc.traverseTree() if e.getCategory() == "chiang_hair_bsdf" and hasattr(e, "getInputs")]


def load_inputs(path, *, node: str | None = None, instance: str | None = None) -> dict:
    """The inputs of the `chiang_hair_bsdf` node of a .mtlx file, with its graph evaluated:
    {tint_R, tint_TT, tint_TRT, ior, roughness_R, roughness_TT, roughness_TRT, cuticle_angle,
    absorption_coefficient}. `node` picks one by name (or name path) when the file has several;
    `instance` picks the instance node of a nodedef-implementing nodegraph when several exist."""
    mx = _mx()
    doc = mx.createDocument()
    try:
        mx.readFromXmlFile(doc, str(path))
    except Exception as exc:
        raise MaterialXLoadError(f"{path}: cannot read the MaterialX document: {exc}") from exc
    found = _hair_nodes(doc)
    if node is not None:
        found = [n for n in found if node in (n.getName(), n.getNamePath())]
    if not found:
        raise MaterialXLoadError(f"{path}: no chiang_hair_bsdf node{f' named {node!r}' if node else ''}")
    if len(found) > 1:
        raise MaterialXLoadError(f"{path}: {len(found)} chiang_hair_bsdf nodes "
                                 f"({', '.join(n.getNamePath() for n in found)}); pick one with node=")
    bsdf = found[0]
    ev = _Evaluator(doc)
    parent = bsdf.getParent()
    interface = ev.outer_interface
    if parent.getCategory() == "nodegraph":
        inst = None
        if parent.getNodeDefString():
            nodedef = doc.getNodeDef(parent.getNodeDefString())
            if nodedef is None:
                raise MaterialXLoadError(f"{path}: nodegraph '{parent.getName()}' implements nodedef "
                                         f"'{parent.getNodeDefString()}', which is not in the document")
            candidates = [n for n in doc.getNodes() if n.getCategory() == nodedef.getNodeString()]
            if instance is not None:
                candidates = [n for n in candidates if n.getName() == instance]
            if len(candidates) > 1:
                raise MaterialXLoadError(f"{path}: {len(candidates)} instances of '{nodedef.getNodeString()}' "
                                         f"({', '.join(n.getName() for n in candidates)}); pick one with instance=")
            inst = candidates[0] if candidates else None
        interface = ev.graph_interface(parent, inst)
    return ev.node_outputs(bsdf, interface)["out"]


def load(path, *, node: str | None = None, instance: str | None = None, glsl_compat: bool = False) -> Closure:
    """Reads a .mtlx file with the `materialx` package and returns the closure of its
    `chiang_hair_bsdf` node, its inputs evaluated through the graph (chiang_hair_roughness,
    chiang_hair_absorption_from_color, deon_hair_absorption_from_melanin, constant, mix, add,
    subtract, multiply, divide, convert, dot; nodegraph interfaces and nodedef instances).
    Raises MaterialXLoadError naming the node and input it cannot evaluate."""
    inputs = load_inputs(path, node=node, instance=instance)
    return chiang_hair_bsdf(glsl_compat=glsl_compat, **inputs)


def _fmt_value(value) -> str:
    values = value if isinstance(value, (tuple, list, np.ndarray)) else (value,)
    return ", ".join(repr(float(v)) for v in values)


def principled_inputs_from_node(node) -> dict:
    """principled_hair keywords from a Blender Principled Hair BSDF node (bpy's
    ShaderNodeBsdfHairPrincipled, Chiang model): its parametrization and its unlinked input
    sockets' values ("Absorption Coefficient" -> absorption_coefficient; colours drop alpha)."""
    if not hasattr(node, "inputs") or not hasattr(node, "parametrization"):
        raise TypeError(f"node: expected a Principled Hair BSDF node (with .inputs and .parametrization), "
                        f"got {type(node).__name__}")
    from .principled import DEFAULT_MODEL, PARAMETRIZATIONS, PRINCIPLED_HAIR_DEFAULTS

    model = getattr(node, "model", DEFAULT_MODEL)  # no .model (Blender 3.x): the default model
    if str(model).lower() != DEFAULT_MODEL:
        raise ValueError(f"node: model {model!r} is not allowed; chiang_hair_bsdf is the Chiang model ('CHIANG')")

    # Blender's parametrization enum names are PARAMETRIZATIONS' keys in upper case.
    parametrization = str(node.parametrization).lower()
    check.choice("node.parametrization", parametrization, PARAMETRIZATIONS)
    out = {"parametrization": parametrization}
    for socket in node.inputs:
        key = socket.name.lower().replace(" ", "_")
        if key not in PRINCIPLED_HAIR_DEFAULTS or getattr(socket, "is_linked", False):
            continue
        value = socket.default_value
        out[key] = tuple(value)[:3] if hasattr(value, "__len__") else float(value)
    return out


def principled_to_chiang_hair_bsdf(closure_or_inputs=None, **inputs) -> dict:
    """chiang_hair_bsdf inputs equivalent to Principled Hair (Chiang model): the roughness pairs
    (v, s without sqrt(pi/8)), absorption and IOR of Cycles' mapping, cuticle_angle = 0.5 + Offset/pi.
    Pass Principled Hair keywords (as principled_hair takes them, parametrization included) or a
    single-term Chiang Closure. The MaterialX closure then equals principled_hair(...,
    tilt="3.4", accuracy="exact") in value (Blender 4.2+ tilts theta_o instead: same highlight
    position for Offset != 0, not the same values; the coat's sampling-only roughness is dropped)."""
    from .principled import principled_hair

    if closure_or_inputs is not None and inputs:
        raise TypeError("pass a Closure, a Principled Hair node or keywords, not more than one")
    if closure_or_inputs is not None and not isinstance(closure_or_inputs, Closure):
        inputs = principled_inputs_from_node(closure_or_inputs)
        closure_or_inputs = None
    closure = closure_or_inputs if isinstance(closure_or_inputs, Closure) else principled_hair(**inputs)
    params = closure.model_params
    if len(params) != 1 or "v" not in params[0] or closure.weights[0] != (1.0, 1.0, 1.0):
        raise ValueError(f"closure: export needs one Chiang term of weight 1 (principled_hair(...)), got {closure!r}")
    p = params[0]
    k = math.sqrt(math.pi / 8)
    v, s = p["v"], p["s"]
    if abs(v[3] - v[2]) > 1e-12 * v[2]:
        raise ValueError("closure: its TRRT+ variance differs from TRT's, which chiang_hair_bsdf cannot express")
    tint = [tuple(t) for t in p.get("tint", [(1.0, 1.0, 1.0)] * 4)]
    if tint[3] != tint[2]:
        raise ValueError("closure: its TRRT+ tint differs from TRT's, which chiang_hair_bsdf cannot express")
    return {"tint_R": tint[0], "tint_TT": tint[1], "tint_TRT": tint[2], "ior": p["eta"],
            "roughness_R": (v[0], s[0] / k), "roughness_TT": (v[1], s[1] / k), "roughness_TRT": (v[2], s[2] / k),
            "cuticle_angle": 0.5 + p["tilt"] / math.pi, "absorption_coefficient": tuple(p["sigma_a"])}


def export(path=None, closure_or_inputs=None, *, name: str = "hair", **inputs) -> str:
    """Writes a MaterialX 1.39 document equivalent to Principled Hair (see
    principled_to_chiang_hair_bsdf for what "equivalent" means): a `chiang_hair_bsdf` node with the
    mapped inputs (full double precision), a `surface` shader and a `surfacematerial` named `name`.
    Returns the XML text; writes it to `path` when given. The document validates against the
    MaterialX standard libraries, and load() of it gives the same closure values."""
    mx = _mx()
    values = principled_to_chiang_hair_bsdf(closure_or_inputs, **inputs)
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"name: {name!r} is not allowed; use an identifier such as 'hair'")
    doc = mx.createDocument()
    bsdf = doc.addNode("chiang_hair_bsdf", f"{name}_bsdf", "BSDF")
    types = {"ior": "float", "cuticle_angle": "float", "absorption_coefficient": "vector3"}
    for key, value in values.items():
        t = types.get(key, "vector2" if key.startswith("roughness") else "color3")
        bsdf.setInputValue(key, _fmt_value(value), t)
    shown = ", ".join(f"{k}={v!r}" for k, v in inputs.items())
    source = repr(closure_or_inputs) if closure_or_inputs is not None else f"principled_hair({shown})"
    bsdf.setDocString(f"hairbsdf.materialx.export of {source}; equals it with tilt='3.4', accuracy='exact'")
    surface = doc.addNode("surface", f"{name}_surface", "surfaceshader")
    surface.setConnectedNode("bsdf", bsdf)
    material = doc.addMaterialNode(name, surface)
    assert material is not None
    ok, message = doc.validate()
    if not ok:  # validate against the standard libraries as well
        check_doc = mx.createDocument()
        check_doc.importLibrary(_stdlib())
        check_doc.copyContentFrom(doc)
        ok, message = check_doc.validate()
        if not ok:
            raise RuntimeError(f"internal: the exported document does not validate: {message}")
    text = mx.writeToXmlString(doc)
    if path is not None:
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
    return text
