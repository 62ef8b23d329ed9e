"""The README's picture of a `hairbsdf compare` report: a screenshot of a real report's index.html
in headless Chromium (Debian's chromium and chromium-driver, selenium from scripts/requirements.txt).

    .venv/bin/hairbsdf compare --scene swatch --ci --out build/readme_report
    .venv/bin/python lab/report_picture.py build/readme_report      # -> docs/images/compare_report.png
"""

import argparse
import json
import shutil
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("report", type=Path, help="a report folder (with index.html and report.json)")
    p.add_argument("--out", type=Path, default=REPO / "docs" / "images" / "compare_report.png")
    p.add_argument("--size", default="1400x1400", help="window size WxH (default 1400x1400)")
    a = p.parse_args(argv)
    index = a.report / "index.html"
    data = json.loads((a.report / "report.json").read_text())
    if data.get("format") != "hairbsdf-compare-report" or not data["cases"]:
        sys.exit("%s: not a compare report with cases" % a.report)

    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    opts = Options()
    opts.binary_location = shutil.which("chromium") or shutil.which("chromium-browser")
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--window-size=" +
                a.size.replace("x", ",")):
        opts.add_argument(arg)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    d = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=opts)
    try:
        d.get(index.resolve().as_uri())
        d.execute_script("window.scrollTo(0, 0)")
        errors = [e for e in d.get_log("browser") if e.get("level") in ("SEVERE", "WARNING")]
        if errors:
            sys.exit("console messages: %s" % errors)
        a.out.parent.mkdir(parents=True, exist_ok=True)
        if not d.save_screenshot(str(a.out)):
            sys.exit("the screenshot failed")
    finally:
        d.quit()
    c = data["cases"][0]
    print("%s: %s (%s, %s)" % (a.out, index, c["id"], c["status"]))


if __name__ == "__main__":
    main()
