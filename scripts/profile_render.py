"""One bench_hair render with hairbsdf.render, for profilers (docs/benchmarks.md, Engine II).

    perf record -g .venv/bin/python scripts/profile_render.py [samples] [threads]
    perf report --no-children --sort dso,symbol
"""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "blender_tests", "render_units"))

import unit_cases as C  # noqa: E402
from hairbsdf.render import render  # noqa: E402

samples = int(sys.argv[1]) if len(sys.argv) > 1 else 16
threads = int(sys.argv[2]) if len(sys.argv) > 2 else 1
out = render(C.scene_desc(C.case("bench_hair"), samples=samples), threads=threads)
print(f"bench_hair, {samples} spp, {threads} thread(s): {out['stats']['seconds']:.2f} s, {out['stats']['rays']} rays")
