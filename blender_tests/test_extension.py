"""What an artist installs (issue 21): the extension zip (Blender 4.2+) and the legacy add-on zip
(Blender 3.4) from scripts/build_extension, installed through Blender's own path into fresh, empty
Blender user folders, enabled, and rendering `swatch` with HAIRBSDF from the installed package
alone. Its EXR pixels equal those of the checkout's engine on the same .blend, seed and settings, in Blender 3.4, 4.5 and 5.3.
A planted import failure (hairbsdf._core failing as on a too old glibc) gives a one-line report
naming the requirement, not a traceback."""

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from ci import skip_or_fail
from hairbsdf._constants import ENGINE_ID
from hairbsdf.compare.metrics import load_image
from hairbsdf.compare.runner import CYCLES_ACCURACY, blender_script_command, job_tmpdir

pytestmark = pytest.mark.blender

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
JOB = ROOT / "plugin" / "hairbsdf" / "compare" / "blender_job.py"
SCENES = ROOT / "plugin" / "hairbsdf" / "compare" / "scenes"
STAGED_SITE = ROOT / "build" / "blender_site" / "current"
# swatch at its CI size (catalog.py), one seed, 2 threads.
RENDER = dict(res=[128, 96], spp=8, seed=0, threads=2)


def user_env(folder):
    """A user's environment with empty Blender user folders of its own: nothing of the checkout
    or of this machine's Blender configuration."""
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("PYTHON", "HAIRBSDF_", "BLENDER_USER_", "VIRTUAL_ENV"))}
    # No folder of the checkout on PATH: Debian's Blender takes the first python3.11 on PATH as its
    # program name, so with .venv/bin there (scripts/test puts it first) it adopts the venv, whose
    # editable install then shadows the add-on's own copy of hairbsdf.
    env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep)
                                  if p and not Path(p).resolve().is_relative_to(ROOT))
    for name in ("RESOURCES", "CONFIG", "SCRIPTS", "DATAFILES"):
        d = folder / name.lower()
        d.mkdir(parents=True, exist_ok=True)
        env["BLENDER_USER_" + name] = str(d)
    return env


def run(cmd, env, cwd, timeout=600):
    t0 = time.monotonic()
    with job_tmpdir(env) as job_env:
        r = subprocess.run([str(c) for c in cmd], env=job_env, cwd=cwd, capture_output=True, text=True,
                           timeout=timeout)
    return r, time.monotonic() - t0


def bpy_python(blender):
    """The bpy module's Python for Blender 4.5 (.venv) or 5.3 (setup's second venv)."""
    if blender == "4.5":
        return ROOT / ".venv" / "bin" / "python"
    from hairbsdf.compare.runner import bpy5_venv
    py = bpy5_venv() / "bin" / "python"
    if not py.exists():
        skip_or_fail("no bpy 5.3 venv (%s; scripts/setup makes it)" % bpy5_venv())
    return py


def site_packages(python):
    r = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                       capture_output=True, text=True)
    return r.stdout.strip()


BLENDERS = {  # Blender -> what it installs
    "3.4": "legacy",
    "4.5": "extension",
    "5.3": "extension",
}


def command(blender, script, spec):
    if blender == "3.4":
        exe = shutil.which("blender")
        if not exe:
            skip_or_fail("no Debian blender (scripts/setup installs it)")
        return blender_script_command(exe, script, spec)
    py = bpy_python(blender)
    return [py, "-S", script, spec] if script.name == "extension_job.py" else [py, script, spec]


@pytest.fixture(scope="module")
def packages(tmp_path_factory):
    out = tmp_path_factory.mktemp("extension")
    r, seconds = run([ROOT / "scripts" / "build_extension", "--out", out], env=dict(os.environ), cwd=ROOT, timeout=1200)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    print("\n[extension] scripts/build_extension: %.0f s\n%s" % (seconds, r.stdout.strip()))
    ext = sorted(out.glob("hairbsdf_blender-*[0-9].zip"))
    legacy = sorted(out.glob("hairbsdf_blender-*-legacy.zip"))
    assert len(ext) == 1 and len(legacy) == 1, list(out.iterdir())
    return dict(extension=ext[0], legacy=legacy[0])


def blender_job(blender, job, folder, env):
    """One job of the harness's own blender_job.py (the checkout's copy)."""
    path = folder / ("%s.json" % job.get("action"))
    path.write_text(json.dumps(job))
    r, seconds = run(command(blender, JOB, path), env, folder)
    out = json.loads(Path(job.get("meta_out") or job["info_out"]).read_text())
    assert out.get("ok"), (out, r.stdout[-2000:], r.stderr[-2000:])
    return out, seconds


