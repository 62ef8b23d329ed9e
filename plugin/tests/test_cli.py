"""The `hairbsdf` command line: --version everywhere from one source, usage errors exit 2 with a
message naming the parameter, help texts name only files in the repository, and `hairbsdf judge`'s
input errors (on small synthetic EXRs; its detection tests on real Cycles renders are in
blender_tests/test_judge.py)."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import hairbsdf

ROOT = Path(__file__).resolve().parents[2]


def cli(*args):
    env = dict(os.environ, COLUMNS="2000")  # no wrapped paths in --help
    r = subprocess.run([sys.executable, "-m", "hairbsdf.cli"] + [str(a) for a in args], capture_output=True,
                       text=True, cwd=str(ROOT), timeout=120, env=env)
    return r.returncode, r.stdout, r.stderr


@pytest.mark.parametrize("cmd", [[], ["compare"], ["judge"]])
def test_version(cmd):
    rc, out, err = cli(*cmd, "--version")
    assert rc == 0, err
    assert out.strip() == "hairbsdf %s" % hairbsdf.__version__


@pytest.mark.parametrize("args, message", [
    (["--res", "abc"], "argument --res: takes WxH with W, H >= 1, e.g. 320x240, not 'abc'"),
    (["--res", "0x10"], "argument --res: takes WxH"),
    (["--spp", "0"], "argument --spp: must be an integer >= 1, not '0'"),
    (["--seeds", "0"], "argument --seeds: must be an integer >= 1, not '0'"),
    (["--seeds", "two"], "argument --seeds: must be an integer >= 1, not 'two'"),
    (["--jobs", "0"], "argument --jobs/-j: must be an integer >= 1"),
    (["--thresholds", "no_such.toml"], "argument --thresholds: file no_such.toml does not exist"),
])
def test_compare_usage_errors_exit_2(args, message):
    rc, out, err = cli("compare", *args)
    assert rc == 2, (out, err)
    assert message in err, err


@pytest.mark.parametrize("args, message", [
    ([], "usage: hairbsdf scenes"),
    (["export"], "the following arguments are required: NAME|all, --out"),
    (["export", "no_such_scene", "--out", "x"], "NAME: unknown scene 'no_such_scene'"),
    (["export", "fiber_gonio:top", "--out", "x"], "NAME: scene fiber_gonio has no variant 'top'"),
    (["export", "swatch", "--out", "x", "--jobs", "0"], "--jobs must be an integer >= 1, not 0"),
    (["export", "swatch", "--out", "x", "--blender", "no_such_blender"], "--blender no_such_blender:"),
    (["render", "no_such_folder", "--out", "x"], "FOLDER: no_such_folder has no portable.json"),
    (["frobnicate"], "argument ACTION: invalid choice: 'frobnicate'"),
])
def test_scenes_usage_errors_exit_2(args, message):
    rc, out, err = cli("scenes", *args)
    assert rc == 2, (out, err)
    assert message in err, err


def test_scenes_list_names_every_library_scene():
    from hairbsdf.compare.runner import load_catalog
    rc, out, err = cli("scenes", "list")
    assert rc == 0, err
    assert [line.split()[0] for line in out.splitlines()] == list(load_catalog()[0])


def test_judge_missing_thresholds_exits_2(tmp_path):
    rc, out, err = cli("judge", tmp_path, tmp_path, "--thresholds", tmp_path / "no.toml")
    assert rc == 2 and "argument --thresholds: file %s does not exist" % (tmp_path / "no.toml") in err, err


def test_help_names_only_repository_files():
    """--help texts point at files in the repository or package (docs/..., hairbsdf/...)."""
    texts = []
    for cmd in ([], ["compare"], ["judge"], ["scenes"], ["scenes", "export"], ["fit"], ["plot"]):
        rc, out, err = cli(*cmd, "--help")
        assert rc == 0, (cmd, err)
        texts.append(out)
    text = "\n".join(texts)
    # Names of notes that live outside the repository (spelled in two parts so that
    # test_docs.py does not flag this line).
    assert "cycles-hair" + "-notes" not in text and "blender" + "-integration" not in text
    for ref in set(re.findall(r"[\w./-]+\.(?:md|toml|py)\b", text)):
        if ref.startswith("/"):
            assert Path(ref).exists() and ".venv" not in Path(ref).parts, ref
            continue
        name = ref.split("/")[-1]
        found = list(ROOT.glob("**/" + name)) if "/" not in ref else [ROOT / ref, ROOT / "plugin" / ref]
        assert any(p.exists() for p in found if ".venv" not in p.parts), ref
    assert "judge REF TEST" in texts[0]


# --------------------------------------------------------------------------- judge: bad input

def _exr(path, img):
    from hairbsdf.compare import images
    path.parent.mkdir(parents=True, exist_ok=True)
    assert images.write_exr(path, np.asarray(img, np.float32))
    return path


def _seeds(folder, n, shape=(6, 8, 4), seed=0):
    rng = np.random.default_rng(seed)
    for i in range(n):
        _exr(folder / ("s%d.exr" % i), 0.5 + 0.05 * rng.standard_normal(shape))
    return folder


def test_judge_empty_folder(tmp_path):
    (tmp_path / "empty").mkdir()
    rc, out, err = cli("judge", tmp_path / "empty", _seeds(tmp_path / "b", 3), "--out", tmp_path / "rep")
    assert rc == 2 and "%s: no .exr files in this folder" % (tmp_path / "empty") in err, err


def test_judge_one_seed(tmp_path):
    rc, out, err = cli("judge", _seeds(tmp_path / "a", 3), _seeds(tmp_path / "b", 1), "--out", tmp_path / "rep")
    assert rc == 2 and "%s: one seed (s0.exr)" % (tmp_path / "b") in err and "at least 2" in err, err


def test_judge_mismatched_size_and_channels(tmp_path):
    a = _seeds(tmp_path / "a", 3)
    rc, out, err = cli("judge", a, _seeds(tmp_path / "b", 3, shape=(6, 9, 4)), "--out", tmp_path / "rep")
    assert rc == 2 and "%s: size/channels 9x6x4 differ from REF" % (tmp_path / "b" / "s0.exr") in err, err
    rc, out, err = cli("judge", a, _seeds(tmp_path / "c", 3, shape=(6, 8, 3)), "--out", tmp_path / "rep")
    assert rc == 2 and "size/channels 8x6x3 differ" in err, err
    _exr(tmp_path / "a" / "s9.exr", np.zeros((6, 8, 3)))
    rc, out, err = cli("judge", a, _seeds(tmp_path / "d", 3), "--out", tmp_path / "rep")
    assert rc == 2 and "%s: size/channels 8x6x3 differ from" % (tmp_path / "a" / "s9.exr") in err, err


def test_judge_unreadable_file(tmp_path):
    a = _seeds(tmp_path / "a", 3)
    (a / "s1.exr").write_bytes(b"not an image")
    rc, out, err = cli("judge", a, _seeds(tmp_path / "b", 3), "--out", tmp_path / "rep")
    assert rc == 2 and "%s: cannot read it as an image" % (a / "s1.exr") in err, err


def test_judge_mean_and_variance_errors(tmp_path):
    b = _seeds(tmp_path / "b", 3)
    m = _exr(tmp_path / "m" / "mean.exr", np.full((6, 8, 4), 0.5))
    rc, out, err = cli("judge", m, b, "--out", tmp_path / "rep")
    assert rc == 2 and "%s: no seed count" % m in err, err
    (tmp_path / "m" / "mean.json").write_text(json.dumps(dict(seeds=1)))
    rc, out, err = cli("judge", m, b, "--out", tmp_path / "rep")
    assert rc == 2 and "%s: 1 seed(s)" % m in err, err
    (tmp_path / "m" / "mean.json").write_text(json.dumps(dict(seeds=4)))
    rc, out, err = cli("judge", m, b, "--out", tmp_path / "rep")
    assert rc == 2 and "its variance image %s does not exist" % (tmp_path / "m" / "mean_var.exr") in err, err


def test_judge_seed_count_from_the_exr_header(tmp_path):
    """hairbsdf:seeds and hairbsdf:variance as EXR attributes of the mean; an identical pair passes."""
    import OpenImageIO as oiio
    rng = np.random.default_rng(1)
    stack = 0.5 + 0.05 * rng.standard_normal((4, 6, 8, 3))
    var = _exr(tmp_path / "m" / "v.exr", stack.var(axis=0, ddof=1))
    mean = np.ascontiguousarray(stack.mean(axis=0), np.float32)
    spec = oiio.ImageSpec(8, 6, 3, oiio.FLOAT)
    spec.attribute("hairbsdf:seeds", 4)
    spec.attribute("hairbsdf:variance", var.name)
    path = tmp_path / "m" / "mean.exr"
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec) and out.write_image(mean)
    out.close()
    rc, o, err = cli("judge", path, path, "--out", tmp_path / "rep", "--no-flip")
    assert rc == 0, o + err
    case = json.loads((tmp_path / "rep" / "report.json").read_text())["cases"][0]
    assert case["sizes"]["seeds"] == 4 and case["inputs"]["ref"][1] == str(var)


def test_subcommands():
    """Top-level argparse: a command's options go to that command; a missing or unknown one exits 2."""
    rc, out, err = cli("compare", "--help")
    assert rc == 0 and "usage: hairbsdf compare" in out and "--shard" in out, err
    rc, out, err = cli("judge", "--help")
    assert rc == 0 and "usage: hairbsdf judge" in out and "REF" in out, err
    rc, out, err = cli()
    assert rc == 2 and "COMMAND" in err
    rc, out, err = cli("nonsense")
    assert rc == 2 and "invalid choice: 'nonsense'" in err, err
    rc, out, err = cli("report")
    assert rc == 2 and "usage: hairbsdf report merge" in err, err
    from hairbsdf import cli as module
    assert module.main(["--help"]) == 0 and module.main(["nonsense"]) == 2


def test_judge_title_and_reproduce(tmp_path):
    """judge's report is titled "TEST vs REF" from the folder names (or --title), not "hairbsdf vs
    Cycles", and its reproduce line is the judge command."""
    a, b = _seeds(tmp_path / "cycles_seeds", 3), _seeds(tmp_path / "my_seeds", 3, seed=1)
    rc, o, err = cli("judge", a, b, "--out", tmp_path / "rep", "--no-flip", "--exit-zero")
    data = json.loads((tmp_path / "rep" / "report.json").read_text())
    html = (tmp_path / "rep" / "index.html").read_text()
    assert rc == 0 and data["title"] == "my_seeds vs cycles_seeds", o + err
    assert "<title>my_seeds vs cycles_seeds</title>" in html and "hairbsdf vs Cycles" not in html
    assert data["cases"][0]["reproduce"].startswith("hairbsdf judge %s %s" % (a, b))
    rc, o, err = cli("judge", a, b, "--out", tmp_path / "rep2", "--no-flip", "--exit-zero", "--title", "mine <3")
    assert rc == 0 and "<title>mine &lt;3</title>" in (tmp_path / "rep2" / "index.html").read_text(), o + err
