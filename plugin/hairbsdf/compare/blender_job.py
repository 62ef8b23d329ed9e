"""One harness job, run inside Blender (never imported by the harness itself).

    blender -b --factory-startup --python-exit-code 1 --python blender_job.py -- job.json
    .venv/bin/python blender_job.py job.json                        (the bpy module)

job.json:
  action "build":  build a library scene (catalog module) into an empty file and save it
                   {scenes_dir, module, cfg, blend_out, info_out}; the builder's cfg gets
                   asset_dir = the folder of blend_out, for files the scene refers to
  action "render": open a .blend, set seed / samples / size / engine, render one linear EXR
                   {blend, engine: CYCLES|engine_id, engine_id: our engine's bl_idname (the harness
                    writes hairbsdf._constants.ENGINE_ID), accuracy, default_accuracy: our engine's
                    settings (runner.ACCURACIES, from the scene schema), seed, spp, res,
                    threads, osl, force_parity, exr_out, meta_out, scenes_dir, sites,
                    hair_model: null or {model, path, mapping, label} (--model, our engine only),
                    overrides: [{key, material, node, input, value} | {key, setting, value}] (--sweep)}
Writes meta_out / info_out (JSON) last, so its presence means the job finished.  Uses only
bpy and the standard library: Blender 3.4's Python has no access to the venv.
"""

import hashlib
import json
import os
import sys
import time
import traceback

import bpy


def _argv():
    if "--" in sys.argv:
        return sys.argv[sys.argv.index("--") + 1:]
    return sys.argv[1:]


def _write_json(path, data):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(data, f, indent=1, default=str)
    os.replace(tmp, path)


def _versions():
    return dict(blender=bpy.app.version_string, blender_version=list(bpy.app.version),
                build_hash=getattr(bpy.app, "build_hash", b"").decode() if isinstance(
                    getattr(bpy.app, "build_hash", b""), bytes) else str(getattr(bpy.app, "build_hash", "")),
                is_module=not bool(bpy.app.binary_path), python=sys.version.split()[0])


def exit_blender_process(status=0):
    """Ends a Blender process at once (the bpy module can hang at exit with classes registered, and
    Blender itself exits too), first removing Blender's session temporary folder (bpy.app.tempdir,
    a fresh blender_XXXXXX per process), which only a normal exit would remove."""
    sys.stdout.flush()
    sys.stderr.flush()
    session_temp = bpy.app.tempdir
    if session_temp and os.path.basename(os.path.normpath(session_temp)).startswith("blender_"):
        import shutil
        shutil.rmtree(session_temp, ignore_errors=True)
    os._exit(status)


def _scene_lib(scenes_dir):
    if scenes_dir not in sys.path:
        sys.path.insert(0, scenes_dir)
    import scene_lib  # shipped in the package (hairbsdf/compare/scenes)
    return scene_lib


# --------------------------------------------------------------------------- build

def do_build(job):
    lib = _scene_lib(job["scenes_dir"])
    import importlib
    mod = importlib.import_module(job["module"])
    t0 = time.time()
    scene = lib.reset_scene()
    # asset_dir: where a builder may write files the .blend refers to (e.g. an HDRI)
    cfg = dict(job["cfg"], asset_dir=os.path.dirname(os.path.abspath(job["blend_out"])))
    info = mod.build(scene, cfg) or {}
    settings, warnings = lib.read_parity_settings(scene)
    bpy.ops.wm.save_as_mainfile(filepath=job["blend_out"], check_existing=False)
    _write_json(job["info_out"], dict(ok=True, info=info, settings=settings, parity_warnings=warnings,
                                      versions=_versions(), seconds=time.time() - t0))


# --------------------------------------------------------------------------- engine

def _engines():
    return [getattr(c, "bl_idname", None) for c in bpy.types.RenderEngine.__subclasses__()]


def ensure_hairbsdf(sites, engine_id):
    """Registers our engine (bl_idname engine_id): the installed add-on (scripts/install_blender_addon)
    or the hairbsdf package (venv for the bpy module, else a staged copy).  Returns (how, errors)."""
    errors = []
    if engine_id in _engines():
        return "already registered", errors

    def from_package():
        for site in sites or []:
            if site and os.path.isdir(site) and site not in sys.path:
                sys.path.insert(0, site)
        import hairbsdf.blender
        hairbsdf.blender.register()
        return "hairbsdf.blender.register() from %s" % os.path.dirname(os.path.dirname(hairbsdf.blender.__file__))

    def from_addon():
        import addon_utils
        for name in ("hairbsdf_blender", "bl_ext.user_default.hairbsdf_blender"):
            try:
                mod = addon_utils.enable(name, default_set=False, handle_error=lambda exc: errors.append(
                    "add-on %s: %s" % (name, exc)))
            except Exception as exc:  # pragma: no cover
                errors.append("add-on %s: %s" % (name, exc))
                mod = None
            if mod is not None and engine_id in _engines():
                return "add-on " + name
        raise RuntimeError("no hairbsdf add-on installed (scripts/install_blender_addon)")

    order = (from_package, from_addon) if not bpy.app.binary_path else (from_addon, from_package)
    for fn in order:
        try:
            how = fn()
            if engine_id in _engines():
                return how, errors
            errors.append("%s: engine not registered" % fn.__name__)
        except Exception as exc:
            errors.append("%s: %s: %s" % (fn.__name__, type(exc).__name__, exc))
    return None, errors


