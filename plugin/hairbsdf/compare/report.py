"""The report: DIR/index.html (one page: a scenes x Blender versions matrix, then every case
with its images, metrics table, settings and versions), DIR/report.json (machine-readable),
DIR/junit.xml (CI), and DIR/cases/<case>/ (PNG previews, mean EXRs, the engine's renders).

``merge(dirs, out)`` joins the reports of several shards (``hairbsdf report merge``)."""

from __future__ import annotations

import datetime
import html
import json
import math
import os
import shutil
import string
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from .._constants import ENGINE_ID
from . import images as I

TEMPLATES = Path(__file__).resolve().parent / "templates"
FORMAT = "hairbsdf-compare-report"
FORMAT_VERSION = 1
BAD = ("FAIL", "CRASH", "NO OUTPUT", "ERROR")
ORDER = {"FAIL": 0, "CRASH": 1, "NO OUTPUT": 2, "ERROR": 3, "PENDING": 4, "PASS": 5, "INFO": 6, "SKIPPED": 7}


# --------------------------------------------------------------------------- json helpers

def clean(x):
    """JSON-safe copy: NaN/inf as strings, numpy scalars as Python numbers, arrays dropped."""
    if isinstance(x, dict):
        return {str(k): clean(v) for k, v in x.items() if not isinstance(v, np.ndarray)}
    if isinstance(x, (list, tuple)):
        return [clean(v) for v in x]
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and (math.isnan(x) or math.isinf(x)):
        return str(x)
    if isinstance(x, Path):
        return str(x)
    return x


def fmt(v):
    if v is None:
        return "&ndash;"
    if isinstance(v, str):
        return html.escape(v)
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v) or math.isinf(v):
            return str(v)
        if v == 0:
            return "0"
        a = abs(v)
        return ("%.3e" % v) if (a < 1e-3 or a >= 1e5) else ("%.4g" % v)
    return html.escape(str(v))


# --------------------------------------------------------------------------- case assets

