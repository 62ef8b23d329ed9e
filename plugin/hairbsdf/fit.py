"""`hairbsdf fit`: least-squares fit of a model's free parameters to a target BSDF over a gonio
grid (docs/fit.md).

The objective is the solid-angle weighted L2 distance between the two far-field values (RGB,
cosine included, averaged over h where the model depends on h) over (theta_o, theta_i,
delta_phi): sum_k w_k |f_model - f_target|^2 with w_k from gonio.GonioGrid. Errors are reported
relative to the target: |f - g| / |g| in that norm, in total and per lobe where the model's lobes
are the same light paths as Principled Hair's (R, TT, TRT, TRRT+).

Every fittable model's free parameters, bounds and fixed keywords are declared here, in FIT_MODELS:
the search ranges (a fitting choice, narrower than the models' ranges) and the starts or fixed values
that differ from a model's defaults; the others are the defaults, read from the model's table."""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import gonio
from ._deps import require
from .gonio import H_NODES
from .closure import LOBES
from .principled import PRINCIPLED_HAIR_DEFAULTS as PRINCIPLED
from .spec import ALIASES, CONSTRUCTORS, SpecError, build, format_spec, parse_spec
from .zoo import model_defaults

DEON, EPIC, KAJIYA_KAY, MARSCHNER, SCHEUERMANN, YAN_FUR = (
    model_defaults(m) for m in ("deon", "epic", "kajiya_kay", "marschner", "scheuermann", "yan_fur"))


# --- Free parameters ------------------------------------------------------------------------------

@dataclass(frozen=True)
class FreeParam:
    """One fitted number. `log`: the optimiser works on ln(value) (exponents spanning decades)."""

    name: str
    lower: float
    upper: float
    start: float
    log: bool = False
    doc: str = ""

    def to_internal(self, value: float) -> float:
        return math.log(value) if self.log else float(value)

    def from_internal(self, x: float) -> float:
        # clipped: exp(ln(upper)) may round above the constructor's range
        return min(max(math.exp(x) if self.log else float(x), self.lower), self.upper)


@dataclass(frozen=True)
class FitModel:
    """A fittable model: its constructor, free parameters (bounds, start), the map from free
    values to constructor keywords, the keywords held fixed, and which Principled Hair lobe each
    of its eval_lobes slots is (None: no counterpart; per-lobe errors only where all are named)."""

    name: str
    free: tuple[FreeParam, ...]
    to_kwargs: Callable[[dict], dict]
    fixed: dict = field(default_factory=dict)
    lobe_of_slot: tuple = (None, None, None, None)
    depends_on_h: bool = False
    note: str = ""

    @property
    def constructor(self) -> str:
        """The hairbsdf constructor it fits: its short name's (spec.ALIASES)."""
        return ALIASES.get(self.name, self.name)

    def kwargs(self, values: dict) -> dict:
        return {**self.fixed, **self.to_kwargs(values)}

    def closure(self, values: dict):
        import hairbsdf
        return getattr(hairbsdf, self.constructor)(**self.kwargs(values))


def _rgb(values: dict, key: str) -> tuple:
    return tuple(values[f"{key}.{c}"] for c in "rgb")


def _rgb_params(key: str, lower: float, upper: float, start, doc: str) -> tuple:
    return tuple(FreeParam(f"{key}.{c}", lower, upper, s, doc=doc) for c, s in zip("rgb", start))


def _kajiya_kay_kwargs(v):
    # specular is grey (a surface reflection); diffuse = (1 - specular) * diffuse_scale keeps
    # diffuse + specular <= 1 per channel, the constructor's energy bound, inside box bounds.
    ks = v["specular"]
    return {"diffuse": tuple((1.0 - ks) * d for d in _rgb(v, "diffuse_scale")), "specular": (ks, ks, ks),
            "exponent": v["exponent"]}


