"""pytest fixtures for the Blender tests; the helpers live in blender_env.py (see there)."""

import pytest

from blender_env import (KINDS, ensure_staged, need_renderer, require, run_snippet,  # noqa: F401
                         skip_or_fail, staged_has, venv_has_render)


# --------------------------------------------------------------------------- fixtures

@pytest.fixture(params=list(KINDS), ids=list(KINDS.values()))
def blender_kind(request):
    """'bpy' (bpy 4.5 module in the venv) or 'blender' (Debian's Blender 3.4 executable)."""
    require(request.param)
    return request.param


@pytest.fixture
def run_blender(tmp_path):
    def _run(kind, code, **kw):
        require(kind)
        return run_snippet(kind, code, tmp_path, **kw)
    return _run


@pytest.fixture
def renderer_available():
    """Returns the Blender kinds that can render with hairbsdf._render right now."""
    ok = {}
    ok["bpy"] = venv_has_render()
    ensure_staged()
    ok["blender"] = staged_has("_render*.so")
    return ok
