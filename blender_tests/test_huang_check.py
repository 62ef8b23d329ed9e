"""Huang BSDF check against real Cycles 4.5 and 5.3 (no render engine of ours involved).

Cycles renders one straight strand with the Huang model (bsdf_check/render_huang.py,
bsdf_check/huang_cases.py); every pixel is a sun-lit BSDF evaluation averaged over many samples,
because Cycles' Huang eval is stochastic. Two case sets:
  * near: camera rays with pixel_coverage = 1/60 (near field), one value per image row (h);
  * far:  pixels 3 radii tall (far field, h-independent), one value per case.
The renders run in a bpy 4.5 or bpy 5.3 subprocess (the venvs of scripts/setup) and are cached under
build/blender_tests/huang_check/. Ours uses the energy-compensation tables of the Blender that
rendered (glass_albedo_table "4.x" or "5.x", docs/blender5.md).

Metric per case: rel = |ours - cycles| / max(|cycles|, 1e-3 x the case's maximum per channel);
pass when median <= max(1e-3, 4 x noise) and p99 <= max(1e-2, 4 x the 99th percentile of the
noise) (fiber_gonio Huang: median 1e-3 and p99 1e-2 once Cycles' own Monte Carlo noise is below
them), and the noise-weighted mean signed difference (bias) is within 1e-3 + 4 of its standard
errors. "noise" is the standard error of Cycles' average (over the image columns) relative to the
same scale.

Metric per lobe (lobe_scales): over every row and channel of a set, Cycles' values are fitted as
sum_p k_p ours_p (R, TT, TRT, TRRT+) by weighted least squares; each k_p must lie within
LOBE_TOL[p] + 4 standard errors of 1. One seed resolves k_TRT to +-0.001 (near set), far finer than
any one row, so a TRT or TRRT+ 10 % off fails (test_the_gate_fails_on_a_planted_lobe_error) and
one 3 % off would. The same comparison with accuracy="converged" (HUANG_CHECK_FULL=1) shows
where Cycles' Simpson rule differs from the converged integral.

CI size: one seed, trt_points 16384 and tolerance 1e-3 (set here, not the API defaults), both sets in 4.5 and the far set in 5.3 (near 256 spp,
far 4096 spp in huang_cases.py): 268 s of CPU for 4.5's two sets, renders and our eval included, about 2.5 min of
wall time on 2 idle cores, plus about 40 s for 5.3's far set (docs/huang.md section 8 has the measured scales,
docs/blender5.md the 5.3 ones).

    .venv/bin/python -m pytest blender_tests/test_huang_check.py -s
Environment: HUANG_CHECK_REFRESH=1 re-renders; HUANG_CHECK_FULL=0 is the CI size (no 'converged'
table; the default under CI=true); HUANG_CHECK_SEEDS=N averages N independent renders (seeds
0..N-1, each cached; Cycles' noise falls as 1/sqrt(N), so the strict scene-wide median and p99 of
issue 6 can be judged where the noise allows); HUANG_CHECK_TRT_POINTS=N evaluates ours with N
quasi-Monte Carlo points per node for TRT (default 16384); BSDF_CHECK_BPY_PYTHON as in
test_bsdf_check.py (and BSDF_CHECK_BPY5_PYTHON for 5.x).
"""

import fcntl
import hashlib
import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest
from ci import skip_or_fail, under_ci

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
CHECK_DIR = os.path.join(HERE, "bsdf_check")
CACHE_DIR = os.path.join(REPO, "build", "blender_tests", "huang_check")
FILES = [os.path.join(REPO, "plugin", "hairbsdf", "compare", "scenes", "fiber_gonio.py"), os.path.join(CHECK_DIR, "render_huang.py"),
         os.path.join(CHECK_DIR, "huang_cases.py")]