def _scheuermann_kwargs(v):
    # primary highlight grey (R is uncoloured), secondary = (1 - primary) * secondary_scale.
    p = v["primary"]
    return {"primary_color": (p, p, p), "secondary_color": tuple((1.0 - p) * s for s in _rgb(v, "secondary_scale")),
            "primary_exponent": v["primary_exponent"], "secondary_exponent": v["secondary_exponent"],
            "primary_shift": v["primary_shift"], "secondary_shift": v["secondary_shift"]}


# Starts that reparametrize a default: a grey free value is the default's first channel, and a
# "scale" start gives the default colour back through the model's kwargs map.
_KK_SPECULAR = KAJIYA_KAY["specular"][0]
_SCHEUERMANN_PRIMARY = SCHEUERMANN["primary_color"][0]


def _defaults_of(model: dict, *names: str) -> dict:
    """Fixed keywords held at the model's defaults."""
    return {name: model[name] for name in names}


FIT_MODELS: dict[str, FitModel] = {m.name: m for m in (
    FitModel(
        "epic",
        (*_rgb_params("base_color", 0.0, 1.0, EPIC["base_color"], "C per channel"),
         FreeParam("specular", 0.0, 1.0, EPIC["specular"], doc="R scale / 0.5"),
         FreeParam("roughness", 0.05, 1.0, EPIC["roughness"], doc="beta_R = roughness^2"),
         FreeParam("shift", -0.25, 0.25, EPIC["shift"], doc="alpha_R = -2 shift, in sin theta"),
         FreeParam("scatter", 0.0, 1.0, EPIC["scatter"], doc="multiple-scattering fake (shadow = 1)")),
        lambda v: {"base_color": _rgb(v, "base_color"), "specular": v["specular"], "roughness": v["roughness"],
                   "shift": v["shift"], "scatter": v["scatter"]},
        fixed=_defaults_of(EPIC, "variant"), lobe_of_slot=(*LOBES[:3], None),
        note="slot 3 (multiple-scattering fake) has no Principled Hair counterpart"),
    FitModel(
        "kajiya_kay",
        (FreeParam("specular", 0.0, 1.0, _KK_SPECULAR, doc="K_s, grey"),
         *_rgb_params("diffuse_scale", 0.0, 1.0, tuple(d / (1.0 - _KK_SPECULAR) for d in KAJIYA_KAY["diffuse"]),
                      "K_d = (1 - K_s) x this, per channel"),
         FreeParam("exponent", 1.0, 10_000.0, KAJIYA_KAY["exponent"], log=True, doc="p, fitted in ln p")),
        _kajiya_kay_kwargs, note="specular / diffuse are not Principled Hair's light paths: total error only"),
    FitModel(
        "scheuermann",
        (FreeParam("primary", 0.0, 1.0, _SCHEUERMANN_PRIMARY, doc="primary colour, grey"),
         *_rgb_params("secondary_scale", 0.0, 1.0,
                      tuple(s / (1.0 - _SCHEUERMANN_PRIMARY) for s in SCHEUERMANN["secondary_color"]),
                      "secondary = (1 - primary) x this"),
         FreeParam("primary_exponent", 1.0, 10_000.0, SCHEUERMANN["primary_exponent"], log=True, doc="fitted in ln p"),
         FreeParam("secondary_exponent", 1.0, 10_000.0, SCHEUERMANN["secondary_exponent"], log=True,
                   doc="fitted in ln p"),
         FreeParam("primary_shift", -0.5, 0.5, SCHEUERMANN["primary_shift"]),
         FreeParam("secondary_shift", -0.5, 0.5, SCHEUERMANN["secondary_shift"])),
        _scheuermann_kwargs, fixed=_defaults_of(SCHEUERMANN, "shift_texture", "noise"),
        note="two shifted specular cones, no transmission: total error only"),
    FitModel(
        "marschner",
        (*_rgb_params("sigma_a", 0.0, 40.0, MARSCHNER["sigma_a"], "absorption per channel"),
         FreeParam("alpha_r", -0.35, 0.35, MARSCHNER["alpha_r"], doc="R shift, radians"),
         FreeParam("beta_r", 0.02, 0.7, MARSCHNER["beta_r"], doc="R width, radians"),
         FreeParam("glint_scale", 0.0, 5.0, MARSCHNER["glint_scale"], doc="k_G")),
        lambda v: {"sigma_a": _rgb(v, "sigma_a"), "alpha_r": v["alpha_r"], "beta_r": v["beta_r"],
                   "glint_scale": v["glint_scale"]},
        fixed={**_defaults_of(MARSCHNER, "eta"), "eccentricity": 1.0}, lobe_of_slot=(*LOBES[:3], None),
        note="circular fibre (eccentricity 1) like Principled Hair; no TRRT+ lobe"),
    FitModel(
        "deon",
        # sigma_a starts at Principled Hair's default absorption (d'Eon's own is derived from melanin)
        (*_rgb_params("sigma_a", 0.0, 40.0, PRINCIPLED["absorption_coefficient"], "absorption per channel"),
         FreeParam("roughness", 0.03, 0.6, DEON["roughness"], doc="beta_R, radians"),
         FreeParam("tilt", -0.2, 0.2, DEON["tilt"], doc="cuticle tilt, radians")),
        lambda v: {"sigma_a": _rgb(v, "sigma_a"), "roughness": v["roughness"], "tilt": v["tilt"]},
        fixed=_defaults_of(DEON, "eta"), lobe_of_slot=LOBES),
    FitModel(
        "principled",
        (FreeParam("melanin", 0.0, 0.999, PRINCIPLED["melanin"]),
         FreeParam("melanin_redness", 0.0, 1.0, PRINCIPLED["melanin_redness"]),
         FreeParam("roughness", 0.05, 1.0, PRINCIPLED["roughness"]),
         FreeParam("radial_roughness", 0.05, 1.0, PRINCIPLED["radial_roughness"]),
         FreeParam("offset", -0.2, 0.2, PRINCIPLED["offset"], doc="radians")),
        lambda v: dict(v), fixed={"parametrization": "melanin"}, lobe_of_slot=LOBES,
        depends_on_h=True, note=f"Chiang (Principled Hair) in the melanin parametrization, coat {PRINCIPLED['coat']:g}, "
                                f"IOR {PRINCIPLED['ior']:g}"),
    FitModel(
        "yan_fur",
        (*_rgb_params("cortex_absorption", 0.0, 40.0, YAN_FUR["cortex_absorption"], "sigma_ca per channel"),
         FreeParam("roughness", 0.05, 1.0, YAN_FUR["roughness"], doc="Chiang's beta_m"),
         FreeParam("radial_roughness", 0.05, 1.0, YAN_FUR["radial_roughness"], doc="Chiang's beta_n"),
         FreeParam("alpha", -0.2, 0.2, YAN_FUR["alpha"], doc="cuticle tilt, radians")),
        lambda v: {"cortex_absorption": _rgb(v, "cortex_absorption"), "roughness": v["roughness"],
                   "radial_roughness": v["radial_roughness"], "alpha": v["alpha"]},
        fixed=_defaults_of(YAN_FUR, "eta"), lobe_of_slot=(*LOBES, None, None), depends_on_h=True,
        note=f"the medulla at Yan 2015's fit (kappa {YAN_FUR['medulla_ratio']:g}); TTs / TRTs have no Principled "
             "Hair counterpart (in the total only); each evaluation with a new cortex_absorption builds a table (~1 s)"),
)}


