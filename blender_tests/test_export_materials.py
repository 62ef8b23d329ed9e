"""Material, world, light, camera and integrator export, in bpy 4.5 and Blender 3.4."""

import math

import numpy as np
import pytest

from hairbsdf import _render
from hairbsdf.blender._common import lookup3_hash_uint2
from hairbsdf.blender.export_scene import load_scene

pytestmark = pytest.mark.blender

MATERIALS_SCENE = r'''
import math
import os
from hairbsdf.blender.export_scene import export_scene, save_scene
V = tuple(bpy.app.version)
scene = hs.reset(width=40, height=30, spp=7)
mats = {}

def new_mat(name):
    m = bpy.data.materials.new(name); m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes): nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    mats[name] = m
    return m, nt, out

# 1. Principled Hair, melanin: Value -> Melanin, RGB -> Tint, Hair Info Random -> Random,
#    Math (its defaults: 0.5 + 0.5) -> Roughness, folded; Noise Texture -> Coat (unsupported:
#    warned, socket value used)
m, nt, out = new_mat("Melanin")
h = nt.nodes.new("ShaderNodeBsdfHairPrincipled"); h.name = "PH"
if hasattr(h, "model"): h.model = "CHIANG"
h.parametrization = "MELANIN"
fg.node_input(h, "Melanin Redness").default_value = 0.3
fg.node_input(h, "Roughness").default_value = 0.21
fg.node_input(h, "Offset").default_value = math.radians(3.0)
val = nt.nodes.new("ShaderNodeValue"); val.outputs[0].default_value = 0.42
nt.links.new(val.outputs[0], fg.node_input(h, "Melanin"))
rgbn = nt.nodes.new("ShaderNodeRGB"); rgbn.outputs[0].default_value = (0.9, 0.5, 0.25, 1.0)
nt.links.new(rgbn.outputs[0], fg.node_input(h, "Tint"))
hi = nt.nodes.new("ShaderNodeHairInfo")
nt.links.new(hi.outputs["Random"], fg.node_input(h, "Random"))
math_node = nt.nodes.new("ShaderNodeMath"); math_node.name = "MyMath"
nt.links.new(math_node.outputs[0], fg.node_input(h, "Roughness"))
fg.node_input(h, "Coat").default_value = 0.13
noise = nt.nodes.new("ShaderNodeTexNoise"); noise.name = "MyNoise"
nt.links.new(noise.outputs["Fac"], fg.node_input(h, "Coat"))
nt.links.new(h.outputs[0], out.inputs["Surface"])

# 2. Mix(0.25) of hair (COLOR, Random socket driven by a Value node) and a red diffuse,
#    added to an emission through Add Shader, with a reroute on the way
m, nt, out = new_mat("Mixed")
h = nt.nodes.new("ShaderNodeBsdfHairPrincipled"); h.parametrization = "COLOR"
if hasattr(h, "model"): h.model = "CHIANG"
fg.node_input(h, "Color").default_value = (0.3, 0.2, 0.1, 1.0)
rv = nt.nodes.new("ShaderNodeValue"); rv.outputs[0].default_value = 0.77
nt.links.new(rv.outputs[0], fg.node_input(h, "Random"))
d = nt.nodes.new("ShaderNodeBsdfDiffuse"); d.inputs["Color"].default_value = (1, 0, 0, 1)
mix = nt.nodes.new("ShaderNodeMixShader"); mix.inputs["Fac"].default_value = 0.25
nt.links.new(h.outputs[0], mix.inputs[1]); nt.links.new(d.outputs[0], mix.inputs[2])
e = nt.nodes.new("ShaderNodeEmission"); e.inputs["Color"].default_value = (0, 0, 1, 1); e.inputs["Strength"].default_value = 2.5
add = nt.nodes.new("ShaderNodeAddShader")
rr = nt.nodes.new("NodeReroute")
nt.links.new(mix.outputs[0], rr.inputs[0]); nt.links.new(rr.outputs[0], add.inputs[0]); nt.links.new(e.outputs[0], add.inputs[1])
nt.links.new(add.outputs[0], out.inputs["Surface"])

# 3. Mix Fac from a Value node (0.6): absorption hair vs legacy Hair BSDF (Transmission, linked Tangent)
m, nt, out = new_mat("FacLinked")
h = nt.nodes.new("ShaderNodeBsdfHairPrincipled"); h.parametrization = "ABSORPTION"
if hasattr(h, "model"): h.model = "CHIANG"
fg.node_input(h, "Absorption Coefficient").default_value = (0.1, 0.2, 0.3)
old = nt.nodes.new("ShaderNodeBsdfHair"); old.name = "OldHair"; old.component = "Transmission"
old.inputs["Color"].default_value = (0.5, 0.4, 0.3, 1.0); old.inputs["Offset"].default_value = 0.1
fg.node_input(old, "RoughnessU").default_value = 0.3; fg.node_input(old, "RoughnessV").default_value = 0.7
tan = nt.nodes.new("ShaderNodeTangent"); nt.links.new(tan.outputs[0], fg.node_input(old, "Tangent"))
mix = nt.nodes.new("ShaderNodeMixShader")
fv = nt.nodes.new("ShaderNodeValue"); fv.outputs[0].default_value = 0.6
nt.links.new(fv.outputs[0], mix.inputs["Fac"])
nt.links.new(h.outputs[0], mix.inputs[1]); nt.links.new(old.outputs[0], mix.inputs[2])
nt.links.new(mix.outputs[0], out.inputs["Surface"])

# 4. unsupported closure
m, nt, out = new_mat("Glossy")
g = nt.nodes.new("ShaderNodeBsdfGlossy"); g.name = "ShinyThing"
nt.links.new(g.outputs[0], out.inputs["Surface"])

# 5. Huang (4.x only)
if V >= (4, 0, 0):
    m, nt, out = new_mat("Huang")
    h = nt.nodes.new("ShaderNodeBsdfHairPrincipled"); h.model = "HUANG"; h.name = "HuangNode"
    h.parametrization = "MELANIN"
    fg.node_input(h, "Aspect Ratio").default_value = 0.6
    fg.node_input(h, "Secondary Reflection").default_value = 0.4
    fg.node_input(h, "Transmission").default_value = 1.3
    nt.links.new(h.outputs[0], out.inputs["Surface"])

# 6. Principled BSDF (diffuse of Base Color) and a material without nodes
m, nt, out = new_mat("PBSDF")
p = nt.nodes.new("ShaderNodeBsdfPrincipled"); p.inputs["Base Color"].default_value = (0.1, 0.6, 0.2, 1)
nt.links.new(p.outputs[0], out.inputs["Surface"])
nonode = bpy.data.materials.new("NoNodes"); nonode.use_nodes = False; nonode.diffuse_color = (0.2, 0.3, 0.4, 1.0)
mats["NoNodes"] = nonode

# one mesh object per material (plus an empty slot)
for i, (name, mat) in enumerate(mats.items()):
    pl = hs.make_plane(size=0.5, location=(i, 0, 0), name="P_" + name)
    hs.add_slot(pl, mat)
empty_slot = hs.make_plane(size=0.5, location=(0, 3, 0), name="EmptySlot")
empty_slot.data.materials.append(None)
# a smooth-shaded "tent" (two triangles folded along x = 0), scaled non-uniformly
tent_mesh = bpy.data.meshes.new("Tent")
tent_mesh.from_pydata([(-1, -1, 0), (0, -1, 0.5), (0, 1, 0.5), (-1, 1, 0), (1, -1, 0), (1, 1, 0)], [],
                      [(0, 1, 2, 3), (1, 4, 5, 2)])
for poly in tent_mesh.polygons:
    poly.use_smooth = True
tent = bpy.data.objects.new("Tent", tent_mesh)
scene.collection.objects.link(tent)
tent.location = (0, 6, 0)
tent.scale = (1.0, 1.0, 3.0)

# world: Background colour x strength mixed with an Environment texture background
w = bpy.data.worlds.new("W"); scene.world = w; w.use_nodes = True
nt = w.node_tree
for n in list(nt.nodes): nt.nodes.remove(n)
wo = nt.nodes.new("ShaderNodeOutputWorld")
bg = nt.nodes.new("ShaderNodeBackground"); bg.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1); bg.inputs["Strength"].default_value = 1.5
bg2 = nt.nodes.new("ShaderNodeBackground"); bg2.inputs["Color"].default_value = (1, 1, 1, 1)
sky = nt.nodes.new("ShaderNodeTexSky"); sky.name = "MySky"
nt.links.new(sky.outputs[0], bg2.inputs["Color"])
wm = nt.nodes.new("ShaderNodeMixShader"); wm.inputs["Fac"].default_value = 0.5
nt.links.new(bg.outputs[0], wm.inputs[1]); nt.links.new(bg2.outputs[0], wm.inputs[2])
nt.links.new(wm.outputs[0], wo.inputs["Surface"])

# lights
sun = hs.make_light("SUN", energy=3.0, color=(1.0, 0.5, 0.25), angle=math.radians(2.0))
pt = hs.make_light("POINT", location=(1, 2, 3), energy=100.0, shadow_soft_size=0.3)
sp = hs.make_light("SPOT", location=(-1, -2, 2), target=(0, 0, 0), energy=50.0, spot_size=math.radians(40), spot_blend=0.3, shadow_soft_size=0.1)
ar = hs.make_light("AREA", location=(0, 0, 4), energy=20.0, shape="ELLIPSE", size=0.5, size_y=0.25)
if V >= (4, 0, 0):
    pt.data.use_soft_falloff = False
    ar.data.exposure = 1.0

# camera + render settings
cam = hs.make_camera(location=(0, -5, 1), target=(0, 0, 0), lens=35.0, sensor_fit="VERTICAL", shift=(0.1, -0.05))
cam.scale = (2.0, 2.0, 2.0)
cam.data.sensor_height = 20.0
scene.render.resolution_percentage = 50
scene.render.pixel_aspect_x = 2.0
cy = scene.cycles
cy.samples = 7; cy.seed = 5; cy.use_animated_seed = True; scene.frame_current = 3
cy.max_bounces = 6; cy.diffuse_bounces = 2; cy.glossy_bounces = 3; cy.transmission_bounces = 5
cy.transparent_max_bounces = 4; cy.min_light_bounces = 1
cy.pixel_filter_type = "BOX"; cy.filter_width = 0.01
cy.film_exposure = 1.7; cy.light_sampling_threshold = 0.02; cy.blur_glossy = 0.5
cy.use_denoising = True
scene.render.film_transparent = True
scene.cycles_curves.shape = "RIBBONS"; scene.cycles_curves.subdivisions = 3

dg = bpy.context.evaluated_depsgraph_get()
desc, rep = export_scene(dg, render=True)
save_scene(os.path.join(TMP, "m.npz"), desc)
emit({"warnings": rep.all_warnings(), "version": list(V),
      "cam_matrix": [list(r) for r in cam.matrix_world], "sun_z": list(sun.matrix_world.col[2][:3]),
      "spot_z": list(sp.matrix_world.col[2][:3]), "area_matrix": [list(r) for r in ar.matrix_world]})
'''


