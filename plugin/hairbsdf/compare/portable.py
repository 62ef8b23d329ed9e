"""`hairbsdf scenes`: the scene library in a form any renderer reads (docs/portable_scenes.md).

    hairbsdf scenes list
    hairbsdf scenes export NAME|all --out DIR [--tar]     one folder (or DIR/NAME.tar.gz) per scene
    hairbsdf scenes render FOLDER --out DIR [--seeds N]   our renderer on an exported description, no Blender

An exported folder holds the USD (geometry, camera, lights; hair as Curves with widths), the
MaterialX document or the list of what MaterialX cannot express, render_settings.json, our scene
description (hairbsdf_scene.npz), Cycles' per-seed references at CI size and a README.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
import math
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

from ..render import CLOSURES, PRINCIPLED_HAIR_INPUTS, schema_default

FORMAT = "hairbsdf-portable-scene"
FORMAT_VERSION = 1
SCENE_FILE = "hairbsdf_scene.npz"
USD_FILE = "scene.usda"
MATERIALX_FILE = "materials.mtlx"
SETTINGS_FILE = "render_settings.json"
MANIFEST_FILE = "portable.json"
MATERIALS_JSON = "materials.json"
REFERENCE_DIR = "references/cycles"
MIN_JUDGE_SEEDS = 2  # hairbsdf judge needs a spread: noise-free scenes get two (identical) Cycles seeds
JOB_SCRIPT = Path(__file__).resolve().parent / "portable_job.py"

EPILOG = """\
examples:
  hairbsdf scenes list
  hairbsdf scenes export swatch --out out/portable               -> out/portable/swatch/
  hairbsdf scenes export all --out out/portable --tar            -> out/portable/NAME.tar.gz per scene
  hairbsdf scenes render out/portable/swatch --out out/mine      our renderer, no Blender
  hairbsdf judge out/portable/swatch/references/cycles out/mine  judge it (docs/compare.md)

