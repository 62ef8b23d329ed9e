"""Instructions of one render by stage of the path loop, from callgrind on a profiling build.

    valgrind --tool=callgrind --dump-instr=yes --compress-pos=no --compress-strings=no \\
        --callgrind-out-file=build/cg/render.out --toggle-collect='hairbsdf::render::RenderJob::run()' \\
        .venv/bin/python lab/profile_render.py --samples 1 --threads 1 --modules build/profile/plugin
    .venv/bin/python lab/callgrind_stages.py build/cg/render.out build/profile/plugin

The module must be the profiling build's (lab/README.md, "A profiling build"), the very build that was
profiled (the addresses are looked up in it): GCC inlines the hit's frame, the closure eval and MIS into
the path's stage functions (src/render/path_stages.h) and those into trace_path, so only the line tables
say which statement an instruction belongs to. Every instruction of trace_path, of the stages and of the
wavefront's driver (trace_tile_wavefront; profile_render.py --per-pixel renders without it), and every call they make (with all below it),
goes to the stage of its statement in integrator.cpp (addr2line -i: the innermost frame of the inline chain
on a line of the stages, so a helper's body counts where it is written), refined by what was called or
inlined there (the rules below); the driver's own lines are the wavefront's queues. Outside them: camera
rays and the film, and the BVH build. Shares are of the render loop: RenderJob::run without the BVH build
and scene preparation.
"""

import argparse
import collections
import glob
import os
import re
import subprocess
import sys

TRACE_PATH = "hairbsdf::render::trace_path("
# The path loop's functions: the per-pixel loop, the stages it and the wavefront call (path_stages.h, when
# GCC did not inline them), and the wavefront's driver (its own lines: queues, sorting, gathers).
WAVEFRONT = ("hairbsdf::render::trace_tile_wavefront(", "hairbsdf::render::(anonymous namespace)::trace_rows(",
             "hairbsdf::render::(anonymous namespace)::shade_with_kernels(")
PATH_FUNCTIONS = (TRACE_PATH, "hairbsdf::render::stages::") + WAVEFRONT
RENDER_SO = "_render"

