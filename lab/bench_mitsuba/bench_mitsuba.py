"""hairbsdf's batch kernels against Mitsuba 3's `hair` BSDF on the same rows, in one run (issue 27).

Run with a Python that has both `hairbsdf` and `mitsuba==3.9.1` (see README.md); Mitsuba is a
benchmark-only dependency. First checks that both compute the same eval and pdf on shared rows,
then times eval, pdf and sample for both (NumPy in and out; for Mitsuba also on Dr.Jit arrays).

Frame mapping (found and checked here): our fibre frame has the tangent along x and the view
direction `wo` (towards the camera) with offset h given per row; Mitsuba's hair frame has the tangent
along y, takes si.wi as the direction towards the camera and derives h from it, h_mitsuba =
sin(gamma(si.wi)) with the normal along z. A row maps by x -> y (tangent), the cross-section reflected
(our y -> -x) and rotated about the tangent so that Mitsuba's h equals -h (the reflection flips the
sign of h); wi maps by the same transform to Mitsuba's `wo`.
"""

import argparse
import os
import time

import numpy as np

os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

try:
    import hairbsdf  # noqa: E402
except ImportError:  # Mitsuba's venv: take hairbsdf from the repository's .venv (scripts/setup)
    import site
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    site.addsitedir(str(root / ".venv" / "lib" / f"python{sys.version_info[0]}.{sys.version_info[1]}" / "site-packages"))
    import hairbsdf  # noqa: E402

mi.set_variant("llvm_ad_rgb")


def to_mitsuba(v, wo, h):
    """Rows v (N, 3) of our fibre frame in Mitsuba's hair frame, for view directions wo and offsets h."""
    m_h = -h
    target = np.arctan2(np.sqrt(1 - m_h * m_h), -m_h)  # the angle of wo's cross-section part in Mitsuba's (x, z)
    angle = target - np.arctan2(wo[:, 2], -wo[:, 1])
    c, s = np.cos(angle), np.sin(angle)
    y, z = -v[:, 1], v[:, 2]
    return np.stack([c * y - s * z, v[:, 0], s * y + c * z], 1)


def rows(n, seed):
    rng = np.random.default_rng(seed)
    wo = rng.normal(size=(n, 3))
    wi = rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    return wo, wi, rng.uniform(-1, 1, n), rng.random((n, 3))


def closures(accuracy):
    """Principled Hair with Blender's defaults except the tilt (0: Mitsuba tilts the scales by its own
    convention) and the same closure in Mitsuba, with our absorption coefficient."""
    ours = hairbsdf.principled_hair(offset=0.0, accuracy=accuracy)
    p = ours.model_params[0]
    sigma = np.array(p["sigma_a"])
    scale = float(sigma.max())
    theirs = mi.load_dict({"type": "hair", "sigma_a": {"type": "rgb", "value": list(sigma / scale)}, "scale": scale,
                           "longitudinal_roughness": 0.3, "azimuthal_roughness": 0.3, "scale_tilt": 0.0,
                           "int_ior": p["eta"], "ext_ior": 1.0})
    return ours, theirs


def mi_rows(wo, wi, h):
    si = dr.zeros(mi.SurfaceInteraction3f, len(h))
    si.wi = mi.Vector3f(*to_mitsuba(wo, wo, h).astype(np.float32).T)
    return si, mi.Vector3f(*to_mitsuba(wi, wo, h).astype(np.float32).T)


def check(n=65536):
    """Both libraries on the same rows: the relative difference of eval (all channels) and pdf."""
    wo, wi, h, _ = rows(n, 1)
    h = np.clip(h, -0.999, 0.999)
    ctx = mi.BSDFContext()
    print("| accuracy | eval: median, 99th pct, max rel. diff | pdf: median, 99th pct, max |")
    print("|---|---|---|")
    for accuracy in ("exact", "cycles"):
        ours, theirs = closures(accuracy)
        si, m_wo = mi_rows(wo, wi, h)
        value = np.array(theirs.eval(ctx, si, m_wo)).reshape(3, -1).T
        pdf = np.array(theirs.pdf(ctx, si, m_wo))
        ref, ref_pdf = ours.eval(wo, wi, h), ours.pdf(wo, wi, h)
        floor = 1e-4 * np.abs(ref).max()
        d = np.abs(value - ref) / np.maximum(np.abs(ref), floor)
        dp = np.abs(pdf - ref_pdf) / np.maximum(ref_pdf, 1e-4 * ref_pdf.max())
        print(f"| {accuracy} | {np.median(d):.1e}, {np.percentile(d, 99):.1e}, {d.max():.1e} | "
              f"{np.median(dp):.1e}, {np.percentile(dp, 99):.1e}, {dp.max():.1e} |")


