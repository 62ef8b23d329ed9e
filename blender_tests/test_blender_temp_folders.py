"""Blender processes of the harness leave no temporary folders behind.

Each Blender process makes a session folder, $TMPDIR/blender_XXXXXX, which only a normal exit
removes; our jobs end with os._exit (the bpy module can hang at exit), so blender_job's
exit_blender_process removes it first, and runner.run_job runs every job with a TMPDIR of its own
that it removes afterwards, also after a crash or a timeout.
"""

import json
import os
import stat
import subprocess
import tempfile

import pytest

from hairbsdf.compare import runner

pytestmark = pytest.mark.blender


@pytest.mark.parametrize("spec", ["bpy", "blender"], ids=["bpy4.5", "blender3.4"])
def test_a_job_removes_its_session_folder(spec, tmp_path):
    """The job itself (no run_job): a render job with none of its keys ends with an error (so it ran
    to its end) and removes Blender's session folder."""
    try:
        target = runner.resolve_target(spec)
    except runner.TargetError as exc:
        pytest.fail(f"{spec}: {exc} (scripts/setup installs it)")
    temp = tmp_path / "tmp"
    temp.mkdir()
    job = tmp_path / "job.json"
    meta = tmp_path / "meta.json"
    job.write_text(json.dumps(dict(action="render", meta_out=str(meta))))
    subprocess.run(target.command(job), env=dict(os.environ, TMPDIR=str(temp)), cwd=tmp_path, timeout=300,
                   capture_output=True)
    result = json.loads(meta.read_text())
    assert result["ok"] is False and result["status"] == "ERROR", result
    assert os.listdir(temp) == []


def test_run_job_removes_the_folder_after_a_crash(tmp_path, monkeypatch):
    """A process that makes a session folder and is killed by a signal: run_job reports the crash
    and leaves nothing in the temporary folder."""
    temp = tmp_path / "tmp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    crashing = tmp_path / "python"  # stands in for a bpy Python: its command is [path, job script, job]
    crashing.write_text('#!/bin/sh\nmkdir "$TMPDIR/blender_abc123" && touch "$TMPDIR/blender_abc123/x"\n'
                        'kill -9 $$\n')
    crashing.chmod(crashing.stat().st_mode | stat.S_IXUSR)
    target = runner.Target("crashing", "bpy", str(crashing), "bpy-0", (0,))
    result = runner.run_job(target, dict(action="render", meta_out=str(tmp_path / "meta.json")),
                            tmp_path / "job.json", tmp_path / "job.log", timeout=60)
    assert result["status"] == "CRASH" and result["rc"] == -9, result
    assert os.listdir(temp) == []
