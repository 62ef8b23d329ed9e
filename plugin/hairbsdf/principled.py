"""Blender's Principled Hair BSDF: `principled_hair(...)` and its absorption helpers,
with Cycles' semantics (docs/principled_hair.md lists every clamp)."""

from __future__ import annotations

import inspect

import numpy as np

from . import _core
from . import _validate as check
from ._param_docs import CHOICE, FLOAT, with_parameters
from .closure import Closure
from .render import CLOSURES, principled_hair_input_rows

_SCENE_SCHEMA = _core.scene_schema()


def _choices(path: str) -> dict:
    """A scene-schema enum's names in lower case -> the index C++ takes (the row lists the
    C++ enum's names in the enum's order), the default first. The one place these names are written
    is the schema row (plugin/bindings/scene_schema.cpp)."""
    row = next(r for r in _SCENE_SCHEMA if r["path"] == path and r["allowed"])
    names = {name.lower(): index for index, name in enumerate(row["allowed"])}
    default = row["default"].lower()
    return {default: names.pop(default), **names}


PARAMETRIZATIONS = _choices(CLOSURES + ".parametrization")
ACCURACIES = _choices("integrator.accuracy")
TILTS = _choices("integrator.tilt")
MODELS = tuple(_choices(CLOSURES + ".model"))
# The defaults: each table's first entry (the schema row's default).
DEFAULT_MODEL, DEFAULT_PARAMETRIZATION, DEFAULT_ACCURACY, DEFAULT_TILT = (
    next(iter(t)) for t in (MODELS, PARAMETRIZATIONS, ACCURACIES, TILTS))

# Huang's options (accuracy, sampler, tolerance, max_evaluations, trt_points, color_roughness,
# glass_albedo_table): their table beside C++ HuangHairParams (params/huang.h) gives the names,
# choices, defaults and ranges (docs/huang.md §4); a choice is passed to C++ as its index there.
HUANG_OPTIONS = {p["name"]: p for p in _core.huang_option_schema()}
HUANG_OPTION_DEFAULTS = {name: p["default"] for name, p in HUANG_OPTIONS.items()}


def _node_defaults(hair_model: str) -> dict:
    """The Principled Hair node's Blender 4.5 defaults (docs/cycles.md §1; offset in radians) for
    `hair_model` ("CHIANG" or "HUANG"), read from the scene schema's input rows, whose defaults are
    the C++ PrincipledHairInputs struct's: the one place they are written."""
    out = {}
    for key, row in principled_hair_input_rows().items():
        if key != "random" and hair_model in row["hair_models"].split():
            text = row["default"].strip("()")
            values = tuple(float(v) for v in text.split(","))
            out[key] = values if row["kind"] == "vector" else values[0]
    # The socket's own value; a scene's unlinked Random means the per-curve hash instead.
    out["random"] = 0.0
    return out


PRINCIPLED_HAIR_DEFAULTS = _node_defaults("CHIANG")
# Inputs of the Huang model (Blender 4.5 node): Radial Roughness and Coat are accepted and ignored
# like Cycles does (Radial Roughness is used by color_roughness="osl" only).
HUANG_DEFAULTS = dict(PRINCIPLED_HAIR_DEFAULTS, **_node_defaults("HUANG"))
del _SCENE_SCHEMA
# The RGB inputs: the schema rows of kind "vector" (the others are numbers).
_COLOR_INPUTS = frozenset(key for key, row in principled_hair_input_rows().items() if row["kind"] == "vector")


