"""Statistical checks for any closure: chi-square goodness of fit of `sample` against
`pdf`, the integral of the pdf, and the sampled furnace. Used by the test suite and
available to users who write their own BSDF (needs scipy for the chi-square p-value).

All domains are fibre-aligned: cells in (sin theta_i, delta phi) have equal solid angle
and the lobes sit near sin theta_i = -sin theta_o (docs/validation.md §5.E).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from .closure import Closure

# 6-point Gauss-Legendre rule on [-1, 1].
_GL_X, _GL_W = np.polynomial.legendre.leggauss(6)


@dataclass
class Chi2Result:
    p_value: float
    statistic: float
    dof: int
    samples: int
    message: str  # why it failed outright, or "" (e.g. a sample landed where the pdf is 0)

    def passed(self, alpha: float) -> bool:
        return not self.message and self.p_value >= alpha


def sidak_alpha(alpha: float, tests: int) -> float:
    """Per-test significance so that the family of `tests` keeps overall level `alpha`."""
    return 1.0 - (1.0 - alpha) ** (1.0 / tests)


def _fibre_direction(sin_theta, phi):
    cos_theta = np.sqrt(np.clip(1.0 - sin_theta**2, 0.0, None))
    return np.stack([sin_theta, cos_theta * np.cos(phi), cos_theta * np.sin(phi)], axis=-1)


def _cell_probabilities(closure: Closure, wo, h, theta_bins: int, phi_bins: int, nodes: int) -> np.ndarray:
    """Integral of pdf over each (sin theta, delta phi) cell, by Gauss-Legendre per cell."""
    phi_o = np.arctan2(wo[2], wo[1])
    gx, gw = np.polynomial.legendre.leggauss(nodes)
    ds = 2.0 / theta_bins
    dp = 2.0 * np.pi / phi_bins
    s_nodes = (-1.0 + ds * (np.arange(theta_bins)[:, None] + 0.5 + 0.5 * gx[None, :])).ravel()
    p_nodes = (-np.pi + dp * (np.arange(phi_bins)[:, None] + 0.5 + 0.5 * gx[None, :])).ravel()
    S, P = np.meshgrid(s_nodes, p_nodes + phi_o, indexing="ij")
    wi = _fibre_direction(S.ravel(), P.ravel())
    pdf = closure.pdf(wo, wi, h).reshape(theta_bins, nodes, phi_bins, nodes)
    weights = (0.5 * ds * gw)[None, :, None, None] * (0.5 * dp * gw)[None, None, None, :]
    return (pdf * weights).sum(axis=(1, 3))


def chi2_test(closure: Closure, wo, h: float, *, samples: int = 1_000_000, theta_bins: int = 128,
              phi_bins: int = 256, nodes: int = 4, seed: int = 0, min_expected: float = 5.0) -> Chi2Result:
    """Pearson chi-square test of the directions `sample` draws against `pdf`, in the
    fibre-aligned domain. Cells with fewer than `min_expected` expected samples are pooled."""
    from scipy.special import gammaincc

    wo = np.asarray(wo, dtype=np.float64)
    wo = wo / np.linalg.norm(wo)
    rng = np.random.default_rng(seed)
    result = closure.sample(wo, h, rng.random((samples, 3)))
    valid = result.lobe >= 0
    wi = result.wi[valid]
    phi_o = np.arctan2(wo[2], wo[1])
    s = np.clip(wi[:, 0], -1.0, np.nextafter(1.0, 0.0))
    dphi = np.mod(np.arctan2(wi[:, 2], wi[:, 1]) - phi_o + np.pi, 2.0 * np.pi) - np.pi
    ti = np.clip(((s + 1.0) * 0.5 * theta_bins).astype(int), 0, theta_bins - 1)
    pj = np.clip(((dphi + np.pi) / (2.0 * np.pi) * phi_bins).astype(int), 0, phi_bins - 1)
    observed = np.bincount(ti * phi_bins + pj, minlength=theta_bins * phi_bins).astype(np.float64)
    expected = _cell_probabilities(closure, wo, h, theta_bins, phi_bins, nodes).ravel() * samples

    message = ""
    zero = expected <= 0
    if np.any(observed[zero] > 0):
        message = f"{int(observed[zero].sum())} samples fell in cells where the pdf is 0"
    total_probability = expected.sum() / samples
    if total_probability > 1.1:
        message = message or f"the pdf integrates to {total_probability:.4f} > 1.1"

    order = np.argsort(expected)
    exp_sorted, obs_sorted = expected[order], observed[order]
    keep = exp_sorted >= min_expected
    pooled_exp, pooled_obs = exp_sorted[~keep].sum(), obs_sorted[~keep].sum()
    exp_list = exp_sorted[keep]
    obs_list = obs_sorted[keep]
    if pooled_exp > 0:
        exp_list = np.append(exp_list, pooled_exp)
        obs_list = np.append(obs_list, pooled_obs)
    # Samples the sampler failed to produce (lobe == -1) count as missing probability mass.
    missing_obs = samples - valid.sum()
    missing_exp = max(samples - expected.sum(), 0.0)
    if missing_exp >= min_expected or missing_obs > 0:
        exp_list = np.append(exp_list, max(missing_exp, 1e-300))
        obs_list = np.append(obs_list, missing_obs)
    statistic = float(np.sum((obs_list - exp_list) ** 2 / exp_list))
    dof = len(exp_list) - 1
    if dof < 1:
        return Chi2Result(0.0, statistic, dof, samples, message or "too few cells for a chi-square test")
    p_value = float(gammaincc(dof / 2.0, statistic / 2.0))
    return Chi2Result(p_value, statistic, dof, samples, message)


def _panels(closure: Closure) -> tuple[int, int]:
    """Panels one lobe width wide, from the narrowest lobe of the closure's models."""
    try:
        params = getattr(closure, "model_params", [])
        theta_scale = min(np.sqrt(min(p["v"])) for p in params)
        phi_scale = min(min(p["s"]) for p in params)
    except (KeyError, TypeError, ValueError):
        return 256, 512  # no lobe widths known (plugins, Python BSDFs, Huang)
    return int(np.clip(np.ceil(np.pi / theta_scale), 32, 2048)), int(np.clip(np.ceil(2 * np.pi / phi_scale), 64, 4096))