REFRESH = os.environ.get("HUANG_CHECK_REFRESH", "") not in ("", "0")
# CI size: no 'converged' table (informational, and its eval costs up to a second per value);
# HUANG_CHECK_FULL=1 (the default outside CI) prints it too.
FULL = os.environ.get("HUANG_CHECK_FULL", "" if under_ci() else "1") not in ("", "0")
SEEDS = int(os.environ.get("HUANG_CHECK_SEEDS", "1"))
# Our eval's TRT is quasi-Monte Carlo (docs/huang.md §4): its default 16384 points per node err by
# 0.2-2 % of TRT, which shows against a reference of many seeds; HUANG_CHECK_TRT_POINTS changes it.
TRT_POINTS = int(os.environ.get("HUANG_CHECK_TRT_POINTS", "16384"))
# The TT cubature's target with fixed TRT points: 1e-3, the thresholds' basis (the API default, 1e-2, is for
# speed and gives medians near 3e-3 on the near set).
TT_TOLERANCE = 1e-3
# The per-lobe scale gate (lobe_scales): |k_p - 1| <= LOBE_TOL[p] + 4 standard errors. R and TT follow
# Cycles' Simpson rule exactly (measured k within 4e-4 of 1 at one seed); TRT and TRRT+ carry our
# quasi-Monte Carlo error at the default points (measured TRT 1.0003, TRRT+ 0.9941 +- 0.0012 near).
LOBE_TOL = (0.005, 0.005, 0.02, 0.02)
MEDIAN_TOL, P99_TOL, FLOOR = 1e-3, 1e-2, 1e-3

pytestmark = pytest.mark.blender


BLENDERS = {"bpy": "bpy4.5", "bpy5": "bpy5.3"}  # which -> test id


def _bpy_python(blender):
    if blender == "bpy5":
        py = os.environ.get("BSDF_CHECK_BPY5_PYTHON")
        if not py:
            from hairbsdf.compare.runner import bpy5_venv
            venv = bpy5_venv()
            py = str(venv / "bin" / "python") if venv else ""
        return py
    py = os.environ.get("BSDF_CHECK_BPY_PYTHON") or os.path.join(REPO, ".venv", "bin", "python")
    return py if os.path.exists(py) else sys.executable


def _render(which, seed=0, blender="bpy"):
    py = _bpy_python(blender)
    if not py or not os.path.exists(py):
        skip_or_fail("no Python with bpy for %s (%r; run scripts/setup)" % (BLENDERS[blender], py))
    r = subprocess.run([py, "-c", "import importlib.metadata as m; print(m.version('bpy'))"], capture_output=True,
                       text=True)
    if r.returncode != 0:
        skip_or_fail("no bpy module in %s" % py)
    version = "bpy-" + r.stdout.strip()
    if (int(version[4:].split(".")[0]) >= 5) != (blender == "bpy5"):
        skip_or_fail("%s has %s, not %s" % (py, version, BLENDERS[blender]))
    h = hashlib.sha256()
    for path in FILES:
        with open(path, "rb") as f:
            h.update(f.read())
    h.update((which + version).encode())
    os.makedirs(CACHE_DIR, exist_ok=True)
    out = os.path.join(CACHE_DIR, "%s-%s-%s%s.npz" % (version, which, h.hexdigest()[:16], "-s%d" % seed if seed else ""))
    with open(out + ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if REFRESH or not os.path.exists(out):
            log = out[:-4] + ".log"
            t0 = time.time()
            with open(log, "w") as f:
                r = subprocess.run([py, os.path.join(CHECK_DIR, "render_huang.py"), "--out", out, "--cases", which,
                                    "--seed", str(seed)], stdout=f, stderr=subprocess.STDOUT, timeout=7200,
                                   cwd=CHECK_DIR)
            if r.returncode != 0 or not os.path.exists(out):
                with open(log) as f:
                    pytest.fail("render failed, log %s:\n%s" % (log, f.read()[-3000:]))
            print("\n[huang_check] rendered %s seed %d with %s in %.0fs" % (which, seed, version, time.time() - t0))
    d = np.load(out)
    return {k: d[k] for k in d.files if k != "meta"}, json.loads(str(d["meta"])), out


def combine(renders):
    """One data set from independent renders (seeds) of the same case set: per case, the rows
    (values of h) that every render kept; rgb the mean of the renders' means, sem the standard
    error of that mean (renders of equal size)."""
    if len(renders) == 1:
        return renders[0]
    parts = []
    for k in np.unique(renders[0]["case"]):
        rows = [r["case"] == k for r in renders]
        common = set(renders[0]["h"][rows[0]].tolist())
        for r, m in zip(renders[1:], rows[1:]):
            common &= set(r["h"][m].tolist())
        idx = [np.nonzero(m & np.isin(r["h"], sorted(common)))[0] for r, m in zip(renders, rows)]
        idx = [i[np.argsort(r["h"][i])] for r, i in zip(renders, idx)]
        part = {key: renders[0][key][idx[0]] for key in renders[0]}
        part["rgb"] = np.mean([r["rgb"][i] for r, i in zip(renders, idx)], axis=0)
        part["sem"] = np.sqrt(np.sum([r["sem"][i] ** 2 for r, i in zip(renders, idx)], axis=0)) / len(renders)
        part["alpha"] = np.mean([r["alpha"][i] for r, i in zip(renders, idx)], axis=0)
        parts.append(part)
    return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}


