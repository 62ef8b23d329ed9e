"""`hairbsdf fit` (docs/fit.md): safe spec parsing, recovery of known parameters, the residual
never above the start, the command line."""

import json
import subprocess
import sys

import numpy as np
import pytest

from hairbsdf import cli, gonio
from hairbsdf.fit import FIT_MODELS, fit, relative_errors
from hairbsdf.spec import SpecError, build, format_spec, parse_spec

PY = sys.executable


# --- Starts --------------------------------------------------------------------------------------------

# What a fit starts from or holds fixed where it is not the model's default (a fitting choice).
NOT_THE_DEFAULT = {"marschner": {"eccentricity"}, "deon": {"sigma_a"}, "principled": {"parametrization"}}


@pytest.mark.parametrize("name", sorted(FIT_MODELS))
def test_fits_start_at_the_models_defaults(name):
    """A fit's start keywords are the model's table defaults (read, not copied), but the declared choices."""
    from hairbsdf import model_schema
    from hairbsdf.principled import PRINCIPLED_HAIR_DEFAULTS

    model = FIT_MODELS[name]
    defaults = (PRINCIPLED_HAIR_DEFAULTS if name == "principled"
                else {p["name"]: p["default"] for p in model_schema(name)})
    start = model.kwargs({p.name: p.start for p in model.free})
    for key, value in start.items():
        if key in NOT_THE_DEFAULT.get(name, ()):
            continue
        if isinstance(value, str):
            assert value == defaults[key], key
        else:
            np.testing.assert_allclose(np.atleast_1d(value), np.atleast_1d(defaults[key]), rtol=1e-12, err_msg=key)


# --- Specs ------------------------------------------------------------------------------------------------

def test_spec_parses_literal_keywords():
    assert parse_spec("epic_hair(roughness=0.3, base_color=(0.2, 0.1, 0.05), shift=-0.02)") == (
        "epic_hair", {"roughness": 0.3, "base_color": (0.2, 0.1, 0.05), "shift": -0.02})
    assert parse_spec("epic") == ("epic_hair", {})
    assert parse_spec(" hairbsdf.deon_hair(tabulated=False, pigments='deon') ") == (
        "deon_hair", {"tabulated": False, "pigments": "deon"})
    # melanin without parametrization means the melanin parametrization ("color" would ignore it)
    assert parse_spec("principled_hair(melanin=0.6)") == ("principled_hair", {"parametrization": "melanin",
                                                                              "melanin": 0.6})
    assert parse_spec("principled_hair(absorption_coefficient=(1, 2, 3))")[1]["parametrization"] == "absorption"
    assert parse_spec("principled_hair(parametrization='color', melanin=0.6)")[1]["parametrization"] == "color"
    name, kwargs = parse_spec("marschner_hair(sigma_a=[0.5, 1, 2], beta_r=0.2)")
    assert parse_spec(format_spec(name, kwargs)) == (name, kwargs)


@pytest.mark.parametrize("text, fragment", [
    ("", "empty model spec"),
    ("epic_hair(roughness=", "cannot parse"),
    ("__import__('os').system('true')", "is not a constructor name"),
    ("os.system('true')", "is not a constructor name"),
    ("open(file='x')", "unknown constructor 'open'"),
    ("[epic_hair()]", "is not a call"),
    ("epic_hair(0.3)", "positional arguments are not allowed"),
    ("epic_hair(**{'roughness': 0.3})", "'**' is not allowed"),
    ("epic_hair(roughness=float('0.3'))", "is not a literal"),
    ("epic_hair(roughness=x)", "is not a literal"),
    ("epic_hair(roughness=1+1)", "is not a literal"),
    ("epic_hair(base_color={'r': 1})", "is not allowed"),
    ("epic_hair(base_color=('a', 1, 2))", "is not allowed"),
    ("epic_hair(roughness=0.3); 1", "cannot parse"),
])
def test_spec_errors_name_what_is_allowed(text, fragment):
    with pytest.raises(SpecError) as err:
        parse_spec(text)
    assert fragment in str(err.value)
    if fragment not in ("positional arguments are not allowed", "'**' is not allowed", "is not a literal",
                        "is not allowed"):
        assert "principled_hair" in str(err.value) and "deon_hair" in str(err.value)  # names the allowed ones


