"""Image means per seed of Cycles or the hairbsdf engine with scene.cycles.use_light_tree on and off
(the light-tree numbers of docs/engine.md). Runs with the .venv's bpy:

  .venv/bin/python lab/light_tree_toggle.py ENGINE BLEND [--seeds 0 8] [--spp 8] [--many] [--out DIR]

ENGINE is CYCLES or HAIRBSDF; BLEND e.g. a harness-built scene from build/compare_cache/blend. Writes
DIR/ENGINE_means.json ({"True": [mean per seed], "False": [...]}) and the EXRs into DIR; 128 x 96, 1 thread."""
import argparse
import json
import os

import bpy
import numpy as np

from hairbsdf._constants import ENGINE_ID
from hairbsdf.compare import blender_job as bj

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def add_light(kind, name, loc, energy, target=(0, 0, 0), **props):
    from mathutils import Vector

    data = bpy.data.lights.new(name, kind)
    data.energy = energy
    for k, v in props.items():
        setattr(data, k, v)
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = loc
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = (Vector(target) - Vector(loc)).to_track_quat("-Z", "Y")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("engine", choices=("CYCLES", ENGINE_ID))
    ap.add_argument("blend", help="the .blend to render")
    ap.add_argument("--seeds", type=int, nargs=2, default=(0, 8), metavar=("FIRST", "END"),
                    help="seeds FIRST .. END-1 (default 0 8)")
    ap.add_argument("--spp", type=int, default=8, help="samples per pixel (default 8)")
    ap.add_argument("--many", action="store_true", help="add five lights (three points, a spot, an area)")
    ap.add_argument("--out", default=os.path.join(ROOT, "build", "lab", "light_tree_toggle"),
                    help="output folder (default build/lab/light_tree_toggle)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    bpy.ops.wm.open_mainfile(filepath=os.path.abspath(a.blend), load_ui=False)
    tag = ""
    if a.many:
        tag = "many_"
        add_light("POINT", "P1", (0.3, -0.4, 0.2), 3.0, shadow_soft_size=0.05)
        add_light("POINT", "P2", (-0.5, 0.3, -0.3), 10.0, shadow_soft_size=0.1)
        add_light("POINT", "P3", (0.6, -0.8, -0.5), 20.0, shadow_soft_size=0.2, use_soft_falloff=False)
        add_light("SPOT", "S1", (0.0, -0.9, 0.6), 30.0, shadow_soft_size=0.1, spot_size=0.7, spot_blend=0.3)
        add_light("AREA", "A2", (0.9, 0.5, 0.2), 15.0, size=0.3)
    blends = {}
    for tree in (True, False):
        bpy.context.scene.cycles.use_light_tree = tree
        blends[tree] = os.path.join(a.out, f"{tag}{a.engine}_lt{int(tree)}.blend")
        bpy.ops.wm.save_as_mainfile(filepath=blends[tree], copy=True)
    means = {}
    out_json = os.path.join(a.out, f"{tag}{a.engine}_means.json")
    for tree in (True, False):
        for seed in range(*a.seeds):
            exr = os.path.join(a.out, f"{tag}{a.engine}_lt{int(tree)}_s{seed}.exr")
            job = dict(action="render", blend=blends[tree], engine=a.engine, engine_id=ENGINE_ID, accuracy="CYCLES",
                       seed=seed, spp=a.spp, res=[128, 96], threads=1, osl=False, force_parity=False, exr_out=exr,
                       scenes_dir=os.path.join(ROOT, "plugin", "hairbsdf", "compare", "scenes"),
                       sites=[os.path.join(ROOT, "build", "blender_site", "current")], hair_model=None)
            meta = bj.do_render(job)
            if not meta.get("ok"):
                raise SystemExit(f"render failed: {meta}")
            if bool(bpy.context.scene.cycles.use_light_tree) != tree:
                raise SystemExit("use_light_tree did not stick in the saved .blend")
            img = bpy.data.images.load(exr)
            px = np.array(img.pixels[:], dtype=np.float64).reshape(-1, 4)
            means.setdefault(str(tree), []).append(float(px[:, :3].mean()))
            with open(out_json, "w") as f:
                json.dump(means, f)
    print(f"wrote {out_json}")
    bj.exit_blender_process(0)


if __name__ == "__main__":
    main()
