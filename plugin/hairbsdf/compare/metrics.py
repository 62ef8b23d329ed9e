"""Image metrics for the comparison harness.  NumPy only, with OpenImageIO, SciPy and FLIP
used when importable, so every function runs on synthetic arrays in unit tests.

Images are float arrays (H, W, C), linear, row 0 at the top.  A *stack* is (n, H, W, C): n
independent renders (seeds) of one engine.

* ``error_stats``    mean / RMS / max of the absolute and relative error, PSNR
* ``idiff_rule``     OpenImageIO's idiff / ``oiiotool --fail --failpercent`` verdict
* ``flip``           NVIDIA FLIP (flip-evaluator), HDR mode on linear images, over a fixed
                     exposure range taken from the reference (``flip_exposures``)
* ``welch``          per-pixel Welch t-test between two stacks (or summary statistics, e.g.
                     variance passes) with a Sidak correction over all tested pixel-channels:
                     tells bias from Monte Carlo noise
* ``mean_bias``      bias of the image mean, with its standard error from the seeds
* ``gonio_errors``   per-pixel relative error on noise-free goniometer renders
* ``paired_effect``  size of a change rendered with the same seeds (exact vs Cycles accuracy)
"""

from __future__ import annotations

import math

import numpy as np

from .. import _core
from .._deps import require

WHAT = "hairbsdf compare"


def _stats():
    return require("scipy.stats", "compare", WHAT)


# --------------------------------------------------------------------------- images

def load_image(path) -> np.ndarray:
    """(H, W, C) float32 from any file OpenImageIO reads (EXR for the renders)."""
    oiio = require("OpenImageIO", "compare", WHAT)

    buf = oiio.ImageBuf(str(path))
    if buf.has_error:
        raise IOError("cannot read %s: %s" % (path, buf.geterror()))
    px = buf.get_pixels(oiio.FLOAT)
    if px is None or px.size == 0:
        raise IOError("cannot read %s: %s" % (path, buf.geterror()))
    px = np.asarray(px, dtype=np.float32)
    if px.ndim == 2:
        px = px[..., None]
    return px


def rgb(img):
    img = np.asarray(img)
    return img[..., :3] if img.shape[-1] >= 3 else np.repeat(img[..., :1], 3, axis=-1)


def luminance(img):
    """Rec.709 luminance of linear RGB, with C++ luminance()'s weights (_core.LUMINANCE_WEIGHTS)."""
    c = rgb(img).astype(np.float64)
    w = _core.LUMINANCE_WEIGHTS
    return w[0] * c[..., 0] + w[1] * c[..., 1] + w[2] * c[..., 2]


def srgb_oetf(x):
    """Blender's 'Standard' view transform (sRGB OETF), clamped to [0, 1]."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


# --------------------------------------------------------------------------- basic errors

def rel_floor(ref, frac=1e-3):
    """Per-channel denominator floor for relative errors: frac times the 99.9th percentile
    of |ref| in that channel (a robust peak), so dark pixels are judged on the image's scale."""
    r = np.abs(rgb(ref)).reshape(-1, 3).astype(np.float64)
    peak = np.percentile(r, 99.9, axis=0) if r.shape[0] else np.zeros(3)
    return np.maximum(frac * peak, 1e-12)


def error_stats(ref, test, floor_frac=1e-3):
    """Mean, RMS and max of |test - ref| and of the relative error |test - ref| / max(|ref|, floor),
    over the RGB channels, and PSNR = 20 log10(peak / RMS) with peak the largest value of the
    two images (OpenImageIO's ImageBufAlgo.compare convention)."""
    a = rgb(ref).astype(np.float64)
    b = rgb(test).astype(np.float64)
    if a.shape != b.shape:
        raise ValueError("image sizes differ: %s vs %s" % (a.shape, b.shape))
    d = np.abs(b - a)
    rel = d / np.maximum(np.abs(a), rel_floor(a, floor_frac))
    rms = float(np.sqrt(np.mean(d * d))) if d.size else 0.0
    return dict(mean_abs=float(d.mean()) if d.size else 0.0, rms_abs=rms, max_abs=float(d.max()) if d.size else 0.0,
                mean_rel=float(rel.mean()) if d.size else 0.0,
                rms_rel=float(np.sqrt(np.mean(rel * rel))) if d.size else 0.0,
                max_rel=float(rel.max()) if d.size else 0.0,
                psnr=float("inf") if rms == 0 else float(20.0 * math.log10(max(float(np.abs(a).max()),
                                                                              float(np.abs(b).max()), 1e-30) / rms)))


