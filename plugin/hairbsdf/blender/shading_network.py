"""The shading-network compiler: the node tree feeding a material's closure inputs -> a small
program for the renderer's shading VM (bsdf_core/include/hairbsdf/render/shading_vm.h,
docs/shading_vm.md).

Each closure input is compiled by walking the links backwards from its socket; every node
output becomes registers written by one or a few VM instructions. `finish()` writes each closure
input as a number (a socket value, a Value / RGB node) or a register of the program, which holds
every instruction: the scene loader folds what does not depend on the hit, once, in C++
(render/scene.cpp; a material whose inputs all fold has no program there: the renderer's fast
path). The exporter's own arithmetic on computed values (closure weights times Mix Shader factors,
the world's colour x strength sums) is emitted as instructions too (`multiply`, `add`,
`mix_factors`): nothing here runs the VM. Unsupported nodes are reported with a warning naming them, and the
socket's own default value is used, as the exporter always did.

Supported: Value, RGB, Hair Info (Random, Intercept, Length, Is Strand), Attribute (Geometry),
Math, Map Range (float), Clamp, ColorRamp, Mix (float, vector, colour) and legacy MixRGB,
Separate / Combine RGB, XYZ and Color (RGB mode), Invert, Gamma, Brightness/Contrast, Image
Texture (flat projection) on curve UVs from Texture Coordinate > UV or a UV Map node, Mapping
(Point / Texture / Vector, unlinked Location / Rotation / Scale), reroutes
and muted nodes (their internal links). Socket conversions follow Cycles: colour -> float is the
luminance, vector -> float the average, float -> colour / vector (f, f, f).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ._common import luminance_weights, mapping_matrix, rgb


@functools.cache
def vm_instruction_set() -> dict:
    """The shading VM's opcodes, argument counts and enums under Blender's identifiers
    ({"ops", "argument_counts", "operands" (the register blocks each op reads and writes),
    "math_types", "map_range_types", "clamp_types", "ramp_interpolations", "mix_blends", "mix_flags",
    "hair_info_outputs", "image_interpolations", "image_extensions", "image_flags"}), as
    render/shading_vm.h declares them. Read from the renderer module on first use (it loads
    Embree and TBB)."""
    from hairbsdf import _render
    return _render.shading_vm_instruction_set()


def _vm(table: str) -> dict:
    return vm_instruction_set()[table]


# Curve attribute names that stand for a UV map: UV_ATTRIBUTE is the default one (Texture
# Coordinate > UV, a UV Map node with no map named), UV_ATTRIBUTE + name a named map. The hair
# exporter resolves them per object (export_hair.uv_rgba).
UV_ATTRIBUTE = "<uv>"
RAMP_TABLE_SIZE = 256  # Cycles bakes a ColorRamp into 256 RGBA entries (RAMP_TABLE_SIZE)
MAX_DEPTH = 64


@dataclass(frozen=True)
class Reg:
    """A register: kind 'k' (constant slot) or 't' (temporary, placed after the constants)."""
    kind: str
    index: int


@dataclass(frozen=True)
class Value:
    """A compiled socket value: `width` (1 float, 3 colour / vector) registers from `reg`."""
    reg: Reg
    width: int


@dataclass
class _Instruction:
    words: list          # opcode, then ints and Regs
    reads: list          # (word position, width)
    writes: list         # (word position, width)
    dynamic: bool = False


def operand_blocks(op: str, args) -> tuple:
    """(reads, writes) of instruction `op` with arguments `args` (after the opcode): lists of
    (argument index, width), from the VM's declaration of its register blocks."""
    reads, writes = [], []
    for o in _vm("operands")[op]:
        width = o["width"] + (o["width_per_arg"] * int(args[o["width_arg"]]) if o["width_arg"] >= 0 else 0)
        (writes if o["write"] else reads).append((o["arg"], width))
    return reads, writes


def _width(socket_type: str) -> int:
    return 3 if socket_type in ("RGBA", "VECTOR") else 1


def _kind_of(socket_type: str) -> str:
    return {"RGBA": "color", "VECTOR": "vector"}.get(socket_type, "float")


