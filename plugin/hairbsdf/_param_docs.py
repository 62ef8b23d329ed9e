"""Docstring sections generated from a parameter table (the dicts of hairbsdf.model_schema), so that
a constructor's prose says what each parameter means and the numbers (defaults, ranges, choices) are
written once, in the table (plugin/tests/test_model_tables.py checks the docstrings)."""

from __future__ import annotations

import math
from . import _core

# The parameter kinds (a schema dict's "type"), named once in C++ (hairbsdf/param_kinds.h), in ParamKind's order.
PARAM_KINDS = _core.PARAM_KINDS
FLOAT, RGB, CHOICE, BOOL, INT, VECTOR2 = PARAM_KINDS

HEADING = "Parameters (generated from the table, {}):"


def _number(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def parameters_block(schema: list, source: str) -> str:
    """One line per table row: name, range or choices, default, meaning."""
    lines = [HEADING.format(source)]
    for p in schema:
        if p["type"] == CHOICE:
            allowed = "one of " + ", ".join(repr(c) for c in p["choices"])
        elif p["type"] == BOOL:
            allowed = "True or False"
        elif p["type"] == INT:
            allowed = f"a whole number in [{int(p['min'])}, {int(p['max'])}]"
        else:
            lo, hi = p["min"], p["max"]
            span = ("finite" if math.isinf(lo) and math.isinf(hi) else f">= {_number(lo)}" if math.isinf(hi)
                    else f"in [{_number(lo)}, {_number(hi)}]")
            allowed = {RGB: "RGB (or grey), each channel ", VECTOR2: "2 numbers, each "}.get(p["type"], "") + span
        d = p["default"]
        if p["optional"]:
            default = "derived unless given"
        elif isinstance(d, tuple):
            default = "(" + ", ".join(_number(x) for x in d) + ")"
        else:
            default = repr(d) if isinstance(d, str) else _number(d)
        lines.append(f"    {p['name']}: {allowed}; default {default}. {p['description']}")
    return "\n".join(lines)


def with_parameters(schema: list, source: str):
    """A decorator appending parameters_block(schema, source) to the function's docstring."""
    def decorate(function):
        function.__doc__ = (function.__doc__ or "").rstrip() + "\n\n" + parameters_block(schema, source) + "\n"
        return function
    return decorate
