"""Light units through the whole engine path, per Blender: a grey diffuse plane lit by one
light at a time (sun, point with a radius, spot with a non-uniformly scaled object, area
rectangle, area disk, uniform world), rendered by Cycles and by HAIRBSDF in the same process;
the image means must agree within the Monte Carlo noise.

The renderer's units are calibrated against Cycles 4.5 in blender_tests/render_units from
hand-written scene descriptions; this test checks the exporter's light semantics per
version, in particular Blender 3.4's (Cycles 3.x): area lights at power / (4 area) instead of
power / (pi area), and spot cones with the extra cosine and no object scale
(export_lights.py, docs/engine.md)."""

import numpy as np
import pytest

from blender_env import ENGINE_KINDS, need_renderer, record

pytestmark = pytest.mark.blender

LIGHTS = r'''
import os
hb = register_engine()
from hairbsdf.blender import engine
scene = hs.reset(width=40, height=30, spp=ARGS["spp"], film_transparent=False)
cy = scene.cycles
cy.max_bounces = 0  # direct light only: low noise, the light's units alone
scene.hairbsdf.threads = 2
plane = hs.make_plane(size=4.0)
hs.add_slot(plane, hs.diffuse_material("Grey", (0.5, 0.5, 0.5)))
hs.make_camera(location=(0.0, -2.2, 2.2), target=(0.0, 0.0, 0.0), lens=35.0)
lights = {}
lights["sun"] = hs.make_light("SUN", energy=2.0, location=(1, -1, 2), angle=0.1)
lights["point"] = hs.make_light("POINT", energy=40.0, location=(0.4, -0.3, 0.9), shadow_soft_size=0.2)
spot = hs.make_light("SPOT", energy=60.0, location=(-0.3, -0.2, 1.2), target=(0.1, 0.2, 0.0),
                     spot_size=1.1, spot_blend=0.3, shadow_soft_size=0.1)
spot.scale = (1.0, 0.6, 1.3)
lights["spot_scaled"] = spot
rect = hs.make_light("AREA", energy=30.0, location=(0.2, 0.3, 1.0), target=(0.0, 0.0, 0.0), shape="RECTANGLE",
                     size=0.6)
rect.data.size_y = 0.3
lights["area_rect"] = rect
lights["area_disk"] = hs.make_light("AREA", energy=30.0, location=(-0.2, 0.1, 0.8), target=(0.0, 0.0, 0.0),
                                    shape="DISK", size=0.5)
world = bpy.data.worlds.new("W")
world.use_nodes = False
scene.world = world
out = {}
for name in list(lights) + ["world"]:
    for n, o in lights.items():
        o.hide_render = n != name
    world.color = (0.3, 0.3, 0.3) if name == "world" else (0.0, 0.0, 0.0)
    r = {eng: px[..., :3] for eng, px in render_engines(scene, f"{name}_").items()}
    assert engine.LAST_RENDER.get("status") == "ok", engine.LAST_RENDER
    out[name] = {"cycles": float(r["CYCLES"].mean()), "ours": float(r["HAIRBSDF"].mean()),
                 # noise of the difference of the means, from 2 x 2 pixel blocks (neighbours
                 # see almost the same light, so their differences are mostly noise)
                 "sigma": float(np.sqrt(0.5 * ((r["CYCLES"] - r["HAIRBSDF"])[::2, ::2] -
                                               (r["CYCLES"] - r["HAIRBSDF"])[1::2, 1::2]).var() /
                                        r["CYCLES"][::2, ::2].size))}
emit({"version": bpy.app.version_string, "lights": out})
'''


def test_light_units_match_cycles(run_blender, engine_kind, renderer_available, capsys):
    need_renderer(engine_kind, renderer_available)
    r = run_blender(engine_kind, LIGHTS, args={"spp": 64}).result
    record(f"engine_lights_{ENGINE_KINDS[engine_kind]}", r)
    lines, bad = [], []
    for name, m in r["lights"].items():
        ratio = m["ours"] / m["cycles"]
        lines.append(f"{name:12s} Cycles {m['cycles']:.5f} ours {m['ours']:.5f} ratio {ratio:.4f} "
                     f"(noise {m['sigma'] / m['cycles']:.1e})")
        # 5 sigma of the block estimate, and at least 1 % (the block noise estimate is rough)
        if abs(m["ours"] - m["cycles"]) > max(5.0 * m["sigma"], 0.01 * m["cycles"]):
            bad.append(name)
    with capsys.disabled():
        print(f"\n[light units] {r['version']}:\n  " + "\n  ".join(lines))
    assert not bad, f"{r['version']}: light means differ beyond the noise for {bad}:\n" + "\n".join(lines)
    assert all(np.isfinite(m["ours"]) and m["cycles"] > 1e-3 for m in r["lights"].values())


