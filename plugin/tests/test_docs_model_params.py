"""docs/models.md's parameter tables against each zoo model's parameter table (bsdf_core/include/hairbsdf/
params/<model>.h, read through `hairbsdf.model_schema`), which is where its parameters, defaults and ranges
are declared: every parameter has a row, every row names a parameter (or a per-sample input), and each
row's default and range hold the declared numbers. A planted difference in either place fails (test_planted_differences_are_caught)."""

import re
from pathlib import Path

import pytest

import hairbsdf

DOC = Path(__file__).resolve().parents[2] / "docs" / "models.md"
NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:e[-+]?\d+)?", re.IGNORECASE)
# A row's first cell that is not a factory parameter: inputs given per sample (ShadingContext).
PER_SAMPLE = "per sample"


def numbers(text):
    return [float(x) for x in NUMBER.findall(text.replace("\u2212", "-"))]


def section(doc, model):
    """The text of the section whose heading names the model's function (`epic_hair`, `yan_fur`)."""
    name = {"yan_fur": "yan_fur", "cycles_hair": "cycles_hair_bsdf"}.get(model, model + "_hair")
    m = re.search(r"^## [^\n]*`%s`[^\n]*$" % re.escape(name), doc, re.MULTILINE)
    assert m, f"docs/models.md has no section for `{name}`"
    end = doc.find("\n## ", m.end())
    return doc[m.end():end if end >= 0 else len(doc)]


def parameter_rows(text):
    """{name: (default cell, range cell)} of the section's parameter table."""
    rows = {}
    for line in text.splitlines():
        m = re.match(r"^\| `(\w+)`([^|]*)\|([^|]*)\|([^|]*)\|", line)
        if m:
            name, rest, default, allowed = m.groups()
            if PER_SAMPLE in rest:
                continue
            rows.setdefault(name, (default, allowed))
    return rows


def close(a, b):
    return abs(a - b) <= 1e-3 * max(abs(a), abs(b), 1e-3)


def mismatches(doc, model, schema, text=None):
    """`text`: the part of `doc` holding the table (default: the model's section of docs/models.md)."""
    rows = parameter_rows(section(doc, model) if text is None else text)
    out = []
    names = [p["name"] for p in schema]
    for extra in sorted(set(rows) - set(names)):
        out.append(f"{model}: the docs list `{extra}`, the factory has no such parameter")
    for p in schema:
        if p["name"] not in rows:
            out.append(f"{model}: `{p['name']}` has no row in docs/models.md")
            continue
        default, allowed = rows[p["name"]]
        kind = p["type"]
        if kind == "choice":
            for c in p["choices"]:
                if f'"{c}"' not in allowed:
                    out.append(f"{model}.{p['name']}: choice {c!r} missing from the range cell {allowed.strip()!r}")
            want = p["choices"][int(round(p["default"][0] if isinstance(p["default"], (list, tuple))
                                          else p["default"]))] if not isinstance(p["default"], str) else p["default"]
            if f'"{want}"' not in default:
                out.append(f"{model}.{p['name']}: default {want!r} not in {default.strip()!r}")
            continue
        if kind == "bool":
            want = "True" if bool(p["default"]) else "False"
            if want not in default:
                out.append(f"{model}.{p['name']}: default {want} not in {default.strip()!r}")
            continue
        got = numbers(allowed)
        for bound in (p["min"], p["max"]):
            if not any(close(bound, g) for g in got):
                out.append(f"{model}.{p['name']}: range bound {bound} not in {allowed.strip()!r}")
        if p.get("optional"):
            continue  # derived from other parameters unless given
        values = p["default"] if isinstance(p["default"], (list, tuple)) else [p["default"]]
        shown = numbers(default)
        for v in values:
            if not any(close(v, g) for g in shown):
                out.append(f"{model}.{p['name']}: default {v} not in {default.strip()!r}")
    return out


# The zoo and Cycles' legacy Hair BSDF (built by name from its table, params/cycles_hair.h, outside the zoo).
@pytest.mark.parametrize("model", hairbsdf.zoo_model_names() + ["cycles_hair"])
def test_docs_parameter_table_matches_the_factory(model):
    problems = mismatches(DOC.read_text(encoding="utf-8"), model, hairbsdf.model_schema(model))
    assert not problems, "\n".join(problems)


