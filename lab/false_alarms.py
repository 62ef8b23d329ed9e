#!/usr/bin/env python3
"""False-alarm rates of the judge's gates, measured with Cycles against Cycles (issue 22, item 2).

Renders (or reuses from the harness's cache) a pool of Cycles per-seed EXRs of library scenes at CI
size, through the same code path as `hairbsdf compare` (runner.Runner.build / render_one; the
renders land in build/compare_cache/cycles/, so a rerun renders nothing and `compare` reuses them).
Then, per scene and per seed count k, it splits the pool into disjoint pairs of k-seed sets
(seeds [2ik, 2ik+k) against [2ik+k, 2(i+1)k)) and runs each pair through the judge's own gate
code (judge.evaluate, as `hairbsdf judge` and `compare --ci` run it). Both sides are Cycles, so
every failing gate is a false alarm. It prints, per gate, failures / trials with the
Clopper-Pearson 95 % interval (independent trials only).

Disjoint trials are few at 64 seeds, so it also resamples the pool (random, overlapping splits;
not independent, so no interval) and reports each gate's null distribution: the rate of the old
|z| > 2 rule and of the new t-critical rule, the per-case p-value of the image-mean test and the
Sidak-adjusted smallest per-pixel p (both uniform on [0, 1] for a calibrated test, so their
fraction below 1 % is the false-alarm rate), and the fraction of pixel-channels below p = 1e-3.

    .venv/bin/python lab/false_alarms.py --help
    .venv/bin/python lab/false_alarms.py --scenes swatch,ribbons_vs_3d:RIBBONS --pool 640,768
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
import math
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent


def clopper_pearson(k, n, conf=0.95):
    """Exact two-sided binomial interval for k successes in n trials."""
    from scipy import stats
    a = 1.0 - conf
    lo = 0.0 if k == 0 else float(stats.beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(stats.beta.ppf(1 - a / 2, k + 1, n - k))
    return lo, hi


def cpu_seconds():
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


# --------------------------------------------------------------------------- renders

def render_pool(scene, pool, jobs, threads, out, log=print):
    """Per-seed Cycles EXRs of `scene` (NAME or NAME:VARIANT) at CI size, seeds 0..pool-1, bpy.
    Returns (paths, ledger entry) where the ledger records the compute of renders made now."""
    from hairbsdf.compare import runner
    target = runner.resolve_target("bpy")
    (case,) = runner.expand_cases([scene], [target], ci=True, seeds=pool, exact_seeds=0)
    opts = runner.Options(out=out / "compare", cache=runner.default_cache_dir(), jobs=jobs, threads=threads,
                          ci=True, progress=False)
    r = runner.Runner([case], opts)
    b = r.build(case)
    if not b.get("ok"):
        raise SystemExit("building %s failed: %s\n%s" % (scene, b.get("error"), b.get("log_tail", "")))
    case_dir = opts.out / "cases" / case.dirname
    t0, c0 = time.time(), cpu_seconds()
    done = [0, 0]  # rendered now, cached

    def one(seed):
        res = r.render_one(case, b["blend"], "CYCLES", "CYCLES", seed, case_dir)
        if not res.get("ok"):
            raise RuntimeError("Cycles seed %d of %s: %s %s\n%s" % (seed, scene, res.get("status"), res.get("error"),
                                                                    res.get("log_tail", "")))
        done[1 if res.get("cached") else 0] += 1
        n = done[0] + done[1]
        if n % 32 == 0 or n == pool:
            el = time.time() - t0
            log("  %s: %d/%d seeds (%d rendered now, %d cached), %.0f s" % (scene, n, pool, done[0], done[1], el),
                flush=True)
        return seed, res["exr"], (None if res.get("cached") else res.get("wall_seconds"))

    with cf.ThreadPoolExecutor(max_workers=max(1, jobs)) as ex:
        results = sorted(ex.map(one, range(pool)))
    walls = {s: w for s, _, w in results if w is not None}
    entry = dict(scene=scene, case=case.id, res=list(case.res), spp=case.spp, blender=target.label,
                 rendered=len(walls), cached=pool - len(walls), wall_seconds=time.time() - t0,
                 cpu_seconds=cpu_seconds() - c0, render_wall_seconds=walls, jobs=jobs, threads=r.threads)
    return [p for _, p, _ in results], entry


def load_pool(paths):
    from hairbsdf.compare import metrics as M
    return np.stack([M.load_image(p) for p in paths]).astype(np.float32)


# --------------------------------------------------------------------------- trials

GATES = ("welch", "mean_bias_sigma", "mean_bias_rel", "nonfinite")


def judge_trial(A, B, limits):
    """The judge's gates on two stacks, exactly as `hairbsdf judge` / `compare --ci` gate them.
    Returns ({gate: failed}, metrics)."""
    from hairbsdf.compare import judge
    from hairbsdf.compare import metrics as M
    checks, mets, _ = judge.evaluate("noisy", A, B, limits, flip=False, ci=True)
    nf = sum(M.nonfinite(im)[0] for im in list(A) + list(B))
    checks.append(judge.nonfinite_check({"all": nf}, []))
    failed = {c["name"]: (c["gate"] and not c["passed"]) for c in checks}
    out = {g: bool(failed.get(g, False)) for g in GATES}
    # informational, not a gate: one seed too far out for a normal spread (heavy tails)
    out["seed_tails"] = any(c["name"] == "seed_tails" and not c["passed"] for c in checks)
    out["any"] = any(c["gate"] and not c["passed"] for c in checks)
    return out, mets


def null_stats(X, I, ia, ib, limits):
    """Cheap per-trial statistics for the resampled null distributions, with the judge's own
    functions: X the pool's RGB (float64), I its per-seed image means as (n, 1, 1, 3) stacks
    (mean_bias on them equals mean_bias on the images), ia / ib the seed indices of the sides."""
    from hairbsdf.compare import metrics as M
    A, B = X[ia], X[ib]
    ma, va = A.mean(axis=0), A.var(axis=0, ddof=1)
    mb, vb = B.mean(axis=0), B.var(axis=0, ddof=1)
    w = M.welch_from_stats(ma, va, len(ia), mb, vb, len(ib), alpha=limits["welch_alpha"],
                           floor_abs=limits["welch_floor_abs"], floor_rel=limits["welch_floor_rel"])
    b = M.mean_bias(I[ia], I[ib], floor_rel=limits["welch_floor_rel"])
    crit = M.mean_bias_critical(b["df"], limits["mean_bias_alpha"])
    noisy = (va + vb) > 0
    return dict(z=b["z"], df=b["df"], crit=crit, p_mean=float(2 * M.t_sf(abs(b["z"]), b["df"])[()]),
                welch_fail=w["n_fail"] > 0,
                welch_case_p=float(-np.expm1(w["m"] * np.log1p(-w["min_p"]))) if w["min_p"] < 1 else 1.0,
                frac_p1e3=float(np.count_nonzero(w["p"] < 1e-3)) / w["m"],
                frac_p1e3_noisy=float(np.count_nonzero((w["p"] < 1e-3) & noisy)) / max(int(noisy.sum()), 1),
                rel_sigma=b["rel_sigma"], rel=b["rel"])


def fmt_rate(k, n):
    lo, hi = clopper_pearson(k, n)
    return "%3d/%-3d  %5.1f %%  [%4.1f, %5.1f] %%" % (k, n, 100.0 * k / n, 100 * lo, 100 * hi)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] + " Cycles against Cycles on disjoint "
                                 "seed sets through judge.evaluate; prints failures/trials per gate with "
                                 "Clopper-Pearson 95 % intervals, the resampled null distributions and the compute.",
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="Renders are cached in build/compare_cache/cycles/ (the harness's cache), "
                                        "so a rerun with the same or a smaller pool renders nothing.")
    ap.add_argument("--scenes", default="swatch,ribbons_vs_3d:RIBBONS",
                    help="library scenes (NAME or NAME:VARIANT), comma-separated (default %(default)s)")
    ap.add_argument("--pool", default="128",
                    help="Cycles seeds per scene, 0..POOL-1; one number, or one per scene, comma-separated "
                         "(default %(default)s)")
    ap.add_argument("--sizes", default="4,16,64", help="seeds per side of a trial (default %(default)s)")
    ap.add_argument("--resamples", type=int, default=1000,
                    help="random overlapping splits per size for the null distributions (default %(default)s)")
    ap.add_argument("--mean-resamples", type=int, default=20000,
                    help="random overlapping splits per size for the image-mean gate alone (default %(default)s)")
    ap.add_argument("--jobs", type=int, default=2, help="parallel render processes (default %(default)s)")
    ap.add_argument("--threads", type=int, default=1, help="threads per render (default %(default)s)")
    ap.add_argument("--render-only", action="store_true", help="render the pool and stop")
    ap.add_argument("--out", type=Path, default=REPO / "build" / "lab" / "false_alarms",
                    help="results folder: results.json, ledger.json (default %(default)s)")
    args = ap.parse_args(argv)

    from hairbsdf.compare import metrics as M
    from hairbsdf.compare.thresholds import Thresholds

    args.out.mkdir(parents=True, exist_ok=True)
    sizes = [int(s) for s in args.sizes.split(",")]
    scenes = [s.strip() for s in args.scenes.split(",") if s.strip()]
    pools = [int(p) for p in args.pool.split(",")]
    if len(pools) == 1:
        pools = pools * len(scenes)
    if len(pools) != len(scenes):
        ap.error("--pool takes one number or one per scene")
    ledger_path = args.out / "ledger.json"
    ledger = json.loads(ledger_path.read_text()) if ledger_path.exists() else {}
    limits = Thresholds.load(None).for_case("judge")
    t_all, c_all = time.time(), cpu_seconds()
    results = dict(date=time.strftime("%Y-%m-%d"), sizes=sizes, scenes={}, limits={
        k: limits[k] for k in ("welch_alpha", "mean_bias_alpha", "mean_bias_rel")})
    for scene, pool in zip(scenes, pools):
        print("[%s] pool of %d Cycles seeds at CI size (bpy)" % (scene, pool), flush=True)
        paths, entry = render_pool(scene, pool, args.jobs, args.threads, args.out)
        led = ledger.setdefault(scene, dict(render_wall_seconds={}, cpu_seconds=0.0, wall_seconds=0.0))
        led["render_wall_seconds"].update({str(k): v for k, v in entry["render_wall_seconds"].items()})
        if entry["rendered"]:
            led["cpu_seconds"] += entry["cpu_seconds"]
            led["wall_seconds"] += entry["wall_seconds"]
        led.update(res=entry["res"], spp=entry["spp"], blender=entry["blender"], case=entry["case"])
        ledger_path.write_text(json.dumps(ledger, indent=1))
        print("  rendered now %d, cached %d; this scene's renders so far: %d seeds, %.0f s wall, %.0f s CPU"
              % (entry["rendered"], entry["cached"], len(led["render_wall_seconds"]), led["wall_seconds"],
                 led["cpu_seconds"]), flush=True)
        if args.render_only:
            continue
        stack = load_pool(paths)
        X = M.rgb(stack).astype(np.float64)
        I = X.mean(axis=(1, 2))[:, None, None, :]
        sres = dict(res=entry["res"], spp=entry["spp"], blender=entry["blender"], pool=pool, sizes={})
        rng = np.random.default_rng(20261126)
        for k in sizes:
            n_trials = pool // (2 * k)
            if n_trials == 0:
                print("  k=%d: the pool has no disjoint pair" % k)
                continue
            t0 = time.time()
            fails = {g: 0 for g in GATES + ("any", "seed_tails")}
            old = 0
            zs = []
            for i in range(n_trials):
                A, B = stack[2 * i * k:2 * i * k + k], stack[2 * i * k + k:2 * (i + 1) * k]
                f, mets = judge_trial(A, B, limits)
                for g, v in f.items():
                    fails[g] += v
                z = mets["mean_bias"]["z"]
                zs.append(z)
                old += abs(z) > 2.0
            nulls = []
            for _ in range(args.resamples if args.resamples else 0):
                perm = rng.permutation(pool)[:2 * k]
                nulls.append(null_stats(X, I, perm[:k], perm[k:], limits))
            rs = dict(trials=n_trials, fails=fails, old_abs_z_2=old, z=zs)
            # the image-mean gate needs only the per-seed image means: many more resamples, cheaply
            mnew = mold = 0
            for _ in range(args.mean_resamples):
                perm = rng.permutation(pool)[:2 * k]
                b = M.mean_bias(I[perm[:k]], I[perm[k:]], floor_rel=limits["welch_floor_rel"])
                mnew += abs(b["z"]) > M.mean_bias_critical(b["df"], limits["mean_bias_alpha"])
                mold += abs(b["z"]) > 2.0
            if args.mean_resamples:
                rs["mean_resampled"] = dict(n=args.mean_resamples, new=mnew / args.mean_resamples,
                                            old=mold / args.mean_resamples)
            if nulls:
                zn = np.array([x["z"] for x in nulls])
                rs["resampled"] = dict(
                    n=len(nulls),
                    mean_new=float(np.mean([abs(x["z"]) > x["crit"] for x in nulls])),
                    mean_old=float(np.mean(np.abs(zn) > 2.0)),
                    mean_p_below_1pct=float(np.mean([x["p_mean"] < 0.01 for x in nulls])),
                    welch=float(np.mean([x["welch_fail"] for x in nulls])),
                    welch_case_p_below_1pct=float(np.mean([x["welch_case_p"] < 0.01 for x in nulls])),
                    welch_case_p_below_10pct=float(np.mean([x["welch_case_p"] < 0.10 for x in nulls])),
                    pixels_below_1e3=float(np.mean([x["frac_p1e3"] for x in nulls])),
                    noisy_pixels_below_1e3=float(np.mean([x["frac_p1e3_noisy"] for x in nulls])),
                    z_sd=float(zn.std()), z_q99=float(np.quantile(np.abs(zn), 0.99)),
                    median_df=float(np.median([x["df"] for x in nulls])),
                    median_crit=float(np.median([x["crit"] for x in nulls])),
                    rel_sigma_median=float(np.median([x["rel_sigma"] for x in nulls])))
            sres["sizes"][str(k)] = rs
            print("  k=%2d: %d disjoint trials, %d resampled, %.0f s" % (k, n_trials, len(nulls), time.time() - t0),
                  flush=True)
        results["scenes"][scene] = sres
    results["analysis_wall_seconds"] = time.time() - t_all
    results["analysis_cpu_seconds"] = cpu_seconds() - c_all
    results["ledger"] = ledger
    (args.out / "results.json").write_text(json.dumps(results, indent=1))
    if args.render_only:
        return 0
    print()
    print("Disjoint trials (independent): failures / trials, rate, Clopper-Pearson 95 %")
    hdr = "%-22s %4s  %-34s %-34s %-34s %-34s %-34s" % ("scene", "k", "welch", "mean_bias_sigma (t crit)",
                                                       "mean_bias_rel", "any gate", "old |z| > 2 (for reference)")
    print(hdr)
    for scene, sres in results["scenes"].items():
        for k, rs in sres["sizes"].items():
            n = rs["trials"]
            print("%-22s %4s  %-34s %-34s %-34s %-34s %-34s" % (
                scene, k, fmt_rate(rs["fails"]["welch"], n), fmt_rate(rs["fails"]["mean_bias_sigma"], n),
                fmt_rate(rs["fails"]["mean_bias_rel"], n), fmt_rate(rs["fails"]["any"], n),
                fmt_rate(rs["old_abs_z_2"], n)))
    print("nonfinite (gate): %s" % ", ".join("%s k=%s %d/%d" % (s, k, rs["fails"]["nonfinite"], rs["trials"])
                                              for s, sr in results["scenes"].items() for k, rs in sr["sizes"].items()))
    print("seed_tails (informational, not a gate): %s" % ", ".join(
        "%s k=%s %d/%d" % (s, k, rs["fails"]["seed_tails"], rs["trials"])
        for s, sr in results["scenes"].items() for k, rs in sr["sizes"].items()))
    print()
    print("Resampled null distributions (overlapping splits, point estimates only)")
    print("%-22s %4s %6s %8s %8s %8s %8s %8s %8s %8s %10s %10s %7s %7s" % (
        "scene", "k", "n", "z new", "z old", "p<1%", "sd(z)", "q99|z|", "crit", "welch", "px p<1e-3", "noisy px",
        "df", "rel sd"))
    for scene, sres in results["scenes"].items():
        for k, rs in sres["sizes"].items():
            r = rs.get("resampled")
            if not r:
                continue
            print("%-22s %4s %6d %7.2f%% %7.2f%% %7.2f%% %8.2f %8.2f %8.2f %7.2f%% %9.3f%% %9.3f%% %7.1f %6.2f%%" % (
                scene, k, r["n"], 100 * r["mean_new"], 100 * r["mean_old"], 100 * r["mean_p_below_1pct"], r["z_sd"],
                r["z_q99"], r["median_crit"], 100 * r["welch"], 100 * r["pixels_below_1e3"],
                100 * r["noisy_pixels_below_1e3"], r["median_df"], 100 * r["rel_sigma_median"]))
    print()
    print("Image-mean gate on resampled per-seed image means (overlapping splits, point estimates only)")
    for scene, sres in results["scenes"].items():
        for k, rs in sres["sizes"].items():
            r = rs.get("mean_resampled")
            if r:
                print("%-22s %4s %7d splits: t critical %.2f %%, old |z| > 2 %.2f %%" % (
                    scene, k, r["n"], 100 * r["new"], 100 * r["old"]))
    print()
    tot_cpu = sum(v["cpu_seconds"] for v in ledger.values())
    tot_wall = sum(v["wall_seconds"] for v in ledger.values())
    n_r = sum(len(v["render_wall_seconds"]) for v in ledger.values())
    print("Compute: renders %d (ledger, all runs): %.0f s wall, %.0f s CPU; this analysis %.0f s wall, %.0f s CPU"
          % (n_r, tot_wall, tot_cpu, results["analysis_wall_seconds"], results["analysis_cpu_seconds"]))
    print("results: %s" % (args.out / "results.json"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