def write_case_assets(out_dir, result, maps):
    """PNG previews, and beside them EXRs of the means, variances and the Welch t map, of one
    case; fills result['images'] and writes case.json.  The mean EXRs carry the header attributes
    hairbsdf:seeds and hairbsdf:variance, so `hairbsdf judge` reads a case folder's means directly."""
    out_dir = Path(out_dir)
    cdir = out_dir / "cases" / result["dir"]
    cdir.mkdir(parents=True, exist_ok=True)
    imgs = {}
    rel = lambda p: os.path.relpath(p, out_dir)  # noqa: E731
    ours_name = result.get("engine_label") or ("hairbsdf" if result.get("engine", ENGINE_ID) == ENGINE_ID
                                                else "Cycles (self-check)")
    ref_name = result.get("ref_label") or "Cycles"  # `hairbsdf judge`: REF

    def mean_exr(key, stem):
        attrs, var = {}, None
        if key + "_var" in maps:
            var = cdir / (stem + "_var.exr")
            I.write_exr(var, maps[key + "_var"])
            attrs = {"hairbsdf:seeds": int(maps[key + "_n"]), "hairbsdf:variance": var.name}
        I.write_exr(cdir / (stem + "_mean.exr"), maps[key], attrs)
        return rel(cdir / (stem + "_mean.exr")), (rel(var) if var else None)

    if "cycles" in maps and "ours" in maps:
        ref, test = maps["cycles"], maps["ours"]
        ev = I.auto_exposure(ref)
        I.write_png(cdir / "cycles.png", I.display(ref, ev))
        I.write_png(cdir / "hairbsdf.png", I.display(test, ev))
        c_exr, c_var = mean_exr("cycles", "cycles")
        o_exr, o_var = mean_exr("ours", "hairbsdf")
        n_c = result["sizes"]["seeds"]
        n_o = result["sizes"].get("seeds_test", n_c)
        imgs["cycles"] = dict(path=rel(cdir / "cycles.png"), exr=c_exr, var_exr=c_var, label=ref_name,
                              caption="%s (mean of %d render%s), display %+.1f EV" % (
                                  ref_name, n_c, "s" if n_c > 1 else "", ev),
                              swap=rel(cdir / "hairbsdf.png"), swap_label=ours_name)
        imgs["ours"] = dict(path=rel(cdir / "hairbsdf.png"), exr=o_exr, var_exr=o_var, label=ours_name,
                            caption="%s (mean of %d), display %+.1f EV" % (ours_name, n_o, ev))
        d = maps["diff"]
        scale = float(np.percentile(np.abs(d), 99.5)) if d.size else 0.0
        scale = scale if scale > 0 else max(float(np.abs(d).max()), 1e-12)
        I.write_png(cdir / "diff.png", I.signed_map(d, scale))
        imgs["diff"] = dict(path=rel(cdir / "diff.png"),
                            caption="difference of the means, %s - %s (luminance); blue: darker, orange: "
                                    "brighter" % (ours_name, ref_name),
                            colorbar=dict(gradient=I.css_gradient(I.DIVERGING), labels=[-scale, 0.0, scale]))
    if "z" in maps:
        z = maps["z"]
        w = result.get("metrics", {}).get("welch", {})
        tc = w.get("t_critical_median_df")
        tc = float(tc) if isinstance(tc, (int, float)) and math.isfinite(tc) else 5.0
        T = 6.0  # fixed scale: |t| of a few is noise, beyond 6 stands out (failures are green)
        zimg = I.signed_map(z, T)
        if "zfail" in maps and np.any(maps["zfail"]):
            zimg[maps["zfail"]] = (0, 255, 0)
        I.write_png(cdir / "z.png", zimg)
        I.write_exr(cdir / "t.exr", z)
        imgs["z"] = dict(path=rel(cdir / "z.png"), exr=rel(cdir / "t.exr"),
                         caption="Welch t per pixel (channel of largest |t|); green: fails after the Sidak "
                                 "correction (|t| > about %.1f at the median df)" % tc,
                         colorbar=dict(gradient=I.css_gradient(I.DIVERGING), labels=[-T, 0.0, T]))
    if "rel" in maps:
        r = np.where(maps.get("mask", np.ones(maps["rel"].shape, bool)), maps["rel"], np.nan)
        img = I.log_map(np.nan_to_num(r, nan=1e-9), -7, -1)
        img[~np.isfinite(r)] = (40, 40, 40)
        I.write_png(cdir / "rel.png", img)
        imgs["rel"] = dict(path=rel(cdir / "rel.png"),
                           caption="per-pixel relative error (max over RGB), log scale; grey: not compared "
                                   "(silhouettes, background)",
                           colorbar=dict(gradient=I.css_gradient(I.SEQUENTIAL), labels=["1e-7", "1e-4", "1e-1"]))
    if "flip" in maps:
        I.write_png(cdir / "flip.png", I.colormap(maps["flip"], I.SEQUENTIAL))
        fl = result.get("metrics", {}).get("flip", {})
        ex = ""
        if isinstance(fl.get("start_exposure"), (int, float)):
            ex = ", exposures %+.1f to %+.1f EV from the reference" % (fl["start_exposure"], fl["stop_exposure"])
        imgs["flip"] = dict(path=rel(cdir / "flip.png"), caption="FLIP error map (HDR%s)" % ex,
                            colorbar=dict(gradient=I.css_gradient(I.SEQUENTIAL), labels=[0.0, 0.5, 1.0]))
    result["images"] = imgs
    with open(cdir / "case.json", "w") as f:
        json.dump(clean(result), f, indent=1)
    return result


# --------------------------------------------------------------------------- html

def _badge(status, href=None):
    cls = status.replace(" ", "-")
    if href:
        return '<a class="badge %s" href="%s">%s</a>' % (cls, href, html.escape(status))
    return '<span class="badge %s">%s</span>' % (cls, html.escape(status))


def _anchor(case):
    return "case-" + case["dir"]


def key_metric(case):
    m = case.get("metrics") or {}
    if case["status"] in ("SKIPPED",):
        return case.get("reason", "")
    if "gonio" in m:
        g = m["gonio"]
        return "median %s, p99 %s" % (fmt(g.get("median")), fmt(g.get("p99")))
    if "mean_bias" in m:
        b = m["mean_bias"]
        s = "bias %+.2f%% (z %+.1f)" % (100 * b["rel"], b["z"]) if isinstance(b.get("z"), float) else ""
        w = m.get("welch")
        if w:
            s += ", Welch fails %d" % w["n_fail"]
        return s
    return (case.get("reason") or "")[:80]