def oiio_compare(ref, test, failthresh, warnthresh=None):
    """OpenImageIO's ImageBufAlgo.compare on two arrays."""
    oiio = require("OpenImageIO", "compare", WHAT)
    a = np.ascontiguousarray(ref, dtype=np.float32)
    b = np.ascontiguousarray(test, dtype=np.float32)
    bufs = []
    for x in (a, b):
        spec = oiio.ImageSpec(x.shape[1], x.shape[0], x.shape[2], oiio.FLOAT)
        buf = oiio.ImageBuf(spec)
        buf.set_pixels(oiio.ROI(), x)
        bufs.append(buf)
    r = oiio.ImageBufAlgo.compare(bufs[0], bufs[1], float(failthresh),
                                  float(failthresh if warnthresh is None else warnthresh))
    return dict(meanerror=float(r.meanerror), rms_error=float(r.rms_error), PSNR=float(r.PSNR),
                maxerror=float(r.maxerror), maxx=int(r.maxx), maxy=int(r.maxy), maxc=int(r.maxc),
                nfail=int(r.nfail), nwarn=int(r.nwarn))


def idiff_rule(ref, test, failthresh=0.016, failpercent=1.0, hardfail=float("inf"), display=True):
    """idiff's verdict (OIIO src/idiff): a pixel fails when any channel differs by more than
    failthresh; the image fails when more than failpercent % of the pixels fail or the max
    error exceeds hardfail.  display=True compares the Standard-view (sRGB) images, which is
    what Blender's render tests compare (8-bit PNGs); False compares linear values."""
    a, b = rgb(ref).astype(np.float64), rgb(test).astype(np.float64)
    if display:
        a, b = srgb_oetf(a), srgb_oetf(b)
    npix = a.shape[0] * a.shape[1]
    res = oiio_compare(a, b, failthresh)
    nfail, maxerr, via = res["nfail"], res["maxerror"], "OpenImageIO ImageBufAlgo.compare"
    pct = 100.0 * nfail / max(npix, 1)
    ok = not (nfail > failpercent / 100.0 * npix or maxerr > hardfail)
    return dict(nfail=nfail, npix=npix, percent=pct, maxerror=maxerr, failthresh=failthresh,
                failpercent=failpercent, hardfail=hardfail, passed=ok, via=via, display=display)


FLIP_SPAN = 8  # stops below the reference's highlight that HDR-FLIP evaluates, one exposure per stop


def flip_exposures(ref, span=FLIP_SPAN):
    """(start, stop) exposures for HDR-FLIP, from the reference alone: start maps the reference's
    highlight (99.9th percentile of its luminance) to 0.85, stop is `span` stops brighter.  The same
    range serves the test image, and a fixed span makes scores compare across scenes: FLIP's own
    choice (start from the maximum, stop from the median of the frame) collapses to one exposure
    when a bright background fills half the frame, and then dark hair in front of it scores near 0."""
    lum = luminance(np.maximum(rgb(ref), 0.0))
    hi = float(np.percentile(lum, 99.9)) if lum.size else 0.0
    start = math.log2(0.85 / hi) if (math.isfinite(hi) and hi > 0) else 0.0
    return start, start + span


