"""Batch throughput of the NumPy API (evals/s, samples/s) with 1 and 2 threads.
Called by scripts/bench; prints a Markdown table."""

import argparse
import time

import numpy as np

import hairbsdf


def rate(fn, n, repeats=3, clock=time.perf_counter):
    best = 1e30
    for _ in range(repeats):
        t0 = clock()
        fn()
        best = min(best, clock() - t0)
    return n / best


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("-n", type=int, default=2_000_000, help="batch size")
    parser.add_argument("--per-row-only", action="store_true", help="only the per-row inputs' table")
    parser.add_argument("--cpu-rows-only", action="store_true",
                        help="only one line: 1 thread, M rows per CPU-second, best of 5, of the float64 batch calls "
                             "and the float32 kernel eval (to compare two builds as ratios)")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    n = args.n
    if args.per_row_only:
        wo, wi = (rng.normal(size=(n, 3)).astype(np.float32) for _ in range(2))
        per_row(n, rng, wo, wi, rng.uniform(-1, 1, n).astype(np.float32), rng.random((n, 3)).astype(np.float32))
        return
    wo, wi = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    h, u = rng.uniform(-1, 1, n), rng.random((n, 3))
    hair = hairbsdf.principled_hair(parametrization="melanin", melanin=0.5)
    core = hair._core  # the C++ batch call, without the Python argument checks
    if args.cpu_rows_only:
        cpu_rows(n, hair, wo, wi, h, u)
        return
    print("| threads | eval M/s (API) | eval M/s (C++ batch) | sample M/s | pdf M/s |")
    print("|---|---|---|---|---|")
    for threads in (1, 2):
        hairbsdf.set_num_threads(threads)
        api = rate(lambda: hair.eval(wo, wi, h), n) / 1e6
        batch = rate(lambda: core.eval(wo, wi, h), n) / 1e6
        sample = rate(lambda: core.sample(wo, h, u), n) / 1e6
        pdf = rate(lambda: core.pdf(wo, wi, h), n) / 1e6
        print(f"| {threads} | {api:.2f} | {batch:.2f} | {sample:.2f} | {pdf:.2f} |")
    kernels(n, rng)


def cpu_rows(n, hair, wo, wi, h, u):
    """One line of M rows per CPU-second on 1 thread, best of 5: the float64 batch calls through the core's
    thread pool and point cache, and the float32 kernel eval on the same rows."""
    core = hair._core
    hairbsdf.set_num_threads(1)
    f32 = [a.astype(np.float32) for a in (wo, wi, h)]
    calls = {"eval": lambda: core.eval(wo, wi, h), "pdf": lambda: core.pdf(wo, wi, h),
             "sample": lambda: core.sample(wo, h, u), "kernel_eval": lambda: hair.eval(*f32)}
    print(" ".join(f"{name}={rate(fn, n, 5, time.process_time) / 1e6:.3f}" for name, fn in calls.items()))


