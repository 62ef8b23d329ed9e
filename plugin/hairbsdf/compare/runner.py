"""Runs the comparison matrix: builds the library scenes, renders Cycles (cached) and our
engine, each render in its own Blender process, then judges every case and writes the report.

A case is one scene (or scene variant, or user .blend) in one Blender.  Per case:
  build   library scenes only: the builder makes a .blend (cached per Blender)
  cycles  n seeds with Cycles (cached by scene hash, settings, seed and Blender version)
  ours    n seeds with the engine under test (HAIRBSDF by default), never cached
  exact   the engine with exact special functions, on the first seeds (the size of the
          effect of Cycles' truncated series; informational)
A crash, timeout or missing image in one render fails that case only.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import dataclasses
import fcntl
import hashlib
import json
import os
import re
import runpy
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from importlib import resources
from pathlib import Path

import numpy as np

from .. import _blender_versions, _version
from .._constants import ENGINE_ID
from ..render import schema_choices
from . import judge, metrics
from .progress import Progress
from .thresholds import Thresholds

HERE = Path(__file__).resolve().parent
JOB_SCRIPT = HERE / "blender_job.py"


def find_repo():
    p = HERE.parents[2]
    return p if (p / "blender_tests").is_dir() else None


REPO = find_repo()


def package_dir(name):
    """A folder shipped inside hairbsdf.compare (scenes): Blender imports from it, so it must be
    a real directory, not a zip member."""
    path = Path(str(resources.files(__package__) / name))
    if not path.is_dir():
        raise FileNotFoundError("hairbsdf.compare/%s is missing from this installation (%s)" % (name, path))
    return path


def scenes_dir():
    env = os.environ.get("HAIRBSDF_SCENES")
    if env:
        return Path(env)
    return package_dir("scenes")


def default_cache_dir():
    env = os.environ.get("HAIRBSDF_COMPARE_CACHE")
    if env:
        return Path(env)
    if REPO:
        return REPO / "build" / "compare_cache"
    return Path(os.path.expanduser("~/.cache/hairbsdf/compare"))


def default_thresholds():
    env = os.environ.get("HAIRBSDF_THRESHOLDS")
    if env:
        return Path(env)
    return Path(str(resources.files(__package__) / "thresholds.toml"))


def load_catalog(sdir=None):
    sdir = Path(sdir or scenes_dir())
    path = sdir / "catalog.py"
    if not path.exists():
        raise FileNotFoundError("no scene library: %s does not exist" % path)
    ns = runpy.run_path(str(path))
    return ns["SCENES"], ns.get("DEFAULT_SCENE", "swatch")


def _sha(*parts):
    h = hashlib.sha256()
    for p in parts:
        h.update(p if isinstance(p, bytes) else str(p).encode())
        h.update(b"\0")
    return h.hexdigest()[:16]


# Cycles before CHIANG_LCG_BEFORE seeds Chiang's per-hit LCG with hash(x, y) ^ seed, and an LCG is linear
# in its state: seeds 0..7 differ in the three low bits only, which shifts the LCG's second number by
# multiples of about 0.502 (mod 1), so every pixel gets nearly the same number on every seed. Such
# renders share a per-pixel error that their spread does not show, and the Welch test fails on
# noise. Those Blenders get seeds that differ in all bits (blender_seed).


# The engine's accuracy settings as Blender's enum names them: the scene schema's integrator.accuracy choices
# (scene_schema.cpp), upper case, in its order: Cycles' truncated series (the default), exact functions.
ACCURACIES = tuple(a.upper() for a in schema_choices("integrator.accuracy"))
CYCLES_ACCURACY, EXACT_ACCURACY = ACCURACIES


def blender_seed(version, index):
    """The scene seed of render number `index` for a Blender of `version`."""
    if tuple(version) >= _blender_versions.CHIANG_LCG_BEFORE:
        return int(index)
    x = (int(index) + 0x9E3779B9) & 0xFFFFFFFF  # a 32-bit integer mix (splitmix-style finaliser)
    x = ((x ^ (x >> 16)) * 0x85EBCA6B) & 0xFFFFFFFF
    x = ((x ^ (x >> 13)) * 0xC2B2AE35) & 0xFFFFFFFF
    return (x ^ (x >> 16)) & 0x7FFFFFFF  # Blender's seed property stops at 2^31 - 1


def file_hash(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()[:16]


_CONTENT_HASHES = {}  # (path, mtime, size) -> file_hash


def blend_content_hash(path):
    """file_hash, computed once per version of the file."""
    st = os.stat(path)
    key = (os.path.abspath(path), st.st_mtime_ns, st.st_size)
    if key not in _CONTENT_HASHES:
        _CONTENT_HASHES[key] = file_hash(path)
    return _CONTENT_HASHES[key]


def safe(s):
    return re.sub(r"[^A-Za-z0-9._-]+", "_", s)


# --------------------------------------------------------------------------- Blenders

class TargetError(RuntimeError):
    pass


def blender_script_command(blender, script, *script_args):
    """A Blender executable running `script` in the background with factory settings, exiting with
    status 1 if the script raises; `script_args` follow "--" (the script's own arguments).
    -noaudio: no sound system (a background job needs none; PulseAudio's client may leave a
    pulse-XXXXXX folder in TMPDIR when it finds no server)."""
    return [str(blender), "-b", "-noaudio", "--factory-startup", "--python-exit-code", "1", "--python", str(script),
            "--", *map(str, script_args)]


@dataclasses.dataclass
class Target:
    spec: str
    kind: str            # "bpy" (a Python with the bpy module) or "exe" (a Blender executable)
    path: str
    label: str           # e.g. bpy-4.5.15, blender-3.4.1
    version: tuple

    def command(self, job_json):
        if self.kind == "bpy":
            return [self.path, str(JOB_SCRIPT), str(job_json)]
        return blender_script_command(self.path, JOB_SCRIPT, job_json)

    def as_dict(self):
        return dict(spec=self.spec, kind=self.kind, path=self.path, label=self.label, version=list(self.version))


def _parse_version(s):
    nums = [int(x) for x in re.findall(r"\d+", s)[:3]]
    return tuple(nums + [0] * (3 - len(nums)))


def _bpy_pythons():
    env = os.environ.get("HAIRBSDF_BPY_PYTHON")
    if env:
        yield env
    yield sys.executable
    if REPO:
        yield str(REPO / ".venv" / "bin" / "python")


def bpy5_venv():
    """The repository's second venv (bpy 5.x on Python 3.13): its name is declared once, as
    BPY5_VENV=... in scripts/setup, and read from there."""
    if not REPO:
        return None
    try:
        text = (REPO / "scripts" / "setup").read_text()
    except OSError:
        return None
    m = re.search(r"^BPY5_VENV=(\S+)\s*$", text, re.M)
    return REPO / m.group(1) if m else None


def _bpy5_pythons():
    env = os.environ.get("HAIRBSDF_BPY5_PYTHON")
    if env:
        yield env
    venv = bpy5_venv()
    if venv:
        yield str(venv / "bin" / "python")


DEBIAN_BLENDER = "/usr/bin/blender"


def all_target_specs():
    """`--blender all`: every Blender that scripts/setup installs and that is here: bpy 4.5
    (.venv), bpy 5.x (the second venv) and Debian's Blender 3.4."""
    specs = ["bpy"]
    if any(p and os.path.exists(p) for p in _bpy5_pythons()):
        specs.append("bpy5")
    if shutil.which("blender") or os.path.exists(DEBIAN_BLENDER):
        specs.append(shutil.which("blender") or DEBIAN_BLENDER)
    return specs


def resolve_target(spec):
    """'bpy' (the bpy module: this Python or the repository's .venv), 'bpy5' (bpy 5.x: the
    repository's second venv or $HAIRBSDF_BPY5_PYTHON), a Blender executable, or a Python
    interpreter that has bpy."""
    if spec in ("bpy", "bpy5") or os.path.basename(spec).startswith("python"):
        cands = (list(_bpy_pythons()) if spec == "bpy" else list(_bpy5_pythons()) if spec == "bpy5"
                 else [spec])
        for py in cands:
            if not py or not os.path.exists(py):
                continue
            r = subprocess.run([py, "-c", "import importlib.metadata as m; print(m.version('bpy'))"],
                               capture_output=True, text=True)
            if r.returncode == 0 and r.stdout.strip():
                v = r.stdout.strip()
                return Target(spec, "bpy", py, "bpy-" + v, _parse_version(v))
        raise TargetError("no Python with the bpy module found (tried %s); run scripts/setup or pip install bpy"
                          % ", ".join(c for c in cands if c))
    exe = shutil.which(spec) or (spec if os.path.exists(spec) else None)
    if not exe:
        raise TargetError("Blender executable '%s' not found" % spec)
    try:
        r = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=120)
    except Exception as exc:
        raise TargetError("`%s --version` failed: %s" % (exe, exc))
    first = next((l for l in r.stdout.splitlines() if l.startswith("Blender")), None)
    if r.returncode != 0 or not first:
        raise TargetError("`%s --version` did not print a Blender version" % exe)
    v = first.split()[1]
    return Target(spec, "exe", exe, "blender-" + v, _parse_version(v))


