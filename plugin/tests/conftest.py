import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from ci import skip_or_fail

sys.path.insert(0, str(Path(__file__).parent))  # makes `reference` importable


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


@pytest.fixture
def best_kernel():
    """The batch kernels on the best instruction set before and after the test (test_batch_kernels*.py)."""
    import hairbsdf

    hairbsdf.set_batch_kernel("best")
    yield
    hairbsdf.set_batch_kernel("best")


# --- The example plugin (examples/plugins/kajiya_kay), built once per session -----------------
ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "plugins" / "kajiya_kay"


def cmake():
    found = shutil.which("cmake") or shutil.which("cmake", path=str(Path(sys.executable).parent))
    if not found:
        skip_or_fail("cmake not found (scripts/setup installs it)")
    return found


def build_standalone(tmp: Path) -> Path:
    """What a plugin author does: install the header, configure the example against it, build."""
    include = tmp / "prefix" / "include" / "hairbsdf"
    include.mkdir(parents=True)
    shutil.copy(ROOT / "bsdf_core" / "include" / "hairbsdf" / "plugin.h", include)
    build = tmp / "build"
    generator = ["-G", "Ninja"] if shutil.which("ninja") or (Path(sys.executable).parent / "ninja").exists() else []
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")
    configure = [cmake(), "-S", str(EXAMPLE), "-B", str(build), *generator, "-DCMAKE_BUILD_TYPE=Release",
                 f"-DHAIRBSDF_INCLUDE_DIR={tmp / 'prefix' / 'include'}"]
    for cmd in (configure, [cmake(), "--build", str(build), "-j2"]):
        run = subprocess.run(cmd, capture_output=True, text=True, env=env)
        assert run.returncode == 0, f"{' '.join(cmd)}\n{run.stdout}\n{run.stderr}"
    cache = (build / "CMakeCache.txt").read_text()
    assert f"HAIRBSDF_INCLUDE_DIR:PATH={tmp / 'prefix' / 'include'}" in cache  # the installed header was used
    return build / "hairbsdf_plugin_kajiya_kay.so"


@pytest.fixture(scope="session")
def kk_path(tmp_path_factory):
    given = os.environ.get("HAIRBSDF_KAJIYA_KAY_PLUGIN")
    if given:
        return Path(given)
    return build_standalone(tmp_path_factory.mktemp("kajiya_kay"))


@pytest.fixture(scope="session")
def kk(kk_path):
    import hairbsdf

    return hairbsdf.load_plugin(kk_path)