def pdf_integral(closure: Closure, wo, h: float, *, theta_panels: int | None = None,
                 phi_panels: int | None = None) -> float:
    """Integral of pdf over the sphere by composite 6-point Gauss-Legendre in theta (with
    the cos theta weight) and phi; panels default to one lobe width."""
    wo = np.asarray(wo, dtype=np.float64)
    wo = wo / np.linalg.norm(wo)
    auto_theta, auto_phi = _panels(closure)
    return float(_sphere_integral(lambda wi: closure.pdf(wo, wi, h)[:, None], theta_panels or auto_theta,
                                  phi_panels or auto_phi)[0])


def albedo_quadrature(closure, wo, h: float, *, theta_panels: int | None = None,
                      phi_panels: int | None = None) -> np.ndarray:
    """Directional albedo (RGB), the integral of eval over the sphere, by the quadrature of
    pdf_integral. Works for any object with Closure's eval (plugins, python_bsdf)."""
    wo = np.asarray(wo, dtype=np.float64)
    wo = wo / np.linalg.norm(wo)
    auto_theta, auto_phi = _panels(closure)
    return _sphere_integral(lambda wi: closure.eval(wo, wi, h), theta_panels or auto_theta, phi_panels or auto_phi)


def _sphere_integral(fn, theta_panels: int, phi_panels: int) -> np.ndarray:
    """Integral over the sphere of fn(wi) -> (M, K) by composite 6-point Gauss-Legendre in theta
    (with the cos theta weight) and phi."""
    dt = np.pi / theta_panels
    dp = 2.0 * np.pi / phi_panels
    theta = (-0.5 * np.pi + dt * (np.arange(theta_panels)[:, None] + 0.5 + 0.5 * _GL_X[None, :])).ravel()
    wt = np.tile(0.5 * dt * _GL_W, theta_panels) * np.cos(theta)
    phi = (-np.pi + dp * (np.arange(phi_panels)[:, None] + 0.5 + 0.5 * _GL_X[None, :])).ravel()
    wp = np.tile(0.5 * dp * _GL_W, phi_panels)
    total = 0.0
    rows = max(1, 2_000_000 // len(phi))
    for start in range(0, len(theta), rows):  # a block of theta rows at a time keeps memory small
        t = theta[start:start + rows]
        T, P = np.meshgrid(t, phi, indexing="ij")
        wi = _fibre_direction(np.sin(T).ravel(), P.ravel())
        values = np.asarray(fn(wi))
        values = values.reshape(len(t), len(phi), values.shape[-1])
        total = total + np.einsum("ijk,j,i->k", values, wp, wt[start:start + rows])
    return np.asarray(total)


def sampled_furnace(closure: Closure, wo, h: float, *, samples: int = 1_000_000, seed: int = 0) -> np.ndarray:
    """Mean sample weight (RGB), the Monte Carlo estimate of the directional albedo."""
    rng = np.random.default_rng(seed)
    result = closure.sample(wo, h, rng.random((samples, 3)))
    return result.weight.mean(axis=0)


# --- The standard battery (hairbsdf.test_plugin) ------------------------------------------------

@dataclass
class Check:
    """One check of the battery: its name, verdict and what was measured."""

    name: str
    passed: bool
    detail: str
    seconds: float = 0.0

    def __str__(self) -> str:
        return f"  {'PASS' if self.passed else 'FAIL'}  {self.name:<20} {self.detail}"


@dataclass
class BatteryResult:
    """The result of `battery` / hairbsdf.test_plugin: truthy when every check passed."""

    name: str
    checks: list = field(default_factory=list)
    seconds: float = 0.0

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    def __bool__(self) -> bool:
        return self.passed

    def __getitem__(self, name: str) -> Check:
        for c in self.checks:
            if c.name == name:
                return c
        raise KeyError(f"{name!r}: no such check; checks: {', '.join(c.name for c in self.checks)}")

    @property
    def failed(self) -> list:
        return [c for c in self.checks if not c.passed]

    def __str__(self) -> str:
        verdict = "PASSED" if self.passed else f"FAILED ({len(self.failed)} of {len(self.checks)} checks)"
        lines = [f"hairbsdf battery: {self.name}"] + [str(c) for c in self.checks]
        lines.append(f"  {verdict} in {self.seconds:.1f} s")
        return "\n".join(lines)


def _unit(theta_deg: float, phi_deg: float) -> np.ndarray:
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t), math.cos(t) * math.cos(p), math.cos(t) * math.sin(p)])


