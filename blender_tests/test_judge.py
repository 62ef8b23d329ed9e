"""`hairbsdf judge` on real Cycles renders: the four detection tests of issue 22.

The renders: the library scene `swatch` at CI size (128x96), 8 spp, 8 seeds per side, made by
`hairbsdf compare --engine CYCLES` (Cycles on seeds 0-7 as REF, Cycles on seeds 1000-1007 as
TEST) and kept in the harness's cache (build/compare_cache/cycles/), so a second run renders
nothing.  Every judge run is a subprocess in which `import bpy` fails: judge needs no Blender.
"""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parent.parent
PY = str(REPO / ".venv" / "bin" / "python") if (REPO / ".venv" / "bin" / "python").exists() else sys.executable
SEEDS, SPP = 8, 8
PATCH = (5, 40)  # x, y of a 10x10 patch on the backdrop, left of the strands
NO_BPY = "import sys; sys.modules['bpy'] = None; from hairbsdf.cli import main; sys.exit(main(sys.argv[1:]))"

pytestmark = pytest.mark.blender  # xdist workers share the cache; its per-image locks render each image once


@pytest.fixture(scope="session")
def cycles_sets(tmp_path_factory):
    """{'ref': [exr...], 'test': [exr...]}: two independent Cycles seed sets of swatch."""
    out = tmp_path_factory.mktemp("swatch_cycles")  # the renders stay in the harness's cache
    r = subprocess.run([PY, "-m", "hairbsdf.compare", "-q", "--scene", "swatch", "--ci", "--engine", "CYCLES",
                        "--seeds", str(SEEDS), "--spp", str(SPP), "--no-flip", "--exit-zero", "-j", "2",
                        "--out", str(out)], capture_output=True, text=True, cwd=str(REPO), timeout=900)
    assert r.returncode == 0, r.stdout + r.stderr
    case = json.loads((out / "report.json").read_text())["cases"][0]
    sets = dict(ref=[x["exr"] for x in case["renders"] if x["kind"] == "cycles"],
                test=[x["exr"] for x in case["renders"] if x["kind"] == "ours"])
    assert len(sets["ref"]) == len(sets["test"]) == SEEDS, case["renders"]
    return sets


def _folder(dst, files, change=None):
    """Copies the EXRs into dst (one per seed), applying change(index, image) if given."""
    from hairbsdf.compare import images, metrics
    dst.mkdir(parents=True)
    for i, f in enumerate(files):
        if change is None:
            shutil.copy(f, dst / ("seed%02d.exr" % i))
        else:
            img = metrics.load_image(f)
            images.write_exr(dst / ("seed%02d.exr" % i), change(i, img.copy()))
    return dst


def judge(ref, test, out):
    """Runs `hairbsdf judge` with bpy blocked; returns (returncode, output, report case)."""
    r = subprocess.run([PY, "-c", NO_BPY, "judge", str(ref), str(test), "--out", str(out)], capture_output=True,
                       text=True, cwd=str(REPO), timeout=300)
    rep = out / "report.json"
    case = json.loads(rep.read_text())["cases"][0] if rep.exists() else None
    return r.returncode, r.stdout + r.stderr, case


def checks(case):
    return {c["name"]: c for c in case["checks"]}


def test_independent_cycles_sets_pass(cycles_sets, tmp_path):
    ref = _folder(tmp_path / "ref", cycles_sets["ref"])
    test = _folder(tmp_path / "test", cycles_sets["test"])
    rc, out, case = judge(ref, test, tmp_path / "rep")
    assert rc == 0, out
    assert case["status"] == "PASS", out
    ch = checks(case)
    assert ch["welch"]["value"] == 0 and ch["mean_bias_sigma"]["passed"] and ch["nonfinite"]["value"] == 0
    for name in ("index.html", "junit.xml", "report.json"):
        assert (tmp_path / "rep" / name).exists()
    assert "REF (mean of 8 renders" in (tmp_path / "rep" / "index.html").read_text()


def test_bias_of_one_percent_fails_on_the_image_mean(cycles_sets, tmp_path):
    ref = _folder(tmp_path / "ref", cycles_sets["ref"])
    test = _folder(tmp_path / "test", cycles_sets["test"], lambda i, im: im * np.float32(1.01))
    rc, out, case = judge(ref, test, tmp_path / "rep")
    assert rc == 1, out
    ch = checks(case)
    assert not ch["mean_bias_sigma"]["passed"], ch["mean_bias_sigma"]
    assert ch["mean_bias_sigma"]["value"] > 2.0


def test_patch_of_five_percent_fails_the_per_pixel_test(cycles_sets, tmp_path):
    x, y = PATCH

    def patch(i, im):
        im[y:y + 10, x:x + 10, :3] *= np.float32(1.05)
        return im

    ref = _folder(tmp_path / "ref", cycles_sets["ref"])
    test = _folder(tmp_path / "test", cycles_sets["test"], patch)
    rc, out, case = judge(ref, test, tmp_path / "rep")
    assert rc == 1, out
    ch = checks(case)
    assert not ch["welch"]["passed"] and ch["welch"]["value"] >= 1, ch["welch"]
    assert ch["welch"]["value"] <= 300  # the patch's pixel-channels only
    assert ch["mean_bias_sigma"]["passed"], "the image mean is not what catches a local change"


def test_one_nan_pixel_fails_and_is_named(cycles_sets, tmp_path):
    def nan(i, im):
        if i == 3:
            im[23, 17, 1] = np.nan
        return im

    ref = _folder(tmp_path / "ref", cycles_sets["ref"])
    test = _folder(tmp_path / "test", cycles_sets["test"], nan)
    rc, out, case = judge(ref, test, tmp_path / "rep")
    assert rc == 1, out
    ch = checks(case)["nonfinite"]
    assert not ch["passed"] and ch["value"] == 1, ch
    first = case["metrics"]["nonfinite"]["first"]
    assert len(first) == 1 and first[0]["x"] == 17 and first[0]["y"] == 23 and first[0]["channel"] == 1
    assert first[0]["file"].endswith("seed03.exr")
    html = (tmp_path / "rep" / "index.html").read_text()
    assert "seed03.exr x=17 y=23 channel 1 = nan" in html
    assert "x=17 y=23" in out


def test_mean_and_variance_input(cycles_sets, tmp_path):
    """TEST as a mean EXR, its variance EXR and a sidecar JSON: passes, and the 1.01 bias fails."""
    from hairbsdf.compare import images, metrics
    stack = np.stack([metrics.load_image(f) for f in cycles_sets["test"]]).astype(np.float64)
    ref = _folder(tmp_path / "ref", cycles_sets["ref"])
    for name, k in (("same", 1.0), ("biased", 1.01)):
        d = tmp_path / name
        d.mkdir()
        images.write_exr(d / "mean.exr", stack.mean(axis=0) * k)
        images.write_exr(d / "mean_var.exr", stack.var(axis=0, ddof=1) * k * k)
        (d / "mean.json").write_text(json.dumps(dict(seeds=SEEDS)))
        rc, out, case = judge(ref, d / "mean.exr", tmp_path / ("rep_" + name))
        assert rc == (0 if k == 1.0 else 1), out
        assert checks(case)["mean_bias_sigma"]["passed"] == (k == 1.0), checks(case)["mean_bias_sigma"]