class ImageTable:
    """Scene-wide list of the images programs sample (index = VM image index), read once each."""

    def __init__(self):
        self.images: list[dict] = []     # {"name", "pixels" (H, W, 4) float32}
        self.associated: list[bool] = []
        self.srgb_encoded: list[bool] = []
        self._index: dict = {}

    def index(self, image, warn):
        """The VM index of a bpy Image, or None when it has no pixels (warned)."""
        key = image.name_full
        if key not in self._index:
            from .images import read_image_rgba
            pixels, associated, encoded = read_image_rgba(image, warn)
            if pixels is None:
                self._index[key] = None
            else:
                self._index[key] = len(self.images)
                self.images.append({"name": image.name_full, "pixels": np.ascontiguousarray(pixels, np.float32)})
                self.associated.append(associated)
                self.srgb_encoded.append(encoded)
        return self._index[key]


class AttributeTable:
    """Scene-wide list of the named curve attributes programs read (index = VM attribute index),
    and the images they sample (`images`: a table of its own, or one shared with the scene's materials)."""

    def __init__(self, images: ImageTable | None = None):
        self.names: list[str] = []
        self.images = images if images is not None else ImageTable()

    def index(self, name: str) -> int:
        if name not in self.names:
            self.names.append(name)
        return self.names.index(name)


