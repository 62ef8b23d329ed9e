"""Finds test functions that cannot fail: no `assert`, no `pytest.raises`/`pytest.fail`/
`pytest.approx`, no `assert_*` call (NumPy's, unittest's), no `raise`, and no call to a helper
that does one of these (helpers are resolved by name over all the files given, transitively).
"""

import ast
from pathlib import Path

_PYTEST_CHECKS = {"raises", "fail", "approx", "warns", "deprecated_call"}


def _called_name(call):
    f = call.func
    if isinstance(f, ast.Attribute):
        return f.attr
    if isinstance(f, ast.Name):
        return f.id
    return None


def _direct_check(fn):
    """True when fn's body itself can fail."""
    for node in ast.walk(fn):
        if isinstance(node, (ast.Assert, ast.Raise)):
            return True
        if isinstance(node, ast.Call):
            f = node.func
            if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id == "pytest" \
                    and f.attr in _PYTEST_CHECKS:
                return True
            name = _called_name(node)
            if name and name.startswith("assert"):
                return True
    return False


def _calls(fn):
    return {n for n in (_called_name(c) for c in ast.walk(fn) if isinstance(c, ast.Call)) if n}


def functions(paths):
    """{path: [FunctionDef]} for every function (nested and methods too) in the files."""
    out = {}
    for p in paths:
        tree = ast.parse(Path(p).read_text(), filename=str(p))
        out[p] = [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
    return out


def find_tests_that_cannot_fail(test_files, helper_files=()):
    """['path::name'] of the test functions (test_* in test_*.py) that cannot fail."""
    defs = functions(list(test_files) + list(helper_files))
    by_name = {}
    for fns in defs.values():
        for fn in fns:
            by_name.setdefault(fn.name, []).append(fn)
    checking = {name for name, fns in by_name.items() if any(_direct_check(f) for f in fns)}
    changed = True
    while changed:  # a helper that calls a checking helper checks too
        changed = False
        for name, fns in by_name.items():
            if name not in checking and any(_calls(f) & checking for f in fns):
                checking.add(name)
                changed = True
    out = []
    for path in test_files:
        for fn in defs[path]:
            if fn.name.startswith("test") and not _direct_check(fn) and not (_calls(fn) & checking):
                out.append("%s::%s" % (Path(path).as_posix(), fn.name))
    return out


def load_allowlist(path):
    """{'path::function': reason} of the [[no_assert]] entries of an allowlist file."""
    import tomllib
    out = {}
    for k, e in enumerate(tomllib.loads(Path(path).read_text()).get("no_assert", [])):
        if not e.get("test") or not e.get("reason", "").strip():
            raise ValueError("%s: [[no_assert]] entry %d needs test and reason" % (path, k + 1))
        out[e["test"]] = e["reason"]
    return out
