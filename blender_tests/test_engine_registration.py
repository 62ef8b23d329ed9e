"""Engine registration in bpy 4.5 and Blender 3.4, the Cycles/generic panel patching and its
undoing, the installable add-on (legacy in 3.4, extension in 4.5) and the command-line
render `blender -b x.blend -E HAIRBSDF -o ... -F OPEN_EXR -f 1`."""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from blender_env import BLENDER_EXE, ROOT, VENV_PY, need_renderer, require, run_snippet
from hairbsdf.compare.runner import job_tmpdir

pytestmark = pytest.mark.blender

REGISTRATION = r'''
import hairbsdf.blender as hb
from hairbsdf.blender import ui, engine

def engines():
    return sorted(getattr(c, "bl_idname", "?") for c in bpy.types.RenderEngine.__subclasses__()
                  if getattr(c, "is_registered", False))

def panels_with(engine_id):
    """Blender/Cycles panels showing for engine_id (the engine's own HAIRBSDF_* panels aside)."""
    out = []
    for cls in ui._all_panel_classes():
        ce = getattr(cls, "COMPAT_ENGINES", None)
        if ce and engine_id in ce and not cls.__name__.startswith("HAIRBSDF_"):
            out.append(cls.__name__)
    return sorted(set(out))

cycles_base = None
try:
    from cycles.ui import CyclesButtonsPanel
    cycles_base = CyclesButtonsPanel
except ImportError:
    pass
before = panels_with("HAIRBSDF")
base_before = sorted(cycles_base.COMPAT_ENGINES) if cycles_base else None
hb.register()
hb.register()  # idempotent
scene = bpy.context.scene
scene.render.engine = "HAIRBSDF"
cls = engine.HairBsdfRenderEngine
res = {
    "engines": engines(), "label": cls.bl_label, "preview": cls.bl_use_preview,
    "postprocess": cls.bl_use_postprocess, "custom_nodes": cls.bl_use_shading_nodes_custom,
    "engine_set": scene.render.engine, "settings": [scene.hairbsdf.threads, scene.hairbsdf.tilt, scene.hairbsdf.accuracy],
    "patched": panels_with("HAIRBSDF"), "before": before,
    "cycles_base_after_register": sorted(cycles_base.COMPAT_ENGINES) if cycles_base else None,
    "cycles_base_before": base_before,
    "cycles_sampling_still_cycles": "CYCLES" in bpy.types.CYCLES_RENDER_PT_sampling.COMPAT_ENGINES,
    "denoise_panel_patched": "HAIRBSDF" in getattr(getattr(bpy.types, "CYCLES_RENDER_PT_sampling_render_denoise", object), "COMPAT_ENGINES", ()),
    "poll_sampling": bpy.types.CYCLES_RENDER_PT_sampling.poll(type("C", (), {"engine": "HAIRBSDF"})()),
    "poll_own": bpy.types.HAIRBSDF_RENDER_PT_settings.poll(type("C", (), {"engine": "HAIRBSDF"})()),
}
from hairbsdf import _core
props = scene.hairbsdf.bl_rna.properties
schema = {k["path"]: k for k in _core.scene_schema()}
from hairbsdf.blender._common import SCENE_SETTINGS
choices = ("tilt", "accuracy", "huang_sampler", "curve_intersector")
res["enums"] = {n: [[i.identifier, i.value] for i in props[n].enum_items] for n in choices}
res["enum_defaults"] = {n: props[n].default for n in choices}
res["schema"] = {n: [schema[SCENE_SETTINGS[n]]["allowed"], schema[SCENE_SETTINGS[n]]["default"]] for n in choices}
res["prose"] = {n: sorted(ui.CHOICE_PROSE.get(n, {})) for n in choices}
res["wavefront"] = [props["wavefront"].default, schema["integrator.wavefront"]["default"]]
# The settings reach the exported scene: integrator keys and top-level keys.
from hairbsdf.blender.export_scene import export_scene
scene.hairbsdf.wavefront, scene.hairbsdf.curve_intersector, scene.hairbsdf.accuracy = False, "EMBREE", "EXACT"
desc, _ = export_scene(bpy.context.evaluated_depsgraph_get(), render=True)
res["exported"] = [desc["integrator"]["wavefront"], desc["curve_intersector"], desc["integrator"]["accuracy"]]
scene.hairbsdf.tilt = "3.4"
hb.unregister()
res["engines_after"] = engines()
res["patched_after"] = panels_with("HAIRBSDF")
res["has_settings_after"] = hasattr(bpy.types.Scene, "hairbsdf")
res["cycles_base_after_unregister"] = sorted(cycles_base.COMPAT_ENGINES) if cycles_base else None
hb.register()
res["reregistered"] = "HAIRBSDF" in engines()
hb.unregister()
emit(res)
'''


