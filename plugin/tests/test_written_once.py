"""Names the Python side shares are written in one place (issue 26): the others read them from there.
Each test fails when a copy reappears as a literal."""

import ast
import inspect
import re
from pathlib import Path

from hairbsdf._constants import ENGINE_ID

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "plugin" / "hairbsdf"


def string_literals(path: Path):
    """(line, text) of each string constant in a Python file, docstrings left out (prose may name things)."""
    tree = ast.parse(path.read_text(), str(path))
    docstrings = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                docstrings.add(id(first.value))
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
            yield node.lineno, node.value


def python_sources():
    """The package, the add-on and the scripts' Python files."""
    for folder in (PACKAGE, ROOT / "plugin" / "blender_addon", ROOT / "scripts"):
        yield from sorted(folder.rglob("*.py"))


def shell_scripts():
    """scripts/ files that are not Python (bash, some with Python in a here-document)."""
    return sorted(p for p in (ROOT / "scripts").iterdir() if p.is_file() and p.suffix != ".py")


def test_engine_id_is_written_only_in_constants():
    word = re.compile(r"\b%s\b" % re.escape(ENGINE_ID))
    one_place = PACKAGE / "_constants.py"
    copies = ["%s:%d: %r" % (p.relative_to(ROOT), line, text[:80])
              for p in python_sources() if p != one_place
              for line, text in string_literals(p) if word.search(text)]
    quoted = re.compile(r"[\"']%s[\"']" % re.escape(ENGINE_ID))
    copies += ["%s:%d" % (p.relative_to(ROOT), n) for p in shell_scripts()
               for n, text in enumerate(p.read_text(errors="replace").splitlines(), 1) if quoted.search(text)]
    assert not copies, "the engine id %r is spelled outside hairbsdf/_constants.py; import ENGINE_ID (or, in a " \
                       "job script, read job['engine_id']):\n%s" % (ENGINE_ID, "\n".join(copies))


def test_plugin_model_name_is_written_only_in_the_factory():
    """model_factory.h's kPluginModel, read as _core.PLUGIN_MODEL (hairbsdf.zoo.PLUGIN_MODEL); the model
    names are one list, _core.model_names(), that the scene's hair_model closure allows too."""
    from hairbsdf import _core

    name = _core.PLUGIN_MODEL
    copies = ["%s:%d: %r" % (p.relative_to(ROOT), line, text)
              for p in sorted(PACKAGE.rglob("*.py"))
              for line, text in string_literals(p) if text == name or text.startswith(name + ":")]
    assert not copies, "the plugin model's name %r is spelled in Python; use hairbsdf.zoo.PLUGIN_MODEL:\n%s" % (
        name, "\n".join(copies))
    assert _core.model_names()[-1] == name and set(_core.zoo_model_names()) < set(_core.model_names())


