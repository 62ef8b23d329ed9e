"""Statistical checks for any closure: chi-square goodness of fit of `sample` against
`pdf`, the integral of the pdf, and the sampled furnace. Used by the test suite and
available to users who write their own BSDF (needs scipy for the chi-square p-value).

All domains are fibre-aligned: cells in (sin theta_i, delta phi) have equal solid angle
and the lobes sit near sin theta_i = -sin theta_o (peer-tests §5.E).
"""

from __future__ import annotations

from dataclasses import dataclass

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
        params = closure.model_params
        theta_scale = min(np.sqrt(min(p["v"])) for p in params)
        phi_scale = min(min(p["s"]) for p in params)
    except (KeyError, TypeError, ValueError):
        return 256, 512
    return int(np.clip(np.ceil(np.pi / theta_scale), 32, 2048)), int(np.clip(np.ceil(2 * np.pi / phi_scale), 64, 4096))


def pdf_integral(closure: Closure, wo, h: float, *, theta_panels: int | None = None,
                 phi_panels: int | None = None) -> float:
    """Integral of pdf over the sphere by composite 6-point Gauss-Legendre in theta (with
    the cos theta weight) and phi; panels default to one lobe width."""
    wo = np.asarray(wo, dtype=np.float64)
    wo = wo / np.linalg.norm(wo)
    auto_theta, auto_phi = _panels(closure)
    theta_panels = theta_panels or auto_theta
    phi_panels = phi_panels or auto_phi
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
        pdf = closure.pdf(wo, wi, h).reshape(len(t), len(phi))
        total += float((pdf * wp[None, :]).sum(axis=1) @ wt[start:start + rows])
    return total


def sampled_furnace(closure: Closure, wo, h: float, *, samples: int = 1_000_000, seed: int = 0) -> np.ndarray:
    """Mean sample weight (RGB), the Monte Carlo estimate of the directional albedo."""
    rng = np.random.default_rng(seed)
    result = closure.sample(wo, h, rng.random((samples, 3)))
    return result.weight.mean(axis=0)
