"""Argument checks shared by the public API: every error names the argument and what is allowed."""

from __future__ import annotations

import difflib
import functools
import math
from typing import Iterable

import numpy as np

_FLOAT_DTYPES = (np.float32, np.float64)


def _as_float_array(name: str, value) -> np.ndarray:
    if isinstance(value, np.ndarray):
        if value.dtype.type not in _FLOAT_DTYPES:
            raise TypeError(f"{name}: dtype {value.dtype} is not allowed; pass float32 or float64")
        return value.astype(np.float64, copy=False)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected an array of numbers, got {type(value).__name__}") from exc
    return arr


def _check_finite(name: str, arr: np.ndarray) -> None:
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or Inf; all values must be finite")


def _per_row(name: str, value) -> np.ndarray:
    """Scalar or (N,) finite float64 -> (N,)."""
    arr = _as_float_array(name, value)
    if arr.ndim > 1:
        raise ValueError(f"{name}: shape {arr.shape} is not allowed; pass a scalar or (N,)")
    arr = np.atleast_1d(arr)
    _check_finite(name, arr)
    return arr


def _triples(name: str, value) -> np.ndarray:
    """(N,3) or (3,) finite float64 rows."""
    arr = _as_float_array(name, value)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name}: shape {tuple(np.shape(value))} is not allowed; pass (N, 3) or (3,)")
    _check_finite(name, arr)
    return arr


per_row = _per_row  # scalar or (N,) finite float64 -> (N,)
triples = _triples  # (N, 3) or (3,) finite float64


def directions(name: str, value) -> np.ndarray:
    """(N,3) or (3,) -> (N,3) unit float64 vectors."""
    arr = _triples(name, value)
    norm = np.linalg.norm(arr, axis=1)
    if np.any(norm == 0):
        raise ValueError(f"{name}: contains a zero-length direction; directions must be non-zero")
    return arr / norm[:, None]


def offsets(name: str, value) -> np.ndarray:
    """Scalar or (N,) h in [-1, 1] -> (N,) float64."""
    arr = _per_row(name, value)
    if np.any(np.abs(arr) > 1.0 + 1e-6):
        raise ValueError(f"{name}: values must lie in [-1, 1] (the offset across the fibre)")
    return np.clip(arr, -1.0, 1.0)


def normals(name: str, value) -> np.ndarray:
    """(N,3) or (3,) curve normals -> (N,3) float64; zero rows are allowed (Cycles' fallback frame)."""
    return _triples(name, value)


def coverages(name: str, value) -> np.ndarray:
    """Scalar or (N,) pixel coverage (half a pixel in units of the fibre radius), > 0."""
    arr = _per_row(name, value)
    if np.any(arr <= 0.0):
        raise ValueError(f"{name}: values must be > 0 (half a pixel's footprint in units of the radius)")
    return arr


def unit_interval(name: str, value) -> np.ndarray:
    """Scalar or (N,) values in [0, 1] -> (N,) float64."""
    arr = _per_row(name, value)
    if np.any(arr < 0.0) or np.any(arr > 1.0):
        raise ValueError(f"{name}: values must lie in [0, 1]")
    return arr


fractions = unit_interval  # the name the model zoo uses


def flags(name: str, value) -> np.ndarray:
    """Scalar or (N,) booleans -> (N,) float64 of 0 / 1."""
    arr = np.asarray(value)
    if arr.dtype != bool:
        if not (np.issubdtype(arr.dtype, np.integer) and np.all((arr == 0) | (arr == 1))):
            raise TypeError(f"{name}: expected booleans (True / False), got dtype {arr.dtype}")
    if arr.ndim > 1:
        raise ValueError(f"{name}: shape {arr.shape} is not allowed; pass a scalar or (N,)")
    return np.atleast_1d(arr).astype(np.float64)


def uniforms(name: str, value) -> np.ndarray:
    """(N,3) or (3,) uniform numbers in [0, 1]."""
    arr = _triples(name, value)
    if np.any(arr < 0.0) or np.any(arr > 1.0):
        raise ValueError(f"{name}: values must lie in [0, 1]")
    return arr


def broadcast_rows(**arrays: np.ndarray) -> list[np.ndarray]:
    """Broadcasts arrays whose first axis is N or 1 to a common N (C-contiguous copies)."""
    lengths = {len(a) for a in arrays.values()}
    n = max(lengths)
    out = []
    for name, a in arrays.items():
        if len(a) not in (1, n):
            sizes = ", ".join(f"{k}: {len(v)}" for k, v in arrays.items())
            raise ValueError(f"{name}: {len(a)} rows do not match the others ({sizes}); pass N rows or 1")
        if len(a) == 1 and n != 1:
            a = np.repeat(a, n, axis=0)
        out.append(np.ascontiguousarray(a, dtype=np.float64))
    return out


def real(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}: expected a number, got {type(value).__name__}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name}: must be finite, got {value}")
    return v


def color(name: str, value) -> tuple[float, float, float]:
    """An RGB triple, or a number for grey."""
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        v = real(name, value)
        return (v, v, v)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected an RGB triple of numbers, got {value!r}") from exc
    if arr.shape != (3,):
        raise ValueError(f"{name}: expected an RGB triple (3 numbers), got shape {arr.shape}")
    _check_finite(name, arr)
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def choice(name: str, value, allowed: Iterable[str]) -> str:
    allowed = list(allowed)
    if not isinstance(value, str):
        raise TypeError(f"{name}: expected one of {allowed}, got {value!r}")
    if value not in allowed:
        raise ValueError(f"{name}={value!r} is not allowed; choose one of {allowed}")
    return value


def keywords(function: str, given: dict, allowed: Iterable[str]) -> None:
    allowed = list(allowed)
    for key in given:
        if key not in allowed:
            close = difflib.get_close_matches(key, allowed, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise TypeError(f"{function}() got an unknown keyword {key!r}{hint}; allowed: {', '.join(allowed)}")


def in_range(name: str, value, lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False) -> float:
    """A real number in [lo, hi] (or open at either end); the error names the range."""
    v = real(name, value)
    below = v <= lo if lo_open else v < lo
    above = v >= hi if hi_open else v > hi
    if below or above:
        left = "(" if lo_open else "["
        right = ")" if hi_open else "]"
        raise ValueError(f"{name}={value!r} is out of range; allowed: {left}{lo:g}, {hi:g}{right}")
    return v


# Huang's `tolerance` (relative error target of its eval and albedo, docs/huang.md §4): the range
# its constructor and the per-call keyword accept.
@functools.cache
def huang_tolerance_range() -> tuple[float, float]:
    """Huang's tolerance range: its row in the options table beside C++ HuangHairParams (params/huang.h)."""
    from . import _core  # lazily: this module is imported before the core is loaded

    return next((p["min"], p["max"]) for p in _core.huang_option_schema() if p["name"] == "tolerance")


def huang_tolerance(value) -> float:
    """Huang's `tolerance`: a number in huang_tolerance_range(); the error names the range."""
    return in_range("tolerance", value, *huang_tolerance_range())
