"""One render of a unit-case scene with a chosen THICK-curve intersector, for timing and callgrind
(docs/benchmarks.md, "Engine VII"; docs/engine.md, "Curve intersection").

    .venv/bin/python lab/curve_intersectors.py --intersector SWEEP [--samples 4] [--threads 1]
    .venv/bin/python lab/curve_intersectors.py --approximate-pieces 4     # the floor: straight proxies alone

--approximate-pieces K replaces each Catmull-Rom segment by K straight pieces through points of the curve and
renders them as THICK_LINEAR: Embree's cost for such proxies with no exact test. It is not Cycles' surface; it
measures what an own intersector could save at most.
"""

import argparse
import importlib.util
import os
import sys

import numpy as np

LAB = os.path.dirname(os.path.abspath(__file__))
UNIT_CASES = os.path.join(os.path.dirname(LAB), "blender_tests", "render_units", "unit_cases.py")


def catmull_rom_points(points, offsets, pieces):
    """Each curve's points at u = j / pieces of every segment (uniform Catmull-Rom, end keys doubled), x y z r."""
    out, out_offsets = [], [0]
    u = np.arange(pieces)[:, None] / pieces
    basis = 0.5 * np.hstack([-u ** 3 + 2 * u ** 2 - u, 3 * u ** 3 - 5 * u ** 2 + 2, -3 * u ** 3 + 4 * u ** 2 + u,
                             u ** 3 - u ** 2])
    for c in range(len(offsets) - 1):
        keys = points[offsets[c]:offsets[c + 1]].astype(np.float64)
        padded = np.concatenate([keys[:1], keys, keys[-1:]])
        rows = [basis @ padded[s:s + 4] for s in range(len(keys) - 1)] + [keys[-1:]]
        curve = np.concatenate(rows)
        out.append(curve)
        out_offsets.append(out_offsets[-1] + len(curve))
    return np.concatenate(out).astype(np.float32), np.asarray(out_offsets, np.int32)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--intersector", choices=["EMBREE", "SWEEP"], default="EMBREE",
                    help="the scene's curve_intersector (default EMBREE)")
    ap.add_argument("--approximate-pieces", type=int, default=0, metavar="K",
                    help="render K straight pieces per segment as THICK_LINEAR instead (not Cycles' surface)")
    ap.add_argument("--scene", default="bench_hair", help="a unit_cases.py scene (default bench_hair)")
    ap.add_argument("--samples", type=int, default=4, help="samples per pixel (default 4)")
    ap.add_argument("--threads", type=int, default=1, help="render threads (default 1)")
    ap.add_argument("--modules", default="", help="a folder with hairbsdf's _core and _render native modules to "
                    "use instead of the installed ones (a profiling build's plugin/, lab/README.md)")
    a = ap.parse_args()
    if a.samples < 1 or a.threads < 1 or a.approximate_pieces < 0:
        ap.error("--samples and --threads must be positive, --approximate-pieces not negative")
    if a.modules:
        spec = importlib.util.spec_from_file_location("profile_render", os.path.join(LAB, "profile_render.py"))
        profile_render = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(profile_render)
        profile_render.use_native_modules(a.modules, ap)
    from hairbsdf.render import render
    spec = importlib.util.spec_from_file_location("unit_cases", UNIT_CASES)
    cases = sys.modules["unit_cases"] = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cases)
    desc = cases.scene_desc(cases.case(a.scene), samples=a.samples)
    if a.approximate_pieces:
        curves = desc["curves"]
        curves["points"], curves["curve_offsets"] = catmull_rom_points(
            np.asarray(curves["points"]), np.asarray(curves["curve_offsets"]), a.approximate_pieces)
        desc["curve_shape"] = "THICK_LINEAR"
        what = f"{a.approximate_pieces} straight pieces per segment (THICK_LINEAR)"
    else:
        desc["curve_intersector"] = a.intersector
        what = f"curve_intersector {a.intersector}"
    out = render(desc, threads=a.threads)
    stats = out["stats"]
    print(f"{a.scene}, {what}, {a.samples} spp, {a.threads} thread(s): {stats['seconds']:.2f} s "
          f"(build {stats['build_seconds']:.2f} s), {stats['rays']} rays, mean {out['combined'][..., :3].mean():.6f}, "
          f"peak {stats['peak_memory_bytes'] / 1e6:.1f} MB", flush=True)


if __name__ == "__main__":
    main()
