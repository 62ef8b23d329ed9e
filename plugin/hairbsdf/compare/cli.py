"""`hairbsdf compare` / `python -m hairbsdf.compare`: does our engine match Cycles, and where not?"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import shlex
import sys
from pathlib import Path

from .._constants import ENGINE_ID

EPILOG = """\
examples:
  hairbsdf compare                                  the swatch scene, bpy 4.5, full size -> out/compare/
  hairbsdf compare --scene all --ci                 every library scene at CI size
  hairbsdf compare --scene fiber_gonio --blender /usr/bin/blender
  hairbsdf compare --scene all --ci --blender all   in Blender 3.4, bpy 4.5 and bpy 5.3 (those installed)
  hairbsdf compare --scene my_groom.blend --seeds 8 --spp 64
  hairbsdf compare --scene all --blender bpy --blender blender --ci --shard 2/4 --out out/shard2
  hairbsdf report merge out/shard1 out/shard2 out/shard3 out/shard4 --out out/compare
  hairbsdf compare --scene swatch --engine CYCLES   null test: Cycles against itself on other seeds
  hairbsdf compare --scene swatch --model epic      our engine renders Epic in place of Principled Hair
  hairbsdf compare --model plugin:build/kk.so:examples/plugins/kajiya_kay/mapping.py    your BSDF plugin
  hairbsdf compare --sweep examples/sweeps/fiber_gonio_melanin_roughness.toml --ci --no-exact
                                                    a 24-case parameter sweep (schema: docs/cluster.md)
  hairbsdf compare --sweep examples/sweeps/fiber_gonio_melanin_roughness.toml --ci --no-exact --scheduler local:2
                                                    the same on a Dask LocalCluster of 2 worker processes
  hairbsdf compare --scene all --scheduler tcp://head:8786 --storage /shared/hb    on a Dask cluster

how it judges (details: docs/compare.md):
  noise-free scenes (fiber_gonio): per-pixel relative error, median <= 1e-4 and p99 <= 2e-3
  noisy scenes: several independent renders (seeds) per engine; a per-pixel Welch t-test with a
    Sidak correction (family-wise 1%%) must find no biased pixel, and the image-mean bias must pass
    a t test at 1%% per case and be within 0.5%%; the furnace's image mean within 0.5%% of Cycles'
  informational: mean/RMS/max absolute and relative error, PSNR, the idiff rule, FLIP, and the
    effect of exact special functions (our engine rendered with accuracy EXACT)
  thresholds: hairbsdf/compare/thresholds.toml in the package (may tighten the fixed floors, never loosen them)

exit status: 0 when no case FAILs, CRASHes or has NO OUTPUT / ERROR (PENDING and SKIPPED are fine),
  1 otherwise, 2 for bad arguments (a bad sweep file included), 3 when the Dask cluster cannot be
  used (no scheduler within --scheduler-timeout, no workers, a worker with another hairbsdf), 130 when
  interrupted (Ctrl-C).
