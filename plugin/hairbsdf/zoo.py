"""The model zoo (issue 7): classic and real-time hair models behind the common closure
interface. Formulas, defaults and their sources: docs/models.md. Every constructor works with no
arguments; out-of-range parameters raise ValueError naming the parameter and the allowed range.

The parameter names, defaults and ranges live in one table per model, beside its C++ Params struct
(bsdf_core/include/hairbsdf/params/<model>.h); `model_schema(name)` returns it and
`make_model(name, params)` builds a model from named values, as the renderer's `hair_model`
closure and the Blender engine's material override do."""

from __future__ import annotations

import functools
import inspect

from . import _core
from . import _validate as check
from ._param_docs import BOOL, CHOICE, FLOAT, INT, RGB, with_parameters
from .closure import Closure

PLUGIN_MODEL = _core.PLUGIN_MODEL  # the model name that loads a plugin library (`path`)


def zoo_model_names() -> list[str]:
    """The zoo's model names: kajiya_kay, epic, scheuermann, marschner, deon, yan_fur."""
    return list(_core.zoo_model_names())


def zoo_models() -> list[tuple[str, str, str]]:
    """(name, title, one-line summary) per zoo model, from the models' tables (Blender's override menu)."""
    return [tuple(m) for m in _core.zoo_models()]


def model_schema(model: str, path: str | None = None) -> list[dict]:
    """The parameters of a zoo model, or of the plugin at `path` (model "plugin"): dicts with
    name, type ("float", "rgb", "choice", "bool"), default, min, max, choices, optional and
    description. ValueError for an unknown model."""
    if not isinstance(model, str):
        raise TypeError(f"model: expected a string, got {type(model).__name__}")
    if model == PLUGIN_MODEL and not isinstance(path, str):
        raise TypeError("path: the plugin model needs the path of the plugin library")
    return _core.model_schema(model, path or "")


def make_model(model: str, params: dict | None = None, *, path: str | None = None) -> Closure:
    """A zoo model (or, with model="plugin", the plugin at `path`) from a dict of named
    parameters; missing ones take their defaults (model_schema). Values: a number, an RGB
    triple (or a number for grey), a choice's name, a bool."""
    params = dict(params or {})
    if model == PLUGIN_MODEL and not isinstance(path, str):
        raise TypeError("path: the plugin model needs the path of the plugin library")
    core = _core.make_model(model, params, path or "")
    args = ", ".join(f"{k}={v!r}" for k, v in params.items())
    return Closure(core, f"make_model({model!r}, {{{args}}}" + (f", path={path!r})" if path else ")"))


def model_defaults(model: str) -> dict:
    """A zoo model's parameters that have a default, by name: its table's (model_schema)."""
    return {p["name"]: p["default"] for p in _core.model_schema(model, "") if not p["optional"]}


# Each row kind's Python check (TypeError naming the parameter); the ranges, choices and the rules between
# parameters are the factory's (_core.make_model: ValueError naming the parameter and what is allowed).
def _check_choice(name, value, row):
    if not isinstance(value, str):
        raise TypeError(f"{name}: expected a string, one of {row['choices']}")
    return value.lower()  # case-insensitive: Blender's enum identifiers are upper case


def _check_bool(name, value, row):
    if not isinstance(value, bool):
        raise TypeError(f"{name}: expected True or False")
    return value


_CHECKS = {FLOAT: lambda name, value, row: check.real(name, value),
           INT: lambda name, value, row: check.real(name, value),
           RGB: lambda name, value, row: check.color(name, value),
           CHOICE: _check_choice, BOOL: _check_bool}
_ANNOTATIONS = {FLOAT: float, INT: int, RGB: "tuple[float, float, float] | float", CHOICE: str, BOOL: bool}


def _shown(value) -> str:
    return f"{value:g}" if isinstance(value, float) else repr(value)


# Model -> its constructor's name ("epic" -> "epic_hair"), recorded by _from_table: the one place the pairs are
# written is each constructor's decorator (spec's and fit's names derive from this).
CONSTRUCTOR_OF_MODEL: dict[str, str] = {}


def _from_table(model: str):
    """Turns a function whose body is its prose docstring into `model`'s constructor, built from the model's
    table (_core.model_schema): keyword-only parameters with the table's defaults (an inspect.Signature, so
    help() and IDEs show them; an optional row defaults to None, "derived unless given"), each value checked by
    its row's kind, the closure's repr in table order, and the docstring's generated Parameters block."""
    schema = _core.model_schema(model, "")

    def decorate(prose):
        name = prose.__name__
        CONSTRUCTOR_OF_MODEL[model] = name
        signature = inspect.Signature(
            [inspect.Parameter(row["name"], inspect.Parameter.KEYWORD_ONLY,
                               default=None if row["optional"] else row["default"],
                               annotation=_ANNOTATIONS[row["type"]]) for row in schema], return_annotation=Closure)

        def constructor(**given) -> Closure:
            check.keywords(name, given, [row["name"] for row in schema])
            values = {}
            for row in schema:
                value = given.get(row["name"], None if row["optional"] else row["default"])
                if value is not None:  # an optional row not given: the builder derives it
                    values[row["name"]] = _CHECKS[row["type"]](row["name"], value, row)
            shown = ", ".join(f"{key}={_shown(value)}" for key, value in values.items())
            return Closure(_core.make_model(model, values, ""), f"{name}({shown})")

        functools.update_wrapper(constructor, prose)
        constructor.__signature__ = signature
        return with_parameters(schema, f"bsdf_core/include/hairbsdf/params/{model}.h")(constructor)
    return decorate