def flip(ref, test, exposures=None):
    """Mean HDR-FLIP of test against ref (linear images) and the error map; (None, None, reason)
    when flip-evaluator fails (MissingDependency when it is not installed).  exposures: (start,
    stop) in stops, default flip_exposures(ref); one exposure per stop between them."""
    flip_evaluator = require("flip_evaluator", "compare", WHAT)
    a = np.ascontiguousarray(np.maximum(rgb(ref), 0.0), dtype=np.float32)
    b = np.ascontiguousarray(np.maximum(rgb(test), 0.0), dtype=np.float32)
    start, stop = flip_exposures(ref) if exposures is None else exposures
    params = dict(startExposure=float(start), stopExposure=float(stop),
                  numExposures=max(2, int(round(stop - start)) + 1))
    try:
        err, mean, _params = flip_evaluator.evaluate(a, b, "HDR", inputsRGB=False, applyMagma=False,
                                                     computeMeanError=True, parameters=params)
    except SystemExit as exc:  # it calls sys.exit on bad arguments
        return None, None, "flip-evaluator exited (%s)" % exc
    except Exception as exc:  # pragma: no cover
        return None, None, "flip-evaluator failed: %s" % exc
    err = np.asarray(err, dtype=np.float32)
    if err.ndim == 3:
        err = err[..., 0]
    return float(mean), err, None


# --------------------------------------------------------------------------- statistics

def t_sf(t, df):
    """Upper tail P(T > t) of Student's t (normal where df is infinite)."""
    t = np.asarray(t, dtype=np.float64)
    df = np.broadcast_to(np.asarray(df, dtype=np.float64), t.shape)
    out = np.empty_like(t)
    inf = ~np.isfinite(df)
    stats = _stats()
    if np.any(~inf):
        out[~inf] = stats.t.sf(t[~inf], df[~inf])
    out[inf] = stats.norm.sf(t[inf])
    return out


def t_isf(p, df):
    """Critical value t with P(T > t) = p."""
    stats = _stats()
    return float(stats.t.isf(p, df) if np.isfinite(df) else stats.norm.isf(p))


def sidak(alpha, m):
    """Per-test level giving family-wise level alpha over m independent tests."""
    return float(-np.expm1(np.log1p(-alpha) / max(int(m), 1)))


def stack_stats(stack):
    """(mean, variance with ddof=1, n) over axis 0 of an (n, H, W, C) stack."""
    s = np.asarray(stack, dtype=np.float64)
    n = s.shape[0]
    mean = s.mean(axis=0)
    var = s.var(axis=0, ddof=1) if n > 1 else np.zeros_like(mean)
    return mean, var, n


# Below this many seeds on either side, a pixel-channel whose renders are all identical on one side
# only (zero sample variance there, not on the other side) is not tested by the per-pixel Welch test
# ("unresolved"; docs/statistics.md).  Strand-edge pixels are bimodal across seeds (exact background,
# or a grazed strand); with few seeds one side can land entirely on the background and the other
# entirely on the strand, and then neither variance sees the gap between the modes.
WELCH_CONSTANT_SIDE_SEEDS = 8


