"""Shading programs through the renderer (docs/shading_vm.md), without Blender: hand-written
programs on an Emission colour of straight strands seen at the pixel centres, so each pixel is
the program's value at one hit. Checks the hit context (intercept and point attributes linear in
the segment's u, curve attributes, Hair Info > Length and Random), the register links of the
closures, hair inputs from registers, and the handling of invalid programs."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf import _render
from hairbsdf.render import render

_OPS = _render.shading_vm_instruction_set()["ops"]  # declared once, in render/shading_vm.h
HAIR_INFO, COPY, ATTRIBUTE, MATH, IMAGE_TEXTURE = (_OPS[k] for k in ("HAIR_INFO", "COPY", "ATTRIBUTE", "MATH",
                                                                     "IMAGE_TEXTURE"))
N_KEYS = 9  # keys at x = -1, -0.75, ..., 1


def _camera(width):
    """Orthographic, looking along +y at the z = 0 plane, 2 units wide."""
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = (1, 0, 0), (0, 0, 1), (0, -1, 0), (0, -3, 0)
    return {"type": "ORTHO", "matrix_world": m, "resolution": (width, 8), "sensor_fit": "HORIZONTAL",
            "ortho_scale": 2.0, "clip_start": 0.01, "clip_end": 100.0}


def _scene(program, color, width=200, curves_extra=None, strength=1.0):
    pts = np.zeros((N_KEYS, 4), np.float32)
    pts[:, 0] = np.linspace(-1.0, 1.0, N_KEYS)
    pts[:, 3] = 0.1
    curves = {"points": pts, "curve_offsets": np.array([0, N_KEYS], np.int32),
              "curve_random": np.array([0.375], np.float32), "curve_material": np.array([0], np.int32),
              "curve_intercept_total": np.array([2.5], np.float32)}
    curves.update(curves_extra or {})
    material = {"name": "emit", "closures": [{"type": "emission", "color": color, "strength": strength}]}
    if program is not None:
        material["program"] = program
    return {"curves": curves, "materials": [material], "camera": _camera(width),
            "integrator": {"samples": 1, "max_bounces": 0, "filter_type": "BLACKMAN_HARRIS", "filter_width": 1e-4,
                           "film_transparent": True}}


def _program(code, constants=(), registers=3):
    return {"code": np.asarray(code, np.int32), "constants": np.asarray(constants, np.float32),
            "registers": registers}


def _middle_row(out, width=200):
    row = out["combined"][4]
    x = -1.0 + (np.arange(width) + 0.5) * 2.0 / width
    # interior segments only: there uniform Catmull-Rom through evenly spaced keys is linear in u
    inner = np.abs(x) < 0.74
    return x[inner], row[inner]


def test_intercept_is_linear_in_the_segment_parameter():
    # registers 0..2 = Hair Info > Intercept
    prog = _program([HAIR_INFO, 1, 0, COPY, 1, 0, COPY, 2, 0])
    intercept = ((np.linspace(-1, 1, N_KEYS) + 1) / 2) ** 2  # not linear in x: per key
    out = render(_scene(prog, {"register": 0}, curves_extra={"point_intercept": intercept.astype(np.float32)}))
    assert not out["stats"]["warnings"], out["stats"]["warnings"]
    x, px = _middle_row(out)
    keys = np.linspace(-1, 1, N_KEYS)
    k = np.clip(np.floor((x + 1) / 0.25).astype(int), 0, N_KEYS - 2)
    u = (x - keys[k]) / 0.25
    want = (1 - u) * intercept[k] + u * intercept[k + 1]
    np.testing.assert_allclose(px[:, 0], want, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(px[:, 1], want, rtol=1e-5, atol=1e-6)
    assert np.all(px[:, 3] == 1.0)


def test_attributes_length_random_and_strength():
    # r0..r4 = attribute 0 (point colour), r5..r9 = attribute 1 (curve float); colour = point
    # attribute RGB; strength = Length x Random (Math multiply) + curve attribute Fac
    code = [ATTRIBUTE, 0, 0, ATTRIBUTE, 1, 5, HAIR_INFO, 2, 10, HAIR_INFO, 0, 11, MATH, 2, 0, 12, 10, 11, 10,
            MATH, 0, 0, 13, 12, 8, 8]
    keys = np.linspace(-1, 1, N_KEYS)
    point = np.stack([(keys + 1) / 2, 1 - (keys + 1) / 2, np.full(N_KEYS, 0.25), np.ones(N_KEYS)], 1)
    curve = np.array([[0.5, 0.5, 0.5, 1.0]], np.float32)
    extra = {"attributes": [{"name": "tone", "domain": "POINT", "data": point.astype(np.float32)},
                            {"name": "weight", "domain": "CURVE", "data": curve}]}
    scene = _scene(_program(code, registers=14), {"register": 0}, curves_extra=extra)
    scene["materials"][0]["closures"][0]["strength"] = {"register": 13}
    out = render(scene)
    assert not out["stats"]["warnings"], out["stats"]["warnings"]
    x, px = _middle_row(out)
    strength = 2.5 * 0.375 + 0.5
    np.testing.assert_allclose(px[:, 0], strength * (x + 1) / 2, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(px[:, 1], strength * (1 - (x + 1) / 2), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(px[:, 2], strength * 0.25, rtol=1e-6)


def test_hair_inputs_from_registers_equal_constant_inputs():
    """A hair closure whose Melanin and Roughness come from registers renders like the same
    constants given directly (the same parameters per hit)."""
    light = {"type": "SUN", "direction": (0.3, -0.8, 0.5), "strength": (2.0, 2.0, 2.0), "angle": 0.0}

    def scene(melanin, roughness, program=None):
        s = _scene(None, (0, 0, 0), width=64)
        s["materials"] = [{"name": "hair", "closures": [{
            "type": "principled_hair", "model": "CHIANG", "parametrization": "MELANIN",
            "inputs": {"melanin": melanin, "roughness": roughness, "random": None}}]}]
        if program is not None:
            s["materials"][0]["program"] = program
        s["lights"] = [light]
        return s

    # constants 0.6 (melanin), 0.2 and 0.1 (roughness = 0.2 + 0.1 via Math, hit-independent here)
    prog = _program([MATH, 0, 0, 3, 1, 2, 2], constants=(0.6, 0.2, 0.1), registers=4)
    linked = render(scene({"register": 0}, {"register": 3}, prog))["combined"]
    const = render(scene(float(np.float32(0.6)), float(np.float32(0.2) + np.float32(0.1))))["combined"]
    assert linked[..., 3].sum() > 20
    # the loader folds the program (no input depends on the hit): the same pixels, bit for bit
    assert np.array_equal(linked, const)
    # eval_hit_bsdf folds as the renderer does
    rng = np.random.default_rng(3)
    wo, wi = (v / np.linalg.norm(v, axis=1, keepdims=True) for v in rng.normal(size=(2, 16, 3)))
    h = rng.uniform(-1, 1, 16)
    folded = _render.eval_hit_bsdf(scene({"register": 0}, {"register": 3}, prog), 0, wo, wi, h)
    plain = _render.eval_hit_bsdf(scene(float(np.float32(0.6)), float(np.float32(0.2) + np.float32(0.1))), 0,
                                  wo, wi, h)
    assert all(np.array_equal(a, b) for a, b in zip(folded, plain))


def test_loader_folds_constant_registers_and_keeps_the_hit_dependent_ones():
    """The emission colour is a block gathered from a constant Math result, Hair Info >
    Intercept and a given constant, the strength a constant Math result: the loader folds the
    strength and the constant parts of the colour into the program's constants and keeps the
    Copies of the colour block, so each pixel is (0.5, intercept, 0.25) x 3."""
    multiply, add = 2, 0
    code = [MATH, multiply, 0, 3, 0, 1, 1,      # r3 = 0.5 x 0.5 = 0.25 (constant)
            HAIR_INFO, 1, 4,                    # r4 = Intercept
            MATH, add, 0, 5, 0, 0, 0,           # r5 = 0.5 + 0.5 (constant)
            COPY, 6, 0, COPY, 7, 4, COPY, 8, 3,  # r6..r8 = (0.5, intercept, 0.25)
            MATH, add, 0, 9, 5, 2, 2,           # r9 = 1 + 2 = 3 (constant): the strength
            HAIR_INFO, 0, 10]                   # r10 = Random, read by nothing
    intercept = ((np.linspace(-1, 1, N_KEYS) + 1) / 2).astype(np.float32)
    scene = _scene(_program(code, constants=(0.5, 0.5, 2.0), registers=11), {"register": 6},
                   curves_extra={"point_intercept": intercept})
    scene["materials"][0]["closures"][0]["strength"] = {"register": 9}
    out = render(scene)
    assert not out["stats"]["warnings"], out["stats"]["warnings"]
    x, px = _middle_row(out)
    np.testing.assert_allclose(px[:, 0], 1.5, rtol=1e-6)
    np.testing.assert_allclose(px[:, 1], 3.0 * (x + 1) / 2, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(px[:, 2], 0.75, rtol=1e-6)


@pytest.mark.parametrize("program,warning", [
    (_program([99, 0, 0]), "unknown opcode 99"),
    (_program([COPY, 0, 1], constants=(1.0,), registers=2), "constants are read-only"),
    (_program([HAIR_INFO, 1, 0], registers=1), "outside the program's 1"),  # colour link needs 3 registers
])
def test_invalid_program_is_dropped_with_a_warning(program, warning):
    out = render(_scene(program, {"register": 0}))
    warnings = "\n".join(out["stats"]["warnings"])
    assert warning in warnings and "the program is ignored" in warnings, warnings
    assert np.isfinite(out["combined"]).all()
    # the closure keeps its constant colour: the default emission colour 0.8 grey
    x, px = _middle_row(out)
    np.testing.assert_allclose(px[:, :3], 0.8, rtol=1e-6)


def test_register_link_errors_name_the_key():
    scene = _scene(_program([HAIR_INFO, 1, 0], registers=3), {"register": -1})
    with pytest.raises(ValueError, match=r"\['color'\]\['register'\]: must be >= 0"):
        render(scene)
    scene = _scene(_program([HAIR_INFO, 1, 0], registers=3), {"reg": 0})
    with pytest.raises(ValueError, match=r"\['color'\]: expected a number or \{'register': slot\}"):
        render(scene)


def test_eval_program_matches_the_renderer_contract():
    # registers 0..1 constants (3, 0.5); r2 = intercept; r3 = intercept * 3 clamped
    prog = _program([HAIR_INFO, 1, 2, MATH, 2, 1, 3, 2, 0, 0], constants=(3.0, 0.5), registers=4)
    regs = _render.eval_program(prog, intercept=np.array([0.1, 0.5], np.float32))
    np.testing.assert_allclose(regs[:, 2], [0.1, 0.5], rtol=1e-7)
    np.testing.assert_allclose(regs[:, 3], [0.3, 1.0], rtol=1e-6)
    with pytest.raises(ValueError, match="instruction 0"):
        _render.eval_program(_program([99]))
    assert hairbsdf is not None


def test_image_texture_reads_the_scene_images_at_the_attribute_uv():
    # r0..r4 = point attribute (u, 0.5, 0, 1) with u = (x + 1) / 2 along the strand; r5..r8 =
    # ImageTexture (image 0, Closest, Repeat, no flags) at (r0, r1); colour = r5..r7
    code = [ATTRIBUTE, 0, 0, IMAGE_TEXTURE, 0, 1, 0, 0, 5, 0]
    keys = np.linspace(-1, 1, N_KEYS)
    uv = np.zeros((N_KEYS, 4), np.float32)
    uv[:, 0], uv[:, 1], uv[:, 3] = (keys + 1) / 2, 0.5, 1.0
    texels = np.array([[[0.1, 1.0, 0.0, 1.0], [0.2, 1.0, 0.0, 1.0], [0.3, 1.0, 0.0, 1.0], [0.4, 1.0, 0.0, 1.0]]],
                      np.float32)  # 4 x 1, RGBA
    scene = _scene(_program(code, registers=9), {"register": 5},
                   curves_extra={"attributes": [{"name": "<uv>", "domain": "POINT", "data": uv}]})
    scene["images"] = [{"name": "strip", "pixels": texels}]
    out = render(scene)
    assert not out["stats"]["warnings"], out["stats"]["warnings"]
    x, px = _middle_row(out)
    s = (x + 1) / 2 * 4
    away = np.abs(s - np.round(s)) > 0.02  # away from texel edges
    np.testing.assert_allclose(px[away, 0], texels[0, np.floor(s[away]).astype(int), 0], rtol=1e-6)
    # eval_program takes the same images; a missing image list is a validation error
    regs = _render.eval_program(_program(code, registers=9), attributes=uv[None, 2:3, :], images=scene["images"])
    assert regs[0, 5] == pytest.approx(texels[0, int(uv[2, 0] * 4), 0])
    with pytest.raises(ValueError, match="image index 0 outside"):
        _render.eval_program(_program(code, registers=9), attributes=uv[None, 2:3, :])
    scene["images"] = [{"name": "bad", "pixels": texels[..., :3]}]
    with pytest.raises(ValueError, match=r"\['images'\]\[0\]\['pixels'\]: expected shape \(height, width, 4\)"):
        render(scene)


def _split_arguments(text):
    """'type (0 min-max, 1 range), out, value' -> 3 arguments (commas inside parentheses kept)."""
    parts, depth, current = [], 0, ""
    for ch in text:
        depth += (ch == "(") - (ch == ")")
        if ch == "," and depth == 0:
            parts.append(current)
            current = ""
        else:
            current += ch
    return [p.strip() for p in parts + [current] if p.strip()]


def test_docs_instruction_table_matches_the_declaration():
    """docs/shading_vm.md's table of instructions (opcode, name, arguments) equals what
    render/shading_vm.h declares, as the exporter reads it."""
    import re
    from pathlib import Path
    doc = (Path(__file__).resolve().parents[2] / "docs" / "shading_vm.md").read_text()
    rows = re.findall(r"^\| (\d+) \| (\w+) \| ([^|]+) \|", doc, flags=re.M)
    documented = {re.sub(r"(?<!^)(?=[A-Z])", "_", name).upper(): (int(op), len(_split_arguments(args)))
                  for op, name, args in rows}
    isa = _render.shading_vm_instruction_set()
    declared = {name: (op, isa["argument_counts"][name]) for name, op in isa["ops"].items()}
    assert documented == declared


def _operand_cases():
    """(op, numbers): each op with valid numbers for its non-register arguments; MIX_VECTOR
    uniform and non-uniform (its factor's width follows argument 0)."""
    numbers = {"COLOR_RAMP": {2: 2}, "MIX_VECTOR": {0: 1}}
    cases = [(op, numbers.get(op, {})) for op in _OPS]
    return cases + [("MIX_VECTOR", {0: 0})]


@pytest.mark.parametrize("op, numbers", _operand_cases(), ids=lambda c: c if isinstance(c, str) else str(c))
def test_exporter_places_each_operand_as_the_vm_validates_it(op, numbers):
    """The exporter's compiler reads the VM's declaration of each op's register blocks
    (shading_network.operand_blocks): with each block in turn placed last, the program it writes
    is valid with exactly the registers the exporter allots, and invalid, naming that block, with
    one fewer. A width the exporter reads wrong (too narrow or too wide) fails one of the two."""
    from hairbsdf.blender.shading_network import AttributeTable, Reg, ShadingNetwork, operand_blocks
    count = _render.shading_vm_instruction_set()["argument_counts"][op]
    declared = _render.shading_vm_instruction_set()["operands"][op]
    plain = [numbers.get(i, 0) for i in range(count)]
    reads, writes = operand_blocks(op, plain)
    blocks = dict(reads + writes)
    images = [{"name": "texel", "pixels": np.ones((1, 1, 4), np.float32)}]
    for last in (o for o in declared if o["arg"] != 1 or op != "COLOR_RAMP"):  # the ramp's table is a constant
        net = ShadingNetwork(AttributeTable(), warn=pytest.fail, link_source=lambda s: None)
        args = list(plain)
        if op == "COLOR_RAMP":
            args[1] = net.constant([0.5] * blocks[1]).reg
        for o in sorted((o for o in declared if not isinstance(args[o["arg"]], Reg)), key=lambda o: o is last):
            args[o["arg"]] = net._temp(blocks[o["arg"]])
        net._emit(op, args)
        program = net._program()
        _render.eval_program(program, attributes=np.zeros((1, 1, 4), np.float32), images=images)
        program["registers"] -= 1
        with pytest.raises(ValueError, match=f"{last['what']} (reads|writes) register"):
            _render.eval_program(program, attributes=np.zeros((1, 1, 4), np.float32), images=images)
