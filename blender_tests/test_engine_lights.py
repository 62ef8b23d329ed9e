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