def fit_model(name: str) -> FitModel:
    # a constructor's name or short name (spec.ALIASES) -> the model fitting that constructor
    by_constructor = {m.constructor: key for key, m in FIT_MODELS.items()}
    key = name if name in FIT_MODELS else by_constructor.get(ALIASES.get(name, name), name)
    if key not in FIT_MODELS:
        raise ValueError(f"unknown fit model {name!r}; choose one of {', '.join(FIT_MODELS)}")
    return FIT_MODELS[key]


# --- Errors -----------------------------------------------------------------------------------------

def relative_errors(model_lobes: np.ndarray, target_lobes: np.ndarray, weights: np.ndarray,
                    lobe_of_slot=(None, None, None, None)) -> dict:
    """{"total": |f - g| / |g|, and per Principled lobe name |f_p - g_p| / |g| (None where the model's
    slots do not all have a Principled counterpart)}; norms are sqrt(sum w |.|^2) over the grid."""
    f, g = model_lobes.sum(axis=1), target_lobes.sum(axis=1)
    norm = math.sqrt(float(np.sum(weights[:, None] * g * g))) or 1.0

    def dist(a, b):
        return math.sqrt(float(np.sum(weights[:, None] * (a - b) ** 2))) / norm

    out = {"total": dist(f, g)}
    comparable = all(s is not None for s in lobe_of_slot[:3])
    for p, lobe in enumerate(LOBES):
        slots = [i for i, s in enumerate(lobe_of_slot) if s == lobe]
        # None: the model's lobes are other light paths, or it has no such lobe
        out[lobe] = dist(model_lobes[:, slots].sum(axis=1), target_lobes[:, p]) if comparable and slots else None
    return out