exit status: 0 done, 1 a scene failed to export or render, 2 bad arguments.
"""


class UsageError(ValueError):
    pass


# --------------------------------------------------------------------------- scene keys

def _key(section: dict, path: str, closure_type: str = ""):
    """section's value of the scene key `path` (its last part), or the key's default from the scene schema."""
    name = path.rsplit(".", 1)[-1]
    return section[name] if section.get(name) is not None else schema_default(path, closure_type)


CLOSURE = CLOSURES + "."
INPUT = PRINCIPLED_HAIR_INPUTS + "."


# --------------------------------------------------------------------------- MaterialX

def materialx_limits(desc) -> dict:
    """{material name: [what MaterialX's chiang_hair_bsdf cannot express exactly]} for every material
    of the description (an empty list: exact). Keys not given take the scene schema's defaults."""
    tilt = _key(desc.get("integrator", {}), "integrator.tilt")
    out = {}
    for m in desc.get("materials", []):
        limits = []
        if m.get("program"):
            limits.append("node networks on closure inputs (evaluated per hit by our shading VM)")
        closures = m.get("closures", [])
        weights = [_key(c, CLOSURE + "weight") for c in closures]  # {"register": k}: a computed Mix Shader weight
        if len(closures) > 1 or any(isinstance(w, dict) or tuple(w) != (1.0, 1.0, 1.0) for w in weights):
            limits.append("Mix / Add of closures")
        for c in closures:
            t = c.get("type")
            if t == "cycles_hair":
                limits.append("the legacy Hair BSDF")
            elif t == "hair_model":
                limits.append("a zoo model or plugin (%s)" % c.get("model"))
            elif t == "principled_hair":
                # an input driven by a node network ({"register": k}) counts as possibly non-zero
                inp = {k: (1.0 if isinstance(v, dict) else v) for k, v in c.get("inputs", {}).items()}
                if _key(c, CLOSURE + "model", t) == "HUANG":
                    limits.append("the Huang model")
                    continue
                if float(_key(inp, INPUT + "coat")) != 0.0:
                    limits.append("Coat")
                if tilt != "3.4" and float(_key(inp, INPUT + "offset")) != 0.0:
                    limits.append("the tilt convention (Blender 4.2+ tilts the outgoing direction; chiang_hair_bsdf's "
                                  "cuticle_angle follows Blender 3.4's convention)")
                if float(_key(inp, INPUT + "random_color")) or float(_key(inp, INPUT + "random_roughness")):
                    limits.append("per-strand Random Color / Random Roughness (a node graph on the primvar "
                                  "hairbsdf_random)")
            elif t not in ("diffuse", "emission"):
                limits.append("closure type %s" % t)
        out[m.get("name", "?")] = sorted(set(limits))
    return out


def _ident(name):
    s = "".join(ch if ch.isalnum() or ch == "_" else "_" for ch in name)
    return s if s and not s[0].isdigit() else "m_" + s


def write_materialx(desc, path):
    """One MaterialX document with a surfacematerial per material (only call it when
    materialx_limits is empty for every material)."""
    from .. import materialx
    mx = materialx._mx()
    doc = mx.createDocument()
    for m in desc.get("materials", []):
        name = _ident(m["name"])
        c = (m.get("closures") or [dict(type="diffuse")])[0]
        if c["type"] == "principled_hair":
            inputs = {k: v for k, v in c.get("inputs", {}).items() if k != "random" and v is not None}
            inputs = {k: (tuple(float(x) for x in v) if hasattr(v, "__len__") else float(v)) for k, v in inputs.items()}
            part = mx.createDocument()
            parametrization = _key(c, CLOSURE + "parametrization", c["type"]).lower()
            mx.readFromXmlString(part, materialx.export(None, parametrization=parametrization, name=name, **inputs))
            for elem in part.getChildren():
                copy = doc.addChildOfCategory(elem.getCategory(), elem.getName())
                copy.copyContentFrom(elem)
            doc.getChild(name).setDocString("Blender material %s (Principled Hair, Chiang)" % m["name"])
            continue
        if c["type"] == "diffuse":
            node = doc.addNode("oren_nayar_diffuse_bsdf", name + "_bsdf", "BSDF")
            color = _key(c, CLOSURE + "color", c["type"])
            node.setInputValue("color", ", ".join(repr(float(v)) for v in color), "color3")
            node.setInputValue("roughness", "0.0", "float")  # Lambert, as Cycles' Diffuse BSDF at roughness 0
            surface = doc.addNode("surface", name + "_surface", "surfaceshader")
            surface.setConnectedNode("bsdf", node)
        else:  # emission
            strength = float(_key(c, CLOSURE + "strength", c["type"]))
            col = [float(v) * strength for v in _key(c, CLOSURE + "color", c["type"])]
            node = doc.addNode("uniform_edf", name + "_edf", "EDF")
            node.setInputValue("color", ", ".join(repr(v) for v in col), "color3")
            surface = doc.addNode("surface", name + "_surface", "surfaceshader")
            surface.setConnectedNode("edf", node)
        mat = doc.addMaterialNode(name, surface)
        mat.setDocString("Blender material %s" % m["name"])
    check = mx.createDocument()
    check.importLibrary(materialx._stdlib())
    check.copyContentFrom(doc)
    ok, message = check.validate()
    if not ok:
        raise RuntimeError("internal: the MaterialX document does not validate: %s" % message)
    mx.writeToXmlFile(doc, str(path))


# --------------------------------------------------------------------------- settings, README

def _plain(x):
    """JSON-able copy: arrays and tuples as lists, NumPy scalars as numbers."""
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if hasattr(x, "tolist"):
        return x.tolist()
    return x


def render_settings(desc, blender_settings, seeds, blender_seeds, blender_version):
    """What a renderer needs besides the scene files; keys not given take the scene schema's defaults."""
    integ, cam = desc["integrator"], desc["camera"]
    setting = lambda name: _key(integ, "integrator." + name)  # noqa: E731
    return {
        "resolution": [int(v) for v in cam["resolution"]],
        "spp": int(integ["samples"]),
        "seeds": dict(count=len(seeds), harness_seeds=list(seeds), cycles_seeds=list(blender_seeds),
                      note="each reference EXR is one independent Cycles render; render yours with other seeds"),
        "bounces": {k: int(integ[k]) for k in ("max_bounces", "diffuse_bounces", "glossy_bounces",
                                                 "transmission_bounces", "transparent_bounces",
                                                 "min_light_bounces") if k in integ},
        "pixel_filter": dict(type=integ["filter_type"], width_px=float(integ["filter_width"])),
        "exposure": dict(film_exposure=float(setting("exposure")),
                         note="a linear multiplier on the image (Cycles' Film > Exposure)"),
        "colour_space": dict(working="scene-linear Rec.709 primaries, D65 (Blender's default 'Linear Rec.709')",
                             references="linear float32 RGBA OpenEXR, no view transform, alpha = coverage",
                             view_transform=blender_settings.get("view_settings.view_transform")),
        "light_sampling": dict(light_tree=bool(setting("light_tree")),
                               light_threshold=float(setting("light_sampling_threshold")),
                               multiple_importance_sampling={
                                   "%s_%d" % (lt.get("type", "?"), i): bool(_key(lt, "lights[].use_mis"))
                                   for i, lt in enumerate(desc.get("lights", []))},
                               world_mis=bool(_key(desc.get("world", {}), "world.mis"))),
        "filter_glossy": float(setting("filter_glossy")),
        "clamp": dict(direct=float(setting("clamp_direct")), indirect=float(setting("clamp_indirect"))),
        "film_transparent": bool(setting("film_transparent")),
        "curves": dict(shape=_key(desc, "curve_shape"), subdivisions=int(_key(desc, "curve_subdivisions")),
                       backface_culling=bool(_key(desc, "curve_backface_culling"))),
        "principled_hair_tilt": integ.get("tilt"),
        "blender_version": blender_version,
        "blender": blender_settings,
    }


README = """\
# {title} (`{case}`)

{description}

Exported by `hairbsdf scenes export` (hairbsdf {version}) from the hairbsdf scene library, rendered by
Cycles in Blender {blender} at the harness's CI size: {res[0]} x {res[1]} pixels, {spp} samples per pixel,
{seeds} independent seeds. Kind: {kind}. Format: docs/portable_scenes.md of the hairbsdf repository.

## Files

| file | what |
|---|---|
| `{usd}` | geometry, camera and lights (Blender's USD exporter; hair as BasisCurves: Catmull-Rom, pinned, widths = 2 x radius, primvar `hairbsdf_random` = Hair Info > Random); metres, Z up |
| `{mtlx}` | {mtlx_what} |
| `{materials}` | every material as our description has it: the closures with their Principled Hair inputs (angles in radians; `random` null = Hair Info > Random, the primvar), weights, node-network programs; the hair prim `hair_NAME` uses material NAME |
| `{settings}` | resolution, spp, seeds, bounces, pixel filter, exposure, colour space, light sampling; `blender` holds Blender's own property values |
| `{scene}` | our scene description, exactly what the hairbsdf engine renders (`hairbsdf.scene_file.load_scene`, no Blender needed) |
| `{refs}/seed_NN.exr` | Cycles' references: one linear float32 RGBA EXR per seed |
| `{manifest}` | all of the above, machine-readable |

## MaterialX

{mtlx_text}

## Judge your renderer

1. Render the scene {seeds} or more times, each with its own random seed, at {res[0]} x {res[1]} and {spp} spp
   with the settings of `{settings}`; write linear float32 EXRs (RGBA or RGB; the same channels as the
   references), one per seed, into a folder, say `mine/`.
2. `pip install 'hairbsdf[compare]'` (no Blender needed), then

       hairbsdf judge {refs} mine --out judge_report

   Exit status 0 means no pixel and no image-mean bias is distinguishable from noise at a 1 % false-alarm
   level; `judge_report/index.html` shows where the images differ.

{deterministic}Our own renderer does the same without Blender: `hairbsdf scenes render . --out mine` then the judge line.
"""
DETERMINISTIC_NOTE = """\
This scene is noise-free (1 spp at the pixel centre, delta lights): the two reference seeds are the same image,
so the judge gates the image mean (to about 4e-4 of it) but its per-pixel test has no power. Compare per pixel
too, as `hairbsdf compare` does: |yours - Cycles| / max(|Cycles|, 1e-3 x the brightest strand pixel) on pixels
covered 2 px inside the strands, median <= 1e-4 and 99th percentile <= 2e-3.

"""


# --------------------------------------------------------------------------- export

def _progress(enabled):
    def say(text):
        if enabled:
            print("[hairbsdf scenes] %s" % text, file=sys.stderr, flush=True)
    return say


def export_scenes(names, out, *, tar=False, blender="bpy", cache=None, jobs=2, timeout=900, progress=True):
    """Exports library scenes (names: scene, scene:variant or 'all') into out. Returns a list of
    {case, ok, path, error}."""
    from .. import _version
    from .._blender_versions import SCENES_EXPORT_FROM
    from .runner import Options, Runner, Target, TargetError, blender_seed, default_cache_dir, expand_cases, \
        resolve_target, safe
    say = _progress(progress)
    try:  # the names first: a typo should not wait for Blender
        expand_cases(names, [Target("check", "bpy", "", "check", (99, 0, 0))], ci=True)
    except ValueError as exc:
        raise UsageError("NAME: %s" % exc)
    try:
        target = resolve_target(blender)
    except TargetError as exc:
        raise UsageError("--blender %s: %s" % (blender, exc))
    if target.kind != "bpy" or target.version < SCENES_EXPORT_FROM:
        raise UsageError("--blender %s: export needs the bpy module of Blender 4.x or 5.x (USD export; Debian's "
                         "Blender 3.4 has none), e.g. bpy or bpy5" % blender)
    try:
        cases = expand_cases(names, [target], ci=True)
    except ValueError as exc:
        raise UsageError("NAME: %s" % exc)
    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="hairbsdf_export_"))
    runner = Runner(cases, Options(out=work, cache=Path(cache or default_cache_dir()), jobs=jobs, timeout=timeout,
                                   ci=True, progress=False))
    results = []
    try:
        for k, case in enumerate(cases):
            name = case.id.split("@")[0]
            say("%d/%d %s: building the scene" % (k + 1, len(cases), name))
            if case.skip:
                results.append(dict(case=name, ok=False, error="skipped: " + case.skip))
                continue
            try:
                results.append(_export_case(runner, case, name, out, work, tar, say, _version.__version__,
                                            blender_seed, safe))
            except Exception as exc:  # one scene's fault must not stop the others
                results.append(dict(case=name, ok=False, error="%s: %s" % (type(exc).__name__, exc)))
            r = results[-1]
            say("%d/%d %s: %s" % (k + 1, len(cases), name,
                                  ("wrote " + r["path"]) if r["ok"] else "FAILED: " + r["error"]))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return results


