"""Shared helpers for the Blender tests: run a code snippet in a fresh bpy 4.5 process (the
venv) or in Debian's Blender 3.4 (`blender -b`), and get back what it emit()s.
Test modules import them with `from blender_env import ...` (conftest.py holds the fixtures):
`from conftest import ...` would pick up plugin/tests/conftest.py when pytest collects both
folders in one run, as scripts/test does.

    def test_x(run_blender):
        out = run_blender("bpy", '''
            import hair_scenes as hs
            hs.reset()
            emit({"version": list(bpy.app.version)})
        ''')

Inside a snippet: `bpy`, `np` (numpy), `hs` (scenes/hair_scenes), `fg` (the library's fiber_gonio),
`emit(obj)` (JSON, numpy-aware), `ARGS` (the dict passed as args=...), `TMP` (a per-test
folder), `register_engine()` (imports hairbsdf.blender and registers the engine) and
`loaded_libraries(*names)` (shared libraries mapped in the process).
Blender 3.4 imports hairbsdf from the staged copy (build/blender_site/current, refreshed
once per session with scripts/stage_blender_site.py); bpy 4.5 imports the venv's install.
Every run is a subprocess that ends with os._exit, so a bpy process never hangs at exit.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
import textwrap
import time
from pathlib import Path

import pytest
from ci import skip_or_fail  # noqa: F401  (re-exported for the tests)

ROOT = Path(__file__).resolve().parent.parent
TESTS = ROOT / "blender_tests"
SCENES = TESTS / "scenes"  # test-only scene helpers (hair_scenes, engine_memory)
LIBRARY = ROOT / "plugin" / "hairbsdf" / "compare" / "scenes"  # the scene library (fiber_gonio, scene_lib)
VENV_PY = ROOT / ".venv" / "bin" / "python"
SITE = ROOT / "build" / "blender_site" / "current"
ADDON_SRC = ROOT / "plugin" / "blender_addon"
RECORDS = ROOT / "build" / "blender_tests" / "engine"
BLENDER_EXE = os.environ.get("HAIRBSDF_BLENDER") or shutil.which("blender") or "/usr/bin/blender"
RESULT_TAG = "@@RESULT@@"
DEFAULT_TIMEOUT = 180

KINDS = {"bpy": "bpy4.5", "blender": "blender3.4"}
# The engine's own tests also run in bpy 5.3 (the second venv of scripts/setup): the fixture engine_kind.
# Not yet in 5.3 (they fail there; docs/blender5.md "Engine tests in 5.3"): test_engine_passes (the
# OPEN_EXR_MULTILAYER enum is gone), test_engine_world_texture and three image-texture tests of
# test_shading_network (Cycles 5.x samples Linear/Cubic image textures differently), and
# test_compiler_folds_evaluates_and_warns / test_emission_networks_match_cycles_per_pixel (renamed socket,
# removed Combine RGB node).
ENGINE_KINDS = {"bpy": "bpy4.5", "bpy5": "bpy5.3", "blender": "blender3.4"}


def venv5_py():
    """Python of the bpy 5.x venv (its name is declared once, in scripts/setup), or None."""
    from hairbsdf.compare.runner import bpy5_venv
    venv = bpy5_venv()
    return venv / "bin" / "python" if venv else None

RUNNER = r'''
import importlib, json, os, sys, time, traceback
_args = json.loads(os.environ["HB_TEST_ARGS"])
for _p in reversed(_args["paths"]):
    if _p not in sys.path:
        sys.path.insert(0, _p)
for _m in _args.get("pre_import", []):  # modules to load before bpy (import-order tests)
    importlib.import_module(_m)
import bpy
import numpy as np
import fiber_gonio as fg
import hair_scenes as hs


def _default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, (np.bool_,)):
        return bool(o)
    if hasattr(o, "__iter__"):
        return list(o)
    return str(o)


def emit(obj):
    sys.stdout.write("@@RESULT@@" + json.dumps(obj, default=_default) + "\n")
    sys.stdout.flush()


def loaded_libraries(*names):
    """Paths of the shared libraries mapped in this process whose file name contains one of names."""
    out = set()
    with open("/proc/self/maps") as f:
        for line in f:
            path = line.split()[-1] if line.rstrip().count(" ") >= 5 else ""
            if path.startswith("/") and any(n in os.path.basename(path) for n in names):
                out.add(path)
    return sorted(out)


def register_engine():
    import hairbsdf.blender
    hairbsdf.blender.register()
    return hairbsdf.blender


def render_engines(scene, prefix="", engines=("CYCLES", "HAIRBSDF")):
    """Renders the scene with each engine to TMP/<prefix><engine>.exr; {engine: RGBA (H, W, 4)}."""
    out = {}
    for eng in engines:
        scene.render.engine = eng
        scene.render.filepath = os.path.join(_args["tmp"], prefix + eng + ".exr")
        bpy.ops.render.render(write_still=True)
        px, (w, h) = fg.read_exr_rgba(scene.render.filepath)
        out[eng] = np.asarray(px).reshape(h, w, 4)
    return out


_ns = {"bpy": bpy, "np": np, "fg": fg, "hs": hs, "emit": emit, "ARGS": _args["args"], "TMP": _args["tmp"],
       "register_engine": register_engine, "render_engines": render_engines, "loaded_libraries": loaded_libraries,
       "__name__": "__hb_snippet__"}
_rc = 0
try:
    with open(_args["snippet"]) as _f:
        exec(compile(_f.read(), _args["snippet"], "exec"), _ns)
except SystemExit as _e:
    _rc = int(_e.code or 0)
except BaseException:
    traceback.print_exc()
    _rc = 1
sys.stdout.flush()  # ends at once (bpy can hang at exit); the launcher's TMPDIR holds Blender's session folder
sys.stderr.flush()
os._exit(_rc)
'''




# --------------------------------------------------------------------------- availability

def have_bpy() -> bool:
    return VENV_PY.exists() and subprocess.run(
        [str(VENV_PY), "-c", "import importlib.util,sys; sys.exit(importlib.util.find_spec('bpy') is None)"],
        capture_output=True).returncode == 0


def have_bpy5() -> bool:
    py = venv5_py()
    return bool(py) and py.exists() and subprocess.run(
        [str(py), "-c", "import importlib.util,sys; sys.exit(importlib.util.find_spec('bpy') is None)"],
        capture_output=True).returncode == 0


def have_blender() -> bool:
    return Path(BLENDER_EXE).exists() or shutil.which(BLENDER_EXE) is not None


def staged_has(module_glob: str) -> bool:
    return any((SITE / "hairbsdf").glob(module_glob)) if (SITE / "hairbsdf").is_dir() else False


def venv_has_render(py=None) -> bool:
    py = py or VENV_PY
    return subprocess.run([str(py), "-c", "import hairbsdf._render"], capture_output=True).returncode == 0


_staged_once = False


def ensure_staged():
    """Refresh build/blender_site/current from the working tree (content-hashed, cheap),
    once per session, under a lock shared by pytest-xdist workers."""
    global _staged_once
    if _staged_once:
        return
    lock_path = ROOT / "build" / "blender_site.stage.lock"
    lock_path.parent.mkdir(parents=True, exist_ok=True)
    with open(lock_path, "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        r = subprocess.run([str(VENV_PY), str(ROOT / "scripts" / "stage_blender_site.py")],
                           capture_output=True, text=True, cwd=ROOT)
        fcntl.flock(lock, fcntl.LOCK_UN)
    if r.returncode != 0:
        skip_or_fail("staging the module for Blender failed (run scripts/setup):\n" + r.stdout + r.stderr)
    _staged_once = True


# --------------------------------------------------------------------------- running

class BlenderRun:
    def __init__(self, kind, proc, results, seconds, log_path):
        self.kind = kind
        self.returncode = proc.returncode
        self.stdout = proc.stdout
        self.stderr = proc.stderr
        self.results = results
        self.seconds = seconds
        self.log_path = log_path

    @property
    def result(self):
        """The last emitted object."""
        if not self.results:
            raise AssertionError(f"{self.kind}: the snippet emitted nothing; log {self.log_path}:\n"
                                 + self.tail())
        return self.results[-1]

    def tail(self, n=6000):
        return (self.stdout + "\n--- stderr ---\n" + self.stderr)[-n:]


def _write_runner(tmp: Path) -> Path:
    path = tmp / "hb_runner.py"
    if not path.exists():
        path.write_text(RUNNER)
    return path


def run_snippet(kind: str, code: str, tmp: Path, args=None, timeout=DEFAULT_TIMEOUT, env=None,
                check=True, pre_import=()) -> BlenderRun:
    """Run `code` in a fresh process of `kind` ('bpy', 'bpy5' or 'blender'); `pre_import` modules are
    imported before bpy (bpy module only: Blender itself has loaded everything already)."""
    from hairbsdf.compare.runner import blender_script_command, job_tmpdir
    tmp.mkdir(parents=True, exist_ok=True)
    snippet = tmp / f"snippet_{kind}_{time.monotonic_ns()}.py"
    snippet.write_text(textwrap.dedent(code))
    runner = _write_runner(tmp)
    paths = [str(SCENES), str(LIBRARY)]
    if kind == "blender":
        ensure_staged()
        paths.append(str(SITE))
    base_env = dict(os.environ)
    base_env["HB_TEST_ARGS"] = json.dumps({"paths": paths, "snippet": str(snippet), "args": args or {},
                                           "tmp": str(tmp), "pre_import": list(pre_import)})
    base_env.setdefault("PYTHONUNBUFFERED", "1")
    if kind == "bpy":
        cmd = [str(VENV_PY), str(runner)]
    elif kind == "bpy5":
        cmd = [str(venv5_py()), str(runner)]
    elif kind == "blender":
        cmd = blender_script_command(BLENDER_EXE, runner)
    else:
        raise ValueError(kind)
    t0 = time.perf_counter()
    with job_tmpdir(base_env, parent=tmp) as full_env:  # under the test's own folder
        full_env.update(env or {})
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=full_env, cwd=str(tmp))
    seconds = time.perf_counter() - t0
    log_path = snippet.with_suffix(".log")
    log_path.write_text(proc.stdout + "\n--- stderr ---\n" + proc.stderr)
    results = [json.loads(line[len(RESULT_TAG):]) for line in proc.stdout.splitlines()
               if line.startswith(RESULT_TAG)]
    run = BlenderRun(kind, proc, results, seconds, log_path)
    if check and proc.returncode != 0:
        pytest.fail(f"{ENGINE_KINDS.get(kind, kind)} exited with {proc.returncode}; log {log_path}:\n{run.tail()}")
    return run


def require(kind: str):
    if kind == "bpy" and not have_bpy():
        skip_or_fail("bpy 4.5 is not installed in .venv (run scripts/setup)")
    if kind == "bpy5" and not have_bpy5():
        skip_or_fail(f"bpy 5.x is not installed in {venv5_py()} (run scripts/setup)")
    if kind == "blender" and not have_blender():
        skip_or_fail(f"Blender executable {BLENDER_EXE!r} not found (apt-get install blender)")


def record(name: str, data: dict):
    """Keep a measured number (export speed, cancel latency...) in build/blender_tests/engine."""
    RECORDS.mkdir(parents=True, exist_ok=True)
    path = RECORDS / f"{name}.json"
    path.write_text(json.dumps(data, indent=1, sort_keys=True))
    return path


def need_renderer(kind: str, available: dict):
    if not available.get(kind):
        where = ("the venv (pip install -e . via scripts/setup)" if kind in ("bpy", "bpy5")
                 else "build/blender_site/current (scripts/setup stages it for Blender's Python)")
        skip_or_fail(f"hairbsdf._render is not available in {where} yet")


# --------------------------------------------------------------------------- plugins

CRASHING_PLUGIN = r'''
// A hair BSDF plugin that loads fine and segfaults on its first eval, sample or pdf: the
// harness must contain it (blender_tests/test_harness_compare.py).
#include <hairbsdf/plugin.h>
#include <csignal>
namespace {
const hairbsdf_param kParams[] = {{"albedo", HAIRBSDF_PARAM_FLOAT, {0.5}, 0, 1, "unused"}};
int crash() { std::raise(SIGSEGV); return 1; }
void* create(const double*, char*, size_t) { static int instance; return &instance; }
void destroy(void*) {}
int eval(const void*, size_t, const double*, const double*, const double*, const double*, double*, double*) { return crash(); }
int sample(const void*, size_t, const double*, const double*, const double*, const double*, double*, double*, double*,
           int32_t*) { return crash(); }
int pdf(const void*, size_t, const double*, const double*, const double*, const double*, double*) { return crash(); }
const hairbsdf_plugin kPlugin = {HAIRBSDF_PLUGIN_ABI_VERSION, 0, "crasher", "segfaults", 1, kParams,
                                 create, destroy, eval, sample, pdf};
}  // namespace
HAIRBSDF_PLUGIN_ENTRY { return host_abi_version == HAIRBSDF_PLUGIN_ABI_VERSION ? &kPlugin : nullptr; }
'''


def build_plugin(source: Path, out: Path) -> Path:
    """Compiles a one-file plugin against bsdf_core/include (docs/plugins.md §2, by hand)."""
    cxx = shutil.which("c++") or shutil.which("g++")
    if not cxx:
        skip_or_fail("no C++ compiler to build a test plugin")
    r = subprocess.run([cxx, "-O2", "-std=c++17", "-shared", "-fPIC", "-fvisibility=hidden",
                        f"-I{ROOT / 'bsdf_core' / 'include'}", str(source), "-o", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    return out


def kajiya_kay_plugin(tmp: Path) -> Path:
    """The example plugin (examples/plugins/kajiya_kay), or $HAIRBSDF_KAJIYA_KAY_PLUGIN."""
    given = os.environ.get("HAIRBSDF_KAJIYA_KAY_PLUGIN")
    if given:
        return Path(given)
    return build_plugin(ROOT / "examples" / "plugins" / "kajiya_kay" / "kajiya_kay.cpp",
                        tmp / "hairbsdf_plugin_kajiya_kay.so")


def crashing_plugin(tmp: Path) -> Path:
    src = tmp / "crasher.cpp"
    src.write_text(CRASHING_PLUGIN)
    return build_plugin(src, tmp / "crasher.so")
