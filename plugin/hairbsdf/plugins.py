"""Bring your own hair BSDF: plugins in shared libraries (the C ABI of
bsdf_core/include/hairbsdf/plugin.h) and BSDFs written in NumPy (`python_bsdf`).

    kk = hairbsdf.load_plugin("build/cpp/examples/plugins/kajiya_kay/hairbsdf_plugin_kajiya_kay.so")
    hair = kk(exponent=80, color=(0.4, 0.2, 0.1))   # a Closure, like principled_hair(...)
    hairbsdf.test_plugin(kk, exponent=80)            # furnace, weight = eval/pdf, chi2, fuzzing

Walk-through: docs/plugins.md.
"""

from __future__ import annotations

import math
import os
from typing import Callable, NamedTuple

import numpy as np

from . import _core
from . import _validate as check
from ._param_docs import FLOAT, RGB
from .closure import Closure, SampleResult

PluginError = _core.PluginError
PLUGIN_ABI_VERSION = _core.PLUGIN_ABI_VERSION


class ParamSpec(NamedTuple):
    """One parameter of a plugin's schema."""

    name: str
    type: str          # FLOAT or RGB (_param_docs: the kinds' names)
    default: object    # float, or an RGB tuple
    min: float         # inclusive range (every channel of an RGB)
    max: float
    description: str


def _fmt(x: float) -> str:
    return f"{x:g}"


class PluginConstructor:
    """What `load_plugin` returns: call it with the schema's parameters as keywords to get a
    Closure. `params` is the schema (name -> ParamSpec)."""

    def __init__(self, library: _core.PluginLibrary):
        self._library = library
        self.name: str = library.name
        self.path: str = library.path
        self.description: str = library.description
        self.abi_version: int = library.abi_version
        self.has_lobes: bool = library.has_lobes
        self.params: dict[str, ParamSpec] = {}
        for p in library.params:
            default = tuple(p["default"]) if p["type"] == RGB else float(p["default"][0])
            self.params[p["name"]] = ParamSpec(p["name"], p["type"], default, p["min"], p["max"], p["description"])
        lines = [f"{self.name}(**params) -> Closure: {self.description or 'hair BSDF plugin'}", "", "Parameters:"]
        for p in self.params.values():
            lines.append(f"  {p.name} ({p.type}, default {p.default}, range [{_fmt(p.min)}, {_fmt(p.max)}])"
                         f"{': ' + p.description if p.description else ''}")
        self.__doc__ = "\n".join(lines)

    def __repr__(self) -> str:
        return f"<hairbsdf plugin {self.name!r} from {self.path!r}, params: {', '.join(self.params)}>"

    def values(self, **params) -> dict:
        """The full parameter set (defaults filled in), validated: errors name the parameter
        and its allowed range."""
        check.keywords(self.name, params, self.params)
        out = {name: spec.default for name, spec in self.params.items()}
        for name, value in params.items():
            spec = self.params[name]
            allowed = f"allowed [{_fmt(spec.min)}, {_fmt(spec.max)}]"
            if spec.type == FLOAT:
                v = check.real(name, value)
                if not spec.min <= v <= spec.max:
                    raise ValueError(f"{name}={value!r} is out of range; {allowed}")
                out[name] = v
            else:
                c = check.color(name, value)
                for channel, v in zip("rgb", c):
                    if not spec.min <= v <= spec.max:
                        raise ValueError(f"{name}: channel {channel} = {v:g} is out of range; {allowed} "
                                         f"for each channel")
                out[name] = c
        return out

    def __call__(self, **params) -> Closure:
        values = self.values(**params)
        flat = []
        for name, spec in self.params.items():
            v = values[name]
            flat.extend(v if spec.type == RGB else (v, v, v))
        core = self._library.create(flat)
        shown = ", ".join(f"{k}={v!r}" for k, v in params.items())
        return Closure(core, f"{self.name}({shown})")


