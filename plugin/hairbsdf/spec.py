"""Model specs for the command line (`hairbsdf fit`, `hairbsdf plot`): a text such as
`principled_hair(melanin=0.6)` or `epic_hair(roughness=0.3, base_color=(0.2, 0.1, 0.05))`.

A spec is parsed with Python's `ast`, never evaluated: it must be ONE call of a known constructor
with literal keyword arguments (numbers, strings, booleans, tuples / lists of numbers; unary minus
allowed). Anything else raises SpecError naming what is allowed."""

from __future__ import annotations

import ast

from .principled import DEFAULT_MODEL
from .zoo import CONSTRUCTOR_OF_MODEL, zoo_model_names

# Constructor name -> the hairbsdf attribute it calls: Principled Hair and the zoo models' (zoo's
# CONSTRUCTOR_OF_MODEL). Short names are accepted too (`epic` = `epic_hair`, a zoo model's name), so that
# `--model epic` and `--target epic` read the same.
_ZOO = {model: CONSTRUCTOR_OF_MODEL[model] for model in zoo_model_names()}
CONSTRUCTORS = {name: name for name in ("principled_hair", *_ZOO.values())}
ALIASES = {"principled": "principled_hair", DEFAULT_MODEL: "principled_hair",
           **{model: name for model, name in _ZOO.items() if model != name}, "yan": _ZOO["yan_fur"]}
ALLOWED_TEXT = ("a call of one of " + ", ".join(CONSTRUCTORS) +
                " (or the short names " + ", ".join(ALIASES) + ") with literal keyword arguments, "
                "e.g. \"principled_hair(melanin=0.6, roughness=0.3)\"")


class SpecError(ValueError):
    """A spec that is not a call of a known constructor with literal keyword arguments."""


def parse_spec(text: str) -> tuple[str, dict]:
    """'epic_hair(roughness=0.3)' -> ('epic_hair', {'roughness': 0.3}). Never evaluates code.

    A bare name ('epic', 'principled_hair') means the constructor's defaults. For principled_hair
    the parametrization is inferred when not given: melanin / melanin_redness -> "melanin",
    absorption_coefficient -> "absorption" (the library default, "color", would ignore them)."""
    if not isinstance(text, str) or not text.strip():
        raise SpecError(f"empty model spec; expected {ALLOWED_TEXT}")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise SpecError(f"cannot parse model spec {text!r} ({exc.msg}); expected {ALLOWED_TEXT}") from None
    node = tree.body
    if isinstance(node, (ast.Name, ast.Attribute)):
        node = ast.Call(func=node, args=[], keywords=[])
    if not isinstance(node, ast.Call):
        raise SpecError(f"model spec {text!r} is not a call; expected {ALLOWED_TEXT}")
    name = _callee_name(node.func, text)
    if node.args:
        raise SpecError(f"model spec {text!r}: positional arguments are not allowed, use keywords "
                        f"(e.g. {name}(roughness=0.3))")
    kwargs = {}
    for kw in node.keywords:
        if kw.arg is None:
            raise SpecError(f"model spec {text!r}: '**' is not allowed; give literal keyword arguments")
        try:
            value = ast.literal_eval(kw.value)
        except ValueError:
            raise SpecError(f"model spec {text!r}: the value of {kw.arg!r} is not a literal "
                            f"({ast.unparse(kw.value)!r}); use numbers, strings, booleans or tuples of numbers") from None
        kwargs[kw.arg] = _check_literal(kw.arg, value, text)
    if name == "principled_hair" and "parametrization" not in kwargs:
        if "melanin" in kwargs or "melanin_redness" in kwargs:
            kwargs = {"parametrization": "melanin", **kwargs}
        elif "absorption_coefficient" in kwargs:
            kwargs = {"parametrization": "absorption", **kwargs}
    return name, kwargs


def build(text: str):
    """The hairbsdf.Closure a spec describes. Constructor errors (unknown keyword, value out of
    range) come back as SpecError with the constructor's message."""
    import hairbsdf

    name, kwargs = parse_spec(text)
    try:
        return getattr(hairbsdf, CONSTRUCTORS[name])(**kwargs)
    except (TypeError, ValueError) as exc:
        raise SpecError(f"model spec {text!r}: {exc}") from None


def format_spec(name: str, kwargs: dict) -> str:
    """The canonical text of a spec: parse_spec(format_spec(n, k)) == (n, k) for literal values."""
    return f"{name}(" + ", ".join(f"{k}={_fmt(v)}" for k, v in kwargs.items()) + ")"


def _fmt(value):
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (tuple, list)):
        return "(" + ", ".join(_fmt(v) for v in value) + ")"
    return repr(value)


def _callee_name(func, text: str) -> str:
    # `hairbsdf.epic_hair(...)` is accepted as well as `epic_hair(...)`; nothing else.
    if isinstance(func, ast.Attribute) and isinstance(func.value, ast.Name) and func.value.id == "hairbsdf":
        name = func.attr
    elif isinstance(func, ast.Name):
        name = func.id
    else:
        raise SpecError(f"model spec {text!r}: {ast.unparse(func)!r} is not a constructor name; expected {ALLOWED_TEXT}")
    name = ALIASES.get(name, name)
    if name not in CONSTRUCTORS:
        raise SpecError(f"model spec {text!r}: unknown constructor {name!r}; expected {ALLOWED_TEXT}")
    return name


def _check_literal(key: str, value, text: str):
    if isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (tuple, list)) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return tuple(value)
    raise SpecError(f"model spec {text!r}: {key}={value!r} is not allowed; values must be numbers, strings, "
                    "booleans or tuples of numbers")