# --------------------------------------------------------------------------- cases

@dataclasses.dataclass
class Case:
    id: str
    scene: str
    variant: str | None
    file: str | None
    target: Target
    kind: str
    meta: dict
    res: tuple | None
    spp: int | None
    seeds: int
    exact_seeds: int
    skip: str | None = None
    # --sweep (sweep.py): the point's values by axis name, and what blender_job.py sets for it
    sweep_point: dict | None = None
    overrides: list = dataclasses.field(default_factory=list)

    @property
    def dirname(self):
        return safe(self.id.replace("@", "__"))


def expand_cases(scene_args, targets, *, ci=False, spp=None, res=None, seeds=None, exact_seeds=None, catalog=None):
    """All cases of the matrix, sorted by id (the order --shard slices)."""
    catalog = catalog if catalog is not None else load_catalog()[0]
    names = []
    for s in scene_args:
        for part in s.split(","):
            part = part.strip()
            if part == "all":
                names.extend(catalog)
            elif part:
                names.append(part)
    profile = "ci" if ci else "full"
    cases = []
    for name in names:
        for t in targets:
            if name.endswith(".blend"):
                if not os.path.exists(name):
                    raise ValueError("no such .blend file: %s" % name)
                n = seeds or (4 if ci else 8)
                cases.append(Case("%s@%s" % (Path(name).stem, t.label), Path(name).stem, None,
                                  str(Path(name).resolve()), t, "noisy" if n >= 2 else "info",
                                  dict(title=Path(name).name, description="user file %s" % name), res, spp, n,
                                  exact_seeds if exact_seeds is not None else 0))
                continue
            scene, _, variant = name.partition(":")
            if scene not in catalog:
                raise ValueError("unknown scene '%s' (library: %s; or give a .blend file)"
                                 % (scene, ", ".join(catalog)))
            meta = catalog[scene]
            variants = [variant] if variant else (meta.get("variants") or [None])
            for v in variants:
                if v is not None and v not in (meta.get("variants") or []):
                    raise ValueError("scene %s has no variant '%s' (variants: %s)" % (scene, v, meta.get("variants")))
                size = meta[profile]
                det = meta["kind"] == "deterministic"
                n = 1 if det else (seeds or size["seeds"])
                if exact_seeds is not None:
                    ex = min(exact_seeds, n)
                else:
                    ex = 1 if det else (0 if ci else min(n, 2))
                skip = None
                oldest = max(tuple(meta.get("min_blender", (0, 0, 0))),
                             tuple((meta.get("variant_min_blender") or {}).get(v, (0, 0, 0))))
                if t.version < oldest:
                    skip = "needs Blender %s+ (this is %s)" % (".".join(map(str, oldest[:2])), t.label)
                cid = "%s%s@%s" % (scene, "-" + v if v else "", t.label)
                cases.append(Case(cid, scene, v, None, t, meta["kind"], meta,
                                  tuple(res or size["res"]), int(spp or size["spp"]), int(n), int(ex), skip))
    seen = set()
    out = []
    for c in sorted(cases, key=lambda c: c.id):
        if c.id not in seen:
            seen.add(c.id)
            out.append(c)
    return out


