"""The scene format is declared once, in C++ (plugin/bindings/scene_schema.cpp): its table is
exported as hairbsdf.render.scene_schema(), checked by validate_scene (no TBB) and by the
renderer. These tests keep docs/scene_desc.md equal to the table and check the walker's
errors name the key path and what is allowed."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hairbsdf import _core
from hairbsdf.render import scene_schema, validate_scene

DOC = Path(__file__).resolve().parents[2] / "docs" / "scene_desc.md"


def _number(x):
    return str(int(x)) if float(x).is_integer() else repr(x)


def _type(k):
    kind, cols = k["kind"], k["columns"]
    text = {
        "array": f"{k['dtype']} ({k['rows'] or 'N'},)" if cols == 0 else f"{k['dtype']} ({k['rows'] or 'N'}, {cols})",
        "image": f"{k['dtype']} (H, W, {cols})",
        "vector": f"{cols} numbers",
        "matrix": "float64 (4, 4)" if cols == 4 else "float64 (3, 4) or (4, 4)",
        "int pair": "(int, int)",
        "enum": "str",
        "model name": "str",
        "list of enum": "list of str",
        "model params": "dict",
        "informational": "any, not read",
    }.get(kind, kind)
    return text + (' or {"register": k}' if k["register_link"] else "")


def _allowed(k):
    if k["allowed"]:
        return ", ".join(f"`{a}`" for a in k["allowed"])
    if k["kind"] == "model name":
        return ", ".join(["a zoo model"] + [f"`{m}`" for m in _core.model_names() if m not in _core.zoo_model_names()])
    if k["minimum"] is None:
        return ""
    lo, hi = k["minimum"], k["maximum"]
    return f">= {_number(lo)}" if hi == float("inf") else f"{_number(lo)} to {_number(hi)}"


def _need(k):
    return "required" if k["required"] else (f"`{k['default']}`" if k["default"] else "optional")


def expected_rows():
    """The doc table's rows as the declaration gives them: key, for types, type, required or
    default, allowed."""
    return [(f"`{k['path']}`", k["only_for"], _type(k), _need(k), _allowed(k)) for k in scene_schema()]


def documented_rows():
    text = DOC.read_text()
    table = text.split("<!-- scene schema table -->")[1].strip().split("\n\n")[0]
    rows = re.findall(r"^\|(.*)\|\s*$", table, flags=re.M)[2:]  # after the header and its rule
    return [tuple(cell.strip() for cell in row.split("|")) for row in rows]


def test_docs_key_table_matches_the_declaration():
    """docs/scene_desc.md's key table lists every declared key, in order, with its type,
    default and allowed values; a key in one and not the other fails."""
    expected, documented = expected_rows(), documented_rows()
    if documented != expected:
        lines = ["| " + " | ".join(r) + " |" for r in expected]
        missing = [r for r in expected if r not in documented]
        extra = [r for r in documented if r not in expected]
        pytest.fail(f"docs/scene_desc.md differs from scene_schema(): not documented {missing}, not declared "
                    f"{extra}; the rows should be:\n" + "\n".join(lines))


def test_docs_example_names_every_key():
    """Every key name in the doc's annotated example is declared, and every declared name
    appears in it."""
    block = DOC.read_text().split("```python")[1].split("```")[0]
    code = "\n".join(line.split("#")[0] for line in block.splitlines())  # the comments left out
    example = set(re.findall(r'"(\w+)"\s*:', code))
    declared = {k["path"].rsplit(".", 1)[-1].rstrip("[]") for k in scene_schema()}
    assert example - declared == set(), "in the example, not declared"
    assert declared - example == set(), "declared, not in the example"


def test_schema_rows_are_well_formed():
    rows = scene_schema()
    paths = {k["path"] for k in rows}
    for k in rows:
        parent = k["path"].rsplit(".", 1)[0] if "." in k["path"] else ""
        if k["path"].endswith("[]"):
            assert k["path"][:-2] in paths, k
        elif parent:
            assert parent in paths, k
        if k["kind"] in ("enum", "list of enum"):
            assert k["allowed"] and (not k["default"] or k["default"] in k["allowed"] + ["[]"]), k
        assert k["meaning"], k
    # Principled Hair's inputs: the exporter reads their sockets from these rows
    models = next(k["allowed"] for k in rows if k["path"] == "materials[].closures[].model" and k["allowed"])
    inputs = [k for k in rows if k["path"].startswith("materials[].closures[].inputs.")]
    assert inputs and all(k["socket"] and k["socket_kind"] in ("float", "color", "vector") for k in inputs)
    assert all(set(k["hair_models"].split()) <= set(models) for k in inputs)
    assert all(k["socket_kind"] == "float" for k in inputs if k["kind"] == "float")
    # the legacy Hair BSDF's inputs likewise: each linkable cycles_hair key names its socket
    legacy = [k for k in rows if "cycles_hair" in k["only_for"].split() and k["register_link"]]
    assert legacy and all(k["socket"] and k["socket_kind"] in ("float", "color") for k in legacy), legacy
    # the geometry's arrays say which count their length is or matches: the walker checks it, the docs show it
    uncounted = [k["path"] for k in rows if k["kind"] == "array" and k["path"].split(".")[0] in ("curves", "meshes")
                 and not k["rows"]]
    assert uncounted == []
    # a row kept for some types names only types its sibling "type" row allows (a typo would hide the row)
    for k in rows:
        if k["only_for"]:
            sibling = k["path"].rsplit(".", 1)[0] + ".type"
            allowed = next(t["allowed"] for t in rows if t["path"] == sibling)
            assert set(k["only_for"].split()) <= set(allowed), (k["path"], k["only_for"], allowed)


def test_optional_plain_keys_have_their_default_from_the_scene_struct():
    """An optional plain value (number, bool, name, RGB) is bound to its field in the C++ scene
    (render/scene.h), and its default is that field's initial value: a row left unbound has no
    default to show. The SPOT matrix and a plugin's path mean "absent" when left out."""
    plain = ("float", "int", "bool", "enum", "vector")
    absent_means_none = {"lights[].matrix_world", "materials[].closures[].path"}
    unbound = [k["path"] for k in scene_schema()
               if k["kind"] in plain and not k["required"] and not k["default"] and k["path"] not in absent_means_none]
    assert unbound == []


