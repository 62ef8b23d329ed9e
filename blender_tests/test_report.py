"""The comparison report without Blender: synthetic cases through the real judge and report
writer (index.html, report.json, junit.xml, case folders), `report merge`, and a screenshot of
the page in headless Chromium (Debian's chromium + chromium-driver through selenium): the page
loads, every image is there, no console errors, hovering swaps the renders."""

import json
import os
import shutil
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest
from ci import require_module, skip_or_fail as _skip_or_fail

from hairbsdf.compare import judge, report
from hairbsdf.compare.images import write_png
from hairbsdf.compare.thresholds import Thresholds

REPO = Path(__file__).resolve().parent.parent
SHOTS = REPO / "build" / "blender_tests" / "report"




def synthetic_case(scene, label, status_kind, variant=None, seed=0):
    """A case result as the runner makes it, from synthetic stacks."""
    rng = np.random.default_rng(seed)
    img = np.zeros((24, 32, 4))
    img[..., 3] = 1.0
    img[6:18, 4:28, :3] = rng.uniform(0.1, 1.0, 3)
    cases_dir = "%s%s__%s" % (scene, "-" + variant if variant else "", label)
    res = dict(id="%s%s@%s" % (scene, "-" + variant if variant else "", label), dir=cases_dir, scene=scene,
               variant=variant, file=None, kind="noisy", title=scene.title(), description="synthetic " + scene,
               model="chiang", blender=dict(spec="bpy", kind="bpy", path="/x", label=label, version=[4, 5, 0]),
               engine="HAIRBSDF", sizes=dict(res=[32, 24], spp=4, seeds=4, exact_seeds=0, threads=1), osl=False,
               pending=None, limits={}, checks=[], metrics={}, renders=[
                   dict(kind="cycles", seed=0, status="OK", ok=True, cached=True, seconds=0.1, wall=1.0),
                   dict(kind="ours", seed=0, status="OK", ok=True, cached=False, seconds=0.2, wall=2.0)],
               status=None, reason="", settings={"cycles.samples": 4}, versions={"blender": "4.5.0"})
    if status_kind == "crash":
        res.update(status="CRASH", reason="hairbsdf render CRASH: exited with status -6", log_tail="Aborted")
        return res, {}
    a = np.stack([img + 0.01 * rng.standard_normal(img.shape) for _ in range(4)])
    b = np.stack([img * (1.03 if status_kind == "fail" else 1.0) + 0.01 * rng.standard_normal(img.shape)
                  for _ in range(4)])
    lim = Thresholds().for_case(scene)
    checks, mets, maps = judge.evaluate("noisy", a, b, lim, flip=True)
    res.update(checks=checks, metrics=mets, limits=lim, status=judge.status_of(checks))
    return res, maps


def make_report(out, specs):
    results = []
    for args in specs:
        res, maps = synthetic_case(*args)
        if maps:
            report.write_case_assets(out, res, maps)
        results.append(res)
    run = dict(created="2026-01-01T00:00:00", command="test", hairbsdf="hairbsdf test", seconds=1.0)
    return report.write_report(out, results, run), results


SPECS = [("swatch", "bpy-4.5.15", "pass"), ("furnace", "bpy-4.5.15", "fail"),
         ("melanin_sweep", "blender-3.4.1", "crash"), ("ribbons_vs_3d", "blender-3.4.1", "pass", "THICK")]


def test_report_files(tmp_path):
    index, results = make_report(tmp_path, SPECS)
    statuses = {r["id"]: r["status"] for r in results}
    assert statuses["swatch@bpy-4.5.15"] == "PASS"
    assert statuses["furnace@bpy-4.5.15"] == "FAIL"
    html = index.read_text()
    assert "Scenes &times; Blender versions" in html and "bpy-4.5.15" in html and "blender-3.4.1" in html
    for r in results:
        assert 'id="case-%s"' % r["dir"] in html
    data = json.loads((tmp_path / "report.json").read_text())
    assert data["format"] == "hairbsdf-compare-report" and data["summary"]["bad"] == 2
    assert {c["id"] for c in data["cases"]} == set(statuses)
    case = next(c for c in data["cases"] if c["id"] == "swatch@bpy-4.5.15")
    for key in ("cycles", "ours", "diff", "z"):
        assert (tmp_path / case["images"][key]["path"]).is_file(), key
    assert (tmp_path / case["images"]["cycles"]["exr"]).is_file()
    assert {c["name"] for c in case["checks"]} >= {"welch", "mean_bias_sigma", "mean_bias_rel", "psnr", "idiff",
                                                  "flip"} - ({"flip"} if "flip" not in case["metrics"] else set())
    root = ET.parse(tmp_path / "junit.xml").getroot()
    suites = {s.get("name"): s for s in root.iter("testsuite")}
    assert set(suites) == {"hairbsdf.compare.bpy-4.5.15", "hairbsdf.compare.blender-3.4.1"}
    assert suites["hairbsdf.compare.bpy-4.5.15"].get("failures") == "1"
    assert suites["hairbsdf.compare.blender-3.4.1"].get("errors") == "1"
    names = [tc.get("name") for tc in root.iter("testcase")]
    assert "ribbons_vs_3d-THICK" in names