def version_comparisons(path: Path):
    """(line, tuple) of each comparison with a literal version tuple, such as `blender_version() < (4, 0, 0)`."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Compare):
            for side in [node.left, *node.comparators]:
                if isinstance(side, ast.Tuple) and len(side.elts) == 3 and all(
                        isinstance(e, ast.Constant) and isinstance(e.value, int) for e in side.elts):
                    yield node.lineno, tuple(e.value for e in side.elts)


def test_blender_version_cutoffs_are_named_once():
    """Every Blender version the package compares with is a named cut-off in hairbsdf/_blender_versions.py (the
    library scenes, which run without the package, read that file by its path)."""
    one_place = PACKAGE / "_blender_versions.py"
    copies = ["%s:%d: %s" % (p.relative_to(ROOT), line, version)
              for p in sorted(PACKAGE.rglob("*.py")) if p != one_place for line, version in version_comparisons(p)]
    assert not copies, "compare with a named cut-off of hairbsdf/_blender_versions.py:\n" + "\n".join(copies)
    from hairbsdf import _blender_versions as versions
    assert versions.tilt_convention((4, 1, 9)) == "3.4" and versions.tilt_convention(versions.TILT_ON_VIEW_FROM) == "4.2"


def test_scene_format_version_is_the_schemas():
    """The scene description's version is read from the schema's `version` row (scene_schema.cpp), never
    written as a number in the package (`SCENE_DESC_VERSION = 1`, `{"version": 1}`)."""
    from hairbsdf.render import SCENE_DESC_VERSION, scene_schema

    (row,) = [k for k in scene_schema() if k["path"] == "version"]
    assert SCENE_DESC_VERSION == row["minimum"] == row["maximum"] == int(row["default"])
    copies = []
    for p in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(p.read_text(), str(p))):
            if isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant) and any(
                    isinstance(t, ast.Name) and t.id == "SCENE_DESC_VERSION" for t in node.targets):
                copies.append("%s:%d" % (p.relative_to(ROOT), node.lineno))
            if isinstance(node, ast.Dict):
                copies += ["%s:%d" % (p.relative_to(ROOT), node.lineno) for key, value in zip(node.keys, node.values)
                           if isinstance(key, ast.Constant) and key.value == "version"
                           and isinstance(value, ast.Constant) and isinstance(value.value, int)]
    assert not copies, "the scene format's version is written as a number; use hairbsdf.render." \
                       "SCENE_DESC_VERSION:\n" + "\n".join(copies)


def literal_fallbacks(function: ast.FunctionDef, names: set, choices: set):
    """(line, key) of each `x.get(key, literal)` in a function whose key is one of `names` and whose literal is
    a value a key could default to: a number, a bool, a tuple of numbers or one of the `choices`."""
    def value_like(e):
        return isinstance(e, ast.Constant) and (isinstance(e.value, (int, float)) or e.value in choices)

    for node in ast.walk(function):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "get"
                and len(node.args) == 2 and isinstance(node.args[0], ast.Constant) and node.args[0].value in names):
            fallback = node.args[1]
            if value_like(fallback) or (isinstance(fallback, ast.Tuple) and all(map(value_like, fallback.elts))):
                yield node.lineno, node.args[0].value


def test_portable_reads_the_schemas_defaults():
    """portable.py's materialx_limits, write_materialx and render_settings take a missing key's default from the
    scene schema (portable._key), never from a literal fallback. (write_materialx's grey, _core's
    DEFAULT_SURFACE_COLOR, is no literal.)"""
    from hairbsdf.render import scene_schema

    names = {k["path"].rsplit(".", 1)[-1].removesuffix("[]") for k in scene_schema()}
    choices = {c for k in scene_schema() for c in k["allowed"]}
    path = PACKAGE / "compare" / "portable.py"
    functions = {n.name: n for n in ast.parse(path.read_text()).body if isinstance(n, ast.FunctionDef)}
    copies = ["portable.py:%d: %s" % hit for name in ("materialx_limits", "write_materialx", "render_settings")
              for hit in literal_fallbacks(functions[name], names, choices)]
    assert not copies, "a scene key's default written again; use portable._key:\n" + "\n".join(copies)


def accuracy_literals(path: Path, ids: set):
    """(line, what) where the harness spells an accuracy id: a literal compared with an expression that mentions
    `accuracy`, passed as `accuracy=` or as .get("accuracy", ...)'s fallback, or any literal accuracy id that
    is not also an engine id (CYCLES is both)."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any("accuracy" in ast.unparse(s) for s in sides) and any(
                    isinstance(s, ast.Constant) and s.value in ids for s in sides):
                yield node.lineno, ast.unparse(node)
        elif isinstance(node, ast.keyword) and node.arg == "accuracy" and isinstance(node.value, ast.Constant):
            yield node.value.lineno, "accuracy=%r" % node.value.value
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "get"
              and len(node.args) == 2 and isinstance(node.args[0], ast.Constant) and node.args[0].value == "accuracy"):
            yield node.lineno, ast.unparse(node)
        elif isinstance(node, ast.Constant) and node.value in ids - {"CYCLES"}:
            yield node.lineno, repr(node.value)


def test_harness_reads_the_accuracy_ids_from_the_schema():
    """The harness's accuracy settings (runner.ACCURACIES) are the scene schema's integrator.accuracy choices;
    blender_job.py gets them in job.json."""
    from hairbsdf.compare import runner
    from hairbsdf.render import schema_choices

    assert runner.ACCURACIES == tuple(a.upper() for a in schema_choices("integrator.accuracy"))
    copies = ["%s:%d: %s" % (p.name, line, what) for p in (PACKAGE / "compare").glob("*.py")
              for line, what in accuracy_literals(p, set(runner.ACCURACIES))]
    assert not copies, "an accuracy id spelled in the harness; use runner.ACCURACIES:\n" + "\n".join(copies)


