"""`hairbsdf compare --scheduler local:N|ADDRESS`: every Blender process of the run (a scene build
or one render) is one Dask task on a worker (docs/cluster.md).

The client keeps the local runner (runner.Runner): cases, cache keys, judging and the report are
the same code; only Runner._run_job changes, from a local subprocess to a task. On the worker the
task runs runner.run_job with the worker's own installation (its blender_job.py, its scene library,
its Blender), under guard.py so that a killed worker takes its Blender's process group with it.

Files travel two ways:
  - through the scheduler (default): the task gets the .blend's bytes (scattered once per file)
    and returns its outputs' bytes; the client writes them;
  - through a storage folder every worker and the client see (--storage DIR): inputs are read and
    outputs written there; the Cycles cache lives in DIR/cache.
Every file the client or a worker writes goes to a unique temporary name first and is renamed.
"""

from __future__ import annotations

import os
import re
import shutil
import sys
import tempfile
import threading
import time
import uuid
from pathlib import Path

from .. import _version
from . import runner as R

GUARD = Path(__file__).resolve().parent / "guard.py"
OUTPUT_KEYS = ("exr_out", "meta_out", "blend_out", "info_out")
EXIT_CLUSTER = 3  # no scheduler within the timeout, a worker with another hairbsdf, no workers


class ClusterError(RuntimeError):
    """The cluster cannot be used: the message says why (exit status EXIT_CLUSTER)."""


class VersionMismatch(ClusterError):
    pass


def parse_scheduler(spec):
    """'local:N' -> ('local', N); an address (tcp://host:port, host:port, a scheduler file's
    path) -> ('address', spec). Raises ValueError naming what is allowed."""
    m = re.fullmatch(r"local:(\d+)", spec.strip())
    if m:
        n = int(m.group(1))
        if n < 1:
            raise ValueError("--scheduler local:N needs N >= 1 worker processes, not %d" % n)
        return "local", n
    if spec.startswith("local"):
        raise ValueError("--scheduler takes local:N (N worker processes) or a scheduler address, not %r" % spec)
    if not re.fullmatch(r"(tcp|tls|ws|wss|inproc)://\S+|[\w.-]+:\d+", spec.strip()):
        raise ValueError("--scheduler takes local:N or a scheduler address such as tcp://host:8786, not %r" % spec)
    return "address", spec.strip()


# --------------------------------------------------------------------------- worker side

_TARGETS = {}


def worker_info():
    """What a worker runs: reported in report.json and checked against the client."""
    import platform

    import hairbsdf
    try:
        from distributed import get_worker
        address = get_worker().address
    except (ImportError, ValueError):
        address = None
    return dict(address=address, host=platform.node(), pid=os.getpid(), cwd=os.getcwd(),
                python=sys.version.split()[0], hairbsdf=hairbsdf.__version__, hairbsdf_file=hairbsdf.__file__)


def _check_version(client_version):
    v = _version.__version__
    if v != client_version:
        info = worker_info()
        raise VersionMismatch("worker %s on %s has hairbsdf %s (%s), the client %s: install the same wheel on both"
                              % (info["address"], info["host"], v, info["hairbsdf_file"], client_version))


class GuardedTarget(R.Target):
    """A Blender target whose process runs under guard.py, watching this worker process."""

    def command(self, job_json):
        return [sys.executable, "-I", str(GUARD), str(os.getpid())] + super().command(job_json)


def _worker_target(spec, label):
    if spec not in _TARGETS:
        _TARGETS[spec] = R.resolve_target(spec)
    t = _TARGETS[spec]
    if t.label != label:
        raise ClusterError("worker %s resolves --blender %s to %s, the client to %s"
                           % (worker_info()["address"], spec, t.label, label))
    return GuardedTarget(**{k: getattr(t, k) for k in ("spec", "kind", "path", "label", "version")})


def run_task(client_version, spec, label, job, inputs, storage, timeout, name):
    """One Blender process on a worker. inputs: {job key: bytes, or a path in storage}.
    Returns the job's result with 'worker' and 'outputs' ({key: bytes or a staged path}).
    With storage, files are staged in storage/staging/NAME (the task's key: a rerun after a
    worker loss starts it afresh; the client removes it)."""
    _check_version(client_version)
    target = _worker_target(spec, label)
    if storage:
        stage = Path(storage) / "staging" / name
        shutil.rmtree(stage, ignore_errors=True)
        stage.mkdir(parents=True)
    else:
        stage = Path(tempfile.mkdtemp(prefix="hairbsdf-task-"))
    try:
        job = dict(job, scenes_dir=str(R.scenes_dir()), sites=[])  # this installation's, not the client's
        for key, val in inputs.items():
            if isinstance(val, bytes):
                p = stage / ("input-" + Path(job[key]).name)
                p.write_bytes(val)
                job[key] = str(p)
        wanted = {k: job[k] for k in OUTPUT_KEYS if job.get(k)}
        for k, p in wanted.items():
            job[k] = str(stage / Path(p).name)
        log = stage / "job.log"
        res = R.run_job(target, job, str(stage / "job.json"), str(log), timeout)
        res["worker"] = worker_info()
        outs = dict((k, job[k]) for k in wanted if os.path.exists(job[k]))
        outs["log"] = str(log)
        if not storage:
            outs = {k: Path(p).read_bytes() for k, p in outs.items() if os.path.exists(p)}
        res["outputs"] = outs
        return res
    finally:
        if not storage:
            shutil.rmtree(stage, ignore_errors=True)


