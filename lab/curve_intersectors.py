"""One render of a unit-case scene with a chosen THICK-curve intersector, for timing and callgrind
(docs/benchmarks.md, "Engine VII"; docs/engine.md, "Curve intersection").

    .venv/bin/python lab/curve_intersectors.py --intersector SWEEP [--samples 4] [--threads 1]
    .venv/bin/python lab/curve_intersectors.py --approximate-pieces 4     # the floor: straight proxies alone
    .venv/bin/python lab/curve_intersectors.py --seeds 4 --samples 16 --threads 2  # image means: ratio and z

--approximate-pieces K replaces each Catmull-Rom segment by K straight pieces through points of the curve and
renders them as THICK_LINEAR: Embree's cost for such proxies with no exact test. It is not Cycles' surface; it
measures what an own intersector could save at most.

--seeds N renders seeds 0 .. N-1 with each intersector (EMBREE and SWEEP, alternated) and prints each one's mean
and sd of the per-seed image means, their ratio and its z (the difference of the means over the combined
standard error of the per-seed means): docs/benchmarks.md "Engine VII"'s image means.
"""

import argparse
import importlib.util
import math
import os
import sys

import numpy as np

from render_args import add_render_arguments, use_native_modules

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


def render_mean(render, desc, threads):
    """One render: its output and the image mean (RGB)."""
    out = render(desc, threads=threads)
    return out, float(out["combined"][..., :3].mean())


def compare_seeds(render, cases, a):
    """Seeds 0 .. a.seeds - 1 with EMBREE and SWEEP, alternated: each intersector's mean and sd of the per-seed
    image means, the ratio SWEEP / EMBREE of their means and its z (the difference of the means over the
    combined standard error of the per-seed means)."""
    means = {"EMBREE": [], "SWEEP": []}
    for seed in range(a.seeds):
        for intersector in means:
            desc = cases.scene_desc(cases.case(a.scene), samples=a.samples, seed=seed)
            desc["curve_intersector"] = intersector
            out, mean = render_mean(render, desc, a.threads)
            means[intersector].append(mean)
            print(f"seed {seed}, {intersector}: mean {mean:.6f}, {out['stats']['seconds']:.2f} s", flush=True)
    m = {k: float(np.mean(v)) for k, v in means.items()}
    sd = {k: float(np.std(v, ddof=1)) for k, v in means.items()}
    standard_error = math.sqrt((sd["EMBREE"] ** 2 + sd["SWEEP"] ** 2) / a.seeds)
    z = (m["SWEEP"] - m["EMBREE"]) / standard_error if standard_error > 0 else float("inf")
    print(f"{a.scene}, {a.seeds} seeds x {a.samples} spp, {a.threads} thread(s): EMBREE {m['EMBREE']:.6f} "
          f"(sd {sd['EMBREE']:.5f}), SWEEP {m['SWEEP']:.6f} (sd {sd['SWEEP']:.5f}), "
          f"ratio {m['SWEEP'] / m['EMBREE']:.4f}, z {z:.2f}", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--intersector", choices=["EMBREE", "SWEEP"], default="EMBREE",
                    help="the scene's curve_intersector (default EMBREE)")
    ap.add_argument("--approximate-pieces", type=int, default=0, metavar="K",
                    help="render K straight pieces per segment as THICK_LINEAR instead (not Cycles' surface)")
    ap.add_argument("--seeds", type=int, default=0, metavar="N",
                    help="render seeds 0 .. N-1 with each intersector (EMBREE and SWEEP, alternated) and print "
                    "the ratio of the image means and its z; --intersector is then not used")
    ap.add_argument("--scene", default="bench_hair", help="a unit_cases.py scene (default bench_hair)")
    add_render_arguments(ap, samples_default=4)
    a = ap.parse_args()
    if a.samples < 1 or a.threads < 1 or a.approximate_pieces < 0 or a.seeds < 0:
        ap.error("--samples and --threads must be positive, --approximate-pieces and --seeds not negative")
    if a.seeds and (a.seeds < 2 or a.approximate_pieces):
        ap.error("--seeds: at least 2, and not with --approximate-pieces")
    if a.modules:
        use_native_modules(a.modules, ap)
    from hairbsdf.render import render
    spec = importlib.util.spec_from_file_location("unit_cases", UNIT_CASES)
    cases = sys.modules["unit_cases"] = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cases)
    if a.seeds:
        compare_seeds(render, cases, a)
        return
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
    out, mean = render_mean(render, desc, a.threads)
    stats = out["stats"]
    print(f"{a.scene}, {what}, {a.samples} spp, {a.threads} thread(s): {stats['seconds']:.2f} s "
          f"(build {stats['build_seconds']:.2f} s), {stats['rays']} rays, mean {mean:.6f}, "
          f"peak {stats['peak_memory_bytes'] / 1e6:.1f} MB", flush=True)


if __name__ == "__main__":
    main()