def test_parameter_kind_names_come_from_the_core():
    """The parameter kinds' names (a schema dict's "type") are C++'s (hairbsdf/param_kinds.h), read as
    _core.PARAM_KINDS and unpacked once in hairbsdf/_param_docs.py; no module compares a kind with a literal."""
    from hairbsdf import _core, _param_docs, zoo

    assert _param_docs.PARAM_KINDS == _core.PARAM_KINDS
    assert {row["type"] for m in zoo.zoo_model_names() + ["cycles_hair"] for row in zoo.model_schema(m)} <= set(
        _core.PARAM_KINDS)
    names = set(_core.PARAM_KINDS) | {k.upper() for k in _core.PARAM_KINDS}
    copies = []
    for p in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(p.read_text(), str(p))):
            if isinstance(node, ast.Compare):
                sides = [node.left, *node.comparators]
                if any(re.search(r"""\[["']type["']\]|\.type\b|\.kind\b""", ast.unparse(s)) for s in sides) and any(
                        isinstance(s, ast.Constant) and s.value in names for s in sides):
                    copies.append("%s:%d: %s" % (p.relative_to(ROOT), node.lineno, ast.unparse(node)))
    assert not copies, "a parameter kind spelled again; use hairbsdf._param_docs' names:\n" + "\n".join(copies)


def test_producers_read_the_schemas_choice_lists():
    """A scene key's list of choices (all of its names in one tuple, list, set or dict's values; a subset is a
    condition, not the list) is the schema row's: producers read it with hairbsdf.render.schema_choices(path)."""
    from hairbsdf.render import scene_schema

    choice_sets = {}
    for row in scene_schema():
        if row["kind"] == "enum" and len(row["allowed"]) >= 2:
            choice_sets.setdefault(frozenset(row["allowed"]), row["path"])

    def spelled_lists(path):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            items = node.values if isinstance(node, ast.Dict) else getattr(node, "elts", None)
            if not isinstance(node, (ast.Tuple, ast.List, ast.Set, ast.Dict)) or not items or len(items) < 2:
                continue
            if all(isinstance(x, ast.Constant) and isinstance(x.value, str) for x in items):
                names = frozenset(x.value for x in items)
                if names in choice_sets:
                    yield node.lineno, choice_sets[names], sorted(names)

    # The catalog's variants are the scenes a test renders; that ribbons_vs_3d renders every shape is its choice.
    chosen = {PACKAGE / "compare" / "scenes" / "catalog.py"}
    copies = ["%s:%d: %s spells %s" % (p.relative_to(ROOT), line, key, names)
              for p in python_sources() if p not in chosen for line, key, names in spelled_lists(p)]
    assert not copies, "choice lists written again (read them with schema_choices):\n" + "\n".join(copies)


def test_chiang_row_inputs_are_the_schemas_rows():
    """The inputs that may vary per row (closure.ROW_INPUTS, from C++ chiang_row_inputs) are named and shaped by
    the scene schema's Principled Hair rows; closure.py tells a number from an RGB input by that shape, never by
    comparing with an input's name."""
    from hairbsdf.closure import ROW_INPUTS
    from hairbsdf.render import principled_hair_input_rows

    rows = principled_hair_input_rows()
    assert ROW_INPUTS and set(ROW_INPUTS) <= set(rows)
    assert ROW_INPUTS == {name: rows[name]["columns"] if rows[name]["kind"] == "vector" else 0 for name in ROW_INPUTS}
    path = PACKAGE / "closure.py"
    copies = ["closure.py:%d: %s" % (node.lineno, ast.unparse(node))
              for node in ast.walk(ast.parse(path.read_text(), str(path))) if isinstance(node, ast.Compare)
              for side in [node.left, *node.comparators] if isinstance(side, ast.Constant) and side.value in rows]
    assert not copies, "a per-row input compared by name; use ROW_INPUTS[name] (its columns):\n" + "\n".join(copies)


def test_principled_hair_inputs_path_is_written_once():
    """The scene key of Principled Hair's inputs is hairbsdf.render.PRINCIPLED_HAIR_INPUTS; the others read its
    rows with render.principled_hair_input_rows()."""
    from hairbsdf.render import PRINCIPLED_HAIR_INPUTS

    one_place = PACKAGE / "render.py"
    copies = ["%s:%d: %r" % (p.relative_to(ROOT), line, text) for p in python_sources() if p != one_place
              for line, text in string_literals(p) if PRINCIPLED_HAIR_INPUTS in text]
    assert not copies, "the Principled Hair inputs' path spelled again; use hairbsdf.render's " \
                       "principled_hair_input_rows:\n" + "\n".join(copies)


