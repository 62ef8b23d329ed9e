"""The closure object every constructor returns: a weighted sum of BSDF models with
batch eval, per-lobe eval, sample, pdf and directional albedo on NumPy arrays.
Frames and conventions: docs/conventions.md."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import _core
from . import _validate as check

LOBES = ("R", "TT", "TRT", "TRRT+")


class SampleResult(NamedTuple):
    """Result of Closure.sample: arrays of N rows. A row with lobe == -1 (and pdf 0,
    weight 0) produced no direction."""

    wi: np.ndarray      # (N, 3) sampled direction towards the light, fibre frame
    weight: np.ndarray  # (N, 3) eval / pdf
    pdf: np.ndarray     # (N,) density per unit solid angle
    lobe: np.ndarray    # (N,) index into LOBES


class Closure:
    """A weight times a hair BSDF model, or a sum of such terms (OSL-style).

    Directions are (N, 3) or (3,) arrays in the fibre frame (x = tangent, root to tip);
    they are normalised. `h` is a scalar or (N,) in [-1, 1]. Rows broadcast.
    """

    def __init__(self, core: _core.ClosureSum, description: str):
        self._core = core
        self._description = description

    def __repr__(self) -> str:
        return self._description

    # --- evaluation -------------------------------------------------------------------
    def eval(self, wo, wi, h) -> np.ndarray:
        """BSDF value including the cosine factor (Cycles' convention), (N, 3)."""
        wo, wi, h = self._rows(wo=check.directions("wo", wo), wi=check.directions("wi", wi), h=check.offsets("h", h))
        return self._core.eval(wo, wi, h)

    def eval_lobes(self, wo, wi, h) -> np.ndarray:
        """Per-lobe values (N, 4, 3) in the order R, TT, TRT, TRRT+; they sum to eval."""
        wo, wi, h = self._rows(wo=check.directions("wo", wo), wi=check.directions("wi", wi), h=check.offsets("h", h))
        return self._core.eval_lobes(wo, wi, h)

    def pdf(self, wo, wi, h) -> np.ndarray:
        """The density `sample` reports for wi, per unit solid angle, (N,)."""
        wo, wi, h = self._rows(wo=check.directions("wo", wo), wi=check.directions("wi", wi), h=check.offsets("h", h))
        return self._core.pdf(wo, wi, h)

    def sample(self, wo, h, u) -> SampleResult:
        """Samples wi from 3 uniform numbers per row (docs/conventions.md for their roles)."""
        wo, h, u = self._rows(wo=check.directions("wo", wo), h=check.offsets("h", h), u=check.uniforms("u", u))
        wi, weight, pdf, lobe = self._core.sample(wo, h, u)
        return SampleResult(wi, weight, pdf, lobe)

    def albedo(self, wo, h, *, panels_per_scale: float = 1.0, max_nodes: int = 4_000_000) -> np.ndarray:
        """Directional albedo, the integral of eval over all wi, by deterministic
        composite Gauss-Legendre quadrature sized from the narrowest lobe, (N, 3)."""
        wo, h = self._rows(wo=check.directions("wo", wo), h=check.offsets("h", h))
        panels = check.real("panels_per_scale", panels_per_scale)
        if panels <= 0:
            raise ValueError("panels_per_scale: must be > 0")
        if not isinstance(max_nodes, int) or max_nodes < 1000:
            raise ValueError("max_nodes: must be an integer >= 1000")
        return self._core.albedo(wo, h, panels, max_nodes)

    # --- OSL-style arithmetic ---------------------------------------------------------
    def __mul__(self, weight) -> "Closure":
        w = check.color("weight", weight)
        return Closure(self._core.scaled(w), f"{_fmt_weight(w)} * ({self._description})")

    __rmul__ = __mul__

    def __add__(self, other) -> "Closure":
        if not isinstance(other, Closure):
            return NotImplemented
        return Closure(self._core.plus(other._core), f"{self._description} + {other._description}")

    @property
    def weights(self) -> list[tuple[float, float, float]]:
        """The weight of each term of the sum."""
        return [tuple(w) for w in self._core.closure_weights()]

    @property
    def model_params(self) -> list[dict]:
        """The mapped model parameters of each term (sigma_a, v, v_sample, s, eta, tilt)."""
        return self._core.model_params()

    @staticmethod
    def _rows(**arrays):
        return check.broadcast_rows(**arrays)


def _fmt_weight(w) -> str:
    return f"{w[0]:g}" if w[0] == w[1] == w[2] else f"({w[0]:g}, {w[1]:g}, {w[2]:g})"
