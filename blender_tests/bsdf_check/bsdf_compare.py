"""Compare an npz written by render_cases.py against a BSDF implementation.

    python bsdf_compare.py file.npz [--against reference|hairbsdf] [--h h|h_probe] [--quiet]

Used by ../test_bsdf_check.py.  Pure numpy; no bpy.

Metric (per case): for every kept pixel and RGB channel c,
    rel = |ours - cycles| / max(|cycles|, floor_c),  floor_c = FLOOR_FRACTION * max_pixels |cycles_c|
i.e. relative error, with a floor of 1e-3 of the brightest pixel of that channel
in that case so that pixels in the dark tails (where a relative error is
meaningless) count by their absolute error on the scale of the case.
The case passes when median(rel) <= MEDIAN_TOL and p99(rel) <= P99_TOL.
"""

import argparse
import json
import os
import sys

import numpy as np

FLOOR_FRACTION = 1e-3
MEDIAN_TOL = 1e-4
P99_TOL = 2e-3

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
REFERENCE_DIR = os.path.join(REPO, "plugin", "tests", "reference")


def load(path):
    d = np.load(path)
    meta = json.loads(str(d["meta"]))
    arrays = {k: d[k] for k in d.files if k != "meta"}
    return arrays, meta


def node_inputs(params):
    """Case params -> keyword arguments in hairbsdf / reference spelling."""
    kw = {k: (tuple(v) if isinstance(v, list) else v) for k, v in params.items()
          if k not in ("parametrization", "model")}
    return params["parametrization"].lower(), kw


# --------------------------------------------------------------------------
# evaluators: f(params, wo, wi, h, tilt) -> (N, 3)

def reference_module():
    """The independent float64 reference (plugin/tests/reference/chiang_reference.py)."""
    if REFERENCE_DIR not in sys.path:
        sys.path.insert(0, REFERENCE_DIR)
    import chiang_reference  # noqa: E402
    return chiang_reference


def reference_evaluator():
    ref = reference_module()
    random = ref.cycles_curve_random(0)

    def ev(params, wo, wi, h, tilt):
        par, kw = node_inputs(params)
        prm = ref.principled_hair_params(parametrization=par, random=random, **kw)
        return ref.chiang_eval(prm, wo, wi, h, accuracy="cycles", tilt=tilt)
    ev.name = "reference (chiang_reference.py)"
    return ev


def hairbsdf_evaluator(hairbsdf):
    random = float(hairbsdf.cycles_curve_random(0))

    def ev(params, wo, wi, h, tilt):
        par, kw = node_inputs(params)
        c = hairbsdf.principled_hair(model="chiang", parametrization=par, random=random,
                                     tilt=tilt, **kw)
        return np.asarray(c.eval(np.ascontiguousarray(wo), np.ascontiguousarray(wi),
                                 np.ascontiguousarray(h)), dtype=np.float64)
    ev.name = "hairbsdf"
    return ev


# Cycles' legacy Hair BSDF (render_cycles_hair.py). Cycles evaluates it with fast_acosf /
# fast_atan2f / fast_cosf in float (angle errors up to ~5e-5 rad); hairbsdf uses exact double
# functions, so each case differs by a near-constant factor of up to ~4e-4 (measured, see
# docs/models.md §6). Pixels below LEGACY_ABS_FLOOR (case peaks are 5e-3 to 0.7) are zero at this scale (Cycles' float
# cos(pi/2) leaves +3e-8 in 3.4 and -1.5e-7 (negative pixels) in 4.5 where the stretched azimuth is
# clamped to pi; ours is ~1e-17).
LEGACY_MEDIAN_TOL = 1e-3
LEGACY_P99_TOL = 2e-3
LEGACY_ABS_FLOOR = 1e-4