# (wo, h) pairs of the battery: moderate, steep, head-on and grazing views.
DEFAULT_VIEWS = ((_unit(-35, 20), 0.3), (_unit(60, -110), -0.8), (_unit(0, 90), 0.0), (_unit(80, 10), 0.95))


@dataclass
class BatteryOptions:
    """Sizes of the battery. The defaults take a few seconds for a C plugin."""

    views: tuple = DEFAULT_VIEWS
    furnace_bound: float = 1.01      # max directional albedo allowed (white furnace)
    theta_panels: int = 128          # quadrature of the albedo (6 Gauss-Legendre nodes each)
    phi_panels: int = 128
    furnace_samples: int = 200_000   # sampled furnace per view
    consistency_samples: int = 20_000  # weight = eval/pdf and sample pdf = pdf(), per view
    rtol: float = 1e-6               # of those two checks
    chi2_samples: int = 200_000      # per view
    chi2_alpha: float = 0.01         # family-wise (Sidak over the views)
    chi2_bins: tuple = (64, 128)     # cells in sin(theta_i) and delta phi
    chi2_nodes: int = 8              # Gauss-Legendre nodes per cell and axis for the expected counts; lobes
                                     # much narrower than a cell (Phong exponents in the thousands) need more
    fuzz_samples: int = 20_000
    seed: int = 0


