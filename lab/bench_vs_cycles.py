"""Render time of our engine against Cycles 4.5 on the same Blender scenes, equal samples, 2 threads
(issue 29's goals: Chiang <= 0.7x, Huang <= 1.0x; docs/benchmarks.md, "Engine against Cycles").

    .venv/bin/python lab/bench_vs_cycles.py [--scenes bench_hair,swatch] [--model chiang|huang|scene]
                                            [--rounds 3] [--spp N] [--res WxH] [--before DIR] [--embree]
                                            [--per-pixel] [--json F] [--perf]

Scenes: `bench_hair` (blender_tests/render_units: 1500 strands over a plane, sun + world, 160 x 160, 32 spp)
and the harness scenes of plugin/hairbsdf/compare/scenes/catalog.py (`swatch`, `huang_ellipse`, ...), at
bench sizes where sampling takes most of the time (bench_hair 160 x 160, swatch 256 x 192, huang_ellipse
320 x 240, 32 spp each; other scenes their CI size), unless --res / --spp say otherwise. Each is built once in bpy 4.5; `--model huang` (or chiang) then sets every Principled Hair
node's model, so both engines render the same Huang (or Chiang) scene. Our scene is exported from that
Blender scene (the HAIRBSDF exporter) once.

Each round renders every scene in its own child process, Cycles first, then ours, then with --before
ours again from another build of the module (DIR is put first on sys.path: a folder holding another
build's hairbsdf package and .so files). Ours renders with the scene's defaults (the wavefront path tracer, its
Chiang hits through the batch kernels; curve_intersector AUTO, which is SWEEP at these sizes). --embree renders
ours again with curve_intersector EMBREE (Embree's own round curves; docs/engine.md, "Curve intersection"),
--per-pixel again with integrator.wavefront off (the per-pixel loop); both: also the two together, the
configuration before they became the defaults. Per render:
  wall   seconds of the render call: Cycles' bpy.ops.render.render (scene sync, BVH build, sampling),
         ours hairbsdf.render.render (scene checks, BVH build, sampling)
  cpu    user + system CPU seconds of the child over the same call (all threads)
On a shared machine the CPU ratio is the steadier one: a loaded machine stretches wall time, much
less the CPU time a render needs. The table goes to stdout, progress to stderr, the medians
per scene at the end with the goal each model has. Ctrl-C stops the run and prints what was measured.

--perf runs each child under `perf record` (cpu-clock, 499 Hz), switched on only around the render call,
and splits its samples by library: how much of each engine's render is Embree (Cycles' bundled Embree 4,
our Debian Embree 3.13), and "ours' Embree / Cycles' all", the ratio to Cycles our engine would reach if
everything but Embree were free (docs/benchmarks.md, "Embree in both engines"). Needs perf (linux-perf).
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
RENDER_UNITS = os.path.join(ROOT, "blender_tests", "render_units")
GOALS = {"chiang": 0.7, "huang": 1.0}  # issue 29's hard goals, ours / Cycles at equal samples
# (WxH or None for the scene's own, spp): sizes where sampling, not start-up, takes most of the time.
BENCH_SIZE = {"bench_hair": (None, 32), "swatch": ([256, 192], 32), "huang_ellipse": ([320, 240], 32)}

# --perf: the child switches the parent's `perf record` on and off around the render call (its control fifo).
PERF_SWITCH = r"""
import os
def perf_switch(command):
    if os.environ.get("HAIRBSDF_PERF_CTL"):
        with open(os.environ["HAIRBSDF_PERF_CTL"], "w") as f:
            f.write(command + "\n")
        with open(os.environ["HAIRBSDF_PERF_ACK"]) as f:
            f.readline()
"""

# Builds one scene in bpy, exports ours once, then times Cycles' render of it.
CYCLES_CHILD = PERF_SWITCH + r"""
import importlib, json, os, resource, sys, time
import bpy
import hairbsdf, hairbsdf.blender
from hairbsdf.blender import export_scene as ex
name, model, res, spp, npz, render_units = json.loads(sys.argv[-1])
hairbsdf.blender.register()
if name == "bench_hair":
    sys.path.insert(0, render_units)
    import unit_cases as C
    import cycles_render as R
    c = C.case(name)
    scene = R.reset()
    R.settings(scene, c, spp or c["samples"], 2)
    R.build(c)
    if res:
        scene.render.resolution_x, scene.render.resolution_y = res
