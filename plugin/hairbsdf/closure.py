"""The closure object every constructor returns: a weighted sum of BSDF models with
batch eval, per-lobe eval, sample, pdf and directional albedo on NumPy arrays.
Frames and conventions: docs/conventions.md."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import _core
from . import _validate as check

LOBES = ("R", "TT", "TRT", "TRRT+")
# eval_lobes of a closure with yan_fur in it has two more slots: its medulla-scattered lobes (docs/models.md §7).
YAN_FUR_LOBES = LOBES + ("TTs", "TRTs")


class SampleResult(NamedTuple):
    """Result of Closure.sample: arrays of N rows. A row with lobe == -1 (and pdf 0,
    weight 0) produced no direction."""

    wi: np.ndarray      # (N, 3) sampled direction towards the light, fibre frame
    weight: np.ndarray  # (N, 3) eval / pdf
    pdf: np.ndarray     # (N,) density per unit solid angle
    lobe: np.ndarray    # (N,) index into LOBES (YAN_FUR_LOBES for yan_fur)


class Closure:
    """A weight times a hair BSDF model, or a sum of such terms (OSL-style).

    Directions are (N, 3) or (3,) arrays in the fibre frame (x = tangent, root to tip);
    they are normalised. `h` is a scalar or (N,) in [-1, 1]. Rows broadcast.
    """

    def __init__(self, core: _core.ClosureSum, description: str, principled: tuple | None = None):
        self._core = core
        self._description = description
        # principled_hair(model="chiang")'s uniform inputs (principled_chiang's argument), which
        # per-row `inputs=` start from; None for every other closure.
        self._principled = principled

    def __repr__(self) -> str:
        return self._description

    # --- evaluation -------------------------------------------------------------------
    # The keyword arrays normal=, pixel_coverage= and near_field= are the optional per-sample
    # shading fields of the Huang model (docs/huang.md §1); other models ignore them.
    #   normal:         (N, 3) or (3,) curve normal (the ellipse's major axis) in the fibre frame;
    #                   zero rows use Cycles' fallback frame (particle hair). Default: zero.
    #   pixel_coverage: scalar or (N,), half a pixel's footprint at the hit in units of the fibre
    #                   radius (Cycles: 0.5 dP / r). Default 1.
    #   near_field:     scalar or (N,) bool: the near field is allowed (Cycles: camera rays). It is
    #                   used where the projected radius exceeds pixel_coverage. Default False.
    # For far-field use h only decides whether the hit is inside the projected ellipse (|h| < r);
    # the value integrates over the whole visible width.
    #   random:         scalar or (N,) in [0, 1], the per-strand random number (Hair Info > Random)
    #                   passed to plugin models (hairbsdf.load_plugin); built-in models ignore it
    #                   (principled_hair takes it as the `random` keyword). Default 0.
    #   shadow:         scalar or (N,) in [0, 1], the Epic model's light visibility through the hair
    #                   volume (docs/models.md §2), default 1 = unoccluded; other models ignore it.
    # A single Chiang closure given float32 arrays of N rows (wo, wi (N, 3), h (N,) or a number)
    # runs on the float32 SIMD batch kernels (docs/simd.md): C-contiguous input is read in place,
    # the result is float32. `out=`: a preallocated result array. float64 rows and everything else
    # take the scalar double path (hairbsdf.set_batch_kernel chooses otherwise).
    # `inputs=`: per-row node inputs of a principled_hair(model="chiang") closure (ROW_INPUTS; docs/simd.md),
    #   a dict of (N,) arrays ((N, 3) for absorption_coefficient) that replace the closure's values row by
    #   row, with the node's meaning (random is the Random socket). float32 rows run on the kernels.
    #   tolerance:      Huang's error target relative to each row's total, in [1e-6, 0.5]
    #                   (docs/huang.md §4); None: the closure's own (principled_hair's `tolerance`).
    #                   Other models ignore it; pdf accepts it for symmetry (the mixture pdf is exact).
    def eval(self, wo, wi, h, *, normal=None, pixel_coverage=None, near_field=None, random=None,
             shadow=None, out=None, inputs=None, tolerance=None) -> np.ndarray:
        """BSDF value including the cosine factor (Cycles' convention), (N, 3)."""
        if inputs is not None:
            _no_extras(normal, pixel_coverage, near_field, random, shadow)
            return self._rows_call(0, wo, wi, h, inputs, out)
        core = self._core_for(tolerance)
        if normal is None and pixel_coverage is None and near_field is None and random is None and shadow is None:
            result = core.kernel_eval(wo, wi, _h_rows(h, wo), out)
            if result is not None:
                return result
        return _into(out, self._eval(wo, wi, h, False, normal, pixel_coverage, near_field, random, shadow, core))

    def eval_lobes(self, wo, wi, h, *, normal=None, pixel_coverage=None, near_field=None, random=None,
                   shadow=None, tolerance=None) -> np.ndarray:
        """Per-lobe values (N, 4, 3) in the order R, TT, TRT, TRRT+; they sum to eval. With a
        yan_fur closure in the sum: (N, 6, 3), adding its medulla-scattered TTs and TRTs."""
        return self._eval(wo, wi, h, True, normal, pixel_coverage, near_field, random, shadow,
                          self._core_for(tolerance))

    def pdf(self, wo, wi, h, *, normal=None, pixel_coverage=None, near_field=None, random=None,
            shadow=None, out=None, inputs=None, tolerance=None) -> np.ndarray:
        """The density `sample` reports for wi, per unit solid angle, (N,)."""
        if tolerance is not None:
            check.huang_tolerance(tolerance)
        if inputs is not None:
            _no_extras(normal, pixel_coverage, near_field, random, shadow)
            return self._rows_call(1, wo, wi, h, inputs, out)
        extra = _extras(normal, pixel_coverage, near_field, random, shadow)
        if not extra:
            result = self._core.kernel_pdf(wo, wi, _h_rows(h, wo), out)
            if result is not None:
                return result
        rows = self._rows(wo=check.directions("wo", wo), wi=check.directions("wi", wi), h=check.offsets("h", h), **extra)
        if not extra:
            return _into(out, self._core.pdf(*rows))
        return _into(out, self._core.pdf_ex(*rows[:3], *_extra_args(extra, rows[3:])))

    def sample(self, wo, h, u, *, normal=None, pixel_coverage=None, near_field=None, random=None,
               shadow=None, inputs=None) -> SampleResult:
        """Samples wi from 3 uniform numbers per row (docs/conventions.md for their roles)."""
        if inputs is not None:
            _no_extras(normal, pixel_coverage, near_field, random, shadow)
            return SampleResult(*self._rows_call(2, wo, u, h, inputs, None))
        extra = _extras(normal, pixel_coverage, near_field, random, shadow)
        if not extra:
            result = self._core.kernel_sample(wo, _h_rows(h, wo), u)
            if result is not None:
                return SampleResult(*result)
        rows = self._rows(wo=check.directions("wo", wo), h=check.offsets("h", h), u=check.uniforms("u", u), **extra)
        if not extra:
            wi, weight, pdf, lobe = self._core.sample(*rows)
        else:
            wi, weight, pdf, lobe = self._core.sample_ex(*rows[:3], *_extra_args(extra, rows[3:]))
        return SampleResult(wi, weight, pdf, lobe)

    def _rows_call(self, op, wo, second, h, inputs, out):
        """eval (op 0), pdf (1) or sample (2) with per-row node inputs: the kernels for float rows,
        else (float64 rows, bad rows, set_batch_kernel("scalar")) the double path row by row."""
        if self._principled is None:
            raise ValueError("inputs: per-row node inputs need a single principled_hair(model='chiang') "
                             "closure (times a weight); this closure is " + self._description)
        arrays = _row_inputs(inputs)
        weight = tuple(self._core.closure_weights()[0])
        result = _core.chiang_rows(op, self._principled, weight, arrays, wo, second, _h_rows(h, wo), out, False)
        if result is not None:
            return result
        second_name, second_check = ("u", check.uniforms) if op == 2 else ("wi", check.directions)
        named = dict(wo=check.directions("wo", wo), second=second_check(second_name, second), h=check.offsets("h", h))
        for name, value in arrays.items():
            named[name] = check.triples(name, value) if ROW_INPUTS[name] else check.per_row(name, value)
        rows = dict(zip(named, self._rows(**named)))
        row_arrays = {name: rows[name] for name in arrays}
        result = _core.chiang_rows(op, self._principled, weight, row_arrays, rows["wo"], rows["second"], rows["h"],
                                   None, True)
        return result if op == 2 else _into(out, result)

    def _eval(self, wo, wi, h, lobes, normal, pixel_coverage, near_field, random=None, shadow=None, core=None):
        core = self._core if core is None else core
        extra = _extras(normal, pixel_coverage, near_field, random, shadow)
        rows = self._rows(wo=check.directions("wo", wo), wi=check.directions("wi", wi), h=check.offsets("h", h), **extra)
        if not extra:
            return core.eval_lobes(*rows) if lobes else core.eval(*rows)
        return core.eval_ex(*rows[:3], lobes, *_extra_args(extra, rows[3:]))

    def _core_for(self, tolerance):
        """The core sum, with every Huang closure's tolerance replaced when one is given."""
        if tolerance is None:
            return self._core
        return self._core.with_huang_tolerance(check.huang_tolerance(tolerance))

    # --- Huang model helpers ----------------------------------------------------------
    def huang_details(self, wo, h, wi=None, *, normal=None, pixel_coverage=None, near_field=None) -> dict:
        """Per row of a single Huang closure: projected radius r (of the ellipse, seen from wo),
        transparent (|h| >= r: Cycles renders the hit as transparent), near_field (in use),
        h_lo / h_hi (the r-normalised integration interval) and, when wi is given, the number of
        residual integrand evaluations its eval used."""
        extra = _extras(normal, pixel_coverage, near_field)
        wi_arr = check.directions("wi", wi) if wi is not None else np.zeros((1, 3))
        rows = self._rows(wo=check.directions("wo", wo), wi=wi_arr, h=check.offsets("h", h), **extra)
        if wi is None:
            rows[1] = np.zeros((0, 3))
        return self._core.huang_details(*rows[:3], *_extra_args(extra, rows[3:], _HUANG_ORDER))

    def sample_directions(self, wo, h, u, *, normal=None, pixel_coverage=None, near_field=None) -> SampleResult:
        """Directions of the Huang mixture sampler and their density, without evaluating the BSDF
        (weight is returned as 0): cheap, for statistical tests and custom estimators. A single
        Huang closure only."""
        extra = _extras(normal, pixel_coverage, near_field)
        rows = self._rows(wo=check.directions("wo", wo), h=check.offsets("h", h), u=check.uniforms("u", u), **extra)
        wi, pdf, lobe = self._core.huang_sample_directions(*rows[:3], *_extra_args(extra, rows[3:], _HUANG_ORDER))
        return SampleResult(wi, np.zeros_like(wi), pdf, lobe)

    def cycles_estimate(self, wo, wi, h, *, samples: int = 1, seed: int = 0, normal=None, pixel_coverage=None,
                        near_field=None) -> np.ndarray:
        """Mean of `samples` runs of Cycles' stochastic eval (one random visible normal per Simpson
        node), per lobe (N, 4, 3), for a single Huang closure. Its expectation is
        eval_lobes(..., accuracy='cycles')."""
        if not isinstance(samples, int) or samples < 1:
            raise ValueError("samples: must be an integer >= 1")
        extra = _extras(normal, pixel_coverage, near_field)
        rows = self._rows(wo=check.directions("wo", wo), wi=check.directions("wi", wi), h=check.offsets("h", h), **extra)
        return self._core.huang_cycles_estimate(*rows[:3], *_extra_args(extra, rows[3:], _HUANG_ORDER), samples,
                                                 int(seed) & 0xFFFFFFFF)

    def albedo(self, wo, h, *, panels_per_scale: float = 1.0, max_nodes: int = 4_000_000,
               tolerance=None, huang_quadrature: bool = False) -> np.ndarray:
        """Directional albedo, the integral of eval over all wi, by deterministic
        composite Gauss-Legendre quadrature sized from the narrowest lobe, (N, 3).
        Huang closures (accuracy "cycles") instead integrate Cycles' stochastic eval along each
        sampled path's own exit (unbiased for the eval's integral) until its standard error is
        below half of `tolerance` (default: the closure's) times the albedo, at most max_nodes
        samples (docs/huang.md §6); huang_quadrature=True
        keeps the quadrature for them too (slow: minutes a row)."""
        wo, h = self._rows(wo=check.directions("wo", wo), h=check.offsets("h", h))
        panels = check.real("panels_per_scale", panels_per_scale)
        if panels <= 0:
            raise ValueError("panels_per_scale: must be > 0")
        if not isinstance(max_nodes, int) or max_nodes < 1000:
            raise ValueError("max_nodes: must be an integer >= 1000")
        if not isinstance(huang_quadrature, bool):
            raise TypeError("huang_quadrature: expected True or False")
        # The core's Huang tolerance: 0 keeps the quadrature, < 0 each closure's own tolerance.
        huang_tolerance = 0.0 if huang_quadrature else -1.0 if tolerance is None else check.huang_tolerance(tolerance)
        return self._core.albedo(wo, h, panels, max_nodes, huang_tolerance)

    # --- OSL-style arithmetic ---------------------------------------------------------
    def __mul__(self, weight) -> "Closure":
        w = check.color("weight", weight)
        return Closure(self._core.scaled(w), f"{_fmt_weight(w)} * ({self._description})", self._principled)

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


_EXTRA_ORDER = ("normal", "pixel_coverage", "near_field", "random", "shadow")
_HUANG_ORDER = _EXTRA_ORDER[:3]


def _extras(normal, pixel_coverage, near_field, random=None, shadow=None) -> dict:
    """The given optional per-sample fields, validated (an empty dict when none is given)."""
    out = {}
    if normal is not None:
        out["normal"] = check.normals("normal", normal)
    if pixel_coverage is not None:
        out["pixel_coverage"] = check.coverages("pixel_coverage", pixel_coverage)
    if near_field is not None:
        out["near_field"] = check.flags("near_field", near_field)
    if random is not None:
        out["random"] = check.unit_interval("random", random)
    if shadow is not None:
        out["shadow"] = check.fractions("shadow", shadow)
    return out


def _extra_args(extra: dict, arrays: list, order=_EXTRA_ORDER) -> list:
    """Broadcast arrays of `extra` (in insertion order) -> the core's (normal, pixel_coverage,
    near_field, random, shadow) arguments, None where not given."""
    given = dict(zip(extra.keys(), arrays))
    return [given.get(k) for k in order]


# The node inputs `inputs=` may give per row (docs/simd.md); the others stay the closure's. Name ->
# columns as the scene schema's row says: 0 for a number a row (N,), 3 for an RGB triple a row (N, 3).
ROW_INPUTS = dict(_core.CHIANG_ROW_INPUTS)


def _no_extras(normal, pixel_coverage, near_field, random, shadow) -> None:
    if not (normal is None and pixel_coverage is None and near_field is None and random is None and shadow is None):
        raise ValueError("inputs: per-row node inputs do not combine with normal=, pixel_coverage=, near_field=, "
                         "random= or shadow= (the Chiang model has no such fields; give random in inputs)")


def _row_inputs(inputs) -> dict:
    """inputs= checked: known names, float arrays ((N, 3) or (3,) for an RGB input, else (N,) or a
    number), finite. Kept in their float type for the kernels."""
    if not isinstance(inputs, dict):
        raise TypeError(f"inputs: expected a dict of per-row arrays, got {type(inputs).__name__}")
    out = {}
    for name, value in inputs.items():
        if name not in ROW_INPUTS:
            raise ValueError(f"inputs: {name!r} cannot vary per row; allowed: {', '.join(ROW_INPUTS)}")
        columns = ROW_INPUTS[name]
        arr = value if isinstance(value, np.ndarray) and value.dtype in (np.float32, np.float64) else None
        if arr is None:
            arr = check.triples(name, value) if columns else check.per_row(name, value)
        if columns and (arr.ndim != 2 or arr.shape[1] != columns) and arr.shape != (columns,):
            raise ValueError(f"inputs: {name}: shape {arr.shape} is not allowed; pass (N, {columns}) or ({columns},)")
        if not columns and arr.ndim > 1:
            raise ValueError(f"inputs: {name}: shape {arr.shape} is not allowed; pass a number or (N,)")
        if not np.isfinite(arr).all():
            raise ValueError(f"inputs: {name}: contains NaN or Inf; all values must be finite")
        out[name] = arr
    return out


def _h_rows(h, wo):
    """h as the kernels take it: a number becomes (N,) in wo's float type; anything else as given."""
    number = isinstance(h, (float, int, np.floating, np.integer)) and not isinstance(h, (bool, np.bool_))
    if number and isinstance(wo, np.ndarray) and wo.ndim == 2:
        return np.full(len(wo), h, dtype=np.float32 if wo.dtype == np.float32 else np.float64)
    return h


def _into(out, result: np.ndarray) -> np.ndarray:
    """The scalar path's result, written into `out` when one is given."""
    if out is None:
        return result
    if not isinstance(out, np.ndarray) or out.shape != result.shape or not out.flags.writeable:
        raise ValueError(f"out: must be a writeable array of shape {result.shape}")
    out[...] = result
    return out


def _fmt_weight(w) -> str:
    return f"{w[0]:g}" if w[0] == w[1] == w[2] else f"({w[0]:g}, {w[1]:g}, {w[2]:g})"