def render_seeds(which, n, blender="bpy"):
    """`n` seeds of a case set, combined: (arrays, meta of seed 0, path of seed 0)."""
    results = [_render(which, s, blender) for s in range(n)]
    arrays = combine([r[0] for r in results])
    meta = dict(results[0][1], seeds=n)
    return arrays, meta, results[0][2]


def glass_albedo_table(meta):
    """The energy-compensation tables of the Blender that rendered (docs/blender5.md)."""
    return "5.x" if int(meta["blender_version_string"].split(".")[0]) >= 5 else "4.x"


def closure_for(params, accuracy="cycles", glass_table="4.x"):
    import hairbsdf
    kw = {k: (tuple(v) if isinstance(v, list) else v) for k, v in params.items()
          if k not in ("parametrization", "normal", "model")}
    kw["trt_points"] = TRT_POINTS
    kw["tolerance"] = TT_TOLERANCE
    kw["glass_albedo_table"] = glass_table
    return hairbsdf.principled_hair(model="huang", parametrization=params["parametrization"].lower(),
                                    random=float(hairbsdf.cycles_curve_random(0)), accuracy=accuracy, **kw)


LOBES = ("R", "TT", "TRT", "TRRT+")


def our_lobes(arrays, meta, accuracy="cycles", glass_table=None):
    """Our per-lobe values (rows, 4, 3) at every row of a set (R, TT, TRT, TRRT+; they sum to eval), with
    the rendering Blender's energy-compensation tables unless `glass_table` names others."""
    glass_table = glass_table or glass_albedo_table(meta)
    out = np.zeros((len(arrays["h"]), 4, 3))
    for k, case in enumerate(meta["cases"]):
        m = arrays["case"] == k
        c = closure_for(case["params"], accuracy, glass_table)
        normal = arrays["normal"][m] if "normal" in case["params"] else None
        out[m] = c.eval_lobes(arrays["wo"][m], arrays["wi"][m], arrays["h"][m], normal=normal,
                              pixel_coverage=arrays["pixel_coverage"][m], near_field=arrays["near_field"][m])
    return out


def lobe_scales(lobes, arrays):
    """Cycles' values as a weighted sum of ours per lobe, cycles ~ sum_p k_p ours_p, fitted by least
    squares over every row and channel of a set with weights 1 / sem^2: k (4,) and its standard
    errors (4,). A lobe of ours that is off by a factor shows as k_p != 1, here far more precisely
    than in any one row (TRT and TRRT+ carry over half the value in a quarter of the near set's rows)."""
    x = lobes.transpose(0, 2, 1).reshape(-1, 4)
    y = arrays["rgb"].reshape(-1)
    w = 1.0 / np.maximum(arrays["sem"].reshape(-1), 1e-12) ** 2
    a = x.T @ (w[:, None] * x)
    k = np.linalg.solve(a, x.T @ (w * y))
    resid = y - x @ k
    dof = max(len(y) - 4, 1)
    inflation = max(1.0, float(np.sum(w * resid ** 2)) / dof)  # Cycles' sem under-estimated -> wider
    return k, np.sqrt(np.diag(np.linalg.inv(a)) * inflation)


def compare(arrays, meta, lobes):
    rows = []
    for k, case in enumerate(meta["cases"]):
        m = arrays["case"] == k
        ours = lobes[m].sum(axis=1)
        cy, sem = arrays["rgb"][m], arrays["sem"][m]
        floor = np.maximum(FLOOR * np.max(np.abs(cy), axis=0), 1e-30)
        scale = np.maximum(np.abs(cy), floor)
        rel = np.abs(ours - cy) / scale
        rsem = sem / scale
        z = np.abs(ours - cy) / np.maximum(sem, 1e-30)
        noise = float(np.median(rsem))
        med, p99 = float(np.median(rel)), float(np.percentile(rel, 99))
        # Signed mean relative difference over the pixels, weighted by 1 / noise^2 (green channel).
        w = 1.0 / np.maximum(rsem[:, 1], 1e-12) ** 2
        bias = float(np.sum(w * ((ours - cy)[:, 1] / scale[:, 1])) / np.sum(w))
        bias_err = float(1.0 / np.sqrt(np.sum(w)))
        ok = (med <= max(MEDIAN_TOL, 4 * noise) and p99 <= max(P99_TOL, 4 * float(np.percentile(rsem, 99)))
              and abs(bias) <= MEDIAN_TOL + 4 * bias_err)
        rows.append(dict(name=case["name"], n=int(m.sum()), median=med, p99=p99, noise=noise, bias=bias,
                         bias_err=bias_err, zmed=float(np.median(z)), ok=bool(ok), peak=float(np.max(cy)),
                         rel=rel.ravel(), rsem=rsem.ravel()))
    return rows


