"""`hairbsdf compare --scheduler local:2 --sweep` on a real Dask LocalCluster of 2 worker
processes (issue 30; docs/cluster.md).

The client and its workers run from a temporary folder with a temporary venv whose hairbsdf is
the repaired wheel (scripts/build_extension --wheels-only, as test_wheel.py builds it); bpy, Dask
and the other third-party packages come from the checkout's .venv through a path entry (a .pth
line, whose own .pth files, the editable hairbsdf's among them, are not run), so that hairbsdf
can only come from the wheel. Steps, sharing one storage folder:

1. the sweep examples/sweeps/fiber_gonio_melanin_roughness.toml (fiber_gonio:front, melanin ×
   roughness) at CI size on the cluster; while it runs the test SIGKILLs the worker process of a
   running render: the report is still complete, that render's Blender and its guard are gone,
   no Blender of the run is left, and report.json names the scheduler, the workers (their
   hairbsdf from the wheel, their Blender) and the worker loss;
2. the same sweep again, locally from the checkout (a second run on the same storage): every
   Cycles render comes from the shared cache the workers filled, the verdicts are the same and
   our engine's images are bit-identical;
and, separately: a Blender crash on a worker is CRASH; Ctrl-C in the client leaves no worker,
guard or Blender; a worker with another hairbsdf version is an error (a real LocalCluster).

HAIRBSDF_CLUSTER_SWEEP=FILE runs another sweep file (the default is the 24-case example).
"""

import json
import os
import resource
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from ci import require_module

pytestmark = pytest.mark.blender

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SWEEP = Path(os.environ.get("HAIRBSDF_CLUSTER_SWEEP") or ROOT / "examples" / "sweeps"
             / "fiber_gonio_melanin_roughness.toml")
VENV = ROOT / ".venv"


def inside(path, folder):
    return Path(path).resolve().is_relative_to(Path(folder).resolve())


def blender_jobs(tmp):
    """{pid: cmdline} of Blender job processes whose job file is under tmp."""
    out = {}
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            cmd = (d / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        args = [a.decode(errors="replace") for a in cmd if a]
        if any(a.endswith("blender_job.py") for a in args) and any(str(tmp) in a for a in args):
            out[int(d.name)] = args
    return out


def ppid(pid):
    try:
        return int(Path("/proc/%d/stat" % pid).read_text().rsplit(")", 1)[1].split()[1])
    except (OSError, IndexError, ValueError):
        return None


def ancestor(pid, word):
    """The nearest ancestor of pid whose command line contains word."""
    for _ in range(6):
        pid = ppid(pid)
        if not pid or pid <= 1:
            return None
        try:
            if word in Path("/proc/%d/cmdline" % pid).read_bytes().decode(errors="replace"):
                return pid
        except OSError:
            return None
    return None


def alive(pid):
    try:
        state = Path("/proc/%d/stat" % pid).read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.fixture(scope="module")
def wheel_venv(tmp_path_factory):
    """A venv in a temporary folder with the repaired wheel; third-party packages from .venv."""
    require_module("distributed")  # the [dask] extra (scripts/setup installs it)
    tmp = tmp_path_factory.mktemp("cluster")
    assert not inside(tmp, ROOT)
    r = subprocess.run([str(ROOT / "scripts" / "build_extension"), "--wheels-only", "--python", sys.executable],
                       cwd=ROOT, capture_output=True, text=True, timeout=1800)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    wheel = r.stdout.strip().splitlines()[-1]
    venv = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    site = venv / "lib" / ("python%d.%d" % sys.version_info[:2]) / "site-packages"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-index", "--target", str(site),
                    wheel], check=True, capture_output=True)
    dep_site = VENV / "lib" / ("python%d.%d" % sys.version_info[:2]) / "site-packages"
    (site / "checkout_venv_packages.pth").write_text(str(dep_site) + "\n")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "HAIRBSDF_", "VIRTUAL_ENV"))}
    env["PATH"] = "%s%s%s" % (venv / "bin", os.pathsep, env.get("PATH", ""))
    # Each job's own TMPDIR (runner.job_tmpdir) is made here: the worker these tests kill cannot remove its job's.
    (tmp / "tmp").mkdir()
    env["TMPDIR"] = str(tmp / "tmp")
    py = venv / "bin" / "python"
    r = subprocess.run([str(py), "-c", "import sys, hairbsdf, bpy, distributed; print(hairbsdf.__file__); "
                        "print(sys.path)"], cwd=tmp, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert inside(r.stdout.splitlines()[0], venv), r.stdout
    assert str(ROOT / "plugin") not in r.stdout, "the checkout's sources are on sys.path: %s" % r.stdout
    return tmp, py, env


def run_compare(py, cwd, env, out, *args, on_poll=None, timeout=600, scene=None):
    what = ["--scene", scene] if scene else ["--sweep", str(SWEEP)]
    cmd = [str(py), "-m", "hairbsdf.compare"] + what + ["--ci", "--no-exact", "--no-flip", "--out", str(out)] + [
        str(a) for a in args]
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)
    reader.start()
    try:
        while proc.poll() is None:
            if on_poll:
                on_poll()
            time.sleep(0.1)
            if time.monotonic() - t0 > timeout:
                raise AssertionError("compare did not finish in %d s:\n%s" % (timeout, "".join(lines)[-4000:]))
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        reader.join(5)
    text = "".join(lines)
    data = json.loads((Path(out) / "report.json").read_text()) if (Path(out) / "report.json").exists() else None
    return proc.returncode, text, data, time.monotonic() - t0


