"""The staged copy of the module (build/blender_site/current, docs/blender.md) works in
Debian's system Python with its NumPy 1.24 and inside Debian's Blender 3.4, and gives
the same numbers as the venv's build."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from ci import skip_or_fail

import hairbsdf

REPO = Path(__file__).resolve().parents[2]
SITE = REPO / "build" / "blender_site" / "current"

PROBE = """
import json, sys
sys.path.insert(0, {site!r})
import numpy, hairbsdf
hair = hairbsdf.principled_hair(parametrization="melanin", melanin=0.6, offset=0.05)
wo = numpy.array([[0.3, 0.1, 0.9], [-0.5, 0.7, 0.2]])
wi = numpy.array([[-0.2, 0.5, 0.8], [0.1, -0.9, 0.3]])
print("RESULT" + json.dumps({{"numpy": numpy.__version__, "file": hairbsdf.__file__,
                             "eval": hair.eval(wo, wi, [0.3, -0.6]).tolist()}}))
"""


def expected():
    hair = hairbsdf.principled_hair(parametrization="melanin", melanin=0.6, offset=0.05)
    return hair.eval(np.array([[0.3, 0.1, 0.9], [-0.5, 0.7, 0.2]]), np.array([[-0.2, 0.5, 0.8], [0.1, -0.9, 0.3]]),
                     [0.3, -0.6])


def run_probe(cmd):
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    lines = [l for l in out.stdout.splitlines() if l.startswith("RESULT")]
    assert out.returncode == 0 and lines, out.stdout[-2000:] + out.stderr[-2000:]
    return json.loads(lines[0][len("RESULT"):])


def need(path_or_cmd):
    if shutil.which(path_or_cmd) is None and not os.path.exists(path_or_cmd):
        reason = f"{path_or_cmd} is not installed (scripts/setup installs it)"
        skip_or_fail(reason)
    if not SITE.exists():
        pytest.fail("build/blender_site/current is missing: run scripts/setup")


def test_system_python_with_debian_numpy():
    need("/usr/bin/python3")
    result = run_probe(["/usr/bin/python3", "-c", PROBE.format(site=str(SITE))])
    assert result["numpy"].startswith("1.")
    assert str(SITE.resolve()) in str(Path(result["file"]).resolve())
    np.testing.assert_allclose(result["eval"], expected(), rtol=1e-12)


@pytest.mark.blender
def test_debian_blender_34():
    need("blender")
    result = run_probe(["blender", "-b", "--factory-startup", "--python-exit-code", "1",
                        "--python-expr", PROBE.format(site=str(SITE))])
    np.testing.assert_allclose(result["eval"], expected(), rtol=1e-12)
