"""The third Blender target (bpy 5.3 on Python 3.13): the venv's name is declared once in
scripts/setup and found from there by the harness; setup says what to do without Python 3.13.
No Blender needed (docs/blender5.md)."""

import re
import shutil
import subprocess
from pathlib import Path


from hairbsdf.compare import runner

REPO = Path(__file__).resolve().parents[2]
SETUP = REPO / "scripts" / "setup"


def test_bpy5_venv_is_declared_once_and_read_from_setup():
    text = SETUP.read_text()
    decl = re.findall(r"^BPY5_VENV=(\S+)\s*$", text, re.M)
    assert decl == [".venv-bpy5"], decl
    assert runner.bpy5_venv() == REPO / ".venv-bpy5"
    # nowhere else in the code is the folder spelled out
    for path in list((REPO / "plugin" / "hairbsdf").rglob("*.py")) + list((REPO / "blender_tests").glob("*.py")):
        assert ".venv-bpy5" not in path.read_text(), path


def test_all_lists_bpy5_only_where_it_is_installed(monkeypatch, tmp_path):
    monkeypatch.setenv("HAIRBSDF_BPY5_PYTHON", str(tmp_path / "missing" / "python"))
    monkeypatch.setattr(runner, "bpy5_venv", lambda: tmp_path / "no-venv")
    assert "bpy5" not in runner.all_target_specs()
    fake = tmp_path / "python3.13"
    fake.write_text("")
    monkeypatch.setenv("HAIRBSDF_BPY5_PYTHON", str(fake))
    specs = runner.all_target_specs()
    assert specs[:2] == ["bpy", "bpy5"], specs


def test_setup_without_python313_exits_2_with_advice(tmp_path):
    """Only the 3.13 step runs (everything before it is sliced off): no python3.13 anywhere on PATH,
    no pyenv, an empty HOME, and the venv missing."""
    text = SETUP.read_text()
    start = text.index("# 5. Blender 5.x")
    script = tmp_path / "step5.sh"
    script.write_text("set -euo pipefail\nROOT=%s\nlog() { echo \"$*\"; }\nsrc_hash=x\ncd %s\n" % (tmp_path, tmp_path)
                      + text[start:])
    bin_dir = tmp_path / "bin"  # PATH: only what the step needs before it stops
    bin_dir.mkdir()
    (bin_dir / "cat").symlink_to(shutil.which("cat"))
    env = {"PATH": str(bin_dir), "HOME": str(tmp_path), "PYTHON313": ""}
    r = subprocess.run([shutil.which("bash"), str(script)], capture_output=True, text=True, env=env, cwd=tmp_path, timeout=60)
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    assert "needs Python 3.13" in r.stderr and "pyenv install 3.13" in r.stderr and "PYTHON313=" in r.stderr
    assert not (tmp_path / ".venv-bpy5").exists()
