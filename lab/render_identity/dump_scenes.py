"""Builds harness scenes (CI size) in bpy and saves each exported SceneDesc (no render):
    python lab/render_identity/dump_scenes.py OUT_DIR"""
import sys, os, importlib
import bpy
import hairbsdf.blender
from hairbsdf.blender import export_scene as ex
scenes_dir = os.path.join(os.path.dirname(hairbsdf.__file__), "compare", "scenes")
sys.path.insert(0, scenes_dir)
import scene_lib as lib
import catalog
hairbsdf.blender.register()
out = sys.argv[1]
os.makedirs(out, exist_ok=True)
cases = [("swatch", None), ("fiber_gonio", "front"), ("fiber_gonio", "back"), ("fiber_gonio_huang", "huang_front"),
         ("mixed", None), ("huang_ellipse", None), ("shading_network", None), ("furnace", None)]
for name, variant in cases:
    meta = catalog.SCENES[name]
    scene = lib.reset_scene()
    ci = meta["ci"]
    cfg = dict(res=list(ci["res"]), spp=ci["spp"], seed=0, threads=2, variant=variant, osl=False, asset_dir=out)
    importlib.import_module(meta["module"]).build(scene, cfg)
    scene.render.engine = "HAIRBSDF"
    dg = bpy.context.evaluated_depsgraph_get()
    desc, report = ex.export_scene(dg, render=True)
    path = os.path.join(out, f"{name}_{variant or 'main'}.npz")
    ex.save_scene(path, desc)
    print("saved", path, [c["type"] for m in desc["materials"] for c in m["closures"]])