def welch_from_stats(mean_a, var_a, n_a, mean_b, var_b, n_b, alpha=0.01, floor_abs=1e-6, floor_rel=1e-4,
                     mask=None, constant_side_seeds=WELCH_CONSTANT_SIDE_SEEDS):
    """Per-pixel, per-channel Welch t-test of E[b] = E[a] from means and variances of the
    per-render estimates (n renders each; variance passes give the same numbers).

    The standard error gets a floor (floor_abs + floor_rel |mean_a|), so pixels without noise
    (an empty background, a constant world) are not failed for float rounding.  The p-values
    use the Welch-Satterthwaite degrees of freedom; a pixel-channel fails when p < the Sidak
    level for a family-wise alpha over all m tested pixel-channels.  Under the null hypothesis
    the whole image fails with probability about alpha; a bias fails it when it stands out of
    the per-pixel noise.

    With fewer than `constant_side_seeds` renders on either side, pixel-channels with zero
    variance on exactly one side are unresolved: not tested, not counted in m, counted in
    n_unresolved (their zero variance does not bound that side's noise; docs/statistics.md)."""
    ma, va = np.asarray(mean_a, np.float64), np.asarray(var_a, np.float64)
    mb, vb = np.asarray(mean_b, np.float64), np.asarray(var_b, np.float64)
    if n_a < 2 or n_b < 2:
        raise ValueError("the Welch test needs at least 2 renders per engine (got %d and %d)" % (n_a, n_b))
    ea, eb = va / n_a, vb / n_b
    floor = (floor_abs + floor_rel * np.abs(ma)) ** 2
    se2 = ea + eb + floor
    t = (mb - ma) / np.sqrt(se2)
    # Degrees of freedom: the estimated part ea + eb counts with min(n_a, n_b) - 1 (Hsu's conservative
    # choice) and the floor as known (Satterthwaite for their sum), so noise-free pixels keep df = inf.
    # The Welch-Satterthwaite estimate used before is too large at the Sidak level (about 3e-7 per
    # test) when a 4-sample variance comes out small: Cycles against Cycles failed 1.2-2.5 % of
    # cases at 4 seeds per side instead of 1 % (docs/statistics.md).
    est = ea + eb
    nu0 = min(n_a, n_b) - 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        df = np.where(est > 0, nu0 * se2 * se2 / np.where(est > 0, est * est, 1.0), np.inf)
    if mask is None:
        sel = np.ones(t.shape, dtype=bool)
    else:
        sel = np.broadcast_to(np.asarray(mask, bool)[..., None] if np.ndim(mask) == t.ndim - 1 else mask, t.shape)
    unresolved = np.zeros(t.shape, dtype=bool)
    if min(n_a, n_b) < constant_side_seeds:
        unresolved = sel & ((va == 0) != (vb == 0))
        sel = sel & ~unresolved
    n_unresolved = int(np.count_nonzero(unresolved))
    m = int(np.count_nonzero(sel))
    p = np.ones_like(t)
    p[sel] = np.minimum(1.0, 2.0 * t_sf(np.abs(t[sel]), df[sel]))
    level = sidak(alpha, m)
    fail = (p < level) & sel
    n_fail = int(np.count_nonzero(fail))
    # map: signed t of the channel with the largest |t| per pixel; fail mask per pixel
    idx = np.argmax(np.abs(t), axis=-1)
    tmap = np.take_along_axis(t, idx[..., None], axis=-1)[..., 0]
    min_p = float(p[sel].min()) if m else 1.0
    df_sel = df[sel]
    df_fin = df_sel[np.isfinite(df_sel)]  # pixels with noise (noise-free ones have df = inf)
    med_df = float(np.median(df_fin)) if df_fin.size else float("inf")
    return dict(n_fail=n_fail, m=m, alpha=alpha, level=level, min_p=min_p, n_unresolved=n_unresolved,
                constant_side_seeds=int(constant_side_seeds),
                max_abs_t=float(np.abs(t[sel]).max()) if m else 0.0,
                fail_fraction=n_fail / max(m, 1), n_a=int(n_a), n_b=int(n_b), median_df=med_df,
                t_critical_median_df=t_isf(level / 2.0, med_df) if m else float("inf"),
                passed=n_fail == 0, t_map=tmap, fail_map=fail.any(axis=-1), p=p)


def welch(stack_a, stack_b, alpha=0.01, floor_abs=1e-6, floor_rel=1e-4, mask=None,
          constant_side_seeds=WELCH_CONSTANT_SIDE_SEEDS):
    """welch_from_stats on two stacks (n, H, W, C); only RGB is tested."""
    ma, va, na = stack_stats(rgb(stack_a))
    mb, vb, nb = stack_stats(rgb(stack_b))
    return welch_from_stats(ma, va, na, mb, vb, nb, alpha=alpha, floor_abs=floor_abs, floor_rel=floor_rel, mask=mask,
                            constant_side_seeds=constant_side_seeds)


def _image_means(stack, mask=None):
    """(n, 3) mean RGB of each render (over the mask's pixels)."""
    s = rgb(np.asarray(stack, dtype=np.float64))
    if mask is None:
        return s.reshape(s.shape[0], -1, 3).mean(axis=1)
    m = np.asarray(mask, bool)
    return s[:, m, :].mean(axis=1)