# --- The fit ------------------------------------------------------------------------------------------

@dataclass
class FitResult:
    model: str
    target: str                 # the target's canonical spec
    spec: str                   # the fitted model's canonical spec
    parameters: dict            # constructor keywords of the fit (free and fixed)
    free_values: dict           # free parameter name -> value
    error: dict                 # relative errors at the fit (relative_errors)
    start_error: dict           # ... at the declared start
    evaluations: int
    seconds: float
    message: str
    grid: dict

    def as_json(self) -> dict:
        return dict(self.__dict__)


class _Progress:
    """Prints a line to stderr at most every `every` seconds."""

    def __init__(self, enabled: bool, every: float = 2.0):
        self.enabled, self.every, self.last = enabled, every, time.monotonic()

    def __call__(self, text: str, force: bool = False):
        now = time.monotonic()
        if self.enabled and (force or now - self.last >= self.every):
            self.last = now
            print(f"[fit] {text}", file=sys.stderr, flush=True)


def fit(target: str, model: str, *, grid: int = 24, h_count: int = H_NODES, starts: int = 1, seed: int = 0,
        max_evaluations: int = 300, start: dict | None = None, progress: bool = False) -> FitResult:
    """Fits `model` (a FIT_MODELS name) to the `target` spec. The first start is the declared
    start (or `start`, free parameter name -> value, overriding it); further starts are uniform in
    the bounds, drawn with `seed`. Returns the best of all starts."""
    least_squares = require("scipy.optimize", "tools", "hairbsdf fit").least_squares

    fm = fit_model(model)
    target_name, target_kwargs = parse_spec(target)
    target_closure = build(target)
    g = gonio.GonioGrid.make(grid)
    report = _Progress(progress)
    t0 = time.monotonic()
    target_h = gonio.depends_on_h(target_name, target_kwargs)
    report(f"evaluating the target on {len(g)} direction pairs" + (f" x {h_count} h nodes" if target_h else ""),
           force=True)
    target_lobes = gonio.far_field_lobes(target_closure, g.wo, g.wi, h_count, target_h)
    target_value = target_lobes.sum(axis=1)
    sqrt_w = np.sqrt(g.weights)[:, None]
    norm = math.sqrt(float(np.sum(g.weights[:, None] * target_value ** 2))) or 1.0

    names = [p.name for p in fm.free]
    lower = np.array([p.to_internal(p.lower) for p in fm.free])
    upper = np.array([p.to_internal(p.upper) for p in fm.free])
    unknown = set(start or {}) - set(names)
    if unknown:
        raise ValueError(f"start: unknown free parameters {sorted(unknown)}; {fm.name} has {names}")
    first = {p.name: (start or {}).get(p.name, p.start) for p in fm.free}
    for p in fm.free:
        if not p.lower <= first[p.name] <= p.upper:
            raise ValueError(f"start: {p.name}={first[p.name]} is outside [{p.lower}, {p.upper}]")
    rng = np.random.default_rng(seed)
    x_starts = [np.array([p.to_internal(first[p.name]) for p in fm.free])]
    x_starts += [rng.uniform(lower, upper) for _ in range(starts - 1)]

    def values_of(x):
        return {n: p.from_internal(float(xi)) for n, p, xi in zip(names, fm.free, x)}

    def model_lobes(x):
        return gonio.far_field_lobes(fm.closure(values_of(x)), g.wo, g.wi, h_count, fm.depends_on_h)

    count = [0, 0]  # evaluations in this start, in all starts
    best = {"cost": math.inf, "x": x_starts[0]}  # the best point seen in any evaluation

    class _Budget(Exception):
        pass

    def residuals(x, which):
        if count[0] >= max_evaluations:
            raise _Budget  # this start's evaluations (finite-difference ones included) are spent
        count[0] += 1
        count[1] += 1
        r = (sqrt_w * (model_lobes(x).sum(axis=1) - target_value) / norm).ravel()
        cost = float(r @ r)
        if cost < best["cost"]:
            best.update(cost=cost, x=np.array(x, float))
        report(f"{fm.name} start {which}/{len(x_starts)}: {count[0]} evaluations, "
               f"relative error {math.sqrt(best['cost']):.4g}")
        return r

    messages = []
    for k, x0 in enumerate(x_starts, 1):
        count[0] = 0
        try:
            sol = least_squares(residuals, x0, bounds=(lower, upper), args=(k,), x_scale="jac", diff_step=1e-5,
                                method="trf")
            messages.append(str(sol.message))
        except _Budget:
            messages.append(f"stopped after {max_evaluations} evaluations (--max-evaluations)")
    evaluations = count[1]
    report(f"{fm.name}: done, {evaluations} evaluations in {time.monotonic() - t0:.1f} s, "
           f"relative error {math.sqrt(best['cost']):.4g}", force=True)
    best_x = best["x"]

    free_values = values_of(best_x)
    kwargs = fm.kwargs(free_values)
    err = relative_errors(model_lobes(best_x), target_lobes, g.weights, fm.lobe_of_slot)
    start_err = relative_errors(model_lobes(x_starts[0]), target_lobes, g.weights, fm.lobe_of_slot)
    return FitResult(
        model=fm.name, target=format_spec(target_name, target_kwargs), spec=format_spec(fm.constructor, kwargs),
        parameters=kwargs, free_values=free_values, error=err, start_error=start_err, evaluations=evaluations,
        seconds=time.monotonic() - t0, message="; ".join(messages),
        grid={"theta": grid, "delta_phi": 2 * grid, "h_nodes": h_count, "points": len(g)})