def best(fn, repeats):
    """Best wall-clock and best CPU time (all of this process's threads) of `repeats` calls."""
    fn()  # warm-up (Dr.Jit compiles its kernel on the first call)
    wall = cpu = 1e30
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall, cpu = min(wall, time.perf_counter() - t0), min(cpu, time.process_time() - c0)
    return wall, cpu


def timing(n, threads, repeats):
    wo, wi, h, u = rows(n, 2)
    wo32, wi32, h32, u32 = (a.astype(np.float32) for a in (wo, wi, h, u))
    # Mitsuba's rows, prepared in its frame once (the frame change is not timed).
    m_wi, m_wo = to_mitsuba(wo, wo, h).astype(np.float32), to_mitsuba(wi, wo, h).astype(np.float32)
    ours, theirs = closures("cycles")
    hairbsdf.set_num_threads(threads)
    dr.set_thread_count(threads)
    ctx = mi.BSDFContext()

    def mi_numpy(op):
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        si.wi = mi.Vector3f(m_wi[:, 0], m_wi[:, 1], m_wi[:, 2])
        if op == "sample":
            bs, w = theirs.sample(ctx, si, mi.Float(u32[:, 0]), mi.Point2f(u32[:, 1], u32[:, 2]))
            return bs.wo.numpy(), w.numpy(), bs.pdf.numpy()
        d = mi.Vector3f(m_wo[:, 0], m_wo[:, 1], m_wo[:, 2])
        return (theirs.eval(ctx, si, d) if op == "eval" else theirs.pdf(ctx, si, d)).numpy()

    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(m_wi[:, 0], m_wi[:, 1], m_wi[:, 2])
    d = mi.Vector3f(m_wo[:, 0], m_wo[:, 1], m_wo[:, 2])
    s1, s2 = mi.Float(u32[:, 0]), mi.Point2f(u32[:, 1], u32[:, 2])
    dr.eval(si, d, s1, s2)

    def mi_drjit(op):
        if op == "sample":
            bs, w = theirs.sample(ctx, si, s1, s2)
            dr.eval(bs.wo, bs.pdf, w)
        elif op == "eval":
            dr.eval(theirs.eval(ctx, si, d))
        else:
            dr.eval(theirs.pdf(ctx, si, d))
        dr.sync_thread()  # the LLVM back end runs its kernels asynchronously

    ours_calls = {"eval": lambda: ours.eval(wo32, wi32, h32), "pdf": lambda: ours.pdf(wo32, wi32, h32),
                  "sample": lambda: ours.sample(wo32, h32, u32)}
    # On a shared machine the wall clock counts other jobs; rows per CPU-second of this process do not.
    print(f"| {threads} thread(s): M rows/s (M rows per CPU-second) | hairbsdf, NumPy f32 | Mitsuba, NumPy f32 | "
          "Mitsuba, Dr.Jit arrays |")
    print("|---|---|---|---|")
    for op in ("eval", "pdf", "sample"):
        times = [best(ours_calls[op], repeats), best(lambda: mi_numpy(op), repeats),
                 best(lambda: mi_drjit(op), repeats)]
        print(f"| {op} | " + " | ".join(f"{n / w / 1e6:.1f} ({n / c / 1e6:.1f})" for w, c in times) + " |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=2_000_000, help="rows per call (default 2e6)")
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(f"mitsuba {mi.__version__}, variant {mi.variant()}; hairbsdf kernels: {hairbsdf.get_batch_kernel()}")
    print()
    check()
    for threads in args.threads:
        print()
        timing(args.n, threads, args.repeats)
    print()
    print(f"load average {os.getloadavg()}; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")


if __name__ == "__main__":
    main()
