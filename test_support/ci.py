"""What "under CI" means for the tests, defined once.

CI runs `bash .ci/run` with CI=true. Any non-empty value other than 0/false/no counts, so a
developer's `CI=false` never turns skips into failures (or back).
"""

import os

import pytest

_OFF = ("", "0", "false", "no", "off")


def under_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() not in _OFF


def skip_or_fail(reason: str):
    """A missing prerequisite: a skip on a developer's machine, a failure under CI."""
    if under_ci():
        pytest.fail(reason)
    pytest.skip(reason)


def require_module(name: str):
    """`pytest.importorskip` that fails under CI instead of skipping."""
    try:
        return __import__(name)
    except ImportError as exc:
        skip_or_fail("cannot import %s: %s" % (name, exc))