# --- Text output -------------------------------------------------------------------------------------

def format_errors(err: dict) -> str:
    parts = [f"total {err['total']:.4f}"]
    parts += [f"{lobe} {err[lobe]:.4f}" for lobe in LOBES if err.get(lobe) is not None]
    return ", ".join(parts)


def describe_models() -> str:
    lines = ["Fittable models, their free parameters [bounds] (start) and fixed keywords:"]
    for fm in FIT_MODELS.values():
        lines.append(f"\n  {fm.name} ({fm.constructor}){': ' + fm.note if fm.note else ''}")
        for p in fm.free:
            lines.append(f"    {p.name:22s} [{p.lower:g}, {p.upper:g}] ({p.start:g}){'  ' + p.doc if p.doc else ''}")
        if fm.fixed:
            lines.append("    fixed: " + ", ".join(f"{k}={v!r}" for k, v in fm.fixed.items()))
    return "\n".join(lines) + "\n"


def _text_report(res: FitResult) -> str:
    lines = [f"target : {res.target}", f"model  : {res.model}", f"fit    : {res.spec}", "free parameters:"]
    lines += [f"  {k:22s} {v:.6g}" for k, v in res.free_values.items()]
    lines.append("relative L2 error (solid-angle weighted, of the target's norm):")
    lines.append(f"  at the start: {format_errors(res.start_error)}")
    lines.append(f"  at the fit  : {format_errors(res.error)}")
    lines.append(f"{res.evaluations} evaluations, {res.seconds:.1f} s; grid {res.grid}; {res.message}")
    return "\n".join(lines) + "\n"


# --- Command line --------------------------------------------------------------------------------------