# --------------------------------------------------------------------------- client side

def _atomic_place(dest, data=None, src=None):
    """Writes bytes, or moves a staged file, to dest through a unique temporary name."""
    dest = str(dest)
    os.makedirs(os.path.dirname(dest), exist_ok=True)
    tmp = "%s.tmp-%s" % (dest, uuid.uuid4().hex[:12])
    if data is not None:
        with open(tmp, "wb") as f:
            f.write(data)
    else:
        try:
            os.replace(src, tmp)
        except OSError:  # another file system
            shutil.copyfile(src, tmp)
    os.replace(tmp, dest)


def close(client, cluster):
    """Closes the client, then a LocalCluster (its workers' guards kill their Blenders) and its scratch folder."""
    for x in (client, cluster):
        if x is not None:
            try:
                x.close()
            except Exception:  # pragma: no cover - closing a cluster that is gone
                pass
    if cluster is not None and getattr(cluster, "hairbsdf_scratch", None):
        shutil.rmtree(cluster.hairbsdf_scratch, ignore_errors=True)


def connect(spec, timeout):
    """(client, cluster or None, description). Raises ClusterError when no scheduler answers."""
    from .._deps import require
    require("distributed", "dask", "hairbsdf compare --scheduler")
    import logging

    import dask
    from distributed import Client, LocalCluster
    kind, val = parse_scheduler(spec)
    if kind == "local":
        scratch = tempfile.mkdtemp(prefix="hairbsdf-dask-")
        cluster = LocalCluster(n_workers=val, threads_per_worker=1, processes=True, dashboard_address=None,
                               local_directory=scratch, silence_logs=logging.ERROR)
        cluster.hairbsdf_scratch = scratch  # close() removes it
        return Client(cluster), cluster, "LocalCluster of %d worker processes (%s)" % (val, cluster.scheduler_address)
    try:
        with dask.config.set({"distributed.comm.timeouts.connect": "%ds" % timeout}):
            client = Client(val, timeout=timeout)
    except (OSError, TimeoutError) as exc:
        raise ClusterError("no Dask scheduler answered at %s within %d s (%s: %s); start one with `dask scheduler` "
                           "or give --scheduler local:N" % (val, timeout, type(exc).__name__, exc)) from None
    return client, None, "scheduler %s" % val


def retry_policy():
    import dask
    return int(dask.config.get("distributed.scheduler.allowed-failures"))