else:
    sys.path.insert(0, os.path.join(os.path.dirname(hairbsdf.__file__), "compare", "scenes"))
    import scene_lib as lib
    import catalog
    meta = catalog.SCENES[name]
    ci = meta["ci"]
    scene = lib.reset_scene()
    cfg = dict(res=list(res or ci["res"]), spp=spp or ci["spp"], seed=0, threads=2, variant=None, osl=False,
               asset_dir=os.path.dirname(npz))
    importlib.import_module(meta["module"]).build(scene, cfg)
models = set()
for mat in bpy.data.materials:
    for node in (mat.node_tree.nodes if mat.node_tree else []):
        if node.bl_idname == "ShaderNodeBsdfHairPrincipled":
            if model != "scene":
                node.model = model.upper()
            models.add(node.model.lower())
if not os.path.exists(npz):
    scene.render.engine = "HAIRBSDF"
    desc, _ = ex.export_scene(bpy.context.evaluated_depsgraph_get(), render=True)
    ex.save_scene(npz, desc)
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.render.threads_mode = "FIXED"
scene.render.threads = 2
scene.render.filepath = os.path.join(os.path.dirname(npz), "cycles")
perf_switch("enable")
u0 = resource.getrusage(resource.RUSAGE_SELF)
t0 = time.perf_counter()
bpy.ops.render.render(write_still=False)
wall = time.perf_counter() - t0
u1 = resource.getrusage(resource.RUSAGE_SELF)
perf_switch("disable")
cpu = (u1.ru_utime - u0.ru_utime) + (u1.ru_stime - u0.ru_stime)
print("@@RESULT@@", json.dumps(dict(wall=wall, cpu=cpu, models=sorted(models),
                                    samples=scene.cycles.samples,
                                    res=[scene.render.resolution_x, scene.render.resolution_y])))
"""

OURS_CHILD = PERF_SWITCH + r"""
import json, resource, sys, time
first, npz, settings = sys.argv[-3], sys.argv[-2], json.loads(sys.argv[-1])
if first:  # the other build: drop the editable install's finder, which would win over sys.path
    sys.meta_path = [f for f in sys.meta_path if "editable" not in type(f).__module__]
    sys.path.insert(0, first)
import hairbsdf
from hairbsdf.render import render
from hairbsdf.scene_file import load_scene
desc = load_scene(npz)[0]
for key, value in settings.items():  # "curve_intersector", "integrator.wavefront", ...
    where = desc
    *parents, last = key.split(".")
    for parent in parents:
        where = where[parent]
    where[last] = value
