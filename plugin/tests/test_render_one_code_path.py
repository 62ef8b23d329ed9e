"""One code path: the engine's BSDF at a hit (render::Bsdf, set up and evaluated by the
integrator's code, through the test hook _render.eval_hit_bsdf) equals `eval` of the Python API
at the same inputs, for every closure the engine renders: Principled Hair (Chiang; Huang's
stochastic eval against Closure.cycles_estimate with the same seeds),
the legacy Hair BSDF, every zoo model and diffuse. Bit for bit where the engine does the API's arithmetic, else within float
rounding (1e-12 relative)."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf.render import validate_scene
from test_render import _integrator, _ortho_camera, _straight_strand, _unit
from test_render_models import IDS as ZOO_IDS, ZOO

N = 400


def _stable(v):
    """Rows of v normalized, and which of them normalizing again leaves bit-identical. The API
    normalizes every direction it is given and the engine hook does not, so other rows reach the
    two one ulp apart (enough for Huang's stochastic eval to take another random path)."""
    for _ in range(4):
        v = v / np.linalg.norm(v, axis=1, keepdims=True)
    return v, np.all(v / np.linalg.norm(v, axis=1, keepdims=True) == v, axis=1)


def _directions(seed):
    rng = np.random.default_rng(seed)
    wo, wo_ok = _stable(rng.normal(size=(3 * N, 3)))
    wi, wi_ok = _stable(rng.normal(size=(3 * N, 3)))
    keep = np.flatnonzero(wo_ok & wi_ok)[:N]
    assert len(keep) == N
    return wo[keep], wi[keep], rng.uniform(-0.99, 0.99, N)


def _hits(closures, *, normal=None, seed=0, **integrator):
    """The engine's (value, pdf, lobes) for one material made of `closures`, at N random hits."""
    from hairbsdf import _render

    camera, _ = _ortho_camera(_unit((0.3, 0.5, 0.8)), 0.2, (4, 8))
    scene = validate_scene({"version": 1, "curves": _straight_strand(), "camera": camera,
                            "materials": [{"name": "m", "closures": closures}], "integrator": _integrator(**integrator)})
    wo, wi, h = _directions(seed)
    n = normal(wo, h) if normal else None
    return (wo, wi, h, n), _render.eval_hit_bsdf(scene, 0, wo, wi, h, normal=n, seed=seed)


def _assert_same(got, expected, what, rtol=1e-12):
    assert np.max(np.abs(expected)) > 0, f"{what}: the inputs see no value"
    err = np.abs(got - expected) / np.maximum(np.abs(expected), 1e-300)
    bad = (got != expected) & (err > rtol)
    assert not bad.any(), f"{what}: {bad.sum()} of {bad.size} differ, max relative error {err[bad].max():.3g}"


CHIANG = [
    ("melanin", {"melanin": 0.4, "roughness": 0.25, "coat": 0.3}),
    ("color", {"color": (0.5, 0.3, 0.2), "roughness": 0.6, "radial_roughness": 0.2, "offset": 0.05}),
    ("absorption", {"absorption_coefficient": (0.3, 0.6, 1.2), "ior": 1.4, "random_roughness": 0.5}),
]


@pytest.mark.parametrize("parametrization,inputs", CHIANG, ids=[c[0] for c in CHIANG])
def test_chiang_hits_equal_eval(parametrization, inputs):
    weight = (0.8, 0.6, 0.4)
    closure = {"type": "principled_hair", "weight": weight, "model": "CHIANG",
               "parametrization": parametrization.upper(), "inputs": dict(inputs, random=0.3)}
    (wo, wi, h, _), (value, pdf, lobes) = _hits([closure])
    api = hairbsdf.principled_hair(parametrization=parametrization, random=0.3, **inputs)
    _assert_same(value, np.asarray(weight) * api.eval(wo, wi, h), "value")
    _assert_same(pdf, api.pdf(wo, wi, h), "pdf")
    _assert_same(lobes[:, :4], np.asarray(weight) * api.eval_lobes(wo, wi, h), "lobes")


def test_huang_hits_equal_cycles_estimate():
    inputs = {"melanin": 0.3, "roughness": 0.3, "aspect_ratio": 0.8}
    closure = {"type": "principled_hair", "weight": (1, 1, 1), "model": "HUANG", "parametrization": "MELANIN",
               "inputs": dict(inputs, random=None)}
    (wo, wi, h, _), (value, pdf, lobes) = _hits([closure], seed=7)
    api = hairbsdf.principled_hair(model="huang", parametrization="melanin", **inputs)
    estimate = api.cycles_estimate(wo, wi, h, samples=1, seed=7)  # (N, 4, 3), the same LCG seeds per row
    # Outside the projected ellipse the engine's closure is a transparent one: no value in any direction.
    transparent = api.huang_details(wo, h)["transparent"]
    assert 0 < transparent.sum() < N / 4
    estimate[transparent] = 0
    _assert_same(lobes[:, :4], estimate, "lobes")
    _assert_same(value, estimate.sum(axis=1), "value")
    assert np.all(pdf[~transparent] == 1.0) and np.all(pdf[transparent] == 0)  # Cycles' sampler reports pdf 1


@pytest.mark.parametrize("transmission", [False, True], ids=["reflection", "transmission"])
def test_cycles_hair_hits_equal_eval(transmission):
    color = (0.7, 0.5, 0.3)
    closure = {"type": "cycles_hair", "weight": (1, 1, 1), "color": color,
               "component": "TRANSMISSION" if transmission else "REFLECTION",
               "offset": 0.05, "roughness_u": 0.3, "roughness_v": 0.6}

    def normal(wo, h):  # the API's N in the fibre frame (models/cycles_hair.h), as the hit's shading normal
        x = np.array([1.0, 0, 0])
        y = np.cross(x, wo)
        y /= np.linalg.norm(y, axis=1, keepdims=True)
        z = np.cross(x, y)
        return -h[:, None] * y - np.sqrt(1 - h * h)[:, None] * z

    (wo, wi, h, _), (value, pdf, _) = _hits([closure], normal=normal)
    api = hairbsdf.cycles_hair_bsdf(component="transmission" if transmission else "reflection", color=color, offset=0.05,
                               roughness_u=0.3, roughness_v=0.6)
    _assert_same(value, api.eval(wo, wi, h), "value")
    _assert_same(pdf, api.pdf(wo, wi, h), "pdf")


@pytest.mark.parametrize("model,params,make", ZOO, ids=ZOO_IDS)
def test_zoo_hits_equal_eval(model, params, make):
    weight = (0.9, 0.7, 0.5)
    (wo, wi, h, _), (value, pdf, _) = _hits([{"type": "hair_model", "weight": weight, "model": model,
                                              "params": params}])
    api = make()
    _assert_same(value, np.asarray(weight) * api.eval(wo, wi, h), "value")  # random 0 in both
    _assert_same(pdf, api.pdf(wo, wi, h), "pdf")


def test_diffuse_and_mixture_hits():
    """Diffuse is Lambert about the hit's normal; a mixture sums weight x value and mixes the pdfs
    by |average(weight)|, as ClosureSum does."""
    hair = {"type": "principled_hair", "weight": (0.6, 0.6, 0.6), "model": "CHIANG", "parametrization": "MELANIN",
            "inputs": {"melanin": 0.5, "roughness": 0.3, "random": 0.0}}
    diffuse = {"type": "diffuse", "weight": (0.4, 0.4, 0.4), "color": (0.8, 0.5, 0.2)}
    (wo, wi, h, n), (value, pdf, _) = _hits([hair, diffuse], normal=lambda wo, h: wo)
    cos = np.maximum(np.sum(n * wi, axis=1), 0.0)
    lambert = np.where(cos[:, None] > 0, (cos / np.pi)[:, None] * (0.4 * np.array([0.8, 0.5, 0.2])), 0.0)
    api = hairbsdf.principled_hair(parametrization="melanin", melanin=0.5, roughness=0.3, random=0.0)
    expected = 0.6 * api.eval(wo, wi, h) + lambert
    np.testing.assert_allclose(value, expected, rtol=1e-12, atol=1e-300)
    w_hair, w_diffuse = 0.6, np.mean([0.32, 0.2, 0.08])
    hair_pdf = api.pdf(wo, wi, h)
    expected_pdf = (w_hair * np.where(hair_pdf != 0, hair_pdf, 0) + w_diffuse * cos / np.pi) / (w_hair + w_diffuse)
    np.testing.assert_allclose(pdf, expected_pdf, rtol=1e-12, atol=1e-300)
