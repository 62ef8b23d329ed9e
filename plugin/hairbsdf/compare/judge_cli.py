"""`hairbsdf judge REF TEST`: the statistics of `hairbsdf compare` on images that any renderer
made (docs/compare.md, "Judging your own renderer").  No Blender, no bpy.

A side (REF or TEST) is either
  * a folder of per-seed EXRs (every *.exr in it is one independent render), or
  * a mean EXR: the per-pixel mean over the seeds, with the per-pixel variance (ddof=1, of one
    render across the seeds) in a second EXR and the seed count N given by
      - a sidecar NAME.json next to NAME.exr: {"seeds": N, "variance": "NAME_var.exr"}, or
      - EXR header attributes of the mean: hairbsdf:seeds (int), hairbsdf:variance (a file
        name, relative to the mean's folder);
    the variance file defaults to NAME_var.exr.
"""

from __future__ import annotations

import argparse
import datetime
import json
import platform
import shlex
import sys
from pathlib import Path

import numpy as np

EPILOG = """\
examples:
  hairbsdf judge cycles_seeds/ my_seeds/                 folders of per-seed EXRs -> out/judge/
  hairbsdf judge cycles_seeds/ my_mean.exr --out rep/    TEST as a mean + my_mean_var.exr + my_mean.json

gates (docs/compare.md): no NaN/Inf; per-pixel Welch test, Sidak-corrected to family-wise 1%%
  (no failing pixel-channel); image-mean bias |z| <= t(1 - 0.01/2, Welch df), a 1%% false-alarm
  level per case, and |relative| <= 0.5%% (the relative bound gates only where the critical |z|
  times sigma resolves it, unless --strict). Measured rates: docs/statistics.md.

exit status: 0 pass, 1 fail, 2 bad arguments or input.
"""

MAX_NAMED = 10  # NaN/Inf values named with coordinates


class InputError(ValueError):
    pass


def build_parser(prog="hairbsdf judge"):
    from .._version import __version__
    from .cli import file_arg
    p = argparse.ArgumentParser(
        prog=prog, formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Judge a renderer's images (TEST) against reference images (REF, e.g. Cycles) with the "
                    "noise-aware statistics of `hairbsdf compare`; writes an HTML/JSON/JUnit report.")
    p.add_argument("ref", metavar="REF", help="folder of per-seed EXRs, or a mean EXR (with its variance and seeds)")
    p.add_argument("test", metavar="TEST", help="the same for the renderer under test")
    p.add_argument("--out", default="out/judge", help="report folder (default: out/judge)")
    p.add_argument("--thresholds", default=None, metavar="FILE", type=file_arg,
                   help="thresholds TOML ([defaults] applies; may tighten the fixed floors, never loosen them)")
    p.add_argument("--strict", action="store_true",
                   help="fail the relative image-mean bound when the noise is too large to verify it "
                        "(default: informational then, and the |z| test gates)")
    p.add_argument("--no-flip", action="store_true", help="skip FLIP (informational)")
    p.add_argument("--title", default=None,
                   help="the report's title (default: 'TEST vs REF' from the two folder or file names)")
    p.add_argument("--exit-zero", action="store_true", help="exit 0 even when the case fails")
    p.add_argument("--version", action="version", version="hairbsdf %s" % __version__)
    return p


# --------------------------------------------------------------------------- input

def _load(path):
    from . import metrics as M
    try:
        return M.load_image(path)
    except Exception as exc:
        raise InputError("%s: cannot read it as an image (%s)" % (path, exc)) from None


def _header(path, name):
    from .._deps import require
    oiio = require("OpenImageIO", "compare", "hairbsdf judge")
    spec = oiio.ImageInput.open(str(path))
    if spec is None:
        return None
    try:
        return spec.spec().getattribute(name)
    finally:
        spec.close()


def load_side(path):
    """(stack or metrics.Summary, [files]) of one side; InputError names the file at fault."""
    from . import metrics as M
    p = Path(path)
    if p.is_dir():
        files = sorted(f for f in p.iterdir() if f.suffix.lower() == ".exr" and f.is_file())
        if not files:
            raise InputError("%s: no .exr files in this folder" % p)
        if len(files) < 2:
            raise InputError("%s: one seed (%s); the Welch test and the image-mean bias need at least 2 "
                             "independent renders" % (p, files[0].name))
        imgs = []
        for f in files:
            im = _load(f)
            if imgs and im.shape != imgs[0].shape:
                raise InputError("%s: size/channels %dx%dx%d differ from %s (%dx%dx%d)"
                                 % (f, im.shape[1], im.shape[0], im.shape[2], files[0],
                                    imgs[0].shape[1], imgs[0].shape[0], imgs[0].shape[2]))
            imgs.append(im)
        return np.stack(imgs), [str(f) for f in files]
    if not p.exists():
        raise InputError("%s: no such file or folder" % p)
    mean = _load(p)
    side = p.with_suffix(".json")
    meta = {}
    if side.exists():
        try:
            meta = json.loads(side.read_text())
        except (OSError, ValueError) as exc:
            raise InputError("%s: not valid JSON (%s)" % (side, exc)) from None
    seeds = meta.get("seeds", _header(p, "hairbsdf:seeds"))
    var_name = meta.get("variance") or _header(p, "hairbsdf:variance") or (p.stem + "_var.exr")
    var_path = p.parent / var_name
    if seeds is None:
        raise InputError("%s: no seed count (EXR attribute hairbsdf:seeds or \"seeds\" in %s)" % (p, side))
    try:
        seeds = int(seeds)
    except (TypeError, ValueError):
        raise InputError("%s: seed count %r is not an integer" % (p, seeds)) from None
    if seeds < 2:
        raise InputError("%s: %d seed(s); the Welch test and the image-mean bias need at least 2" % (p, seeds))
    if not var_path.exists():
        raise InputError("%s: its variance image %s does not exist" % (p, var_path))
    var = _load(var_path)
    if var.shape != mean.shape:
        raise InputError("%s: size/channels %s differ from the mean %s (%s)" % (var_path, var.shape, p, mean.shape))
    return M.Summary(mean, var, seeds), [str(p), str(var_path)]