# --------------------------------------------------------------------------- render

def apply_hair_model(spec):
    """--model: every material with a Principled Hair node renders with spec's zoo model or
    plugin, its parameters from the user's mapping (or the defaults). Needs the engine's
    package (registered by ensure_hairbsdf). Returns {material: parameters}."""
    from hairbsdf.blender import model_override
    mapping = model_override.load_mapping(spec["mapping"]) if spec.get("mapping") else None
    return model_override.override_materials(bpy.data.materials, spec["model"], spec.get("path"), mapping)


# Settings under this path are our engine's own (ui.py's scene.hairbsdf): set on our renders once the engine
# is registered, left out of Cycles' (which has none; its reference is the same scene).
ENGINE_SETTINGS = "hairbsdf."


def engine_overrides(overrides, ours):
    """The overrides a render takes: (before our engine is registered, after), ours or Cycles'."""
    own = [o for o in overrides or [] if o.get("setting", "").startswith(ENGINE_SETTINGS)]
    return [o for o in overrides or [] if o not in own], (own if ours else [])


def apply_overrides(scene, overrides):
    """--sweep (sweep.py): sets a node input on the named material ("*": every material that has
    the node; the node by name, label or type) or a render setting (a dotted path from the scene,
    e.g. cycles.samples, or hairbsdf.wavefront for our engine's own). Raises ValueError naming the
    sweep key when something is not there."""
    for o in overrides or []:
        if "setting" in o:
            obj, parts = scene, o["setting"].split(".")
            for part in parts[:-1]:
                obj = getattr(obj, part, None)
            if obj is None or not hasattr(obj, parts[-1]):
                raise ValueError("%s: the scene has no setting %s" % (o["key"], o["setting"]))
            setattr(obj, parts[-1], type(getattr(obj, parts[-1]))(o["value"]))
            continue
        mats = [m for m in bpy.data.materials if m.node_tree and (o["material"] in ("*", m.name))]
        hits = 0
        for m in mats:
            for n in m.node_tree.nodes:
                if o["node"] not in (n.name, n.label, n.bl_idname, getattr(n, "type", None)):
                    continue
                sock = next((i for i in n.inputs if i.name == o["input"]), None)  # hidden ones too
                if sock is None:
                    raise ValueError("%s: node %s of material %s has no input %r (inputs: %s)" % (
                        o["key"], n.name, m.name, o["input"], ", ".join(i.name for i in n.inputs)))
                v = o["value"]
                sock.default_value = v if not hasattr(sock.default_value, "__len__") else [v] * len(
                    sock.default_value) if not isinstance(v, list) else v
                hits += 1
        if not hits:
            raise ValueError("%s: no node %r in %s (materials: %s)" % (
                o["key"], o["node"], "any material" if o["material"] == "*" else "material %r" % o["material"],
                ", ".join(m.name for m in bpy.data.materials)))


def _fault_hook(job):
    """Test hook (blender_tests/test_harness_compare.py): HAIRBSDF_COMPARE_FAULT=crash|hang
    makes every render that is not Cycles abort or hang, to check that the harness survives."""
    fault = os.environ.get("HAIRBSDF_COMPARE_FAULT")
    if not fault or job["engine"] == "CYCLES":
        return
    sys.stdout.flush()
    if fault == "crash":
        os.abort()
    if fault == "hang":
        time.sleep(3600)


