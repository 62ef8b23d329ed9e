"""pytest fixtures for the Blender tests; the helpers live in blender_env.py (see there)."""

import pytest

from blender_env import (ENGINE_KINDS, KINDS, crashing_plugin, ensure_staged, kajiya_kay_plugin, need_renderer,  # noqa: F401
                         require, run_snippet, skip_or_fail, staged_has, venv5_py, venv_has_render)


# --------------------------------------------------------------------------- fixtures

@pytest.fixture(params=list(KINDS), ids=list(KINDS.values()))
def blender_kind(request):
    """'bpy' (bpy 4.5 module in the venv) or 'blender' (Debian's Blender 3.4 executable)."""
    require(request.param)
    return request.param


@pytest.fixture(params=list(ENGINE_KINDS), ids=list(ENGINE_KINDS.values()))
def engine_kind(request):
    """blender_kind plus 'bpy5' (bpy 5.3 in the second venv of scripts/setup): the engine's own tests."""
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
    py5 = venv5_py()
    ok["bpy5"] = bool(py5) and py5.exists() and venv_has_render(py5)
    ensure_staged()
    ok["blender"] = staged_has("_render*.so")
    return ok


@pytest.fixture(scope="session")
def kk_plugin(tmp_path_factory):
    """The Kajiya-Kay example plugin, built once per session."""
    return kajiya_kay_plugin(tmp_path_factory.mktemp("kk_plugin"))


@pytest.fixture(scope="session")
def crash_plugin(tmp_path_factory):
    """A plugin that segfaults on its first call (blender_env.CRASHING_PLUGIN)."""
    return crashing_plugin(tmp_path_factory.mktemp("crash_plugin"))
