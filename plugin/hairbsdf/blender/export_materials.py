"""Blender materials -> the closure lists of docs/scene_desc.md.

Supported (everything else is reported with a warning naming the node and socket):
  * Principled Hair BSDF, Chiang and Huang models (Blender 3.4 has no model enum = Chiang),
    all three parametrizations, every input as its socket value;
  * Hair BSDF (Cycles' legacy node, both components; a linked Tangent is warned about and
    the curve tangent used);
  * Diffuse BSDF, Principled BSDF (rendered as a diffuse of its Base Color), Emission;
  * Mix Shader and Add Shader, folded into closure weights: a Fac computed by nodes makes the
    weight a register of the material's program (per hit where the Fac depends on the hit, as
    Cycles mixes closures);
  * linked closure inputs: the node network feeding them is compiled into the material's
    shading program (shading_network.py, docs/shading_vm.md), which the scene loader folds
    where it does not depend on the hit; Hair Info > Random straight into the Principled Hair's
    Random socket stays None (per-curve random).
A material without nodes is a diffuse of its viewport colour and a missing material is
Cycles' default surface (a grey diffuse, GREY), as in Cycles' shader sync.
A material whose hair model override is set (Material tab, model_override.py) has its
Principled Hair closures replaced by `hair_model` closures of the same weights: the step
after translating it (MaterialTable.index, override_closures).
"""

from __future__ import annotations

import functools
import os

from .. import _core
from .._blender_versions import EMISSION_SAMPLING_FROM
from ..render import CLOSURES, principled_hair_input_rows, scene_schema, schema_choices, schema_default
from ..zoo import PLUGIN_MODEL
from ._common import luminance_weights, blender_version, find_socket, rgb
from .shading_network import AttributeTable, ShadingNetwork, Value

GREY = _core.DEFAULT_SURFACE_COLOR  # Cycles' default surface colour (render/scene.h)
_GREY_DIFFUSE = f"{GREY[0]:g} grey diffuse"
DEFAULT_MATERIAL_NAME = "__default__"

MAX_DEPTH = 64


@functools.cache
def principled_hair_inputs(model: str) -> tuple:
    """(key in scene_desc, socket identifier, kind) of the Principled Hair inputs `model` reads
    (Random apart): the scene schema's rows (plugin/bindings/scene_schema.cpp), so the exporter,
    the renderer and docs/scene_desc.md share one table."""
    return tuple((key, k["socket"], k["socket_kind"]) for key, k in principled_hair_input_rows().items()
                 if model in k["hair_models"].split())


@functools.cache
def cycles_hair_inputs() -> tuple:
    """(key in scene_desc, socket identifier, kind) of the legacy Hair BSDF's inputs: the scene schema's
    cycles_hair rows that name a socket, as principled_hair_inputs reads Principled Hair's."""
    return tuple((k["path"].rsplit(".", 1)[1], k["socket"], k["socket_kind"]) for k in scene_schema()
                 if k["socket"] and "cycles_hair" in k["only_for"].split())


@functools.cache
def cycles_hair_defaults() -> dict:
    """The legacy Hair BSDF node's defaults, for a socket that cannot be read: its table
    (bsdf_core/include/hairbsdf/params/cycles_hair.h), as hairbsdf.zoo reads it."""
    from hairbsdf.zoo import CYCLES_HAIR_DEFAULTS  # lazily, as the scene schema

    return CYCLES_HAIR_DEFAULTS


def _mul(w, f):
    if isinstance(f, tuple):
        return tuple(a * b for a, b in zip(w, f))
    return tuple(a * f for a in w)