class ShadingNetwork:
    """One material's program under construction. `warn(msg)` reports a problem."""

    def __init__(self, attributes: AttributeTable, warn, link_source):
        self.attributes = attributes
        self.warn = warn
        self.link_source = link_source  # (socket) -> (node, output socket) or None
        self.constants: list[float] = []
        self._constant_slots: dict = {}
        self.instructions: list[_Instruction] = []
        self.temps = 0
        self._outputs: dict = {}      # (node pointer, output identifier) -> Value
        self._dynamic: set = set()    # temp indices written by hit-dependent instructions
        self.uses_intercept = False
        self.attribute_names: set = set()

    # ------------------------------------------------------------------ registers
    def constant(self, values) -> Value:
        values = tuple(float(np.float32(v)) for v in values)
        slot = self._constant_slots.get(values)
        if slot is None:
            slot = len(self.constants)
            self.constants.extend(values)
            self._constant_slots[values] = slot
        return Value(Reg("k", slot), len(values))

    def _temp(self, n: int) -> Reg:
        reg = Reg("t", self.temps)
        self.temps += n
        return reg

    def _emit(self, op: str, args, dynamic=False):
        """op: the instruction's name in vm_instruction_set()["ops"]; args: after the opcode, a Reg
        where the VM declares a register block, an int elsewhere."""
        if len(args) != _vm("argument_counts")[op]:
            raise AssertionError(f"{op}: {len(args)} arguments, the VM takes {_vm('argument_counts')[op]}")
        reads, writes = operand_blocks(op, args)
        registers = {i for i, _ in reads + writes}
        for i, a in enumerate(args):
            if isinstance(a, Reg) != (i in registers):
                raise AssertionError(f"{op}: argument {i} is {a!r}; the VM declares "
                                     f"{'a register' if i in registers else 'a number'} there")
        ins = _Instruction([_vm("ops")[op]] + list(args), [(i + 1, w) for i, w in reads], [(i + 1, w) for i, w in writes])
        ins.dynamic = dynamic or any(self._is_dynamic(ins.words[p], w) for p, w in ins.reads)
        if ins.dynamic:
            for p, w in ins.writes:
                self._dynamic.update(range(ins.words[p].index, ins.words[p].index + w))
        self.instructions.append(ins)

    def _is_dynamic(self, reg, width=1) -> bool:
        return reg.kind == "t" and any(i in self._dynamic for i in range(reg.index, reg.index + width))

    def is_dynamic(self, value: Value) -> bool:
        return self._is_dynamic(value.reg, value.width)

    def component(self, value: Value, i: int) -> Value:
        return Value(Reg(value.reg.kind, value.reg.index + i), 1)

    # ------------------------------------------------------------------ conversions
    def convert(self, value: Value, src_type: str, kind: str) -> Value:
        """Cycles' implicit socket conversion from an output of `src_type` to `kind`."""
        if kind == "float":
            if value.width == 1:
                return value
            out = self._temp(1)
            if src_type == "RGBA":
                weights = self.constant(luminance_weights())
                self._emit("LUMINANCE", [out, value.reg, weights.reg])
            else:
                self._emit("AVERAGE", [out, value.reg])
            return Value(out, 1)
        if value.width == 3:
            return value
        return self.gather([value, value, value])

    def gather(self, parts) -> Value:
        """Three single floats -> one 3-wide value (constant when all three are)."""
        if all(p.reg.kind == "k" for p in parts):
            return self.constant([self.constants[p.reg.index] for p in parts])
        out = self._temp(3)
        for i, p in enumerate(parts):
            self._emit("COPY", [Reg("t", out.index + i), p.reg])
        return Value(out, 3)

    # ------------------------------------------------------------------ arithmetic on colours
    # For values the exporter combines (closure weights times Mix Shader factors, the world's
    # colour x strength sums) when nodes compute one of them: instructions, folded by the loader.
    def multiply(self, a: Value, b: Value) -> Value:
        """a (3 wide) times b (1 or 3 wide), per component, in float as the VM computes."""
        return self._per_component("MULTIPLY", a, b)

    def add(self, a: Value, b: Value) -> Value:
        """a + b, both 3 wide."""
        return self._per_component("ADD", a, b)

    def _per_component(self, operation: str, a: Value, b: Value) -> Value:
        out = self._temp(3)
        unused = self.constant((0.0,))
        for i in range(3):
            bi = b if b.width == 1 else self.component(b, i)
            self._emit("MATH", [_vm("math_types")[operation], 0, Reg("t", out.index + i), self.component(a, i).reg,
                                bi.reg, unused.reg])
        return Value(out, 3)

    def mix_factors(self, fac: Value) -> tuple:
        """(1 - t, t) with t = Fac clamped to [0, 1]: the weights of a Mix Shader's two inputs
        (Cycles' svm_node_mix_closure)."""
        t = self._temp(1)
        self._emit("CLAMP", [_vm("clamp_types")["MINMAX"], t, fac.reg, self.constant((0.0,)).reg,
                             self.constant((1.0,)).reg])
        rest = self._temp(1)
        self._emit("MATH", [_vm("math_types")["SUBTRACT"], 0, rest, self.constant((1.0,)).reg, t,
                            self.constant((0.0,)).reg])
        return Value(rest, 1), Value(t, 1)

    def constant_of(self, value: Value):
        """A value held in the constants (a socket value, a Value / RGB node) as a number or a
        tuple; None when instructions compute it (the loader folds those)."""
        if value.reg.kind != "k":
            return None
        v = self.constants[value.reg.index:value.reg.index + value.width]
        return v[0] if value.width == 1 else tuple(v)

    # ------------------------------------------------------------------ sockets
    def input(self, node, socket, kind: str, depth=0) -> Value:
        """The value reaching input `socket` of `node`, as `kind` ('float' | 'color' | 'vector')."""
        default = self.socket_default(socket, kind)
        src = self.link_source(socket)
        if src is None or not getattr(socket, "enabled", True):
            return default
        snode, sout = src
        value = self.output(snode, sout, depth + 1, node, socket)
        if value is None:
            return default
        return self.convert(value, sout.type, kind)

    def socket_default(self, socket, kind: str) -> Value:
        dv = getattr(socket, "default_value", None)
        if dv is None:
            return self.constant((0.0,) if kind == "float" else (0.0, 0.0, 0.0))
        try:
            f = float(dv)
            return self.constant((f,) if kind == "float" else (f, f, f))
        except TypeError:
            c = rgb(dv)
            if kind == "float":
                if getattr(socket, "type", "") == "VECTOR":
                    return self.constant((sum(c) / 3.0,))
                return self.constant((sum(a * b for a, b in zip(c, luminance_weights())),))
            return self.constant(c)

    def output(self, node, out, depth, consumer, consumer_socket):
        """The Value of output `out` of `node`, or None (unsupported: warned)."""
        key = (node.as_pointer(), out.identifier)
        if key in self._outputs:
            return self._outputs[key]
        if depth > MAX_DEPTH:
            self.warn(f"node network too deep at '{node.name}'; using the socket value")
            return None
        if node.mute:
            value = self._muted(node, out, depth)
        else:
            compile_node = _NODES.get(node.bl_idname)
            value = compile_node(self, node, out, depth) if compile_node else None
            if compile_node is None or value is _UNSUPPORTED:
                detail = "" if compile_node is None else f" (its {_setting(node)})"
                self.warn(f"'{consumer.name}' > '{consumer_socket.name}' is driven by '{node.name}' "
                          f"({_label(node)} > {out.name}){detail}, which hairbsdf does not evaluate; "
                          "using the socket value")
                value = None
        self._outputs[key] = value
        return value

    def _muted(self, node, out, depth):
        for link in getattr(node, "internal_links", []):
            if link.to_socket.identifier == out.identifier:
                return self.input(node, link.from_socket, _kind_of(out.type), depth)
        return self.constant((0.0,) * _width(out.type))

    # ------------------------------------------------------------------ program
    def finish(self, inputs) -> dict | None:
        """Resolves `inputs`: a list of (container, key, Value, kind). A value held in the
        constants (a socket value, a Value / RGB node) is written into the container as a number /
        tuple, one computed by instructions as {"register": slot}. Returns the program dict of
        docs/scene_desc.md (every instruction, unfolded), or None when no input reads a register.
        Folding is the scene loader's (render/scene.cpp, docs/shading_vm.md): it runs the program
        once, turns the inputs that do not depend on the hit into constants and keeps the rest."""
        n_const = len(self.constants)
        linked = False
        for container, key, value, kind in inputs:
            if value.reg.kind == "k":
                container[key] = self.constant_of(value)
            else:
                container[key] = {"register": n_const + value.reg.index}
                linked = True
        if not linked:
            return None
        return self._program()

    def _program(self) -> dict:
        n_const = len(self.constants)
        code = []
        for ins in self.instructions:
            code.extend(n_const + w.index if isinstance(w, Reg) and w.kind == "t" else
                        w.index if isinstance(w, Reg) else int(w) for w in ins.words)
        return {"code": np.asarray(code, np.int32), "constants": np.asarray(self.constants, np.float32),
                "registers": n_const + self.temps}


