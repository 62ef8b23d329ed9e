"""The shading-network compiler (plugin/hairbsdf/blender/shading_network.py) and the renderer's
shading VM, against Blender and Cycles.

* test_compiler_*: node trees built with bpy are compiled; constant networks give registers
  whose values are the same at every hit (the scene loader folds them; so do Mix Shader factors,
  as closure weights, and the world's Strength), hit-dependent ones a
  program whose evaluation (hairbsdf._render.eval_program) is checked against formulas written
  here from Blender's node definitions, and unsupported nodes are warned by name with the socket value used.
* test_emission_networks_match_cycles_per_pixel: the strongest check. Straight strands whose
  Emission colour is a node network (Hair Info, ColorRamp, Map Range, Math, Mix, Gamma, ...; and
  point / curve attributes in 4.x), seen by an orthographic camera at 1 sample per pixel (the
  pixel centre) with no bounces: every pixel is the network's value at one hit. Cycles and
  HAIRBSDF render the same scene in one process and must agree per pixel (median relative
  error <= 1e-4, p99 <= 2e-3, the fibre goniometer's limits).
* test_image_texture_*: Image Texture on curve UVs (Curves' 2D-vector curve attributes, particle
  hair's emitter UVs): the compiler's handling of its settings, the same per-pixel comparison for
  every interpolation / extension / image kind, and Principled Hair coloured by an image
  (render means within 5 % of Cycles', test_engine_render's limit)."""

import re

import numpy as np
import pytest

from blender_env import ENGINE_KINDS, need_renderer, record

pytestmark = pytest.mark.blender

COMPILER = r'''
import math
from hairbsdf.blender.export_materials import MaterialTable
from hairbsdf import _render

def sock(coll, identifier):
    """A socket by identifier (the Mix node's A / B / Factor names repeat per data type)."""
    return next(s for s in coll if s.identifier == identifier)

class Report:
    def __init__(self): self.warnings = []
    def warn(self, msg): self.warnings.append(msg)

def new_mat(name):
    m = bpy.data.materials.new(name); m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes): nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    h = nt.nodes.new("ShaderNodeBsdfHairPrincipled"); h.name = "PH"
    if hasattr(h, "model"): h.model = "CHIANG"
    h.parametrization = "MELANIN"
    nt.links.new(h.outputs[0], out.inputs["Surface"])
    return m, nt, h

def inp(node, name):
    return fg.node_input(node, name)

# 1. constant network: Roughness = Value 0.2 x Value 3 (Math), Melanin = Clamp(1.7) -> folded
m1, nt, h = new_mat("Constant")
a = nt.nodes.new("ShaderNodeValue"); a.outputs[0].default_value = 0.2
mul = nt.nodes.new("ShaderNodeMath"); mul.operation = "MULTIPLY"; mul.inputs[1].default_value = 3.0
nt.links.new(a.outputs[0], mul.inputs[0]); nt.links.new(mul.outputs[0], inp(h, "Roughness"))
cl = nt.nodes.new("ShaderNodeClamp"); cl.inputs["Value"].default_value = 1.7
nt.links.new(cl.outputs[0], inp(h, "Melanin"))

# 2. hit-dependent: Roughness = Map Range (linear, clamp) of Intercept 0.2..0.8 -> 0.1..0.6,
#    Coat = Math(POWER, Random, 2), Tint = ColorRamp (linear) of Intercept
m2, nt, h = new_mat("Dynamic")
info = nt.nodes.new("ShaderNodeHairInfo")
mr = nt.nodes.new("ShaderNodeMapRange"); mr.clamp = True
mr.inputs["From Min"].default_value = 0.2; mr.inputs["From Max"].default_value = 0.8
mr.inputs["To Min"].default_value = 0.1; mr.inputs["To Max"].default_value = 0.6
nt.links.new(info.outputs["Intercept"], mr.inputs["Value"]); nt.links.new(mr.outputs["Result"], inp(h, "Roughness"))
pw = nt.nodes.new("ShaderNodeMath"); pw.operation = "POWER"; pw.inputs[1].default_value = 2.0
nt.links.new(info.outputs["Random"], pw.inputs[0]); nt.links.new(pw.outputs[0], inp(h, "Coat"))
ramp = nt.nodes.new("ShaderNodeValToRGB")
ramp.color_ramp.elements[0].position = 0.25; ramp.color_ramp.elements[0].color = (1.0, 0.5, 0.0, 1.0)
ramp.color_ramp.elements[1].position = 0.75; ramp.color_ramp.elements[1].color = (0.0, 0.25, 1.0, 0.5)
nt.links.new(info.outputs["Intercept"], ramp.inputs["Fac"]); nt.links.new(ramp.outputs["Color"], inp(h, "Tint"))

# 3. unsupported node (Noise Texture) on Roughness: warned, socket value; Random socket from a
#    Math of Random stays a program input; Random straight from Hair Info stays None (Dynamic)
m3, nt, h = new_mat("Unsupported")
inp(h, "Roughness").default_value = 0.27
noise = nt.nodes.new("ShaderNodeTexNoise"); noise.name = "MyNoise"
nt.links.new(noise.outputs["Fac"], inp(h, "Roughness"))
info = nt.nodes.new("ShaderNodeHairInfo")
half = nt.nodes.new("ShaderNodeMath"); half.operation = "MULTIPLY"; half.inputs[1].default_value = 0.5
nt.links.new(info.outputs["Random"], half.inputs[0]); nt.links.new(half.outputs[0], inp(h, "Random"))

# 4. every Mix blend the VM supports, colour mix of two RGBs by Intercept (factor clamp off),
#    into an Emission colour: one material per blend
blends = ["MIX", "ADD", "MULTIPLY", "SUBTRACT", "SCREEN", "DIVIDE", "DIFFERENCE", "DARKEN", "LIGHTEN", "OVERLAY",
          "DODGE", "BURN", "SOFT_LIGHT", "LINEAR_LIGHT", "EXCLUSION"]
available = {e.identifier for e in bpy.types.ShaderNodeMix.bl_rna.properties["blend_type"].enum_items}
blends = [b for b in blends if b in available]  # Exclusion: Blender 3.5+
for blend in blends:
    m = bpy.data.materials.new("Blend_" + blend); m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes): nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    e = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    mix = nt.nodes.new("ShaderNodeMix"); mix.data_type = "RGBA"; mix.blend_type = blend
    mix.clamp_factor = False
    sock(mix.inputs, "A_Color").default_value = (0.2, 0.6, 0.9, 1.0)
    sock(mix.inputs, "B_Color").default_value = (0.5, 0.3, 0.0, 1.0)
    info = nt.nodes.new("ShaderNodeHairInfo")
    nt.links.new(info.outputs["Intercept"], sock(mix.inputs, "Factor_Float"))
    nt.links.new(sock(mix.outputs, "Result_Color"), e.inputs["Color"])

# 5. closure weights: Mix Shader(Fac = Intercept) of a Diffuse and Mix Shader(Fac = 0.25 x 2, a Math node
#    on constants) of Principled Hair and Emission: every weight a register, none warned
m5, nt, h = new_mat("MixWeights")
out = [n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputMaterial"][0]
d = nt.nodes.new("ShaderNodeBsdfDiffuse")
e = nt.nodes.new("ShaderNodeEmission")
inner = nt.nodes.new("ShaderNodeMixShader")
fm = nt.nodes.new("ShaderNodeMath"); fm.operation = "MULTIPLY"
fm.inputs[0].default_value = 0.25; fm.inputs[1].default_value = 2.0
nt.links.new(fm.outputs[0], inner.inputs["Fac"])
nt.links.new(h.outputs[0], inner.inputs[1]); nt.links.new(e.outputs[0], inner.inputs[2])
outer = nt.nodes.new("ShaderNodeMixShader")
info = nt.nodes.new("ShaderNodeHairInfo")
nt.links.new(info.outputs["Intercept"], outer.inputs["Fac"])
nt.links.new(d.outputs[0], outer.inputs[1]); nt.links.new(inner.outputs[0], outer.inputs[2])
nt.links.new(outer.outputs[0], out.inputs["Surface"])

# 6. the world: Background Strength = 0.75 x 2 (Math), Color (0.2, 0.4, 0.6): a register of the
#    world's program
from hairbsdf.blender.export_world import export_world
w = bpy.data.worlds.new("WProgram"); bpy.context.scene.world = w; w.use_nodes = True
wnt = w.node_tree
bg = [n for n in wnt.nodes if n.bl_idname == "ShaderNodeBackground"][0]
bg.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1.0)
ws = wnt.nodes.new("ShaderNodeMath"); ws.operation = "MULTIPLY"
ws.inputs[0].default_value = 0.75; ws.inputs[1].default_value = 2.0
wnt.links.new(ws.outputs[0], bg.inputs["Strength"])
wrep = Report()
world = export_world(bpy.context.scene, wrep)
wp = world["program"]
world_out = {"color": world["color"], "registers": _render.eval_program(wp)[0].tolist(), "warnings": wrep.warnings}

rep = Report()
table = MaterialTable(rep)
res = {}
x = np.linspace(-0.25, 1.25, 13).astype(np.float32)   # intercept values, beyond 0..1 on purpose
rnd = np.linspace(0.0, 1.0, 13).astype(np.float32)
for mat in [m1, m2, m3, m5] + [bpy.data.materials["Blend_" + b] for b in blends]:
    d = table.materials[table.index(mat)]
    entry = {"closures": d["closures"], "program": None, "eval": None}
    if "program" in d:
        p = d["program"]
        entry["program"] = {"code": p["code"].tolist(), "constants": p["constants"].tolist(),
                            "registers": int(p["registers"])}
        entry["eval"] = _render.eval_program(p, rnd, x, 1.5, 1.0).tolist()
    res[mat.name] = entry
emit({"version": list(bpy.app.version), "materials": res, "warnings": rep.warnings, "world": world_out,
      "x": x.tolist(), "random": rnd.tolist(), "needs": [list(n[0:1]) + [sorted(n[1])] for n in table.needs]})
'''