# Hair lit only by an emissive mesh quad (lab/emissive_mesh_clamp.py's setup, smaller), Clamp
# Direct / Indirect 0.03: low enough to cut Cycles' own light samples (its mean drops by a third
# against Clamp 0), so the engine must match Cycles' contribution sizes, not only their sum.
# Cycles light-samples emissive triangles (3.x: its light distribution, 4.x / 5.x: its light tree)
# and weights BSDF hits of them by MIS; an engine that reaches them by BSDF rays only has rare,
# large contributions that the clamp cuts (0.07 of Cycles' mean at Clamp 1, docs/engine.md). Each engine renders the one scene SEEDS times; the image means over the hair
# pixels are compared with the harness's mean-bias test (metrics.mean_bias, t-critical).
# ARGS["textured"]: the quad's Strength is 30 x (0.5 + U) from its UVs (mean 30, as the constant 30):
# Cycles' emission estimate counts a linked Strength as 1, so Emission Sampling Auto light-samples
# the quad in 4.x; with the estimate at 0 the engine left it to BSDF rays (ratio 0.0035, z -473, bpy 4.5).
EMISSIVE_MESH = r'''
hb = register_engine()
from hairbsdf.blender import engine
scene = hs.reset(width=ARGS["size"][0], height=ARGS["size"][1], spp=ARGS["spp"], film_transparent=True)
cy = scene.cycles
cy.max_bounces = 2
cy.sample_clamp_direct = cy.sample_clamp_indirect = ARGS["clamp"]
scene.hairbsdf.threads = 2
world = bpy.data.worlds.new("W")
world.use_nodes = False
world.color = (0.0, 0.0, 0.0)
scene.world = world
base = hs.make_plane(size=0.8, location=(0.0, 0.0, 0.0), name="Scalp")
hs.add_slot(base, hs.diffuse_material("Skin", (0.2, 0.2, 0.2)))
hs.add_slot(base, hs.hair_material("Hair", melanin=0.2, roughness=0.3))
hs.add_particle_hair(base, count=60, length=0.5, radius_scale=0.02, material_slot=2, seed=3)
base.show_instancer_for_render = False
# a 0.5 m quad above and in front of the hair, facing it, outside the camera's view
lamp = hs.make_plane(size=0.5, location=(0.0, -1.0, 1.5), name="Lamp")
lamp.rotation_euler = (3.83, 0.0, 0.0)
glow = hs.emission_material("Glow", (1.0, 0.9, 0.8), 30.0)
if ARGS["textured"]:
    nt = glow.node_tree
    em = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeEmission")
    uv, xyz, strength = (nt.nodes.new(t) for t in ("ShaderNodeTexCoord", "ShaderNodeSeparateXYZ", "ShaderNodeMath"))
    strength.operation = "MULTIPLY_ADD"
    strength.inputs[1].default_value, strength.inputs[2].default_value = 30.0, 15.0
    nt.links.new(uv.outputs["UV"], xyz.inputs[0])
    nt.links.new(xyz.outputs["X"], strength.inputs[0])
    nt.links.new(strength.outputs[0], em.inputs["Strength"])
hs.add_slot(lamp, glow)
hs.make_camera(location=(0.0, -3.0, 0.3), target=(0.0, 0.0, 0.25))
stacks = {"CYCLES": [], "HAIRBSDF": []}
for seed in range(ARGS["seeds"]):
    cy.seed = seed
    for eng, px in render_engines(scene, f"s{seed}_").items():
        stacks[eng].append(px)
    assert engine.LAST_RENDER.get("status") == "ok", engine.LAST_RENDER
cyc, ours = np.asarray(stacks["CYCLES"]), np.asarray(stacks["HAIRBSDF"])
mask = (cyc[..., 3] > 0.5).all(axis=0) & (ours[..., 3] > 0.5).all(axis=0)
# each render's mean RGB over the hair pixels
emit({"version": bpy.app.version_string, "pixels": int(mask.sum()),
      "cycles": cyc[:, mask, :3].mean(axis=1).tolist(), "ours": ours[:, mask, :3].mean(axis=1).tolist()})
'''


def test_emissive_mesh_light_sampling_with_clamp(run_blender, engine_kind, renderer_available, capsys):
    from hairbsdf.compare import metrics
    need_renderer(engine_kind, renderer_available)
    r = run_blender(engine_kind, EMISSIVE_MESH,
                    args={"size": (48, 36), "spp": 32, "seeds": 4, "clamp": 0.03, "textured": True}).result
    assert r["pixels"] > 50, "too few hair pixels"
    # per-render image means as 1 x 1 images: mean_bias's statistics over the renders
    b = metrics.mean_bias(np.asarray(r["cycles"])[:, None, None, :], np.asarray(r["ours"])[:, None, None, :])
    crit = metrics.mean_bias_critical(b["df"])
    record(f"engine_emissive_mesh_{ENGINE_KINDS[engine_kind]}", {k: b[k] for k in ("mean_a", "mean_b", "rel", "z", "df")})
    line = (f"Cycles {b['mean_a']:.5f} ours {b['mean_b']:.5f} ratio {b['mean_b'] / b['mean_a']:.4f} "
            f"z {b['z']:.2f} (critical {crit:.2f}, relative sigma {b['rel_sigma']:.1e})")
    with capsys.disabled():
        print(f"\n[emissive mesh, textured Strength, clamp 0.03] {r['version']}: {line}")
    # resolving power: a 10 % bias must stand out (the BSDF-only engine was 94 % dark)
    assert b["rel_sigma"] < 0.03, line
    assert abs(b["z"]) < crit, f"{r['version']}: image means differ beyond the noise: {line}"