# Each constructor below is its table's (_from_table); its body is the prose the table does not say.

@_from_table("kajiya_kay")
def kajiya_kay_hair():
    """Kajiya and Kay 1989 (§2.4): diffuse K_d sin(t, l) plus specular K_s cos^p(e, e'),
    normalised so that `diffuse` is the diffuse albedo and `specular` the specular albedo at
    normal view (docs/models.md §1).

    diffuse + specular must not exceed 1 in any channel; the lobe is about 1/sqrt(exponent) wide.
    Lobes: eval_lobes index 0 = specular, 3 = diffuse.
    """


@_from_table("epic")
def epic_hair():
    """Epic / Unreal 2016 real-time hair (Karis's SIGGRAPH 2016 course notes; docs/models.md §2).

    base_color's default is Blender's Principled Hair colour, a dark brown; shift's is about
    Marschner's / Blender's 2 degree cuticle tilt. variant "environment": R x saturate(wi.wr + 1),
    no TT, every beta + 0.2. energy "bounded": eval divided per channel by max(1, the model's albedo
    at this view and shadow); "published": the notes' model exactly.
    The multiple-scattering term reads the per-sample `shadow=` input of eval / pdf / sample
    (the light's visibility through the hair volume; 1 when not given).
    Lobes: R, TT, TRT, and the multiple-scattering term in slot 3.
    """


@_from_table("scheuermann")
def scheuermann_hair():
    """Scheuermann (ATI) 2004: two Kajiya-Kay specular lobes on shifted tangents (docs/models.md §3).

    Each colour bounds its lobe's albedo, and primary + secondary must not exceed 1 in any channel.
    The default exponents give light-space widths about Marschner's beta_R and 2 beta_R; the shifts
    move the tangents along the normal, by default Principled Hair's R and TRT at its 2 degree offset.
    Lobes: eval_lobes index 0 = primary, 2 = secondary.
    """


@_from_table("marschner")
def marschner_hair():
    """Marschner et al. 2003 (docs/models.md §4); angles in radians, defaults from Table 1.

    sigma_a's default is Blender's Principled Hair absorption. energy "bounded": eval divided per
    channel by max(1, the model's albedo at this view and cross-section orientation); "published":
    the paper's model.
    The cross-section's major axis is the per-sample `normal=` (zero: the view-dependent frame).
    """


@_from_table("deon")
def deon_hair():
    """d'Eon et al. 2011 energy-conserving hair with the Gaussian-detector azimuthal term (docs/models.md §5).

    Colour: melanin and melanin_redness (Principled Hair's defaults) through the pigments' constants,
    or sigma_a directly. roughness: the M variance is beta^2 and the detector's sd beta.
    Lobes: R, TT, TRT, TRRT+ (residual, so that sigma_a = 0 conserves energy).
    """


# --- Cycles' legacy Hair BSDF node ----------------------------------------------------------------
# The node's sockets, Blender's defaults and the allowed ranges: its table (params/cycles_hair.h), which
# also checks the values (make_model).
CYCLES_HAIR_DEFAULTS = model_defaults("cycles_hair")


@_from_table("cycles_hair")
def cycles_hair_bsdf():
    """Cycles' legacy "Hair BSDF" node, as Cycles evaluates and samples it (docs/models.md §6).

    Defaults are the Blender node's; component is case-insensitive (Blender's 'REFLECTION' /
    'TRANSMISSION' accepted).
    The split between the components follows Cycles' shading normal at the hit, which depends on
    `h` (reflection where wi . N >= 0). Lobes: reflection in slot 0 (R), transmission in slot 1 (TT).
    Cycles' sampler is not its eval's density (docs/models.md §6): `sample` returns Cycles' pdf
    and weight = color, `pdf` returns eval's density.
    """


@_from_table("yan_fur")
def yan_fur():
    """Yan et al. 2015 fur, the double cylinder (docs/models.md §7). Defaults: Yan 2015's measured fit.

    Lobes (eval_lobes is (N, 6, 3)): R, TT, TRT, TRRT+ unscattered (Chiang's with the medulla's
    transmittance, at h), TTs and TRTs scattered in the medulla (Monte Carlo tables, built once per
    (medulla_ratio, cortex_absorption, medulla_*, eta) in the process).
    """