def _register(value):
    assert isinstance(value, dict) and set(value) == {"register"}, value
    return value["register"]


def _mix_reference(blend, t, a, b):
    """Blender's colour blend formulas (Cycles' svm_mix), per channel, float64."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    t = np.asarray(t, float)[:, None]
    lerp = lambda x, y: x + t * (y - x)  # noqa: E731
    tm = 1 - t
    if blend == "MIX":
        return lerp(a, b)
    if blend == "ADD":
        return lerp(a, a + b)
    if blend == "MULTIPLY":
        return lerp(a, a * b)
    if blend == "SUBTRACT":
        return lerp(a, a - b)
    if blend == "SCREEN":
        return 1 - (tm + t * (1 - b)) * (1 - a)
    if blend == "DIVIDE":
        return np.where(b != 0, tm * a + t * a / np.where(b != 0, b, 1), a)
    if blend == "DIFFERENCE":
        return lerp(a, np.abs(a - b))
    if blend == "DARKEN":
        return lerp(a, np.minimum(a, b))
    if blend == "LIGHTEN":
        return lerp(a, np.maximum(a, b))
    if blend == "OVERLAY":
        return np.where(a < 0.5, a * (tm + 2 * t * b), 1 - (tm + 2 * t * (1 - b)) * (1 - a))
    if blend == "DODGE":
        d = 1 - t * b
        return np.where(a == 0, a, np.where(d <= 0, 1.0, np.minimum(a / np.where(d > 0, d, 1), 1.0)))
    if blend == "BURN":
        d = tm + t * b
        return np.where(d <= 0, 0.0, np.clip(1 - (1 - a) / np.where(d > 0, d, 1), 0, 1))
    if blend == "SOFT_LIGHT":
        scr = 1 - (1 - b) * (1 - a)
        return tm * a + t * ((1 - a) * b * a + a * scr)
    if blend == "LINEAR_LIGHT":
        return a + t * (2 * b - 1)
    if blend == "EXCLUSION":
        return np.maximum(lerp(a, a + b - 2 * a * b), 0)
    raise KeyError(blend)


def test_compiler_folds_evaluates_and_warns(run_blender, engine_kind, renderer_available):
    need_renderer(engine_kind, renderer_available)
    r = run_blender(engine_kind, COMPILER).result
    mats, warnings = r["materials"], "\n".join(r["warnings"])
    x, rnd = np.asarray(r["x"]), np.asarray(r["random"])

    # 1. constant networks: registers of a program with no Hair Info or attribute, whose values
    #    are the same at every hit (the scene loader folds them: render_shading_vm_test's
    #    ShadingVmFold, plugin/tests/test_render_shading_program.py)
    const = mats["Constant"]
    assert const["program"] is not None
    regs = np.asarray(const["eval"])  # at 13 hits of different Random and Intercept
    const_inputs = const["closures"][0]["inputs"]
    rough, melanin = regs[:, _register(const_inputs["roughness"])], regs[:, _register(const_inputs["melanin"])]
    assert (rough == rough[0]).all() and rough[0] == pytest.approx(0.6, rel=1e-6)
    assert (melanin == 1.0).all()  # Clamp 0..1

    # 2. the dynamic material: registers, and their values per hit
    dyn = mats["Dynamic"]
    assert dyn["program"] is not None
    inputs = dyn["closures"][0]["inputs"]
    regs = np.asarray(dyn["eval"])
    rough = regs[:, _register(inputs["roughness"])]
    want = np.clip(0.1 + (x - 0.2) / 0.6 * 0.5, 0.1, 0.6)
    np.testing.assert_allclose(rough, want, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(regs[:, _register(inputs["coat"])], rnd ** 2, rtol=1e-6, atol=1e-7)
    tint = regs[:, _register(inputs["tint"]):_register(inputs["tint"]) + 3]
    # Cycles bakes the ramp (linear between its two stops) into 256 entries at i / 255 and
    # interpolates linearly between entries
    ramp = lambda t: (1 - np.clip((t - 0.25) / 0.5, 0, 1))[:, None] * np.array([1.0, 0.5, 0.0]) + \
        np.clip((t - 0.25) / 0.5, 0, 1)[:, None] * np.array([0.0, 0.25, 1.0])  # noqa: E731
    table = ramp(np.arange(256) / 255.0)
    f = np.clip(x, 0, 1) * 255
    i = np.minimum(np.floor(f).astype(int), 254)
    t = (f - i)[:, None]
    np.testing.assert_allclose(tint, (1 - t) * table[i] + t * table[i + 1], atol=2e-6)
    assert inputs["random"] is None  # Hair Info > Random straight in: per-curve random
    assert inputs["melanin"] == pytest.approx(0.8)  # unlinked: the socket value

    # 3. unsupported node: named, socket value; Random from a Math is a program input
    uns = mats["Unsupported"]["closures"][0]["inputs"]
    assert uns["roughness"] == pytest.approx(0.27)
    # the Noise Texture's output is "Fac" before Blender 5.0, "Factor" since
    assert re.search(r"'PH' > 'Roughness' is driven by 'MyNoise' \(Noise Texture > Fac(tor)?\)", warnings), warnings
    regs = np.asarray(mats["Unsupported"]["eval"])
    np.testing.assert_allclose(regs[:, _register(uns["random"])], 0.5 * rnd, rtol=1e-6)

    # 4. Mix blends (factor beyond 0..1 unclamped)
    a, b = (0.2, 0.6, 0.9), (0.5, 0.3, 0.0)
    for name, m in mats.items():
        if not name.startswith("Blend_"):
            continue
        blend = name[len("Blend_"):]
        color = m["closures"][0]["color"]
        regs = np.asarray(m["eval"])
        k = _register(color)
        np.testing.assert_allclose(regs[:, k:k + 3], _mix_reference(blend, x, a, b), rtol=2e-6, atol=2e-6,
                                   err_msg=blend)
    needs = r["needs"]
    assert [True, []] in needs  # some material reads the intercept, none an attribute

    # 5. closure weights from Mix Shader factors: registers, (1 - t) for the Diffuse and t x (1 - 0.5),
    #    t x 0.5 for the hair and the emission, t = Intercept clamped (the Mix Shader's clamp)
    mw = mats["MixWeights"]
    assert [c["type"] for c in mw["closures"]] == ["diffuse", "principled_hair", "emission"]
    regs = np.asarray(mw["eval"])
    t = np.clip(x, 0, 1)[:, None]
    for c, want in zip(mw["closures"], (1 - t, t * 0.5, t * 0.5)):
        k = _register(c["weight"])
        np.testing.assert_allclose(regs[:, k:k + 3], np.repeat(want, 3, axis=1), rtol=1e-6, atol=1e-7)
    assert "MixWeights" not in warnings
    # 6. the world's colour: a register of its program, (0.2, 0.4, 0.6) x 1.5
    world = r["world"]
    k = _register(world["color"])
    np.testing.assert_allclose(world["registers"][k:k + 3], [0.3, 0.6, 0.9], rtol=1e-6)
    assert not world["warnings"], world["warnings"]


# ---------------------------------------------------------------------------- per pixel

EMISSION_COMMON = r'''
import os
import scene_lib as lib
V = tuple(bpy.app.version)

def sock(coll, identifier):
    """A socket by identifier (the Mix node's A / B / Factor names repeat per data type)."""
    return next(s for s in coll if s.identifier == identifier)

def emission_scene(w, h):
    """Emission only: one sample per pixel at its centre (filter 0.01 px), no bounces."""
    scene = hs.reset(width=w, height=h, spp=1, film_transparent=True)
    scene.cycles.max_bounces = 0
    scene.cycles.filter_width = 0.01
    scene.hairbsdf.threads = 2
    return scene

def emission_material(name):
    m = bpy.data.materials.new(name); m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes): nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    e = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    return m, nt, e