def table(rows, title):
    lines = ["", title, "%-42s %4s %9s %9s %9s %10s %8s %6s %9s %s" % (
        "case", "px", "median", "p99", "noise", "bias", "+-", "z_med", "peak", "")]
    for r in rows:
        lines.append("%-42s %4d %9.2e %9.2e %9.2e %+10.2e %8.1e %6.2f %9.3e %s" % (
            r["name"], r["n"], r["median"], r["p99"], r["noise"], r["bias"], r["bias_err"], r["zmed"], r["peak"],
            "" if r["ok"] else "FAIL"))
    med = np.array([r["median"] for r in rows])
    lines.append("summary: median of case medians %.2e, worst median %.2e, worst p99 %.2e, worst |bias| %.2e, "
                 "%d/%d cases fail" % (np.median(med), med.max(), max(r["p99"] for r in rows),
                                       max(abs(r["bias"]) for r in rows), sum(not r["ok"] for r in rows), len(rows)))
    rel = np.concatenate([r["rel"] for r in rows])
    noise = np.concatenate([r["rsem"] for r in rows])
    lines.append("all values of the set (issue 6's fiber_gonio metric, strict): median %.2e (<= %.0e: %s), p99 %.2e "
                 "(<= %.0e: %s); Cycles' own noise: median %.2e, p99 %.2e" % (
                     np.median(rel), MEDIAN_TOL, "yes" if np.median(rel) <= MEDIAN_TOL else "no",
                     np.percentile(rel, 99), P99_TOL, "yes" if np.percentile(rel, 99) <= P99_TOL else "no",
                     np.median(noise), np.percentile(noise, 99)))
    return "\n".join(lines)


