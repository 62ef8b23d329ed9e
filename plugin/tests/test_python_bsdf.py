"""Python-defined BSDFs (hairbsdf.python_bsdf): the NumPy Kajiya-Kay of
examples/plugins/kajiya_kay/kajiya_kay.py agrees with the C plugin to 1e-6 in eval, lobes, pdf
and sample, works with the testing helpers and the battery; the wrapper checks what the
callables return and names the problem."""

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

import hairbsdf
from hairbsdf import testing

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "plugins" / "kajiya_kay"


def numpy_kajiya_kay():
    spec = importlib.util.spec_from_file_location("kajiya_kay_example", EXAMPLE / "kajiya_kay.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.kajiya_kay


PARAMS = [{}, {"color": (0.9, 0.7, 0.1), "specular_color": (0.5, 1.0, 0.8), "specular": 0.65, "exponent": 7.5},
          {"specular": 1.0, "exponent": 900.0}, {"specular": 0.0}]


def unit_rows(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("params", PARAMS)
def test_numpy_kajiya_kay_matches_the_c_plugin(kk, params, rng):
    c, py = kk(**params), numpy_kajiya_kay()(**params)
    n = 4000
    wo, wi, h, u = unit_rows(rng, n), unit_rows(rng, n), rng.uniform(-1, 1, n), rng.random((n, 3))
    wo[:4] = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0.6, 0, 0.8]]  # poles and theta_o = 0
    wi[-50:] = -wo[-50:] * [[-1, 1, 1]]  # on the mirror cone: the specular peak
    u[:3] = [[0, 0, 0], [1, 1, 1], [0.5, 0.5, 1e-12]]

    def close(a, b):
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-6 * max(1.0, float(np.abs(b).max())) * 1e-6)

    close(py.eval(wo, wi, h), c.eval(wo, wi, h))
    close(py.eval_lobes(wo, wi, h), c.eval_lobes(wo, wi, h))
    close(py.pdf(wo, wi, h), c.pdf(wo, wi, h))
    # Same uniforms -> same directions: compare in the plugin's frame via theta and delta phi
    # (the host may rotate the frame about the fibre; Python's frame has phi_o = atan2(wo.z, wo.y)).
    sc, sp = c.sample(wo, h, u), py.sample(wo, h, u)
    np.testing.assert_array_equal(sc.lobe, sp.lobe)
    ok = sc.lobe >= 0
    close(sp.wi[ok, 0], sc.wi[ok, 0])
    close(sp.pdf, sc.pdf)
    close(sp.weight, sc.weight)
    close(py.pdf(wo[ok], sp.wi[ok], h[ok]), c.pdf(wo[ok], sc.wi[ok], h[ok]))


def test_numpy_kajiya_kay_passes_the_battery():
    options = testing.BatteryOptions(theta_panels=64, phi_panels=64, furnace_samples=100_000,
                                     consistency_samples=5_000, chi2_samples=100_000, fuzz_samples=5_000)
    result = hairbsdf.test_plugin(numpy_kajiya_kay()(specular=0.5), options=options, verbose=False)
    assert result.passed, str(result)


def test_default_sampler_and_helpers():
    """eval only: uniform sphere sampling, and the helpers run on it."""
    def lambert_fibre(wo, wi, h):
        return (np.sqrt(1 - wi[:, 0] ** 2) / math.pi**2)[:, None] * np.array([0.8, 0.5, 0.2])

    bsdf = hairbsdf.python_bsdf(lambert_fibre, name="lambert_fibre")
    assert "uniform sphere" in repr(bsdf)
    wo = np.array([0.3, 0.0, 0.95])
    np.testing.assert_allclose(bsdf.albedo(wo, 0.2, theta_panels=32, phi_panels=16), [[0.8, 0.5, 0.2]], rtol=1e-6)
    np.testing.assert_allclose(testing.sampled_furnace(bsdf, wo, 0.2, samples=200_000), [0.8, 0.5, 0.2], rtol=1e-2)
    assert testing.pdf_integral(bsdf, wo, 0.2) == pytest.approx(1.0, abs=1e-9)
    result = testing.chi2_test(bsdf, wo, 0.2, samples=100_000, theta_bins=16, phi_bins=32)
    assert result.passed(0.01), result
    lobes = bsdf.eval_lobes(wo, [0, 1, 0], 0.0)
    assert lobes.shape == (1, 4, 3) and np.all(lobes[0, 1:] == 0)


def test_errors_name_the_problem():
    def good(wo, wi, h):
        return np.zeros((len(wo), 3))

    with pytest.raises(ValueError, match="sample: give sample and pdf together"):
        hairbsdf.python_bsdf(good, pdf=lambda wo, wi, h: np.ones(len(wo)))
    with pytest.raises(ValueError, match="pdf: give sample and pdf together"):
        hairbsdf.python_bsdf(good, sample=lambda wo, h, u: None)
    with pytest.raises(TypeError, match="eval: expected a callable"):
        hairbsdf.python_bsdf(3)
    bad_shape = hairbsdf.python_bsdf(lambda wo, wi, h: np.zeros(len(wo)), name="flat")
    with pytest.raises(ValueError, match=r"flat: eval returned shape \(2,\); it must return \(N, 3\)"):
        bad_shape.eval(np.ones((2, 3)), np.ones((2, 3)), 0.0)
    with pytest.raises(ValueError, match="wo: shape"):
        hairbsdf.python_bsdf(good).eval(np.ones((2, 2)), np.ones((2, 3)), 0.0)
    bad_sample = hairbsdf.python_bsdf(good, lambda wo, h, u: (wo, wo, np.ones(len(wo))), lambda wo, wi, h: np.ones(len(wo)),
                                      name="short")
    with pytest.raises(ValueError, match=r"short: sample must return \(wi, weight, pdf, lobe\)"):
        bad_sample.sample(np.ones((2, 3)), 0.0, np.full((2, 3), 0.5))
    # A raising or NaN-returning callable is a failed check in the battery, not a crash.
    nan = hairbsdf.python_bsdf(lambda wo, wi, h: np.full((len(wo), 3), np.nan), name="nan")
    result = hairbsdf.test_plugin(nan, options=testing.BatteryOptions(theta_panels=8, phi_panels=8,
                                  furnace_samples=1000, consistency_samples=1000, chi2_samples=20_000,
                                  chi2_bins=(8, 16), fuzz_samples=1000), verbose=False)
    assert not result.passed and not result["fuzz"].passed and not result["furnace"].passed