_UNSUPPORTED = object()


def _label(node):
    return getattr(node, "bl_label", "") or node.bl_idname


def _setting(node):
    if node.bl_idname == "ShaderNodeTexImage":
        source = getattr(node.image, "source", "none") if node.image is not None else "none"
        return (f"projection {node.projection}, interpolation {node.interpolation}, extension {node.extension}, "
                f"image source {source}")
    if node.bl_idname == "ShaderNodeMapping":
        linked = [s.name for s in node.inputs if s.name != "Vector" and s.is_linked]
        return f"vector_type {node.vector_type}" + (f", linked {' / '.join(linked)}" if linked else "")
    for prop in ("data_type", "mode", "attribute_type", "operation"):
        if hasattr(node, prop):
            return f"{prop} {getattr(node, prop)}"
    return "settings"


def _sock(node, identifier):
    for s in node.inputs:
        if s.identifier == identifier:
            return s
    return None


def _in(net, node, identifier, kind, depth):
    return net.input(node, _sock(node, identifier), kind, depth)


# ---------------------------------------------------------------------------- nodes
# Each returns the Value of output `out`, or _UNSUPPORTED.

def _value_node(net, node, out, depth):
    return net.constant((out.default_value,))


def _rgb_node(net, node, out, depth):
    return net.constant(rgb(out.default_value))


def _hair_info(net, node, out, depth):
    which = _vm("hair_info_outputs").get(out.identifier)
    if which is None:
        return _UNSUPPORTED
    if which == _vm("hair_info_outputs")["Intercept"]:
        net.uses_intercept = True
    reg = net._temp(1)
    net._emit("HAIR_INFO", [which, reg], dynamic=True)
    return Value(reg, 1)