'''

EMISSION = EMISSION_COMMON + r'''
hb = register_engine()
from hairbsdf.blender import engine
W, H = ARGS["w"], ARGS["h"]
scene = emission_scene(W, H)

def ramp_node(nt, interpolation, stops):
    r = nt.nodes.new("ShaderNodeValToRGB")
    cr = r.color_ramp
    cr.interpolation = interpolation
    while len(cr.elements) < len(stops):
        cr.elements.new(0.5)
    for el, (pos, col) in zip(cr.elements, stops):
        el.position = pos; el.color = tuple(col) + (1.0,)
    return r

networks = []

# a. B-spline ramp on Intercept
m, nt, e = emission_material("RampBSpline")
info = nt.nodes.new("ShaderNodeHairInfo")
r = ramp_node(nt, "B_SPLINE", [(0.0, (0.9, 0.1, 0.1)), (0.4, (0.1, 0.8, 0.2)), (1.0, (0.2, 0.3, 1.0))])
nt.links.new(info.outputs["Intercept"], r.inputs["Fac"]); nt.links.new(r.outputs["Color"], e.inputs["Color"])
networks.append(m)

# b. Ease ramp on a smootherstep Map Range, and Cardinal / Constant ramps combined by a legacy
#    MixRGB OVERLAY whose factor is Random
m, nt, e = emission_material("RampEaseOverlay")
info = nt.nodes.new("ShaderNodeHairInfo")
mr = nt.nodes.new("ShaderNodeMapRange"); mr.interpolation_type = "SMOOTHERSTEP"
mr.inputs["From Min"].default_value = 0.1; mr.inputs["From Max"].default_value = 0.9
nt.links.new(info.outputs["Intercept"], mr.inputs["Value"])
r1 = ramp_node(nt, "EASE", [(0.0, (0.1, 0.2, 0.3)), (1.0, (0.9, 0.7, 0.2))])
nt.links.new(mr.outputs["Result"], r1.inputs["Fac"])
r2 = ramp_node(nt, "CARDINAL", [(0.1, (0.3, 0.9, 0.1)), (0.5, (0.9, 0.2, 0.6)), (0.8, (0.1, 0.1, 0.9))])
nt.links.new(info.outputs["Intercept"], r2.inputs["Fac"])
r3 = ramp_node(nt, "CONSTANT", [(0.0, (0.2, 0.2, 0.2)), (0.5, (0.7, 0.4, 0.1))])
nt.links.new(info.outputs["Intercept"], r3.inputs["Fac"])
mix_a = nt.nodes.new("ShaderNodeMixRGB"); mix_a.blend_type = "OVERLAY"
nt.links.new(info.outputs["Random"], mix_a.inputs["Fac"])
nt.links.new(r1.outputs["Color"], mix_a.inputs["Color1"]); nt.links.new(r2.outputs["Color"], mix_a.inputs["Color2"])
mix_b = nt.nodes.new("ShaderNodeMixRGB"); mix_b.blend_type = "SCREEN"; mix_b.use_clamp = True
mix_b.inputs["Fac"].default_value = 0.7
nt.links.new(mix_a.outputs["Color"], mix_b.inputs["Color1"]); nt.links.new(r3.outputs["Color"], mix_b.inputs["Color2"])
nt.links.new(mix_b.outputs["Color"], e.inputs["Color"])
networks.append(m)

# c. Math and Map Range into Combine XYZ: pingpong of Intercept x Length, stepped map range,
#    sine with the clamp flag
m, nt, e = emission_material("MathCombine")
info = nt.nodes.new("ShaderNodeHairInfo")
mul = nt.nodes.new("ShaderNodeMath"); mul.operation = "MULTIPLY"
nt.links.new(info.outputs["Intercept"], mul.inputs[0]); nt.links.new(info.outputs["Length"], mul.inputs[1])
pp = nt.nodes.new("ShaderNodeMath"); pp.operation = "PINGPONG"; pp.inputs[1].default_value = 0.35
nt.links.new(mul.outputs[0], pp.inputs[0])
st = nt.nodes.new("ShaderNodeMapRange"); st.interpolation_type = "STEPPED"; st.inputs["Steps"].default_value = 5
st.inputs["To Min"].default_value = 0.1; st.inputs["To Max"].default_value = 0.9
nt.links.new(info.outputs["Intercept"], st.inputs["Value"])
sn = nt.nodes.new("ShaderNodeMath"); sn.operation = "SINE"; sn.use_clamp = True
sc = nt.nodes.new("ShaderNodeMath"); sc.operation = "MULTIPLY_ADD"
sc.inputs[1].default_value = 9.0; sc.inputs[2].default_value = 0.3
nt.links.new(info.outputs["Intercept"], sc.inputs[0]); nt.links.new(sc.outputs[0], sn.inputs[0])
comb = nt.nodes.new("ShaderNodeCombineXYZ")
nt.links.new(pp.outputs[0], comb.inputs["X"]); nt.links.new(st.outputs["Result"], comb.inputs["Y"])
nt.links.new(sn.outputs[0], comb.inputs["Z"])
nt.links.new(comb.outputs["Vector"], e.inputs["Color"])
networks.append(m)

# d. colour adjustments: Combine Color(Intercept, Random, 0.4) -> Gamma -> Bright/Contrast ->
#    Invert, then Separate Color swapping channels into Combine RGB; Strength from a Clamp
m, nt, e = emission_material("ColourAdjust")
info = nt.nodes.new("ShaderNodeHairInfo")
cc = nt.nodes.new("ShaderNodeCombineColor"); cc.inputs["Blue"].default_value = 0.4
nt.links.new(info.outputs["Intercept"], cc.inputs["Red"]); nt.links.new(info.outputs["Random"], cc.inputs["Green"])
ga = nt.nodes.new("ShaderNodeGamma"); ga.inputs["Gamma"].default_value = 2.2
nt.links.new(cc.outputs["Color"], ga.inputs["Color"])
bc = nt.nodes.new("ShaderNodeBrightContrast")
bc.inputs["Bright"].default_value = 0.05; bc.inputs["Contrast"].default_value = 0.3
nt.links.new(ga.outputs["Color"], bc.inputs["Color"])
iv = nt.nodes.new("ShaderNodeInvert"); iv.inputs["Fac"].default_value = 0.35
nt.links.new(bc.outputs["Color"], iv.inputs["Color"])
sep = nt.nodes.new("ShaderNodeSeparateColor")
nt.links.new(iv.outputs["Color"], sep.inputs["Color"])
if bpy.app.version < (5, 0, 0):  # the legacy Combine RGB node (removed in 5.0)
    crgb = nt.nodes.new("ShaderNodeCombineRGB")
    (r_in, g_in, b_in), crgb_out = (crgb.inputs[k] for k in "RGB"), crgb.outputs["Image"]
else:
    crgb = nt.nodes.new("ShaderNodeCombineColor")
    (r_in, g_in, b_in), crgb_out = (crgb.inputs[k] for k in ("Red", "Green", "Blue")), crgb.outputs["Color"]
nt.links.new(sep.outputs["Red"], g_in); nt.links.new(sep.outputs["Green"], b_in)
nt.links.new(sep.outputs["Blue"], r_in)
nt.links.new(crgb_out, e.inputs["Color"])
clampn = nt.nodes.new("ShaderNodeClamp"); clampn.clamp_type = "RANGE"
clampn.inputs["Min"].default_value = 1.4; clampn.inputs["Max"].default_value = 0.6
fl = nt.nodes.new("ShaderNodeMath"); fl.operation = "MULTIPLY_ADD"
fl.inputs[1].default_value = 1.5; fl.inputs[2].default_value = 0.3
nt.links.new(info.outputs["Intercept"], fl.inputs[0]); nt.links.new(fl.outputs[0], clampn.inputs["Value"])
nt.links.new(clampn.outputs["Result"], e.inputs["Strength"])
networks.append(m)

