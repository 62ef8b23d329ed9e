#!/usr/bin/env python3
"""Plots the BSDF-level check: Cycles' pixels across the strand (dots) against
hairbsdf's eval (lines) for a few cases, and the per-pixel relative error of all cases.
Reads the cached renders of blender_tests/test_bsdf_check.py.

    .venv/bin/python scripts/plot_bsdf_check.py [--out docs/images/bsdf_check.png]
"""

import argparse
import glob
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "blender_tests" / "bsdf_check"))

import hairbsdf  # noqa: E402
import bsdf_compare  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(REPO / "docs" / "images" / "bsdf_check.png"))
    parser.add_argument("--cases", default="color_blond_coat_to+0_ti-20_dp+171,absorption_clear_to-40_ti+50_dp-115,"
                        "melanin_dark_ior17_to+30_ti-20_dp+140,color_blond_coat_to-40_ti+25_dp-115")
    args = parser.parse_args()
    files = sorted(glob.glob(str(REPO / "build/blender_tests/bsdf_check/bpy-4.5*-full-*.npz")))
    if not files:
        sys.exit("no cached renders: run `.venv/bin/python -m pytest blender_tests/test_bsdf_check.py` first")
    data = np.load(files[-1], allow_pickle=True)
    meta = json.loads(str(data["meta"]))
    evaluate = bsdf_compare.hairbsdf_evaluator(hairbsdf)
    names = {c["name"]: i for i, c in enumerate(meta["cases"])}
    wanted = [names[n] for n in args.cases.split(",") if n in names]

    fig, axes = plt.subplots(1, len(wanted) + 1, figsize=(4.2 * (len(wanted) + 1), 3.6))
    colors = ("#d62728", "#2ca02c", "#1f77b4")
    for ax, index in zip(axes, wanted):
        case = meta["cases"][index]
        sel = data["case"] == index
        h = data["h"][sel]
        order = np.argsort(h)
        ours = evaluate(case["params"], data["wo"][sel], data["wi"][sel], h, "4.2")
        for c in range(3):
            ax.plot(h[order], ours[order, c], color=colors[c], lw=1.2)
            ax.plot(h[order][::12], data["rgb"][sel][order, c][::12], "o", ms=3, color=colors[c], mfc="none")
        ax.set_title(case["name"].replace("_to", "\nθo ").replace("_ti", " θi ").replace("_dp", " Δφ "), fontsize=8)
        ax.set_xlabel("h")
    axes[0].set_ylabel("pixel / sun strength")
    errors = []
    for index, case in enumerate(meta["cases"]):
        sel = data["case"] == index
        ours = evaluate(case["params"], data["wo"][sel], data["wi"][sel], data["h"][sel], "4.2")
        cycles = data["rgb"][sel]
        floor = 1e-3 * np.abs(cycles).max(axis=0)
        errors.append((np.abs(ours - cycles) / np.maximum(np.abs(cycles), floor)).ravel())
    errors = np.concatenate(errors)
    ax = axes[-1]
    ax.hist(np.log10(np.maximum(errors, 1e-9)), bins=80, color="0.4")
    ax.axvline(-4, color="k", ls="--", lw=0.8)
    ax.set_xlabel("log10 relative error per pixel")
    ax.set_title(f"{len(meta['cases'])} cases, {errors.size:,} pixel channels\nmedian {np.median(errors):.1e}, "
                 f"p99 {np.percentile(errors, 99):.1e}", fontsize=8)
    fig.suptitle("hairbsdf eval (lines) vs Cycles 4.5 pixels (circles), one strand lit by a sun", fontsize=10)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
