"""The `hairbsdf` command line: --version everywhere from one source, usage errors exit 2 with a
message naming the parameter, help texts name only files in the repository."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import hairbsdf

ROOT = Path(__file__).resolve().parents[2]


def cli(*args):
    env = dict(os.environ, COLUMNS="2000")  # no wrapped paths in --help
    r = subprocess.run([sys.executable, "-m", "hairbsdf.cli"] + [str(a) for a in args], capture_output=True,
                       text=True, cwd=str(ROOT), timeout=120, env=env)
    return r.returncode, r.stdout, r.stderr


@pytest.mark.parametrize("cmd", [[], ["compare"]])
def test_version(cmd):
    rc, out, err = cli(*cmd, "--version")
    assert rc == 0, err
    assert out.strip() == "hairbsdf %s" % hairbsdf.__version__


@pytest.mark.parametrize("args, message", [
    (["--res", "abc"], "argument --res: takes WxH with W, H >= 1, e.g. 320x240, not 'abc'"),
    (["--res", "0x10"], "argument --res: takes WxH"),
    (["--spp", "0"], "argument --spp: must be an integer >= 1, not '0'"),
    (["--seeds", "0"], "argument --seeds: must be an integer >= 1, not '0'"),
    (["--seeds", "two"], "argument --seeds: must be an integer >= 1, not 'two'"),
    (["--jobs", "0"], "argument --jobs/-j: must be an integer >= 1"),
    (["--thresholds", "no_such.toml"], "argument --thresholds: file no_such.toml does not exist"),
])
def test_compare_usage_errors_exit_2(args, message):
    rc, out, err = cli("compare", *args)
    assert rc == 2, (out, err)
    assert message in err, err


def test_help_names_only_repository_files():
    """--help texts point at files in the repository or package (docs/..., hairbsdf/...)."""
    texts = []
    for cmd in ([], ["compare"], ["fit"], ["plot"]):
        rc, out, err = cli(*cmd, "--help")
        assert rc == 0, (cmd, err)
        texts.append(out)
    text = "\n".join(texts)
    assert "cycles-hair-notes" not in text and "blender-integration" not in text
    for ref in set(re.findall(r"[\w./-]+\.(?:md|toml|py)\b", text)):
        if ref.startswith("/"):
            assert Path(ref).exists() and ".venv" not in Path(ref).parts, ref
            continue
        name = ref.split("/")[-1]
        found = list(ROOT.glob("**/" + name)) if "/" not in ref else [ROOT / ref, ROOT / "plugin" / ref]
        assert any(p.exists() for p in found if ".venv" not in p.parts), ref
