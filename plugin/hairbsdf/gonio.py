"""Gonio grids shared by `hairbsdf fit` and `hairbsdf plot`: directions from angles in the fibre
frame (docs/conventions.md), the h-averaged (far-field) value of a closure, and the solid-angle
weights of a (theta_o, theta_i, delta_phi) grid."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from .principled import DEFAULT_MODEL

REC709 = np.array(_core.LUMINANCE_WEIGHTS)  # Rec.709 luminance weights, C++ luminance()'s (math.h)
# Gauss-Legendre nodes in h for the far field of h-dependent models. Chiang's value at one h is
# a narrow logistic in phi around Phi(p, h); 8 nodes leave 15 % of the far field's norm, 16: 1.5 %,
# 32: 2e-4 (radial roughness 0.3; measured against 128 nodes on the 24-cell grid).
H_NODES = 32


def direction(theta, phi) -> np.ndarray:
    """Unit vectors (..., 3) of longitudinal angle theta (sin theta = w.x) and azimuth phi."""
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
    return np.stack([np.sin(theta), np.cos(theta) * np.cos(phi), np.cos(theta) * np.sin(phi)], axis=-1)


def h_nodes(count: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes in h on [-1, 1] and weights summing to 1 (the mean over h)."""
    if count < 1:
        raise ValueError("h nodes: must be >= 1")
    x, w = np.polynomial.legendre.leggauss(count)
    return x, w / 2.0


def depends_on_h(name: str, kwargs: dict) -> bool:
    """Whether a spec's value changes with h. Chiang (Principled Hair) and yan_fur (its unscattered
    lobes) do; Huang's far field integrates over the width (h only decides the hit), and the other
    zoo models have no h."""
    if name == "yan_fur":
        return True
    return name == "principled_hair" and str(kwargs.get("model", DEFAULT_MODEL)).lower() != "huang"


def far_field_lobes(closure, wo, wi, h_count: int, h_dependent: bool, **eval_kw) -> np.ndarray:
    """Per-lobe values (N, 4, 3) ((N, 6, 3) for yan_fur) averaged over h (Gauss-Legendre, h_count
    nodes) when the model depends on h, else at h = 0; eval_kw (e.g. Huang's tolerance=) go to eval_lobes."""
    wo = np.asarray(wo, float).reshape(-1, 3)
    wi = np.asarray(wi, float).reshape(-1, 3)
    if not h_dependent:
        return closure.eval_lobes(wo, wi, 0.0, **eval_kw)
    nodes, weights = h_nodes(h_count)
    total = 0.0
    for h, w in zip(nodes, weights):
        total = total + w * closure.eval_lobes(wo, wi, float(h), **eval_kw)
    return total


@dataclass(frozen=True)
class GonioGrid:
    """Midpoint cells in theta_o and theta_i over (-90, 90) degrees, and periodic nodes in
    delta_phi over [-180, 180) degrees (phi_o = 0). `weights` are the solid-angle measures
    cos(theta_o) cos(theta_i) d theta_o d theta_i d delta_phi, normalised to sum to 1, so that
    sum(w * f^2) approximates the mean of f^2 over pairs of directions."""

    theta_o: np.ndarray   # (N,) radians, one per grid point
    theta_i: np.ndarray
    delta_phi: np.ndarray
    wo: np.ndarray        # (N, 3)
    wi: np.ndarray        # (N, 3)
    weights: np.ndarray   # (N,)
    shape: tuple          # (n_theta, n_theta, n_phi)

    @classmethod
    def make(cls, n_theta: int, n_phi: int | None = None) -> "GonioGrid":
        if n_theta < 2:
            raise ValueError("grid: need at least 2 theta cells")
        n_phi = 2 * n_theta if n_phi is None else n_phi
        theta = -np.pi / 2 + (np.arange(n_theta) + 0.5) * np.pi / n_theta
        phi = -np.pi + np.arange(n_phi) * 2 * np.pi / n_phi
        to, ti, dp = np.meshgrid(theta, theta, phi, indexing="ij")
        to, ti, dp = to.ravel(), ti.ravel(), dp.ravel()
        w = np.cos(to) * np.cos(ti)
        return cls(to, ti, dp, direction(to, 0.0), direction(ti, dp), w / w.sum(), (n_theta, n_theta, n_phi))

    def __len__(self) -> int:
        return len(self.weights)