def _matrix(cases):
    rows = {}
    targets = []
    for c in cases:
        name = c["scene"] + ("-" + c["variant"] if c.get("variant") else "")
        lab = c["blender"]["label"]
        if lab not in targets:
            targets.append(lab)
        rows.setdefault(name, {})[lab] = c
    out = ["<table><tr><th>scene</th>%s</tr>" % "".join("<th>%s</th>" % html.escape(t) for t in targets)]
    for name in sorted(rows):
        cells = []
        for t in targets:
            c = rows[name].get(t)
            if c is None:
                cells.append("<td>&ndash;</td>")
            else:
                cells.append('<td>%s <span class="cell-note">%s</span></td>' % (
                    _badge(c["status"], "#" + _anchor(c)), html.escape(key_metric(c))))
        out.append("<tr><th>%s</th>%s</tr>" % (html.escape(name), "".join(cells)))
    out.append("</table>")
    return "\n".join(out)


def _figure(key, im, case):
    """One image; a click opens it full size (the viewer in page.html).  The reference's figure is a
    wipe: ours lies over it, and the slider below sets where ours begins."""
    label = im.get("label") or key
    if key == "cycles" and im.get("swap"):
        img = ('<div class="wipe"><img class="view" src="%s" alt="%s" data-b="%s" data-title="%s | %s">'
               '<img class="top" src="%s" alt="%s"></div>'
               '<input class="wipe-range" type="range" min="0" max="100" value="50" aria-label="wipe position">'
               % (html.escape(im["path"]), html.escape(label), html.escape(im["swap"]), html.escape(label),
                  html.escape(im.get("swap_label", "")), html.escape(im["swap"]),
                  html.escape(im.get("swap_label", ""))))
        caption = "left: %s; right: %s (drag the slider). %s" % (label, im.get("swap_label", ""), im["caption"])
    else:
        img = '<img class="view" src="%s" alt="%s" data-title="%s">' % (
            html.escape(im["path"]), html.escape(key), html.escape(im["caption"]))
        caption = im["caption"]
    cb = ""
    if im.get("colorbar"):
        labels = "".join("<span>%s</span>" % (fmt(l) if not isinstance(l, str) else html.escape(l))
                         for l in im["colorbar"]["labels"])
        cb = '<div class="cbar" style="background: %s"></div><div class="cbar-labels">%s</div>' % (
            im["colorbar"]["gradient"], labels)
    links = [' <a href="%s">EXR</a>' % html.escape(im["exr"])] if im.get("exr") else []
    if im.get("var_exr"):
        links.append(' <a href="%s">variance EXR</a>' % html.escape(im["var_exr"]))
    return '<figure class="%s">%s%s<figcaption>%s</figcaption>%s</figure>' % (
        "pair" if key == "cycles" and im.get("swap") else key, img, cb, html.escape(caption), "".join(links))


def _check_badge(ch):
    """Gates: PASS or FAIL.  Informational rows never FAIL: a neutral 'within' or 'over' (their limit)."""
    if ch["name"] == "exact_effect":
        return "INFO"
    if ch["gate"]:
        return "PASS" if ch["passed"] else "FAIL"
    if ch.get("value") is None:
        return "n/a"
    return "within" if ch["passed"] else "over"


def _checks_table(case):
    rows = ['<table class="metrics"><tr><th>metric</th><th>value</th><th>limit</th><th>result</th><th>role</th>'
            '<th>detail</th></tr>']
    for ch in case.get("checks", []):
        limit = "" if ch.get("limit") is None else "%s %s" % (html.escape(ch["op"]), fmt(ch["limit"]))
        cls = "failrow" if (ch["gate"] and not ch["passed"]) else ("inforow" if not ch["gate"] else "")
        rows.append('<tr class="%s"><td>%s</td><td class="num">%s</td><td class="num">%s</td><td>%s</td>'
                    '<td>%s</td><td>%s</td></tr>' % (
                        cls, html.escape(ch["label"]), fmt(ch["value"]), limit, _badge(_check_badge(ch)),
                        '<span class="badge gate">gate</span>' if ch["gate"] else
                        '<span class="badge infoonly">info</span>', html.escape(ch.get("detail", ""))))
    rows.append("</table>")
    return "\n".join(rows)


def _kv_table(d):
    if not d:
        return "<p>&ndash;</p>"
    return "<table>%s</table>" % "".join("<tr><th>%s</th><td>%s</td></tr>" % (html.escape(str(k)), fmt(v))
                                         for k, v in d.items())