class ClusterRunner(R.Runner):
    """A Runner whose Blender processes are Dask tasks."""

    def __init__(self, cases, opts, client, description, storage=None, threads=None):
        super().__init__(cases, opts)
        self.client = client
        self.storage = Path(storage).resolve() if storage else None
        self.description = description
        if threads is not None:
            self.threads = threads
        self.version = _version.__version__
        self.futures = []  # in flight
        self.aborted = False
        self.done = self.losses = self.submitted = 0
        self.lock = threading.Lock()
        self.scattered = {}
        self.workers_seen = {}

    # ----------------------------------------------------------------- set-up
    def check_workers(self, wait_timeout):
        """Waits for a worker, then checks that every worker has the client's hairbsdf."""
        try:
            self.client.wait_for_workers(1, timeout=wait_timeout)
        except (TimeoutError, OSError):
            raise ClusterError("the scheduler has no workers after %d s (start some with `dask worker ADDRESS`)"
                               % wait_timeout) from None
        infos = self.client.run(worker_info)
        for a, i in infos.items():
            i["address"] = a  # client.run runs outside a task, where get_worker() has no answer
        bad = ["%s on %s: hairbsdf %s (%s)" % (a, i["host"], i["hairbsdf"], i["hairbsdf_file"])
               for a, i in infos.items() if i["hairbsdf"] != self.version]
        if bad:
            raise VersionMismatch("the client has hairbsdf %s, but %s; install the same wheel everywhere"
                                  % (self.version, "; ".join(bad)))
        return infos

    # ----------------------------------------------------------------- one job
    def _inputs(self, job):
        blend = job.get("blend")
        if not blend:
            return {}
        if self.storage and Path(blend).resolve().is_relative_to(self.storage):
            return {}
        with self.lock:  # the .blend's bytes go to the cluster once
            if blend not in self.scattered:
                self.scattered[blend] = self.client.scatter(Path(blend).read_bytes())
            return {"blend": self.scattered[blend]}

    def _run_job(self, target, job, job_path, log_path):
        from distributed import KilledWorker
        if self.aborted:
            raise ClusterError("the run was interrupted")
        name = "%s-%s" % (job["action"], uuid.uuid4().hex)
        fut = self.client.submit(run_task, self.version, target.spec, target.label, job, self._inputs(job),
                                 str(self.storage) if self.storage else None, self.o.timeout, name, pure=False,
                                 key=name)
        with self.lock:
            self.futures.append(fut)
            self.submitted += 1
        t0 = time.time()
        try:
            try:
                res = fut.result()
                self._done(fut, name)
            except KilledWorker as exc:
                self._done(fut, name)
                return dict(ok=False, status="CRASH", wall_seconds=time.time() - t0,
                            error="the workers running this render died %d times (Dask's retry limit, "
                                  "distributed.scheduler.allowed-failures): %s" % (retry_policy() + 1, exc))
            self._place(job, log_path, res.pop("outputs", {}))
        finally:
            if self.storage:
                shutil.rmtree(self.storage / "staging" / name, ignore_errors=True)
        w = res.get("worker") or {}
        with self.lock:
            seen = self.workers_seen.setdefault(w.get("address"), dict(w, blender=[]))
            lab = ((res.get("versions") or {}).get("blender"))
            if lab and lab not in seen["blender"]:
                seen["blender"].append(lab)
        return res

    def _done(self, fut, name):
        """Counts the task's worker losses, then releases it: a result the client holds must not
        be computed again when the worker that kept it dies."""
        try:
            losses = self.client.run_on_scheduler(_suspicious, key=name)
        except Exception:  # pragma: no cover - a scheduler that went away
            losses = 0
        with self.lock:
            self.losses += losses
            self.done += 1
            self.futures.remove(fut)
        fut.release()

    @staticmethod
    def _place(job, log_path, outs):
        """Writes a task's outputs where the local runner expects them (atomically)."""
        wanted = dict((k, job[k]) for k in OUTPUT_KEYS if job.get(k))
        wanted["log"] = log_path
        for k, dest in wanted.items():
            if k in outs:
                if isinstance(outs[k], bytes):
                    _atomic_place(dest, data=outs[k])
                else:
                    _atomic_place(dest, src=outs[k])

    # ----------------------------------------------------------------- progress
    def _monitor(self, stop):
        last = None
        while not stop.wait(5.0):
            with self.lock:
                futs = list(self.futures)
            states = {}
            for f in futs:
                states[f.status] = states.get(f.status, 0) + 1
            try:
                running = sum(len(v) for v in self.client.processing().values())
                losses = self.client.run_on_scheduler(_suspicious) + self.losses
                nworkers = len(self.client.scheduler_info(n_workers=-1)["workers"])
            except Exception:  # a scheduler that is going away: no line this time
                continue
            line = ("cluster: %d on workers, %d waiting, %d done, %d failed; %d worker%s; tasks hit by a worker loss: %d"
                    % (running, max(states.get("pending", 0) - running, 0), self.done,
                       states.get("error", 0) + states.get("lost", 0), nworkers, "" if nworkers == 1 else "s",
                       losses))
            if line != last:
                self.progress.message(line)
                last = line

    def _abort(self):
        with self.lock:
            self.aborted = True
            futs = list(self.futures)
        self.client.cancel(futs)

    def run(self, on_case=None):
        stop = threading.Event()
        mon = threading.Thread(target=self._monitor, args=(stop,), daemon=True)
        mon.start()
        try:
            return super().run(on_case=on_case)
        finally:
            stop.set()

    def run_info(self, initial_workers):
        """report.json's runs[].cluster."""
        workers = {a: dict(i, blender=[]) for a, i in (initial_workers or {}).items()}
        for a, i in self.workers_seen.items():
            workers.setdefault(a, dict(i, blender=[]))["blender"] = i["blender"]
        return dict(scheduler=self.description, storage=str(self.storage) if self.storage else None,
                    task_worker_losses=self.losses,
                    transport="storage folder" if self.storage else "scheduler",
                    allowed_failures=retry_policy(), tasks=self.submitted,
                    workers=sorted(workers.values(), key=lambda w: str(w.get("address"))))


def _suspicious(dask_scheduler=None, key=None):
    """Worker deaths while a task was on the worker (the counter that
    distributed.scheduler.allowed-failures bounds), of one task or summed over all."""
    tasks = [dask_scheduler.tasks[key]] if key in dask_scheduler.tasks else [] if key else dask_scheduler.tasks.values()
    return int(sum(getattr(ts, "suspicious", 0) for ts in tasks))