def _shape(side):
    from . import metrics as M
    return side.mean.shape if isinstance(side, M.Summary) else side.shape[1:]


def _scan(side, files):
    """NaN/Inf per file: ({file: count}, [(file, x, y, c, value)]) and a copy with them set to 0."""
    from . import metrics as M
    counts, where = {}, []
    if isinstance(side, M.Summary):
        arrays = [(files[0], side.mean), (files[1], side.var)]
    else:
        arrays = list(zip(files, side))
    for name, img in arrays:
        n, w = M.nonfinite(img, MAX_NAMED)
        counts[name] = n
        where += [(name,) + x for x in w]
    if sum(counts.values()):
        if isinstance(side, M.Summary):
            side = M.Summary(np.nan_to_num(side.mean, nan=0, posinf=0, neginf=0),
                             np.nan_to_num(side.var, nan=0, posinf=0, neginf=0), side.n)
        else:
            side = np.nan_to_num(side, nan=0, posinf=0, neginf=0)
    return side, counts, where


# --------------------------------------------------------------------------- run

def run(args, argv_text=""):
    from .._deps import exit_status_for_extra
    if exit_status_for_extra("compare", "hairbsdf judge"):
        return 1
    from . import judge, report
    from . import metrics as M
    from .thresholds import ThresholdError, Thresholds
    import hairbsdf

    try:
        thr = Thresholds.load(args.thresholds)
    except ThresholdError as exc:
        print("error: --thresholds: %s" % exc, file=sys.stderr)
        return 2
    except (OSError, ValueError) as exc:
        print("error: --thresholds %s: %s" % (args.thresholds, exc), file=sys.stderr)
        return 2
    try:
        ref, ref_files = load_side(args.ref)
        test, test_files = load_side(args.test)
        if _shape(ref) != _shape(test):
            a, b = _shape(ref), _shape(test)
            raise InputError("%s: size/channels %dx%dx%d differ from REF %s (%dx%dx%d)"
                             % (test_files[0], b[1], b[0], b[2], ref_files[0], a[1], a[0], a[2]))
    except InputError as exc:
        print("error: %s" % exc, file=sys.stderr)
        return 2
    ref, c_ref, w_ref = _scan(ref, ref_files)
    test, c_test, w_test = _scan(test, test_files)
    limits = thr.for_case("judge")
    checks, mets, maps = judge.evaluate("noisy", ref, test, limits, flip=not args.no_flip, ci=not args.strict)
    counts = dict(c_ref, **c_test)
    nf = judge.nonfinite_check(counts, w_ref + w_test, MAX_NAMED)
    checks.insert(0, nf)
    mets["nonfinite"] = dict(total=nf["value"], per_file={k: v for k, v in counts.items() if v},
                             first=[dict(file=f, x=x, y=y, channel=c, value=v) for f, x, y, c, v in
                                    (w_ref + w_test)[:MAX_NAMED]])
    status = judge.status_of(checks)
    failed = [ch["label"] for ch in checks if ch["gate"] and not ch["passed"]]
    n_ref = ref.n if isinstance(ref, M.Summary) else ref.shape[0]
    n_test = test.n if isinstance(test, M.Summary) else test.shape[0]
    h, w, _ = _shape(ref)
    res = dict(id="judge", dir="judge", scene="judge", variant=None, file=None, kind="noisy",
               title="%s vs %s" % (args.test, args.ref),
               description="REF %s (%d seeds), TEST %s (%d seeds)" % (args.ref, n_ref, args.test, n_test),
               blender=dict(label="judge", path=""), engine="TEST", engine_label="TEST", ref_label="REF",
               sizes=dict(res=[w, h], seeds=n_ref, seeds_test=n_test), limits=limits, checks=checks,
               metrics=report.clean(mets), renders=[], status=status,
               reason=("failed: " + "; ".join(failed)) if failed else "",
               inputs=dict(ref=ref_files, test=test_files))
    res["reproduce"] = argv_text
    out = Path(args.out)
    report.write_case_assets(out, res, maps)
    run_info = dict(created=datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
                    command=argv_text, hairbsdf="hairbsdf %s" % hairbsdf.__version__, host=platform.node(),
                    python=sys.version.split()[0], thresholds=thr.source)
    index = report.write_report(out, [res], run_info, title=args.title or default_title(args.ref, args.test),
                                tool="hairbsdf judge")
    for line in report.summary_lines([res]):
        print(line)
    if nf["value"]:
        print("  " + nf["detail"])
    print("report: %s" % index.resolve())
    return 0 if (status != "FAIL" or args.exit_zero) else 1


def default_title(ref, test):
    """'TEST vs REF' from the names of the two folders (or mean EXRs, without .exr)."""
    def name(p):
        p = Path(p).resolve()
        return p.stem if p.suffix.lower() == ".exr" else p.name
    return "%s vs %s" % (name(test), name(ref))


def main(argv=None, prog="hairbsdf judge"):
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(prog).parse_args(argv)
    return run(args, argv_text="%s %s" % (prog, " ".join(shlex.quote(a) for a in argv)))


if __name__ == "__main__":
    sys.exit(main())