# The stages' statements in source order: (a substring of the first line of a block, its stage). Each
# line of integrator.cpp from that line on belongs to the stage until the next marker.
BLOCKS = [
    ("namespace stages {", "path loop: bookkeeping (bounces, roulette, throughput)"),
    ("RGB add(const IntegratorSettings& is", "film: a path's contributions (clamp, lobe shares)"),
    ("double forward_mis(const PathState& st", "MIS: lights hit by rays (forward MIS, suns, world)"),
    ("int hit_material(", "path loop: bookkeeping (bounces, roulette, throughput)"),
    ("// Lights crossed before the surface", "MIS: lights hit by rays (forward MIS, suns, world)"),
    ("bool prepare_hit_inline(", "path loop: bookkeeping (bounces, roulette, throughput)"),
    ("surface_point(s, ray, hit, sp);", "hit set-up: frame, tangent, h, attributes, material program"),
    ("h.first_hair = ", "path loop: bookkeeping (bounces, roulette, throughput)"),
    ("if (!material.program().empty())", "hit set-up: frame, tangent, h, attributes, material program"),
    ("const RGB emission = ", "MIS: lights hit by rays (forward MIS, suns, world)"),
    ("if (killed || st.terminate_after", "path loop: bookkeeping (bounces, roulette, throughput)"),
    ("bool prepare_bsdf(", "path loop: bookkeeping (bounces, roulette, throughput)"),
    ("bsdf.set(s.materials", "closure set-up: Bsdf::set (models' parameters, view terms)"),
    ("bool draw_light_sample_inline(", "NEE: MIS weight, contribution, shadow-ray set-up"),
    ("BsdfNumbers draw_bsdf_numbers_inline(", "BSDF sample (closure pick, model sample, MIS pdf)"),
    ("if (!isfinite(st.throughput))", "path loop: bookkeeping (bounces, roulette, throughput)"),
    ("bool sample_bsdf(", "BSDF sample (closure pick, model sample, MIS pdf)"),
    ("// The halves on their own", "path loop: bookkeeping (bounces, roulette, throughput)"),
    ("PathResult trace_path(", "path loop: bookkeeping (bounces, roulette, throughput)"),
    ("Ray camera_ray(", "outside"),
]
# Refinements by a function called, or inlined, at the statement: (substring of its name, stage).
CALLEES = [
    ("Geometry::occluded", "Embree: shadow rays (rtcOccluded1 / 1M, our filters)"),
    ("Geometry::intersect", "Embree: camera and bounce rays (rtcIntersect1 / 1M, our filters)"),
    ("LightSet::sample(", "NEE: light pick and light sample"),
    ("chiang_batch_run(", "batch kernels: NEE eval and BSDF sample (float32; the wavefront's)"),
    ("render_eval(", "NEE: BSDF eval"),
    ("Bsdf::eval(", "NEE: BSDF eval"),
]
ORDER = [
    "Embree: camera and bounce rays (rtcIntersect1 / 1M, our filters)",
    "Embree: shadow rays (rtcOccluded1 / 1M, our filters)",
    "hit set-up: frame, tangent, h, attributes, material program",
    "closure set-up: Bsdf::set (models' parameters, view terms)",
    "NEE: light pick and light sample",
    "NEE: BSDF eval",
    "NEE: MIS weight, contribution, shadow-ray set-up",
    "BSDF sample (closure pick, model sample, MIS pdf)",
    "batch kernels: NEE eval and BSDF sample (float32; the wavefront's)",
    "MIS: lights hit by rays (forward MIS, suns, world)",
    "path loop: bookkeeping (bounces, roulette, throughput)",
    "film: a path's contributions (clamp, lobe shares)",
    "wavefront: queues, sorting, gathers",
    "camera rays and film (outside the path loop)",
    "BVH build and scene preparation",
]


def parse(path):
    """Self costs by (function, address) and calls (caller, call-site address, callee, inclusive cost)."""
    own = collections.defaultdict(int)
    calls = []
    fn = cfn = None
    after_calls = False
    with open(path) as f:
        for line in f:
            if line.startswith("fn="):
                fn = line[3:].rstrip("\n")
                fn = re.sub(r"^\(\d+\) ?", "", fn) or fn
            elif line.startswith("cfn="):
                cfn = re.sub(r"^\(\d+\) ?", "", line[4:].rstrip("\n"))
            elif line.startswith("calls="):
                after_calls = True
            elif line[:2] == "0x":
                parts = line.split()
                addr, cost = int(parts[0], 16), int(parts[2]) if len(parts) > 2 else 0
                if after_calls:
                    calls.append((fn, addr, cfn, cost))
                    after_calls = False
                else:
                    own[(fn, addr)] += cost
    return own, calls


def load_base(own, module):
    """Where the module was loaded: a path function's lowest executed address (its entry) minus its symbol's value."""
    sym = subprocess.run(["nm", "-C", module], capture_output=True, text=True, check=True).stdout
    for prefix in PATH_FUNCTIONS:
        names = {f for f, _ in own if f.startswith(prefix) and "clone" not in f}
        for l in sym.splitlines():
            name = l.split(" ", 2)[-1]
            if name in names:
                return min(a for (f, a) in own if f == name) - int(l.split()[0], 16)
    sys.exit("no path function of the module in the profile")


def inline_chains(module, addrs):
    """addr -> [(function, file:line)] from the innermost inlined frame out (addr2line -i)."""
    addrs = sorted(addrs)
    out = subprocess.run(["addr2line", "-C", "-f", "-i", "-a", "-e", module], input="\n".join(hex(a) for a in addrs),
                         capture_output=True, text=True, check=True).stdout.splitlines()
    chains, cur = {}, None
    i = 0
    while i < len(out):
        if out[i].startswith("0x"):
            cur = int(out[i], 16)
            chains[cur] = []
            i += 1
        else:
            chains[cur].append((out[i], out[i + 1]))
            i += 2
    return chains