def _attribute_block(net, name):
    """The 5 registers (RGB, Fac, Alpha) of curve attribute `name`, one instruction per program."""
    key = ("__attribute__", name)
    block = net._outputs.get(key)
    if block is None:
        index = net.attributes.index(name)
        net.attribute_names.add(name)
        block = Value(net._temp(5), 5)
        net._emit("ATTRIBUTE", [index, block.reg], dynamic=True)
        net._outputs[key] = block
    return block


def _attribute(net, node, out, depth):
    if getattr(node, "attribute_type", "GEOMETRY") != "GEOMETRY" or not node.attribute_name:
        return _UNSUPPORTED
    block = _attribute_block(net, node.attribute_name)
    offset, width = {"Color": (0, 3), "Vector": (0, 3), "Fac": (3, 1), "Alpha": (4, 1)}[out.identifier]
    return Value(Reg("t", block.reg.index + offset), width)


def _uv(net, map_name=""):
    """The UV (u, v, 0) of the strand: Cycles' curve UV (docs/shading_vm.md)."""
    return Value(_attribute_block(net, UV_ATTRIBUTE + map_name).reg, 3)


def _tex_coord(net, node, out, depth):
    if out.identifier != "UV" or getattr(node, "from_instancer", False):
        return _UNSUPPORTED
    return _uv(net)


def _uv_map(net, node, out, depth):
    if getattr(node, "from_instancer", False):
        return _UNSUPPORTED
    return _uv(net, node.uv_map)


def _mapping(net, node, out, depth):
    """Mapping (Point, Texture, Vector) with unlinked Location / Rotation / Scale: the affine map
    Blender's node applies, as three multiply-adds per component (float32 constants)."""
    if node.vector_type == "NORMAL":  # normalised after the map: not an affine map
        return _UNSUPPORTED
    values = {}
    for name, default in (("Location", (0.0, 0.0, 0.0)), ("Rotation", (0.0, 0.0, 0.0)), ("Scale", (1.0, 1.0, 1.0))):
        sock = _sock(node, name)
        if sock is None or not getattr(sock, "enabled", True):
            values[name] = default
            continue
        if net.link_source(sock) is not None:
            return _UNSUPPORTED
        values[name] = tuple(float(v) for v in sock.default_value)
    m = mapping_matrix(node.vector_type, values["Location"], values["Rotation"], values["Scale"])
    vec = _in(net, node, "Vector", "vector", depth)
    parts = []
    for i in range(3):
        acc = net.constant((m[i, 3],))
        for j in (2, 1, 0):
            reg = net._temp(1)
            net._emit("MATH", [_vm("math_types")["MULTIPLY_ADD"], 0, reg, net.component(vec, j).reg,
                                net.constant((m[i, j],)).reg, acc.reg])
            acc = Value(reg, 1)
        parts.append(acc)
    return net.gather(parts)


def _image_texture(net, node, out, depth):
    if node.projection != "FLAT" or out.identifier not in ("Color", "Alpha"):
        return _UNSUPPORTED
    image = node.image
    if image is None:
        # Cycles' missing-texture colour (magenta, alpha 1)
        net.warn(f"'{node.name}' has no image; like Cycles, it reads magenta")
        return net.constant((1.0, 0.0, 1.0) if out.identifier == "Color" else (1.0,))
    if getattr(image, "source", "FILE") not in ("FILE", "GENERATED") or node.interpolation not in _vm("image_interpolations") \
            or node.extension not in _vm("image_extensions"):
        return _UNSUPPORTED
    key = (node.as_pointer(), "__image__")
    block = net._outputs.get(key)
    if block is None:
        index = net.attributes.images.index(image, net.warn)
        if index is None:  # no pixels (warned): Cycles' missing-texture magenta, alpha 1
            return net.constant((1.0, 0.0, 1.0) if out.identifier == "Color" else (1.0,))
        src = net.link_source(_sock(node, "Vector"))
        vector = _in(net, node, "Vector", "vector", depth) if src is not None else _uv(net)
        # Cycles divides by alpha only when the Alpha output is used and alpha was associated.
        alpha_used = any(o.identifier == "Alpha" and o.is_linked for o in node.outputs)
        flags = _vm("image_flags")["UNASSOCIATE_ALPHA"] if alpha_used and net.attributes.images.associated[index] else 0
        if net.attributes.images.srgb_encoded[index]:  # sRGB: decoded after the lookup, as Cycles
            flags |= _vm("image_flags")["SRGB_DECODE"]
        block = Value(net._temp(4), 4)
        net._emit("IMAGE_TEXTURE", [index, _vm("image_interpolations")[node.interpolation],
                                     _vm("image_extensions")[node.extension], flags, block.reg, vector.reg])
        net._outputs[key] = block
    if out.identifier == "Alpha":
        return Value(Reg("t", block.reg.index + 3), 1)
    return Value(block.reg, 3)