def float_literals(path: Path):
    """(line, value) of each float constant in a Python file."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Constant) and isinstance(node.value, float):
            yield node.lineno, node.value


def test_luminance_weights_are_written_once():
    """The Rec.709 luminance weights of C++ luminance() (math.h) reach Python as _core.LUMINANCE_WEIGHTS (gonio,
    compare.metrics); Cycles' rgb_to_y in Linear Rec.709 (more digits: Blender's colour -> float conversion) is
    another fact, written once in blender/_common.py. No other module spells either."""
    import numpy as np

    from hairbsdf import _core, gonio
    from hairbsdf.blender._common import CYCLES_REC709_RGB_TO_Y
    from hairbsdf.compare import metrics

    assert tuple(gonio.REC709) == _core.LUMINANCE_WEIGHTS
    assert tuple(metrics.luminance(np.eye(3)[None])[0]) == _core.LUMINANCE_WEIGHTS
    one_place = PACKAGE / "blender" / "_common.py"
    copies = ["%s:%d: %r" % (p.relative_to(ROOT), line, value) for p in python_sources()
              for line, value in float_literals(p)
              if value in _core.LUMINANCE_WEIGHTS or (value in CYCLES_REC709_RGB_TO_Y and p != one_place)]
    assert not copies, "luminance weights spelled again; use _core.LUMINANCE_WEIGHTS (or, for Blender's " \
                       "conversion, _common.CYCLES_REC709_RGB_TO_Y):\n" + "\n".join(copies)


def test_cycles_addon_is_checked_once():
    """Export requires the Cycles add-on, checked once (export_scene.cycles_settings raises ExportError without it);
    the exporter then reads an object's Cycles settings (light.cycles, world.cycles, material.cycles) directly, with
    no fallback for a missing add-on (getattr(x, "cycles", None))."""
    copies = []
    for p in sorted((PACKAGE / "blender").glob("*.py")):
        for node in ast.walk(ast.parse(p.read_text(), str(p))):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("getattr", "hasattr")
                    and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant)
                    and str(node.args[1].value).startswith("cycles")):
                copies.append("%s:%d: %s" % (p.relative_to(ROOT), node.lineno, ast.unparse(node)))
    assert not copies, "a fallback for a missing Cycles add-on (export_scene.cycles_settings already requires " \
                       "it); read x.cycles:\n" + "\n".join(copies)


def cpp_string_literals(text: str, first_line: int = 1):
    """(line, text) of each string literal in C++ source, comments and prose (a docstring of sentences) left out."""
    literal = re.compile(r'"(?:[^"\\\n]|\\.)*"|//[^\n]*|/\*.*?\*/', re.S)
    for m in literal.finditer(text):
        if m.group().startswith('"') and not re.search(r"\w\. [A-Z]", m.group()):
            yield first_line + text.count("\n", 0, m.start()), m.group()[1:-1]


def test_array_keys_are_named_only_in_the_schemas_rows():
    """The scene's array and image keys (curves.points, meshes.triangles, attributes' data, programs' code, ...) are
    named once, in their scene_schema.cpp rows, which bind each to its vector and say which count its length matches:
    render.cpp reads them with read_fields / read_list, and the walker's length checks take the names from the rows."""
    from hairbsdf.render import scene_schema

    names = {k["path"].rsplit(".", 1)[-1] for k in scene_schema() if k["kind"] in ("array", "image")}
    assert {"points", "curve_offsets", "triangles", "data", "code", "pixels"} <= names
    word = re.compile(r"\b(%s)\b" % "|".join(sorted(names)))
    bindings = ROOT / "plugin" / "bindings"
    schema = (bindings / "scene_schema.cpp").read_text()
    table_end = schema.index("\nstd::string leaf(")  # the walker and the readers follow the table
    sources = {"render.cpp": ((bindings / "render.cpp").read_text(), 1),
               "scene_schema.cpp": (schema[table_end:], schema.count("\n", 0, table_end) + 1)}
    copies = ["%s:%d: %r" % (name, line, text) for name, (source, first_line) in sources.items()
              for line, text in cpp_string_literals(source, first_line) if word.search(text)]
    assert not copies, "an array key spelled outside its schema row; read its row (SceneKey::defines, per, ...):\n" + \
                       "\n".join(copies)