def principled_hair(model: str = DEFAULT_MODEL, parametrization: str = DEFAULT_PARAMETRIZATION, *,
                    accuracy: str = DEFAULT_ACCURACY, tilt: str = DEFAULT_TILT, **inputs) -> Closure:
    """Blender's Principled Hair BSDF as Cycles renders it.

    Keywords are the node's socket names in snake_case (defaults: Blender 4.5):
    color, melanin, melanin_redness, tint, absorption_coefficient, roughness,
    radial_roughness, coat, ior, offset (radians), random_color, random_roughness, random.
    `parametrization` is "color" (Direct Coloring), "melanin" or "absorption".
    `accuracy="exact"` replaces Cycles' truncated Bessel series by exact special functions;
    `tilt="3.4"` selects Blender 3.4-4.1's tilt convention and sampler.
    `random` is the socket value; Cycles uses the per-curve hash when it is unlinked
    (see `cycles_curve_random`).

    model="huang" (Blender 4.x, docs/huang.md): the same colour keywords plus aspect_ratio,
    reflection, transmission, secondary_reflection (their defaults: Blender 4.5's, as above); coat and
    radial_roughness are accepted and ignored like in Cycles. Its options are listed below, generated
    from their table; eval, eval_lobes, pdf and albedo also take `tolerance=` per call (docs/huang.md
    §4: cost and error per tolerance; fixed trt_points err by a few % of TRT at 16384, ~N^-1/2).
    eval / eval_lobes / pdf / sample take the keyword arrays normal=, pixel_coverage=, near_field=.
    model="chiang": eval / pdf / sample take per-row node inputs, inputs={"roughness": (N,) array, ...}
    (roughness, radial_roughness, coat, random, melanin, absorption_coefficient (N, 3); docs/simd.md).
    """
    if not isinstance(model, str):
        raise TypeError(f"model: expected a string, one of {list(MODELS)}")
    check.choice("model", model.lower(), MODELS)
    if model.lower() == "huang":
        return _principled_huang(parametrization, accuracy=accuracy, tilt=tilt, **inputs)
    if isinstance(parametrization, str):
        parametrization = parametrization.lower()
    check.choice("parametrization", parametrization, PARAMETRIZATIONS)
    check.choice("accuracy", accuracy, ACCURACIES)
    check.choice("tilt", tilt, TILTS)
    check.keywords("principled_hair", inputs, PRINCIPLED_HAIR_DEFAULTS)

    values = dict(PRINCIPLED_HAIR_DEFAULTS)
    for key, value in inputs.items():
        values[key] = check.color(key, value) if key in _COLOR_INPUTS else check.real(key, value)

    arguments = (PARAMETRIZATIONS[parametrization], values, ACCURACIES[accuracy], TILTS[tilt])
    core = _core.principled_chiang(arguments)
    shown = ", ".join(f"{k}={v}" for k, v in inputs.items())
    extra = "".join(f", {k}={v!r}" for k, v in (("accuracy", accuracy), ("tilt", tilt))
                    if v != {"accuracy": DEFAULT_ACCURACY, "tilt": DEFAULT_TILT}[k])
    return Closure(core, f"principled_hair(model='chiang', parametrization={parametrization!r}"
                         f"{', ' + shown if shown else ''}{extra})", principled=arguments)


def _principled_huang(parametrization, *, tilt=DEFAULT_TILT, **given) -> Closure:
    """model="huang" of principled_hair (see its docstring and docs/huang.md): Huang's options (its signature,
    from their table HUANG_OPTIONS) and the node's inputs."""
    if isinstance(parametrization, str):
        parametrization = parametrization.lower()
    check.choice("parametrization", parametrization, PARAMETRIZATIONS)
    if tilt != DEFAULT_TILT:
        raise ValueError(f"tilt: the Huang model has no tilt convention option (only {DEFAULT_TILT!r})")
    options = {name: given.pop(name) for name in HUANG_OPTIONS if name in given}
    # A choice is checked here and passed as its index; a real number is checked here (its range names it); the
    # integers' kind, range and rule (trt_points) are checked by the core (module.cpp's huang_options).
    core_options = {}
    for name, value in options.items():
        row = HUANG_OPTIONS[name]
        if row["type"] == CHOICE:
            value = row["choices"].index(check.choice(name, value, row["choices"]))
        elif row["type"] == FLOAT:
            value = options[name] = check.in_range(name, value, row["min"], row["max"])
        core_options[name] = value
    inputs = given
    check.keywords("principled_hair(model='huang')", inputs, HUANG_DEFAULTS)
    values = dict(HUANG_DEFAULTS)
    for key, value in inputs.items():
        values[key] = check.color(key, value) if key in _COLOR_INPUTS else check.real(key, value)
    core = _core.principled_huang(PARAMETRIZATIONS[parametrization], values, core_options)
    shown = ", ".join(f"{k}={v}" for k, v in inputs.items())
    extra = "".join(f", {k}={v!r}" for k, v in options.items() if v != HUANG_OPTION_DEFAULTS[k])
    return Closure(core, f"principled_hair(model='huang', parametrization={parametrization!r}"
                         f"{', ' + shown if shown else ''}{extra})")