def _first_bad(bad: np.ndarray, **arrays) -> str:
    i = int(np.flatnonzero(bad)[0])
    shown = ", ".join(f"{k}={np.array2string(np.asarray(v[i]), precision=4)}" for k, v in arrays.items())
    return f"{int(bad.sum())} rows, e.g. {shown}"


def _check_furnace(closure, o: BatteryOptions, albedos: list) -> Check:
    for wo, h in o.views:
        albedos.append(albedo_quadrature(closure, wo, h, theta_panels=o.theta_panels, phi_panels=o.phi_panels))
    a = np.array(albedos)
    if not np.all(np.isfinite(a)):
        return Check("furnace", False, "the albedo quadrature is not finite (eval returned NaN or Inf)")
    worst = int(np.argmax(a.max(axis=1)))
    detail = (f"max albedo {a.max():.5f} (view {worst}) <= {o.furnace_bound} over {len(o.views)} views; "
              f"min {a.min():.4f}")
    if a.max() > o.furnace_bound:
        detail = f"max albedo {a.max():.5f} at view {worst} exceeds {o.furnace_bound} (energy is created)"
    return Check("furnace", bool(a.max() <= o.furnace_bound and a.min() >= -1e-9), detail)


def _check_sampled_furnace(closure, o: BatteryOptions, albedos: list) -> Check:
    rng = np.random.default_rng(o.seed + 1)
    worst, worst_text = 0.0, ""
    for k, (wo, h) in enumerate(o.views):
        s = closure.sample(wo, h, rng.random((o.furnace_samples, 3)))
        w = np.where(s.lobe[:, None] >= 0, s.weight, 0.0)
        if not np.all(np.isfinite(w)):
            return Check("sampled furnace", False, f"view {k}: non-finite sample weights")
        mean, sigma = w.mean(axis=0), w.std(axis=0) / math.sqrt(len(w))
        z = np.abs(mean - albedos[k]) / (4.0 * sigma + 2e-3)
        if z.max() > worst:
            worst = float(z.max())
            worst_text = f"view {k}: mean weight {np.array2string(mean, precision=4)} vs albedo " \
                         f"{np.array2string(np.asarray(albedos[k]), precision=4)}"
    detail = f"mean weight = albedo within 4 sigma + 2e-3 ({worst:.2f} of the allowance used); {worst_text}"
    if worst > 1.0:
        detail = ("mean sample weight differs from the albedo (the sampler misses part of eval, or weight is "
                  f"not eval/pdf): {worst_text}")
    return Check("sampled furnace", worst <= 1.0, detail)


def _check_consistency(closure, o: BatteryOptions) -> list:
    rng = np.random.default_rng(o.seed + 2)
    worst_w = worst_p = 0.0
    bad_w = bad_p = ""
    count = 0
    for k, (wo, h) in enumerate(o.views):
        s = closure.sample(wo, h, rng.random((o.consistency_samples, 3)))
        ok = s.lobe >= 0
        count += int(ok.sum())
        if not ok.any():
            continue
        wi = s.wi[ok]
        value = closure.eval(wo, wi, h)
        pdf = closure.pdf(wo, wi, h)
        expected = value / pdf[:, None]
        err_w = np.abs(s.weight[ok] - expected) / (np.abs(expected) + 1e-12 * (np.abs(expected).max() + 1e-300))
        err_p = np.abs(s.pdf[ok] - pdf) / (np.abs(pdf) + 1e-300)
        err_w = np.where(np.isfinite(err_w), err_w, np.inf).max(axis=1)
        err_p = np.where(np.isfinite(err_p), err_p, np.inf)
        if err_w.max() > worst_w:
            i = int(np.argmax(err_w))
            worst_w = float(err_w.max())
            bad_w = f" (view {k}: weight {np.array2string(s.weight[ok][i], precision=6)} vs eval/pdf " \
                    f"{np.array2string(expected[i], precision=6)})"
        if err_p.max() > worst_p:
            i = int(np.argmax(err_p))
            worst_p = float(err_p.max())
            bad_p = f" (view {k}: sample pdf {s.pdf[ok][i]:.6g} vs pdf() {pdf[i]:.6g})"
    return [Check("weight = eval/pdf", worst_w <= o.rtol,
                  f"max relative error {worst_w:.2g} <= {o.rtol:g} over {count} samples"
                  f"{bad_w if worst_w > o.rtol else ''}"),
            Check("sample pdf = pdf()", worst_p <= o.rtol,
                  f"max relative error {worst_p:.2g} <= {o.rtol:g} over {count} samples"
                  f"{bad_p if worst_p > o.rtol else ''}")]