def test_register_unregister(run_blender, engine_kind):
    r = run_blender(engine_kind, REGISTRATION).result
    assert "HAIRBSDF" in r["engines"] and r["label"] == "hairbsdf"
    assert (r["preview"], r["postprocess"], r["custom_nodes"]) == (True, True, False)  # previews: test_engine_preview.py
    assert r["engine_set"] == "HAIRBSDF"
    assert r["settings"] == [0, "AUTO", "CYCLES"]
    # The choices of scene.hairbsdf's enums are the scene schema's integrator names in capitals (tilt adds
    # AUTO), with the schema's defaults and UI prose for each. A .blend file saves an item's position:
    # the order is pinned here, so a reordered table fails.
    ids = {n: [i for i, _ in items] for n, items in r["enums"].items()}
    assert ids == {"tilt": ["AUTO", "4.2", "3.4"], "accuracy": ["CYCLES", "EXACT"],
                   "huang_sampler": ["CYCLES", "MIXTURE"], "curve_intersector": ["EMBREE", "SWEEP", "AUTO"]}
    assert all([v for _, v in items] == list(range(len(items))) for items in r["enums"].values())
    for n, (allowed, default) in r["schema"].items():
        assert ids[n][-len(allowed):] == [a.upper() for a in allowed], n
        assert r["prose"][n] == sorted(allowed), n  # every choice has its label and description, none stale
        assert r["enum_defaults"][n] == ("AUTO" if n == "tilt" else default.upper()), n
    assert r["wavefront"] == [True, "True"]
    assert r["exported"] == [False, "EMBREE", "exact"]  # each differs from its default
    assert r["before"] == []
    for name in ("CYCLES_RENDER_PT_sampling", "CYCLES_RENDER_PT_sampling_render", "CYCLES_RENDER_PT_sampling_advanced",
                 "CYCLES_RENDER_PT_light_paths", "CYCLES_RENDER_PT_light_paths_max_bounces", "CYCLES_RENDER_PT_film",
                 "CYCLES_RENDER_PT_film_transparency", "CYCLES_RENDER_PT_film_pixel_filter", "CYCLES_RENDER_PT_curves",
                 "RENDER_PT_format",
                 "DATA_PT_lens", "PARTICLE_PT_hair_shape"):
        assert name in r["patched"], name
    assert not any(p.startswith("RENDER_PT_eevee") for p in r["patched"])
    # Cycles' shared base set is untouched: only the chosen panels got a per-class copy
    assert r["cycles_base_after_register"] == r["cycles_base_before"] == ["CYCLES"]
    assert r["cycles_sampling_still_cycles"] and not r["denoise_panel_patched"]
    assert r["poll_sampling"] and r["poll_own"]
    # unregister restores everything
    assert "HAIRBSDF" not in r["engines_after"]
    assert r["patched_after"] == [] and not r["has_settings_after"]
    assert r["cycles_base_after_unregister"] == ["CYCLES"]
    assert r["reregistered"]


MAKE_BLEND = r'''
scene = hs.reset(width=48, height=32, spp=4)
mat = hs.hair_material("Hair", parametrization="MELANIN", melanin=0.4, roughness=0.3)
hs.curves_grid("Fur", nx=6, ny=4, size=1.0, n_points=6, length=0.8, radius=0.03, material=mat)
hs.make_camera(location=(0.0, -3.5, 0.6), target=(0.0, 0.0, 0.4))
hs.make_light("SUN", energy=4.0)
scene.world = bpy.data.worlds.new("W"); scene.world.use_nodes = False; scene.world.color = (0.05, 0.05, 0.05)
bpy.ops.wm.save_as_mainfile(filepath=ARGS["path"])
emit({"saved": ARGS["path"]})
'''