def test_constructor_errors_become_spec_errors():
    with pytest.raises(SpecError, match="roughness"):
        build("epic_hair(roughness=2.0)")
    with pytest.raises(SpecError, match="colour"):
        build("epic_hair(colour=1)")
    assert repr(build("principled_hair(melanin=0.6)")).startswith("principled_hair(model='chiang', "
                                                                  "parametrization='melanin'")


# --- Fits -------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("target, expected, tolerance", [
    ("epic_hair(base_color=(0.4, 0.25, 0.1), specular=0.7, roughness=0.45, shift=0.06, scatter=0.2)",
     {"base_color.r": 0.4, "base_color.g": 0.25, "base_color.b": 0.1, "specular": 0.7, "roughness": 0.45,
      "shift": 0.06, "scatter": 0.2}, 2e-3),
    ("kajiya_kay_hair(diffuse=(0.3, 0.2, 0.1), specular=0.4, exponent=30)",
     {"specular": 0.4, "diffuse_scale.r": 0.5, "diffuse_scale.g": 1 / 3, "diffuse_scale.b": 1 / 6, "exponent": 30.0},
     2e-3),
    # h-dependent: Chiang (melanin parametrization) averaged over h, fitted to itself
    ("principled_hair(melanin=0.4, melanin_redness=0.6, roughness=0.4, radial_roughness=0.5, offset=0.05)",
     {"melanin": 0.4, "melanin_redness": 0.6, "roughness": 0.4, "radial_roughness": 0.5, "offset": 0.05}, 2e-3),
])
def test_fit_recovers_known_parameters(target, expected, tolerance):
    model = {"principled_hair": "principled"}.get(parse_spec(target)[0], parse_spec(target)[0].replace("_hair", ""))
    res = fit(target, model, grid=10, h_count=12, max_evaluations=150)
    assert res.start_error["total"] > 0.1  # the declared start is elsewhere
    assert res.error["total"] < 1e-4, res
    for name, value in expected.items():
        assert res.free_values[name] == pytest.approx(value, rel=tolerance, abs=tolerance), (name, res.free_values)


def test_fit_recovers_from_a_given_start():
    target = "epic_hair(base_color=(0.4, 0.25, 0.1), roughness=0.3, shift=-0.05)"
    res = fit(target, "epic", grid=10, start={"roughness": 0.8, "shift": 0.2, "base_color.g": 0.9})
    assert res.free_values["roughness"] == pytest.approx(0.3, abs=1e-3)
    assert res.free_values["shift"] == pytest.approx(-0.05, abs=1e-3)
    assert res.parameters["base_color"] == pytest.approx((0.4, 0.25, 0.1), abs=1e-3)
    # a start on a log-scaled bound: exp(ln 10000) rounds above 10000, the constructor's limit
    at_bound = fit("kajiya_kay", "kajiya_kay", grid=4, start={"exponent": 10_000.0}, max_evaluations=3)
    assert at_bound.start_error["total"] > 0
    with pytest.raises(ValueError, match="outside"):
        fit(target, "epic", grid=4, start={"roughness": 2.0})
    with pytest.raises(ValueError, match="unknown free parameters"):
        fit(target, "epic", grid=4, start={"colour": 2.0})


def test_fit_starts_are_seeded_and_evaluations_bounded():
    kwargs = dict(grid=6, h_count=4, starts=3, max_evaluations=12)
    a = fit("principled_hair(melanin=0.3)", "epic", seed=7, **kwargs)
    b = fit("principled_hair(melanin=0.3)", "epic", seed=7, **kwargs)
    assert a.free_values == b.free_values and a.error == b.error
    assert a.evaluations == 3 * 12 and "stopped after 12 evaluations" in a.message
    single = fit("principled_hair(melanin=0.3)", "epic", grid=6, h_count=4, max_evaluations=12)
    assert a.error["total"] <= single.error["total"]  # the first start is the same; more starts never lose