def kernels(n, rng):
    """The float32 SIMD batch kernels of one Chiang closure with Blender's defaults (docs/simd.md),
    NumPy in and out through the public API; the scalar double path on the same float32 rows."""
    wo = rng.normal(size=(n, 3)).astype(np.float32)
    wi = rng.normal(size=(n, 3)).astype(np.float32)
    h = rng.uniform(-1, 1, n).astype(np.float32)
    u = rng.random((n, 3)).astype(np.float32)
    rows64 = (wo.astype(np.float64), wi.astype(np.float64), h.astype(np.float64))
    hair = hairbsdf.principled_hair()
    out = np.empty((n, 3), dtype=np.float32)
    print()
    print(f"Batch kernels ({hairbsdf.get_batch_kernel()}), Principled Hair defaults, N = {n}, M rows/s")
    print()
    print("| threads | eval f32 | eval f32 out= | pdf f32 | sample f32 | eval f64 converted | eval f32, scalar path |")
    print("|---|---|---|---|---|---|---|")
    for threads in (1, 2):
        hairbsdf.set_num_threads(threads)
        hairbsdf.set_batch_kernel("best")
        figures = [rate(lambda: hair.eval(wo, wi, h), n), rate(lambda: hair.eval(wo, wi, h, out=out), n),
                   rate(lambda: hair.pdf(wo, wi, h), n), rate(lambda: hair.sample(wo, h, u), n)]
        hairbsdf.set_batch_kernel("best", float64="float32")
        figures.append(rate(lambda: hair.eval(*rows64), n))
        hairbsdf.set_batch_kernel("scalar")
        figures.append(rate(lambda: hair.eval(wo, wi, h), n, repeats=1))
        hairbsdf.set_batch_kernel("best")
        print(f"| {threads} | " + " | ".join(f"{f / 1e6:.1f}" for f in figures) + " |")
    # On a shared machine the wall clock counts other jobs' time: rows per second of this process's
    # CPU time (all its threads) estimate the rate of one idle core.
    hairbsdf.set_num_threads(1)
    cpu = [rate(lambda: hair.eval(wo, wi, h), n, 5, time.process_time),
           rate(lambda: hair.eval(wo, wi, h, out=out), n, 5, time.process_time),
           rate(lambda: hair.pdf(wo, wi, h), n, 5, time.process_time),
           rate(lambda: hair.sample(wo, h, u), n, 5, time.process_time)]
    print()
    print("Per CPU-second, 1 thread (M rows): eval %.1f, eval out= %.1f, pdf %.1f, sample %.1f" %
          tuple(f / 1e6 for f in cpu))
    per_row(n, rng, wo, wi, h, u)


def per_row(n, rng, wo, wi, h, u):
    """The kernels with per-row node inputs (docs/simd.md): melanin hair whose roughness, radial
    roughness, coat, random and melanin vary per row (the per-row `prepare` runs on every row)."""
    hair = hairbsdf.principled_hair(parametrization="melanin", random_roughness=0.3, random_color=0.2)
    inputs = {"roughness": rng.uniform(0.1, 0.8, n).astype(np.float32),
              "radial_roughness": rng.uniform(0.1, 0.8, n).astype(np.float32),
              "coat": rng.uniform(0.0, 0.5, n).astype(np.float32),
              "random": rng.random(n).astype(np.float32),
              "melanin": rng.uniform(0.1, 0.9, n).astype(np.float32)}
    calls = {"eval": lambda: hair.eval(wo, wi, h, inputs=inputs),
             "pdf": lambda: hair.pdf(wo, wi, h, inputs=inputs),
             "sample": lambda: hair.sample(wo, h, u, inputs=inputs)}
    print()
    print(f"Per-row inputs ({', '.join(inputs)}), melanin, N = {n}, M rows/s, best of 3")
    print()
    print("| threads | eval f32 | pdf f32 | sample f32 |")
    print("|---|---|---|---|")
    for threads in (1, 2):
        hairbsdf.set_num_threads(threads)
        print(f"| {threads} | " + " | ".join(f"{rate(fn, n) / 1e6:.1f}" for fn in calls.values()) + " |")
    # Per CPU-second (see kernels()), and the same closure without inputs (the hoisted prepare) in the
    # same run, for the ratio.
    hairbsdf.set_num_threads(1)
    uniform = {"eval": lambda: hair.eval(wo, wi, h), "pdf": lambda: hair.pdf(wo, wi, h),
               "sample": lambda: hair.sample(wo, h, u)}
    cpu = [rate(fn, n, 5, time.process_time) / 1e6 for fn in calls.values()]
    cpu_uniform = [rate(fn, n, 5, time.process_time) / 1e6 for fn in uniform.values()]
    print()
    print("Per-row inputs, per CPU-second, 1 thread (M rows): eval %.1f, pdf %.1f, sample %.1f" % tuple(cpu))
    print("The same closure without inputs, per CPU-second, 1 thread (M rows): eval %.1f, pdf %.1f, sample %.1f"
          % tuple(cpu_uniform))


if __name__ == "__main__":
    main()
