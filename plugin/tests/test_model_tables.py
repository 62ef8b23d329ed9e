"""The Python side of the models' parameter tables (bsdf_core/include/hairbsdf/params/<model>.h): each zoo
constructor's keywords and defaults are its table's names and defaults, and `model_params()` reports every
table row that is a field of the model under the table's name; each constructor's docstring carries the
Parameters block generated from its table and repeats none of its numbers in the prose. Planted differences fail
(test_planted_signature_differences_are_caught, test_planted_docstring_numbers_are_caught)."""

import inspect
import re

import numpy as np
import pytest

import hairbsdf
from hairbsdf import _core, _param_docs, materialx, principled


def constructor(model):
    return getattr(hairbsdf, {"yan_fur": "yan_fur", "cycles_hair": "cycles_hair_bsdf"}.get(model, model + "_hair"))


def signature_mismatches(model, function, schema):
    params = inspect.signature(function).parameters
    out = []
    if sorted(params) != sorted(p["name"] for p in schema):
        out.append(f"{model}: keywords {sorted(params)} are not the table's {sorted(p['name'] for p in schema)}")
    for p in schema:
        if p["name"] not in params:
            continue
        got = params[p["name"]].default
        want = None if p["optional"] else p["default"]
        same = got == want if want is None or isinstance(want, (str, bool)) else np.allclose(got, want)
        if not same:
            out.append(f"{model}.{p['name']}: keyword default {got!r}, the table's {want!r}")
    return out


# The zoo and Cycles' legacy Hair BSDF, built by name from its table (params/cycles_hair.h) outside the zoo.
@pytest.mark.parametrize("model", hairbsdf.zoo_model_names() + ["cycles_hair"])
def test_constructor_keywords_are_the_table(model):
    problems = signature_mismatches(model, constructor(model), hairbsdf.model_schema(model))
    assert not problems, "\n".join(problems)


# MaterialX's support nodes (params/materialx.h); chiang_hair_bsdf takes **inputs, checked against its table.
MATERIALX_NODES = ["chiang_hair_roughness", "chiang_hair_absorption_from_color", "deon_hair_absorption_from_melanin"]


@pytest.mark.parametrize("node", MATERIALX_NODES)
def test_materialx_keywords_are_the_table(node):
    problems = signature_mismatches(node, getattr(materialx, node), _core.materialx_schema(node))
    assert not problems, "\n".join(problems)


# Every kind of row (number, RGB, choice, bool, converted, optional, builder input) is in these four; Marschner's
# energy table and Yan's medulla tables would add seconds and no new kind.
@pytest.mark.parametrize("model", ["kajiya_kay", "epic", "scheuermann", "deon", "cycles_hair"])
def test_model_params_name_the_table_rows(model):
    (d,) = hairbsdf.make_model(model).model_params
    assert d["model"] == model
    for p in hairbsdf.model_schema(model):
        if model == "deon" and p["name"] in ("melanin", "melanin_redness", "pigments"):
            assert p["name"] not in d  # inputs the builder turns into sigma_a
            continue
        assert p["name"] in d, f"{model}: model_params() lacks {p['name']}"
        if p["type"] in ("choice", "bool") or not p["optional"]:
            got, want = d[p["name"]], p["default"]
            assert got == want if isinstance(want, (str, bool)) else np.allclose(got, want), (p["name"], got, want)


def test_planted_signature_differences_are_caught():
    schema = hairbsdf.model_schema("kajiya_kay")
    assert not signature_mismatches("kajiya_kay", hairbsdf.kajiya_kay_hair, schema)

    def renamed(*, diffuse=(0.5,) * 3, specular=(0.5,) * 3, exponents=60.0):
        pass

    def other_default(*, diffuse=(0.5,) * 3, specular=(0.5,) * 3, exponent=61.0):
        pass

    assert any("keywords" in p for p in signature_mismatches("kajiya_kay", renamed, schema))
    assert any("exponent: keyword default 61.0" in p for p in signature_mismatches("kajiya_kay", other_default, schema))


# Numbers the table owns, written again in a docstring's prose: a number after "default(s)", "(default)",
# a bracketed numeric range, `keyword=number`, or a bare number in parentheses ("(0.88)", "(15 deg)").
DOC_LITERALS = re.compile(
    r"\bdefaults?\b[\s:=(]*[-+]?\.?\d|\(\s*default\s*\)|\[\s*[-+]?\.?\d[^\]]*,[^\]]*\]|\b\w+=[-+]?\.?\d"
    r"|(?<![\w)])\(\s*[-+]?\.?\d[\d.e-]*\s*(?:deg)?\s*[,)]", re.IGNORECASE)


def docstring_problems(function, schema, source):
    doc = function.__doc__ or ""
    block = _param_docs.parameters_block(schema, source)
    problems = [] if block in doc else [f"{function.__name__}: the generated Parameters block is missing or edited"]
    prose = doc.split(_param_docs.HEADING.split("{")[0])[0]
    problems += [f"{function.__name__}: {m.group(0)!r} repeats a number of the table"
                 for m in DOC_LITERALS.finditer(prose)]
    return problems


TABLE_DOCS = [(m, lambda m=m: (constructor(m), hairbsdf.model_schema(m), f"bsdf_core/include/hairbsdf/params/{m}.h"))
              for m in hairbsdf.zoo_model_names() + ["cycles_hair"]] + [
    ("principled_hair", lambda: (hairbsdf.principled_hair, list(principled.HUANG_OPTIONS.values()),
                                 'bsdf_core/include/hairbsdf/params/huang.h; model="huang" only'))] + [
    (n, lambda n=n: (getattr(materialx, n), _core.materialx_schema(n), "bsdf_core/include/hairbsdf/params/materialx.h"))
    for n in ["chiang_hair_bsdf"] + MATERIALX_NODES]


@pytest.mark.parametrize("name,case", TABLE_DOCS, ids=[n for n, _ in TABLE_DOCS])
def test_docstrings_take_numbers_from_the_table(name, case):
    problems = docstring_problems(*case())
    assert not problems, "\n".join(problems)


def test_planted_docstring_numbers_are_caught():
    schema = hairbsdf.model_schema("kajiya_kay")
    source = "bsdf_core/include/hairbsdf/params/kajiya_kay.h"
    assert not docstring_problems(hairbsdf.kajiya_kay_hair, schema, source)

    def old_style():
        """exponent: p in [0, 10000] (default 60, a lobe about 7.4 degrees wide)."""

    old_style.__doc__ += "\n\n" + _param_docs.parameters_block(schema, source)
    found = docstring_problems(old_style, schema, source)
    assert any("[0, 10000]" in p for p in found) and any("default 6" in p for p in found), found

    def no_block():
        """Kajiya-Kay."""

    assert any("Parameters block" in p for p in docstring_problems(no_block, schema, source))
    # a default changed in the table no longer matches the docstring's block
    changed = [dict(p, default=61.0) if p["name"] == "exponent" else p for p in schema]
    assert any("Parameters block" in p for p in docstring_problems(hairbsdf.kajiya_kay_hair, changed, source))