# e. float and vector Mix, DIFFERENCE and LIGHTEN colour mixes, a smoothstep Map Range
m, nt, e = emission_material("Mixes")
info = nt.nodes.new("ShaderNodeHairInfo")
mf = nt.nodes.new("ShaderNodeMix"); mf.data_type = "FLOAT"; mf.clamp_factor = False
sock(mf.inputs, "A_Float").default_value = 0.2; sock(mf.inputs, "B_Float").default_value = 0.9
nt.links.new(info.outputs["Intercept"], sock(mf.inputs, "Factor_Float"))
mv = nt.nodes.new("ShaderNodeMix"); mv.data_type = "VECTOR"; mv.factor_mode = "NON_UNIFORM"
sock(mv.inputs, "A_Vector").default_value = (0.1, 0.5, 0.9); sock(mv.inputs, "B_Vector").default_value = (0.8, 0.2, 0.4)
ssm = nt.nodes.new("ShaderNodeMapRange"); ssm.interpolation_type = "SMOOTHSTEP"
ssm.inputs["From Min"].default_value = 0.8; ssm.inputs["From Max"].default_value = 0.2
nt.links.new(info.outputs["Intercept"], ssm.inputs["Value"])
fv = nt.nodes.new("ShaderNodeCombineXYZ")
nt.links.new(sock(mf.outputs, "Result_Float"), fv.inputs["X"]); nt.links.new(ssm.outputs["Result"], fv.inputs["Y"])
nt.links.new(info.outputs["Random"], fv.inputs["Z"])
nt.links.new(fv.outputs["Vector"], sock(mv.inputs, "Factor_Vector"))
md = nt.nodes.new("ShaderNodeMix"); md.data_type = "RGBA"; md.blend_type = "DIFFERENCE"
sock(md.inputs, "B_Color").default_value = (0.6, 0.1, 0.3, 1.0)
nt.links.new(info.outputs["Intercept"], sock(md.inputs, "Factor_Float"))
nt.links.new(sock(mv.outputs, "Result_Vector"), sock(md.inputs, "A_Color"))
ml = nt.nodes.new("ShaderNodeMix"); ml.data_type = "RGBA"; ml.blend_type = "LIGHTEN"; ml.clamp_result = True
sock(ml.inputs, "Factor_Float").default_value = 0.8; sock(ml.inputs, "B_Color").default_value = (0.3, 0.5, 0.2, 1.0)
nt.links.new(sock(md.outputs, "Result_Color"), sock(ml.inputs, "A_Color"))
nt.links.new(sock(ml.outputs, "Result_Color"), e.inputs["Color"])
networks.append(m)

