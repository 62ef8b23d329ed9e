"""Render time of huang_ellipse (Huang, three aspect ratios) against Cycles 4.5, 2 threads, equal spp.

    .venv/bin/python lab/bench_huang_render.py [--res 320x240] [--spp 32] [--rounds 2] [--before PATH]

Each round renders, each in its own child process and in this order: Cycles (bpy 4.5, the harness
scene with its parity settings; bpy.ops.render.render, sync and BVH build included), ours
(hairbsdf.render.render on the SceneDesc exported once from that scene, BVH build included) and,
with --before, ours again from another build of the module (PATH is put first on sys.path, e.g. a
folder holding main's hairbsdf package and .so files). Alternating makes a busy machine slow all
alike; compare ratios within one run (docs/benchmarks.md, "Huang's stochastic eval").
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))

CYCLES_CHILD = r"""
import importlib, json, os, sys, time
import bpy
import hairbsdf, hairbsdf.blender
from hairbsdf.blender import export_scene as ex
sys.path.insert(0, os.path.join(os.path.dirname(hairbsdf.__file__), "compare", "scenes"))
import scene_lib as lib
import catalog
res, spp, npz = json.loads(sys.argv[-1])
hairbsdf.blender.register()
meta = catalog.SCENES["huang_ellipse"]
scene = lib.reset_scene()
cfg = dict(res=res, spp=spp, seed=0, threads=2, variant=None, osl=False, asset_dir=os.path.dirname(npz))
importlib.import_module(meta["module"]).build(scene, cfg)
if not os.path.exists(npz):
    scene.render.engine = "HAIRBSDF"
    desc, _ = ex.export_scene(bpy.context.evaluated_depsgraph_get(), render=True)
    ex.save_scene(npz, desc)
scene.render.engine = "CYCLES"
scene.render.filepath = os.path.join(os.path.dirname(npz), "cycles.png")
t0 = time.time()
bpy.ops.render.render(write_still=False)
print("@@SECONDS@@", time.time() - t0)
"""

OURS_CHILD = r"""
import json, sys
first = sys.argv[-2]
if first:  # the other build: drop the editable install's finder, which would win over sys.path
    sys.meta_path = [f for f in sys.meta_path if "editable" not in type(f).__module__]
    sys.path.insert(0, first)
import hairbsdf
from hairbsdf.render import render
from hairbsdf.scene_file import load_scene
npz = sys.argv[-1]
desc = load_scene(npz)[0]
o = render(desc, threads=2)
print("@@SECONDS@@", o["stats"]["seconds"], hairbsdf.__file__)
"""


def child(code, args):
    r = subprocess.run([sys.executable, "-c", code] + args, capture_output=True, text=True)
    for line in r.stdout.splitlines():
        if line.startswith("@@SECONDS@@"):
            return line.split()[1:]
    raise SystemExit("child failed:\n" + r.stdout[-2000:] + r.stderr[-4000:])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--res", default="320x240", help="WxH (default 320x240, as docs/benchmarks.md's Huang row)")
    ap.add_argument("--spp", type=int, default=32, help="samples per pixel (default 32)")
    ap.add_argument("--rounds", type=int, default=2, help="alternated rounds (default 2)")
    ap.add_argument("--before", default="", help="a folder put first on sys.path for a second build of ours")
    a = ap.parse_args()
    try:
        res = [int(v) for v in a.res.lower().split("x")]
        assert len(res) == 2 and min(res) > 0
    except (ValueError, AssertionError):
        ap.error("--res: expected WxH with positive integers, e.g. 320x240")
    if a.spp < 1 or a.rounds < 1:
        ap.error("--spp and --rounds: positive integers")
    with tempfile.TemporaryDirectory() as tmp:
        npz = os.path.join(tmp, "huang_ellipse.npz")
        for k in range(a.rounds):
            cycles = float(child(CYCLES_CHILD, [json.dumps([res, a.spp, npz])])[0])
            ours, where = child(OURS_CHILD, ["", npz])
            line = f"round {k + 1}: Cycles {cycles:.2f} s, ours {float(ours):.2f} s (ratio {float(ours) / cycles:.3f})"
            if a.before:
                before, where_b = child(OURS_CHILD, [a.before, npz])
                line += f", before {float(before):.2f} s (ratio {float(before) / cycles:.3f}; {where_b})"
            print(line, flush=True)


if __name__ == "__main__":
    main()
