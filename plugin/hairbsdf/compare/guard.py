"""python guard.py PARENT_PID CMD...: runs CMD in this process group and kills the whole group
when PARENT_PID (the Dask worker that started it) is gone, so that a worker killed in the middle
of a render leaves no orphan Blender. Exits with CMD's status (a signal is re-raised).

runner.run_job starts this process as the leader of a new session; CMD inherits the group.
Standard library only: it is started by path, not imported.
"""

import os
import signal
import subprocess
import sys


def main():
    parent = int(sys.argv[1])
    proc = subprocess.Popen(sys.argv[2:])
    signal.signal(signal.SIGTERM, lambda *_: os.killpg(0, signal.SIGKILL))
    while True:
        try:
            rc = proc.wait(timeout=0.5)
            break
        except subprocess.TimeoutExpired:
            pass
        if os.getppid() != parent:  # re-parented: the worker died
            os.killpg(0, signal.SIGKILL)
    if rc < 0:  # Blender died of a signal: so do we, for run_job's CRASH report
        signal.signal(-rc, signal.SIG_DFL)
        os.kill(os.getpid(), -rc)
    sys.exit(rc)


if __name__ == "__main__":
    main()