perf_switch("enable")
u0 = resource.getrusage(resource.RUSAGE_SELF)
t0 = time.perf_counter()
o = render(desc, threads=2)
wall = time.perf_counter() - t0
u1 = resource.getrusage(resource.RUSAGE_SELF)
perf_switch("disable")
cpu = (u1.ru_utime - u0.ru_utime) + (u1.ru_stime - u0.ru_stime)
print("@@RESULT@@", json.dumps(dict(wall=wall, cpu=cpu, module=hairbsdf.__file__, rays=o["stats"]["rays"])))
"""


def child(code, args, perf_dir=None):
    """Runs a child render; with perf_dir, under `perf record` around its render call, and adds the
    child's samples by library (`perf`: {"samples": all, "embree": Embree's})."""
    command, env = [sys.executable, "-c", code] + args, dict(os.environ)
    if perf_dir:
        ctl, ack, data = (os.path.join(perf_dir, n) for n in ("ctl", "ack", "perf.data"))
        for fifo in (ctl, ack):
            if not os.path.exists(fifo):
                os.mkfifo(fifo)
        env.update(HAIRBSDF_PERF_CTL=ctl, HAIRBSDF_PERF_ACK=ack)
        command = ["perf", "record", "-q", "-e", "cpu-clock", "-F", "499", "-D", "-1",
                   "--control", f"fifo:{ctl},{ack}", "-o", data, "--"] + command
    r = subprocess.run(command, capture_output=True, text=True, env=env)
    for line in r.stdout.splitlines():
        if line.startswith("@@RESULT@@"):
            result = json.loads(line.split(None, 1)[1])
            if perf_dir:
                result["perf"] = samples_by_library(data)
            return result
    raise SystemExit("a child render failed:\n" + r.stdout[-2000:] + r.stderr[-4000:])


def samples_by_library(data):
    """{"samples": the render call's samples, "embree": those in an Embree library} of a perf.data file."""
    report = subprocess.run(["perf", "report", "-i", data, "--sort", "dso", "-n", "--stdio", "-q"],
                            capture_output=True, text=True, check=True).stdout
    total = embree = 0
    for line in report.splitlines():
        parts = line.split()
        if len(parts) >= 3 and parts[0].endswith("%") and parts[1].isdigit():
            total += int(parts[1])
            embree += int(parts[1]) if parts[2].startswith("libembree") else 0
    return dict(samples=total, embree=embree)


def parse_res(text, ap):
    if not text:
        return None
    try:
        res = [int(v) for v in text.lower().split("x")]
        if len(res) != 2 or min(res) < 1:
            raise ValueError
        return res
    except ValueError:
        ap.error(f"--res: expected WxH with positive integers (e.g. 320x240), got {text!r}")


def perf_line(row):
    """One render pair's perf split: Embree's share of each engine's render call, and ours' Embree samples
    over Cycles' samples (the ratio ours would reach if everything else were free)."""
    cy, ours = row["cycles"]["perf"], row["ours"]["perf"]
    share = lambda p: 100.0 * p["embree"] / max(p["samples"], 1)
    return (f"perf: Embree {share(cy):.1f} % of Cycles' {cy['samples']} samples, {share(ours):.1f} % of ours' "
            f"{ours['samples']}; ours / Cycles: all {ours['samples'] / max(cy['samples'], 1):.3f}, Embree "
            f"{ours['embree'] / max(cy['embree'], 1):.3f}, ours' Embree / Cycles' all "
            f"{ours['embree'] / max(cy['samples'], 1):.3f}")


def known_scenes():
    sys.path.insert(0, os.path.join(ROOT, "plugin", "hairbsdf", "compare", "scenes"))
    import catalog  # plain data, no bpy
    return ["bench_hair"] + sorted(catalog.SCENES)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="bench_hair,swatch",
                    help="comma-separated scene names: bench_hair or a catalog scene (default bench_hair,swatch)")
    ap.add_argument("--model", default="scene", choices=["scene", "chiang", "huang"],
                    help="set every Principled Hair node to this model; 'scene' keeps each scene's (default)")
    ap.add_argument("--rounds", type=int, default=3, help="alternated rounds (default 3)")
    ap.add_argument("--spp", type=int, default=0, help="samples per pixel (default: the scene's)")
    ap.add_argument("--res", default="", help="WxH (default: the scene's)")
    ap.add_argument("--before", default="", help="a folder put first on sys.path for a second build of ours")
    ap.add_argument("--embree", action="store_true",
                    help="also render ours with curve_intersector EMBREE (one more column)")
    ap.add_argument("--per-pixel", action="store_true",
                    help="also render ours with integrator.wavefront off (one more column; two with --embree)")
    ap.add_argument("--json", default="", help="also write every measurement to this JSON file")
    ap.add_argument("--perf", action="store_true",
                    help="profile each render call with perf and split it into Embree and the rest")
    a = ap.parse_args(argv)
    scenes = [s for s in a.scenes.split(",") if s]
    allowed = known_scenes()
    for s in scenes:
        if s not in allowed:
            ap.error(f"--scenes: unknown scene {s!r}; allowed: {', '.join(allowed)}")
    if not scenes:
        ap.error("--scenes: give at least one scene")
    if a.rounds < 1 or a.spp < 0:
        ap.error("--rounds must be >= 1 and --spp >= 0")
    if a.before and not os.path.isdir(a.before):
        ap.error(f"--before: {a.before!r} is not a folder")
    res = parse_res(a.res, ap)
    if a.perf and not shutil.which("perf"):
        ap.error("--perf: the perf tool is not installed (Debian: apt-get install linux-perf)")

    # Our renders besides the default one: a column each, scene keys set as given.
    variants = {}
    if a.embree:
        variants["EMBREE"] = {"curve_intersector": "EMBREE"}
    if a.per_pixel:
        variants["per pixel"] = {"integrator.wavefront": False}
        if a.embree:
            variants["EMBREE per pixel"] = {"curve_intersector": "EMBREE", "integrator.wavefront": False}
    rows = []
    print("| round | scene | models | Cycles wall / cpu s | ours wall / cpu s | ours / Cycles: wall / cpu |"
          + (" before wall / cpu s | before / Cycles: cpu |" if a.before else "")
          + "".join(f" {v} wall / cpu s | {v} / Cycles: cpu |" for v in variants))
    print("|---|---|---|---|---|---|" + ("---|---|" if a.before else "") + "---|---|" * len(variants))
    try:
        with tempfile.TemporaryDirectory() as tmp:
            for k in range(a.rounds):
                for name in scenes:
                    npz = os.path.join(tmp, f"{name}_{a.model}.npz")
                    print(f"round {k + 1}/{a.rounds}: {name} (Cycles, ours{', before' if a.before else ''}"
                          f"{''.join(', ' + v for v in variants)})",
                          file=sys.stderr, flush=True)
                    size = BENCH_SIZE.get(name, (None, 0))
                    args = [name, a.model, res or size[0], a.spp or size[1], npz, RENDER_UNITS]
                    perf_dir = tmp if a.perf else None
                    cy = child(CYCLES_CHILD, [json.dumps(args)], perf_dir)
                    ours = child(OURS_CHILD, ["", npz, "{}"], perf_dir)
                    row = dict(round=k + 1, scene=name, models=cy["models"], res=cy["res"], samples=cy["samples"],
                               cycles=cy, ours=ours)
                    line = (f"| {k + 1} | {name} | {'+'.join(cy['models'])} | {cy['wall']:.2f} / {cy['cpu']:.2f} | "
                            f"{ours['wall']:.2f} / {ours['cpu']:.2f} | {ours['wall'] / cy['wall']:.3f} / "
                            f"{ours['cpu'] / cy['cpu']:.3f} |")
                    if a.before:
                        row["before"] = b = child(OURS_CHILD, [a.before, npz, "{}"], perf_dir)
                        line += f" {b['wall']:.2f} / {b['cpu']:.2f} | {b['cpu'] / cy['cpu']:.3f} |"
                    for variant, settings in variants.items():
                        row[variant] = w = child(OURS_CHILD, ["", npz, json.dumps(settings)], perf_dir)
                        line += f" {w['wall']:.2f} / {w['cpu']:.2f} | {w['cpu'] / cy['cpu']:.3f} |"
                    rows.append(row)
                    print(line, flush=True)
                    if a.perf:
                        print("  " + perf_line(row), flush=True)
    except KeyboardInterrupt:
        print("interrupted: the medians below cover the renders measured so far", file=sys.stderr)
    print()
    for name in scenes:
        mine = [r for r in rows if r["scene"] == name]
        if not mine:
            continue
        wall = statistics.median(r["ours"]["wall"] / r["cycles"]["wall"] for r in mine)
        cpu = statistics.median(r["ours"]["cpu"] / r["cycles"]["cpu"] for r in mine)
        models = mine[0]["models"]
        goal = max(GOALS[m] for m in models) if models and all(m in GOALS for m in models) else None
        verdict = "" if goal is None else (f"; goal <= {goal}x: " + ("met" if max(wall, cpu) <= goal else
                                                                      "met in CPU time" if cpu <= goal else "not met"))
        print(f"{name} ({'+'.join(models)}, {mine[0]['res'][0]}x{mine[0]['res'][1]}, {mine[0]['samples']} spp, "
              f"{len(mine)} rounds): median ours / Cycles wall {wall:.3f}, cpu {cpu:.3f}{verdict}")
        for variant, settings in variants.items():
            v_wall = statistics.median(r[variant]["wall"] / r["cycles"]["wall"] for r in mine)
            v_cpu = statistics.median(r[variant]["cpu"] / r["cycles"]["cpu"] for r in mine)
            print(f"  with {', '.join(f'{k} {v}' for k, v in settings.items())}: median ours / Cycles wall "
                  f"{v_wall:.3f}, cpu {v_cpu:.3f}")
        if a.perf:
            floor = statistics.median(r["ours"]["perf"]["embree"] / max(r["cycles"]["perf"]["samples"], 1)
                                      for r in mine)
            print(f"  perf: median ours' Embree / Cycles' all {floor:.3f} (ours / Cycles with free shading)")
    if a.json:
        os.makedirs(os.path.dirname(os.path.abspath(a.json)), exist_ok=True)
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
