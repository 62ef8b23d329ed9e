"""Closure weights and the world's inputs computed by a shading program (docs/shading_vm.md), without
Blender: the scene loader folds a weight that does not depend on the hit (and drops a closure whose
weight folds to 0), keeps one that does (a Mix Shader factor from Hair Info > Intercept) and applies it
per hit, folds the legacy Hair BSDF's inputs and the world's colour; `_render.folded_material` shows
what it made of a material. Programs are written by hand, as the exporter writes them: Clamp the
factor, 1 - t, times the weight above."""

import numpy as np

from hairbsdf import _render
from hairbsdf.render import render

_SET = _render.shading_vm_instruction_set()
_OPS, _MATH = _SET["ops"], _SET["math_types"]
HAIR_INFO, COPY, MATH, CLAMP = (_OPS[k] for k in ("HAIR_INFO", "COPY", "MATH", "CLAMP"))
SUBTRACT, MULTIPLY = _MATH["SUBTRACT"], _MATH["MULTIPLY"]
INTERCEPT = _SET["hair_info_outputs"]["Intercept"]
N_KEYS = 9


def _program(code, constants, registers):
    return {"code": np.asarray(code, np.int32), "constants": np.asarray(constants, np.float32),
            "registers": registers}


def _mix_weights(fac_code, fac_reg, first_temp):
    """Instructions after `fac_code` (which leaves the factor in register fac_reg) writing the two
    weights of a Mix Shader, (1 - t) and t with t = clamp(fac), as 3-wide blocks: returns (code,
    register of 1 - t block, register of t block, registers). Constants: 0 at 0, 1 at 1."""
    t, rest, w0, w1 = first_temp, first_temp + 1, first_temp + 2, first_temp + 5
    code = list(fac_code) + [CLAMP, 0, t, fac_reg, 0, 1, MATH, SUBTRACT, 0, rest, 1, t, 0]
    for i in range(3):
        code += [MATH, MULTIPLY, 0, w0 + i, 1, rest, 0, MATH, MULTIPLY, 0, w1 + i, 1, t, 0]
    return code, w0, w1, w1 + 3


def _camera(width):
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = (1, 0, 0), (0, 0, 1), (0, -1, 0), (0, -3, 0)
    return {"type": "ORTHO", "matrix_world": m, "resolution": (width, 8), "sensor_fit": "HORIZONTAL",
            "ortho_scale": 2.0, "clip_start": 0.01, "clip_end": 100.0}


def _scene(material, width=120, lights=(), world=None):
    pts = np.zeros((N_KEYS, 4), np.float32)
    pts[:, 0] = np.linspace(-1.0, 1.0, N_KEYS)
    pts[:, 3] = 0.1
    intercept = ((np.linspace(-1, 1, N_KEYS) + 1) / 2).astype(np.float32)
    scene = {"curves": {"points": pts, "curve_offsets": np.array([0, N_KEYS], np.int32),
                        "curve_random": np.array([0.375], np.float32), "curve_material": np.array([0], np.int32),
                        "point_intercept": intercept},
             "materials": [material], "camera": _camera(width), "lights": list(lights),
             "integrator": {"samples": 1, "max_bounces": 0, "filter_type": "BLACKMAN_HARRIS", "filter_width": 1e-4,
                            "film_transparent": world is None}}
    if world is not None:
        scene["world"] = world
    return scene


def _middle_row(out, width=120):
    x = -1.0 + (np.arange(width) + 0.5) * 2.0 / width
    inner = np.abs(x) < 0.74  # linear interpolation of the intercept holds on the interior segments
    return x[inner], out["combined"][4][inner]


def test_a_computed_weight_folds_to_the_constant_it_computes():
    """Mix Fac = 0.3 x 1 (a Math node on constants): the loader folds both weights, the render equals
    the one with the weights given as numbers, bit for bit, and no program is left."""
    code, w0, w1, registers = _mix_weights([MATH, MULTIPLY, 0, 3, 2, 1, 0], 3, 4)
    program = _program(code, (0.0, 1.0, 0.3), registers)
    red, blue = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)
    material = {"name": "m", "program": program, "closures": [
        {"type": "emission", "weight": {"register": w0}, "color": red},
        {"type": "emission", "weight": {"register": w1}, "color": blue}]}
    t = np.float32(0.3) * np.float32(1.0)
    plain = {"name": "m", "closures": [{"type": "emission", "weight": (float(np.float32(1) - t),) * 3, "color": red},
                                       {"type": "emission", "weight": (float(t),) * 3, "color": blue}]}
    folded = _render.folded_material(material)
    assert folded["registers"] == 0 and not folded["warnings"]
    assert [c["weight"] for c in folded["closures"]] == [c["weight"] for c in plain["closures"]]
    linked, const = render(_scene(material)), render(_scene(plain))
    assert not linked["stats"]["warnings"], linked["stats"]["warnings"]
    assert linked["combined"][..., 3].sum() > 20
    assert np.array_equal(linked["combined"], const["combined"])