# g. closure weights per hit: Mix Shader(Fac = Map Range(Intercept) x Random) of the emission
#    above (a ColorRamp on Intercept) and a Mix Shader (Fac = 0.3 x 2 from a Math node on constants:
#    folded by the loader) of a green and a blue Emission of strength 1.5
m, nt, e = emission_material("MixShaderPerHit")
out_node = [n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputMaterial"][0]
info = nt.nodes.new("ShaderNodeHairInfo")
rp = ramp_node(nt, "LINEAR", [(0.0, (0.9, 0.2, 0.1)), (1.0, (0.2, 0.3, 0.8))])
nt.links.new(info.outputs["Intercept"], rp.inputs["Fac"]); nt.links.new(rp.outputs["Color"], e.inputs["Color"])
green = nt.nodes.new("ShaderNodeEmission"); green.inputs["Color"].default_value = (0.1, 0.8, 0.2, 1.0)
blue = nt.nodes.new("ShaderNodeEmission"); blue.inputs["Color"].default_value = (0.1, 0.2, 0.9, 1.0)
green.inputs["Strength"].default_value = blue.inputs["Strength"].default_value = 1.5
inner = nt.nodes.new("ShaderNodeMixShader")
fm = nt.nodes.new("ShaderNodeMath"); fm.operation = "MULTIPLY"
fm.inputs[0].default_value = 0.3; fm.inputs[1].default_value = 2.0
nt.links.new(fm.outputs[0], inner.inputs["Fac"])
nt.links.new(green.outputs[0], inner.inputs[1]); nt.links.new(blue.outputs[0], inner.inputs[2])
outer = nt.nodes.new("ShaderNodeMixShader")
mr = nt.nodes.new("ShaderNodeMapRange"); mr.inputs["From Min"].default_value = 0.1
mr.inputs["From Max"].default_value = 0.9; mr.clamp = False  # the Mix Shader clamps the Fac
nt.links.new(info.outputs["Intercept"], mr.inputs["Value"])
fr = nt.nodes.new("ShaderNodeMath"); fr.operation = "MULTIPLY_ADD"
fr.inputs[2].default_value = 0.2
nt.links.new(mr.outputs["Result"], fr.inputs[0]); nt.links.new(info.outputs["Random"], fr.inputs[1])
nt.links.new(fr.outputs[0], outer.inputs["Fac"])
nt.links.new(e.outputs[0], outer.inputs[1]); nt.links.new(inner.outputs[0], outer.inputs[2])
nt.links.new(outer.outputs[0], out_node.inputs["Surface"])
networks.append(m)

# Strands: per material a Curves object with 3 straight horizontal strands (different Random),
# 7 keys from x = -0.9 to 0.9, radius 0.02, stacked in z.
rows = []
z = 0.9
for m in networks:
    lines = [[(-0.9 + 1.8 * i / 6, 0.0, z - 0.09 * k) for i in range(7)] for k in range(3)]
    lib.curves_from_polylines(scene, m.name, lines, 0.02, m)
    z -= 0.25
n_attr = 0
if V >= (4, 0, 0):
    # f. attributes (4.x: Curves.add_curves): a point-domain colour and a curve-domain float
    m, nt, e = emission_material("Attributes")
    ac = nt.nodes.new("ShaderNodeAttribute"); ac.attribute_name = "tone"
    af = nt.nodes.new("ShaderNodeAttribute"); af.attribute_name = "weight"
    mix = nt.nodes.new("ShaderNodeMix"); mix.data_type = "RGBA"; mix.blend_type = "MULTIPLY"
    nt.links.new(af.outputs["Fac"], sock(mix.inputs, "Factor_Float"))
    nt.links.new(ac.outputs["Color"], sock(mix.inputs, "A_Color"))
    sock(mix.inputs, "B_Color").default_value = (0.5, 0.9, 0.3, 1.0)
    nt.links.new(sock(mix.outputs, "Result_Color"), e.inputs["Color"])
    curves = bpy.data.hair_curves.new("AttrCurves")
    curves.add_curves([7, 7, 7])
    pos = np.array([[-0.9 + 1.8 * i / 6, 0.0, z - 0.09 * k] for k in range(3) for i in range(7)], np.float32)
    curves.position_data.foreach_set("vector", pos.ravel())
    rad = curves.attributes.get("radius") or curves.attributes.new("radius", "FLOAT", "POINT")
    rad.data.foreach_set("value", np.full(21, 0.02, np.float32))
    tone = curves.attributes.new("tone", "FLOAT_COLOR", "POINT")
    t = np.linspace(0, 1, 21, dtype=np.float32)
    tone.data.foreach_set("color", np.stack([t, 1 - t, 0.3 + 0.5 * t * t, np.ones_like(t)], 1).ravel())
    weight = curves.attributes.new("weight", "FLOAT", "CURVE")
    weight.data.foreach_set("value", np.array([0.2, 0.6, 1.0], np.float32))
    curves.materials.append(m)
    obj = bpy.data.objects.new("AttrCurves", curves)
    scene.collection.objects.link(obj)
    n_attr = 1
hs.make_camera(location=(0.0, -3.0, 0.15), target=(0.0, 0.0, 0.15), kind="ORTHO", ortho_scale=2.0)

r = {eng: px.reshape(-1, 4) for eng, px in render_engines(scene, "emission_").items()}
assert engine.LAST_RENDER.get("status") == "ok", engine.LAST_RENDER
cy, ours = r["CYCLES"], r["HAIRBSDF"]
covered = (cy[:, 3] > 0.999) & (ours[:, 3] > 0.999)
c, o = cy[covered, :3], ours[covered, :3]
rel = np.abs(o - c) / np.maximum(np.abs(c), 1e-3)
emit({"version": bpy.app.version_string, "covered": int(covered.sum()),
      "alpha_mismatch": int(((cy[:, 3] > 0.5) != (ours[:, 3] > 0.5)).sum()),
      "median": float(np.median(rel)), "p99": float(np.percentile(rel, 99)), "max": float(rel.max()),
      "cycles_mean": float(c.mean()), "ours_mean": float(o.mean()), "attributes": n_attr,
      "warnings": engine.LAST_RENDER.get("warnings", [])})
'''


def test_emission_networks_match_cycles_per_pixel(run_blender, engine_kind, renderer_available):
    need_renderer(engine_kind, renderer_available)
    r = run_blender(engine_kind, EMISSION, args={"w": 240, "h": 240}).result
    record(f"shading_network_emission_{ENGINE_KINDS[engine_kind]}", r)
    summary = (f"{r['version']}: {r['covered']} covered pixels, median {r['median']:.1e} p99 {r['p99']:.1e} "
               f"max {r['max']:.1e}, mean Cycles {r['cycles_mean']:.5f} ours {r['ours_mean']:.5f}, "
               f"{r['alpha_mismatch']} coverage mismatches")
    print("\n" + summary)
    assert r["covered"] > 2000, summary
    assert not r["warnings"], r["warnings"]
    assert r["median"] <= 1e-4 and r["p99"] <= 2e-3, summary


# ---------------------------------------------------------------------------- Image Texture

IMAGE_COMMON = EMISSION_COMMON + r'''

def make_images():
    """An 8 x 4 float EXR (alpha 0.4..1, premultiplied as Blender stores float buffers) and the
    same colours as an 8-bit sRGB PNG (straight alpha): every texel differs from its neighbours."""
    w, h = 8, 4
    c = np.arange(w)[None, :] + np.zeros((h, 1))
    r = np.arange(h)[:, None] + np.zeros((1, w))
    rgba = np.stack([0.1 + 0.8 * ((c * 5 + r * 3) % 8) / 7, 0.15 + 0.7 * r / 3,
                     0.2 + 0.7 * ((c * 3 + r * 7) % 11) / 10, 0.4 + 0.6 * ((c + 2 * r) % 5) / 4], -1)
    rgba = rgba.astype(np.float32)  # rows bottom first, as Blender's pixel buffers
    out = {}
    for name, fmt, is_float in (("tex.exr", "OPEN_EXR", True), ("tex.png", "PNG", False)):
        img = bpy.data.images.new(name, w, h, alpha=True, float_buffer=is_float)
        img.pixels.foreach_set(rgba.ravel())
        img.filepath_raw = os.path.join(TMP, name)
        img.file_format = fmt
        img.save()
        out[name] = bpy.data.images.load(os.path.join(TMP, name), check_existing=False)
    return out

def curves_with_uv(scene, name, lines, radius, material, uvs, attr="surface_uv_coordinate", more=()):
    """A Curves object with real curve data (the geometry-nodes helper of scene_lib, applied, so
    that 3.4 can hold attributes set from Python) and a 2D-vector curve attribute `attr`."""
    obj = lib.curves_from_polylines(scene, name, lines, radius, material)
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.modifier_apply(modifier=obj.modifiers[0].name)
    for an, values in ((attr, uvs),) + tuple(more):
        a = obj.data.attributes.new(an, "FLOAT2", "CURVE")
        a.data.foreach_set("vector", np.asarray(values, np.float32).ravel())
    return obj

def image_node(nt, image, interpolation="Linear", extension="REPEAT"):
    t = nt.nodes.new("ShaderNodeTexImage")
    t.image = image
    t.interpolation = interpolation
    t.extension = extension
    return t

def swept_vector(nt, uv_socket, lo, hi):
    """(Map Range(Intercept: 0..1 -> lo..hi), UV.y, 0): the lookup sweeps u along each strand."""
    info = nt.nodes.new("ShaderNodeHairInfo")
    mr = nt.nodes.new("ShaderNodeMapRange")
    mr.inputs["To Min"].default_value = lo; mr.inputs["To Max"].default_value = hi
    mr.clamp = False
    nt.links.new(info.outputs["Intercept"], mr.inputs["Value"])
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    nt.links.new(uv_socket, sep.inputs["Vector"])
    comb = nt.nodes.new("ShaderNodeCombineXYZ")
    nt.links.new(mr.outputs["Result"], comb.inputs["X"]); nt.links.new(sep.outputs["Y"], comb.inputs["Y"])
    return comb.outputs["Vector"]
'''

IMAGE_EMISSION = IMAGE_COMMON + r'''
hb = register_engine()
from hairbsdf.blender import engine
W, H = ARGS["w"], ARGS["h"]
scene = emission_scene(W, H)
images = make_images()

# Curves: per material 3 horizontal strands whose surface_uv_coordinate v sits between texel
# centres, at an edge and outside the image; u is swept along the strand (Intercept) from
# outside left to outside right, through every texel. The Vector is (swept u, UV.y, 0).
cases = [("LinearRepeat", "Linear", "REPEAT"), ("ClosestExtend", "Closest", "EXTEND"),
         ("LinearClip", "Linear", "CLIP"), ("CubicRepeat", "Cubic", "REPEAT"), ("ClosestRepeat", "Closest", "REPEAT")]
if V >= (3, 5, 0):
    cases.append(("LinearMirror", "Linear", "MIRROR"))
cases.append(("MappingPoint", "Linear", "REPEAT"))  # a Mapping node (Point) between the vector and the image
cases.append(("PNGLinear", "Linear", "REPEAT"))  # 8-bit sRGB: Cycles interpolates the encoded values
# (PNGLinear also uses the Alpha output: the 8-bit association, then unassociation and decoding)
vs = [(-0.05, 0.37, 0.93), (-0.3, 0.5, 1.12), (0.01, 0.62, 0.99)]
Z0, DZ, DS = 1.1, 0.18, 0.055  # first row, rows per material, strands within one
z = Z0
for k, (name, interp, ext) in enumerate(cases):
    m, nt, e = emission_material(name)
    tc = nt.nodes.new("ShaderNodeTexCoord")
    t = image_node(nt, images["tex.png" if name.startswith("PNG") else "tex.exr"], interp, ext)
    # u from -1.25 (Cycles' frac at a negative integer: u * 8 = -10) to 2.1
    vector = swept_vector(nt, tc.outputs["UV"], -1.25, 2.1)
    if name == "MappingPoint":
        mp = nt.nodes.new("ShaderNodeMapping"); mp.vector_type = "POINT"
        mp.inputs["Location"].default_value = (0.1, -0.3, 0.0)
        mp.inputs["Rotation"].default_value = (0.0, 0.0, 0.4)
        mp.inputs["Scale"].default_value = (1.3, 0.8, 1.0)
        nt.links.new(vector, mp.inputs["Vector"])
        vector = mp.outputs["Vector"]
    nt.links.new(vector, t.inputs["Vector"])
    nt.links.new(t.outputs["Color"], e.inputs["Color"])
    if name == "PNGLinear":
        nt.links.new(t.outputs["Alpha"], e.inputs["Strength"])
    lines = [[(-0.9 + 1.8 * i / 6, 0.0, z - DS * j) for i in range(7)] for j in range(3)]
    curves_with_uv(scene, name, lines, 0.02, m, [(0.3, v) for v in vs[k % 3]])
    z -= DZ
# Vector unlinked (Cycles' default: the UV), Color and Alpha (the alpha output unassociates).
m, nt, e = emission_material("DefaultUVAlpha")
t = image_node(nt, images["tex.exr"])
nt.links.new(t.outputs["Color"], e.inputs["Color"]); nt.links.new(t.outputs["Alpha"], e.inputs["Strength"])
lines = [[(-0.9 + 1.8 * i / 6, 0.0, z - DS * j) for i in range(7)] for j in range(3)]
curves_with_uv(scene, "DefaultUVAlpha", lines, 0.02, m, [(0.07, 0.81), (0.5, 0.5), (0.93, 0.12)])
z -= DZ
# A UV Map node naming a second 2D-vector attribute, the 8-bit sRGB PNG, Closest (exact).
m, nt, e = emission_material("NamedMapPNG")
uvm = nt.nodes.new("ShaderNodeUVMap"); uvm.uv_map = "second"
t = image_node(nt, images["tex.png"], "Closest", "REPEAT")
nt.links.new(swept_vector(nt, uvm.outputs["UV"], -0.2, 1.2), t.inputs["Vector"])
nt.links.new(t.outputs["Color"], e.inputs["Color"])
lines = [[(-0.9 + 1.8 * i / 6, 0.0, z - DS * j) for i in range(7)] for j in range(3)]
curves_with_uv(scene, "NamedMapPNG", lines, 0.02, m, [(0.0, 0.0)] * 3,
               more=(("second", [(0.0, 0.1), (0.0, 0.45), (0.0, 0.8)]),))
# Particle hair: the emitter's UV at the root (Texture Coordinate > UV, Linear), and a UV Map
# node naming the emitter's second UV layer (Closest, on interpolated children), on vertical
# strands seen edge-on.
bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0.0, 0.0, -1.02))
em = bpy.context.active_object
me = em.data
# the emitter's shape in its mesh (a non-uniform object scale would keep Cycles' curves in
# object space, elliptical in world space: not what this test is about)
co = np.empty(len(me.vertices) * 3, np.float32); me.vertices.foreach_get("co", co)
me.vertices.foreach_set("co", (co.reshape(-1, 3) * np.array([1.8, 0.3, 1.0], np.float32)).ravel())
second = me.uv_layers.new(name="Second")
uv0 = np.empty(len(me.uv_layers[0].data) * 2, np.float32); me.uv_layers[0].data.foreach_get("uv", uv0)
second.data.foreach_set("uv", (uv0 * np.float32(0.5) + np.float32(0.6)).astype(np.float32))
for name, source, interp in (("ParticleUV", None, "Linear"), ("ParticleNamed", "Second", "Closest")):
    m, nt, e = emission_material(name)
    t = image_node(nt, images["tex.exr"], interp, "REPEAT")
    if source is not None:
        uvm = nt.nodes.new("ShaderNodeUVMap"); uvm.uv_map = source
        nt.links.new(uvm.outputs["UV"], t.inputs["Vector"])
    else:
        tc = nt.nodes.new("ShaderNodeTexCoord")
        nt.links.new(tc.outputs["UV"], t.inputs["Vector"])
    nt.links.new(t.outputs["Color"], e.inputs["Color"])
    me.materials.append(m)
