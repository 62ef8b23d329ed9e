"""Rates of the scalar batch calls (float64 rows: ClosureSum eval / pdf / sample through the core's thread pool
and point cache, bsdf_core/include/hairbsdf/batch/batch_rows.h) and of the float32 kernel eval, in M rows per
CPU-second on 1 thread, best of 5. Run it with two builds' Pythons in turn to compare them as ratios
(docs/benchmarks.md, "The batch loops in the core").

    .venv/bin/python lab/bench_batch_rows.py [N]
"""
import sys
import time

import numpy as np

import hairbsdf


def rate(fn, n, repeats=5):
    best = 1e30
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return n / best / 1e6


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 300_000
    rng = np.random.default_rng(0)
    wo, wi = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    h, u = rng.uniform(-1, 1, n), rng.random((n, 3))
    hair = hairbsdf.principled_hair(parametrization="melanin", melanin=0.5)
    core = hair._core  # the C++ batch call, without the Python argument checks
    hairbsdf.set_num_threads(1)
    f32 = [a.astype(np.float32) for a in (wo, wi, h)]
    rates = {"eval": rate(lambda: core.eval(wo, wi, h), n), "pdf": rate(lambda: core.pdf(wo, wi, h), n),
             "sample": rate(lambda: core.sample(wo, h, u), n), "kernel_eval": rate(lambda: hair.eval(*f32), n)}
    print(" ".join(f"{k}={v:.3f}" for k, v in rates.items()))


if __name__ == "__main__":
    main()
