"""The Python side of the models' parameter tables (bsdf_core/include/hairbsdf/params/<model>.h): each zoo
constructor's keywords and defaults are its table's names and defaults, and `model_params()` reports every
table row that is a field of the model under the table's name. Planted differences fail
(test_planted_signature_differences_are_caught)."""

import inspect

import numpy as np
import pytest

import hairbsdf


def constructor(model):
    return getattr(hairbsdf, model if model == "yan_fur" else model + "_hair")


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


@pytest.mark.parametrize("model", hairbsdf.zoo_model_names())
def test_constructor_keywords_are_the_table(model):
    problems = signature_mismatches(model, constructor(model), hairbsdf.model_schema(model))
    assert not problems, "\n".join(problems)


# Every kind of row (number, RGB, choice, bool, converted, optional, builder input) is in these four; Marschner's
# energy table and Yan's medulla tables would add seconds and no new kind.
@pytest.mark.parametrize("model", ["kajiya_kay", "epic", "scheuermann", "deon"])
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