class MaterialTranslator:
    """Translates one node tree at a time, a material's (translate) or the world's
    (export_world.export_world): both walk their shaders with `walk`. Warnings go to `report`
    prefixed with the owner ("Material 'Hair'", "World 'World'")."""

    def __init__(self, report, attributes: AttributeTable | None = None):
        self.report = report
        self.owner = ""
        self.attributes = attributes if attributes is not None else AttributeTable()
        self.network = None
        self.pending = []  # (container, key, Value, kind) resolved by network.finish()
        self.per_hit_weights = True  # a Mix Shader Fac may depend on the hit (not for the world: no hit)

    def begin(self, owner: str) -> None:
        """Starts a node tree: warnings name `owner`, its values compile into a fresh network."""
        self.owner = owner
        self.network = ShadingNetwork(self.attributes, self.warn, self._link_source)
        self.pending = []

    # ------------------------------------------------------------------ helpers
    def warn(self, msg: str) -> None:
        self.report.warn(f"{self.owner}: {msg}")

    @staticmethod
    def _link_source(socket, depth=0):
        """(node, output socket) feeding `socket`, following reroutes and muted links;
        None when unlinked."""
        if socket is None or not socket.is_linked or depth > MAX_DEPTH:
            return None
        links = [lk for lk in socket.links if not getattr(lk, "is_muted", False)]
        if not links:
            return None
        link = links[0]
        node, out = link.from_node, link.from_socket
        if node.type == "REROUTE" or node.bl_idname == "NodeReroute":
            return MaterialTranslator._link_source(node.inputs[0], depth + 1)
        return node, out

    def linked(self, node, ident: str, kind: str, container: dict, key: str) -> None:
        """Compiles input `ident` of `node` into `container[key]`: a constant, or a register of
        the material's program when it depends on the hit (resolved in translate())."""
        sock = find_socket(node.inputs, ident)
        if sock is None:
            return
        self.pending.append((container, key, self.network.input(node, sock, kind), kind))

    def value(self, node, ident: str, kind: str, default=None):
        """Input `ident` of `node` for what is read once per render (the world's inputs, the legacy
        Hair BSDF's): a number or tuple when it sits in the constants, else the Value that
        instructions compute (the scene loader folds it). A network that depends on the hit is
        reported and the socket value is used."""
        sock = find_socket(node.inputs, ident)
        if sock is None:
            return default
        v = self.network.input(node, sock, kind)
        if self.network.is_dynamic(v):
            fallback = self._socket_default(sock, kind, default)
            self.warn(f"'{node.name}' > '{sock.name}' varies per hit, which hairbsdf supports only for closure "
                      f"inputs and Mix Shader factors; using the socket value {_fmt(fallback)}")
            return fallback
        constant = self.network.constant_of(v)
        return v if constant is None else constant

    def per_render(self, node, ident: str, kind: str, container: dict, key: str) -> None:
        """`container[key]` from input `ident` of `node` (value): a computed one becomes a register
        of the program (resolved in translate())."""
        v = self.value(node, ident, kind)
        if isinstance(v, Value):
            self.pending.append((container, key, v, kind))
        elif v is not None:
            container[key] = v

    def times(self, a: Value, b: Value) -> Value:
        """a (3 wide) times b (1 or 3 wide): a constant when both are (so a constant weight goes out
        as numbers), else instructions the scene loader folds."""
        ca, cb = self.network.constant_of(a), self.network.constant_of(b)
        if ca is not None and cb is not None:
            return self.network.constant(_mul(ca, cb))
        return self.network.multiply(a, b)

    @staticmethod
    def _socket_default(sock, kind, default):
        dv = getattr(sock, "default_value", None)
        if dv is None:
            return default
        if kind == "float":
            try:
                return float(dv)
            except TypeError:
                return MaterialTranslator._convert(rgb(dv), "color", "float")
        try:
            return rgb(dv)
        except TypeError:
            return (float(dv),) * 3

    @staticmethod
    def _convert(v, src_kind, kind):
        if kind == "float":
            if src_kind == "float":
                return v
            if src_kind == "color":  # Cycles' colour -> float: luminance
                return sum(a * b for a, b in zip(v, luminance_weights()))
            return sum(v) / 3.0  # vector -> float: average
        if src_kind == "float":
            return (v, v, v)
        return tuple(v)

    # ------------------------------------------------------------------ materials
    def translate(self, material) -> dict:
        name = DEFAULT_MATERIAL_NAME if material is None else material.name
        self.begin(f"Material '{name}'")
        out = {"name": name}
        closures = self._closures(material)
        # Each weight is a Value of the network: a constant goes out as numbers, a computed one as a
        # register. A closure of constant weight 0 is left out here; one of computed weight by the loader.
        constants = [self.network.constant_of(c["weight"]) for c in closures]
        out["closures"] = [c for c, w in zip(closures, constants) if w is None or max(w) > 0.0 or min(w) < 0.0]
        self.pending += [(c, "weight", c["weight"], "color") for c in out["closures"]]
        kept = {id(c) for c in out["closures"]} | {id(c.get("inputs")) for c in out["closures"]}
        program = self.network.finish([p for p in self.pending if id(p[0]) in kept])
        if program is not None:
            out["program"] = program
        if any(c.get("type") == "emission" for c in out["closures"]):
            sampling = emission_sampling(material)
            if sampling is not None:  # None: the scene's default
                out["emission_sampling"] = sampling
        return out

    def _closures(self, material) -> list:
        """The material's closures, their weights Values of the network."""
        one = self.network.constant((1.0, 1.0, 1.0))
        if material is None:
            return [_diffuse(one, GREY)]
        nt = material.node_tree if getattr(material, "use_nodes", False) else None
        if nt is None:
            return [_diffuse(one, rgb(material.diffuse_color))]
        output = None
        try:
            output = nt.get_output_node("CYCLES")
        except Exception:  # pragma: no cover - very old API
            output = None
        if output is None:
            # Cycles renders a node material without an active output as black.
            self.warn("no active Material Output node; rendered black")
            return []
        surface = find_socket(output.inputs, "Surface")
        volume = find_socket(output.inputs, "Volume")
        if volume is not None and self._link_source(volume) is not None:
            self.warn("the Volume output is not supported and is ignored")
        disp = find_socket(output.inputs, "Displacement")
        if disp is not None and self._link_source(disp) is not None:
            self.warn("displacement is not supported and is ignored")
        src = self._link_source(surface)
        closures = []
        if src is not None:
            self.walk(src[0], src[1], one, lambda node, weight: self._shader(node, weight, closures))
        return closures

    def program_needs(self) -> tuple:
        """(reads Hair Info > Intercept, attribute names) of the last translated material."""
        if self.network is None:
            return False, set()
        return self.network.uses_intercept, set(self.network.attribute_names)

    def walk(self, node, out_socket, weight, visit, depth=0):
        """Walks the shader nodes feeding `out_socket` of `node`: muted nodes pass through, Mix
        and Add Shader fold into weights, and every other node is handed to `visit(node, weight)`
        (a material's closures, the world's backgrounds). A weight is a Value of the network: a
        constant, or instructions where a Mix Shader's Fac is computed by nodes (then every weight
        below it is)."""
        if depth > MAX_DEPTH:
            self.warn("shader graph too deep; truncated")
            return
        t = node.bl_idname
        if node.mute:
            # A muted node passes its first matching input through (internal links).
            for link in getattr(node, "internal_links", []):
                if link.to_socket == out_socket or link.to_socket.identifier == out_socket.identifier:
                    src = self._link_source(link.from_socket)
                    if src is not None:
                        self.walk(src[0], src[1], weight, visit, depth + 1)
                    return
            return
        if t == "ShaderNodeMixShader":
            sock = find_socket(node.inputs, "Fac")
            fac = self.network.input(node, sock, "float") if sock is not None else self.network.constant((0.5,))
            if not self.per_hit_weights and self.network.is_dynamic(fac):
                fac = self.network.constant((self.value(node, "Fac", "float", 0.5),))  # warned: the socket value
            shaders = [s for s in node.inputs if s.type == "SHADER"]
            constant = self.network.constant_of(fac)
            if constant is None:  # computed (per hit where it depends on the hit): the factors are registers
                factors = self.network.mix_factors(fac)
            else:
                constant = min(max(constant, 0.0), 1.0)  # svm_node_mix_closure clamps
                factors = (self.network.constant((1.0 - constant,)), self.network.constant((constant,)))
            for sock, f in zip(shaders, factors):
                src = self._link_source(sock)
                if src is not None and self.network.constant_of(f) != 0.0:  # a constant 0 adds nothing
                    self.walk(src[0], src[1], self.times(weight, f), visit, depth + 1)
            return
        if t == "ShaderNodeAddShader":
            for sock in (s for s in node.inputs if s.type == "SHADER"):
                src = self._link_source(sock)
                if src is not None:
                    self.walk(src[0], src[1], weight, visit, depth + 1)
            return
        visit(node, weight)

    def _shader(self, node, weight, closures):
        """A material's closure node (walk's visit)."""
        t = node.bl_idname
        if t == "ShaderNodeBsdfHairPrincipled":
            closures.append(self._principled_hair(node, weight))
            return
        if t == "ShaderNodeBsdfDiffuse":
            rough = self.value(node, "Roughness", "float", 0.0)
            if isinstance(rough, Value):
                self.warn(f"'{node.name}': Roughness is computed by nodes; Oren-Nayar roughness is not supported, "
                          "rendered as Lambert")
            elif rough > 0.0:
                self.warn(f"'{node.name}': Oren-Nayar roughness {rough:g} is not supported; rendered as Lambert")
            closures.append(self._linked_diffuse(node, "Color", weight))
            return
        if t == "ShaderNodeBsdfPrincipled":
            self.warn(f"'{node.name}' (Principled BSDF) is rendered as a diffuse of its Base Color")
            closures.append(self._linked_diffuse(node, "Base Color", weight))
            return
        if t == "ShaderNodeEmission":
            c = {"type": "emission", "weight": weight, "color": (1.0, 1.0, 1.0), "strength": 1.0}
            self.linked(node, "Color", "color", c, "color")
            self.linked(node, "Strength", "float", c, "strength")
            closures.append(c)
            return
        if t == "ShaderNodeBsdfHair":
            closures.append(self._hair_bsdf(node, weight))
            return
        self.warn(f"'{node.name}' ({_label(node)}) is not supported; rendered as {_GREY_DIFFUSE}")
        closures.append(_diffuse(weight, GREY))

    def _linked_diffuse(self, node, ident, weight) -> dict:
        c = _diffuse(weight, GREY)
        self.linked(node, ident, "color", c, "color")
        return c

    def _principled_hair(self, node, weight) -> dict:
        # Blender < 4.0 has no model enum: its node is the schema's default model (Chiang).
        model = getattr(node, "model", None) or schema_default(CLOSURES + ".model", "principled_hair")
        if model not in schema_choices(CLOSURES + ".model"):
            self.warn(f"'{node.name}': the {model.title()} model is not supported; "
                      f"rendered as {_GREY_DIFFUSE}")
            return _diffuse(weight, GREY)
        inputs = {}
        for key, ident, kind in principled_hair_inputs(model):
            self.linked(node, ident, kind, inputs, key)
        sock = find_socket(node.inputs, "Random")
        src = self._link_source(sock)
        if sock is None or src is None or (src[0].bl_idname == "ShaderNodeHairInfo" and not src[0].mute
                                           and src[1].identifier == "Random"):
            inputs["random"] = None  # per-curve Hair Info > Random (docs/cycles.md §2.2)
        else:
            self.linked(node, "Random", "float", inputs, "random")
        return {"type": "principled_hair", "weight": weight, "model": model,
                "parametrization": node.parametrization, "inputs": inputs}

    def _hair_bsdf(self, node, weight) -> dict:
        """The legacy Hair BSDF node: Cycles' closure with the node's sockets (Offset in radians)."""
        tangent = find_socket(node.inputs, "Tangent")
        if tangent is not None and tangent.is_linked:
            self.warn(f"'{node.name}' > 'Tangent' is linked, which hairbsdf does not evaluate; "
                      "using the curve tangent (the unlinked default)")
        defaults = cycles_hair_defaults()
        c = {"type": "cycles_hair", "weight": weight, "component": node.component.upper()}
        for key, ident, kind in cycles_hair_inputs():
            c[key] = defaults[key]
            self.per_render(node, ident, kind, c, key)
        return c