def build_parser(prog: str = "hairbsdf fit") -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog=prog, formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Least-squares fit of a model's free parameters to a target hair BSDF over a gonio grid "
                    "(theta_o, theta_i, delta_phi; h-averaged far field), weighted by solid angle.",
        epilog="Specs are parsed, never evaluated: " + _allowed() + ".\n"
               "principled_hair with melanin= and no parametrization= uses parametrization='melanin'.\n\n"
               "Examples:\n"
               "  hairbsdf fit --target \"principled_hair(melanin=0.6)\" --model epic\n"
               "  hairbsdf fit --target \"principled_hair(melanin=0.3, melanin_redness=0.9)\" --model deon --json\n"
               "  hairbsdf fit --list\n\nDocs: docs/fit.md.")
    ap.add_argument("--target", metavar="SPEC", help="the BSDF to fit, a spec such as \"principled_hair(melanin=0.6)\"")
    ap.add_argument("--model", metavar="NAME", help="the model to fit: " + ", ".join(FIT_MODELS))
    ap.add_argument("--list", action="store_true", help="list the fittable models and their free parameters")
    ap.add_argument("--grid", type=int, default=24, metavar="N",
                    help="theta cells in (-90, 90) degrees for theta_o and theta_i; delta_phi gets twice as many "
                         "(default 24: 27648 direction pairs)")
    ap.add_argument("--h-nodes", type=int, default=H_NODES, metavar="K",
                    help="Gauss-Legendre nodes in h for h-dependent BSDFs such as Principled Hair (default 32: "
                         "2e-4 of the far field at radial roughness 0.3; raise it for a smaller radial roughness)")
    ap.add_argument("--starts", type=int, default=1, metavar="K",
                    help="optimiser starts: the declared start, then random ones in the bounds (default 1)")
    ap.add_argument("--seed", type=int, default=0, metavar="S", help="seed of the random starts (default 0)")
    ap.add_argument("--max-evaluations", type=int, default=300, metavar="M",
                    help="model evaluations per start, finite-difference ones included (default 300)")
    ap.add_argument("--out", default="out/fit", metavar="DIR", help="directory for fit.json and the polar plots (default out/fit)")
    ap.add_argument("--no-plots", action="store_true", help="do not write the plots")
    ap.add_argument("--json", action="store_true", help="print the result as JSON on stdout")
    ap.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    return ap


def _allowed() -> str:
    return "one call of " + ", ".join(CONSTRUCTORS) + " (or a short name: epic, deon, ...) with literal keyword arguments"


def main(argv=None, prog: str = "hairbsdf fit") -> int:
    ap = build_parser(prog)
    args = ap.parse_args(argv)
    if args.list:
        sys.stdout.write(describe_models())
        return 0
    if not args.target or not args.model:
        ap.error("--target and --model are required (or --list)")
    if args.grid < 2 or args.h_nodes < 1 or args.starts < 1 or args.max_evaluations < 1:
        ap.error("--grid must be >= 2; --h-nodes, --starts and --max-evaluations >= 1")
    try:
        fit_model(args.model)
        parse_spec(args.target)
        build(args.target)
    except (SpecError, ValueError) as exc:
        ap.error(str(exc))
    res = fit(args.target, args.model, grid=args.grid, h_count=args.h_nodes, starts=args.starts, seed=args.seed,
              max_evaluations=args.max_evaluations, progress=not args.quiet)
    from pathlib import Path
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "fit.json").write_text(json.dumps(res.as_json(), indent=2) + "\n")
    files = [out / "fit.json"]
    if not args.no_plots:
        from .plot import fit_comparison_figure
        files.append(fit_comparison_figure(args.target, res.spec, out / f"fit_{res.model}.png",
                                           h_count=args.h_nodes,
                                           title=f"target {res.target}\nfit {res.spec}"))
    if args.json:
        sys.stdout.write(json.dumps({**res.as_json(), "files": [str(f) for f in files]}, indent=2) + "\n")
    else:
        sys.stdout.write(_text_report(res) + "wrote " + ", ".join(str(f) for f in files) + "\n")
    return 0
