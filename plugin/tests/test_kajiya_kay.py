"""Kajiya-Kay 1989 (docs/models.md §1): normalisation, furnace bound, sampler, fuzzing, and
eval against an independent reference written from the paper's formulas."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf import testing
from zoo_checks import (FURNACE_VIEWS, check_chi2_family, check_fuzz, check_sampling_consistency, fibre_dirs,
                        max_albedo, unit)


def reference(wo, wi, kd, ks, p):
    """K_d sin(t, l) / pi^2 + K_s max(0, cos(e, e'))^p / N_s(p); t = x (paper §2.4)."""
    from scipy.integrate import quad
    sin_o, sin_i = wo[:, 0], wi[:, 0]
    theta_o, theta_i = np.arcsin(sin_o), np.arcsin(sin_i)
    norm = 2 * np.pi * quad(lambda t: np.cos(t) ** (p + 1), -np.pi / 2, np.pi / 2, epsabs=0, epsrel=1e-13)[0]
    c = np.cos(theta_i + theta_o)
    spec = np.where(c > 0, np.abs(c) ** p, 0.0) / norm
    diff = np.cos(theta_i) / np.pi**2
    return diff[:, None] * np.asarray(kd) + spec[:, None] * np.asarray(ks)


def test_defaults_and_errors():
    c = hairbsdf.kajiya_kay_hair()
    (d,) = c.model_params
    assert d["model"] == "kajiya_kay" and d["exponent"] == 60 and d["diffuse"] == [0.5] * 3
    with pytest.raises(ValueError, match=r"exponent.*\[0, 10000\]"):
        hairbsdf.kajiya_kay_hair(exponent=-1)
    with pytest.raises(ValueError, match=r"diffuse.*\[0, 1\]"):
        hairbsdf.kajiya_kay_hair(diffuse=(0.2, 1.2, 0.1))
    with pytest.raises(ValueError, match="diffuse \\+ specular"):
        hairbsdf.kajiya_kay_hair(diffuse=0.7, specular=0.4)
    with pytest.raises(TypeError):
        hairbsdf.kajiya_kay_hair(exponant=3)


@pytest.mark.parametrize("p", [0.0, 1.0, 60.0, 777.0])
def test_eval_matches_reference(p, rng):
    kd, ks = (0.3, 0.2, 0.1), (0.5, 0.6, 0.7)
    c = hairbsdf.kajiya_kay_hair(diffuse=kd, specular=ks, exponent=p)
    wo = rng.normal(size=(2000, 3))
    wi = rng.normal(size=(2000, 3))
    wo /= np.linalg.norm(wo, axis=1)[:, None]
    wi /= np.linalg.norm(wi, axis=1)[:, None]
    wi[:500] = -wo[:500] + 0.01 * rng.normal(size=(500, 3))  # near the specular cone
    wi /= np.linalg.norm(wi, axis=1)[:, None]
    lobes = c.eval_lobes(wo, wi, rng.uniform(-1, 1, 2000))
    np.testing.assert_allclose(lobes.sum(axis=1), reference(wo, wi, kd, ks, p), rtol=1e-9, atol=1e-15)
    assert np.all(lobes[:, 1:3] == 0)  # no TT / TRT
    # azimuth and h independence
    rot = fibre_dirs(wi[:, 0], np.arctan2(wi[:, 2], wi[:, 1]) + 1.0)
    np.testing.assert_allclose(c.eval(wo, rot, 0.3), c.eval(wo, wi, -0.9), rtol=1e-12)


@pytest.mark.parametrize("p", [0.0, 2.5, 60.0, 3000.0])
def test_albedo_normalisation(p):
    """K_d is the diffuse albedo; K_s the specular albedo at theta_o = 0 and its maximum."""
    spec = hairbsdf.kajiya_kay_hair(diffuse=0.0, specular=1.0, exponent=p)
    diff = hairbsdf.kajiya_kay_hair(diffuse=1.0, specular=0.0, exponent=p)
    assert abs(spec.albedo(unit(0, 0), 0.0)[0, 0] - 1.0) < 1e-6
    for wo in FURNACE_VIEWS:
        assert abs(diff.albedo(wo, 0.0)[0, 0] - 1.0) < 1e-6
    assert max_albedo(spec) <= 1.0 + 1e-6


@pytest.mark.parametrize("kd,ks", [(0.5, 0.5), (1.0, 0.0), (0.0, 1.0), (0.3, 0.7)])
def test_furnace_bound(kd, ks):
    """Defaults and every gain at its maximum (K_d + K_s = 1): albedo <= 1.01."""
    for p in (0.0, 60.0, 1000.0):
        assert max_albedo(hairbsdf.kajiya_kay_hair(diffuse=kd, specular=ks, exponent=p)) <= 1.01


def test_sampled_furnace_matches_quadrature():
    c = hairbsdf.kajiya_kay_hair()
    for wo in FURNACE_VIEWS[:3]:
        est = testing.sampled_furnace(c, wo, 0.0, samples=200_000)
        assert abs(est[0] - c.albedo(wo, 0.0)[0, 0]) < 5e-3


def test_sampling_consistency(rng):
    for p in (0.0, 60.0, 2000.0):
        check_sampling_consistency(hairbsdf.kajiya_kay_hair(diffuse=(0.2, 0.3, 0.1), specular=0.6, exponent=p), rng)
    # diffuse only: the sampler is exactly proportional, weight = K_d
    s = check_sampling_consistency(hairbsdf.kajiya_kay_hair(diffuse=(0.2, 0.4, 0.6), specular=0.0), rng)
    np.testing.assert_allclose(s.weight[s.lobe >= 0], np.tile([0.2, 0.4, 0.6], ((s.lobe >= 0).sum(), 1)), rtol=1e-9)


def test_pdf_integrates_to_one():
    for p in (0.0, 60.0, 2000.0):
        c = hairbsdf.kajiya_kay_hair(diffuse=0.2, specular=0.8, exponent=p)
        for wo in (unit(-35, 20), unit(80, 0), unit(89.9, 0)):
            assert abs(testing.pdf_integral(c, wo, 0.0) - 1.0) < 1e-3


def test_chi2():
    cases = []
    for p, kd, ks in [(0.0, 0.0, 1.0), (1.0, 0.0, 1.0), (60.0, 0.5, 0.5), (60.0, 0.0, 1.0), (1000.0, 0.1, 0.9)]:
        c = hairbsdf.kajiya_kay_hair(diffuse=kd, specular=ks, exponent=p)
        for wo in (unit(-35, 20), unit(60, 0)):
            cases.append((c, wo, 0.0))
    check_chi2_family(cases)


def test_fuzz(rng):
    for p in (0.0, 1e-9, 60.0, 1e4):
        for kd, ks in ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.5, 0.5)):
            check_fuzz(hairbsdf.kajiya_kay_hair(diffuse=kd, specular=ks, exponent=p), rng, n=5000)