def ours_pixels(out, case):
    from hairbsdf.compare import metrics
    (r,) = [r for r in case["renders"] if r["kind"] == "ours"]
    return metrics.load_image(r["exr"])


def test_sweep_on_a_local_cluster(wheel_venv):
    tmp, py, env = wheel_venv
    storage = tmp / "storage"
    times = {}
    job_temp_before = set(Path(env["TMPDIR"]).glob("hairbsdf_job_*"))

    # 1. On the cluster; kill the worker of one running render.
    killed = {}

    def kill_one_worker():
        if killed:
            return
        for pid, args in blender_jobs(tmp).items():
            worker = ancestor(pid, "multiprocessing")  # the Dask worker process of the LocalCluster
            try:
                render = json.loads(Path(args[-1]).read_text())["action"] == "render"
            except (OSError, ValueError, KeyError):
                render = False
            if not worker or not render:
                continue
            time.sleep(0.3)  # Blender is starting its render (importing bpy takes longer)
            if not alive(pid):
                continue
            os.kill(worker, signal.SIGKILL)
            killed.update(blender=pid, worker=worker, stage=Path(args[-1]).parent)
            return

    rc, text, rep, times["cluster, worker killed"] = run_compare(
        py, tmp, env, tmp / "out1", "--scheduler", "local:2", "--storage", storage, on_poll=kill_one_worker)
    assert rc == 0, text[-6000:]
    assert killed, "no render was seen running on a worker:\n" + text[-3000:]
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and alive(killed["blender"]):
        time.sleep(0.2)
    assert not alive(killed["blender"]), "orphan Blender %s" % killed
    # killed with its worker, not after finishing its render as an orphan would
    assert not list(killed["stage"].glob("*.exr")), "the killed worker's Blender rendered: %s" % killed
    assert not blender_jobs(tmp), "Blender processes left: %s" % blender_jobs(tmp)
    n = len(rep["cases"])
    assert n == 24 or os.environ.get("HAIRBSDF_CLUSTER_SWEEP"), n
    assert all(c["status"] == "PASS" for c in rep["cases"]), [(c["id"], c["status"], c["reason"])
                                                              for c in rep["cases"] if c["status"] != "PASS"]
    run = rep["runs"][0]
    cl = run["cluster"]
    assert cl["scheduler"].startswith("LocalCluster of 2 worker processes") and cl["allowed_failures"] == 3
    assert cl["task_worker_losses"] >= 1, cl
    assert not list((storage / "staging").iterdir()), "staged task files left"
    job_temp_left = set(Path(env["TMPDIR"]).glob("hairbsdf_job_*")) - job_temp_before
    assert len(job_temp_left) <= 1, "job TMPDIRs left (only the killed worker's may be): %s" % job_temp_left
    assert inside(run["hairbsdf_file"], tmp / "venv"), run["hairbsdf_file"]
    for w in cl["workers"]:
        assert inside(w["hairbsdf_file"], tmp / "venv") and not inside(w["cwd"], ROOT), w
    assert any(w["blender"] for w in cl["workers"]), cl["workers"]
    for c in rep["cases"]:
        for r in c["renders"]:
            if r["kind"] == "ours":
                assert inside(r["hairbsdf_file"], tmp / "venv"), r["hairbsdf_file"]
    assert "cluster:" in text and "on workers" in text  # progress from task states
    sweep_page = (tmp / "out1" / "sweep.html").read_text()
    assert sweep_page.count('class="badge PASS') == n and "data:image/png;base64," in sweep_page
    assert run["sweep"]["heatmap"] == ["melanin", "roughness"] and len(run["sweep"]["matrix"]) == n
    biases = [m["bias"] for m in run["sweep"]["matrix"]]
    assert all(b is not None and abs(b) < 1e-3 for b in biases), biases
    assert (tmp / "out1" / "sweep_heatmap_0.png").stat().st_size > 1000

    # 2. Again, locally from the checkout: Cycles from the shared cache in the storage folder, the
    #    same verdicts, bit-identical images of our engine.
    env_local = dict(os.environ, PATH="%s%s%s" % (VENV / "bin", os.pathsep, os.environ.get("PATH", "")))
    rc, text, rep3, times["local, cached"] = run_compare(VENV / "bin" / "python", ROOT, env_local, tmp / "out3",
                                                         "--cache", storage / "cache", "--jobs", "2")
    assert rc == 0, text[-4000:]
    assert inside(rep3["runs"][0]["hairbsdf_file"], ROOT)
    cyc = [r for c in rep3["cases"] for r in c["renders"] if r["kind"] == "cycles"]
    assert len(cyc) == n and all(r["cached"] for r in cyc), [r for r in cyc if not r["cached"]][:2]
    assert all(inside(r["exr"], storage / "cache") for r in cyc)
    assert not list((storage / "cache").rglob("*.tmp-*")), "temporary cache files left"
    a = {c["id"]: c for c in rep["cases"]}
    b = {c["id"]: c for c in rep3["cases"]}
    assert sorted(a) == sorted(b)
    for cid in a:
        assert a[cid]["status"] == b[cid]["status"], cid
        pa, pb = ours_pixels(tmp / "out1", a[cid]), ours_pixels(tmp / "out3", b[cid])
        assert pa.shape == pb.shape and np.array_equal(pa, pb), "%s: our engine's images differ" % cid
    cpu = resource.getrusage(resource.RUSAGE_CHILDREN)
    print("\n[cluster] %d cases; %s; CPU of all child processes %.0f s" % (
        n, ", ".join("%s %.0f s" % kv for kv in times.items()), cpu.ru_utime + cpu.ru_stime))