def _user_env(tmp_path: Path) -> dict:
    return {"BLENDER_USER_CONFIG": str(tmp_path / "user" / "config"),
            "BLENDER_USER_SCRIPTS": str(tmp_path / "user" / "scripts"),
            "BLENDER_USER_RESOURCES": str(tmp_path / "user" / "resources"),
            "BLENDER_USER_EXTENSIONS": str(tmp_path / "user" / "extensions")}


def _read_exr(kind, path, tmp_path):
    code = r'''
img = bpy.data.images.load(ARGS["path"])
w, h = img.size
buf = np.empty(w * h * img.channels, np.float32)
img.pixels.foreach_get(buf)
emit({"size": [w, h], "channels": img.channels, "pixels": buf})
'''
    r = run_snippet(kind, code, tmp_path / "read", args={"path": str(path)}).result
    return np.asarray(r["pixels"], np.float32).reshape(r["size"][1], r["size"][0], r["channels"])


def test_addon_install_and_command_line_render(tmp_path, renderer_available):
    """Blender 3.4: scripts/install_blender_addon (legacy add-on), then the documented
    command line renders an EXR with the engine."""
    require("blender")
    env = dict(os.environ, **_user_env(tmp_path))
    inst = subprocess.run([str(ROOT / "scripts" / "install_blender_addon"), BLENDER_EXE], capture_output=True,
                          text=True, env=env, timeout=120)
    assert inst.returncode == 0, inst.stdout + inst.stderr
    assert "enabled hairbsdf_blender in Blender 3.4" in inst.stdout
    addon = tmp_path / "user" / "scripts" / "addons" / "hairbsdf_blender"
    assert (addon / "__init__.py").exists() and (addon / "_site_path.txt").read_text().strip().endswith("current")
    blend = tmp_path / "fur.blend"
    run_snippet("blender", MAKE_BLEND, tmp_path, args={"path": str(blend)})
    need_renderer("blender", renderer_available)
    report = tmp_path / "report.jsonl"
    cmd = [BLENDER_EXE, "-b", str(blend), "-E", "HAIRBSDF", "-o", str(tmp_path / "out_"), "-F", "OPEN_EXR", "-f", "1"]
    with job_tmpdir(dict(env, HAIRBSDF_REPORT_FILE=str(report))) as job_env:  # the user's command, as documented
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=180, env=job_env)
    out = tmp_path / "out_0001.exr"
    assert r.returncode == 0 and out.exists(), r.stdout[-3000:] + r.stderr[-3000:]
    assert '"status": "ok"' in report.read_text()
    px = _read_exr("blender", out, tmp_path)
    assert np.all(np.isfinite(px))
    alpha = px[..., 3]
    assert 0.02 < (alpha > 0.5).mean() < 0.9, "the fur covers part of the frame"
    assert px[..., :3][alpha > 0.5].mean() > 1e-3, "lit hair is not black"
    # uninstall leaves nothing behind
    un = subprocess.run([str(ROOT / "scripts" / "install_blender_addon"), BLENDER_EXE, "--uninstall"],
                        capture_output=True, text=True, env=env, timeout=120)
    assert un.returncode == 0 and not addon.exists()


def test_extension_install_bpy(tmp_path):
    """bpy 4.5 (Blender 4.2+ API): the add-on installs as an extension from its
    blender_manifest.toml and registers the engine."""
    require("bpy")
    temp = tmp_path / "tmp"  # the installer's TMPDIR: it leaves nothing there (nor Blender's session folder)
    temp.mkdir()
    env = dict(os.environ, TMPDIR=str(temp), **_user_env(tmp_path))
    inst = subprocess.run([str(ROOT / "scripts" / "install_blender_addon"), str(VENV_PY)], capture_output=True,
                          text=True, env=env, timeout=120)
    assert inst.returncode == 0, inst.stdout + inst.stderr
    assert list(temp.iterdir()) == []
    assert "enabled bl_ext.user_default.hairbsdf_blender in Blender 4.5" in inst.stdout
    assert list((tmp_path / "user").rglob("hairbsdf_blender/blender_manifest.toml"))