def test_planted_differences_are_caught():
    doc = DOC.read_text(encoding="utf-8")
    schema = hairbsdf.model_schema("marschner")
    assert not mismatches(doc, "marschner", schema)
    # a row removed from the docs
    assert any("`glint_scale` has no row" in p
               for p in mismatches(doc.replace("| `glint_scale` (k_G)", "| glint scale"), "marschner", schema))
    # a default changed in the factory's table
    changed = [dict(p, default=0.7) if p["name"] == "glint_scale" else p for p in schema]
    assert any("glint_scale: default 0.7" in p for p in mismatches(doc, "marschner", changed))
    # a range changed in the docs
    assert any("range bound 3" in p for p in mismatches(doc.replace("| [1.1, 3] |", "| [1.1, 4] |"), "marschner",
                                                         schema))
    # a parameter the factory does not have
    extra = doc.replace("| `eta` | 1.55 |", "| `eta` | 1.55 |\n| `ior` | 1.55 |", 1)
    assert any("`ior`" in p for p in mismatches(extra, "marschner", schema))


HUANG_DOC = DOC.parent / "huang.md"


def huang_options_text(doc):
    """docs/huang.md's options table: from its heading to the next section."""
    start = doc.index('### Options of `principled_hair(model="huang")`')
    return doc[start:doc.index("\n## ", start)]


def test_huang_options_table_matches_params_huang_h():
    """Huang's options (params/huang.h, read through _core.huang_option_schema) against docs/huang.md §2."""
    doc = HUANG_DOC.read_text(encoding="utf-8")
    schema = hairbsdf._core.huang_option_schema()
    problems = mismatches(doc, "huang", schema, huang_options_text(doc))
    assert not problems, "\n".join(problems)
    changed = [dict(p, default=2e-2) if p["name"] == "tolerance" else p for p in schema]
    assert any("tolerance: default 0.02" in p for p in mismatches(doc, "huang", changed, huang_options_text(doc)))


PRINCIPLED_DOC = DOC.parent / "principled_hair.md"


def principled_default_mismatches(doc, defaults):
    """docs/principled_hair.md's "Inputs and defaults" table against `defaults` (PRINCIPLED_HAIR_DEFAULTS, the
    scene schema's rows, i.e. C++ PrincipledHairInputs): every keyword has a row, and a row's default cell starts
    with its keywords' values in order."""
    start = doc.index("## Inputs and defaults")
    text = doc[start:doc.index("\n## ", start)]
    out, seen = [], set()
    for line in text.splitlines():
        m = re.match(r"^\| ((?:`\w+`(?:, )?)+) \|([^|]*)\|", line)
        if not m:
            continue
        names = re.findall(r"`(\w+)`", m.group(1))
        want = []
        for name in names:
            seen.add(name)
            if name not in defaults:
                out.append(f"the docs list `{name}`, principled_hair has no such keyword")
                continue
            want += list(defaults[name]) if isinstance(defaults[name], tuple) else [defaults[name]]
        got = numbers(m.group(2))[:len(want)]
        if len(got) != len(want) or not all(close(a, b) for a, b in zip(got, want)):
            out.append(f"{', '.join(names)}: the docs say {m.group(2).strip()!r}, the defaults are {want}")
    out += [f"`{name}` has no row in docs/principled_hair.md" for name in sorted(set(defaults) - seen)]
    return out


def test_principled_hair_defaults_table_matches_the_scene_schema():
    doc = PRINCIPLED_DOC.read_text(encoding="utf-8")
    defaults = hairbsdf.PRINCIPLED_HAIR_DEFAULTS
    assert not principled_default_mismatches(doc, defaults)
    changed = dict(defaults, ior=1.6)
    assert any(p.startswith("ior:") for p in principled_default_mismatches(doc, changed))
    assert any("`coat` has no row" in p
               for p in principled_default_mismatches(doc.replace("| `coat` | 0 | all |\n", ""), defaults))