@pytest.mark.parametrize("model, evaluations", [("epic", 30), ("kajiya_kay", 30), ("scheuermann", 20),
                                                ("marschner", 20), ("deon", 8), ("yan_fur", 24)])
def test_fit_residual_is_not_above_the_start(model, evaluations):
    res = fit("principled_hair(melanin=0.5, melanin_redness=0.5)", model, grid=8, h_count=16,
              max_evaluations=evaluations)
    assert res.error["total"] <= res.start_error["total"] * (1 + 1e-12), res
    assert res.error["total"] < 0.9 * res.start_error["total"]  # and it moved
    FIT_MODELS[model].closure(res.free_values)  # the fit is a valid model
    assert build(res.spec) is not None  # and its printed spec reads back


def test_relative_errors_per_lobe():
    g = gonio.GonioGrid.make(4)
    target = np.random.default_rng(1).random((len(g), 4, 3))
    same = relative_errors(target, target, g.weights, ("R", "TT", "TRT", "TRRT+"))
    assert same == {"total": 0.0, "R": 0.0, "TT": 0.0, "TRT": 0.0, "TRRT+": 0.0}
    half = relative_errors(0.5 * target, target, g.weights, ("R", "TT", "TRT", None))
    assert half["total"] == pytest.approx(0.5)
    assert half["TRRT+"] is None and half["R"] > 0
    assert relative_errors(target, target, g.weights)["R"] is None  # lobes of other light paths


def test_grid_weights_are_solid_angle():
    g = gonio.GonioGrid.make(16)
    assert g.weights.sum() == pytest.approx(1.0)
    # the mean of sin^2 theta over the sphere is 1/3, for wo and for wi
    assert np.sum(g.weights * g.wi[:, 0] ** 2) == pytest.approx(1 / 3, rel=1e-2)
    assert np.allclose(np.linalg.norm(g.wi, axis=1), 1.0)


# --- Command line -----------------------------------------------------------------------------------------

def test_fit_help():
    r = subprocess.run([PY, "-m", "hairbsdf.cli", "fit", "--help"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    for opt in ("--target", "--model", "--grid", "--json", "--seed", "--out", "--list", "epic", "deon"):
        assert opt in r.stdout, opt
    assert "hairbsdf fit" in cli.USAGE and "hairbsdf plot" in cli.USAGE


def test_fit_list_names_every_model(capsys):
    assert cli.main(["fit", "--list"]) == 0
    out = capsys.readouterr().out
    for name, fm in FIT_MODELS.items():
        assert name in out and all(p.name in out for p in fm.free)


def test_fit_command_rejects_a_bad_spec(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["fit", "--target", "__import__('os')", "--model", "epic"])
    assert exc.value.code == 2
    assert "principled_hair" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.main(["fit", "--target", "principled_hair()", "--model", "phong"])
    assert "unknown fit model" in capsys.readouterr().err


def test_fit_command_json_and_plot(tmp_path, capsys):
    rc = cli.main(["fit", "--target", "principled_hair(melanin=0.6)", "--model", "epic", "--grid", "6",
                   "--h-nodes", "2", "--max-evaluations", "10", "--json", "--quiet", "--out", str(tmp_path)])
    assert rc == 0
    data = json.loads(capsys.readouterr().out)
    assert data["model"] == "epic" and data["target"].startswith("principled_hair(parametrization='melanin'")
    assert data["error"]["total"] <= data["start_error"]["total"]
    assert set(data["error"]) == {"total", "R", "TT", "TRT", "TRRT+"}
    png = tmp_path / "fit_epic.png"
    assert str(png) in data["files"] and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert json.loads((tmp_path / "fit.json").read_text())["spec"] == data["spec"]


def test_import_does_not_need_matplotlib_or_scipy():
    code = "import sys, hairbsdf, hairbsdf.cli; print('matplotlib' in sys.modules, 'scipy' in sys.modules)"
    r = subprocess.run([PY, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.split() == ["False", "False"], r.stdout + r.stderr