def name_groups(path: Path):
    """(line, names) of each tuple, list or set literal of two or more string constants (None elements allowed)."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)) and all(isinstance(e, ast.Constant) for e in node.elts):
            names = [e.value for e in node.elts if e.value is not None]
            if len(names) >= 2 and all(isinstance(n, str) for n in names):
                yield node.lineno, names


def test_principled_color_inputs_come_from_the_schema():
    """Principled Hair's RGB inputs are its schema rows of kind "vector"; no module lists them again."""
    from hairbsdf.principled import _COLOR_INPUTS
    from hairbsdf.render import principled_hair_input_rows

    assert _COLOR_INPUTS == {k for k, row in principled_hair_input_rows().items() if row["kind"] == "vector"}
    copies = ["%s:%d: %r" % (p.relative_to(ROOT), line, names) for p in python_sources()
              for line, names in name_groups(p) if set(names) <= _COLOR_INPUTS]
    assert not copies, "Principled Hair's RGB inputs listed again; read the schema rows' kind:\n" + "\n".join(copies)


def test_lobe_names_are_written_only_in_closure():
    """The lobe names are closure.LOBES (and YAN_FUR_LOBES); no other module lists them (fit's lobe_of_slot uses
    LOBES)."""
    from hairbsdf.closure import YAN_FUR_LOBES

    one_place = PACKAGE / "closure.py"
    copies = ["%s:%d: %r" % (p.relative_to(ROOT), line, names) for p in python_sources() if p != one_place
              for line, names in name_groups(p) if set(names) <= set(YAN_FUR_LOBES)]
    assert not copies, "lobe names listed again; use hairbsdf.closure.LOBES:\n" + "\n".join(copies)