def _check_pdf_integral(closure, o: BatteryOptions) -> Check:
    rng = np.random.default_rng(o.seed + 3)
    worst, text = 0.0, ""
    for k, (wo, h) in enumerate(o.views):
        s = closure.sample(wo, h, rng.random((20_000, 3)))
        produced = float(np.mean(s.lobe >= 0))
        integral = pdf_integral(closure, wo, h, theta_panels=o.theta_panels, phi_panels=o.phi_panels)
        err = abs(integral - produced) if math.isfinite(integral) else math.inf
        if err >= worst:
            worst, text = err, f"view {k}: integral {integral:.5f}, samples produced {produced:.4f}"
    return Check("pdf normalised", worst <= 0.01,
                 f"integral of pdf = fraction of rows that produce a sample, within 0.01 (worst {worst:.2g}; {text})")


def _check_chi2(closure, o: BatteryOptions) -> Check:
    alpha = sidak_alpha(o.chi2_alpha, len(o.views))
    results = [chi2_test(closure, wo, h, samples=o.chi2_samples, theta_bins=o.chi2_bins[0], phi_bins=o.chi2_bins[1],
                         nodes=o.chi2_nodes, seed=o.seed + 10 + k)
               for k, (wo, h) in enumerate(o.views)]
    p_values = [r.p_value for r in results]
    failed = [(k, r) for k, r in enumerate(results) if not r.passed(alpha)]
    detail = f"p-values {', '.join(f'{p:.3g}' for p in p_values)} >= {alpha:.2g} ({len(results)} views, " \
             f"{o.chi2_samples} samples each)"
    if failed:
        k, r = failed[0]
        detail = f"view {k}: p = {r.p_value:.3g} < {alpha:.2g}{'; ' + r.message if r.message else ''} " \
                 f"(sample does not draw the density pdf reports); all p-values: " \
                 f"{', '.join(f'{p:.3g}' for p in p_values)}"
    return Check("chi2", not failed, detail)


def _fuzz_inputs(o: BatteryOptions):
    rng = np.random.default_rng(o.seed + 4)
    n = o.fuzz_samples
    wo = rng.normal(size=(n, 3))
    wi = rng.normal(size=(n, 3))
    special = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, 0, -1], [1, 1e-9, 0], [-1, 0, 1e-12],
                        [1e-12, 1, 0], [0.6, 0.8, 0]], dtype=np.float64)
    m = len(special)
    wo[:m * m] = np.repeat(special, m, axis=0)
    wi[:m * m] = np.tile(special, (m, 1))
    wi[m * m:m * m + 100] = wo[m * m:m * m + 100]         # wi = wo
    wi[m * m + 100:m * m + 200] = -wo[m * m + 100:m * m + 200]  # wi = -wo
    h = rng.uniform(-1, 1, n)
    h[::7] = 1.0
    h[1::7] = -1.0
    h[2::7] = 0.0
    u = rng.random((n, 3))
    corners = np.array([0.0, 1.0, np.nextafter(1.0, 0.0), 1e-300])
    u[:64] = np.stack(np.meshgrid(corners, corners, corners, indexing="ij"), axis=-1).reshape(-1, 3)
    return wo, wi, h, u