def _closures(desc, name):
    mats = {m["name"]: m for m in desc["materials"]}
    return mats[name]["closures"]


def test_materials_world_lights_camera(run_blender, blender_kind, tmp_path):
    out = run_blender(blender_kind, MATERIALS_SCENE).result
    desc, _ = load_scene(tmp_path / "m.npz")
    warnings = "\n".join(out["warnings"])
    v = tuple(out["version"])

    # 1. linked inputs
    (c,) = _closures(desc, "Melanin")
    assert c["type"] == "principled_hair" and c["parametrization"] == "MELANIN" and c["model"] == "CHIANG"
    i = c["inputs"]
    assert i["melanin"] == pytest.approx(0.42) and i["melanin_redness"] == pytest.approx(0.3)
    assert i["tint"] == pytest.approx((0.9, 0.5, 0.25))
    assert i["random"] is None                      # Hair Info > Random: per curve
    # a Math node on constants (0.5 + 0.5): a register of the program, folded by the scene loader
    program = {m["name"]: m for m in desc["materials"]}["Melanin"]["program"]
    assert _render.eval_program(program)[0, i["roughness"]["register"]] == 1.0
    assert i["coat"] == pytest.approx(0.13)         # Noise Texture not evaluated: socket value
    assert i["offset"] == pytest.approx(math.radians(3.0))
    assert "'PH' > 'Coat' is driven by 'MyNoise' (Noise Texture > Fac)" in warnings
    assert "MyMath" not in warnings
    assert set(i) == {"color", "melanin", "melanin_redness", "tint", "absorption_coefficient", "roughness",
                      "radial_roughness", "coat", "ior", "offset", "random_color", "random_roughness", "random"}
    # 2. Mix 0.25 + Add, through a reroute
    cl = _closures(desc, "Mixed")
    kinds = [x["type"] for x in cl]
    assert kinds == ["principled_hair", "diffuse", "emission"]
    assert cl[0]["weight"] == pytest.approx((0.75,) * 3) and cl[1]["weight"] == pytest.approx((0.25,) * 3)
    assert cl[0]["inputs"]["random"] == pytest.approx(0.77)   # Value node into Random
    assert cl[0]["inputs"]["color"] == pytest.approx((0.3, 0.2, 0.1))
    assert cl[1]["color"] == pytest.approx((1, 0, 0))
    assert cl[2]["weight"] == pytest.approx((1, 1, 1)) and cl[2]["strength"] == pytest.approx(2.5)
    # 3. Fac from a Value node; legacy Hair BSDF with its sockets, a linked Tangent is warned about
    cl = _closures(desc, "FacLinked")
    assert [x["type"] for x in cl] == ["principled_hair", "cycles_hair"]
    assert cl[0]["weight"] == pytest.approx((0.4,) * 3) and cl[1]["weight"] == pytest.approx((0.6,) * 3)
    assert cl[0]["inputs"]["absorption_coefficient"] == pytest.approx((0.1, 0.2, 0.3))
    assert cl[1]["component"] == "TRANSMISSION" and cl[1]["color"] == pytest.approx((0.5, 0.4, 0.3))
    assert cl[1]["offset"] == pytest.approx(0.1) and cl[1]["roughness_u"] == pytest.approx(0.3)
    assert cl[1]["roughness_v"] == pytest.approx(0.7)
    assert "'OldHair' > 'Tangent' is linked" in warnings
    # 4. unsupported closure named
    assert _closures(desc, "Glossy")[0]["color"] == pytest.approx((0.8,) * 3)
    assert "'ShinyThing' (Glossy BSDF) is not supported" in warnings
    # 5. Huang
    if v >= (4, 0, 0):
        hu = _closures(desc, "Huang")[0]
        assert hu["type"] == "principled_hair" and hu["model"] == "HUANG" and hu["parametrization"] == "MELANIN"
        assert hu["inputs"]["aspect_ratio"] == pytest.approx(0.6)
        assert hu["inputs"]["secondary_reflection"] == pytest.approx(0.4)
        assert hu["inputs"]["transmission"] == pytest.approx(1.3)
        assert hu["inputs"]["reflection"] == pytest.approx(1.0)
        assert "coat" not in hu["inputs"] and "radial_roughness" not in hu["inputs"]
        assert not any("HuangNode" in w for w in warnings)
    # 6. Principled BSDF, no nodes, empty slot
    assert _closures(desc, "PBSDF")[0]["color"] == pytest.approx((0.1, 0.6, 0.2))
    assert _closures(desc, "NoNodes")[0]["color"] == pytest.approx((0.2, 0.3, 0.4))
    assert _closures(desc, "__default__")[0]["color"] == pytest.approx((0.8,) * 3)
    tri_mats = {desc["materials"][k]["name"] for k in desc["meshes"]["triangle_material"]}
    assert {"Melanin", "Mixed", "NoNodes", "__default__"} <= tri_mats
    # 7. corner normals: unit; flat faces = the face normal of the exported triangle; the smooth tent's
    # ridge corners share one normal between its two faces (Cycles' smooth shading N)
    m = desc["meshes"]
    verts, tris = np.asarray(m["vertices"], float), np.asarray(m["triangles"])
    cn = np.asarray(m["triangle_normals"], float).reshape(-1, 3, 3)
    assert cn.shape[0] == tris.shape[0]
    np.testing.assert_allclose(np.linalg.norm(cn, axis=-1), 1.0, atol=1e-5)
    face = np.cross(verts[tris[:, 1]] - verts[tris[:, 0]], verts[tris[:, 2]] - verts[tris[:, 0]])
    face /= np.linalg.norm(face, axis=1, keepdims=True)
    tent = verts[tris].mean(axis=1)[:, 1] > 4.0  # the tent's triangles (y around 6)
    assert tent.sum() == 4
    flat = ~tent
    np.testing.assert_allclose(cn[flat], np.repeat(face[flat][:, None, :], 3, axis=1), atol=1e-5)
    ridge = np.abs(verts[tris[tent]][..., 0]) < 1e-6  # corners on x = 0, (T, 3)
    ridge_normals = cn[tent][ridge]
    assert len(ridge_normals) >= 4  # 2 ridge vertices x 2 faces, more where the diagonal ends on the ridge
    np.testing.assert_allclose(ridge_normals, np.repeat(ridge_normals[:1], len(ridge_normals), axis=0), atol=1e-5)
    # on the ridge the smooth normal is vertical (the two faces mirror each other); faces tilt
    np.testing.assert_allclose(ridge_normals[0], (0, 0, 1), atol=1e-5)
    assert np.all(np.abs(face[tent][:, 0]) > 0.5)

    # world: 0.5 * (0.2,0.4,0.6)*1.5 + 0.5 * (sky: unsupported -> socket value white)
    assert desc["world"]["color"] == pytest.approx(tuple(0.5 * 1.5 * c + 0.5 for c in (0.2, 0.4, 0.6)))
    assert "'MySky'" in warnings

    # lights
    lights = {lt["type"]: lt for lt in desc["lights"]}
    assert set(lights) == {"SUN", "POINT", "SPOT", "AREA"}
    assert lights["SUN"]["strength"] == pytest.approx((3.0, 1.5, 0.75))
    assert lights["SUN"]["angle"] == pytest.approx(math.radians(2.0))
    assert lights["SUN"]["direction"] == pytest.approx(out["sun_z"], abs=1e-6)
    assert lights["POINT"]["position"] == pytest.approx((1, 2, 3)) and lights["POINT"]["radius"] == pytest.approx(0.3)
    assert lights["POINT"]["soft_falloff"] is (v < (4, 0, 0))
    assert lights["SPOT"]["direction"] == pytest.approx([-x for x in out["spot_z"]], abs=1e-6)
    assert lights["SPOT"]["spot_size"] == pytest.approx(math.radians(40)) and lights["SPOT"]["spot_blend"] == pytest.approx(0.3)
    area = lights["AREA"]
    assert area["shape"] == "ELLIPSE" and area["size_x"] == pytest.approx(0.5) and area["size_y"] == pytest.approx(0.25)
    # 4.x: 2^exposure; 3.x: Cycles 3.x area radiance power / (4 area) = 4.x's x pi/4 (export_lights.py)
    assert area["strength"] == pytest.approx((40.0,) * 3 if v >= (4, 0, 0) else (20.0 * math.pi / 4,) * 3)
    assert lights["SPOT"].get("spot_cosine", False) is (v < (4, 0, 0))
    assert all(lt["visible_camera"] is False for lt in desc["lights"])  # Blender's default for new lights
    assert desc["curve_backface_culling"] is (v < (3, 6, 0))
    np.testing.assert_allclose(area["matrix_world"], out["area_matrix"], atol=1e-6)

    # camera: resolution x 50 %, scale removed from the matrix, raw lens values
    cam = desc["camera"]
    assert cam["type"] == "PERSP" and tuple(cam["resolution"]) == (20, 15)
    assert cam["pixel_aspect"] == pytest.approx(0.5)
    assert cam["sensor_fit"] == "VERTICAL" and cam["sensor_height"] == pytest.approx(20.0)
    assert cam["lens"] == pytest.approx(35.0) and cam["shift_x"] == pytest.approx(0.1)
    assert cam["shift_y"] == pytest.approx(-0.05)
    m = np.asarray(out["cam_matrix"])
    np.testing.assert_allclose(cam["matrix_world"][:3, :3] * 2.0, m[:3, :3], atol=1e-6)
    np.testing.assert_allclose(cam["matrix_world"][:3, 3], m[:3, 3], atol=1e-6)

    # integrator
    it = desc["integrator"]
    assert it["samples"] == 7
    assert it["seed"] == lookup3_hash_uint2(3, 5)  # animated seed, frame 3
    assert (it["max_bounces"], it["diffuse_bounces"], it["glossy_bounces"], it["transmission_bounces"],
            it["transparent_bounces"], it["min_light_bounces"]) == (6, 2, 3, 5, 4, 1)
    assert it["filter_type"] == "BOX" and it["filter_width"] == 1.0  # Cycles forces 1 px
    assert it["exposure"] == pytest.approx(1.7) and it["film_transparent"] is True
    assert it["light_sampling_threshold"] == pytest.approx(0.02) and it["filter_glossy"] == pytest.approx(0.5)
    assert it["tilt"] == ("4.2" if v >= (4, 2, 0) else "3.4")
    assert it["light_tree"] is (v >= (4, 0, 0))  # Cycles 4.x: use_light_tree on by default; 3.x has no tree
    assert it["chiang_lcg"] is (v < (3, 6, 0))  # Cycles < 3.6: Chiang's longitudinal numbers from its LCG
    assert it["huang_glass_albedo_table"] == ("5.x" if v >= (5, 0, 0) else "4.x")  # Cycles 5.x's Huang tables
    assert desc["curve_shape"] == "RIBBONS" and desc["curve_subdivisions"] == 3
    assert "Denoising" in warnings