def cached_lobes(arrays, meta, path, accuracy="cycles"):
    """our_lobes, computed once per render, accuracy, TRT point count and build of hairbsdf._core
    (xdist workers share it through a file lock, as the renders)."""
    import hairbsdf._core
    h = hashlib.sha256()
    with open(hairbsdf._core.__file__, "rb") as f:
        h.update(f.read())
    h.update(("%s-%d-%d-%s" % (accuracy, TRT_POINTS, SEEDS, glass_albedo_table(meta))).encode())
    out = "%s-lobes-%s.npy" % (path[:-4], h.hexdigest()[:16])
    with open(out + ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not os.path.exists(out):
            np.save(out + ".tmp.npy", our_lobes(arrays, meta, accuracy))
            os.replace(out + ".tmp.npy", out)
    return np.load(out)


# The sets per Blender. Under CI 5.3 runs the far set only (the CI budget; the near set there passed too, docs/
# blender5.md); HUANG_CHECK_BPY5_NEAR=1 adds it under CI, and outside CI it always runs.
RUN_BPY5_NEAR = os.environ.get("HUANG_CHECK_BPY5_NEAR", "" if under_ci() else "1") not in ("", "0")
SETS = [(b, s) for b in BLENDERS for s in ("far", "near") if (b, s) != ("bpy5", "near") or RUN_BPY5_NEAR]


@pytest.fixture(scope="module", params=SETS, ids=[BLENDERS[b] + "-" + s for b, s in SETS])
def cycles_data(request):
    blender, which = request.param
    arrays, meta, path = render_seeds(which, SEEDS, blender)
    return arrays, meta, path, cached_lobes(arrays, meta, path)


def lobe_table(k, se):
    return "per-lobe scale, Cycles ~ sum k_p ours_p over the set: " + ", ".join(
        "%s %.4f +- %.1e%s" % (name, k[p], se[p], "" if lobe_ok(k, se, p) else " FAIL")
        for p, name in enumerate(LOBES))


def lobe_ok(k, se, p):
    return abs(k[p] - 1.0) <= LOBE_TOL[p] + 4.0 * se[p]


def verdict(arrays, meta, lobes):
    """(rows, k, se, failures) of the gate: every case within its bounds, every lobe's scale within
    LOBE_TOL + 4 standard errors of 1 over the set."""
    rows = compare(arrays, meta, lobes)
    k, se = lobe_scales(lobes, arrays)
    failures = ["%s (median %.2e, p99 %.2e)" % (r["name"], r["median"], r["p99"]) for r in rows if not r["ok"]]
    failures += ["lobe %s scale %.4f +- %.4f" % (LOBES[p], k[p], se[p]) for p in range(4) if not lobe_ok(k, se, p)]
    return rows, k, se, failures


def test_huang_matches_cycles(cycles_data, capsys):
    arrays, meta, path, lobes = cycles_data
    rows, k, se, failures = verdict(arrays, meta, lobes)
    text = table(rows, "hairbsdf Huang (accuracy='cycles', trt_points=%d) vs Cycles %s, %s set, %d seed%s"
                 % (TRT_POINTS, meta["blender_version_string"], meta["case_set"], SEEDS, "s" if SEEDS > 1 else ""))
    text += "\n" + lobe_table(k, se)
    if FULL:
        conv = our_lobes(arrays, meta, "converged")
        text += "\n" + table(compare(arrays, meta, conv), "hairbsdf Huang (accuracy='converged') vs Cycles, same renders")
        text += "\n" + lobe_table(*lobe_scales(conv, arrays))
    tag = ("-%dseeds" % SEEDS if SEEDS > 1 else "") + "-trt%d" % TRT_POINTS
    with open(path[:-4] + tag + ".huang.txt", "w") as f:
        f.write(text + "\n")
    with capsys.disabled():
        print(text)
    assert not failures, ", ".join(failures)


@pytest.mark.parametrize("lobe,factor", [(2, 0.9), (3, 0.9)])
def test_the_gate_fails_on_a_planted_lobe_error(cycles_data, lobe, factor):
    """Planted fault: our TRT (or TRRT+) scaled by 0.9 must fail the gate in each set."""
    arrays, meta, _, lobes = cycles_data
    planted = lobes.copy()
    planted[:, lobe] *= factor
    _, k, se, failures = verdict(arrays, meta, planted)
    assert failures, "a %s scaled by %g passed: k %s +- %s" % (LOBES[lobe], factor, k, se)
    assert not lobe_ok(k, se, lobe)


@pytest.fixture(scope="module", params=list(BLENDERS), ids=list(BLENDERS.values()))
def far_data(request):
    """The far set of one Blender (the renders are cached on disk, shared with cycles_data)."""
    arrays, meta, path = render_seeds("far", SEEDS, request.param)
    return arrays, meta


def test_the_gate_fails_with_the_other_blenders_tables(far_data):
    """Planted fault: ours with the other Blender's energy-compensation tables (4.x's against Cycles 5.3,
    5.x's against 4.5) must fail the gate in the far set, where the tables move the value most."""
    arrays, meta = far_data
    other = {"4.x": "5.x", "5.x": "4.x"}[glass_albedo_table(meta)]
    _, k, se, failures = verdict(arrays, meta, our_lobes(arrays, meta, glass_table=other))
    assert failures, "ours with the %s tables passed against Cycles %s: k %s +- %s" % (
        other, meta["blender_version_string"], k, se)


def test_combine_keeps_common_rows_and_averages():
    """Seeds are averaged per case over the rows (h) every seed kept; the standard error of the
    mean of n equal renders is sqrt(sum sem^2) / n."""
    def fake(hs, value, sem):
        n = len(hs)
        return dict(case=np.zeros(n, np.int32), h=np.array(hs, float), rgb=np.full((n, 3), value),
                    sem=np.full((n, 3), sem), alpha=np.ones(n), wo=np.zeros((n, 3)), wi=np.zeros((n, 3)),
                    normal=np.zeros((n, 3)), pixel_coverage=np.full(n, 0.1), near_field=np.ones(n, bool))
    out = combine([fake([0.1, 0.2, 0.3], 1.0, 0.2), fake([0.3, 0.2], 3.0, 0.2)])
    np.testing.assert_array_equal(out["h"], [0.2, 0.3])
    np.testing.assert_allclose(out["rgb"], 2.0)
    np.testing.assert_allclose(out["sem"], np.sqrt(2) * 0.2 / 2)