def _check_fuzz(closure, o: BatteryOptions) -> Check:
    wo, wi, h, u = _fuzz_inputs(o)
    problems = []
    value = np.asarray(closure.eval(wo, wi, h))
    bad = ~np.all(np.isfinite(value), axis=1)
    if bad.any():
        problems.append("eval not finite: " + _first_bad(bad, wo=wo, wi=wi, h=h, value=value))
    bad = np.any(value < -1e-12, axis=1)
    if bad.any():
        problems.append("eval negative: " + _first_bad(bad, wo=wo, wi=wi, h=h, value=value))
    pdf = np.asarray(closure.pdf(wo, wi, h))
    bad = ~np.isfinite(pdf) | (pdf < 0)
    if bad.any():
        problems.append("pdf not finite or negative: " + _first_bad(bad, wo=wo, wi=wi, h=h, pdf=pdf))
    s = closure.sample(wo, h, u)
    ok = s.lobe >= 0
    bad = (s.lobe < -1) | (s.lobe > 3)
    if bad.any():
        problems.append("lobe outside -1..3: " + _first_bad(bad, wo=wo, h=h, u=u, lobe=s.lobe))
    bad = ok & ~(np.all(np.isfinite(s.wi), axis=1) & (np.abs(np.linalg.norm(s.wi, axis=1) - 1.0) < 1e-6))
    if bad.any():
        problems.append("sampled wi not a finite unit vector: " + _first_bad(bad, wo=wo, h=h, u=u, wi=s.wi))
    bad = ok & ~(np.all(np.isfinite(s.weight), axis=1) & np.all(s.weight >= -1e-12, axis=1))
    if bad.any():
        problems.append("sample weight not finite or negative: " + _first_bad(bad, wo=wo, h=h, u=u, weight=s.weight))
    bad = ok & ~(np.isfinite(s.pdf) & (s.pdf > 0))
    if bad.any():
        problems.append("sample pdf not finite and > 0: " + _first_bad(bad, wo=wo, h=h, u=u, pdf=s.pdf))
    bad = ~ok & ~np.isfinite(s.pdf)
    if bad.any():
        problems.append("failed sample call (NaN pdf): " + _first_bad(bad, wo=wo, h=h, u=u))
    n = len(wo)
    if problems:
        return Check("fuzz", False, f"{n} rows of random and edge-case inputs: " + "; ".join(problems))
    return Check("fuzz", True, f"{n} rows of random and edge-case inputs (poles, wi = +-wo, |h| = 1, u at 0 and 1): "
                               f"eval, pdf, sample finite and >= 0")


def battery(closure, *, name: str | None = None, options: BatteryOptions | None = None,
            verbose: bool = True) -> BatteryResult:
    """The standard checks for any closure-like object (Closure, a plugin's closure,
    python_bsdf): white furnace bound, sampled furnace = albedo, weight = eval/pdf, sample
    pdf = pdf(), pdf normalisation, chi-square of sample against pdf, and fuzzing for NaN,
    Inf and negative values. A check that raises is reported as failed with the exception.
    Prints one verdict line per check when `verbose`."""
    o = options or BatteryOptions()
    result = BatteryResult(name or repr(closure))
    if verbose:
        print(f"hairbsdf battery: {result.name}", flush=True)
    start = time.perf_counter()
    albedos: list = []
    steps = [("furnace", lambda: [_check_furnace(closure, o, albedos)]),
             ("sampled furnace", lambda: [_check_sampled_furnace(closure, o, albedos)] if len(albedos) == len(o.views)
              else [Check("sampled furnace", False, "skipped: the furnace quadrature failed")]),
             ("weight = eval/pdf", lambda: _check_consistency(closure, o)),
             ("pdf normalised", lambda: [_check_pdf_integral(closure, o)]),
             ("chi2", lambda: [_check_chi2(closure, o)]),
             ("fuzz", lambda: [_check_fuzz(closure, o)])]
    for label, step in steps:
        t0 = time.perf_counter()
        with np.errstate(all="ignore"):
            try:
                checks = step()
            except Exception as exc:  # a broken BSDF is a verdict, not a crash of the battery
                checks = [Check(label, False, f"raised {type(exc).__name__}: {exc}")]
        for c in checks:
            c.seconds = time.perf_counter() - t0
            result.checks.append(c)
            if verbose:
                print(c, flush=True)
    result.seconds = time.perf_counter() - start
    if verbose:
        print(str(result).splitlines()[-1], flush=True)
    return result