def _row(path):
    return next(k for k in scene_schema() if k["path"] == path)


def test_huang_integrator_choices_are_the_huang_table():
    """integrator.huang_sampler and integrator.huang_glass_albedo_table list the choices of
    Huang's table (params/huang.h), in its order: the scene schema reads them from it."""
    from hairbsdf import _core

    table = {p["name"]: p["choices"] for p in _core.huang_option_schema()}
    assert _row("integrator.huang_sampler")["allowed"] == table["sampler"]
    assert _row("integrator.huang_glass_albedo_table")["allowed"] == table["glass_albedo_table"]


def test_world_program_has_the_material_program_layout():
    """A program's keys are declared once, for a material's and the world's program alike."""
    def layout(prefix):
        """The program's key rows, their paths relative to the program (its own row's meaning
        is where it is used)."""
        rows = [dict(k, path=k["path"][len(prefix):]) for k in scene_schema()
                if k["path"] == prefix or k["path"].startswith(prefix + ".")]
        rows[0]["meaning"] = ""
        return rows

    material = layout("materials[].program")
    assert [k["path"] for k in material] == ["", ".code", ".constants", ".registers"]
    assert layout("world.program") == material


def _scene():
    return {"camera": {"type": "PERSP", "matrix_world": np.eye(4), "resolution": (4, 2)},
            "integrator": {"samples": 1},
            "lights": [{"type": "SUN", "direction": (0, 0, 1), "strength": (1, 1, 1)}]}


