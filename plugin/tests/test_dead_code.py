"""Dead Python code: vulture (scripts/requirements.txt) over the package and lab/.

The tests are read as users of the package (a function they call is not dead) but are not
checked themselves. Names only Blender or pytest use are in vulture_allowlist.py, each with its
reason. The confidence floor is 60 %: vulture rates unused functions, classes, methods and
attributes at 60 % (unused imports at 90 %, unreachable code at 100 %), so a floor of 80 % would
report none of the dead functions this check is for; 60 % reports all of those too. A second test
plants dead code in a copy of the package and expects it reported. Takes a few seconds."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
ALLOWLIST = Path(__file__).with_name("vulture_allowlist.py")
CHECKED = (REPO / "plugin" / "hairbsdf", REPO / "lab")
USERS = (REPO / "plugin" / "tests", REPO / "blender_tests")
MIN_CONFIDENCE = 60


def dead_code(checked) -> list[str]:
    """vulture's findings inside `checked` (folders), with the tests as users and the allowlist."""
    try:
        import vulture  # noqa: F401
    except ImportError:
        pytest.fail("vulture is not installed: run scripts/setup (scripts/requirements.txt)")
    paths = [str(p) for p in (*checked, *USERS, ALLOWLIST)]
    r = subprocess.run([sys.executable, "-m", "vulture", *paths, "--min-confidence", str(MIN_CONFIDENCE)],
                       capture_output=True, text=True, timeout=120, cwd=REPO)
    assert r.returncode in (0, 3), f"vulture failed (exit {r.returncode}):\n{r.stdout}{r.stderr}"
    found = []
    for line in r.stdout.splitlines():  # vulture prints paths under its cwd relative to it
        path, _, rest = line.partition(":")
        path = (REPO / path).resolve()
        if any(path.is_relative_to(Path(c).resolve()) for c in checked):
            found.append("%s:%s" % (path, rest))
    return found


def test_no_dead_code():
    found = dead_code(CHECKED)
    assert not found, ("dead code (delete it, or add the name to plugin/tests/vulture_allowlist.py with the "
                       "reason it is used):\n" + "\n".join(found))


def test_planted_dead_code_is_reported(tmp_path):
    package = tmp_path / "hairbsdf"
    shutil.copytree(CHECKED[0], package, ignore=shutil.ignore_patterns("*.so", "__pycache__"))
    with open(package / "zoo.py", "a") as f:
        f.write("\n\ndef _planted_unused_function():\n    return 1\n")
    with open(package / "closure.py", "a") as f:
        f.write("\n\nimport fractions as _planted_unused_import\n")
    found = "\n".join(dead_code((package, CHECKED[1])))
    assert "unused function '_planted_unused_function'" in found, found
    assert "unused import '_planted_unused_import'" in found, found
    assert found.count("\n") == 1, f"only the two planted findings expected:\n{found}"
