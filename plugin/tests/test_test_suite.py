"""Checks on the test suite itself: every test can fail, and under CI nothing skips silently.

Each check is shown to fail on a planted fault: an assert-less test is found, and a planted skip
or xfail fails a CI=true run unless the allowlist names it.
"""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from assertion_check import load_allowlist as load_no_assert_allowlist
from assertion_check import find_tests_that_cannot_fail
from ci import under_ci
from ci_gate import ALLOWLIST, load_allowlist

ROOT = Path(__file__).resolve().parents[2]
SUPPORT = ROOT / "test_support"


def _test_files():
    tests, helpers = [], [ROOT / "plugin" / "hairbsdf" / "testing.py", *SUPPORT.glob("*.py")]
    for folder in (ROOT / "plugin" / "tests", ROOT / "blender_tests"):
        for p in sorted(folder.rglob("*.py")):
            (tests if p.name.startswith("test_") else helpers).append(p)
    return tests, helpers


def test_every_test_function_can_fail():
    tests, helpers = _test_files()
    found = find_tests_that_cannot_fail(tests, helpers)
    allowed = load_no_assert_allowlist(ALLOWLIST)
    names = ["%s::%s" % (Path(f.split("::")[0]).relative_to(ROOT).as_posix(), f.split("::")[1]) for f in found]
    unlisted = [n for n in names if n not in allowed]
    assert not unlisted, "test functions with nothing that can fail (add an assert, or an entry in %s):\n%s" % (
        ALLOWLIST.name, "\n".join(unlisted))
    stale = sorted(set(allowed) - set(names))
    assert not stale, "allowlist entries that no longer apply: %s" % stale


def test_planted_assertless_test_is_found(tmp_path):
    helper = tmp_path / "helpers.py"
    helper.write_text("def check_positive(x):\n    if x <= 0:\n        raise ValueError(x)\n\n"
                      "def via(x):\n    check_positive(x)\n")
    tests = tmp_path / "test_planted.py"
    tests.write_text(textwrap.dedent("""
        import numpy as np, pytest
        def test_prints_only():
            print(1 + 1)
        def test_asserts():
            assert 1
        def test_numpy():
            np.testing.assert_allclose(1, 1)
        def test_raises():
            with pytest.raises(ValueError):
                int("x")
        def test_helper_two_deep():
            via(3)
    """))
    found = find_tests_that_cannot_fail([tests], [helper])
    assert [f.split("::")[1] for f in found] == ["test_prints_only"]


def _run_pytest(folder, ci, allowlist=None):
    ini = "[pytest]\naddopts = -p ci_gate\npythonpath = %s\n" % SUPPORT
    if allowlist is not None:
        (folder / "allow.toml").write_text(allowlist)
        ini += "skip_allowlist = %s\n" % (folder / "allow.toml")
    (folder / "pytest.ini").write_text(ini)
    env = dict(os.environ, CI=ci)
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist"],
                          cwd=folder, env=env, capture_output=True, text=True, timeout=120)


def test_ci_gate_fails_on_a_planted_skip_and_xfail(tmp_path):
    (tmp_path / "test_planted.py").write_text(textwrap.dedent("""
        import pytest
        def test_skips():
            pytest.skip("planted skip")
        @pytest.mark.xfail(reason="planted xfail")
        def test_xfails():
            assert False
        def test_passes():
            assert True
    """))
    r = _run_pytest(tmp_path, "true")
    assert r.returncode == 1, r.stdout
    assert "SKIP test_planted.py::test_skips: Skipped: planted skip" in r.stdout
    assert "XFAIL test_planted.py::test_xfails: planted xfail" in r.stdout
    assert _run_pytest(tmp_path, "false").returncode == 0  # outside CI: listed, not failed
    allow = ('[[skip]]\nnodeid = "test_planted.py::test_skips"\nkind = "skip"\nreason = "r"\n'
             '[[skip]]\nnodeid = "test_planted.py::test_x*"\nkind = "xfail"\nreason = "r"\n')
    r = _run_pytest(tmp_path, "true", allow)
    assert r.returncode == 0, r.stdout
    r = _run_pytest(tmp_path, "true", allow.replace('kind = "xfail"', 'kind = "skip"'))
    assert r.returncode == 1 and "XFAIL test_planted.py::test_xfails" in r.stdout  # kinds are not interchangeable


def test_allowlist_entries_give_reasons(tmp_path):
    load_allowlist()  # the real file parses, every entry has its reason
    load_no_assert_allowlist(ALLOWLIST)
    bad = tmp_path / "bad.toml"
    bad.write_text('[[skip]]\nnodeid = "x"\nkind = "skip"\nreason = ""\n')
    with pytest.raises(ValueError, match="reason"):
        load_allowlist(bad)
    bad.write_text('[[no_assert]]\ntest = "a.py::test_b"\n')
    with pytest.raises(ValueError, match="reason"):
        load_no_assert_allowlist(bad)


@pytest.mark.parametrize("value,expected", [("true", True), ("1", True), ("yes", True), ("false", False),
                                            ("0", False), ("", False), ("FALSE", False), ("no", False)])
def test_one_definition_of_under_ci(monkeypatch, value, expected):
    monkeypatch.setenv("CI", value)
    assert under_ci() is expected