def _math(net, node, out, depth):
    op = _vm("math_types").get(node.operation)
    if op is None:
        return _UNSUPPORTED
    a, b, c = (net.input(node, s, "float", depth) for s in list(node.inputs)[:3])
    reg = net._temp(1)
    net._emit("MATH", [op, int(node.use_clamp), reg, a.reg, b.reg, c.reg])
    return Value(reg, 1)


def _map_range(net, node, out, depth):
    if getattr(node, "data_type", "FLOAT") != "FLOAT" or out.identifier != "Result":
        return _UNSUPPORTED
    kind = _vm("map_range_types")[node.interpolation_type]
    ins = [_in(net, node, name, "float", depth) for name in ("Value", "From Min", "From Max", "To Min", "To Max", "Steps")]
    reg = net._temp(1)
    net._emit("MAP_RANGE", [kind, int(node.clamp), reg] + [v.reg for v in ins])
    return Value(reg, 1)


def _clamp(net, node, out, depth):
    ins = [_in(net, node, name, "float", depth) for name in ("Value", "Min", "Max")]
    reg = net._temp(1)
    net._emit("CLAMP", [_vm("clamp_types")[node.clamp_type], reg] + [v.reg for v in ins])
    return Value(reg, 1)


def _color_ramp(net, node, out, depth):
    ramp = node.color_ramp
    fac = _in(net, node, "Fac", "float", depth)
    key = (node.as_pointer(), "__ramp__")
    block = net._outputs.get(key)
    if block is None:
        # The table Cycles bakes: Blender's own ColorRamp evaluation at i / 255 (every
        # interpolation and colour mode), looked up linearly unless the ramp is Constant.
        table = []
        for i in range(RAMP_TABLE_SIZE):
            table.extend(ramp.evaluate(i / (RAMP_TABLE_SIZE - 1)))
        tab = net.constant(table)
        block = Value(net._temp(4), 4)
        net._emit("COLOR_RAMP", [_vm("ramp_interpolations")[ramp.interpolation], tab.reg, RAMP_TABLE_SIZE,
                                  block.reg, Reg("t", block.reg.index + 3), fac.reg])
        net._outputs[key] = block
    if out.identifier == "Alpha":
        return Value(Reg("t", block.reg.index + 3), 1)
    return Value(block.reg, 3)


def _mix_color(net, blend, flags, fac, a, b):
    reg = net._temp(3)
    net._emit("MIX_COLOR", [_vm("mix_blends")[blend], flags, reg, fac.reg, a.reg, b.reg])
    return Value(reg, 3)


def _mix_rgb(net, node, out, depth):
    if node.blend_type not in _vm("mix_blends"):
        return _UNSUPPORTED
    fac = _in(net, node, "Fac", "float", depth)
    a = _in(net, node, "Color1", "color", depth)
    b = _in(net, node, "Color2", "color", depth)
    flags = _vm("mix_flags")["CLAMP_FACTOR"] | (_vm("mix_flags")["CLAMP_RESULT"] if node.use_clamp else 0)
    return _mix_color(net, node.blend_type, flags, fac, a, b)  # factor always clamped


