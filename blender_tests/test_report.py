"""The comparison report without Blender: synthetic cases through the real judge and report
writer (index.html, report.json, junit.xml, case folders with PNGs and EXRs), `report merge`,
and the page in headless Chromium (Debian's chromium + chromium-driver through selenium): it
loads, every image is there, informational rows carry a neutral badge, the wipe slider moves,
a click opens the full-size viewer whose zoom is linked between the two layers, and nothing
is logged to the console.  Screenshots of the page and the viewer are saved."""

import json
import os
import shlex
import shutil
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest
from ci import require_module, skip_or_fail as _skip_or_fail

from hairbsdf.compare import judge, report
from hairbsdf.compare.cli import build_parser, reproduce_command
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
    res["reproduce"] = reproduce_command(res, build_parser().parse_args(["--ci"]))
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
    cdir = tmp_path / "cases" / case["dir"]
    for name in ("cycles_mean.exr", "cycles_var.exr", "hairbsdf_mean.exr", "hairbsdf_var.exr", "t.exr"):
        assert (cdir / name).is_file(), name
    assert case["images"]["cycles"]["exr"] == "cases/%s/cycles_mean.exr" % case["dir"]
    assert case["images"]["z"]["exr"] == "cases/%s/t.exr" % case["dir"]
    assert case["reproduce"] == ("hairbsdf compare --scene swatch --blender bpy --ci --res 32x24 --spp 4 --seeds 4 "
                                 "--exact-seeds 0 --out out/reproduce/swatch__bpy-4.5.15")
    args = build_parser().parse_args(shlex.split(case["reproduce"])[2:])  # a valid command line
    assert args.scene == ["swatch"] and args.ci and args.seeds == 4
    assert data["title"] == "hairbsdf vs Cycles"
    # informational checks: never FAIL in the page or JUnit, a neutral "over" where over their limit
    idiff = next(c for c in case["checks"] if c["name"] == "idiff")
    assert not idiff["gate"] and not idiff["passed"] and case["status"] == "PASS"
    assert report._check_badge(idiff) == "over"
    assert "idiff: %s" % idiff["value"] in (tmp_path / "junit.xml").read_text()
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