def welch_df(ea, eb, n_a, n_b, floor2=0.0):
    """Welch-Satterthwaite degrees of freedom of ea + eb + floor2, where ea = var_a / n_a and
    eb = var_b / n_b are estimated from n_a and n_b renders and floor2 is known exactly;
    infinite when nothing is estimated, never below min(n_a, n_b) - 1."""
    se2 = ea + eb + floor2
    denom = (ea * ea / (n_a - 1) if n_a > 1 else 0.0) + (eb * eb / (n_b - 1) if n_b > 1 else 0.0)
    if denom <= 0:
        return float("inf")
    return float(max(se2 * se2 / denom, min(n_a, n_b) - 1.0))


def mean_bias_critical(df, alpha=0.01):
    """Critical |z| of the image-mean test: the two-sided Student-t quantile t(1 - alpha/2, df)
    (z = bias / sigma with sigma from the seeds is t-like with the Welch df, not normal), so an
    unbiased engine fails with probability alpha per case.  The fixed 2 of earlier versions was
    a 4.6 % test for normal z and a 9 % one at 4 seeds per side (docs/statistics.md)."""
    return t_isf(alpha / 2.0, df)


def mean_bias(stack_a, stack_b, mask=None, floor_rel=0.0):
    """Bias of the image mean of b against a, estimated over the renders (seeds).

    Per render, the image mean over RGB (and per channel); bias = mean_b - mean_a,
    sigma = sqrt(var_a / n_a + var_b / n_b + (floor_rel * mean_a)^2) from the spread between
    renders (the floor, as in the Welch test, keeps nearly noise-free images from failing on
    float32 rounding), rel = bias / mean_a, z = bias / sigma, df its Welch-Satterthwaite
    degrees of freedom (welch_df).  Returned for the all-channel mean and per channel."""
    A, B = _image_means(stack_a, mask), _image_means(stack_b, mask)
    na, nb = A.shape[0], B.shape[0]

    def one(a, b):
        ma, mb = float(a.mean()), float(b.mean())
        va = float(a.var(ddof=1)) if na > 1 else 0.0
        vb = float(b.var(ddof=1)) if nb > 1 else 0.0
        sigma = math.sqrt(va / na + vb / nb + (floor_rel * ma) ** 2)
        bias = mb - ma
        return dict(mean_a=ma, mean_b=mb, bias=bias, sigma=sigma,
                    rel=bias / ma if ma != 0 else (0.0 if bias == 0 else float("inf")),
                    rel_sigma=sigma / abs(ma) if ma != 0 else float("inf"),
                    z=bias / sigma if sigma > 0 else (0.0 if bias == 0 else float("inf")),
                    df=welch_df(va / na, vb / nb, na, nb, (floor_rel * ma) ** 2))

    out = one(A.mean(axis=1), B.mean(axis=1))
    out["channels"] = [one(A[:, c], B[:, c]) for c in range(3)]
    out["n_a"], out["n_b"] = int(na), int(nb)
    return out


def seed_spread(stack, mask=None):
    """How the renders' (seeds') image means scatter: each render's mean over RGB relative to the
    mean of all, their coefficient of variation, and the largest leave-one-out deviation
    max_i |x_i - mean(others)| / sd(others), with its critical value for normally scattered means
    (the deviation times sqrt((n - 1) / n) is Student-t with n - 2 degrees of freedom; two-sided,
    Bonferroni over the n seeds at family-wise 1 %) and their ratio `outlier_ratio` (> 1: a seed
    too far out for a normal spread). A heavy-tailed estimator (rare very bright paths) shows as
    one seed far from the others; then few-seed z and Welch tests mislead, because the spread of
    the seeds underestimates the noise most of the time. Needs >= 3 renders."""
    x = _image_means(stack, mask).mean(axis=1)
    n = int(x.shape[0])
    m = float(x.mean())
    out = dict(n=n, rel_means=[float(v / m) if m else float("nan") for v in x],
               cv=float(x.std(ddof=1) / abs(m)) if n > 1 and m else float("nan"), max_dev_sigma=float("nan"),
               outlier_limit=float("nan"), outlier_ratio=float("nan"))
    if n >= 3:
        devs = []
        for i in range(n):
            others = np.delete(x, i)
            sd = float(others.std(ddof=1))
            dev = abs(float(x[i]) - float(others.mean()))
            devs.append(dev / sd if sd > 0 else (0.0 if dev == 0 else float("inf")))
        out["max_dev_sigma"] = float(max(devs))
        out["outlier_limit"] = t_isf(0.01 / (2 * n), n - 2) * math.sqrt(n / (n - 1))
        out["outlier_ratio"] = out["max_dev_sigma"] / out["outlier_limit"]
    return out