def install_and_render(blender, package, folder, blend=None, plant_import_error=False):
    folder.mkdir(parents=True, exist_ok=True)
    spec = dict(package=str(package), out=str(folder / "result.json"), plant_import_error=plant_import_error,
                site_packages=None if blender == "3.4" else site_packages(bpy_python(blender)))
    if blend:
        spec["job"] = dict(action="render", blend=str(blend), engine=ENGINE_ID, engine_id=ENGINE_ID,
                           accuracy=CYCLES_ACCURACY, default_accuracy=CYCLES_ACCURACY,
                           exr_out=str(folder / "installed.exr"), meta_out=str(folder / "installed_meta.json"),
                           force_parity=False, osl=None, hair_model=None, **RENDER)
    spec_path = folder / "spec.json"
    spec_path.write_text(json.dumps(spec))
    r, seconds = run(command(blender, HERE / "extension_job.py", spec_path), user_env(folder / "user"), folder)
    assert Path(spec["out"]).exists(), "no result (rc %s):\n%s\n%s" % (r.returncode, r.stdout[-3000:],
                                                                       r.stderr[-3000:])
    return json.loads(Path(spec["out"]).read_text()), r.stdout + r.stderr, seconds


@pytest.mark.parametrize("blender", sorted(BLENDERS))
def test_installs_enables_and_renders_bit_identically(blender, packages, tmp_path):
    times = {}
    # The scene and the reference: the harness's own job script and the checkout's engine, in
    # empty user folders too (so no installed add-on takes part).
    ref_env = user_env(tmp_path / "ref_user")
    blend = tmp_path / "swatch.blend"
    _, times["build swatch"] = blender_job(blender, dict(
        action="build", scenes_dir=str(SCENES), module="swatch", blend_out=str(blend),
        info_out=str(tmp_path / "build.json"), cfg=dict(RENDER, variant=None, osl=False)), tmp_path, ref_env)
    ref_meta, times["checkout render"] = blender_job(blender, dict(
        action="render", blend=str(blend), engine=ENGINE_ID, engine_id=ENGINE_ID, accuracy=CYCLES_ACCURACY,
        default_accuracy=CYCLES_ACCURACY, exr_out=str(tmp_path / "ref.exr"),
        meta_out=str(tmp_path / "ref_meta.json"), scenes_dir=str(SCENES), force_parity=False, osl=None,
        hair_model=None, sites=[str(STAGED_SITE)] if blender == "3.4" else [], **RENDER), tmp_path, ref_env)
    assert Path(ref_meta["hairbsdf_file"]).resolve().is_relative_to(ROOT), ref_meta["hairbsdf_file"]

    package = packages["legacy" if BLENDERS[blender] == "legacy" else "extension"]
    res, log, times["install + enable + render"] = install_and_render(blender, package, tmp_path / "installed",
                                                                      blend=blend)
    assert res["blender"].startswith(blender), res["blender"]
    assert res["enabled"] and res["engine_registered"], (res, log[-3000:])
    user = (tmp_path / "installed" / "user").resolve()
    for f in (res["hairbsdf_file"], res["job_script"], res["render"]["hairbsdf_file"]):
        assert Path(f).resolve().is_relative_to(user), "%s is not from the installed package in %s" % (f, user)
    assert res["render"].get("ok"), res["render"]
    ours, ref = load_image(tmp_path / "installed" / "installed.exr"), load_image(tmp_path / "ref.exr")
    assert ours.shape == ref.shape == (RENDER["res"][1], RENDER["res"][0], 4)
    assert ref[..., :3].max() > 0
    assert np.array_equal(ours, ref), "installed and checkout renders differ: max |d| %g" % np.abs(ours - ref).max()
    print("\n[extension] Blender %s (%s): %s; %s" % (res["blender"], package.name, ", ".join(
        "%s %.0f s" % kv for kv in times.items()), res["hairbsdf_file"]))


def test_a_failing_native_module_is_reported_not_a_traceback(packages, tmp_path):
    res, log, _ = install_and_render("4.5", packages["extension"], tmp_path, plant_import_error=True)
    assert res["enabled"] and not res["engine_registered"], res
    assert "glibc >= 2.34" in (res["unavailable"] or ""), res
    assert "hairbsdf: the hairbsdf engine is not available" in log and "glibc >= 2.34" in log, log[-3000:]
    assert "Traceback" not in log, log[-3000:]
