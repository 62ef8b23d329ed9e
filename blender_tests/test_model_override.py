"""The engine's hair model override (plugin/hairbsdf/blender/model_override.py) in bpy 4.5 and
Blender 3.4: the
material's property group is filled from the model's schema, the exporter replaces each
Principled Hair closure by a `hair_model` closure of the same weight (other closures stay), and
the engine renders it, with a zoo model and with the example plugin; a bad value is an error
that names the parameter."""

import numpy as np
import pytest

from blender_env import need_renderer

pytestmark = pytest.mark.blender

OVERRIDE_SCENE = r'''
import os
import hairbsdf
register_engine()
from hairbsdf.blender import engine
from hairbsdf.blender import model_override as mo
from hairbsdf.blender.export_scene import export_scene

scene = hs.reset(width=24, height=16, spp=4)
hair = hs.hair_material("Hair", parametrization="MELANIN", melanin=0.5, roughness=0.3)
# Mix(0.25) of a Principled Hair and a diffuse: only the hair closure is replaced, weights kept
mixed = bpy.data.materials.new("Mixed"); mixed.use_nodes = True
nt = mixed.node_tree
for n in list(nt.nodes): nt.nodes.remove(n)
out_node = nt.nodes.new("ShaderNodeOutputMaterial")
ph = nt.nodes.new("ShaderNodeBsdfHairPrincipled")
dif = nt.nodes.new("ShaderNodeBsdfDiffuse")
mix = nt.nodes.new("ShaderNodeMixShader"); mix.inputs["Fac"].default_value = 0.25
nt.links.new(ph.outputs[0], mix.inputs[1]); nt.links.new(dif.outputs[0], mix.inputs[2])
nt.links.new(mix.outputs[0], out_node.inputs["Surface"])
hs.curves_grid("Fur", nx=5, ny=4, size=1.0, n_points=6, length=0.8, radius=0.03, material=hair)
hs.curves_grid("Fur2", nx=2, ny=2, size=0.5, n_points=4, length=0.5, radius=0.03, material=mixed)
hs.make_camera(location=(0.0, -3.5, 0.6), target=(0.0, 0.0, 0.4))
hs.make_light("SUN", energy=4.0)
scene.render.engine = "HAIRBSDF"
scene.hairbsdf.threads = 2
out = {"none": [p.name for p in hair.hairbsdf.params]}
# the menu: the zoo's tables' names and titles between None and Plugin
out["menu"] = [list(i[:2]) for i in mo.OVERRIDES]
out["zoo"] = [list(m[:2]) for m in hairbsdf.zoo.zoo_models()]
# the harness's principled_inputs: Roughness from a Math node on constants (0.2 x 1.5) is the scene
# loader's folded number; Melanin from Hair Info > Intercept stays a register
comp = bpy.data.materials.new("Computed"); comp.use_nodes = True
cnt = comp.node_tree
for n in list(cnt.nodes): cnt.nodes.remove(n)
cout = cnt.nodes.new("ShaderNodeOutputMaterial")
cph = cnt.nodes.new("ShaderNodeBsdfHairPrincipled"); cph.parametrization = "MELANIN"
if hasattr(cph, "model"): cph.model = "CHIANG"
cm = cnt.nodes.new("ShaderNodeMath"); cm.operation = "MULTIPLY"
cm.inputs[0].default_value = 0.2; cm.inputs[1].default_value = 1.5
cnt.links.new(cm.outputs[0], fg.node_input(cph, "Roughness"))
cinfo = cnt.nodes.new("ShaderNodeHairInfo")
cnt.links.new(cinfo.outputs["Intercept"], fg.node_input(cph, "Melanin"))
cnt.links.new(cph.outputs[0], cout.inputs["Surface"])
out["computed_inputs"] = mo.principled_inputs(comp)
out["plain_inputs"] = mo.principled_inputs(hair)

def closures(name):
    desc, rep = export_scene(bpy.context.evaluated_depsgraph_get(), render=True)
    return {m["name"]: m["closures"] for m in desc["materials"]}[name]

def render(tag):
    path = os.path.join(TMP, tag + ".exr")
    scene.render.filepath = path
    try:
        bpy.ops.render.render(write_still=True)
    except RuntimeError as exc:
        pass
    px = np.asarray(fg.read_exr_rgba(path)[0]) if os.path.exists(path) else None
    return {"status": engine.LAST_RENDER.get("status"), "errors": engine.LAST_RENDER.get("errors"),
            "mean": None if px is None else px[..., :3].mean(axis=(0, 1))}

out["hair_none"] = closures("Hair")
# the panel's enum fills the parameters from the schema
hair.hairbsdf.override = "epic"
out["epic_items"] = [[p.name, p.kind, p.current()] for p in hair.hairbsdf.params]
out["epic_schema"] = hairbsdf.model_schema("epic")
given = mo.set_override(hair, "epic", params={"roughness": 0.2, "variant": "environment",
                                               "base_color": (0.5, 0.3, 0.2)})
out["given"] = given
out["hair_epic"] = closures("Hair")
mo.set_override(mixed, "kajiya_kay", params={"exponent": 20.0})
out["mixed_kk"] = closures("Mixed")
out["render_epic"] = render("epic")
mo.set_override(hair, "plugin", path=ARGS["kk"], params={"exponent": 25.0, "color": (0.7, 0.5, 0.2)})
out["plugin_items"] = [[p.name, p.kind, p.current()] for p in hair.hairbsdf.params]
out["hair_plugin"] = closures("Hair")
out["render_plugin"] = render("plugin")
hair.hairbsdf.params["exponent"].value = -1.0   # out of the plugin's range [1, 10000]
out["bad_in_range"] = hair.hairbsdf.params["exponent"].in_range()
out["render_bad"] = render("bad")
hair.hairbsdf.override = "NONE"
mixed.hairbsdf.override = "NONE"
out["render_none"] = render("none")
try:
    mo.set_override(hair, "epic", params={"roughnes": 0.2})
    out["unknown"] = None
except ValueError as exc:
    out["unknown"] = str(exc)
# an integer row (no zoo table has one yet): the panel's item holds, ranges and checks a whole number
from hairbsdf._param_docs import INT
item = hair.hairbsdf.params.add()
item.name, item.kind, item.min, item.max = "count", INT, 1, 8
item.assign(3)
out["int_item"] = [item.current(), item.in_range()]
item.number = 9
out["int_out_of_range"] = item.in_range()
try:
    item.assign(2.5)
    out["int_fraction"] = None
except ValueError as exc:
    out["int_fraction"] = str(exc)
emit(out)
'''