def _renders_table(case):
    rows = ["<table><tr><th>render</th><th>seed</th><th>status</th><th>render s</th><th>process s</th>"
            "<th>cached</th><th>note</th></tr>"]
    for r in case.get("renders", []):
        label = {"cycles": "Cycles", "ours": "engine", "exact": "engine, exact"}.get(r["kind"], r["kind"])
        rows.append("<tr><td>%s</td><td class=num>%s</td><td>%s</td><td class=num>%s</td><td class=num>%s</td>"
                    "<td>%s</td><td>%s</td></tr>" % (label, fmt(r.get("seed")), html.escape(str(r.get("status"))),
                                                     fmt(r.get("seconds")), fmt(r.get("wall")),
                                                     "yes" if r.get("cached") else "",
                                                     html.escape(r.get("error") or "")))
    rows.append("</table>")
    return "".join(rows)


def _case_html(case):
    st = case["status"]
    cls = {"PASS": "ok", "INFO": "ok", "FAIL": "bad", "PENDING": "pending", "SKIPPED": ""}.get(st, "crash")
    parts = ['<section class="case %s" id="%s" data-status="%s">' % (cls, _anchor(case), html.escape(st))]
    name = case["scene"] + (" &middot; " + html.escape(case["variant"]) if case.get("variant") else "")
    parts.append("<h2>%s %s &middot; %s &middot; %s</h2>" % (_badge(st), name, html.escape(case["blender"]["label"]),
                                                             html.escape(case.get("title", ""))))
    if case.get("reason"):
        parts.append('<p class="reason">%s</p>' % html.escape(case["reason"]))
    if st == "PENDING":
        parts.append('<p class="reason">pending: %s%s</p>' % (
            html.escape(str(case.get("pending"))),
            " (measured status: %s)" % case["pending_status"] if case.get("pending_status") else ""))
    if case.get("description"):
        parts.append('<p class="desc">%s</p>' % html.escape(case["description"]))
    if case.get("reproduce"):
        parts.append('<p class="repro">reproduce: <code>%s</code> <button type="button" class="copy">copy</button>'
                     '</p>' % html.escape(case["reproduce"]))
    ims = case.get("images") or {}
    if ims:
        parts.append('<div class="figs">%s</div>' % "".join(
            _figure(k, ims[k], case) for k in ("cycles", "ours", "diff", "z", "rel", "flip") if k in ims))
    if case.get("checks"):
        parts.append(_checks_table(case))
    if case.get("engine_warnings"):
        parts.append('<details open><summary>engine warnings (%d)</summary><ul class="warnings">%s</ul></details>' % (
            len(case["engine_warnings"]), "".join("<li>%s</li>" % html.escape(w) for w in case["engine_warnings"])))
    if case.get("parity_warnings"):
        parts.append('<details open><summary>settings that break parity (%d)</summary><ul class="warnings">%s</ul>'
                     '</details>' % (len(case["parity_warnings"]),
                                     "".join("<li>%s</li>" % html.escape(w) for w in case["parity_warnings"])))
    if case.get("log_tail"):
        parts.append("<details open><summary>log (tail)</summary><pre>%s</pre></details>" % html.escape(
            case["log_tail"]))
    sizes = dict(case.get("sizes") or {})
    sizes["engine"] = case.get("engine")
    if case.get("hair_model"):
        sizes["hair model (--model)"] = case["hair_model"].get("label")
        parts.append("<details open><summary>hair model: %s in place of Principled Hair</summary><pre>%s</pre>"
                     "</details>" % (html.escape(case["hair_model"].get("label", "")), html.escape(json.dumps(
                         dict(model=case["hair_model"], parameters_per_material=case.get("hair_model_params")),
                         indent=1, default=str))))
    sizes["Cycles shading system"] = "OSL" if case.get("osl") else "SVM"
    parts.append("<details><summary>sizes, settings and versions</summary><div class=figs>%s%s%s</div></details>" % (
        _kv_table(sizes), _kv_table(case.get("settings")), _kv_table(dict(
            (case.get("versions") or {}), blender_target=case["blender"]["label"],
            blender_path=case["blender"]["path"]))))
    parts.append("<details><summary>renders</summary>%s</details>" % _renders_table(case))
    info = (case.get("build") or {}).get("info")
    if info:
        parts.append("<details><summary>scene build info</summary><pre>%s</pre></details>" % html.escape(
            json.dumps(clean(info), indent=1)[:20000]))
    parts.append("</section>")
    return "\n".join(parts)


