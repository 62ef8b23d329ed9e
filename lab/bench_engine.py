#!/usr/bin/env python3
"""Engine I benchmarks (goals, not tests; docs/benchmarks.md "Engine I"):

    .venv/bin/python lab/bench_engine.py [--export] [--memory] [--blender34] [--out build/bench/engine.json]

--export   export_scene of 100k strands: Curves (400 x 250 strands x 8 keys, geometry nodes,
           realized) best of 3, and particle hair (1000 parents x 100 interpolated children x
           9 keys, final-render rules) best of 2. Goal: <= 1 s. The depsgraph evaluation
           (Blender's own work) is reported separately.
--memory   1M strands x 16 keys rendered by the HAIRBSDF engine (32 x 24 px, 1 spp, 2 threads):
           peak resident memory the engine adds (export + render) above Blender's scene, the
           export alone, and the renderer's own account; goal <= 2 GB
           (blender_tests/scenes/engine_memory.py).
--blender34  also run --export in Debian's Blender 3.4 (`blender -b`).
Without --export / --memory both run (bpy 4.5). Render time against Cycles: lab/bench_vs_cycles.py.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SCENES = os.path.join(ROOT, "blender_tests", "scenes")
LIBRARY = os.path.join(ROOT, "plugin", "hairbsdf", "compare", "scenes")  # fiber_gonio, which hair_scenes imports
SITE = os.path.join(ROOT, "build", "blender_site", "current")
TAG = "@@BENCH@@"


# ----------------------------------------------------------------------------- inside Blender

def _export_bench():
    import bpy
    import hair_scenes as hs
    from hairbsdf.blender.export_scene import export_scene

    out = {"blender": bpy.app.version_string}
    hs.reset(width=64, height=48, spp=1)
    hs.make_camera(location=(0, -30, 5), target=(0, 0, 0))
    hs.curves_grid("Fur", nx=400, ny=250, size=20.0, n_points=8, length=0.3, radius=0.002)
    t = time.perf_counter()
    dg = bpy.context.evaluated_depsgraph_get()
    out["curves_depsgraph_seconds"] = time.perf_counter() - t
    times = []
    for _ in range(3):
        desc, rep = export_scene(dg, render=True)
        times.append(rep.timings["total"])
    out["curves_strands"] = int(desc["curves"]["curve_random"].size)
    out["curves_keys"] = int(desc["curves"]["points"].shape[0])
    out["curves_export_seconds"] = min(times)
    del desc

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
    out["particles_depsgraph_seconds"] = time.perf_counter() - t
    times = []
    for _ in range(2):
        desc, rep = export_scene(dg, render=False)  # viewport child counts = render counts here
        times.append(rep.timings["total"])
    out["particle_strands"] = int(desc["curves"]["curve_random"].size)
    out["particle_keys"] = int(desc["curves"]["points"].shape[0])
    out["particle_export_seconds"] = min(times)
    return out


def _inside(part):
    sys.path[:0] = [SCENES, LIBRARY]
    import bpy  # noqa: F401
    try:  # Blender 3.4 ignores PYTHONPATH: use the staged copy (docs/blender.md)
        import hairbsdf  # noqa: F401
    except ImportError:
        sys.path.insert(0, SITE)

    if part == "export":
        res = _export_bench()
    else:
        import engine_memory
        res = engine_memory.measure(n_side=1000, keys=16, render=True)
    sys.stdout.write(TAG + json.dumps(res) + "\n")
    from hairbsdf.compare.blender_job import exit_blender_process
    exit_blender_process(0)


# ----------------------------------------------------------------------------- driver

def _run(cmd, env=None):
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=ROOT, timeout=1800)
    lines = [ln[len(TAG):] for ln in r.stdout.splitlines() if ln.startswith(TAG)]
    if r.returncode != 0 or not lines:
        sys.exit(f"failed: {' '.join(cmd)}\n{(r.stdout + r.stderr)[-4000:]}")
    return json.loads(lines[-1])


def main():
    if "--inside" in sys.argv:
        return _inside(sys.argv[sys.argv.index("--inside") + 1])
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--export", action="store_true")
    ap.add_argument("--memory", action="store_true")
    ap.add_argument("--blender34", action="store_true")
    ap.add_argument("--blender", default=os.environ.get("BLENDER") or shutil.which("blender") or "blender")
    ap.add_argument("--out", default=os.path.join(ROOT, "build", "bench", "engine.json"))
    a = ap.parse_args()
    if not (a.export or a.memory):
        a.export = a.memory = True
    me = os.path.abspath(__file__)
    results = {"machine": {"cpus": os.cpu_count(), "load_average": os.getloadavg()}}
    if a.export:
        results["export_bpy45"] = r = _run([sys.executable, me, "--inside", "export"])
        print(f"[export] {r['blender']}: Curves {r['curves_strands']} strands / {r['curves_keys']} keys in "
              f"{r['curves_export_seconds']:.3f} s (depsgraph {r['curves_depsgraph_seconds']:.2f} s); particle hair "
              f"{r['particle_strands']} strands / {r['particle_keys']} keys in {r['particle_export_seconds']:.3f} s "
              f"(depsgraph {r['particles_depsgraph_seconds']:.2f} s)", flush=True)
        if a.blender34:
            results["export_blender34"] = r = _run([a.blender, "-b", "--factory-startup", "--python-exit-code", "1",
                                                    "--python", me, "--", "--inside", "export"])
            print(f"[export] {r['blender']}: Curves {r['curves_strands']} strands in "
                  f"{r['curves_export_seconds']:.3f} s; particle hair {r['particle_strands']} strands in "
                  f"{r['particle_export_seconds']:.3f} s", flush=True)
    if a.memory:
        results["memory_bpy45"] = r = _run([sys.executable, me, "--inside", "memory"])
        gb = 1e-9
        print(f"[memory] {r['blender']}: {r['exported_strands']} strands x {r['keys_per_strand']} keys; engine peak "
              f"+{r['engine_peak_bytes'] * gb:.2f} GB (export alone +{r['export_peak_bytes'] * gb:.2f} GB, "
              f"renderer's account {r['renderer_peak_bytes'] * gb:.2f} GB) above Blender's "
              f"{r['base_rss_bytes'] * gb:.2f} GB; export {r['export_seconds']:.2f} s, engine render "
              f"{r['render_op_seconds']:.1f} s (BVH build {r['build_seconds']:.1f} s)", flush=True)
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    with open(a.out, "w") as f:
        json.dump(results, f, indent=1)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