def test_a_closure_whose_weight_folds_to_zero_is_dropped():
    code, w0, w1, registers = _mix_weights([MATH, MULTIPLY, 0, 3, 1, 1, 0], 3, 4)  # Fac = 1
    material = {"name": "m", "program": _program(code, (0.0, 1.0), registers), "closures": [
        {"type": "diffuse", "weight": {"register": w0}, "color": (1.0, 0.0, 0.0)},
        {"type": "principled_hair", "model": "CHIANG", "parametrization": "MELANIN", "weight": {"register": w1},
         "inputs": {"melanin": 0.4, "random": None}}]}
    folded = _render.folded_material(material)
    assert [c["type"] for c in folded["closures"]] == ["principled_hair"]
    assert folded["closures"][0]["weight"] == (1.0, 1.0, 1.0)
    assert folded["closures"][0]["inputs"]["melanin"] == 0.4
    assert folded["closures"][0]["inputs"]["random"] is None


def test_a_weight_that_depends_on_the_hit_is_applied_per_hit():
    """Mix Fac = Hair Info > Intercept between a red and a blue Emission: each pixel is (1 - t, 0, t);
    the loader keeps the weights as registers. Between two Diffuse closures lit by a sun, the pixels
    equal one Diffuse whose colour is (1 - t, 0, t) from the program (the path per-hit colours took)."""
    code, w0, w1, registers = _mix_weights([HAIR_INFO, INTERCEPT, 2], 2, 3)
    program = _program(code, (0.0, 1.0), registers)
    emit = {"name": "m", "program": program, "closures": [
        {"type": "emission", "weight": {"register": w0}, "color": (1.0, 0.0, 0.0)},
        {"type": "emission", "weight": {"register": w1}, "color": (0.0, 0.0, 1.0)}]}
    folded = _render.folded_material(emit)
    assert folded["registers"] > 0
    assert all(set(c["weight"]) == {"register"} for c in folded["closures"])
    out = render(_scene(emit))
    assert not out["stats"]["warnings"], out["stats"]["warnings"]
    x, px = _middle_row(out)
    t = (x + 1) / 2
    np.testing.assert_allclose(px[:, 0], 1 - t, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(px[:, 2], t, rtol=1e-5, atol=1e-6)

    sun = {"type": "SUN", "direction": (0.3, -0.8, 0.5), "strength": (3.0, 3.0, 3.0), "angle": 0.0}
    mixed = {"name": "m", "program": program, "closures": [
        {"type": "diffuse", "weight": {"register": w0}, "color": (1.0, 0.0, 0.0)},
        {"type": "diffuse", "weight": {"register": w1}, "color": (0.0, 0.0, 1.0)}]}
    # one diffuse, colour (1 - t, 0, t): r2 = t, r3 = 1 - t, then the colour block r4..r6
    colour = _program([HAIR_INFO, INTERCEPT, 2, MATH, SUBTRACT, 0, 3, 1, 2, 0, COPY, 4, 3, COPY, 5, 0, COPY, 6, 2],
                      (0.0, 1.0), 7)
    single = {"name": "m", "program": colour, "closures": [{"type": "diffuse", "color": {"register": 4}}]}
    a, b = render(_scene(mixed, lights=[sun])), render(_scene(single, lights=[sun]))
    assert a["combined"][..., 0].sum() > 1 and a["combined"][..., 2].sum() > 1
    np.testing.assert_allclose(a["combined"], b["combined"], rtol=1e-5, atol=1e-7)


def test_legacy_hair_inputs_fold_and_a_hit_dependent_one_reads_the_zero_hit():
    """The legacy Hair BSDF's inputs are read once per render: computed ones fold; one that depends
    on the hit (never exported so) takes its value at the zero hit, with a warning."""
    program = _program([MATH, MULTIPLY, 0, 2, 0, 1, 0, HAIR_INFO, INTERCEPT, 3], (0.25, 2.0), 4)
    material = {"name": "m", "program": program, "closures": [
        {"type": "cycles_hair", "component": "REFLECTION", "color": (0.5, 0.5, 0.5), "offset": 0.0,
         "roughness_u": {"register": 2}, "roughness_v": {"register": 3}}]}
    folded = _render.folded_material(material)
    c = folded["closures"][0]
    assert c["roughness_u"] == 0.5 and c["roughness_v"] == 0.0 and folded["registers"] == 0
    assert any("legacy Hair BSDF input" in w for w in folded["warnings"]), folded["warnings"]


def test_the_world_colour_from_a_program_is_folded_once():
    """world.color = 0.25 x 2 per channel, computed by the world's program: the background reads 0.5;
    a texture whose weight folds to 0 is left out."""
    program = _program([MATH, MULTIPLY, 0, 2, 0, 1, 0, COPY, 3, 2, COPY, 4, 2, COPY, 5, 2], (0.25, 2.0), 6)
    world = {"color": {"register": 3}, "program": program}
    scene = _scene({"name": "m", "closures": []}, world=world)
    del scene["curves"]  # the background alone
    out = render(scene)
    assert not out["stats"]["warnings"] or all("world" not in w for w in out["stats"]["warnings"])
    np.testing.assert_allclose(out["combined"][0, 0, :3], 0.5, rtol=1e-6)