def summarize(cases):
    counts = {}
    for c in cases:
        counts[c["status"]] = counts.get(c["status"], 0) + 1
    bad = sum(counts.get(s, 0) for s in BAD)
    return dict(counts=counts, total=len(cases), bad=bad, ok=bad == 0 and len(cases) > 0)


DEFAULT_TITLE = "hairbsdf vs Cycles"


def render_index(cases, run, title=DEFAULT_TITLE, tool="hairbsdf compare"):
    summ = summarize(cases)
    cases = sorted(cases, key=lambda c: (ORDER.get(c["status"], 9), c["id"]))
    counts = ", ".join("%d %s" % (n, s) for s, n in sorted(summ["counts"].items(), key=lambda x: ORDER.get(x[0], 9)))
    if summ["total"] == 0:
        verdict, vcls = "no cases", "none"
    elif summ["bad"]:
        verdict, vcls = "%d of %d cases need attention" % (summ["bad"], summ["total"]), "bad"
    else:
        n = summ["total"] - summ["counts"].get("PENDING", 0) - summ["counts"].get("SKIPPED", 0)
        verdict, vcls = ("the case passes" if summ["total"] == 1 else "all %d gated cases pass" % n), "ok"
    runs = run if isinstance(run, list) else [run]
    run_txt = " | ".join("%s; %s; %s%s%s" % (html.escape(r.get("created", "")), html.escape(r.get("command", "")),
                                             html.escape(r.get("hairbsdf", "")),
                                             " (git %s)" % html.escape(r["git"]) if r.get("git") else "",
                                             "; hair model: %s" % html.escape(r["hair_model"]["label"])
                                             if r.get("hair_model") else "")
                         + _cluster_and_sweep(r) for r in runs if r)
    legend = ("PASS: every gating metric within its threshold (hairbsdf/compare/thresholds.toml); FAIL: one is not; "
              "CRASH / NO OUTPUT: the engine's render crashed or produced no image; ERROR: the scene or the Cycles "
              "render failed; PENDING: measured, not gated (a feature the engine lacks); SKIPPED: not for this "
              "Blender.")
    tpl = string.Template((TEMPLATES / "page.html").read_text())
    return tpl.substitute(
        title=html.escape(title), verdict=html.escape(verdict), verdict_class=vcls,
        summary=html.escape(counts), run=run_txt, matrix=_matrix(cases), legend=html.escape(legend),
        cases="\n".join(_case_html(c) for c in cases),
        footer="Generated by %s. Metrics: docs/compare.md." % html.escape(tool),
        css=(TEMPLATES / "report.css").read_text(), js=(TEMPLATES / "report.js").read_text())


def _cluster_and_sweep(run):
    """The run line's note on a Dask run (cluster.py) and the link to a sweep's view (sweep.py)."""
    out = ""
    cl = run.get("cluster")
    if cl:
        out += "; %s, %d worker%s" % (html.escape(cl.get("scheduler", "")), len(cl.get("workers") or []),
                                      "" if len(cl.get("workers") or []) == 1 else "s")
    if run.get("sweep"):
        out += '; <a href="%s">sweep view</a>' % html.escape(run["sweep"].get("page", "sweep.html"))
    return out


# --------------------------------------------------------------------------- junit