"""


def build_parser(prog="hairbsdf compare"):
    from .._version import __version__
    from .runner import default_cache_dir, default_thresholds, load_catalog

    catalog, default_scene = load_catalog()
    scenes = ", ".join(catalog)
    p = argparse.ArgumentParser(
        prog=prog, formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Render scenes with Blender's Cycles and with the hairbsdf engine (-E %s in the same "
                    "Blender), compare them with noise-aware statistics and write an HTML/JSON/JUnit report."
                    % ENGINE_ID)
    p.add_argument("--scene", action="append", metavar="NAME|FILE.blend",
                   help="library scene (%s; NAME:VARIANT for one variant; 'all'), or any .blend file; repeat or "
                        "comma-separate (default: %s)" % (scenes, default_scene))
    p.add_argument("--blender", action="append", metavar="bpy|bpy5|all|PATH",
                   help="'bpy' (the bpy module from pip, e.g. 4.5 LTS in .venv), 'bpy5' (bpy 5.3 in the second venv "
                        "scripts/setup makes), a Blender executable such as Debian's /usr/bin/blender (3.4), or "
                        "'all' (every one of these that is installed); repeat for several (default: bpy)")
    p.add_argument("--cycles-osl", action="store_true",
                   help="render the Cycles reference with its OSL backend (its hair closure differs slightly from "
                        "the SVM one; docs/compare.md)")
    p.add_argument("--spp", type=count_arg(1), help="samples per render (default: the scene's, per size)")
    p.add_argument("--res", metavar="WxH", type=res_arg, help="resolution, e.g. 320x240 (default: the scene's)")
    p.add_argument("--seeds", type=count_arg(1), help="independent renders per engine for the statistics (default: the "
                                             "scene's; >= 2 for the Welch test)")
    p.add_argument("--ci", action="store_true", help="small sizes for CI (the scenes' 'ci' sizes; no exact renders)")
    p.add_argument("--exact-seeds", type=count_arg(0), metavar="N",
                   help="also render the engine with exact special functions on N seeds (default: 2, 0 with --ci, "
                        "1 for noise-free scenes)")
    p.add_argument("--no-exact", action="store_true", help="skip the exact-accuracy renders")
    p.add_argument("--out", default=None, help="report folder (default: out/compare)")
    p.add_argument("--jobs", "-j", type=count_arg(1), default=None,
                   help="renders in parallel, each in its own process (default: the number of cores; threads are "
                        "split between them)")
    p.add_argument("--threads", type=count_arg(0), default=0, help="threads per render (default: cores / jobs)")
    p.add_argument("--shard", metavar="I/N", help="render only shard I of N of the sorted case list (CI matrices; "
                                                  "join the reports with `hairbsdf report merge`)")
    p.add_argument("--model", metavar="NAME|plugin:PATH[:mapping.py]",
                   help="render our side with a zoo model (kajiya_kay, epic, scheuermann, marschner, deon, yan_fur) or a BSDF "
                        "plugin in place of every Principled Hair closure; mapping.py maps the node's inputs to the "
                        "model's parameters (map_inputs), else the model's defaults (docs/compare.md)")
    p.add_argument("--sweep", metavar="FILE", type=file_arg,
                   help="a sweep TOML: render one scene over the product of its axes (node inputs, render settings, "
                        "Blender versions); the report gets sweep.html with the verdicts and a bias heat map "
                        "(schema: docs/cluster.md)")
    p.add_argument("--scheduler", metavar="local:N|ADDRESS",
                   help="run every Blender process as a task on a Dask cluster: local:N starts a LocalCluster of "
                        "N worker processes, ADDRESS (tcp://host:8786) joins a running scheduler; needs "
                        "hairbsdf[dask] (docs/cluster.md)")
    p.add_argument("--storage", metavar="DIR",
                   help="with --scheduler: a folder the client and every worker see at the same path; files travel "
                        "through it instead of the scheduler, and the Cycles cache lives in DIR/cache")
    p.add_argument("--scheduler-timeout", type=count_arg(1), default=30, metavar="S",
                   help="seconds to wait for the scheduler and for a first worker (default 30; then exit 3)")
    p.add_argument("--engine", default=ENGINE_ID,
                   help="engine under test (default %s; CYCLES renders Cycles on other seeds, a null test of "
                        "the statistics)" % ENGINE_ID)
    p.add_argument("--force-parity", action="store_true",
                   help="for user .blend files: apply the parity settings (no denoising, clamps 0, ...) before "
                        "rendering; without it they are only reported")
    p.add_argument("--thresholds", default=None, type=file_arg,
                   help="thresholds TOML (default: %s)" % default_thresholds())
    p.add_argument("--cache", default=None, help="cache folder for built scenes and Cycles renders (default: %s)"
                                                 % default_cache_dir())
    p.add_argument("--no-cache", action="store_true", help="render Cycles again and do not store it")
    p.add_argument("--refresh", action="store_true", help="re-render cached Cycles images and rebuild scenes")
    p.add_argument("--timeout", type=count_arg(1), default=900, help="seconds per render process (default 900)")
    p.add_argument("--no-flip", action="store_true", help="skip FLIP")
    p.add_argument("--list-scenes", action="store_true", help="list the scene library and exit")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    p.add_argument("--exit-zero", action="store_true", help="exit 0 even when cases fail")
    p.add_argument("--version", action="version", version="hairbsdf %s" % __version__)
    return p


def count_arg(lo):
    """argparse type: an integer >= lo (the error names what is allowed; argparse adds the option)."""
    def parse(s):
        try:
            v = int(s)
        except ValueError:
            v = None
        if v is None or v < lo:
            raise argparse.ArgumentTypeError("must be an integer >= %d, not %r" % (lo, s))
        return v
    parse.__name__ = "integer >= %d" % lo
    return parse


def res_arg(s):
    try:
        return parse_res(s)
    except ValueError:
        raise argparse.ArgumentTypeError("takes WxH with W, H >= 1, e.g. 320x240, not %r" % s) from None


def file_arg(s):
    if not os.path.isfile(s):
        raise argparse.ArgumentTypeError("file %s does not exist" % s)
    return s


def parse_res(s):
    if not s:
        return None
    try:
        w, h = s.lower().split("x")
        w, h = int(w), int(h)
        assert w > 0 and h > 0
        return (w, h)
    except (ValueError, AssertionError):
        raise ValueError("--res takes WxH, e.g. 320x240, not %r" % s) from None


def default_out():
    from .runner import REPO
    return (REPO / "out" / "compare") if REPO else Path("out/compare")


def run_compare(args, argv_text=""):
    from .._deps import exit_status_for_extra
    if exit_status_for_extra("compare", "hairbsdf compare"):
        return 1
    from . import report
    from .runner import (Options, Runner, TargetError, default_cache_dir, default_thresholds, expand_cases,
                         load_catalog, resolve_target, shard, all_target_specs)
    from .thresholds import ThresholdError, Thresholds

    catalog, default_scene = load_catalog()
    if args.list_scenes:
        for name, m in catalog.items():
            v = (" variants: " + ", ".join(m["variants"])) if m.get("variants") else ""
            print("%-14s %-13s %s+  %s.%s\n%16s%s" % (name, m["kind"], ".".join(map(str, m["min_blender"][:2])),
                                                      m["title"], v, "", m["description"]))
        return 0
    hair_model = None
    if args.model:
        from .model_spec import ModelSpecError, parse_model_spec
        try:
            hair_model = parse_model_spec(args.model)
        except ModelSpecError as exc:
            print("error: --model %s: %s" % (args.model, exc), file=sys.stderr)
            return 2
        if args.engine.upper() != ENGINE_ID:
            print("error: --model needs --engine %s (the override is our engine's)" % ENGINE_ID, file=sys.stderr)
            return 2
    try:
        thr = Thresholds.load(args.thresholds or default_thresholds())
    except ThresholdError as exc:
        print("error: %s" % exc, file=sys.stderr)
        return 2
    sweep = None
    if args.sweep:
        from . import sweep as sweep_mod
        if args.scene:
            print("error: --sweep names its scene (scene = ... in %s); drop --scene" % args.sweep, file=sys.stderr)
            return 2
        try:
            sweep = sweep_mod.load(args.sweep)
        except sweep_mod.SweepError as exc:
            print("error: --sweep %s" % exc, file=sys.stderr)
            return 2
        if not args.blender and sweep.blender:
            args.blender = list(sweep.blender)
    if args.storage and not args.scheduler:
        print("error: --storage needs --scheduler (local:N or an address)", file=sys.stderr)
        return 2
    if args.scheduler:
        from .cluster import parse_scheduler
        try:
            parse_scheduler(args.scheduler)
        except ValueError as exc:
            print("error: %s" % exc, file=sys.stderr)
            return 2
        from .._deps import exit_status_for_extra as _extra
        if _extra("dask", "hairbsdf compare --scheduler"):
            return 1
    targets = []
    specs = []
    for spec in (args.blender or ["bpy"]):
        specs.extend(all_target_specs() if spec == "all" else [spec])
    for spec in dict.fromkeys(specs):
        try:
            targets.append(resolve_target(spec))
        except TargetError as exc:
            print("error: --blender %s: %s" % (spec, exc), file=sys.stderr)
            return 2
    try:
        exact = 0 if (args.no_exact or hair_model) else args.exact_seeds  # accuracy is Chiang's only
        cases = expand_cases([sweep.scene] if sweep else (args.scene or [default_scene]), targets, ci=args.ci,
                             spp=args.spp, res=args.res, seeds=args.seeds, exact_seeds=exact, catalog=catalog)
        if sweep:
            cases = sweep_mod.expand(sweep, cases)
        cases = shard(cases, args.shard)
    except ValueError as exc:
        print("error: %s" % exc, file=sys.stderr)
        return 2
    for c in cases:
        if c.kind == "noisy" and not c.skip and c.seeds < 2:
            print("note: %s has %d seed; the Welch test and the mean-bias check need >= 2 (--seeds)" % (c.id, c.seeds),
                  file=sys.stderr)
    out = Path(args.out) if args.out else default_out()
    jobs = args.jobs or max(1, min(os.cpu_count() or 1, 8))
    cache = Path(args.cache) if args.cache else default_cache_dir()
    if args.scheduler:
        jobs = max(1, min(256, sum(c.seeds * 2 + c.exact_seeds + 1 for c in cases)))  # tasks in flight
        if args.storage and not args.cache:
            cache = Path(args.storage) / "cache"  # the shared Cycles cache
    opts = Options(out=out, cache=cache, jobs=jobs,
                   threads=args.threads, timeout=args.timeout, use_cache=not args.no_cache, refresh=args.refresh,
                   osl=args.cycles_osl, engine=args.engine.upper(), force_parity=args.force_parity, thresholds=thr,
                   flip=not args.no_flip, ci=args.ci, progress=not args.quiet, argv=sys.argv, hair_model=hair_model)
    client = cluster = workers = None
    if args.scheduler:
        from .cluster import EXIT_CLUSTER, ClusterError, ClusterRunner, connect, retry_policy
        try:
            if args.storage:
                Path(args.storage).mkdir(parents=True, exist_ok=True)
            client, cluster, desc = connect(args.scheduler, args.scheduler_timeout)
            kind_n = args.scheduler.partition(":")[2] if args.scheduler.startswith("local:") else None
            threads = args.threads or (max(1, (os.cpu_count() or 2) // int(kind_n)) if kind_n else 0)
            runner = ClusterRunner(cases, opts, client, desc, storage=args.storage, threads=threads)
            workers = runner.check_workers(args.scheduler_timeout)
        except ClusterError as exc:
            print("error: --scheduler %s: %s" % (args.scheduler, exc), file=sys.stderr)
            _close(client, cluster)
            return EXIT_CLUSTER
        if not args.quiet:
            print("hairbsdf compare: %s, %d worker%s; Dask retries a task after a worker dies, %d times at most "
                  "(distributed.scheduler.allowed-failures)"
                  % (desc, len(workers), "" if len(workers) == 1 else "s", retry_policy()), file=sys.stderr)
    else:
        runner = Runner(cases, opts)
    if not args.quiet:
        print("hairbsdf compare: %d case%s (%s) -> %s" % (len(cases), "" if len(cases) == 1 else "s",
                                                          ", ".join(t.label for t in targets), out), file=sys.stderr)
    try:
        return _run_and_report(args, argv_text, runner, out, targets, opts, hair_model, thr, sweep, workers)
    except KeyboardInterrupt:
        print("\nhairbsdf compare: interrupted; no report written", file=sys.stderr)
        return 130
    finally:
        _close(client, cluster)


def _close(client, cluster):
    if client is not None or cluster is not None:
        from .cluster import close
        close(client, cluster)


def _run_and_report(args, argv_text, runner, out, targets, opts, hair_model, thr, sweep, workers):
    from . import report

    def on_case(res, maps):
        res["reproduce"] = reproduce_command(res, args)
        if res["status"] not in ("SKIPPED",) and maps:
            report.write_case_assets(out, res, maps)
        elif res["status"] not in ("SKIPPED",):
            (out / "cases" / res["dir"]).mkdir(parents=True, exist_ok=True)

    results = runner.run(on_case=on_case)
    for res in results:
        res.setdefault("reproduce", reproduce_command(res, args))
    import hairbsdf
    ver = "hairbsdf %s" % hairbsdf.__version__
    run = dict(hairbsdf_file=hairbsdf.__file__, created=datetime.datetime.now().astimezone().isoformat(timespec="seconds"), git=_git_describe(),
               command=argv_text or " ".join(shlex.quote(a) for a in sys.argv), hairbsdf=ver,
               host=platform.node(), python=sys.version.split()[0], seconds=round(runner.seconds, 1),
               shard=args.shard, targets=[t.as_dict() for t in targets], engine=opts.engine,
               hair_model=hair_model,
               thresholds=thr.source, cache=str(opts.cache))
    if workers is not None:
        run["cluster"] = runner.run_info(workers)
    if sweep:
        from .sweep import sweep_view
        run["sweep"] = sweep_view(out, results, sweep)
    index = report.write_report(out, results, run)
    summ = report.summarize(results)
    print("\nhairbsdf compare: %s in %.0f s" % (", ".join("%d %s" % (n, s) for s, n in summ["counts"].items()),
                                                runner.seconds))
    for line in report.summary_lines(results):
        print(line)
    print("report: %s" % index.resolve())
    return 0 if (summ["bad"] == 0 or args.exit_zero) else 1


def reproduce_command(res, args):
    """The command line that renders and judges this case alone with the run's settings (the seeds
    follow from the Blender version and the seed count, so the renders repeat)."""
    scene = res.get("file") or (res["scene"] + (":" + res["variant"] if res.get("variant") else ""))
    sz = res.get("sizes") or {}
    cmd = ["hairbsdf", "compare"] + (["--sweep", args.sweep] if args.sweep else ["--scene", scene])
    cmd += ["--blender", res["blender"].get("spec") or res["blender"]["path"]]
    if args.ci:
        cmd.append("--ci")
    if sz.get("res"):
        cmd += ["--res", "%dx%d" % tuple(sz["res"])]
    if sz.get("spp"):
        cmd += ["--spp", str(sz["spp"])]
    if sz.get("seeds") and res.get("kind") != "deterministic":
        cmd += ["--seeds", str(sz["seeds"])]
    cmd += ["--exact-seeds", str(sz.get("exact_seeds") or 0)]
    for flag, on in (("--cycles-osl", args.cycles_osl), ("--no-flip", args.no_flip),
                     ("--force-parity", args.force_parity)):
        if on:
            cmd.append(flag)
    if args.engine.upper() != ENGINE_ID:
        cmd += ["--engine", args.engine.upper()]
    for opt, val in (("--model", args.model), ("--thresholds", args.thresholds)):
        if val:
            cmd += [opt, val]
    if args.threads:
        cmd += ["--threads", str(args.threads)]
    cmd += ["--out", "out/reproduce/" + res["dir"]]
    return shlex.join(cmd)


def _git_describe():
    from .runner import REPO
    if not REPO:
        return None
    try:
        import subprocess
        r = subprocess.run(["git", "-C", str(REPO), "describe", "--always", "--dirty"], capture_output=True,
                           text=True, timeout=10)
        return r.stdout.strip() or None
    except Exception:
        return None


def run_merge(argv):
    from .._deps import exit_status_for_extra
    if exit_status_for_extra("compare", "hairbsdf report merge"):
        return 1
    from . import report
    p = argparse.ArgumentParser(prog="hairbsdf report merge",
                                description="Join the reports of several `hairbsdf compare --shard` runs into one.")
    p.add_argument("dirs", nargs="+", help="report folders (each with report.json)")
    p.add_argument("--out", default=None, help="merged report folder (default: out/compare)")
    p.add_argument("--exit-zero", action="store_true", help="exit 0 even when cases fail")
    a = p.parse_args(argv)
    try:
        path, notes = report.merge(a.dirs, Path(a.out) if a.out else default_out())
    except (OSError, ValueError) as exc:
        print("error: %s" % exc, file=sys.stderr)
        return 2
    for n in notes:
        print("note: " + n, file=sys.stderr)
    data = report.load_report(path.parent)
    for line in report.summary_lines(data["cases"]):
        print(line)
    print("report: %s" % path.resolve())
    return 0 if (data["summary"]["bad"] == 0 or a.exit_zero) else 1


def main(argv=None, prog="hairbsdf compare"):
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["merge"] or argv[:2] == ["report", "merge"]:
        return run_merge(argv[2:] if argv[0] == "report" else argv[1:])
    args = build_parser(prog).parse_args(argv)
    return run_compare(args, argv_text="%s %s" % (prog, " ".join(shlex.quote(a) for a in argv)))