def _export_case(runner, case, name, out, work, tar, say, version, blender_seed, safe):
    from ..scene_file import load_scene
    final = out / safe(name)
    if not tar and final.exists() and not (final / MANIFEST_FILE).is_file():  # never delete what we did not write
        return dict(case=name, ok=False, error="%s exists and is not an exported scene (no %s); remove it or "
                    "choose another --out" % (final, MANIFEST_FILE))
    b = runner.build(case)
    if not b.get("ok"):
        return dict(case=name, ok=False, error="building the scene failed: %s" % b.get("error"))
    n = max(case.seeds, MIN_JUDGE_SEEDS)
    say("%s: %d Cycles renders (cached ones are reused)" % (name, n))
    case_dir = work / "cases" / case.dirname
    with cf.ThreadPoolExecutor(max_workers=max(1, runner.o.jobs)) as pool:
        refs = list(pool.map(lambda s: runner.render_one(case, b["blend"], "CYCLES", "CYCLES", s, case_dir),
                             range(n)))
    bad = [r for r in refs if not r.get("ok")]
    if bad:
        return dict(case=name, ok=False, error="a Cycles render failed: %s" % bad[0].get("error"))
    folder = work / "staging" / safe(name)  # moved to out only when complete: a failure leaves nothing there
    folder.mkdir(parents=True)
    say("%s: writing USD and our description (bpy %s)" % (name, ".".join(map(str, case.target.version[:2]))))
    job = dict(blend=b["blend"], res=list(case.res), spp=case.spp, out_dir=str(folder),
               result=str(work / (safe(name) + ".result.json")))
    job_path = work / (safe(name) + ".job.json")
    job_path.write_text(json.dumps(job))
    log = work / (safe(name) + ".log")
    with open(log, "w") as f:
        subprocess.run([case.target.path, str(JOB_SCRIPT), str(job_path)], stdout=f, stderr=subprocess.STDOUT,
                       timeout=runner.o.timeout, cwd=str(work))
    if not Path(job["result"]).exists():
        return dict(case=name, ok=False, error="the export job wrote no result: %s" % log.read_text()[-2000:])
    res = json.loads(Path(job["result"]).read_text())
    if not res.get("ok"):
        return dict(case=name, ok=False, error=res.get("error", "export job failed"))
    desc, _ = load_scene(folder / SCENE_FILE)

    refdir = folder / REFERENCE_DIR
    refdir.mkdir(parents=True)
    for s, r in enumerate(refs):
        shutil.copy(r["exr"], refdir / ("seed_%02d.exr" % s))
    blender_seeds = [blender_seed(case.target.version, s) for s in range(n)]
    settings = render_settings(desc, res["blender_settings"], list(range(n)), blender_seeds, res["blender"])
    (folder / SETTINGS_FILE).write_text(json.dumps(settings, indent=1, default=str) + "\n")

    (folder / MATERIALS_JSON).write_text(json.dumps(_plain(desc["materials"]), indent=1) + "\n")
    limits = materialx_limits(desc)
    scene_limits = sorted({l for v in limits.values() for l in v})
    if not scene_limits:
        write_materialx(desc, folder / MATERIALX_FILE)
        mtlx_what = "the materials as MaterialX 1.39 (`chiang_hair_bsdf` for hair)"
        mtlx_text = ("Every material is expressed exactly: `chiang_hair_bsdf` with the inputs of our Principled "
                     "Hair mapping (hairbsdf.materialx). It evaluates exact special functions where Cycles "
                     "truncates a Bessel series (below 1 % on image means; docs/compare.md).")
    else:
        mtlx_what = "not written: this scene is exported with our own description only (below)"
        mtlx_text = ("**Our description only.** MaterialX cannot express exactly:\n\n" + "\n".join(
            "* `%s`: %s" % (m, "; ".join(v)) for m, v in limits.items() if v) +
            "\n\nThe materials are in `%s` (and `%s`; docs/scene_desc.md of the hairbsdf repository explains each "
            "input); the USD carries only preview surfaces." % (MATERIALS_JSON, SCENE_FILE))
    manifest = dict(
        format=FORMAT, format_version=FORMAT_VERSION, case=name, scene=case.scene, variant=case.variant,
        kind=case.kind, title=case.meta.get("title"), description=case.meta.get("description"),
        hairbsdf_version=version, blender=res["blender"], blender_label=case.target.label,
        materialx=dict(file=MATERIALX_FILE if not scene_limits else None,
                       status="exact" if not scene_limits else "our description only", limits=limits),
        files=dict(usd=USD_FILE, scene_description=SCENE_FILE, materials=MATERIALS_JSON,
                   render_settings=SETTINGS_FILE, references=REFERENCE_DIR, readme="README.md"),
        references=dict(renderer="Cycles", blender=res["blender"], seeds=n, files=sorted(
            p.name for p in refdir.iterdir()), spp=case.spp, resolution=list(case.res)),
        hair=dict(objects=res["hair_objects"], replaced=res["replaced"], substitution_check=res["substitution_check"]),
        usd_fixes=dict(res.get("usd_fixes", {}), usd_options_left_out=res.get("usd_options_unknown", [])),
        export_warnings=res.get("export_warnings", []), parity_warnings=res.get("parity_warnings", []))
    (folder / MANIFEST_FILE).write_text(json.dumps(manifest, indent=1, default=str) + "\n")
    (folder / "README.md").write_text(README.format(
        title=case.meta.get("title", name), case=name, description=case.meta.get("description", ""),
        version=version, blender=res["blender"], res=list(case.res), spp=case.spp, seeds=n, kind=case.kind,
        usd=USD_FILE, mtlx=MATERIALX_FILE, mtlx_what=mtlx_what, mtlx_text=mtlx_text, settings=SETTINGS_FILE,
        scene=SCENE_FILE, refs=REFERENCE_DIR, manifest=MANIFEST_FILE, materials=MATERIALS_JSON,
        deterministic=DETERMINISTIC_NOTE if case.kind == "deterministic" else ""))
    if tar:
        path = out / (safe(name) + ".tar.gz")
        with tarfile.open(path, "w:gz") as t:
            t.add(folder, arcname=safe(name))
    else:
        path = final
        if final.exists():
            shutil.rmtree(final)
        shutil.move(str(folder), str(final))
    return dict(case=name, ok=True, path=str(path), materialx=manifest["materialx"]["status"])


