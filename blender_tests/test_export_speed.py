"""Export speed: 100k strands of Curves (foreach_get + NumPy) and of particle hair (co_hair
per key, the rest vectorised).  The numbers are printed and kept in
build/blender_tests/engine/export_speed_<blender>.json; timing is not asserted (CI machines
vary), only the counts.  Target: 100k Curves strands in <= 1 s."""

import pytest

from blender_env import KINDS, record

pytestmark = pytest.mark.blender

SPEED_SCENE = r'''
import time
from hairbsdf.blender.export_scene import export_scene
scene = hs.reset(width=64, height=48, spp=1)
hs.make_camera(location=(0, -30, 5), target=(0, 0, 0))
# 400 x 250 = 100k curves x 8 keys, realized by geometry nodes
hs.curves_grid("Fur", nx=400, ny=250, size=20.0, n_points=8, length=0.3, radius=0.002)
t = time.perf_counter()
dg = bpy.context.evaluated_depsgraph_get()
t_eval = time.perf_counter() - t
best = None
for _ in range(3):
    desc, rep = export_scene(dg, render=True)
    best = rep.timings["total"] if best is None else min(best, rep.timings["total"])
n_curves = int(desc["curves"]["curve_random"].size)
n_points = int(desc["curves"]["points"].shape[0])

# particle hair: 1000 parents x 100 interpolated children = 100k strands x 9 keys (viewport rules)
hs.reset(width=64, height=48, spp=1)
hs.make_camera(location=(0, -30, 5), target=(0, 0, 0))
plane = hs.make_plane(size=4.0)
ps = hs.add_particle_hair(plane, count=1000, child_type="INTERPOLATED", children_display=100,
                          children_render=100, display_step=3, render_step=3)
if hasattr(ps.settings, "child_percent"):
    ps.settings.child_percent = 100
else:
    ps.settings.child_nbr = 100
t = time.perf_counter()
dg = bpy.context.evaluated_depsgraph_get()
t_peval = time.perf_counter() - t
desc2, rep2 = export_scene(dg, render=False)
emit({"curves": n_curves, "points": n_points, "curves_export_s": best, "curves_depsgraph_s": t_eval,
      "particle_curves": int(desc2["curves"]["curve_random"].size),
      "particle_points": int(desc2["curves"]["points"].shape[0]),
      "particle_export_s": rep2.timings["total"], "particle_depsgraph_s": t_peval,
      "version": bpy.app.version_string})
'''


def test_export_speed(run_blender, blender_kind, capsys):
    out = run_blender(blender_kind, SPEED_SCENE, timeout=300).result
    assert out["curves"] == 100_000 and out["points"] == 800_000
    assert out["particle_curves"] == 100_000 and out["particle_points"] == 900_000
    path = record(f"export_speed_{KINDS[blender_kind]}", out)
    with capsys.disabled():
        print(f"\n[export speed] {out['version']}: Curves 100k strands / 800k keys in {out['curves_export_s']:.3f} s "
              f"(depsgraph {out['curves_depsgraph_s']:.2f} s); particle hair 100k strands / 900k keys in "
              f"{out['particle_export_s']:.3f} s (depsgraph {out['particle_depsgraph_s']:.2f} s) -> {path}")
