"""Which lobe carries Huang's eval error on the worst rows of lab/huang_tolerance.py (docs/huang.md §11).

    .venv/bin/python lab/huang_lobe_errors.py [--rows 48] [--alphas 0.02] [--fields far] [--worst 8]
                                              [--tolerance T] [--tt-only]

Per alpha and field: the rows of huang_tolerance.py's generator (rows(), seed 7) with the largest error of
the total at the default tolerance (or --tolerance), against huang_tolerance.py's reference, and each lobe's
share of the reference and its error, both as fractions of the row's total (R, TT, TRT, TRRT+). With
--tt-only the reference is TT to 1e-5 with a cheap TRT (2048 points per node), and only TT's error is shown.
"""

import argparse

import numpy as np

import hairbsdf
from huang_tolerance import LUMINANCE, closure, field_keywords, rows


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--rows", type=int, default=48)
    p.add_argument("--alphas", default="0.02")
    p.add_argument("--fields", default="far")
    p.add_argument("--worst", type=int, default=8)
    p.add_argument("--tolerance", type=float, default=None)
    p.add_argument("--tt-only", action="store_true")
    a = p.parse_args()
    wo, wi, h = rows(a.rows)
    kw = {} if a.tolerance is None else dict(tolerance=a.tolerance)
    for alpha in (float(x) for x in a.alphas.split(",")):
        for field in a.fields.split(","):
            fk = field_keywords(field == "near", a.rows)
            points = 2048 if a.tt_only else (65536 if alpha >= 0.1 else 16384)  # huang_tolerance.py's reference
            hairbsdf.set_num_threads(2)
            ref = closure(alpha, trt_points=points, tolerance=1e-5, max_evaluations=2_000_000_000).eval_lobes(
                wo, wi, h, **fk) @ LUMINANCE
            hairbsdf.set_num_threads(1)
            val = closure(alpha).eval_lobes(wo, wi, h, **fk, **kw) @ LUMINANCE
            total = ref.sum(1)
            lobe_err = (val - ref) / total[:, None]
            err = np.abs(lobe_err[:, 1]) if a.tt_only else np.abs(val.sum(1) - total) / total
            print("alpha %.2f %s: error %s median %.2e p90 %.2e max %.2e" % (
                alpha, field, "of TT / total" if a.tt_only else "of the total", np.median(err),
                np.percentile(err, 90), err.max()))
            print("  row   error  | share of the total R / TT / TRT / TRRT+ | lobe error / total R / TT / TRT / TRRT+")
            for k in np.argsort(-err)[:a.worst]:
                print("  %3d  %.2e | %s | %s" % (k, err[k], " ".join("%.3f" % x for x in ref[k] / total[k]),
                                                 " ".join("%+.1e" % x for x in lobe_err[k])))


if __name__ == "__main__":
    main()