def emission_sampling(material) -> str | None:
    """Which sides of the material's emissive triangles Cycles light-samples (docs/scene_desc.md):
    Blender >= 4.0's Settings > Emission Sampling ("AUTO" is resolved by the engine, by Cycles' rule),
    Blender 3.x's Settings > Multiple Importance (on: both sides, there is no threshold).
    None when the setting is missing (the scene key is then left out: its default applies)."""
    settings = material.cycles  # the Cycles add-on's material settings (export requires the add-on)
    if blender_version() >= EMISSION_SAMPLING_FROM:
        sampling = getattr(settings, "emission_sampling", None)
        return None if sampling is None else str(sampling)
    return "FRONT_BACK" if getattr(settings, "sample_as_light", True) else "NONE"


def _label(node):
    return getattr(node, "bl_label", "") or node.bl_idname


def _diffuse(weight, color):
    return {"type": "diffuse", "weight": weight, "color": tuple(color)}


def _fmt(v):
    if isinstance(v, tuple):
        return "(" + ", ".join(f"{c:g}" for c in v) + ")"
    if isinstance(v, float):
        return f"{v:g}"
    return repr(v)


class MaterialTable:
    """The scene's material list; materials are translated once, on first use."""

    def __init__(self, report):
        self.attributes = AttributeTable()  # curve attributes the programs read, scene-wide
        self.translator = MaterialTranslator(report, self.attributes)
        self.materials: list[dict] = []
        self.needs: list[tuple] = []  # per material: (reads Intercept, attribute names)
        self._index: dict = {}

    def index(self, material) -> int:
        key = None if material is None else material.name_full
        idx = self._index.get(key)
        if idx is None:
            idx = len(self.materials)
            translated = self.translator.translate(material)
            # the model override step: before the hair exporter asks uses_huang
            translated["closures"] = override_closures(material, translated["closures"], self.translator.warn)
            self.materials.append(translated)
            self.needs.append(self.translator.program_needs() if "program" in self.materials[-1] else (False, set()))
            self._index[key] = idx
        return idx

    def uses_huang(self, index: int) -> bool:
        """Whether scene material `index` has a Principled Hair closure with the Huang model."""
        return any(c.get("model") == "HUANG" for c in self.materials[index].get("closures", ()))

    def slot_indices(self, obj) -> list:
        """Scene material index of each material slot of an evaluated object (at least one
        entry: the default material when the object has no slots)."""
        slots = [s.material for s in obj.material_slots]
        if not slots:
            slots = [None]
        return [self.index(m) for m in slots]


