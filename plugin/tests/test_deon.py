"""d'Eon 2011 (docs/models.md §5): energy conservation, the Gaussian-detector integral against an
independent quadrature, the tables against the direct quadrature, pigment constants, sampler, fuzz."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf import testing
from zoo_checks import check_chi2_family, check_fuzz, check_sampling_consistency, fibre_dirs, max_albedo, unit


def fresnel(c, eta):
    g = np.sqrt(eta**2 - 1 + c * c)
    a = (g - c) / (g + c)
    b = (c * (g + c) - 1) / (c * (g - c) + 1)
    return 0.5 * a * a * (1 + b * b)


def reference_n(p, theta_o, phi, sigma, beta, eta=1.55):
    """N_p = 1/2 int A_p(h) D(beta_p; phi - Phi(p, h)) dh by adaptive quadrature (scipy)."""
    from scipy.integrate import quad
    so, co = np.sin(theta_o), np.cos(theta_o)
    ep = np.sqrt(eta**2 - so**2) / co
    ct = np.sqrt(1 - (so / eta) ** 2)
    b = beta * [1, 0.5, 2][p]

    def integrand(h):
        gi, gt = np.arcsin(h), np.arcsin(h / ep)
        f = fresnel(co * np.cos(gi), eta)
        T = np.exp(-2 * sigma * np.cos(gt) / ct)
        A = [f, (1 - f) ** 2 * T, (1 - f) ** 2 * f * T * T][p]
        x = phi - (2 * p * gt - 2 * gi + p * np.pi)
        d = sum(np.exp(-0.5 * ((np.mod(x + np.pi, 2 * np.pi) - np.pi + 2 * np.pi * k) / b) ** 2) for k in range(-3, 4))
        return 0.5 * A * d / (b * np.sqrt(2 * np.pi))

    pts = np.linspace(-1, 1, 41)
    return sum(quad(integrand, lo, hi, epsabs=1e-13, epsrel=1e-10, limit=200)[0] for lo, hi in zip(pts[:-1], pts[1:]))


def lobes_over_m(c, theta_o, phi):
    """eval_lobes / M_p for wi = (theta_i = -theta_o, phi): recovers N_p (M from the model's formula)."""
    from scipy.special import i0e
    (d,) = c.model_params
    wo = np.array([np.sin(theta_o), 0.0, -np.cos(theta_o)])  # phi_o = -pi/2
    wi = fibre_dirs(np.array([-np.sin(theta_o)]), np.array([phi - np.pi / 2]))
    out = c.eval_lobes(wo, wi, 0.0)[0]
    res = []
    t = d["tilt"]
    for p, rot in enumerate([2 * t, -t, -4 * t]):
        v = (d["roughness"] * [1, 0.5, 2][p]) ** 2
        to = theta_o + rot
        si, ci = -np.sin(theta_o), np.cos(theta_o)
        a = ci * abs(np.cos(to)) / v
        m = np.exp(-np.log(v) - 1 / v - np.log1p(-np.exp(-2 / v)) - si * np.sin(to) / v + a) * i0e(a)
        res.append(out[p] / m)
    return np.array(res)


def test_defaults_pigments_and_errors():
    (d,) = hairbsdf.deon_hair().model_params
    assert d["model"] == "deon" and d["tabulated"] and d["roughness"] == 0.1309
    np.testing.assert_allclose(d["sigma_a"], hairbsdf.absorption_from_melanin(0.8, 1.0), rtol=1e-12)
    q = -np.log(1 - 0.5)
    expect = q * 0.7 * np.array([0.419, 0.697, 1.37]) + q * 0.3 * np.array([0.187, 0.4, 1.05])
    (e,) = hairbsdf.deon_hair(melanin=0.5, melanin_redness=0.3, pigments="deon").model_params
    np.testing.assert_allclose(e["sigma_a"], expect, rtol=1e-12)
    for kw, msg in [({"roughness": 0.01}, r"roughness.*\[0.02, 1\]"), ({"pigments": "pbrt"}, "pigments"),
                    ({"melanin": 2}, r"melanin.*\[0, 1\]"), ({"sigma_a": -1}, r"sigma_a.*\[0, 10000\]"),
                    ({"tilt": 0.5}, r"tilt.*\[-0.2, 0.2\]")]:
        with pytest.raises(ValueError, match=msg):
            hairbsdf.deon_hair(**kw)


@pytest.mark.parametrize("roughness", [0.05, 0.1309, 0.4])
def test_energy_conservation(roughness):
    """sigma_a = 0: R + TT + TRT + the residual integrate to 1 (far field: for every h)."""
    c = hairbsdf.deon_hair(sigma_a=0.0, roughness=roughness)
    for wo in (unit(0, 10), unit(-40, 80), unit(70, 0), unit(88, 0)):
        for h in (0.0, 0.9):
            np.testing.assert_allclose(c.albedo(wo, h, max_nodes=1_000_000)[0], 1.0, atol=1e-3)


@pytest.mark.parametrize("p", [0, 1, 2])
def test_detector_integral_matches_independent_quadrature(p):
    c = hairbsdf.deon_hair(sigma_a=(0.3, 0.6, 1.2), tabulated=False, tilt=0.0)
    for theta_o in (0.0, 0.6):
        for phi in (0.3, 2.0, 3.0):
            got = lobes_over_m(c, theta_o, phi)[p, 0]
            ref = reference_n(p, theta_o, phi, 0.3, 0.1309)
            assert abs(got - ref) <= 1e-4 * max(ref, 1e-3), (theta_o, phi, got, ref)


@pytest.mark.parametrize("roughness,tol", [(0.05, 1e-2), (0.1309, 1e-3), (0.4, 1e-3)])
def test_tables_match_direct_quadrature(roughness, tol, rng):
    kw = dict(sigma_a=(0.3, 0.6, 1.2), roughness=roughness)
    tab, direct = hairbsdf.deon_hair(**kw), hairbsdf.deon_hair(tabulated=False, **kw)
    wo, wi = rng.normal(size=(3000, 3)), rng.normal(size=(3000, 3))
    a, b = direct.eval_lobes(wo, wi, 0.0), tab.eval_lobes(wo, wi, 0.0)
    for p in range(4):
        scale = a[:, p].max()
        # the residual's mean attenuation is a 1D table in theta_o: 2e-3 near grazing views
        assert np.abs(a[:, p] - b[:, p]).max() <= (tol if p < 3 else max(tol, 2e-3)) * scale, p


def test_sampling_consistency(rng):
    for kw in (dict(), dict(sigma_a=0.0, roughness=0.02, tilt=-0.2), dict(sigma_a=1e4, roughness=1.0)):
        check_sampling_consistency(hairbsdf.deon_hair(**kw), rng)


def test_pdf_integrates_to_one():
    c = hairbsdf.deon_hair(roughness=0.1)
    for wo in (unit(-35, 20), unit(80, 0), unit(89.9, 0)):
        assert abs(testing.pdf_integral(c, wo, 0.0) - 1.0) < 1e-3


def test_chi2():
    cases = []
    for kw, wo in ((dict(), unit(-35, 20)), (dict(), unit(60, 0)), (dict(sigma_a=0.0, roughness=0.3), unit(20, 40)),
                   (dict(sigma_a=(2.0, 0.5, 0.1), roughness=0.08, tilt=0.05), unit(-70, 10))):
        cases.append((hairbsdf.deon_hair(**kw), wo, 0.0))
    check_chi2_family(cases, samples=200_000)


def test_fuzz(rng):
    for kw in (dict(), dict(sigma_a=0.0, roughness=0.02, tilt=0.2), dict(eta=3.0, sigma_a=1e4), dict(eta=1.1)):
        check_fuzz(hairbsdf.deon_hair(**kw), rng, n=5000)
