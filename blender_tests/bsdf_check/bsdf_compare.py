"""Compare an npz written by render_cases.py against a BSDF implementation.

    python bsdf_compare.py file.npz [--against reference|hairbsdf] [--h h|h_probe] [--quiet]
    python bsdf_compare.py file.npz --model SPEC       # any hair BSDF against Cycles' Principled Hair

SPEC (the same forms as `hairbsdf compare --model`, plus Python-defined BSDFs):
    NAME[:MAPPING.py]                    a zoo model (kajiya_kay, epic, scheuermann, marschner, deon, yan_fur)
    plugin:LIBRARY[:MAPPING.py]          a BSDF plugin (docs/plugins.md)
    python:FILE.py:FUNCTION[:MAPPING.py] FUNCTION(**params) returns a closure with eval(wo, wi, h),
                                         e.g. a hairbsdf.python_bsdf
MAPPING.py defines map_inputs(inputs) -> params: a case's Principled Hair inputs (the snake_case
keys of cases.py plus `parametrization`, `model` "CHIANG", `random`, the strand's Random, and
`tilt`, "4.2" or "3.4" after the Blender that rendered)
-> the model's parameters; without it the model's defaults are used.

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
# render_cases.edge_alpha_check: with the camera 0.3 px off, a filter that samples the pixel centre
# leaves every pixel empty or covered (a far Blackman-Harris sample may move one of 16 samples);
# a filter spread over the pixel gives the edge rows alpha 0.3 and 0.7.
EDGE_ALPHA_TOL = 0.1


def edge_alpha_problem(checks):
    """None when the render sampled pixel centres (meta['checks'] of render_cases.py or
    render_cycles_hair.py), else what is wrong."""
    if "edge_alpha_max_fraction" not in checks:
        return "the render has no edge-alpha check (render_cases.edge_alpha_check)"
    if len(checks["edge_alpha_rows"]) != 2:
        return "no strand in the edge-alpha render"
    if checks["edge_alpha_max_fraction"] > EDGE_ALPHA_TOL:
        return ("the pixel filter %s does not sample the pixel centre: with the camera %.1f px off, the strand's "
                "edge rows %s have alpha %s (0 or 1 expected); the setting is ignored or too wide"
                % (checks["edge_alpha_filter"], checks["edge_alpha_shift_px"], checks["edge_alpha_rows"],
                   [["%.3f" % a for a in row] for row in checks["edge_alpha_values"]]))
    return None


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


def _load_file(path, label):
    import importlib.util
    spec = importlib.util.spec_from_file_location("bsdf_compare_" + label, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def parse_model(text):
    """SPEC (see the module docstring) -> (constructor(**params) -> closure, map_inputs, label)."""
    mapping = None
    if text.startswith("python:"):
        parts = text[len("python:"):].split(":")
        if len(parts) not in (2, 3) or not parts[0] or not parts[1]:
            raise ValueError("--model python:FILE.py:FUNCTION[:MAPPING.py] needs a file and a function name, got %r"
                             % text)
        path, name = os.path.abspath(parts[0]), parts[1]
        mapping = parts[2] if len(parts) == 3 else None
        if not os.path.isfile(path):
            raise ValueError("--model: %s: no such file" % path)
        module = _load_file(path, "model")
        constructor = getattr(module, name, None)
        if not callable(constructor):
            raise ValueError("--model: %s defines no function %r" % (path, name))
        label = "python:%s:%s" % (os.path.basename(path), name)
    else:
        import hairbsdf
        from hairbsdf.compare.model_spec import parse_model_spec
        rest = text
        if rest.endswith(".py") and ":" in rest:
            rest, mapping = rest.rsplit(":", 1)
        spec = parse_model_spec(rest)
        if spec["model"] == "plugin":
            constructor = hairbsdf.load_plugin(spec["path"])
        else:
            def constructor(**params):
                return hairbsdf.make_model(spec["model"], params)
        label = spec["label"]
    map_inputs = None
    if mapping is not None:
        mapping = os.path.abspath(mapping)
        if not os.path.isfile(mapping):
            raise ValueError("--model: mapping %s: no such file" % mapping)
        map_inputs = getattr(_load_file(mapping, "mapping"), "map_inputs", None)
        if not callable(map_inputs):
            raise ValueError("--model: mapping %s defines no map_inputs(inputs)" % mapping)
        label += " (mapping %s)" % os.path.basename(mapping)
    return constructor, map_inputs, label


def model_evaluator(text, random):
    """An evaluator for any hair BSDF given by SPEC; `random` is the strand's Hair Info > Random
    (the mapping sees it as inputs["random"])."""
    constructor, map_inputs, label = parse_model(text)
    cache = {}

    def ev(params, wo, wi, h, tilt):
        key = repr(sorted(params.items())) + tilt
        if key not in cache:
            inputs = {k: (tuple(v) if isinstance(v, list) else v) for k, v in params.items()}
            inputs.setdefault("model", "CHIANG")
            inputs["random"] = random
            inputs["tilt"] = tilt  # the Blender's convention: "4.2" (4.2+) or "3.4"
            cache[key] = constructor(**(map_inputs(inputs) if map_inputs else {}))
        out = cache[key].eval(np.ascontiguousarray(wo), np.ascontiguousarray(wi), np.ascontiguousarray(h))
        out = np.asarray(out, dtype=np.float64)
        return out.sum(axis=1) if out.ndim == 3 else out  # per-lobe (N, 4, 3) -> (N, 3)
    ev.name = label
    return ev


# --------------------------------------------------------------------------

def case_errors(ours, cycles, abs_floor=1e-30):
    floor = np.maximum(FLOOR_FRACTION * np.max(np.abs(cycles), axis=0), abs_floor)
    rel = np.abs(ours - cycles) / np.maximum(np.abs(cycles), floor)
    bright = cycles > 10.0 * floor
    ratio = float(np.median(cycles[bright] / ours[bright])) if np.any(bright) and np.all(
        ours[bright] != 0) else float("nan")
    return dict(n=int(cycles.shape[0]), median=float(np.median(rel)),
                l1=float(np.abs(ours - cycles).sum()), l1_cycles=float(np.abs(cycles).sum()),
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
    l1 = sum(r["l1"] for r in rows) / max(sum(r["l1_cycles"] for r in rows), 1e-300)
    lines.append("summary: median of case medians %.2e, worst median %.2e, worst p99 %.2e, "
                 "relative L1 over all pixels %.2e, %d/%d cases fail"
                 % (np.median(med), med.max(), p99.max(), l1, sum(not r["ok"] for r in rows), len(rows)))
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("npz", help="renders of the fibre goniometer (render_cases.py; test_bsdf_check.py caches them "
                                "in build/blender_tests/bsdf_check/)")
    ap.add_argument("--against", default="reference", choices=["reference", "hairbsdf"],
                    help="the float64 reference or hairbsdf.principled_hair (default reference)")
    ap.add_argument("--model", metavar="SPEC", help="compare this hair BSDF instead (see above); exits 0 "
                                                    "whatever the errors, which measure its distance from Cycles")
    ap.add_argument("--h", default="h", choices=["h", "h_probe"])
    ap.add_argument("--tilt", default=None)
    ap.add_argument("--quiet", action="store_true")
    a = ap.parse_args(argv)
    arrays, meta = load(a.npz)
    if a.model:
        import hairbsdf
        try:
            ev = model_evaluator(a.model, float(hairbsdf.cycles_curve_random(0)))
        except ValueError as exc:
            ap.error(str(exc))
        rows = compare(arrays, meta, ev, h_key=a.h, tilt=a.tilt)
        text = format_table(rows, meta, ev.name, a.tilt)
        print(text.splitlines()[-1] if a.quiet else text)
        return 0
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