# ---------------------------------------------------------------------------- the model override step
# A material's hair model override (its `hairbsdf` settings, model_override.py) replaces its
# Principled Hair closures by a hair_model closure: the step after translating it
# (MaterialTable.index).


def override_closures(material, closures: list, warn) -> list:
    """`closures` (the material's exported closures) with each principled_hair closure
    replaced by the override's hair_model closure of the same weight."""
    s = getattr(material, "hairbsdf", None) if material is not None else None
    if s is None or s.override == "NONE":
        return closures
    hair = [c for c in closures if c.get("type") == "principled_hair"]
    if not hair:
        warn(f"hair model override '{s.override}' set, but the material has no Principled Hair closure")
        return closures
    model = {"type": "hair_model", "model": s.override, "params": override_params(s)}
    if s.override == PLUGIN_MODEL:
        path = override_plugin_path(s)
        if not path:
            warn(f"hair model override '{PLUGIN_MODEL}' has no plugin path; the Principled Hair closures are rendered")
            return closures
        model["path"] = path
    return [dict(model, weight=c["weight"]) if c.get("type") == "principled_hair" else c for c in closures]


def override_params(settings) -> dict:
    """The parameters as the `hair_model` closure's `params` (optional ones only when used)."""
    return {p.name: p.current() for p in settings.params if not p.optional or p.use}


def override_plugin_path(settings) -> str:
    import bpy  # the settings are Blender data: only called inside Blender

    path = settings.plugin_path
    return os.path.abspath(bpy.path.abspath(path)) if path else ""