for k in range(2):
    ps = lib.particle_hair(scene, em, f"PH{k}", count=25, length=0.3, seed=7 + k, material_slot=k + 1,
                           radius=0.008)
    ps.settings.use_advanced_hair = False
    ps.settings.hair_length = 0.3
    if k == 1:  # interpolated children: their UVs come from uv_on_emitter too
        ps.settings.child_type = "INTERPOLATED"
        ps.settings.rendered_child_count = 2
hs.make_camera(location=(0.0, -3.0, 0.0), target=(0.0, 0.0, 0.0), kind="ORTHO", ortho_scale=2.4)

r = render_engines(scene, "image_")
assert engine.LAST_RENDER.get("status") == "ok", engine.LAST_RENDER
cy, ours = r["CYCLES"], r["HAIRBSDF"]
covered = (cy[..., 3] > 0.999) & (ours[..., 3] > 0.999)
rel = np.abs(ours[..., :3] - cy[..., :3]) / np.maximum(np.abs(cy[..., :3]), 1e-3)
rel_px = np.where(covered, rel.max(-1), 0.0)
# per band of rows (one material each, from the top; the particle hair at the bottom)
bands = {}
zc = Z0
for name in [c[0] for c in cases] + ["DefaultUVAlpha", "NamedMapPNG"]:
    rows = slice(int((1.2 - (zc + 0.02)) / 2.4 * H), int((1.2 - (zc - 2 * DS - 0.02)) / 2.4 * H) + 1)
    cov = covered[::-1][rows]
    vals = rel_px[::-1][rows][cov]
    bands[name] = {"covered": int(cov.sum()), "median": float(np.median(vals)) if vals.size else None,
                   "p99": float(np.percentile(vals, 99)) if vals.size else None,
                   "max": float(vals.max()) if vals.size else None}
    zc -= DZ
rows = slice(int((1.2 - (-0.7)) / 2.4 * H), H)
cov = covered[::-1][rows]; vals = rel_px[::-1][rows][cov]
bands["particles"] = {"covered": int(cov.sum()), "median": float(np.median(vals)) if vals.size else None,
                      "p99": float(np.percentile(vals, 99)) if vals.size else None,
                      "max": float(vals.max()) if vals.size else None}
c, o = cy[covered][:, :3], ours[covered][:, :3]
rr = rel[covered].ravel()
emit({"version": bpy.app.version_string, "covered": int(covered.sum()),
      "alpha_mismatch": int(((cy[..., 3] > 0.5) != (ours[..., 3] > 0.5)).sum()),
      "median": float(np.median(rr)), "p99": float(np.percentile(rr, 99)), "max": float(rr.max()),
      "cycles_mean": float(c.mean()), "ours_mean": float(o.mean()), "bands": bands,
      "warnings": engine.LAST_RENDER.get("warnings", [])})
'''


def test_image_texture_emission_matches_cycles_per_pixel(run_blender, engine_kind, renderer_available):
    """Image Texture on curve UVs per pixel: every interpolation and extension mode on a swept
    lookup, the default UV (Vector unlinked) with the Alpha output, a named UV map on an 8-bit
    sRGB PNG, and particle hair's emitter UVs (active and named layer), against Cycles."""
    need_renderer(engine_kind, renderer_available)
    r = run_blender(engine_kind, IMAGE_EMISSION, args={"w": 240, "h": 240}).result
    record(f"shading_network_image_{ENGINE_KINDS[engine_kind]}", r)
    summary = (f"{r['version']}: {r['covered']} covered pixels, median {r['median']:.1e} p99 {r['p99']:.1e} "
               f"max {r['max']:.1e}, mean Cycles {r['cycles_mean']:.5f} ours {r['ours_mean']:.5f}, "
               f"{r['alpha_mismatch']} coverage mismatches; bands {r['bands']}")
    print("\n" + summary)
    assert r["covered"] > 2000, summary
    assert not r["warnings"], r["warnings"]
    for name, b in r["bands"].items():
        assert b["covered"] > 100, (name, summary)
    assert r["median"] <= 1e-4 and r["p99"] <= 2e-3, summary


IMAGE_MESH = IMAGE_COMMON + r'''
hb = register_engine()
from hairbsdf.blender import engine
W, H = ARGS["w"], ARGS["h"]
scene = emission_scene(W, H)
images = make_images()
# Two emissive quads facing the camera: the left one reads the active-render UV map
# (Texture Coordinate > UV, Linear), the right one a second, rotated and scaled UV map through
# a UV Map node (Closest, REPEAT: texels outside 0..1 too), and is mirrored (scale x -1: the
# exporter reverses its corners, UVs included).
for k, (name, source, interp) in enumerate((("MeshUV", None, "Linear"), ("MeshNamedUV", "Second", "Closest"))):
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(-0.55 + 1.1 * k, 0.0, 0.0), rotation=(1.5708, 0.0, 0.0))
    quad = bpy.context.active_object
    if source is not None:
        quad.scale = (-1.0, 1.0, 1.0)
    me = quad.data
    uv0 = np.empty(len(me.uv_layers[0].data) * 2, np.float32); me.uv_layers[0].data.foreach_get("uv", uv0)
    second = me.uv_layers.new(name="Second")
    c, s = np.cos(0.5), np.sin(0.5)
    uv2 = uv0.reshape(-1, 2) @ np.array([[c, s], [-s, c]], np.float32) * np.float32(1.7) + np.float32(0.3)
    second.data.foreach_set("uv", uv2.astype(np.float32).ravel())
    m, nt, e = emission_material(name)
    t = image_node(nt, images["tex.exr"], interp, "REPEAT")
    if source is None:
        tc = nt.nodes.new("ShaderNodeTexCoord")
        nt.links.new(tc.outputs["UV"], t.inputs["Vector"])
    else:
        uvm = nt.nodes.new("ShaderNodeUVMap"); uvm.uv_map = source
        nt.links.new(uvm.outputs["UV"], t.inputs["Vector"])
    nt.links.new(t.outputs["Color"], e.inputs["Color"])
    me.materials.append(m)
