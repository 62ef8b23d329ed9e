"""Batch throughput of the NumPy API (evals/s, samples/s) with 1 and 2 threads.
Called by scripts/bench; prints a Markdown table."""

import argparse
import time

import numpy as np

import hairbsdf


def rate(fn, n, repeats=3):
    best = 1e30
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return n / best


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("-n", type=int, default=2_000_000, help="batch size")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    n = args.n
    wo, wi = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    h, u = rng.uniform(-1, 1, n), rng.random((n, 3))
    hair = hairbsdf.principled_hair(parametrization="melanin", melanin=0.5)
    core = hair._core  # the C++ batch call, without the Python argument checks
    print("| threads | eval M/s (API) | eval M/s (C++ batch) | sample M/s | pdf M/s |")
    print("|---|---|---|---|---|")
    for threads in (1, 2):
        hairbsdf.set_num_threads(threads)
        api = rate(lambda: hair.eval(wo, wi, h), n) / 1e6
        batch = rate(lambda: core.eval(wo, wi, h), n) / 1e6
        sample = rate(lambda: core.sample(wo, h, u), n) / 1e6
        pdf = rate(lambda: core.pdf(wo, wi, h), n) / 1e6
        print(f"| {threads} | {api:.2f} | {batch:.2f} | {sample:.2f} | {pdf:.2f} |")


if __name__ == "__main__":
    main()