def test_case_means_are_judge_inputs(tmp_path):
    """A case's mean EXRs name their variance and seed count in the header: `hairbsdf judge`
    reads them as they are, and finds the same image-mean bias."""
    from hairbsdf.compare import judge_cli
    make_report(tmp_path / "rep", SPECS[:2])
    case = tmp_path / "rep" / "cases" / "furnace__bpy-4.5.15"
    rc = judge_cli.main([str(case / "cycles_mean.exr"), str(case / "hairbsdf_mean.exr"), "--out",
                         str(tmp_path / "j"), "--exit-zero"])
    data = report.load_report(tmp_path / "j")
    orig = report.load_report(tmp_path / "rep")
    furnace = next(c for c in orig["cases"] if c["scene"] == "furnace")
    assert rc == 0 and data["title"] == "hairbsdf_mean vs cycles_mean"
    rel = furnace["metrics"]["mean_bias"]["rel"]
    assert data["cases"][0]["metrics"]["mean_bias"]["rel"] == pytest.approx(rel, rel=1e-4) and rel > 0.02
    assert data["cases"][0]["status"] == furnace["status"] == "FAIL"


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
    """The page in headless Chromium: every image decodes; informational rows show a neutral
    badge, never FAIL; the wipe slider moves ours over the reference; a click opens the viewer at
    full size (at least 1 screen pixel per image pixel), zoom scales both layers alike, the
    viewer's wipe works, Esc closes it; the filter hides passing cases; no console messages.
    Screenshots of the page and of the open viewer are saved."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    index, results = make_report(tmp_path, SPECS)
    d = _chrome()
    rect = "var r = arguments[0].getBoundingClientRect(); return [r.width, r.height];"
    try:
        d.get(index.resolve().as_uri())
        assert d.title == "hairbsdf vs Cycles"
        n_expected = sum(len(r.get("images", {})) for r in results)
        views = d.find_elements(By.CSS_SELECTOR, "img.view")
        assert len(views) == n_expected and n_expected >= 12
        broken = [i.get_attribute("src") for i in d.find_elements(By.TAG_NAME, "img")
                  if i.is_displayed() and not d.execute_script(
                      "return arguments[0].complete && arguments[0].naturalWidth > 0", i)]
        assert not broken, broken
        # informational rows: "over" (neutral), never FAIL; the passing case has one
        info_badges = [b.text for b in d.find_elements(By.CSS_SELECTOR, "tr.inforow .badge:not(.infoonly)")]
        assert info_badges and "FAIL" not in info_badges and "PASS" not in info_badges, info_badges
        swatch = d.find_element(By.ID, "case-swatch__bpy-4.5.15")
        assert "over" in [b.text for b in swatch.find_elements(By.CSS_SELECTOR, "tr.inforow .badge")]
        repro = swatch.find_element(By.CSS_SELECTOR, ".repro code").text
        assert repro.startswith("hairbsdf compare --scene swatch --blender bpy")
        # the wipe in the page
        pair = swatch.find_element(By.CSS_SELECTOR, "figure.pair")
        d.execute_script("arguments[0].scrollIntoView()", pair)
        d.execute_script("var r = arguments[0]; r.value = 20; r.dispatchEvent(new Event('input'));",
                         pair.find_element(By.CSS_SELECTOR, "input.wipe-range"))
        top = pair.find_element(By.CSS_SELECTOR, "img.top")
        assert "20%" in top.value_of_css_property("clip-path")
        # the viewer: a click opens it full size, zoom is linked, its wipe moves ours
        viewer = d.find_element(By.ID, "viewer")
        assert not viewer.is_displayed()
        ActionChains(d).move_to_element(pair.find_element(By.CSS_SELECTOR, "img.view")).click().perform()
        assert viewer.is_displayed()
        va, vb = d.find_element(By.ID, "v-a"), d.find_element(By.ID, "v-b")
        assert va.get_attribute("src").endswith("cycles.png") and vb.get_attribute("src").endswith("hairbsdf.png")
        natural = d.execute_script("return arguments[0].naturalWidth", va)
        wa, _ = d.execute_script(rect, va)
        wb, _ = d.execute_script(rect, vb)
        assert natural == 32 and wa >= 4 * 240 and wa == pytest.approx(wb), (natural, wa, wb)
        d.find_element(By.ID, "v-out").click()
        wa2, _ = d.execute_script(rect, va)
        wb2, _ = d.execute_script(rect, vb)
        assert wa2 == pytest.approx(wa / 2) and wb2 == pytest.approx(wb / 2)
        d.find_element(By.ID, "v-in").click()
        d.execute_script("var r = document.getElementById('v-wipe'); r.value = 70;"
                         "r.dispatchEvent(new Event('input'));")
        assert "70%" in vb.value_of_css_property("clip-path")
        SHOTS.mkdir(parents=True, exist_ok=True)
        assert d.save_screenshot(str(SHOTS / "report_viewer.png"))
        ActionChains(d).send_keys(Keys.ESCAPE).perform()
        assert not viewer.is_displayed()
        # a single image opens without the wipe layer
        ActionChains(d).move_to_element(swatch.find_element(By.CSS_SELECTOR, "figure.z img.view")).click().perform()
        assert viewer.is_displayed() and not vb.is_displayed()
        d.find_element(By.ID, "v-close").click()
        assert not viewer.is_displayed()
        d.execute_script("var f = document.getElementById('filter'); f.value = 'bad';"
                         "f.dispatchEvent(new Event('change'));")
        visible = [s.get_attribute("data-status") for s in d.find_elements(By.CSS_SELECTOR, "section.case")
                   if s.is_displayed()]
        assert sorted(visible) == ["CRASH", "FAIL"]
        logs = [l for l in d.get_log("browser") if l.get("level") in ("SEVERE", "WARNING")]
        assert not logs, logs
        shot = SHOTS / "report_screenshot.png"
        d.execute_script("var f = document.getElementById('filter'); f.value = 'all';"
                         "f.dispatchEvent(new Event('change')); window.scrollTo(0, 0)")
        assert d.save_screenshot(str(shot))
        assert shot.stat().st_size > 20000
        print("\n[report] screenshots: %s, %s" % (shot, SHOTS / "report_viewer.png"))
    finally:
        d.quit()
