"""The `hair_model` closure of the path tracer (docs/scene_desc.md): every zoo model and the
example plugin rendered on one strand give, pixel by pixel, the closure's eval at the pixel
centre (the BSDF-level key check of test_render.py), and under a uniform world their
directional albedo (which exercises sample and pdf through MIS); bad models and parameters
are errors naming the material and the parameter."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf.render import render, validate_scene
from test_render import R, _integrator, _ortho_camera, _straight_strand, _unit

# (model, params for the scene dict, the same closure through the Python API)
ZOO = [
    ("kajiya_kay", {}, lambda: hairbsdf.kajiya_kay_hair()),
    ("kajiya_kay", {"diffuse": (0.6, 0.3, 0.1), "specular": 0.3, "exponent": 12.0},
     lambda: hairbsdf.kajiya_kay_hair(diffuse=(0.6, 0.3, 0.1), specular=0.3, exponent=12)),
    ("epic", {"base_color": (0.6, 0.4, 0.2), "scatter": 0.5, "variant": "direct"},
     lambda: hairbsdf.epic_hair(base_color=(0.6, 0.4, 0.2), scatter=0.5)),
    ("scheuermann", {}, lambda: hairbsdf.scheuermann_hair()),
    ("marschner", {"sigma_a": (0.2, 0.4, 0.8), "beta_r": 0.2},
     lambda: hairbsdf.marschner_hair(sigma_a=(0.2, 0.4, 0.8), beta_r=0.2)),
    ("deon", {"melanin": 0.3, "roughness": 0.25}, lambda: hairbsdf.deon_hair(melanin=0.3, roughness=0.25)),
    ("yan_fur", {"medulla_ratio": 0.6, "cortex_absorption": (0.2, 0.4, 0.8)},
     lambda: hairbsdf.yan_fur(medulla_ratio=0.6, cortex_absorption=(0.2, 0.4, 0.8))),
]
IDS = ["kajiya_kay", "kajiya_kay-params", "epic", "scheuermann", "marschner", "deon", "yan_fur"]


def _material(model, params, path=None, weight=(1.0, 1.0, 1.0)):
    c = {"type": "hair_model", "weight": weight, "model": model, "params": params}
    if path is not None:
        c["path"] = str(path)
    return {"name": "hair", "closures": [c]}


def _frame(wo):
    x = np.array([1.0, 0, 0])
    y = _unit(np.cross(x, wo))
    return x, y, np.cross(x, y)


def _pixels_vs_eval(material, closure, wo, wi, weight=1.0):
    """Renders one strand lit by a delta sun and returns (rendered, expected) for the pixels
    inside the strand (see test_render.test_strand_pixels_equal_bsdf_eval)."""
    wo, wi = _unit(wo), _unit(wi)
    height, across = 120, 90
    pixel = 2 * R / across
    camera, yc = _ortho_camera(wo, height * pixel, (4, height))
    strength = 2.5
    scene = {"version": 1, "curves": _straight_strand(), "curve_shape": "THICK", "materials": [material],
             "camera": camera, "lights": [{"type": "SUN", "direction": tuple(wi), "strength": (strength,) * 3}],
             "world": {"color": (0, 0, 0)}, "integrator": _integrator()}
    out = render(scene)
    assert out["stats"]["nan_count"] == 0 and not out["stats"]["warnings"]
    img = out["combined"]
    s = ((height - 1 - np.arange(height)) + 0.5 - height / 2) * pixel
    x, y, z = _frame(wo)
    h = -s * np.dot(yc, y) / R
    inside = np.abs(h) < 0.98
    local = lambda w: np.array([w @ x, w @ y, w @ z])  # noqa: E731
    n = int(inside.sum())
    random = hairbsdf.cycles_curve_random(0)
    expected = weight * strength * closure.eval(np.tile(local(wo), (n, 1)), np.tile(local(wi), (n, 1)), h[inside],
                                                random=np.full(n, float(random)))
    return img[inside, 1, :3].astype(np.float64), expected


def _assert_equal_pixels(got, expected):
    assert np.max(expected) > 1e-3, "the test geometry sees no light: pick other directions"
    rel = np.abs(got - expected) / np.maximum(np.abs(expected), 1e-6 * np.max(expected))
    assert np.median(rel) <= 1e-5, f"median relative error {np.median(rel):.2e}"
    assert np.percentile(rel, 99) <= 1e-3, f"p99 relative error {np.percentile(rel, 99):.2e}"


@pytest.mark.parametrize("model,params,make", ZOO, ids=IDS)
@pytest.mark.parametrize("wo,wi", [((0.3, 0.5, 0.8), (-0.2, -0.7, 0.4)), ((-0.4, 0.1, 0.9), (0.5, 0.3, -0.8))],
                         ids=["front", "back"])
def test_zoo_strand_pixels_equal_eval(model, params, make, wo, wi):
    got, expected = _pixels_vs_eval(_material(model, params), make(), wo, wi)
    _assert_equal_pixels(got, expected)


def test_weight_scales_the_model():
    got, expected = _pixels_vs_eval(_material("kajiya_kay", {}, weight=(0.5, 0.25, 1.0)), hairbsdf.kajiya_kay_hair(),
                                    (0.3, 0.5, 0.8), (-0.2, -0.7, 0.4))
    _assert_equal_pixels(got, expected * np.array([0.5, 0.25, 1.0]))


@pytest.mark.parametrize("wo,wi", [((0.3, 0.5, 0.8), (-0.2, -0.7, 0.4)), ((-0.4, 0.1, 0.9), (0.5, 0.3, -0.8))],
                         ids=["front", "back"])
def test_plugin_strand_pixels_equal_eval(kk_path, kk, wo, wi):
    params = {"color": (0.7, 0.5, 0.2), "specular": 0.4, "exponent": 25.0}
    got, expected = _pixels_vs_eval(_material("plugin", params, kk_path), kk(**params), wo, wi)
    _assert_equal_pixels(got, expected)


def _world_albedo(material, closure, wo, spp):
    """Direct light from a uniform white world (MIS of world and BSDF samples, no bounces): the
    means over 48 pixels along the strand of some rows, with their standard errors, and the
    closure's directional albedo (quadrature) at each row's h."""
    wo = _unit(wo)
    height, width = 24, 48
    pixel = 2 * R / 20
    camera, yc = _ortho_camera(wo, height * pixel, (width, height))
    scene = {"version": 1, "curves": _straight_strand(length=4.0), "curve_shape": "THICK", "materials": [material],
             "camera": camera, "world": {"color": (1.0, 1.0, 1.0)}, "integrator": _integrator(samples=spp)}
    img = render(scene)["combined"][..., :3].astype(np.float64)
    s = ((height - 1 - np.arange(height)) + 0.5 - height / 2) * pixel
    x, y, z = _frame(wo)
    h = -s * np.dot(yc, y) / R
    rows = np.flatnonzero(np.abs(h) < 0.95)[::3]  # quadratures are slow for narrow plugin lobes
    mean, se = img[rows].mean(axis=1), img[rows].std(axis=1, ddof=1) / np.sqrt(width)
    local = np.array([wo @ x, wo @ y, wo @ z])
    albedo = np.array([closure.albedo(local, hh)[0] for hh in h[rows]])
    return mean, se, albedo


@pytest.mark.parametrize("model,params,make", [ZOO[1], ZOO[2], ZOO[4]], ids=["kajiya_kay", "epic", "marschner"])
def test_world_light_gives_the_albedo(model, params, make):
    mean, se, albedo = _world_albedo(_material(model, params), make(), (0.3, 0.5, 0.8), spp=64)
    z = (mean - albedo) / np.maximum(se, 1e-4 * albedo)
    assert np.all(np.abs(z) < 5), f"max |z| {np.max(np.abs(z)):.1f}: mean {mean.mean(0)} albedo {albedo.mean(0)}"
    assert np.all(se < 0.05 * albedo + 1e-4), "too noisy to tell a wrong pdf"


def test_plugin_world_light_gives_the_albedo(kk_path, kk):
    params = {"color": (0.7, 0.5, 0.2), "specular": 0.4, "exponent": 25.0}
    mean, se, albedo = _world_albedo(_material("plugin", params, kk_path), kk(**params), (0.3, 0.5, 0.8), spp=64)
    z = (mean - albedo) / np.maximum(se, 1e-4 * albedo)
    assert np.all(np.abs(z) < 5), f"max |z| {np.max(np.abs(z)):.1f}"


def _one_strand_scene(material):
    camera, _ = _ortho_camera(_unit((0.3, 0.5, 0.8)), 0.2, (4, 8))
    return {"version": 1, "curves": _straight_strand(), "materials": [material], "camera": camera,
            "lights": [{"type": "SUN", "direction": (0, 0, 1), "strength": (1, 1, 1)}],
            "integrator": _integrator()}


def test_errors_name_the_material_and_parameter(tmp_path):
    with pytest.raises(ValueError, match=r"\['model'\]: 'yan' is not allowed"):
        validate_scene(_one_strand_scene(_material("yan", {})))
    with pytest.raises(ValueError, match=r"\['path'\]: missing"):
        validate_scene(_one_strand_scene(_material("plugin", {})))
    with pytest.raises(TypeError, match=r"\['params'\]\['exponent'\]"):
        validate_scene(_one_strand_scene(_material("kajiya_kay", {"exponent": None})))
    with pytest.raises(ValueError, match=r"material 'hair'.*exponent=-1 is out of range; allowed: \[0, 10000\]"):
        render(_one_strand_scene(_material("kajiya_kay", {"exponent": -1})))
    with pytest.raises(ValueError, match=r"material 'hair'.*has no parameter 'roughnes'; allowed: base_color"):
        render(_one_strand_scene(_material("epic", {"roughnes": 0.2})))
    with pytest.raises(RuntimeError, match="no such file"):
        render(_one_strand_scene(_material("plugin", {}, tmp_path / "missing.so")))


def test_the_scene_allows_the_names_the_factory_builds():
    """One list of model names (_core.model_names()): the scene's check names it, and a name outside the zoo
    (the legacy Hair BSDF) renders as the factory builds it."""
    with pytest.raises(ValueError, match=r"'yan' is not allowed; use one of \[%s\]"
                       % ", ".join(repr(n) for n in hairbsdf._core.model_names())):
        validate_scene(_one_strand_scene(_material("yan", {})))
    got, expected = _pixels_vs_eval(_material("cycles_hair", {"roughness_u": 0.3}),
                                    hairbsdf.cycles_hair_bsdf(roughness_u=0.3), (0.3, 0.5, 0.8), (-0.3, 0.5, 0.8))
    _assert_equal_pixels(got, expected)


def test_schema_matches_the_constructors():
    """model_schema's defaults are the Python constructors' defaults (one table)."""
    import inspect
    ctors = {"kajiya_kay": hairbsdf.kajiya_kay_hair, "epic": hairbsdf.epic_hair,
             "scheuermann": hairbsdf.scheuermann_hair, "marschner": hairbsdf.marschner_hair,
             "deon": hairbsdf.deon_hair, "yan_fur": hairbsdf.yan_fur}
    assert sorted(hairbsdf.zoo_model_names()) == sorted(ctors)
    for name, ctor in ctors.items():
        sig = inspect.signature(ctor).parameters
        for p in hairbsdf.model_schema(name):
            assert p["name"] in sig, (name, p["name"])
            default = sig[p["name"]].default
            assert default == (None if p["optional"] else p["default"]), (name, p["name"], default, p["default"])
        assert hairbsdf.make_model(name).model_params[0]["model"] == name
