"""`hairbsdf compare --sweep` files and `--scheduler` arguments: the schema's errors name the key
(sweep.py), bad scheduler arguments exit 2, an unreachable scheduler exits 3 within the timeout
(cluster.py). No Blender renders here; blender_tests/test_cluster.py runs sweeps on a cluster."""

import subprocess
import sys
import time
from pathlib import Path

import pytest

from hairbsdf.compare import sweep as S
from hairbsdf.compare.cluster import parse_scheduler

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "sweeps" / "fiber_gonio_melanin_roughness.toml"


def load(tmp_path, text):
    p = tmp_path / "s.toml"
    p.write_text(text)
    return S.load(p)


AXIS = '[[axis]]\nnode = "Hair"\ninput = "Melanin"\nvalues = [0.1, 0.5]\n'


def test_example_is_24_cases():
    sw = S.load(EXAMPLE)
    assert sw.size == 24 and [a.name for a in sw.axes] == ["melanin", "roughness"]
    assert sw.axes[0].values == [0.05, 0.23, 0.41, 0.59, 0.77, 0.95]
    assert sw.heatmap == ("melanin", "roughness")


def test_range_step_and_setting(tmp_path):
    sw = load(tmp_path, 'scene = "swatch"\nblender = ["bpy"]\n[[axis]]\nsetting = "cycles.samples"\nvalues = [1, 4]\n'
                        '[[axis]]\nname = "r"\nmaterial = "M"\nnode = "Hair"\ninput = "Roughness"\n'
                        'range = {start = 0.1, stop = 0.5, step = 0.2}\n')
    assert sw.axes[0].target == {"setting": "cycles.samples"} and sw.axes[0].name == "samples"
    assert sw.axes[1].values == [0.1, 0.3, 0.5] and sw.axes[1].target["material"] == "M"
    assert sw.heatmap == ("samples", "r") and len(sw.points()) == 6


@pytest.mark.parametrize("text, key", [
    ('scene = "swatch"\ncolour = 1\n' + AXIS, "colour: unknown key"),
    (AXIS, "scene: required"),
    ('scene = "swatch"\n', "axis: at least one"),
    ('scene = "swatch"\n[[axis]]\nnode = "Hair"\nvalues = [1]\n', "axis[0].input: required"),
    ('scene = "swatch"\n[[axis]]\nnode = "Hair"\ninput = "Melanin"\n', "axis[0]: give exactly one of values"),
    ('scene = "swatch"\n[[axis]]\nnode = "Hair"\ninput = "Melanin"\nvalues = []\n', "axis[0].values"),
    ('scene = "swatch"\n[[axis]]\nnode = "Hair"\ninput = "Melanin"\nrange = {start = 0, stop = 1, num = 0}\n',
     "axis[0].range.num"),
    ('scene = "swatch"\n[[axis]]\nnode = "Hair"\ninput = "Melanin"\nrange = {start = 0, stop = 1, n = 3}\n',
     "axis[0].range.n: unknown key"),
    ('scene = "swatch"\n[[axis]]\nsetting = "cycles.samples"\nnode = "Hair"\nvalues = [1]\n', "axis[0].node"),
    ('scene = "swatch"\n[[axis]]\nnode = "Hair"\ninput = "Melanin"\nvalue = [1]\n', "axis[0].value: unknown key"),
    ('scene = "swatch"\nheatmap = ["melanin", "nope"]\n' + AXIS, "heatmap: two different axis names"),
    ('scene = "swatch"\n' + AXIS + AXIS, "axis[1].name: 'melanin' is used twice"),
    ('scene = "swatch"\nblender = "bpy"\n' + AXIS, "blender: must be a non-empty list"),
    ('scene = "gone.blend"\n' + AXIS, "scene: no such .blend file"),
    ('scene = "swatch"\n[[axis\n', "not valid TOML"),
])
def test_bad_sweep_names_the_key(tmp_path, text, key):
    with pytest.raises(S.SweepError) as e:
        load(tmp_path, text)
    assert key in str(e.value) and "s.toml" in str(e.value)


def compare(*args, timeout=120):
    return subprocess.run([sys.executable, "-m", "hairbsdf.compare", "-q"] + list(args), capture_output=True,
                          text=True, timeout=timeout)


def test_bad_sweep_file_exits_2(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text('scene = "fiber_gonio"\n[[axis]]\nnode = "Hair"\ninput = "Melanin"\nrange = {start = 0}\n')
    r = compare("--sweep", str(p), "--out", str(tmp_path / "out"))
    assert r.returncode == 2 and "axis[0].range.stop: a number is required" in r.stderr, r.stderr


@pytest.mark.parametrize("spec", ["local:0", "local", "localhost", "tcp:/x"])
def test_bad_scheduler_exits_2(tmp_path, spec):
    with pytest.raises(ValueError):
        parse_scheduler(spec)
    r = compare("--scheduler", spec, "--out", str(tmp_path / "out"))
    assert r.returncode == 2 and "--scheduler" in r.stderr and "local:N" in r.stderr, r.stderr


def test_storage_needs_scheduler(tmp_path):
    r = compare("--storage", str(tmp_path), "--out", str(tmp_path / "out"))
    assert r.returncode == 2 and "--storage needs --scheduler" in r.stderr, r.stderr


def test_unreachable_scheduler_exits_3_within_the_timeout(tmp_path):
    from ci import require_module
    require_module("distributed")  # the [dask] extra: scripts/setup installs it
    t0 = time.monotonic()
    r = compare("--scheduler", "tcp://127.0.0.1:9", "--scheduler-timeout", "3", "--scene", "swatch", "--ci",
                "--out", str(tmp_path / "out"))
    took = time.monotonic() - t0
    assert r.returncode == 3, r.stdout + r.stderr
    assert "no Dask scheduler answered at tcp://127.0.0.1:9 within 3 s" in r.stderr, r.stderr
    assert took < 30, took
