"""Image means of Cycles and the hairbsdf engine for one light of a scene at a time, per bounce budget
and seed: the measurement behind docs/engine.md's "Known differences still open" (the Blender 3.4
area-light deficit). Runs inside Blender (Debian's 3.4 or the .venv's bpy):

  blender -b --factory-startup -P scripts/light_isolation.py -- BLEND OUT.json [options]
  .venv/bin/python scripts/light_isolation.py BLEND OUT.json [options]

Options (key=value): light=NAME (keep only this light; 'world' keeps only the world), bounces=0,1,4
(max_bounces values; the other budgets are raised to match), seeds=8, spp=32, engines=CYCLES,HAIRBSDF,
work=/tmp/light_isolation, hair.SOCKET=VALUE (a Principled Hair input in every material, e.g.
hair.Offset=0), cycles.NAME=VALUE (a scene.cycles setting, e.g. cycles.min_light_bounces=64), no_hair=1 (particle hair
and Curves objects off, to see the rest of the scene alone). The world is set to black unless light=world. 128 x 96 unless res=WxH."""
import json
import os
import sys
import time

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
if len(argv) < 2 or argv[0] in ("-h", "--help"):
    print(__doc__)
    sys.exit(0 if argv and argv[0] in ("-h", "--help") else 2)
blend, out_path = argv[0], argv[1]
opts = dict(a.split("=", 1) for a in argv[2:])
light = opts.get("light")
bounces = [int(b) for b in opts.get("bounces", "0,1,4").split(",")]
seeds = int(opts.get("seeds", 8))
spp = int(opts.get("spp", 32))
engines = opts.get("engines", "CYCLES,HAIRBSDF").split(",")
work = opts.get("work", "/tmp/light_isolation")
res = [int(v) for v in opts.get("res", "128x96").split("x")]
os.makedirs(work, exist_ok=True)

site = os.path.join(ROOT, "build", "blender_site", "current")  # the staged module (scripts/setup)
if not getattr(bpy.app, "binary_path", ""):
    site = None  # bpy from the .venv imports the installed hairbsdf
elif site not in sys.path:
    sys.path.insert(0, site)
from hairbsdf.compare import blender_job  # noqa: E402


def image_mean(path):
    img = bpy.data.images.load(path)
    px = img.pixels[:]
    bpy.data.images.remove(img)
    n = len(px) // 4
    return [sum(px[c::4]) / n for c in range(3)]


results = []
for engine in engines:
    for b in bounces:
        for seed in range(seeds):
            bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
            scene = bpy.context.scene
            for obj in list(scene.objects):
                if obj.type == "LIGHT" and (light == "world" or (light and obj.name != light)):
                    bpy.data.objects.remove(obj)
            if light and light != "world" and scene.world is not None and scene.world.node_tree:
                for node in scene.world.node_tree.nodes:
                    if node.type == "BACKGROUND":
                        node.inputs["Strength"].default_value = 0.0
            if opts.get("no_hair") == "1":
                for obj in list(scene.objects):
                    if obj.type == "CURVES":
                        obj.hide_render = True
                    for mod in obj.modifiers:
                        if mod.type == "PARTICLE_SYSTEM":
                            mod.show_render = False
            for key, value in opts.items():
                if key.startswith("hair."):
                    for mat in bpy.data.materials:
                        for node in (mat.node_tree.nodes if mat.node_tree else []):
                            if node.bl_idname == "ShaderNodeBsdfHairPrincipled":
                                node.inputs[key[5:]].default_value = float(value)
            cy = scene.cycles
            cy.max_bounces = b
            for key in ("diffuse_bounces", "glossy_bounces", "transmission_bounces", "volume_bounces"):
                setattr(cy, key, max(b, 0))
            cy.transparent_max_bounces = max(getattr(cy, "transparent_max_bounces", 8), 8)
            for key, value in opts.items():
                if key.startswith("cycles."):
                    old = getattr(cy, key[7:])
                    setattr(cy, key[7:], type(old)(value) if not isinstance(old, str) else value)
            cy.samples = spp
            cy.seed = seed
            scene.render.resolution_x, scene.render.resolution_y = res
            scene.render.resolution_percentage = 100
            scene.render.threads_mode = "FIXED"
            scene.render.threads = 2
            if engine == "HAIRBSDF":
                how, errors = blender_job.ensure_hairbsdf([site])
                if how is None:
                    raise SystemExit("no HAIRBSDF engine: %s" % errors)
            scene.render.engine = engine
            ims = scene.render.image_settings
            ims.file_format = "OPEN_EXR"
            ims.color_depth = "32"
            path = os.path.join(work, "%s_b%d_s%d.exr" % (engine, b, seed))
            scene.render.filepath = path
            t = time.time()
            bpy.ops.render.render(write_still=True)
            results.append(dict(engine=engine, bounces=b, seed=seed, spp=spp, mean=image_mean(path),
                                seconds=time.time() - t))
            print("light_isolation", engine, b, seed, results[-1]["mean"], flush=True)
with open(out_path, "w") as f:
    json.dump(dict(blend=blend, light=light, results=results), f, indent=1)
