"""One bench_hair render with hairbsdf.render, for profilers (docs/benchmarks.md, Engine II).

    perf record -g .venv/bin/python lab/profile_render.py [--samples 16] [--threads 1]
    perf report --no-children --sort dso,symbol
"""

import argparse
import importlib.util
import os
import sys

from hairbsdf.render import render

# The scene lives with the render-unit tests (not in the package): load that file by path.
UNIT_CASES = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                          "blender_tests", "render_units", "unit_cases.py")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, default=16, help="samples per pixel (default 16)")
    ap.add_argument("--threads", type=int, default=1, help="render threads (default 1)")
    a = ap.parse_args()
    spec = importlib.util.spec_from_file_location("unit_cases", UNIT_CASES)
    cases = sys.modules["unit_cases"] = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cases)
    out = render(cases.scene_desc(cases.case("bench_hair"), samples=a.samples), threads=a.threads)
    print(f"bench_hair, {a.samples} spp, {a.threads} thread(s): {out['stats']['seconds']:.2f} s, "
          f"{out['stats']['rays']} rays")


if __name__ == "__main__":
    main()