def junit_xml(cases, seconds=0.0):
    suites = ET.Element("testsuites", name="hairbsdf.compare")
    by_target = {}
    for c in cases:
        by_target.setdefault(c["blender"]["label"], []).append(c)
    for label, cs in sorted(by_target.items()):
        s = ET.SubElement(suites, "testsuite", name="hairbsdf.compare.%s" % label, tests=str(len(cs)))
        nf = ne = ns = 0
        for c in sorted(cs, key=lambda c: c["id"]):
            t = sum((r.get("wall") or 0.0) for r in c.get("renders", []) if not r.get("cached"))
            tc = ET.SubElement(s, "testcase", classname="hairbsdf.compare.%s" % label.replace(".", "_"),
                               name=c["scene"] + ("-" + c["variant"] if c.get("variant") else ""), time="%.2f" % t)
            lines = ["%s: %s (limit %s %s) %s%s" % (ch["name"], ch["value"], ch["op"], ch["limit"],
                                                     _check_badge(ch), "" if ch["gate"] else " [info]")
                     for ch in c.get("checks", [])]
            st = c["status"]
            if st == "FAIL":
                nf += 1
                el = ET.SubElement(tc, "failure", message=c.get("reason") or "threshold exceeded", type="FAIL")
                el.text = "\n".join(lines)
            elif st in ("CRASH", "NO OUTPUT", "ERROR"):
                ne += 1
                el = ET.SubElement(tc, "error", message=c.get("reason") or st, type=st)
                el.text = c.get("log_tail", "")
            elif st in ("SKIPPED", "PENDING"):
                ns += 1
                msg = c.get("reason") if st == "SKIPPED" else "pending: %s (measured %s)" % (
                    c.get("pending"), c.get("pending_status"))
                ET.SubElement(tc, "skipped", message=msg or st)
            out = ET.SubElement(tc, "system-out")
            out.text = "\n".join(lines)
        s.set("failures", str(nf))
        s.set("errors", str(ne))
        s.set("skipped", str(ns))
    suites.set("time", "%.2f" % seconds)
    return ET.tostring(suites, encoding="unicode")


# --------------------------------------------------------------------------- write / merge

def write_report(out_dir, cases, run, title=DEFAULT_TITLE, tool="hairbsdf compare"):
    """index.html (titled `title`), report.json and junit.xml in out_dir."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    cases = [clean(c) for c in cases]
    data = dict(format=FORMAT, format_version=FORMAT_VERSION, title=title, tool=tool,
                runs=run if isinstance(run, list) else [run], summary=summarize(cases), cases=cases)
    _atomic(out_dir / "report.json", json.dumps(data, indent=1))
    secs = sum(float(r.get("seconds", 0) or 0) for r in data["runs"])
    _atomic(out_dir / "junit.xml", '<?xml version="1.0" encoding="UTF-8"?>\n' + junit_xml(cases, secs))
    _atomic(out_dir / "index.html", render_index(cases, data["runs"], title, tool))
    return out_dir / "index.html"


def _atomic(path, text):
    tmp = str(path) + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def load_report(d):
    p = Path(d) / "report.json"
    with open(p) as f:
        data = json.load(f)
    if data.get("format") != FORMAT:
        raise ValueError("%s is not a hairbsdf compare report" % p)
    return data


def merge(dirs, out):
    """Joins shard reports: copies each case's folder and writes one index, report.json and
    junit.xml.  A case present in several inputs is taken from the last one."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cases, runs, notes, titles = {}, [], [], []
    for d in dirs:
        d = Path(d)
        data = load_report(d)
        titles.append(data.get("title", DEFAULT_TITLE))
        runs.extend(data.get("runs", []))
        for c in data["cases"]:
            if c["id"] in cases:
                notes.append("%s appears in more than one report; using %s" % (c["id"], d))
            src = d / "cases" / c["dir"]
            dst = out / "cases" / c["dir"]
            if src.exists() and src.resolve() != dst.resolve():
                if dst.exists():
                    shutil.rmtree(dst)
                shutil.copytree(src, dst)
            cases[c["id"]] = c
    merged_run = dict(created=_now(), command="hairbsdf report merge " + " ".join(str(d) for d in dirs),
                      hairbsdf=runs[0].get("hairbsdf", "") if runs else "", merged_from=[str(d) for d in dirs],
                      seconds=sum(float(r.get("seconds", 0) or 0) for r in runs), notes=notes)
    path = write_report(out, list(cases.values()), [merged_run] + runs,
                        title=titles[0] if titles else DEFAULT_TITLE, tool="hairbsdf report merge")
    return path, notes


def _now():
    return datetime.datetime.now().astimezone().isoformat(timespec="seconds")


def summary_lines(cases):
    out = []
    w = max([len(c["id"]) for c in cases] + [10])
    for c in sorted(cases, key=lambda c: (ORDER.get(c["status"], 9), c["id"])):
        text = key_metric(c)
        if c["status"] in BAD and c.get("reason"):
            text = (text + "; " if text and c["status"] == "FAIL" else "") + c["reason"]
        out.append("  %-10s %-*s  %s" % (c["status"], w, c["id"], text[:200]))
    return out