def load_plugin(path) -> PluginConstructor:
    """Loads a hair BSDF plugin (a shared library built against hairbsdf/plugin.h) and returns
    its constructor. Raises PluginError when the file is missing, is not a loadable library,
    lacks the entry symbol or a function, was built for another ABI version, or has a bad
    parameter schema; the message says which."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path: expected a file path (str or os.PathLike), got {type(path).__name__}")
    return PluginConstructor(_core.load_plugin(os.fspath(path)))


# --- Python-defined BSDFs ------------------------------------------------------------------------

class PythonBSDF:
    """A BSDF from NumPy-vectorised callables, with the methods of Closure that the testing
    helpers use (eval, eval_lobes, pdf, sample, albedo). Made by `python_bsdf`."""

    def __init__(self, eval: Callable, sample: Callable | None, pdf: Callable | None, name: str):
        self._eval = eval
        self._sample = sample
        self._pdf = pdf
        self.name = name
        self.model_params: list[dict] = [{"model": "python", "name": name}]

    def __repr__(self) -> str:
        sampler = "its own sampler" if self._sample else "uniform sphere sampling"
        return f"python_bsdf(name={self.name!r}, {sampler})"

    @staticmethod
    def _rows(**arrays):
        return check.broadcast_rows(**arrays)

    def _call_eval(self, wo, wi, h) -> np.ndarray:
        wo, wi, h = self._rows(wo=check.directions("wo", wo), wi=check.directions("wi", wi), h=check.offsets("h", h))
        out = np.asarray(self._eval(wo, wi, h), dtype=np.float64)
        n = len(wo)
        if out.shape not in ((n, 3), (n, 4, 3)):
            raise ValueError(f"{self.name}: eval returned shape {out.shape}; it must return (N, 3) or per lobe "
                             f"(N, 4, 3) for N = {n} rows")
        return out

    def eval(self, wo, wi, h) -> np.ndarray:
        """BSDF value including the cosine factor, (N, 3)."""
        out = self._call_eval(wo, wi, h)
        return out.sum(axis=1) if out.ndim == 3 else out

    def eval_lobes(self, wo, wi, h) -> np.ndarray:
        """Per-lobe values (N, 4, 3); an eval that returns (N, 3) is reported as lobe R."""
        out = self._call_eval(wo, wi, h)
        if out.ndim == 3:
            return out
        lobes = np.zeros((len(out), 4, 3))
        lobes[:, 0] = out
        return lobes

    def pdf(self, wo, wi, h) -> np.ndarray:
        """Density of `sample` per unit solid angle, (N,)."""
        wo, wi, h = self._rows(wo=check.directions("wo", wo), wi=check.directions("wi", wi), h=check.offsets("h", h))
        if self._pdf is None:
            return np.full(len(wo), 1.0 / (4.0 * math.pi))
        out = np.asarray(self._pdf(wo, wi, h), dtype=np.float64)
        if out.shape != (len(wo),):
            raise ValueError(f"{self.name}: pdf returned shape {out.shape}; it must return (N,) for N = {len(wo)}")
        return out

    def sample(self, wo, h, u) -> SampleResult:
        """Samples wi from 3 uniforms per row: the user's sampler (wi, weight, pdf, lobe), or
        uniform directions on the sphere with weight = eval / pdf and lobe 0."""
        wo, h, u = self._rows(wo=check.directions("wo", wo), h=check.offsets("h", h), u=check.uniforms("u", u))
        n = len(wo)
        if self._sample is None:
            z = 1.0 - 2.0 * u[:, 0]
            r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
            phi = 2.0 * math.pi * u[:, 1]
            wi = np.stack([z, r * np.cos(phi), r * np.sin(phi)], axis=1)
            pdf = np.full(n, 1.0 / (4.0 * math.pi))
            weight = self.eval(wo, wi, h) / pdf[:, None]
            return SampleResult(wi, weight, pdf, np.zeros(n, dtype=np.int32))
        result = self._sample(wo, h, u)
        if not isinstance(result, SampleResult):
            if not isinstance(result, tuple) or len(result) != 4:
                raise ValueError(f"{self.name}: sample must return (wi, weight, pdf, lobe) or a SampleResult")
            result = SampleResult(*result)
        wi, weight, pdf, lobe = (np.asarray(a) for a in result)
        for label, a, shape in (("wi", wi, (n, 3)), ("weight", weight, (n, 3)), ("pdf", pdf, (n,)),
                                ("lobe", lobe, (n,))):
            if a.shape != shape:
                raise ValueError(f"{self.name}: sample returned {label} of shape {a.shape}; expected {shape}")
        return SampleResult(wi.astype(np.float64), weight.astype(np.float64), pdf.astype(np.float64),
                            lobe.astype(np.int32))

    def albedo(self, wo, h, *, theta_panels: int = 256, phi_panels: int = 256) -> np.ndarray:
        """Directional albedo by composite Gauss-Legendre quadrature of eval, (N, 3)."""
        from .testing import albedo_quadrature

        wo, h = self._rows(wo=check.directions("wo", wo), h=check.offsets("h", h))
        return np.array([albedo_quadrature(self, w, float(x), theta_panels=theta_panels, phi_panels=phi_panels)
                         for w, x in zip(wo, h)])


def python_bsdf(eval: Callable, sample: Callable | None = None, pdf: Callable | None = None, *,
                name: str = "python_bsdf") -> PythonBSDF:
    """Wraps NumPy-vectorised callables as a BSDF usable with hairbsdf.testing and test_plugin.

    eval(wo, wi, h) -> (N, 3) value including the cosine factor (or (N, 4, 3) per lobe R, TT,
    TRT, TRRT+); wo, wi are (N, 3) unit vectors in the fibre frame, h is (N,).
    sample(wo, h, u) -> (wi, weight, pdf, lobe) with u (N, 3) uniforms; pdf(wo, wi, h) -> (N,).
    Give sample and pdf together, or neither (then directions are sampled uniformly on the
    sphere, pdf = 1/(4 pi)). It is meant for BSDF-level work, not for rendering speed.
    """
    for label, fn in (("eval", eval), ("sample", sample), ("pdf", pdf)):
        if fn is not None and not callable(fn):
            raise TypeError(f"{label}: expected a callable, got {type(fn).__name__}")
    if eval is None:
        raise TypeError("eval: a callable eval(wo, wi, h) -> (N, 3) is required")
    if (sample is None) != (pdf is None):
        missing = "pdf" if pdf is None else "sample"
        raise ValueError(f"{missing}: give sample and pdf together (the pdf must be the density sample draws "
                         f"with), or neither for uniform sphere sampling")
    if not isinstance(name, str) or not name:
        raise TypeError("name: expected a non-empty string")
    return PythonBSDF(eval, sample, pdf, name)


def test_plugin(target, *, options=None, verbose: bool = True, **params):
    """Runs the standard battery (hairbsdf.testing.battery) on a plugin and prints a verdict per
    check: white furnace (albedo <= 1.01), sampled furnace = albedo, weight = eval/pdf, sample
    pdf = pdf(), pdf normalisation, chi-square of sample against pdf, and fuzzing for NaN/Inf.

    `target` is a plugin path, a constructor from load_plugin (called with **params), or a
    ready closure (a Closure or python_bsdf; no params then). `options` is a
    testing.BatteryOptions. Returns a testing.BatteryResult, truthy when every check passed.
    """
    from .testing import battery

    if isinstance(target, (str, os.PathLike)):
        target = load_plugin(target)
    if isinstance(target, PluginConstructor):
        closure = target(**params)
        name = f"plugin {target.name!r} ({target.path})"
        name += f" with {', '.join(f'{k}={v!r}' for k, v in params.items())}" if params else " with defaults"
    elif callable(target) and not hasattr(target, "sample"):
        closure = target(**params)
        name = repr(closure)
    else:
        if params:
            raise TypeError(f"params {sorted(params)}: a ready closure takes no parameters; pass its constructor")
        if not all(hasattr(target, m) for m in ("eval", "sample", "pdf")):
            raise TypeError(f"target: expected a plugin path, a plugin constructor or a closure with eval, sample "
                            f"and pdf, got {type(target).__name__}")
        closure, name = target, repr(target)
    return battery(closure, name=name, options=options, verbose=verbose)


test_plugin.__test__ = False  # not a pytest test when imported into a test module
