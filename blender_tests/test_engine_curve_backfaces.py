"""Rays that start inside a 3D curve (THICK): does the tube's inner wall stop them?

Measured with a camera inside a fat strand (radius 0.5) at several distances from its axis,
looking out, in, and along a tangent, in front of a green world: Cycles 3.4.1 never sees the
inner wall (Blender 3.x's Embree 3 is built with BACKFACE_CULLING_CURVES and culls), Cycles
4.5.15 always does (Embree 4 does not cull the Catmull-Rom sweep), except very close to the
wall looking out, where both Embrees miss the hit. The exporter sets curve_backface_culling
for Blender < 3.6 (_blender_versions.CURVE_CULLING_BEFORE); each configuration must show what
Cycles shows.

Shading of such an inner-wall hit (4.5): Cycles' shader_setup_from_ray flips Ng, N and dPdu of
every back-facing hit, curves included, so the Chiang frame's tangent reverses while h stays;
the renderer does the same (integrator.cpp, surface_point). Checked with a hair material,
direct light only: the image mean of a camera inside a fat tube must match Cycles'."""

import numpy as np
import pytest

from blender_env import need_renderer

pytestmark = pytest.mark.blender

INSIDE = r'''
hb = register_engine()
scene = hs.reset(width=8, height=6, spp=1, curve_shape=CURVE_SHAPE, film_transparent=False)
scene.hairbsdf.threads = 2
mat = hs.emission_material("E", (1.0, 0.0, 0.0), 1.0)
hs.curves_grid("Fat", nx=1, ny=1, n_points=6, length=4.0, radius=0.5, material=mat, location=(0, 0, -2))
world = bpy.data.worlds.new("W"); world.use_nodes = False; world.color = (0, 1, 0); scene.world = world
if world.node_tree and "Background" in world.node_tree.nodes:  # 5.x: a world always has its nodes
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 1, 0, 1)
cam = hs.make_camera(location=(0.0, 0.0, 0.0), target=(0.0, 1.0, 0.0), lens=200.0)
out = {}
for frac in (0.0, 0.6, 0.9):
    for name, d in (("out", (0, 1, 0)), ("in", (0, -1, 0)), ("tangent", (1, 0, 0.3))):
        loc = (0.0, frac * 0.5, 0.0)
        hs.look_at(cam, loc, tuple(l + c for l, c in zip(loc, d)))
        seen = ["wall" if px[..., 0].mean() > 0.5 else "world" if px[..., 1].mean() > 0.5 else "mixed"
                for px in render_engines(scene, "inside_").values()]
        out[f"{frac:.1f} {name}"] = seen
emit({"version": bpy.app.version_string, "seen": out})
'''


def test_rays_from_inside_a_tube_as_cycles(run_blender, engine_kind, renderer_available, capsys):
    need_renderer(engine_kind, renderer_available)
    r = run_blender(engine_kind, INSIDE.replace("CURVE_SHAPE", '"THICK"')).result
    with capsys.disabled():
        print(f"\n[inside a tube] {r['version']}: " + ", ".join(f"{k}: Cycles {v[0]}, ours {v[1]}"
                                                              for k, v in r["seen"].items()))
    cycles_sees = {v[0] for v in r["seen"].values()}
    assert cycles_sees == ({"world"} if engine_kind == "blender" else {"wall"}), r["seen"]
    bad = {k: v for k, v in r["seen"].items() if v[0] != v[1]}
    assert not bad, f"{r['version']}: differs from Cycles: {bad}"


def test_linear_3d_curves_are_culled_as_in_cycles_5(run_blender, renderer_available, capsys):
    """Blender 5.x's Linear 3D Curves are Embree's round linear curves, to which Blender's Embree
    build applies back-face culling: from inside a tube Cycles 5.3 sees the world everywhere, and
    so must we (the exporter sets curve_backface_culling for THICK_LINEAR)."""
    need_renderer("bpy5", renderer_available)
    r = run_blender("bpy5", INSIDE.replace("CURVE_SHAPE", '"THICK_LINEAR"')).result
    with capsys.disabled():
        print(f"\n[inside a linear tube] {r['version']}: " + ", ".join(f"{k}: Cycles {v[0]}, ours {v[1]}"
                                                                     for k, v in r["seen"].items()))
    assert {v[0] for v in r["seen"].values()} == {"world"}, r["seen"]
    bad = {k: v for k, v in r["seen"].items() if v[0] != v[1]}
    assert not bad, f"{r['version']}: differs from Cycles: {bad}"


INNER_WALL = r'''
import os
hb = register_engine()
from hairbsdf.blender import engine
scene = hs.reset(width=24, height=16, spp=128, curve_shape="THICK", film_transparent=False)
scene.hairbsdf.threads = 2
scene.cycles.max_bounces = 0
mat = hs.hair_material("Hair", parametrization="MELANIN", melanin=0.2, roughness=0.25, offset=0.08)
hs.curves_grid("Fat", nx=1, ny=1, n_points=6, length=4.0, radius=0.5, material=mat, location=(0, 0, -2))
world = bpy.data.worlds.new("W"); world.use_nodes = False; world.color = (0, 0, 0); scene.world = world
hs.make_camera(location=(0.0, 0.3, -0.4), target=(0.6, -0.2, 0.5), lens=18.0)
hs.make_light("SUN", energy=3.0, location=(0, 0, 0), target=(0.2, 0.4, -1.0))
out = {eng: px[..., :3].mean(axis=2) for eng, px in render_engines(scene).items()}
emit({"version": bpy.app.version_string, "images": out, "status": engine.LAST_RENDER.get("status")})
'''


def test_inner_wall_shading_as_cycles(run_blender, renderer_available, capsys):
    """bpy 4.5 only: Blender 3.4 culls these hits (test above)."""
    need_renderer("bpy", renderer_available)
    r = run_blender("bpy", INNER_WALL).result
    a, b = (np.asarray(r["images"][k]) for k in ("CYCLES", "HAIRBSDF"))
    lit = a > 0.002 * a.max()
    ratio = b[lit] / a[lit]
    med = float(np.median(ratio))
    with capsys.disabled():
        print(f"\n[inner wall] {r['version']}: {lit.sum()} lit pixels, median ours/Cycles {med:.4f}, means "
              f"{b.mean():.4f} / {a.mean():.4f}")
    assert r["status"] == "ok" and lit.sum() > 50
    # Sharp highlights: at 16 spp the pixel-filter sampling alone moved the mean by 4 %; at 128
    # spp both agree within 0.5 %. Without Cycles' back-face flip the mean is 0.44 x Cycles'.
    assert abs(med - 1.0) < 0.02, med
    assert b.mean() == pytest.approx(a.mean(), rel=0.02)