# --------------------------------------------------------------------------- render (no Blender)

def render_exported(folder, out, *, seeds=None, first_seed=1000, threads=0, say=None):
    """Our renderer on an exported description: one EXR per seed into out. Returns the paths."""
    import numpy as np
    from ..render import render
    from ..scene_file import load_scene
    from .images import write_exr
    folder = Path(folder)
    manifest = json.loads((folder / MANIFEST_FILE).read_text())
    desc, _ = load_scene(folder / SCENE_FILE)
    n = int(seeds or manifest["references"]["seeds"])
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for s in range(n):
        d = dict(desc, integrator=dict(desc["integrator"], seed=int(first_seed + s)))
        img = np.asarray(render(d, threads=threads)["combined"], np.float32)
        p = out / ("seed_%02d.exr" % s)
        write_exr(p, img)
        paths.append(p)
        if say:
            say("rendered %s (%d/%d)" % (p, s + 1, n))
    return paths


# --------------------------------------------------------------------------- CLI

def build_parser(prog="hairbsdf scenes"):
    p = argparse.ArgumentParser(prog=prog, formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
                                description="The scene library: list it, export it for any renderer (USD, "
                                            "MaterialX, render settings, Cycles references), render an export "
                                            "with our renderer.")
    sub = p.add_subparsers(dest="action", metavar="ACTION")
    sub.add_parser("list", help="list the library scenes")
    e = sub.add_parser("export", help="export scenes with their Cycles references",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG)
    e.add_argument("names", nargs="+", metavar="NAME|all", help="library scene, NAME:VARIANT, or all")
    e.add_argument("--out", required=True, help="folder to write one folder (or tarball) per scene into")
    e.add_argument("--tar", action="store_true", help="write NAME.tar.gz per scene instead of a folder")
    e.add_argument("--blender", default="bpy", metavar="bpy|bpy5|PYTHON",
                   help="the bpy module that builds, renders and exports (Blender 4.x/5.x; default bpy)")
    e.add_argument("--cache", default=None, help="the harness's scene and Cycles cache (default: compare's)")
    e.add_argument("--jobs", "-j", type=int, default=2, help="parallel Cycles renders (default 2)")
    e.add_argument("--quiet", "-q", action="store_true", help="no progress lines")
    r = sub.add_parser("render", help="render an exported scene with our renderer (no Blender)",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG)
    r.add_argument("folder", help="an exported scene folder (with %s)" % MANIFEST_FILE)
    r.add_argument("--out", required=True, help="folder for the per-seed EXRs")
    r.add_argument("--seeds", type=int, default=None, help="renders (default: as many as the references)")
    r.add_argument("--first-seed", type=int, default=1000, help="seed of the first render (default 1000)")
    r.add_argument("--threads", type=int, default=0, help="render threads (default: all)")
    r.add_argument("--quiet", "-q", action="store_true", help="no progress lines")
    return p