_principled_huang.__signature__ = inspect.Signature(
    [inspect.Parameter("parametrization", inspect.Parameter.POSITIONAL_OR_KEYWORD),
     inspect.Parameter("tilt", inspect.Parameter.KEYWORD_ONLY, default=DEFAULT_TILT),
     *(inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=row["default"])
       for name, row in HUANG_OPTIONS.items()),
     inspect.Parameter("inputs", inspect.Parameter.VAR_KEYWORD)], return_annotation=Closure)


principled_hair = with_parameters(list(HUANG_OPTIONS.values()),
                                  "bsdf_core/include/hairbsdf/params/huang.h; model=\"huang\" only")(principled_hair)


def huang_fallback_normal(tangent) -> np.ndarray:
    """The major axis Cycles uses for Huang hair without curve normals (particle hair):
    make_orthonormals(tangent) -> (a, b), major axis = b = tangent x a, with
    a = normalize((1,1,1) x tangent). Pass world-space tangents (N, 3) or (3,); the result is in
    the same space (transform it into the fibre frame for `normal=`)."""
    t = check.directions("tangent", tangent)
    same = (t[:, 0] == t[:, 1]) & (t[:, 0] == t[:, 2])
    a = np.stack([t[:, 2] - t[:, 1], np.where(same, t[:, 0] + t[:, 2], t[:, 0] - t[:, 2]),
                  np.where(same, -t[:, 1] - t[:, 0], t[:, 1] - t[:, 0])], axis=1)
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.cross(t, a)
    return b[0] if np.ndim(tangent) == 1 else b


def absorption_from_color(color, radial_roughness: float = PRINCIPLED_HAIR_DEFAULTS["radial_roughness"]) -> np.ndarray:
    """Direct Coloring: sigma_a = (ln(max(color, 0)) / P(radial_roughness))^2 (Chiang 2016 eq. 9).
    A black channel gives inf (fully absorbing)."""
    c = check.color("color", color)
    return np.array(_core.absorption_from_color(c, check.real("radial_roughness", radial_roughness)))


def absorption_from_melanin(melanin: float, melanin_redness: float, tint=(1.0, 1.0, 1.0),
                            radial_roughness: float = PRINCIPLED_HAIR_DEFAULTS["radial_roughness"]) -> np.ndarray:
    """The Melanin parametrization of the node: q = -ln(max(1 - melanin, 1e-4)),
    eumelanin q(1 - redness), pheomelanin q*redness with Cycles' constants, plus the
    Direct Coloring absorption of `tint` (0 for white)."""
    return np.array(_core.absorption_from_melanin(
        check.real("melanin", melanin), check.real("melanin_redness", melanin_redness),
        check.color("tint", tint), check.real("radial_roughness", radial_roughness)))


def cycles_curve_random(curve_index) -> np.ndarray:
    """Blender's per-curve Hair Info > Random: lookup3 hash of the curve index, in [0, 1]."""
    idx = np.asarray(curve_index)
    if not np.issubdtype(idx.dtype, np.integer):
        raise TypeError("curve_index: expected integers")
    if np.any(idx < 0) or np.any(idx > 0xFFFFFFFF):
        raise ValueError("curve_index: must lie in [0, 2**32 - 1]")
    out = _core.cycles_curve_random(idx.astype(np.int64))
    return out if out.ndim else float(out)
