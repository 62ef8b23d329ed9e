#!/usr/bin/env python3
"""A render's CPU time by stage, from perf call chains (issue 29 item 2; docs/benchmarks.md
"Engine III: the profile by stage").

    .venv/bin/python lab/profile_stages.py [--scene bench_hair | --npz scene.npz] [--samples 8]
        [--threads 2] [--freq 400] [--json build/bench/profile_bench_hair.json]

Runs `perf record --call-graph dwarf` on lab/profile_render.py and sorts every sample into one stage by
walking its call chain from the leaf up; the first frame that names a stage decides:

- Embree (libembree3, stripped: its functions are told apart by their .eh_frame ranges). Below the
  API entry (rtcIntersect1 / rtcOccluded1) the first Embree function is the BVH traversal the
  scene's accel dispatches to; every Embree function it calls is a leaf (primitive) intersector:
  "traversal" = that first function's own samples, "primitive intersection" = the frames below it
  (round Catmull-Rom curves here; the plane's two triangles are a separate, tiny BVH). Embree samples
  under rtcCommitScene are the BVH build.
- Our code by symbol: shading (the hit's frame, Bsdf set-up, ClosureSum and the models' eval/sample),
  the shading VM (run_program), light sampling (Lights, the light tree, suns and world), film
  (camera rays, the pixel filter, accumulation), the path loop's own work, the ray set-up around
  Embree (Geometry::intersect / occluded). libm and libc frames go to the caller that names a stage.
  Our code outside trace_path (PreparedScene: lights, light tree, materials) is "scene preparation".
"""

import argparse
import bisect
import collections
import json
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
EMBREE = "libembree3.so"
DISPATCH_BYTES = 512  # Embree functions below the API smaller than this are dispatch (AccelN), not traversal

# (stage, substrings of a demangled symbol); the first rule that matches a frame decides.
RULES = [
    ("shading VM", ("run_program", "run_material_program", "ShadingProgram", "shading_vm")),
    ("light sampling", ("Lights::", "LightTree", "light_tree", "Light::", "Environment", "eval_suns",
                        "selection_pdf", "LightPick")),
    ("film", ("Film", "film", "Filter", "Camera::", "accumulate", "PixelFilter")),
    ("ray set-up (Geometry::intersect/occluded)", ("Geometry::intersect", "Geometry::occluded")),
    ("shading", ("Bsdf::", "ClosureSum", "Chiang", "Huang", "huang", "MaterialShader", "prepare_model",
                 "sample_at_hit", "eval_at_hit", "surface_point", "Geometry::curve", "HairModel", "Diffuse",
                 "eval_local", "Emission", "lobe_shares", "chiang", "longitudinal", "azimuthal", "bessel",
                 "closure", "Closure")),
    ("path loop (trace_path's own work)", ("trace_path", "trace_pixel_sample", "Sampler", "power_heuristic")),
]


def embree_functions(path):
    """Start addresses of the library's functions from its .eh_frame (FDE pc ranges), sorted."""
    out = subprocess.run(["readelf", "--debug-dump=frames", path], capture_output=True, text=True, check=True).stdout
    ranges = sorted((int(a, 16), int(b, 16)) for a, b in re.findall(r"FDE cie=\w+ pc=(\w+)\.\.(\w+)", out))
    return ranges


def parse_perf_script(text):
    """Yields (thread, [(ip, symbol, dso)] leaf first) per sample, and the mmaps of libembree3."""
    maps = []  # (start, end, pgoff)
    samples = []
    chain, thread = None, None
    mmap_re = re.compile(r"PERF_RECORD_MMAP2? \d+/\d+: \[(0x[0-9a-f]+)\((0x[0-9a-f]+)\) @ (0x[0-9a-f]+|0) .*?\]: \S+ (\S+)")
    for line in text.splitlines():
        if "PERF_RECORD_MMAP" in line:
            m = mmap_re.search(line)
            if m and EMBREE in m.group(4):
                start, size, off = int(m.group(1), 16), int(m.group(2), 16), int(m.group(3), 16)
                maps.append((start, start + size, off))
            continue
        if not line.strip():
            if chain is not None:
                samples.append((thread, chain))
            chain = None
            continue
        if not line.startswith((" ", "\t")):
            thread = line.split()[0]
            chain = []
            continue
        if chain is None:
            continue
        parts = line.strip().split(None, 1)
        if len(parts) < 2:
            continue
        ip = int(parts[0], 16)
        rest = parts[1]
        dso = rest[rest.rfind("(") + 1:-1] if rest.endswith(")") else ""
        sym = rest[:rest.rfind("(")].strip() if "(" in rest else rest
        chain.append((ip, re.sub(r"\+0x[0-9a-f]+$", "", sym), dso))
    if chain is not None:
        samples.append((thread, chain))
    return samples, maps