def shard(cases, spec):
    """Cases of shard I/N (1-based): every N-th case of the sorted list, starting at I."""
    if not spec:
        return cases
    m = re.fullmatch(r"\s*(\d+)\s*/\s*(\d+)\s*", spec)
    if not m:
        raise ValueError("--shard takes I/N, e.g. 2/4")
    i, n = int(m.group(1)), int(m.group(2))
    if not (1 <= i <= n):
        raise ValueError("--shard I/N needs 1 <= I <= N")
    return [c for k, c in enumerate(cases) if k % n == i - 1]


# --------------------------------------------------------------------------- jobs

@contextlib.contextmanager
def job_tmpdir(env=None, parent=None):
    """A copy of `env` (default: os.environ) with TMPDIR set to a new folder (under `parent` if given),
    removed on exit: where a Blender job's session folder ($TMPDIR/blender_XXXXXX) goes.  Only Blender's
    own exit removes that folder, and our jobs end with os._exit (the bpy module can hang at exit), crash
    or time out.  blender_job.exit_blender_process removes it on a normal end; this removes it also after
    a crash or a timeout, and for the tests' jobs, which end with a plain os._exit."""
    temp = tempfile.mkdtemp(prefix="hairbsdf_job_", dir=parent)
    try:
        yield dict(os.environ if env is None else env, TMPDIR=temp)
    finally:
        shutil.rmtree(temp, ignore_errors=True)


