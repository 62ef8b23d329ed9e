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
    name = model if model == "yan_fur" else model + "_hair"
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


def mismatches(doc, model, schema):
    rows = parameter_rows(section(doc, model))
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


@pytest.mark.parametrize("model", hairbsdf.zoo_model_names())
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