def defaulted_reads(path: Path):
    """(line, key, default, source) of each getattr(x, "key", default) and x.get("key", default) whose default is a
    literal (a constant, a tuple of them, or np.pi / math.pi as "pi"): a fallback value written at the read."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if not isinstance(node, ast.Call) or len(node.args) < 2:
            continue
        is_getattr = isinstance(node.func, ast.Name) and node.func.id == "getattr" and len(node.args) == 3
        is_get = isinstance(node.func, ast.Attribute) and node.func.attr == "get" and len(node.args) == 2
        key, default = node.args[-2], node.args[-1]
        if not ((is_getattr or is_get) and isinstance(key, ast.Constant) and isinstance(key.value, str)):
            continue
        if isinstance(default, ast.Attribute) and default.attr == "pi":
            yield node.lineno, key.value, "pi", ast.unparse(node)
            continue
        try:
            value = ast.literal_eval(default)
        except ValueError:
            continue
        if value is not None:
            yield node.lineno, key.value, value, ast.unparse(node)


def scene_defaults_by_leaf() -> dict:
    """A scene key's last name -> its rows' defaults: the value (render.schema_default) and the row's text,
    strings in lower case."""
    from hairbsdf.render import schema_default, scene_schema

    out = {}
    for row in scene_schema():
        defaults = out.setdefault(row["path"].rsplit(".", 1)[-1], set())
        if row["default"]:
            defaults.add(row["default"].lower())
        for closure_type in row["only_for"].split() or [""]:
            try:
                value = schema_default(row["path"], closure_type)
            except (KeyError, ValueError):
                continue
            defaults.add(value.lower() if isinstance(value, str) else value)
    return out


def test_fallbacks_do_not_repeat_scene_defaults():
    """A scene key's default is its schema row's (the renderer's field): a reader of a Blender attribute or a keyword
    that names a scene key leaves the key out when it is missing, or reads render.schema_default / the one named
    default (principled.DEFAULT_MODEL, _common.TILT_AUTO); it never writes the default again as a fallback. The "AUTO"
    identifier (the tilt setting's and curve_intersector's) is written once, in blender/_common.py. (compare/scenes/ builds Blender scenes in Blender
    itself: its node settings are not scene keys.)"""
    from hairbsdf.blender._common import TILT_AUTO

    defaults = scene_defaults_by_leaf()
    assert {"spread", "visible_camera", "emission_sampling", "model"} <= set(defaults)

    def repeats(key, value):
        value = value.lower() if isinstance(value, str) else value
        return key in defaults and (value in defaults[key] if not isinstance(value, (list, dict)) else False)

    sources = [p for p in sorted(PACKAGE.rglob("*.py")) if "scenes" not in p.relative_to(PACKAGE).parts]
    copies = ["%s:%d: %s" % (p.relative_to(ROOT), line, source) for p in sources
              for line, key, value, source in defaulted_reads(p) if repeats(key, value)]
    blender = PACKAGE / "blender"
    copies += ["%s:%d: %r" % (p.relative_to(ROOT), line, text) for p in sorted(blender.glob("*.py"))
               if p != blender / "_common.py" for line, text in string_literals(p) if text == TILT_AUTO[0]]
    assert not copies, "a scene key's default written again as a fallback; leave the key out or read the " \
                       "schema's default:\n" + "\n".join(copies)


def test_huang_options_are_named_only_in_their_table():
    """Huang's options (params/huang.h's table, principled.HUANG_OPTIONS) give _principled_huang its signature and
    are passed on by row: principled.py spells none of their names (only those principled_hair itself takes)."""
    from hairbsdf import principled

    signature = inspect.signature(principled._principled_huang).parameters
    assert {name: signature[name].default for name in principled.HUANG_OPTIONS} == principled.HUANG_OPTION_DEFAULTS
    own = set(inspect.signature(principled.principled_hair).parameters)
    path = PACKAGE / "principled.py"
    copies = ["principled.py:%d: %r" % (line, text) for line, text in string_literals(path)
              if text in principled.HUANG_OPTIONS and text not in own]
    assert not copies, "a Huang option named again; read principled.HUANG_OPTIONS:\n" + "\n".join(copies)


def test_zoo_constructors_are_named_only_by_their_decorator():
    """Each zoo model's constructor is recorded by zoo._from_table (zoo.CONSTRUCTOR_OF_MODEL); spec's names and
    aliases and fit's models derive from it, so no module writes a constructor's name as a string (the package's
    __all__, its public names, aside)."""
    from hairbsdf import fit, spec
    from hairbsdf.zoo import CONSTRUCTOR_OF_MODEL, zoo_model_names

    constructors = {CONSTRUCTOR_OF_MODEL[m] for m in zoo_model_names()}
    assert constructors <= set(spec.CONSTRUCTORS)
    assert all(spec.ALIASES.get(m, m) == CONSTRUCTOR_OF_MODEL[m] for m in zoo_model_names())
    assert all(fit.fit_model(CONSTRUCTOR_OF_MODEL[m]).name == m for m in zoo_model_names() if m in fit.FIT_MODELS)
    copies = ["%s:%d: %r" % (p.relative_to(ROOT), line, text) for p in python_sources() if p != PACKAGE / "__init__.py"
              for line, text in string_literals(p) if text in constructors - set(zoo_model_names())]
    assert not copies, "a zoo constructor's name written as a string; read zoo.CONSTRUCTOR_OF_MODEL:\n" + \
                       "\n".join(copies)


def test_materialx_inputs_are_named_only_in_their_tables():
    """The MaterialX node helpers' signatures, checks and dicts come from their tables (params/materialx.h, read
    through _core.materialx_schema): those functions spell no input name and tell an input's kind by its row's type
    (no prefix test such as "roughness_"), its lower bound by its row's min. (The simple_hair graph and the .mtlx
    writer wire the nodes' inputs by name: a graph is not a table.)"""
    from hairbsdf import _core, materialx

    nodes = ("chiang_hair_bsdf", "chiang_hair_roughness", "chiang_hair_absorption_from_color",
             "deon_hair_absorption_from_melanin")
    names = {row["name"] for node in nodes for row in _core.materialx_schema(node)}
    assert all(tuple(inspect.signature(getattr(materialx, node)).parameters)[-len(_core.materialx_schema(node)):]
               == tuple(row["name"] for row in _core.materialx_schema(node)) for node in nodes)
    path = PACKAGE / "materialx.py"
    helpers = [node for node in ast.parse(path.read_text()).body
               if isinstance(node, ast.FunctionDef) and node.name in {*nodes, "_pair", "_checked", "_from_table"}]
    assert len(helpers) == len(nodes) + 3
    copies = ["materialx.py:%d: %r" % (n.lineno, n.value) for helper in helpers for n in ast.walk(helper)
              if isinstance(n, ast.Constant) and isinstance(n.value, str)
              and (n.value in names or (n.value.endswith("_") and any(name.startswith(n.value) for name in names)))]
    assert not copies, "a MaterialX input named again; read its table row:\n" + "\n".join(copies)