def run_job(target, job, job_path, log_path, timeout, env=None):
    """Runs one blender_job.py in its own process.  Returns the job's JSON (status OK, NOT
    AVAILABLE, NO OUTPUT, ERROR) or a synthesised one for CRASH / TIMEOUT / NO OUTPUT."""
    job_path, log_path = os.path.abspath(job_path), os.path.abspath(log_path)
    out_json = job.get("meta_out") or job.get("info_out")
    if os.path.exists(out_json):
        os.remove(out_json)
    with open(job_path, "w") as f:
        json.dump(job, f, indent=1)
    t0 = time.time()
    with job_tmpdir(env) as job_env, open(log_path, "w") as log:
        proc = subprocess.Popen(target.command(job_path), stdout=log, stderr=subprocess.STDOUT,
                                cwd=os.path.dirname(job_path), env=job_env, start_new_session=True)
        try:
            rc = proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:  # pragma: no cover
                pass
            proc.wait()
            return dict(ok=False, status="TIMEOUT", error="no result after %d s (killed)" % timeout, rc=None,
                        wall_seconds=time.time() - t0)
    wall = time.time() - t0
    if os.path.exists(out_json):
        with open(out_json) as f:
            res = json.load(f)
        res.setdefault("status", "OK" if res.get("ok") else "ERROR")
        res["rc"], res["wall_seconds"] = rc, wall
        return res
    if rc != 0:
        sig = " (signal %d)" % -rc if rc < 0 else ""
        return dict(ok=False, status="CRASH", error="the process exited with status %d%s and wrote no result"
                    % (rc, sig), rc=rc, wall_seconds=wall)
    return dict(ok=False, status="NO OUTPUT", error="the process exited cleanly but wrote no result", rc=rc,
                wall_seconds=wall)


def log_tail(path, n=3000):
    try:
        with open(path, errors="replace") as f:
            txt = f.read()
    except OSError:
        return ""
    lines = [l for l in txt.splitlines() if not l.startswith("Fra:")]
    return "\n".join(lines)[-n:]


class _Lock:
    def __init__(self, path):
        self.path = str(path) + ".lock"

    def __enter__(self):
        self.f = open(self.path, "w")
        fcntl.flock(self.f, fcntl.LOCK_EX)
        return self

    def __exit__(self, *a):
        fcntl.flock(self.f, fcntl.LOCK_UN)
        self.f.close()


# --------------------------------------------------------------------------- runner

@dataclasses.dataclass
class Options:
    out: Path
    cache: Path
    jobs: int = 1
    threads: int = 0
    timeout: int = 900
    use_cache: bool = True
    refresh: bool = False
    osl: bool = False
    engine: str = ENGINE_ID
    force_parity: bool = False
    thresholds: Thresholds = dataclasses.field(default_factory=Thresholds)
    flip: bool = True
    ci: bool = False
    progress: bool = True
    argv: list = dataclasses.field(default_factory=list)
    hair_model: dict = None  # --model (model_spec.py): our renders override Principled Hair with it