class Summary:
    """Per-pixel mean and variance (ddof=1, of one render's value across the renders) of n
    renders, for inputs that come as a mean and a variance image instead of a stack."""

    def __init__(self, mean, var, n):
        self.mean = np.asarray(mean, np.float32)
        self.var = np.asarray(var, np.float32)
        self.n = int(n)


def mean_bias_from_stats(a, b, floor_rel=0.0):
    """mean_bias from two Summary objects.  The variance of one render's image mean is taken as
    sum(var) / P^2 over the P pixels, i.e. pixels with independent noise (per-pixel scrambled
    samplers); within a pixel the channels count as fully correlated (an upper bound).  The
    degrees of freedom are those of per-seed inputs (welch_df with n_a, n_b renders), which is
    conservative: a variance summed over many independent pixels is known better than that."""

    def side(s, c=None):
        m, v = rgb(s.mean).astype(np.float64), rgb(s.var).astype(np.float64)
        P = m.shape[0] * m.shape[1]
        if c is None:
            mean = float(m.mean())
            var_img = float((np.sqrt(np.maximum(v, 0)).mean(axis=-1) ** 2).sum()) / P ** 2
        else:
            mean = float(m[..., c].mean())
            var_img = float(np.maximum(v[..., c], 0).sum()) / P ** 2
        return mean, var_img

    def one(c=None):
        ma, va = side(a, c)
        mb, vb = side(b, c)
        sigma = math.sqrt(va / a.n + vb / b.n + (floor_rel * ma) ** 2)
        bias = mb - ma
        return dict(mean_a=ma, mean_b=mb, bias=bias, sigma=sigma,
                    rel=bias / ma if ma != 0 else (0.0 if bias == 0 else float("inf")),
                    rel_sigma=sigma / abs(ma) if ma != 0 else float("inf"),
                    z=bias / sigma if sigma > 0 else (0.0 if bias == 0 else float("inf")),
                    df=welch_df(va / a.n, vb / b.n, a.n, b.n, (floor_rel * ma) ** 2))

    out = one()
    out["channels"] = [one(c) for c in range(3)]
    out["n_a"], out["n_b"] = a.n, b.n
    return out


def nonfinite(img, first=10):
    """(count, [(x, y, channel, value)...] of the first `first`) of the NaN and Inf values of
    an (H, W, C) image; row 0 at the top."""
    bad = ~np.isfinite(np.asarray(img))
    ys, xs, cs = np.nonzero(bad)
    where = [(int(x), int(y), int(c), str(float(img[y, x, c]))) for y, x, c in zip(ys[:first], xs[:first], cs[:first])]
    return int(bad.sum()), where


def paired_effect(stack_base, stack_variant, mask=None):
    """Relative change of the image mean from base to variant, both rendered with the same
    seeds (so most of the noise cancels): rel = mean(variant - base) / mean(base), with the
    standard error of the paired differences (None with one pair)."""
    A, B = _image_means(stack_base, mask).mean(axis=1), _image_means(stack_variant, mask).mean(axis=1)
    n = min(A.size, B.size)
    A, B = A[:n], B[:n]
    d = B - A
    base = float(A.mean())
    rel = float(d.mean()) / base if base else 0.0
    sig = float(d.std(ddof=1) / math.sqrt(n)) / abs(base) if n > 1 and base else None
    return dict(n=int(n), rel=rel, rel_sigma=sig, mean_base=base, mean_variant=float(B.mean()))


# --------------------------------------------------------------------------- goniometer

