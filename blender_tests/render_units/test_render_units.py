"""Light units and integrator behaviour of hairbsdf.render against real Cycles renders.

Each case in unit_cases.py (a diffuse plane lit by every light type, and hair patches with
multiple scattering, thick and ribbon curves, orthographic and perspective cameras) is
rendered by Cycles (bpy 4.5, CPU, denoise/adaptive off, light threshold 0, clamp 0, filter
glossy 0) in a subprocess, and by our renderer from a hand-written scene_desc. The image
means (and 4 x 4 block means) must agree within the Monte Carlo noise, estimated per pixel
from two independent renders of ours.

The Cycles images are cached in build/blender_tests/render_units/, keyed by a hash of
unit_cases.py, cycles_render.py and the bpy version (RENDER_UNITS_REFRESH=1 re-renders). A
table (our mean / Cycles mean / render seconds) is printed and written next to the cache.

Run: .venv/bin/python -m pytest blender_tests/render_units -s
"""

import fcntl
import hashlib
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from ci import skip_or_fail as _skip_or_fail

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
CACHE = os.path.join(REPO, "build", "blender_tests", "render_units")
sys.path.insert(0, HERE)

import unit_cases as C  # noqa: E402

pytestmark = pytest.mark.blender

SAMPLES = {"hair": 128, "light": 256}
_SESSION_START = __import__("time").time()
SIGMAS = 4.5


def _samples(c):
    return SAMPLES["hair"] if c["hair"] else SAMPLES["light"]


def _bpy_python():
    py = os.environ.get("BSDF_CHECK_BPY_PYTHON") or os.path.join(REPO, ".venv", "bin", "python")
    return py if os.path.exists(py) else sys.executable