def _mix(net, node, out, depth):
    dt = node.data_type
    if dt == "RGBA":
        if node.blend_type not in _vm("mix_blends"):
            return _UNSUPPORTED
        fac = _in(net, node, "Factor_Float", "float", depth)
        a = _in(net, node, "A_Color", "color", depth)
        b = _in(net, node, "B_Color", "color", depth)
        flags = ((_vm("mix_flags")["CLAMP_FACTOR"] if node.clamp_factor else 0)
                 | (_vm("mix_flags")["CLAMP_RESULT"] if node.clamp_result else 0))
        return _mix_color(net, node.blend_type, flags, fac, a, b)
    if dt == "FLOAT":
        fac = _in(net, node, "Factor_Float", "float", depth)
        a = _in(net, node, "A_Float", "float", depth)
        b = _in(net, node, "B_Float", "float", depth)
        reg = net._temp(1)
        net._emit("MIX_FLOAT", [int(node.clamp_factor), reg, fac.reg, a.reg, b.reg])
        return Value(reg, 1)
    if dt == "VECTOR":
        non_uniform = node.factor_mode == "NON_UNIFORM"
        fac = _in(net, node, "Factor_Vector" if non_uniform else "Factor_Float", "vector" if non_uniform else "float",
                  depth)
        a = _in(net, node, "A_Vector", "vector", depth)
        b = _in(net, node, "B_Vector", "vector", depth)
        reg = net._temp(3)
        net._emit("MIX_VECTOR", [int(non_uniform), int(node.clamp_factor), reg, fac.reg, a.reg, b.reg])
        return Value(reg, 3)
    return _UNSUPPORTED


def _separate(input_identifier, kind):
    def compile_separate(net, node, out, depth):
        if getattr(node, "mode", "RGB") != "RGB":
            return _UNSUPPORTED
        v = _in(net, node, input_identifier, kind, depth)
        index = [o.identifier for o in node.outputs].index(out.identifier)
        return net.component(v, index)
    return compile_separate


def _combine(input_identifiers):
    def compile_combine(net, node, out, depth):
        if getattr(node, "mode", "RGB") != "RGB":
            return _UNSUPPORTED
        return net.gather([_in(net, node, name, "float", depth) for name in input_identifiers])
    return compile_combine


def _invert(net, node, out, depth):
    fac = _in(net, node, "Fac", "float", depth)
    color = _in(net, node, "Color", "color", depth)
    reg = net._temp(3)
    net._emit("INVERT", [reg, fac.reg, color.reg])
    return Value(reg, 3)


def _gamma(net, node, out, depth):
    color = _in(net, node, "Color", "color", depth)
    gamma = _in(net, node, "Gamma", "float", depth)
    reg = net._temp(3)
    net._emit("GAMMA", [reg, color.reg, gamma.reg])
    return Value(reg, 3)


def _bright_contrast(net, node, out, depth):
    color = _in(net, node, "Color", "color", depth)
    bright = _in(net, node, "Bright", "float", depth)
    contrast = _in(net, node, "Contrast", "float", depth)
    reg = net._temp(3)
    net._emit("BRIGHT_CONTRAST", [reg, color.reg, bright.reg, contrast.reg])
    return Value(reg, 3)


_NODES = {
    "ShaderNodeValue": _value_node,
    "ShaderNodeRGB": _rgb_node,
    "ShaderNodeHairInfo": _hair_info,
    "ShaderNodeAttribute": _attribute,
    "ShaderNodeTexCoord": _tex_coord,
    "ShaderNodeUVMap": _uv_map,
    "ShaderNodeTexImage": _image_texture,
    "ShaderNodeMapping": _mapping,
    "ShaderNodeMath": _math,
    "ShaderNodeMapRange": _map_range,
    "ShaderNodeClamp": _clamp,
    "ShaderNodeValToRGB": _color_ramp,
    "ShaderNodeMixRGB": _mix_rgb,
    "ShaderNodeMix": _mix,
    "ShaderNodeSeparateRGB": _separate("Image", "color"),
    "ShaderNodeSeparateXYZ": _separate("Vector", "vector"),
    "ShaderNodeSeparateColor": _separate("Color", "color"),
    "ShaderNodeCombineRGB": _combine(("R", "G", "B")),
    "ShaderNodeCombineXYZ": _combine(("X", "Y", "Z")),
    "ShaderNodeCombineColor": _combine(("Red", "Green", "Blue")),
    "ShaderNodeInvert": _invert,
    "ShaderNodeGamma": _gamma,
    "ShaderNodeBrightContrast": _bright_contrast,
}