def classify(chain, embree_fn, embree_size):
    """One sample's stage, and for Embree samples the Embree functions below the API entry, root first."""
    def embree_id(ip):
        i = bisect.bisect_right(embree_fn, (ip, float("inf"))) - 1
        return f"embree@{embree_fn[i][0]:x}" if i >= 0 and ip < embree_fn[i][1] else f"embree@?{ip:x}"

    frames = [f for f in chain if "kernel.kallsyms" not in f[2]]  # page faults: to the user frame
    api = next((i for i, (_, sym, dso) in enumerate(frames)
                if EMBREE in dso and sym.startswith(("rtcIntersect", "rtcOccluded"))), None)
    if api is not None:
        below = frames[:api]
        if any(EMBREE not in dso and "filter" in sym for _, sym, dso in below):
            return "curve intersection", ("filter callback",)
        path = tuple(embree_id(ip) for ip, _, dso in reversed(below) if EMBREE in dso)
        # Root first: small dispatch functions (a scene of several accels loops over them), then the
        # BVH traversal, then the primitive intersector it calls.
        dispatch = 0
        while dispatch < len(path) and embree_size.get(path[dispatch], 0) < DISPATCH_BYTES:
            dispatch += 1
        if dispatch == len(path):
            return "embree dispatch", path
        return ("traversal" if len(path) == dispatch + 1 else "curve intersection"), path
    if frames and EMBREE in frames[0][2]:
        syms = " ".join(s for _, s, _ in frames)
        return ("BVH build" if "rtcCommitScene" in syms or "trace_path" not in syms else "embree (chain lost)"), ()
    in_loop = any("trace_path" in sym or "trace_pixel_sample" in sym for _, sym, _ in frames)
    for _, sym, dso in frames:
        if not in_loop and "hairbsdf::" in sym:
            return "scene preparation", (re.sub(r"\(.*", "", sym)[-70:],)
        for stage, keys in RULES:
            if any(k in sym for k in keys):
                return stage, (re.sub(r"\(.*", "", sym)[-70:],)
        if "rtcCommitScene" in sym:
            return "BVH build", ()
    leaf = frames[0] if frames else (0, "", "")
    if "python" in leaf[2]:
        return "python", ()
    return "other", (f"{leaf[1]} ({os.path.basename(leaf[2])})",)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="bench_hair", help="a unit_cases scene name (default bench_hair)")
    ap.add_argument("--npz", default="", help="a dumped SceneDesc (.npz) instead of --scene")
    ap.add_argument("--samples", type=int, default=8)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--freq", type=int, default=400, help="perf sampling frequency per thread (Hz)")
    ap.add_argument("--json", default="", help="write the table here")
    ap.add_argument("--perf-data", default="", help="reuse an existing perf.data (skip recording)")
    a = ap.parse_args()
    if a.samples < 1 or a.threads < 1 or a.freq < 1:
        ap.error("--samples, --threads and --freq must be positive")
    lib = next((p for p in ("/usr/lib/x86_64-linux-gnu/libembree3.so.3",) if os.path.exists(p)), None)
    if lib is None:
        sys.exit("libembree3.so.3 not found")
    tmp = tempfile.mkdtemp(prefix="profile_stages_")
    data = a.perf_data or os.path.join(tmp, "perf.data")
    if not a.perf_data:
        scene = ["--npz", a.npz] if a.npz else ["--scene", a.scene]
        cmd = ["perf", "record", "-q", "-F", str(a.freq), "--call-graph", "dwarf,16384", "-o", data, "--",
               sys.executable, os.path.join(HERE, "profile_render.py"), *scene, "--samples", str(a.samples),
               "--threads", str(a.threads)]
        print(" ".join(cmd), flush=True)
        subprocess.run(cmd, check=True)
    text = subprocess.run(["perf", "script", "-i", data, "--show-mmap-events", "-F", "comm,tid,ip,sym,dso"],
                          capture_output=True, text=True).stdout
    samples, _ = parse_perf_script(text)
    fn = embree_functions(lib)
    size = {f"embree@{a:x}": b - a for a, b in fn}
    stages = collections.Counter()
    embree_paths = collections.Counter()
    details = collections.Counter()  # (stage, the frame that named it)
    for _, chain in samples:
        stage, path = classify(chain, fn, size)
        stages[stage] += 1
        if path and path[0].startswith("embree@"):
            embree_paths[(stage,) + path[:3]] += 1
        elif path:
            details[(stage, path[0])] += 1
    total = sum(stages.values())
    render_stages = [s for s in stages if s not in ("BVH build", "python", "other", "scene preparation")]
    in_render = sum(stages[s] for s in render_stages)
    print(f"\n{total} samples, {in_render} in the render loop")
    print(f"{'stage':45} {'% all':>7} {'% render loop':>14}")
    for stage, n in stages.most_common():
        share = f"{100 * n / in_render:13.1f}%" if stage in render_stages else f"{'-':>14}"
        print(f"{stage:45} {100 * n / total:6.1f}% {share}")
    print("\nEmbree call paths below the API (first three functions, root first; sizes from .eh_frame):")
    for key, n in embree_paths.most_common(12):
        print(f"  {key[0]:20} {100 * n / total:5.1f}%  " + " > ".join(f"{p} ({size.get(p, 0)} B)" for p in key[1:]))
    print("\nThe frames that named the stage (our code; 'other': the leaf), above 0.3 %:")
    for (stage, frame), n in details.most_common():
        if n >= 0.003 * total:
            print(f"  {stage:36} {100 * n / total:5.1f}%  {frame}")
    if a.json:
        os.makedirs(os.path.dirname(os.path.abspath(a.json)), exist_ok=True)
        with open(a.json, "w") as f:
            json.dump({"scene": a.npz or a.scene, "samples": a.samples, "threads": a.threads, "perf_samples": total,
                       "render_loop_samples": in_render, "stages": dict(stages),
                       "embree_paths": [[list(k), n] for k, n in embree_paths.most_common(20)],
                       "details": [[list(k), n] for k, n in details.most_common(40)]}, f, indent=1)


if __name__ == "__main__":
    main()