def do_render(job):
    t0 = time.time()
    meta = dict(ok=False, engine=job["engine"], accuracy=job["accuracy"], seed=job["seed"],
                versions=_versions(), job=dict((k, v) for k, v in job.items() if k != "sites"))
    try:
        with open(job["blend"], "rb") as f:  # which geometry this render saw (the harness checks one per case)
            meta["blend_sha256"] = hashlib.sha256(f.read()).hexdigest()[:16]
        bpy.ops.wm.open_mainfile(filepath=job["blend"], load_ui=False)
        scene = bpy.context.scene
        lib = _scene_lib(job.get("scenes_dir"))
        if job.get("force_parity") and lib is not None:
            r = scene.render
            lib.parity_settings(scene, width=r.resolution_x * r.resolution_percentage // 100,
                                height=r.resolution_y * r.resolution_percentage // 100,
                                spp=scene.cycles.samples, seed=job["seed"],
                                curve_shape=scene.cycles_curves.shape,
                                subdivisions=scene.cycles_curves.subdivisions,
                                pixel_filter=scene.cycles.pixel_filter_type,
                                filter_width=scene.cycles.filter_width,
                                film_transparent=scene.render.film_transparent)
        cy = scene.cycles
        cy.seed = int(job["seed"])
        cy.use_animated_seed = False
        if job.get("spp"):
            cy.samples = int(job["spp"])
        if job.get("res"):
            scene.render.resolution_x, scene.render.resolution_y = (int(v) for v in job["res"])
            scene.render.resolution_percentage = 100
        if job.get("osl") is not None and job["engine"] == "CYCLES":
            cy.shading_system = bool(job["osl"])
        cy.device = "CPU"
        if job.get("threads"):
            scene.render.threads_mode = "FIXED"
            scene.render.threads = int(job["threads"])
        ours = job["engine"] == job["engine_id"]
        scene_overrides, engine_setting_overrides = engine_overrides(job.get("overrides"), ours)
        apply_overrides(scene, scene_overrides)
        ims = scene.render.image_settings
        ims.file_format = "OPEN_EXR"
        ims.color_mode = "RGBA"
        ims.color_depth = "32"
        ims.exr_codec = "ZIP"
        scene.render.use_file_extension = True
        if lib is not None:
            meta["settings"], meta["parity_warnings"] = lib.read_parity_settings(scene)
        meta["resolution"] = [scene.render.resolution_x * scene.render.resolution_percentage // 100,
                              scene.render.resolution_y * scene.render.resolution_percentage // 100]
        meta["samples"] = int(cy.samples)
        engine_report = job["exr_out"] + ".engine.jsonl"
        if ours:
            how, errors = ensure_hairbsdf(job.get("sites"), job["engine_id"])
            meta["engine_registration"] = how
            meta["engine_registration_errors"] = errors
            meta["hairbsdf_file"] = getattr(sys.modules.get("hairbsdf"), "__file__", None)  # which copy rendered
            if how is None:
                meta["error"] = "the %s engine is not available in this Blender: %s" % (job["engine_id"],
                                                                                          "; ".join(errors))
                meta["status"] = "NOT AVAILABLE"
                return meta
            scene.render.engine = job["engine_id"]
            if hasattr(scene, "hairbsdf"):
                scene.hairbsdf.accuracy = job["accuracy"]
                if job.get("threads"):
                    scene.hairbsdf.threads = int(job["threads"])
            elif job["accuracy"] != job["default_accuracy"]:
                meta["error"] = "the engine has no accuracy setting"
                meta["status"] = "NOT AVAILABLE"
                return meta
            apply_overrides(scene, engine_setting_overrides)
            if job.get("hair_model"):
                meta["hair_model_params"] = apply_hair_model(job["hair_model"])
            if os.path.exists(engine_report):
                os.remove(engine_report)
            os.environ["HAIRBSDF_REPORT_FILE"] = engine_report
        else:
            try:
                scene.render.engine = job["engine"]
            except (TypeError, ValueError) as exc:
                meta["error"] = "render engine %s is not available in this Blender: %s" % (job["engine"], exc)
                meta["status"] = "NOT AVAILABLE"
                return meta
        if os.path.exists(job["exr_out"]):
            os.remove(job["exr_out"])
        scene.render.filepath = job["exr_out"]
        _fault_hook(job)
        t1 = time.time()
        res = bpy.ops.render.render(write_still=True)
        meta["render_seconds"] = time.time() - t1
        meta["operator_result"] = sorted(res) if res else None
        if ours:
            lines = []
            if os.path.exists(engine_report):
                with open(engine_report) as f:
                    lines = [json.loads(l) for l in f if l.strip()]
            meta["engine_report"] = lines[-1] if lines else None
            status = (lines[-1].get("status") if lines else None)
            if status != "ok":
                errs = (lines[-1].get("errors") if lines else None) or ["the engine wrote no report"]
                meta["error"] = "engine status %s: %s" % (status, "; ".join(str(e) for e in errs))
                meta["status"] = "NO OUTPUT"
                return meta
        if not os.path.exists(job["exr_out"]):
            meta["error"] = "Blender wrote no image (operator returned %s)" % meta["operator_result"]
            meta["status"] = "NO OUTPUT"
            return meta
        meta["ok"] = True
        meta["status"] = "OK"
        return meta
    finally:
        meta["seconds"] = time.time() - t0


def main():
    args = _argv()
    with open(args[0]) as f:
        job = json.load(f)
    out = job.get("meta_out") or job.get("info_out")
    try:
        if job["action"] == "build":
            do_build(job)
        else:
            meta = do_render(job)
            _write_json(job["meta_out"], meta)
    except Exception as exc:
        traceback.print_exc()
        _write_json(out, dict(ok=False, status="ERROR", error="%s: %s" % (type(exc).__name__, exc),
                              traceback=traceback.format_exc(), versions=_versions()))
    exit_blender_process(0)


if __name__ == "__main__":
    main()