def test_worker_with_another_hairbsdf_is_an_error(tmp_path):
    require_module("distributed")
    import logging

    from distributed import Client, LocalCluster

    from hairbsdf.compare import cluster as C
    from hairbsdf.compare.runner import Options, Runner

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                      local_directory=str(tmp_path), silence_logs=logging.ERROR) as lc, Client(lc) as client:
        runner = C.ClusterRunner([], Options(out=tmp_path / "out", cache=tmp_path / "cache", progress=False), client,
                                 "test")
        assert set(runner.check_workers(30)) == set(client.scheduler_info()["workers"])
        runner.version = "0.0.0+planted"  # the client's version as another release
        with pytest.raises(C.VersionMismatch) as e:
            runner.check_workers(30)
        assert "the client has hairbsdf 0.0.0+planted" in str(e.value) and Runner is not None
        fut = client.submit(C.run_task, "0.0.0+planted", "bpy", "bpy-0", {}, {}, None, 10, "t")
        with pytest.raises(C.VersionMismatch) as e:
            fut.result()
        assert "the client 0.0.0+planted" in str(e.value)


def test_blender_crash_on_a_worker_is_crash(wheel_venv):
    """A render that crashes Blender (blender_job.py's test hook aborts every render of our engine)
    is CRASH, as locally; the task succeeds, so Dask does not retry it, and the run completes."""
    tmp, py, env = wheel_venv
    env = dict(env, HAIRBSDF_COMPARE_FAULT="crash")
    rc, text, rep, _ = run_compare(py, tmp, env, tmp / "out_crash", "--scheduler", "local:2", "--storage",
                                   tmp / "storage", scene="fiber_gonio:front")
    assert rc == 1, text[-4000:]
    (case,) = rep["cases"]
    assert case["status"] == "CRASH" and "signal 6" in case["reason"], case["reason"]
    assert rep["runs"][0]["cluster"]["task_worker_losses"] == 0
    assert not blender_jobs(tmp)


def descendants(pid):
    kids = [int(d.name) for d in Path("/proc").iterdir() if d.name.isdigit() and ppid(int(d.name)) == pid]
    return kids + [g for k in kids for g in descendants(k)]


def running_blenders(pid):
    """pid's descendants that are Blender render jobs (not scene builds)."""
    out = []
    for d in descendants(pid):
        try:
            args = Path("/proc/%d/cmdline" % d).read_bytes().decode(errors="replace").split("\0")
            if any(a.endswith("blender_job.py") for a in args) and json.loads(
                    Path([a for a in args if a][-1]).read_text())["action"] == "render":
                out.append(d)
        except (OSError, ValueError, KeyError):
            pass
    return out


def test_ctrl_c_leaves_no_process(wheel_venv):
    """Ctrl-C (SIGINT) in the client while renders run on the cluster: exit 130 within seconds, and
    no worker, guard or Blender of the run is left."""
    tmp, py, env = wheel_venv
    cmd = [str(py), "-m", "hairbsdf.compare", "--sweep", str(SWEEP), "--ci", "--no-exact", "--no-flip", "--out",
           str(tmp / "out_int"), "--scheduler", "local:2", "--cache", str(tmp / "cache_int")]
    proc = subprocess.Popen(cmd, cwd=tmp, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # as in a terminal
    try:
        deadline = time.monotonic() + 120
        while not running_blenders(proc.pid) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)
        assert running_blenders(proc.pid), "no render started"
        family = descendants(proc.pid)
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130 and "interrupted" in out, out[-3000:]
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(alive(p) for p in family):
        time.sleep(0.2)
    assert not [p for p in family if alive(p)], "left after Ctrl-C: %s" % [p for p in family if alive(p)]