def main(argv=None, prog="hairbsdf scenes"):
    p = build_parser(prog)
    try:
        args = p.parse_args(argv)
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else 2
    if args.action is None:
        p.print_help(sys.stderr)
        return 2
    if args.action == "list":
        from .runner import load_catalog
        catalog, _ = load_catalog()
        for name, m in catalog.items():
            v = (" (variants: %s)" % ", ".join(m["variants"])) if m.get("variants") else ""
            print("%-18s %-13s %s%s" % (name, m["kind"], m["title"], v))
        return 0
    if args.action == "render":
        folder = Path(args.folder)
        if not (folder / MANIFEST_FILE).is_file():
            print("hairbsdf scenes render: error: FOLDER: %s has no %s (export one with `hairbsdf scenes export`)"
                  % (folder, MANIFEST_FILE), file=sys.stderr)
            return 2
        if args.seeds is not None and args.seeds < 2:
            print("hairbsdf scenes render: error: --seeds must be an integer >= 2 (judge needs a spread), not %d"
                  % args.seeds, file=sys.stderr)
            return 2
        render_exported(folder, args.out, seeds=args.seeds, first_seed=args.first_seed, threads=args.threads,
                        say=None if args.quiet else _progress(True))
        return 0
    if args.jobs < 1:
        print("hairbsdf scenes export: error: --jobs must be an integer >= 1, not %d" % args.jobs, file=sys.stderr)
        return 2
    try:
        results = export_scenes(args.names, args.out, tar=args.tar, blender=args.blender, cache=args.cache,
                                jobs=args.jobs, progress=not args.quiet)
    except UsageError as exc:
        print("hairbsdf scenes export: error: %s" % exc, file=sys.stderr)
        return 2
    failed = [r for r in results if not r["ok"]]
    for r in failed:
        print("hairbsdf scenes export: %s: %s" % (r["case"], r["error"]), file=sys.stderr)
    return 1 if failed else 0