def _erode(mask, r):
    m = mask.copy()
    for _ in range(int(r)):
        p = np.pad(m, 1, constant_values=False)
        m = (p[1:-1, 1:-1] & p[:-2, 1:-1] & p[2:, 1:-1] & p[1:-1, :-2] & p[1:-1, 2:]
             & p[:-2, :-2] & p[:-2, 2:] & p[2:, :-2] & p[2:, 2:])
    return m


def _components(mask):
    """Connected components (8-neighbour) of a boolean mask: (labels, count)."""
    ndimage = require("scipy.ndimage", "compare", WHAT)
    lab, n = ndimage.label(mask, structure=np.ones((3, 3), int))
    return lab, int(n)


def gonio_roi(shape, roi):
    """Boolean (H, W) mask of the pixels to compare in an orthographic goniometer render:
    roi = {image_width (world units across the image, centred on the origin), end_margin_px,
    strands: [{centre [x, y], axis [ux, uy] (unit, projected), half_length, radius}]}; a
    pixel is kept when its centre lies within some strand's radius of its axis and within
    half_length - end_margin_px of its centre along it."""
    h, w = shape[:2]
    px = roi["image_width"] / float(w)
    xs = (np.arange(w) + 0.5) * px - roi["image_width"] / 2.0
    ys = h * px / 2.0 - (np.arange(h) + 0.5) * px  # row 0 at the top
    X, Y = np.meshgrid(xs, ys)
    keep = np.zeros((h, w), bool)
    margin = roi.get("end_margin_px", 2) * px
    for s in roi["strands"]:
        dx, dy = X - s["centre"][0], Y - s["centre"][1]
        a = dx * s["axis"][0] + dy * s["axis"][1]
        b = -dx * s["axis"][1] + dy * s["axis"][0]
        keep |= (np.abs(a) <= s["half_length"] - margin) & (np.abs(b) <= s["radius"])
    return keep


def gonio_errors(ref, test, erode=2, floor_frac=1e-3, alpha_threshold=0.9999, roi=None):
    """Per-pixel relative error of a noise-free goniometer render (bsdf_check/README.md's
    metric, per strand): pixels fully covered in both images (alpha), eroded by `erode` pixels
    to drop the silhouettes, grouped into strands (connected components); in each strand and
    channel rel = |test - ref| / max(|ref|, floor_frac * strand peak).  Returns median, p99,
    max over all kept pixel-channels, the pixel counts and a per-pixel map (max over RGB)."""
    a, b = np.asarray(ref, np.float64), np.asarray(test, np.float64)
    if a.shape[-1] >= 4 and b.shape[-1] >= 4:
        cov_a, cov_b = a[..., 3] >= alpha_threshold, b[..., 3] >= alpha_threshold
    else:
        cov_a = cov_b = np.ones(a.shape[:2], bool)
    cover = _erode(cov_a & cov_b, erode)
    if roi is not None:
        cover &= np.asarray(roi, bool)
    lab, n = _components(cover)
    A, B = rgb(a), rgb(b)
    relmap = np.zeros(a.shape[:2])
    vals = []
    for k in range(1, n + 1):
        sel = lab == k
        pa, pb = A[sel], B[sel]
        floor = np.maximum(floor_frac * np.abs(pa).max(axis=0), 1e-12)
        rel = np.abs(pb - pa) / np.maximum(np.abs(pa), floor)
        vals.append(rel.reshape(-1))
        relmap[sel] = rel.max(axis=1)
    allv = np.concatenate(vals) if vals else np.zeros(0)
    mismatch = int(np.count_nonzero(cov_a != cov_b))
    return dict(median=float(np.median(allv)) if allv.size else float("nan"),
                p99=float(np.percentile(allv, 99)) if allv.size else float("nan"),
                max=float(allv.max()) if allv.size else float("nan"), n_pixels=int(cover.sum()),
                n_strands=int(n), coverage_mismatch=mismatch,
                coverage_mismatch_fraction=mismatch / max(int(cov_a.sum()), 1), rel_map=relmap, mask=cover)