def block_stages(source):
    """integrator.cpp line number -> stage, from BLOCKS."""
    lines = open(source).read().splitlines()
    stage_of, marker, stage = {}, 0, "outside"  # "outside": not a line of the stages
    for n, text in enumerate(lines, 1):
        if marker < len(BLOCKS) and BLOCKS[marker][0] in text:
            stage = BLOCKS[marker][1]
            marker += 1
        stage_of[n] = stage
    if marker != len(BLOCKS):
        sys.exit(f"integrator.cpp no longer has the line '{BLOCKS[marker][0]}': update BLOCKS in {__file__}")
    return stage_of


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("callgrind_out", help="callgrind's output file (run with --dump-instr=yes --compress-pos=no "
                    "--compress-strings=no)")
    ap.add_argument("modules", help="the profiling build's folder with _render*.so (build/profile/plugin)")
    a = ap.parse_args()
    found = glob.glob(os.path.join(a.modules, RENDER_SO + ".*.so"))
    if not found:
        ap.error(f"modules: no {RENDER_SO}.*.so in {a.modules}")
    module = found[0]
    source = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                          "bsdf_core", "src", "render", "integrator.cpp")
    own, calls = parse(a.callgrind_out)
    if not any(f.startswith(PATH_FUNCTIONS) for f, _ in own):
        ap.error("callgrind_out: no path loop in it (the profiling build, --dump-instr=yes, --compress-strings=no?)")
    total = sum(own.values())
    base = load_base(own, module)
    stage_of = block_stages(source)

    in_path = [(f, addr, cost, None) for (f, addr), cost in own.items() if f.startswith(PATH_FUNCTIONS)]
    # Calls between the path functions are left out: the callee's own instructions and calls count.
    in_path += [(f, addr, cost, callee) for f, addr, callee, cost in calls
                if f.startswith(PATH_FUNCTIONS) and not callee.startswith(PATH_FUNCTIONS)]
    chains = inline_chains(module, {addr - base for _, addr, _, _ in in_path})
    stages = collections.Counter()
    for function, addr, cost, callee in in_path:
        chain = chains[addr - base]
        # The innermost frame on a line of the stages (a function's body, else the statement).
        stage = ("wavefront: queues, sorting, gathers" if function.startswith(WAVEFRONT)
                 else "path loop: bookkeeping (bounces, roulette, throughput)")
        for _, where in chain:
            file, line = where.rsplit(":", 1)
            number = re.match(r"\d+", line)
            if file.endswith("integrator.cpp") and number and stage_of.get(int(number.group()), "outside") != "outside":
                stage = stage_of[int(number.group())]
                break
        names = [name for name, _ in chain[:-1]] + ([callee] if callee else [])
        for pattern, refined in CALLEES:
            if any(pattern in n for n in names):
                stage = refined
                break
        stages[stage] += cost
    path_total = sum(stages.values())
    # Outside the path loop: the scene's preparation (BVH build) and the rest (camera rays, film, TBB).
    build = sum(cost for f, _, callee, cost in calls if callee.startswith("hairbsdf::render::PreparedScene::PreparedScene"))
    stages["BVH build and scene preparation"] = build
    stages["camera rays and film (outside the path loop)"] = total - path_total - build
    loop = total - build
    print(f"{total / 1e6:.1f} M instructions inside RenderJob::run; {loop / 1e6:.1f} M without the BVH build\n")
    print(f"| stage | M instructions | share of the render loop |\n|---|---|---|")
    for stage in ORDER:
        share = f"{100 * stages[stage] / loop:.1f} %" if stage != "BVH build and scene preparation" else "–"
        print(f"| {stage} | {stages[stage] / 1e6:.1f} | {share} |")
    unknown = set(stages) - set(ORDER)
    if unknown:
        sys.exit(f"stages without a row: {sorted(unknown)}")


if __name__ == "__main__":
    main()