def test_override_exports_and_renders(run_blender, blender_kind, renderer_available, kk_plugin):
    need_renderer(blender_kind, renderer_available)
    r = run_blender(blender_kind, OVERRIDE_SCENE, args={"kk": str(kk_plugin)}).result
    assert r["none"] == []
    computed, plain = r["computed_inputs"], r["plain_inputs"]
    assert computed["model"] == "CHIANG" and computed["parametrization"] == "MELANIN"
    assert computed["roughness"] == pytest.approx(0.3, rel=1e-6)  # folded by the loader (folded_material)
    assert set(computed["melanin"]) == {"register"} and computed["random"] is None
    assert set(computed) == set(plain)
    assert plain["melanin"] == pytest.approx(0.5) and plain["roughness"] == pytest.approx(0.3)
    assert r["menu"] == [["NONE", "None"], *r["zoo"], ["plugin", "Plugin"]]
    assert [m[0] for m in r["zoo"]] == ["kajiya_kay", "epic", "scheuermann", "marschner", "deon", "yan_fur"]
    # the items are the schema, at its defaults
    schema = {p["name"]: p for p in r["epic_schema"]}
    assert [i[0] for i in r["epic_items"]] == list(schema)
    for name, kind, value in r["epic_items"]:
        assert kind == schema[name]["type"]
        np.testing.assert_allclose(np.atleast_1d(value) if kind != "choice" else 0,
                                   np.atleast_1d(schema[name]["default"]) if kind != "choice" else 0, rtol=1e-6)
    assert dict((i[0], i[2]) for i in r["epic_items"])["variant"] == "direct"
    # export: principled_hair -> hair_model with the weight and the given values
    assert [c["type"] for c in r["hair_none"]] == ["principled_hair"]
    (c,) = r["hair_epic"]
    assert c["type"] == "hair_model" and c["model"] == "epic" and c["weight"] == [1.0, 1.0, 1.0]
    assert c["params"]["variant"] == "environment"
    np.testing.assert_allclose(c["params"]["roughness"], 0.2, rtol=1e-6)
    np.testing.assert_allclose(c["params"]["base_color"], (0.5, 0.3, 0.2), rtol=1e-6)
    assert set(c["params"]) == set(schema)
    kinds = sorted((m["type"], m["weight"][0]) for m in r["mixed_kk"])
    assert kinds == [("diffuse", 0.25), ("hair_model", 0.75)]
    (p,) = r["hair_plugin"]
    assert p["model"] == "plugin" and p["path"] == str(kk_plugin)
    assert [i[0] for i in r["plugin_items"]] == ["color", "specular_color", "specular", "exponent"]
    np.testing.assert_allclose(p["params"]["exponent"], 25.0)
    # renders: the override changes the image; a bad value is an error naming the parameter
    means = {k: np.asarray(r["render_" + k]["mean"]) for k in ("epic", "plugin", "none")}
    for k in means:
        assert r["render_" + k]["status"] == "ok", r["render_" + k]
        assert np.all(np.isfinite(means[k])) and means[k].sum() > 0
    assert np.abs(means["plugin"] - means["none"]).max() > 0.05 * means["none"].max()
    assert np.abs(means["epic"] - means["none"]).max() > 0.05 * means["none"].max()
    assert r["bad_in_range"] is False
    assert r["render_bad"]["status"] != "ok"
    assert "exponent" in " ".join(r["render_bad"]["errors"] or []), r["render_bad"]
    assert "has no parameter 'roughnes'" in r["unknown"]
    assert r["int_item"] == [3, True] and r["int_out_of_range"] is False
    assert "parameter 'count': expected a whole number, got 2.5" in r["int_fraction"]