hs.make_camera(location=(0.0, -3.0, 0.0), target=(0.0, 0.0, 0.0), kind="ORTHO", ortho_scale=2.4)
r = render_engines(scene, "mesh_")
assert engine.LAST_RENDER.get("status") == "ok", engine.LAST_RENDER
cy, ours = r["CYCLES"], r["HAIRBSDF"]
covered = (cy[..., 3] > 0.999) & (ours[..., 3] > 0.999)
rel = np.abs(ours[..., :3] - cy[..., :3]) / np.maximum(np.abs(cy[..., :3]), 1e-3)
out = {"version": bpy.app.version_string, "warnings": engine.LAST_RENDER.get("warnings", []), "quads": {}}
for k, name in enumerate(("MeshUV", "MeshNamedUV")):
    side = np.zeros(W, bool); side[k * W // 2:(k + 1) * W // 2] = True
    sel = covered & side[None, :]
    vals = rel[sel].max(-1)
    out["quads"][name] = {"covered": int(sel.sum()), "median": float(np.median(vals)),
                          "p99": float(np.percentile(vals, 99)), "texel_spread": float(cy[sel][:, :3].std())}
emit(out)
'''


def test_image_texture_on_mesh_uvs_matches_cycles_per_pixel(run_blender, blender_kind, renderer_available):
    """Shading programs on meshes read the mesh's UV maps at the hit (the active-render map and a
    named one), per pixel against Cycles; before mesh UVs were exported they read (0, 0), one
    texel over the whole quad."""
    need_renderer(blender_kind, renderer_available)
    r = run_blender(blender_kind, IMAGE_MESH, args={"w": 192, "h": 96}).result
    print(f"\n[mesh UVs] {r['version']}: {r['quads']}")
    assert r["warnings"] == ["the scene has no hair to render (no visible Curves objects or particle hair)"], \
        r["warnings"]
    for name, q in r["quads"].items():
        assert q["covered"] > 2000 and q["texel_spread"] > 0.05, (name, q)
        assert q["median"] <= 1e-4 and q["p99"] <= 2e-3, (name, q)


WORKING_SPACE = IMAGE_COMMON + r'''
hb = register_engine()
from hairbsdf.blender import engine
W, H = ARGS["w"], ARGS["h"]
scene = emission_scene(W, H)  # a factory-settings file: set the working space after it
bpy.ops.wm.set_working_color_space(working_space=ARGS["working_space"], convert_colors=False)
images = make_images()
images["tex.exr"].colorspace_settings.name = "Linear Rec.709"  # 5.x reads its own float EXRs as sRGB
# Four emissive quads: an 8-bit sRGB PNG and a linear Rec.709 EXR as Emission Color (Cycles
# converts both into the working space); Strength from the PNG's colour through a Map Range
# (the VM's colour -> float, luminance in the working space); Strength from a constant RGB node
# (the same conversion, folded by the exporter).
for k, name in enumerate(("PNG", "EXR", "MapRangeLuminance", "ConstantLuminance")):
    bpy.ops.mesh.primitive_plane_add(size=0.5, location=(-0.9 + 0.6 * k, 0.0, 0.0), rotation=(1.5708, 0.0, 0.0))
    quad = bpy.context.active_object
    m, nt, e = emission_material(name)
    tc = nt.nodes.new("ShaderNodeTexCoord")
    if name in ("PNG", "EXR"):
        t = image_node(nt, images["tex.png" if name == "PNG" else "tex.exr"], "Linear", "REPEAT")
        nt.links.new(tc.outputs["UV"], t.inputs["Vector"])
        nt.links.new(t.outputs["Color"], e.inputs["Color"])
    elif name == "MapRangeLuminance":
        t = image_node(nt, images["tex.png"], "Closest", "REPEAT")
        nt.links.new(tc.outputs["UV"], t.inputs["Vector"])
        mr = nt.nodes.new("ShaderNodeMapRange")
        mr.inputs["To Min"].default_value = 0.2; mr.inputs["To Max"].default_value = 1.5
        nt.links.new(t.outputs["Color"], mr.inputs["Value"])
        nt.links.new(mr.outputs["Result"], e.inputs["Strength"])
    else:
        c = nt.nodes.new("ShaderNodeRGB"); c.outputs[0].default_value = (0.1, 0.2, 0.9, 1.0)
        nt.links.new(c.outputs[0], e.inputs["Strength"])
    quad.data.materials.append(m)
# Strands below the quads whose Emission Color is a byte colour attribute: Cycles 5.3 renders the same
# values in every working space (its kernel's Rec.709 conversion of byte attributes does not reach
# hair attributes), while Blender's `color` is in the working space: the exporter decodes the bytes.
m, nt, e = emission_material("ByteColor")
at = nt.nodes.new("ShaderNodeAttribute"); at.attribute_name = "col"
nt.links.new(at.outputs["Color"], e.inputs["Color"])
lines = [[(-1.0 + 0.2 * k, 0.0, -0.42 - 0.06 * j) for k in range(11)] for j in range(3)]
obj = lib.curves_from_polylines(scene, "ByteColorHair", lines, 0.025, m)
with bpy.context.temp_override(object=obj, active_object=obj):
    bpy.ops.object.modifier_apply(modifier=obj.modifiers[0].name)
col = obj.data.attributes.new("col", "BYTE_COLOR", "POINT")
n = len(col.data)
srgb = np.stack([0.2 + 0.7 * (np.arange(n) % 5) / 4, 0.9 - 0.6 * (np.arange(n) % 3) / 2,
                 0.1 + 0.8 * (np.arange(n) % 7) / 6, np.ones(n)], -1).astype(np.float32)
col.data.foreach_set("color_srgb", srgb.ravel())
hs.make_camera(location=(0.0, -3.0, 0.0), target=(0.0, 0.0, 0.0), kind="ORTHO", ortho_scale=2.4)
r = render_engines(scene, "ws_")
assert engine.LAST_RENDER.get("status") == "ok", engine.LAST_RENDER
cy, ours = r["CYCLES"], r["HAIRBSDF"]
covered = (cy[..., 3] > 0.999) & (ours[..., 3] > 0.999)
rel = np.abs(ours[..., :3] - cy[..., :3]) / np.maximum(np.abs(cy[..., :3]), 1e-3)
out = {"version": bpy.app.version_string, "working_space": bpy.data.colorspace.working_space,
       "warnings": engine.LAST_RENDER.get("warnings", []), "quads": {}}
quad_rows = np.zeros(H, bool); quad_rows[H // 4:3 * H // 4] = True  # z in [-0.3, 0.3]
regions = {name: quad_rows[:, None] & (np.arange(W) // (W // 4) == k)[None, :]
           for k, name in enumerate(("PNG", "EXR", "MapRangeLuminance", "ConstantLuminance"))}
regions["ByteColorAttribute"] = (np.arange(H) < H // 4)[:, None] & np.ones(W, bool)[None, :]  # row 0: the bottom
for name, region in regions.items():
    sel = covered & region
    vals = rel[sel].max(-1)
    out["quads"][name] = {"covered": int(sel.sum()), "median": float(np.median(vals)),
                          "p99": float(np.percentile(vals, 99)), "cycles_mean": float(cy[sel][:, :3].mean()),
                          "ours_mean": float(ours[sel][:, :3].mean())}
emit(out)
'''


@pytest.mark.parametrize("working_space", ["Linear Rec.709", "Linear Rec.2020", "ACEScg"])
def test_working_space_matches_cycles(run_blender, renderer_available, working_space):
    """Blender 5.x's working colour space (File > Color Management): Cycles renders in it, so it
    converts sRGB and linear Rec.709 images into it and weighs colour -> float conversions by its
    luminance; a hair curve's byte colour attribute is rendered as its sRGB-decoded bytes in every
    working space (Blender's `color` property, in the working space, made the strands' median error
    0.36). Per pixel against Cycles 5.3, Linear Rec.709 as the reference case; the exporter read images
    as Rec.709 and used Rec.709's luminance before."""
    need_renderer("bpy5", renderer_available)
    r = run_blender("bpy5", WORKING_SPACE, args={"w": 192, "h": 96, "working_space": working_space}).result
    print(f"\n[working space] {r['version']} {r['working_space']}: {r['quads']}")
    assert r["working_space"] == working_space
    assert not r["warnings"], r["warnings"]
    for name, q in r["quads"].items():
        assert q["covered"] > 300, (name, q)
        assert q["median"] <= 1e-4 and q["p99"] <= 2e-3, (name, q)


IMAGE_HAIR = IMAGE_COMMON + r'''
hb = register_engine()
from hairbsdf.blender import engine
scene = hs.reset(width=ARGS["w"], height=ARGS["h"], spp=ARGS["spp"], curve_shape="THICK")
images = make_images()
# Principled Hair (Chiang, direct colouring): Color from the image at the strand's UV (Vector
# unlinked), Roughness from the same texel's luminance through a Map Range (colour -> float).
mat = hs.hair_material("ImageHair", parametrization="COLOR", roughness=0.3)
nt = mat.node_tree
ph = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeBsdfHairPrincipled")
t = image_node(nt, images["tex.exr"], "Closest", "REPEAT")
nt.links.new(t.outputs["Color"], fg.node_input(ph, "Color"))
mr = nt.nodes.new("ShaderNodeMapRange")
mr.inputs["To Min"].default_value = 0.2; mr.inputs["To Max"].default_value = 0.6
nt.links.new(t.outputs["Color"], mr.inputs["Value"])
nt.links.new(mr.outputs["Result"], fg.node_input(ph, "Roughness"))
# three groups of 8 vertical strands; group g's UVs fall in the texels where channel g is the
# largest share of the colour (reddest, greenest, bluest), so that each group has its own tint
tex = images["tex.exr"]
px = np.empty(8 * 4 * 4, np.float32); tex.pixels.foreach_get(px)
px = px.reshape(4, 8, 4)  # bottom row first
share = px[..., :3] / px[..., :3].sum(-1, keepdims=True)
rng = np.random.default_rng(3)
for g in range(3):
    order = np.argsort(-share[..., g].ravel())[:3]  # the three texels with the most of channel g
    lines, uvs = [], []
    for k in range(8):
        x = -0.9 + 0.6 * g + 0.065 * k + 0.05
        lines.append([(x, 0.0, 0.8 * i / 5) for i in range(6)])
        r, c = divmod(int(order[k % 3]), 8)
        uvs.append(((c + rng.uniform(0.1, 0.9)) / 8.0, (r + rng.uniform(0.1, 0.9)) / 4.0))
    curves_with_uv(scene, f"Group{g}", lines, 0.028, mat, uvs)
hs.make_camera(location=(0.0, -3.0, 0.4), target=(0.0, 0.0, 0.4), kind="ORTHO", ortho_scale=2.0)
hs.make_light("SUN", energy=2.0, location=(2, -2, 3))
hs.make_light("POINT", energy=60.0, location=(-2, -1.5, 1.5), shadow_soft_size=0.2)
hs.make_light("AREA", energy=20.0, location=(0.3, 2.0, 1.2), target=(0.0, 0.0, 0.4), name="Back", size=1.0)
scene.world = bpy.data.worlds.new("W"); scene.world.use_nodes = False; scene.world.color = (0.05, 0.05, 0.05)
cy = scene.cycles
cy.max_bounces = cy.glossy_bounces = cy.transmission_bounces = cy.diffuse_bounces = 4
out = render_engines(scene)
W = ARGS["w"]
m = (out["CYCLES"][..., 3] > 0.99) & (out["HAIRBSDF"][..., 3] > 0.99)
res = {"version": bpy.app.version_string, "status": engine.LAST_RENDER.get("status"),
       "warnings": engine.LAST_RENDER.get("warnings", []), "n": int(m.sum()), "groups": []}
for g in range(3):
    cols = np.zeros(W, bool); cols[int(W * g / 3):int(W * (g + 1) / 3)] = True
    mg = m & cols[None, :]
    res["groups"].append({"n": int(mg.sum()), "cycles": out["CYCLES"][mg][:, :3].mean(0),
                          "hairbsdf": out["HAIRBSDF"][mg][:, :3].mean(0)})
res["cycles"] = out["CYCLES"][m][:, :3].mean(0)
res["hairbsdf"] = out["HAIRBSDF"][m][:, :3].mean(0)
emit(res)
'''


def test_image_texture_hair_colour_mean_matches_cycles(run_blender, engine_kind, renderer_available):
    """Principled Hair's Color (and Roughness, through a colour -> float conversion) from an
    Image Texture on the strands' UVs, lit and with bounces: the mean colour of each group of
    strands (each on its own part of the image) is within 5 % of Cycles' (test_mean_matches_cycles'
    limit)."""
    need_renderer(engine_kind, renderer_available)
    r = run_blender(engine_kind, IMAGE_HAIR, args={"w": 120, "h": 80, "spp": 64}).result
    record(f"shading_network_image_hair_{ENGINE_KINDS[engine_kind]}", r)
    summary = f"{r['version']}: " + "; ".join(
        f"group {g}: {x['n']} px, Cycles {np.round(x['cycles'], 4).tolist()} ours {np.round(x['hairbsdf'], 4).tolist()}"
        for g, x in enumerate(r["groups"]))
    print("\n" + summary)
    assert r["status"] == "ok" and r["n"] > 300, summary
    assert not r["warnings"], r["warnings"]
    np.testing.assert_allclose(r["hairbsdf"], r["cycles"], rtol=0.05, err_msg=summary)
    for g in r["groups"]:
        np.testing.assert_allclose(g["hairbsdf"], g["cycles"], rtol=0.05, err_msg=summary)


IMAGE_COMPILER = IMAGE_COMMON + r'''
from hairbsdf.blender.export_materials import MaterialTable
from hairbsdf.blender.shading_network import UV_ATTRIBUTE
from hairbsdf import _render

class Report:
    def __init__(self): self.warnings = []
    def warn(self, msg): self.warnings.append(msg)

images = make_images()
gone = bpy.data.images.new("gone", 4, 4); gone.source = "FILE"; gone.filepath = "/nonexistent/gone.png"

def emission(name, image=None, vector=None, **settings):
    m = bpy.data.materials.new(name); m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes): nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial"); e = nt.nodes.new("ShaderNodeEmission")
    e.inputs["Color"].default_value = (0.25, 0.5, 0.75, 1.0)
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    t = nt.nodes.new("ShaderNodeTexImage"); t.name = "Tex"; t.image = image
    for k, v in settings.items():
        setattr(t, k, v)
    if vector is not None:
        vector(nt, t)
    nt.links.new(t.outputs["Color"], e.inputs["Color"])
    return m

def constant_vector(nt, t):  # (2.5 / 8, 1.5 / 4, 0): the centre of texel (2, 1)
    c = nt.nodes.new("ShaderNodeCombineXYZ")
    c.inputs["X"].default_value = 2.5 / 8; c.inputs["Y"].default_value = 1.5 / 4
    nt.links.new(c.outputs["Vector"], t.inputs["Vector"])

def normal_mapping(nt, t):
    tc = nt.nodes.new("ShaderNodeTexCoord"); mp = nt.nodes.new("ShaderNodeMapping"); mp.vector_type = "NORMAL"
    nt.links.new(tc.outputs["UV"], mp.inputs["Vector"]); nt.links.new(mp.outputs["Vector"], t.inputs["Vector"])

def named_map(nt, t):
    uvm = nt.nodes.new("ShaderNodeUVMap"); uvm.uv_map = "Second"
    nt.links.new(uvm.outputs["UV"], t.inputs["Vector"])

mats = [emission("Default", images["tex.exr"]), emission("Box", images["tex.exr"], projection="BOX"),
        emission("NoImage"), emission("MissingFile", gone),
        emission("ConstantVector", images["tex.exr"], constant_vector, interpolation="Closest"),
        emission("NormalMapping", images["tex.exr"], normal_mapping), emission("Named", images["tex.png"], named_map)]
rep = Report()
table = MaterialTable(rep)
res = {}
for m in mats:
    d = table.materials[table.index(m)]
    color = d["closures"][0]["color"]
    res[m.name] = {"color": color, "program": "program" in d, "needs": sorted(table.needs[table.index(m)][1])}
    if isinstance(color, dict):  # a register: its value at a hit
        k = color["register"]
        res[m.name]["color_value"] = _render.eval_program(d["program"], attributes=np.zeros((1, 2, 4), np.float32),
                                                          images=table.attributes.images.images)[0, k:k + 3].tolist()
px = np.empty(8 * 4 * 4, np.float32); images["tex.exr"].pixels.foreach_get(px)
emit({"materials": res, "warnings": rep.warnings, "uv": UV_ATTRIBUTE, "texel_2_1": px.reshape(4, 8, 4)[1, 2].tolist(),
      "exr_colorspace": images["tex.exr"].colorspace_settings.name,
      "images": [im["name"] for im in table.attributes.images.images],
      "srgb": table.attributes.images.srgb_encoded, "attributes": table.attributes.names})
'''


def test_image_texture_compiler(run_blender, engine_kind, renderer_available):
    """What the compiler does with Image Texture settings: the default Vector reads the default
    UV attribute (exported only for such programs), a named UV Map its own, a constant vector
    folds to the texel, no image or a missing file reads Cycles' magenta, and unsupported
    settings (Box projection, a Normal-type Mapping) are warned with the socket value used."""
    need_renderer(engine_kind, renderer_available)
    r = run_blender(engine_kind, IMAGE_COMPILER).result
    mats, warnings, uv = r["materials"], "\n".join(r["warnings"]), r["uv"]
    assert mats["Default"]["program"] and mats["Default"]["needs"] == [uv]
    assert mats["Named"]["program"] and mats["Named"]["needs"] == [uv + "Second"]
    assert not mats["Box"]["program"] and mats["Box"]["color"] == pytest.approx((0.25, 0.5, 0.75))
    assert "'Tex' (Image Texture > Color) (its projection BOX" in warnings
    # the Mapping is warned and its socket value (0, 0, 0) is the lookup vector: a constant (no UV
    # read; the loader folds the lookup)
    assert mats["NormalMapping"]["needs"] == [] and "(Mapping > Vector) (its vector_type NORMAL)" in warnings
    for name in ("NoImage", "MissingFile"):
        assert not mats[name]["program"] and mats[name]["color"] == pytest.approx((1.0, 0.0, 1.0)), name
        assert mats[name]["needs"] == []
    assert "'Tex' has no image; like Cycles, it reads magenta" in warnings
    assert "image 'gone' has no pixels" in warnings
    # a constant vector: the program reads the texel at every hit (the loader folds it, with the
    # VM's own lookup; float EXR, stored premultiplied)
    assert mats["ConstantVector"]["program"] and mats["ConstantVector"]["needs"] == []
    # Blender 5.x reads the float EXR it wrote as sRGB: Blender's pixel buffer is then decoded by
    # OpenColorIO, Cycles' lookup (and ours) by the sRGB formula, 2e-5 apart.
    rel = 1e-6 if r["exr_colorspace"] != "sRGB" else 5e-5
    assert mats["ConstantVector"]["color_value"] == pytest.approx(r["texel_2_1"][:3], rel=rel)
    # each image read once; sRGB files stay encoded (the PNG, and the EXR in 5.x)
    assert len(r["images"]) == 2 and r["srgb"] == [r["exr_colorspace"] == "sRGB", True]
    assert sorted(r["attributes"]) == sorted([uv, uv + "Second"])
