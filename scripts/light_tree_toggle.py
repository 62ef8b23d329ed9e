"""Cycles or the hairbsdf engine with scene.cycles.use_light_tree on and off: image means per seed
(docs/engine.md, ribbons_vs_3d "Session 5 (light tree)"). Run with the .venv's bpy:

  .venv/bin/python scripts/light_tree_toggle.py ENGINE BLEND OUT.json FIRST_SEED END_SEED SPP [many] [WORKDIR]

ENGINE is CYCLES or HAIRBSDF; BLEND e.g. a harness-built scene from build/compare_cache/blend; `many` adds five
lights (points, a spot, an area) to the scene. EXRs go to WORKDIR (default /tmp/lt_tog); 128 x 96, 1 thread."""
import json, os, sys
import numpy as np
import bpy
from hairbsdf.compare import blender_job as bj

engine, blend, out = sys.argv[1], sys.argv[2], sys.argv[3]
seeds = range(int(sys.argv[4]), int(sys.argv[5]))
spp = int(sys.argv[6])
work = sys.argv[8] if len(sys.argv) > 8 else "/tmp/lt_tog"
os.makedirs(work, exist_ok=True)
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# the two blends
bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
tag = ""
if len(sys.argv) > 7 and sys.argv[7] == "many":
    from mathutils import Vector
    tag = "many_"
    sc = bpy.context.scene
    def add(kind, name, loc, energy, target=(0, 0, 0), **props):
        data = bpy.data.lights.new(name, kind)
        data.energy = energy
        for k, v in props.items():
            setattr(data, k, v)
        obj = bpy.data.objects.new(name, data)
        sc.collection.objects.link(obj)
        obj.location = loc
        d = Vector(target) - Vector(loc)
        obj.rotation_mode = "QUATERNION"
        obj.rotation_quaternion = d.to_track_quat("-Z", "Y")
        return obj
    add("POINT", "P1", (0.3, -0.4, 0.2), 3.0, shadow_soft_size=0.05)
    add("POINT", "P2", (-0.5, 0.3, -0.3), 10.0, shadow_soft_size=0.1)
    add("POINT", "P3", (0.6, -0.8, -0.5), 20.0, shadow_soft_size=0.2, use_soft_falloff=False)
    add("SPOT", "S1", (0.0, -0.9, 0.6), 30.0, shadow_soft_size=0.1, spot_size=0.7, spot_blend=0.3)
    add("AREA", "A2", (0.9, 0.5, 0.2), 15.0, size=0.3)
paths = {}
for lt in (True, False):
    bpy.context.scene.cycles.use_light_tree = lt
    p = f"{work}/{tag}{engine}_lt{int(lt)}.blend"
    bpy.ops.wm.save_as_mainfile(filepath=p, copy=True)
    paths[lt] = p
res = {}
for lt in (True, False):
    for s in seeds:
        exr = f"{work}/{tag}{engine}_lt{int(lt)}_s{s}.exr"
        job = dict(action="render", blend=paths[lt], engine=engine, accuracy="CYCLES", seed=s, spp=spp,
                   res=[128, 96], threads=1, osl=False, force_parity=False, exr_out=exr,
                   scenes_dir=os.path.join(ROOT, "plugin", "hairbsdf", "compare", "scenes"),
                   sites=[os.path.join(ROOT, "build", "blender_site", "current")], hair_model=None)
        meta = bj.do_render(job)
        assert meta.get("ok"), meta
        assert bool(bpy.context.scene.cycles.use_light_tree) == lt
        img = bpy.data.images.load(exr)
        px = np.array(img.pixels[:], dtype=np.float64).reshape(-1, 4)
        res.setdefault(str(lt), []).append(float(px[:, :3].mean()))
        with open(out, "w") as f:
            json.dump(res, f)
os._exit(0)