@pytest.mark.parametrize("mutate,error,match", [
    (lambda s: s["lights"][0].pop("direction"), ValueError,
     r"^scene\['lights'\]\[0\]\['direction'\]: missing \(required"),
    (lambda s: s["lights"][0].update(type="AREA"), ValueError, r"^scene\['lights'\]\[0\]\['matrix_world'\]: missing"),
    (lambda s: s["camera"].update(resolution=(0, 2)), ValueError, r"^scene\['camera'\]\['resolution'\]\[0\]: must be >= 1"),
    (lambda s: s["integrator"].update(tilt=4.2), TypeError, r"^scene\['integrator'\]\['tilt'\]: expected a string, one of \['4.2', '3.4'\]"),
    (lambda s: s.update(version=2), ValueError, r"^scene\['version'\]: must be <= 1"),
    (lambda s: s["integrator"].update(samples=2**24 + 1), ValueError, r"^scene\['integrator'\]\['samples'\]: must be <= 16777216"),
    (lambda s: s["integrator"].update(max_bounces=2**20 + 1), ValueError,
     r"^scene\['integrator'\]\['max_bounces'\]: must be <= 1048576"),
    (lambda s: s.update(world={"texture": {"pixels": np.zeros((2, 4, 4)), "weight": (1, 1, 1)}}), ValueError,
     r"^scene\['world'\]\['texture'\]\['pixels'\]: expected shape \(height, width, 3\)"),
    (lambda s: s.update(materials=[{"closures": [{"type": "principled_hair", "inputs": {"roughness": "x"}}]}]),
     TypeError, r"^scene\['materials'\]\[0\]\['closures'\]\[0\]\['inputs'\]\['roughness'\]: expected a number"),
    (lambda s: s.update(materials=[{"closures": [], "program": {"code": [0], "constants": [1.0, 2.0],
                                                                "registers": 1}}]), ValueError,
     r"\['program'\]\['registers'\]: must be >= 2"),
])
def test_errors_name_the_key_path_and_what_is_allowed(mutate, error, match):
    scene = _scene()
    mutate(scene)
    with pytest.raises(error, match=match):
        validate_scene(scene)


def test_keys_of_other_types_are_not_read():
    scene = _scene()
    scene["lights"][0]["shape"] = "TRIANGLE"  # an AREA key on a SUN: not part of the format
    out = validate_scene(scene)
    assert "shape" not in out["lights"][0] and out["camera"]["resolution"] == (4, 2)


def test_validate_scene_does_not_load_tbb():
    code = ("import sys; from hairbsdf.render import validate_scene; import numpy as np;"
            "validate_scene({'camera': {'type': 'ORTHO', 'matrix_world': np.eye(4), 'resolution': (1, 1)},"
            " 'integrator': {'samples': 1}});"
            "maps = open('/proc/self/maps').read();"
            "assert 'libtbb' not in maps and 'hairbsdf._render' not in sys.modules, 'TBB loaded'")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_the_readers_read_materials_at_schema_rows():
    """render.cpp reads a material at the schema's named paths (scene_schema.h's k*Path; a path with no row is
    a logic_error, not an empty read): the loader's folded material gives back each key it was given,
    Principled Hair's inputs at _core.PRINCIPLED_HAIR_INPUTS."""
    from hairbsdf import _render

    inputs_row = _row(_core.PRINCIPLED_HAIR_INPUTS)
    assert inputs_row["kind"] == "dict" and inputs_row["closed"]
    material = {"name": "m", "closures": [
        {"type": "principled_hair", "model": "CHIANG", "parametrization": "MELANIN", "weight": (0.5, 0.5, 0.5),
         "inputs": {"melanin": 0.25, "roughness": 0.5}},
        {"type": "cycles_hair", "component": "TRANSMISSION", "color": (0.25, 0.5, 0.75), "roughness_u": 0.25}]}
    hair, legacy = _render.folded_material(material)["closures"]
    assert hair["weight"] == (0.5, 0.5, 0.5)
    assert (hair["inputs"]["melanin"], hair["inputs"]["roughness"]) == (0.25, 0.5)
    assert (legacy["component"], legacy["color"], legacy["roughness_u"]) == ("TRANSMISSION", (0.25, 0.5, 0.75), 0.25)


def test_hair_model_reads_model_and_path_by_their_rows():
    """A hair_model closure's model and path are bound rows (read_fields copies them; only params are read by
    hand): the loader's folded closure gives them back."""
    from hairbsdf import _render

    material = {"name": "m", "closures": [{"type": "hair_model", "model": "kajiya_kay", "path": "unused.so"}]}
    (model,) = _render.folded_material(material)["closures"]
    assert (model["model"], model["path"]) == ("kajiya_kay", "unused.so")