def test_report_merge(tmp_path):
    make_report(tmp_path / "s1", SPECS[:2])
    make_report(tmp_path / "s2", SPECS[2:])
    path, notes = report.merge([tmp_path / "s1", tmp_path / "s2"], tmp_path / "merged")
    data = report.load_report(tmp_path / "merged")
    assert len(data["cases"]) == 4 and not notes
    assert data["summary"]["counts"] == {"PASS": 2, "FAIL": 1, "CRASH": 1}
    case = next(c for c in data["cases"] if c["id"] == "swatch@bpy-4.5.15")
    assert (tmp_path / "merged" / case["images"]["cycles"]["path"]).is_file()
    assert len(list(ET.parse(tmp_path / "merged" / "junit.xml").getroot().iter("testcase"))) == 4
    # merging a shard twice keeps one copy of each case and says so
    _, notes = report.merge([tmp_path / "s1", tmp_path / "s1"], tmp_path / "merged2")
    assert len(report.load_report(tmp_path / "merged2")["cases"]) == 2 and len(notes) == 2


def test_png_writer_roundtrip(tmp_path):
    oiio = require_module("OpenImageIO")
    img = (np.arange(5 * 7 * 3).reshape(5, 7, 3) * 3 % 256).astype(np.uint8)
    write_png(tmp_path / "a.png", img)
    back = oiio.ImageBuf(str(tmp_path / "a.png")).get_pixels(oiio.UINT8)
    assert np.array_equal(back, img)


def _chrome():
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.options import Options
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        _skip_or_fail("selenium is not installed (scripts/requirements.txt)")
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if not browser or not driver:
        _skip_or_fail("Debian's chromium and chromium-driver are not installed (scripts/setup)")
    opts = Options()
    opts.binary_location = browser
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1400,1000"):
        opts.add_argument(a)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver), options=opts)


def test_report_in_headless_chromium(tmp_path):
    """The page loads, every image decodes, nothing is logged to the console, hovering over the
    Cycles image shows hairbsdf's, and the filter hides passing cases.  Screenshot saved."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    index, results = make_report(tmp_path, SPECS)
    d = _chrome()
    try:
        d.get(index.resolve().as_uri())
        assert d.title == "hairbsdf vs Cycles"
        imgs = d.find_elements(By.TAG_NAME, "img")
        n_expected = sum(len(r.get("images", {})) for r in results)
        assert len(imgs) == n_expected and n_expected >= 12
        broken = [i.get_attribute("src") for i in imgs
                  if not d.execute_script("return arguments[0].complete && arguments[0].naturalWidth > 0", i)]
        assert not broken, broken
        swap = d.find_element(By.CSS_SELECTOR, "img.swap")
        src0 = swap.get_attribute("src")
        d.execute_script("arguments[0].scrollIntoView()", swap)
        ActionChains(d).move_to_element(swap).perform()
        assert swap.get_attribute("src").endswith("hairbsdf.png") and src0.endswith("cycles.png")
        ActionChains(d).move_by_offset(400, 400).perform()
        d.execute_script("var f = document.getElementById('filter'); f.value = 'bad';"
                         "f.dispatchEvent(new Event('change'));")
        visible = [s.get_attribute("data-status") for s in d.find_elements(By.CSS_SELECTOR, "section.case")
                   if s.is_displayed()]
        assert sorted(visible) == ["CRASH", "FAIL"]
        logs = [l for l in d.get_log("browser") if l.get("level") in ("SEVERE", "WARNING")]
        assert not logs, logs
        SHOTS.mkdir(parents=True, exist_ok=True)
        shot = SHOTS / "report_screenshot.png"
        d.execute_script("window.scrollTo(0, 0)")
        assert d.save_screenshot(str(shot))
        assert shot.stat().st_size > 20000
        print("\n[report] screenshot: %s" % shot)
    finally:
        d.quit()