@pytest.fixture(scope="module")
def cycles_images():
    py = _bpy_python()
    r = subprocess.run([py, "-c", "import importlib.metadata as m; print(m.version('bpy'))"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        _skip_or_fail(f"no bpy module in {py}")
    version = r.stdout.strip()
    h = hashlib.sha256()
    for name in ("unit_cases.py", "cycles_render.py"):
        with open(os.path.join(HERE, name), "rb") as f:
            h.update(f.read())
    h.update(json.dumps(SAMPLES).encode() + version.encode())
    os.makedirs(CACHE, exist_ok=True)
    out = os.path.join(CACHE, f"cycles-{version}-{h.hexdigest()[:16]}.npz")
    with open(out + ".lock", "w") as lock:  # pytest-xdist workers: render once
        fcntl.flock(lock, fcntl.LOCK_EX)
        fresh = os.path.exists(out) and os.path.getmtime(out) >= _SESSION_START
        if not os.path.exists(out) or (os.environ.get("RENDER_UNITS_REFRESH") and not fresh):
            _render_cycles(py, version, out)
    d = np.load(out)
    meta = json.loads(str(d["meta"]))
    return {k[4:]: d[k] for k in d.files if k.startswith("img_")}, meta


def _render_cycles(py, version, out):
    """Renders every case with Cycles (one subprocess per sample count) into `out`."""
    groups = {}
    for c in C.CASES:
        groups.setdefault(_samples(c), []).append(c["name"])
    parts = []
    for spp, names in groups.items():
        part = out[:-4] + f".{spp}.npz"
        r = subprocess.run([py, os.path.join(HERE, "cycles_render.py"), "--out", part, "--cases",
                            ",".join(names), "--samples", str(spp), "--threads", "2"],
                           capture_output=True, text=True, cwd=HERE, timeout=900)
        if r.returncode != 0:
            pytest.fail(f"Cycles render failed:\n{(r.stdout + r.stderr)[-4000:]}")
        parts.append(part)
    merged, seconds = {}, {}
    for part in parts:
        d = np.load(part)
        seconds.update(json.loads(str(d["meta"]))["seconds"])
        merged.update({k: d[k] for k in d.files if k != "meta"})
        os.remove(part)
    tmp = out[:-4] + ".tmp.npz"
    np.savez_compressed(tmp, meta=json.dumps({"version": version, "seconds": seconds}), **merged)
    os.replace(tmp, out)


_rows = []


def _blocks(img, n=4):
    h, w = img.shape[:2]
    img = img[: h // n * n, : w // n * n]
    return img.reshape(n, h // n, n, w // n, -1).mean(axis=(1, 3, 4))


def _assert_mean_matches_cycles(name, cycles_images, scene_keys=None, **integrator):
    """Our two renders of case `name` (top-level `scene_keys` and integrator keys set as given) against Cycles'
    image; returns them."""
    from hairbsdf.render import render

    images, meta = cycles_images
    c = C.case(name)
    spp = _samples(c)
    ref = images[name][..., :3].astype(np.float64)
    runs = []
    for seed in (11, 12):
        desc = C.scene_desc(c, samples=spp, seed=seed)
        desc["integrator"].update(integrator)
        desc.update(scene_keys or {})
        runs.append(render(desc, threads=2))
    a, b = (r["combined"][..., :3].astype(np.float64) for r in runs)
    for r in runs:
        assert r["stats"]["nan_count"] == 0 and not r["stats"]["warnings"]
    if integrator or scene_keys:
        name += " + " + ", ".join(f"{k} {v}" for k, v in {**(scene_keys or {}), **integrator}.items())
    ours = 0.5 * (a + b)
    # Per-pixel variance of one render from the two independent ones; the difference
    # ours - cycles has variance <= var(ours) + var(cycles) ~ 1.5 var(one render).
    var_pixel = 0.5 * (a - b) ** 2
    n = ref.size
    sigma = np.sqrt(1.5 * var_pixel.sum()) / n
    diff = ours.mean() - ref.mean()
    _rows.append((name, spp, ours.mean(), ref.mean(), sigma, runs[0]["stats"]["seconds"],
                  meta["seconds"].get(c["name"], float("nan"))))
    assert abs(diff) <= SIGMAS * sigma + 1e-5 * abs(ref.mean()), (
        f"{name}: ours {ours.mean():.6f} vs Cycles {ref.mean():.6f} (diff {diff:.2e}, sigma {sigma:.2e})")
    # 4 x 4 block means, each within its own noise.
    bo, br = _blocks(ours), _blocks(ref)
    m = ref.size / 16  # values per block
    bs = np.sqrt(1.5 * _blocks(var_pixel) * m) / m
    bad = np.abs(bo - br) > SIGMAS * bs + 1e-4 * np.abs(br) + 1e-4 * abs(ref.mean())  # floor: rare events
    assert not bad.any(), f"{name}: blocks differ beyond noise: ours {bo[bad]}, Cycles {br[bad]}, sigma {bs[bad]}"
    return runs


HAIR_CASES = [c["name"] for c in C.CASES if c["hair"]]


@pytest.mark.parametrize("name", C.CASE_NAMES)
def test_mean_matches_cycles(name, cycles_images):
    """The defaults: the wavefront path tracer, its Chiang hair shaded through the float32 batch kernels, THICK
    curves by Sweep (curve_intersector AUTO at these sizes)."""
    runs = _assert_mean_matches_cycles(name, cycles_images)
    if name in HAIR_CASES:
        assert all(r["stats"]["kernel_hits"] > 0 for r in runs), "no hit went through the batch kernels"
        intersector = "SWEEP" if C.case(name)["shape"] == "THICK" else "EMBREE"  # Sweep takes THICK curves only
        assert all(r["stats"]["curve_intersector"] == intersector for r in runs)


@pytest.mark.parametrize("name", HAIR_CASES)
def test_per_pixel_mean_matches_cycles(name, cycles_images):
    """The per-pixel loop and Embree's own curves (the configuration before the wavefront and Sweep became the
    defaults): the same gates against Cycles."""
    runs = _assert_mean_matches_cycles(name, cycles_images, scene_keys={"curve_intersector": "EMBREE"},
                                       wavefront=False)
    assert all(r["stats"]["kernel_hits"] == 0 and r["stats"]["curve_intersector"] == "EMBREE" for r in runs)


@pytest.fixture(scope="module", autouse=True)
def report_table(request):
    """After the module's cases: the table of means and times, printed and written next to the cache."""
    yield
    if not _rows:
        return
    lines = [f"{'case':22s} {'spp':>4s} {'ours':>10s} {'cycles':>10s} {'ratio':>8s} {'noise':>8s} "
             f"{'ours s':>7s} {'cycles s':>8s}"]
    for name, spp, o, r, s, to, tc in _rows:
        lines.append(f"{name:22s} {spp:4d} {o:10.5f} {r:10.5f} {o / r if r else float('nan'):8.4f} "
                     f"{s / r if r else 0:8.1e} {to:7.2f} {tc:8.2f}")
    text = "\n".join(lines)
    with open(os.path.join(CACHE, "report.txt"), "w") as f:
        f.write(text + "\n")
    with request.config.pluginmanager.get_plugin("capturemanager").global_and_fixture_disabled():
        print("\n" + text)