def cycles_hair_evaluator(hairbsdf):
    def ev(params, wo, wi, h, tilt):
        c = hairbsdf.cycles_hair_bsdf(component=params["component"], color=tuple(params["color"]),
                                      offset=params["offset"], roughness_u=params["roughness_u"],
                                      roughness_v=params["roughness_v"])
        return np.asarray(c.eval(np.ascontiguousarray(wo), np.ascontiguousarray(wi),
                                 np.ascontiguousarray(h)), dtype=np.float64)
    ev.name = "hairbsdf.cycles_hair_bsdf"
    return ev


# --------------------------------------------------------------------------

def case_errors(ours, cycles, abs_floor=1e-30):
    floor = np.maximum(FLOOR_FRACTION * np.max(np.abs(cycles), axis=0), abs_floor)
    rel = np.abs(ours - cycles) / np.maximum(np.abs(cycles), floor)
    bright = cycles > 10.0 * floor
    ratio = float(np.median(cycles[bright] / ours[bright])) if np.any(bright) and np.all(
        ours[bright] != 0) else float("nan")
    return dict(n=int(cycles.shape[0]), median=float(np.median(rel)),
                p99=float(np.percentile(rel, 99)), max=float(np.max(rel)), ratio=ratio,
                peak=float(np.max(cycles)))


def compare(arrays, meta, evaluator, h_key="h", tilt=None, median_tol=MEDIAN_TOL, p99_tol=P99_TOL,
            abs_floor=1e-30):
    tilt = tilt or meta["tilt"]
    rows = []
    for k, case in enumerate(meta["cases"]):
        m = arrays["case"] == k
        ours = evaluator(case["params"], arrays["wo"][m], arrays["wi"][m], arrays[h_key][m], tilt)
        e = case_errors(np.asarray(ours, dtype=np.float64), arrays["rgb"][m], abs_floor)
        e["name"] = case["name"]
        e["ok"] = bool(e["median"] <= median_tol and e["p99"] <= p99_tol)
        rows.append(e)
    return rows


def format_table(rows, meta, title, tilt=None, median_tol=MEDIAN_TOL, p99_tol=P99_TOL):
    lines = ["", "%s vs Cycles %s (tilt %s, %s set, %d cases; rel floor %.0e x channel max; "
             "pass: median <= %.0e and p99 <= %.0e)"
             % (title, meta["blender_version_string"], tilt or meta["tilt"], meta["case_set"], len(rows),
                FLOOR_FRACTION, median_tol, p99_tol),
             "%-46s %5s %10s %10s %10s %10s %9s %s" % ("case", "px", "median", "p99", "max",
                                                      "peak", "cy/ours", "")]
    for r in rows:
        lines.append("%-46s %5d %10.2e %10.2e %10.2e %10.3e %9.6f %s"
                     % (r["name"], r["n"], r["median"], r["p99"], r["max"], r["peak"], r["ratio"],
                        "" if r["ok"] else "FAIL"))
    med = np.array([r["median"] for r in rows])
    p99 = np.array([r["p99"] for r in rows])
    lines.append("summary: median of case medians %.2e, worst median %.2e, worst p99 %.2e, "
                 "%d/%d cases fail" % (np.median(med), med.max(), p99.max(),
                                       sum(not r["ok"] for r in rows), len(rows)))
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("npz")
    ap.add_argument("--against", default="reference", choices=["reference", "hairbsdf"])
    ap.add_argument("--h", default="h", choices=["h", "h_probe"])
    ap.add_argument("--tilt", default=None)
    ap.add_argument("--quiet", action="store_true")
    a = ap.parse_args(argv)
    arrays, meta = load(a.npz)
    if a.against == "reference":
        ev = reference_evaluator()
    else:
        import hairbsdf
        ev = hairbsdf_evaluator(hairbsdf)
    rows = compare(arrays, meta, ev, h_key=a.h, tilt=a.tilt)
    text = format_table(rows, meta, ev.name, a.tilt)
    if a.quiet:
        text = text.splitlines()[-1]
    print(text)
    return 0 if all(r["ok"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