class Runner:
    def __init__(self, cases, opts: Options):
        self.cases = cases
        self.o = opts
        self.o.out = Path(self.o.out).resolve()
        self.o.cache = Path(self.o.cache).resolve()
        self.sdir = scenes_dir()
        self.threads = opts.threads or max(1, (os.cpu_count() or 2) // max(opts.jobs, 1))
        self.progress = Progress(0, enabled=opts.progress)
        self.sites = [str(REPO / "build" / "blender_site" / "current")] if REPO else []

    # ----------------------------------------------------------------- keys
    def _builder_hash(self, case):
        files = [self.sdir / "catalog.py", self.sdir / "scene_lib.py", self.sdir / "fiber_gonio.py",
                 self.sdir / (case.meta["module"] + ".py"), JOB_SCRIPT, Path(_blender_versions.__file__)]
        return _sha(*[p.read_bytes() for p in files if p.exists()])

    def _cfg(self, case):
        return dict(res=list(case.res), spp=case.spp, seed=0, threads=self.threads, variant=case.variant,
                    osl=self.o.osl)

    def blend_key(self, case):
        if case.file:
            return file_hash(case.file)
        cfg = dict(self._cfg(case))
        cfg.pop("threads")
        return _sha(self._builder_hash(case), json.dumps(cfg, sort_keys=True), case.target.label)

    # ----------------------------------------------------------------- tasks
    def build(self, case):
        """Path of the case's .blend (built and cached for library scenes) and build info."""
        if case.file:
            return dict(ok=True, blend=case.file, info={}, cached=True)
        if case.skip:  # the catalog's min_blender / variant_min_blender: the one place they are checked
            return dict(ok=False, error="%s: %s" % (case.id, case.skip))
        d = self.o.cache / "blend"
        d.mkdir(parents=True, exist_ok=True)
        key = self.blend_key(case)
        base = d / ("%s-%s" % (safe(case.id.split("@")[0].split("[")[0]), key))  # a sweep's points share it
        blend, info = str(base) + ".blend", str(base) + ".json"
        with _Lock(base):
            if self.o.use_cache and not self.o.refresh and os.path.exists(blend) and os.path.exists(info):
                with open(info) as f:
                    return dict(json.load(f), blend=blend, cached=True)
            job = dict(action="build", scenes_dir=str(self.sdir), module=case.meta["module"], cfg=self._cfg(case),
                       blend_out=blend, info_out=info)
            res = self._run_job(case.target, job, str(base) + ".job.json", str(base) + ".log")
            res.update(blend=blend, cached=False, log=str(base) + ".log")
            if not res.get("ok"):
                res["log_tail"] = log_tail(str(base) + ".log")
                for p in (blend, info):
                    if os.path.exists(p) and not res.get("ok"):
                        os.remove(p)
            return res

    def render_one(self, case, blend, engine, accuracy, seed, case_dir):
        """One render.  Cycles renders are cached by the .blend's bytes, not by the recipe that built
        it: Blender distributes particle hair anew on every build, so a rebuilt scene may have other
        strands (docs/compare.md, "One geometry per case").  Others go into the case's renders/ folder."""
        cycles = engine == "CYCLES" and accuracy == CYCLES_ACCURACY and self.o.engine != "CYCLES_SELF"
        spp = case.spp
        res = list(case.res) if case.res else None
        osl = self.o.osl if engine == "CYCLES" else None
        bseed = blender_seed(case.target.version, seed)
        if cycles:
            d = self.o.cache / "cycles"
            d.mkdir(parents=True, exist_ok=True)
            key = _sha(blend_content_hash(blend), "CYCLES", bseed, spp, res, osl, case.target.label,
                       JOB_SCRIPT.read_bytes(), _version.__version__,
                       json.dumps(case.overrides, sort_keys=True) if case.overrides else "")
            base = d / ("%s-s%d-%s" % (safe(case.id.split("@")[0]), seed, key))
        else:
            rd = case_dir / "renders"
            rd.mkdir(parents=True, exist_ok=True)
            tag = {"CYCLES": "cycles_self", ENGINE_ID: "hairbsdf"}.get(engine, safe(engine.lower()))
            base = rd / ("%s%s_s%d" % (tag, "_exact" if accuracy == EXACT_ACCURACY else "", seed))
        exr, meta_path = str(base) + ".exr", str(base) + ".json"
        job = dict(action="render", blend=blend, engine=engine, engine_id=ENGINE_ID, accuracy=accuracy,
                   default_accuracy=CYCLES_ACCURACY, seed=bseed,
                   spp=spp, res=res, threads=self.threads, osl=osl, force_parity=self.o.force_parity, exr_out=exr,
                   meta_out=meta_path, scenes_dir=str(self.sdir), sites=self.sites,
                   hair_model=None if engine == "CYCLES" else self.o.hair_model, overrides=case.overrides)
        if cycles:  # a shared cache entry: render to unique names, rename when complete (atomic)
            tmp = "%s.tmp-%s" % (base, os.urandom(6).hex())
            job.update(exr_out=tmp + ".exr", meta_out=tmp + ".json")
        lock = _Lock(base) if cycles else None
        if lock:
            lock.__enter__()
        try:
            if cycles and self.o.use_cache and not self.o.refresh and os.path.exists(exr) and os.path.exists(meta_path):
                with open(meta_path) as f:
                    r = json.load(f)
                if r.get("ok"):
                    r.update(exr=exr, cached=True, log=str(base) + ".log")
                    return r
            r = self._run_job(case.target, job, str(base) + ".job.json", str(base) + ".log")
            if cycles:
                _publish(job, exr, meta_path, r)
            r.update(exr=exr, cached=False, log=str(base) + ".log")
            if not r.get("ok"):
                r["log_tail"] = log_tail(str(base) + ".log")
                if cycles and os.path.exists(meta_path):
                    os.remove(meta_path)  # never cache a failure
            return r
        finally:
            if lock:
                lock.__exit__()

    def _run_job(self, target, job, job_path, log_path):
        """One Blender process for one job; cluster.ClusterRunner runs it as a Dask task instead."""
        return run_job(target, job, job_path, log_path, self.o.timeout)

    def _abort(self):
        """Called when the run stops early (Ctrl-C): cluster.ClusterRunner cancels its tasks."""

    # ----------------------------------------------------------------- run
    def run(self, on_case=None):
        """Renders and judges every case; calls on_case(result, maps) as each case finishes.
        Returns the list of case results (dicts)."""
        self.o.out.mkdir(parents=True, exist_ok=True)
        t0 = time.time()
        results = {}
        active = [c for c in self.cases if not c.skip]
        for c in self.cases:
            if c.skip:
                results[c.id] = self._skipped(c)
        n_render = sum(c.seeds * 2 + c.exact_seeds for c in active)
        self.progress.add(len([c for c in active if not c.file]) + n_render)
        pool = cf.ThreadPoolExecutor(max_workers=max(1, self.o.jobs))
        try:
            builds = {c.id: pool.submit(self._build_step, c) for c in active}
            render_futs = {}
            for c in active:
                b = builds[c.id].result()
                if not b.get("ok"):
                    self.progress.add(-(c.seeds * 2 + c.exact_seeds))
                    results[c.id] = self._failed_build(c, b)
                    continue
                render_futs[c.id] = (b, self._submit_renders(pool, c, b))
            for c in active:
                if c.id not in render_futs:
                    continue
                b, futs = render_futs[c.id]
                renders = {k: [f.result() for f in fl] for k, fl in futs.items()}
                res, maps = self._judge(c, b, renders)
                results[c.id] = res
                if on_case:
                    on_case(res, maps)
        except BaseException:  # Ctrl-C: drop the renders not started yet
            self._abort()
            pool.shutdown(wait=True, cancel_futures=True)
            raise
        finally:
            pool.shutdown(wait=True)
        out = [results[c.id] for c in self.cases]
        for r in out:
            if r["status"] == "SKIPPED" and on_case:
                on_case(r, {})
        self.seconds = time.time() - t0
        return out

    def _build_step(self, c):
        if c.file:
            return dict(ok=True, blend=c.file, info={}, cached=True)
        b = self.build(c)
        self.progress.step("built %s%s" % (c.id, " (cached)" if b.get("cached") else ""), b.get("ok", False))
        return b

    def _submit_renders(self, pool, c, b):
        case_dir = self.o.out / "cases" / c.dirname
        case_dir.mkdir(parents=True, exist_ok=True)
        ours_engine = "CYCLES" if self.o.engine in ("CYCLES", "CYCLES_SELF") else self.o.engine

        def task(engine, accuracy, seed, label):
            def fn():
                r = self.render_one(c, b["blend"], engine, accuracy, seed, case_dir)
                self.progress.step("%s %s seed %d%s" % (c.id, label, seed, " (cached)" if r.get("cached") else ""),
                                   r.get("ok", False))
                return r
            return fn

        futs = dict(cycles=[], ours=[], exact=[])
        for s in range(c.seeds):
            futs["cycles"].append(pool.submit(task("CYCLES", CYCLES_ACCURACY, s, "Cycles")))
        # With --engine CYCLES the "engine" is Cycles again on disjoint seeds: a null test of the harness.
        off = 1000 if ours_engine == "CYCLES" else 0
        for s in range(c.seeds):
            futs["ours"].append(pool.submit(task(ours_engine, CYCLES_ACCURACY, s + off, self._ours_label())))
        for s in range(c.exact_seeds):
            futs["exact"].append(pool.submit(task(ours_engine, EXACT_ACCURACY, s + off, self._ours_label() + " exact")))
        if ours_engine == "CYCLES":
            futs["exact"] = []
        return futs

    def _ours_label(self):
        if self.o.hair_model:
            return "hairbsdf [%s]" % self.o.hair_model["label"]
        return {ENGINE_ID: "hairbsdf", "CYCLES": "Cycles (self-check)", "CYCLES_SELF": "Cycles (self-check)"}.get(
            self.o.engine, self.o.engine)

    # ----------------------------------------------------------------- results
    def _base_result(self, c):
        lim = self.o.thresholds.for_case(c.scene, c.variant, tuple(c.target.version))
        return dict(id=c.id, dir=c.dirname, scene=c.scene, variant=c.variant, file=c.file, kind=c.kind,
                    title=c.meta.get("title", c.scene), description=c.meta.get("description", ""),
                    model=c.meta.get("model"), blender=c.target.as_dict(), engine=self.o.engine,
                    hair_model=self.o.hair_model, engine_label=self._ours_label(),
                    sizes=dict(res=list(c.res) if c.res else None, spp=c.spp, seeds=c.seeds,
                               exact_seeds=c.exact_seeds, threads=self.threads),
                    osl=self.o.osl, profile="ci" if self.o.ci else "full", pending=lim.get("pending"),
                    limits=dict(lim), sweep_point=c.sweep_point,
                    checks=[], metrics={}, renders=[], status=None, reason="")

    def _skipped(self, c):
        r = self._base_result(c)
        r.update(status="SKIPPED", reason=c.skip)
        return r

    def _failed_build(self, c, b):
        r = self._base_result(c)
        r.update(status="ERROR", reason="building the scene failed (%s): %s" % (b.get("status"), b.get("error")),
                 log_tail=b.get("log_tail", ""), build=b)
        if r["pending"]:
            r["status"] = "PENDING"
        return r

    @staticmethod
    def _render_summary(kind, r):
        return dict(kind=kind, engine=(r.get("engine") or (r.get("job") or {}).get("engine")),
                    accuracy=r.get("accuracy"), seed=r.get("seed"), status=r.get("status"), ok=bool(r.get("ok")),
                    cached=bool(r.get("cached")), seconds=r.get("render_seconds"), wall=r.get("wall_seconds"),
                    exr=r.get("exr"), log=r.get("log"), error=r.get("error"), log_tail=r.get("log_tail", ""),
                    hairbsdf_file=r.get("hairbsdf_file"), blend_sha256=r.get("blend_sha256"),
                    engine_warnings=((r.get("engine_report") or {}).get("warnings") or []))

    def _judge(self, c, b, renders):
        res = self._base_result(c)
        res["build"] = dict(cached=b.get("cached"), seconds=b.get("seconds"), info=b.get("info", {}))
        res["settings"] = b.get("settings") or {}
        res["parity_warnings"] = list(b.get("parity_warnings") or [])
        summ = []
        for k in ("cycles", "ours", "exact"):
            summ += [self._render_summary(k, r) for r in renders[k]]
        res["renders"] = summ
        cyc_ok = [r for r in renders["cycles"] if r.get("ok")]
        if cyc_ok:
            m = cyc_ok[0]
            res["versions"] = m.get("versions")
            if m.get("settings"):
                res["settings"] = m["settings"]
            res["parity_warnings"] = sorted(set(res["parity_warnings"]) | set(m.get("parity_warnings") or []))
        ew = []
        for r in renders["ours"]:
            for w in (r.get("engine_report") or {}).get("warnings") or []:
                if w not in ew:
                    ew.append(w)
        res["engine_warnings"] = ew
        for r in renders["ours"]:  # --model: the parameters each material got (blender_job.py)
            if r.get("hair_model_params") is not None:
                res["hair_model_params"] = r["hair_model_params"]
                break
        maps = {}
        bad_c = [r for r in renders["cycles"] if not r.get("ok")]
        bad_o = [r for r in renders["ours"] if not r.get("ok")]
        if bad_c:
            res.update(status="ERROR", reason="the Cycles render failed: %s (%s)" % (bad_c[0].get("status"),
                                                                                    bad_c[0].get("error")),
                       log_tail=bad_c[0].get("log_tail", ""))
        elif bad_o:
            st = {"CRASH": "CRASH", "TIMEOUT": "CRASH"}.get(bad_o[0].get("status"), "NO OUTPUT")
            res.update(status=st, reason="%s render %s: %s" % (self._ours_label(), bad_o[0].get("status"),
                                                               bad_o[0].get("error")),
                       log_tail=bad_o[0].get("log_tail", ""))
        elif len({r.get("blend_sha256") for r in renders["cycles"] + renders["ours"] + renders["exact"]
                  if r.get("ok")}) > 1:
            res.update(status="ERROR", reason="the renders opened different .blend files, so they may show different "
                       "strands (Blender distributes particle hair anew on every build); run again with --refresh")
        else:
            try:
                cyc = np.stack([metrics.load_image(r["exr"]) for r in renders["cycles"]])
                ours = np.stack([metrics.load_image(r["exr"]) for r in renders["ours"]])
                ex_ok = [r for r in renders["exact"] if r.get("ok")]
                exact = np.stack([metrics.load_image(r["exr"]) for r in ex_ok]) if ex_ok else None
                lim = res["limits"]
                roi_info = (b.get("info") or {}).get("gonio_roi")
                roi = metrics.gonio_roi(cyc.shape[1:3], roi_info) if roi_info else None
                checks, mets, maps = judge.evaluate(c.kind if c.kind != "info" else "noisy", cyc, ours, lim,
                                                    exact=exact, image_mean=bool(c.meta.get("image_mean")),
                                                    flip=self.o.flip, roi=roi, ci=self.o.ci)
                res["checks"], res["metrics"] = checks, _jsonable(mets)
                res["status"] = judge.status_of(checks)
                failed = [ch["label"] for ch in checks if ch["gate"] and not ch["passed"]]
                res["reason"] = ("failed: " + "; ".join(failed)) if failed else ""
                maps["_stacks"] = dict(cycles_mean=cyc.mean(axis=0), ours_mean=ours.mean(axis=0))
                bad_e = [r for r in renders["exact"] if not r.get("ok")]
                if bad_e:
                    res["exact_note"] = "exact-accuracy render failed: %s" % bad_e[0].get("error")
            except Exception as exc:  # a broken image must not kill the run
                import traceback
                res.update(status="ERROR", reason="comparing the images failed: %s: %s" % (type(exc).__name__, exc),
                           log_tail=traceback.format_exc())
        if res["pending"] and res["status"] not in ("SKIPPED",):
            res["pending_status"] = res["status"]
            res["status"] = "PENDING"
        return res, maps


def _publish(job, exr, meta_path, r):
    """Moves a finished cache entry from its unique temporary names to its key (image first, then
    the meta JSON whose presence marks the entry complete); a failed one is removed."""
    tmp_exr, tmp_meta = job["exr_out"], job["meta_out"]
    if r.get("ok") and os.path.exists(tmp_exr):
        os.replace(tmp_exr, exr)
        r["exr_out"] = exr
        with open(tmp_meta, "w") as f:
            json.dump(dict(r, exr=exr), f, indent=1, default=str)
        os.replace(tmp_meta, meta_path)
        return
    for p in (tmp_exr, tmp_meta):
        if os.path.exists(p):
            os.remove(p)


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items() if not isinstance(v, np.ndarray)}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, float) and (x != x or x in (float("inf"), float("-inf"))):
        return str(x)
    return x
