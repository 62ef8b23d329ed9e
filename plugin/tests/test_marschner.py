"""Marschner 2003 (docs/models.md §4): the azimuthal root solve against closed forms and the
change-of-variables identity, the caustic and eccentricity terms, energy (pinned: the model is not
energy conserving), sampler, fuzzing."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf import testing
from zoo_checks import check_chi2_family, check_fuzz, check_sampling_consistency, fibre_dirs, max_albedo, unit

_trapezoid = getattr(np, "trapezoid", None) or np.trapz  # NumPy 2 name, NumPy 1.x fallback

ETA = 1.55


def fresnel2(e1, e2, g):
    """Unpolarised 2D Fresnel, perpendicular with e1, parallel with e2 (independent of the C++)."""
    ci, si = np.abs(np.cos(g)), np.sin(g)

    def one(e, parallel):
        st = si / e
        ct = np.sqrt(np.clip(1 - st**2, 0, None))
        r = ((e * ci - ct) / (e * ci + ct)) ** 2 if parallel else ((ci - e * ct) / (ci + e * ct)) ** 2
        return np.where(np.abs(st) >= 1, 1.0, r)

    return 0.5 * (one(e1, False) + one(e2, True))


def azimuthal_lobe(c, p, phi):
    """N_p(phi) at theta_i = theta_o = 0 (theta_d = 0, so eta' = eta'' = eta), from eval_lobes."""
    (d,) = c.model_params
    beta = [d["beta_r"], d["beta_r"] / 2, 2 * d["beta_r"]][p]
    alpha = [d["alpha_r"], -d["alpha_r"] / 2, -1.5 * d["alpha_r"]][p]
    m = 0.5 * np.exp(-0.5 * (alpha / beta) ** 2) / (beta * np.sqrt(2 * np.pi))
    wo = np.array([0.0, 0.0, -1.0])  # phi_o = -pi/2 in the closure's frame
    wi = fibre_dirs(np.zeros_like(phi), phi - np.pi / 2)
    return c.eval_lobes(wo, wi, 0.0)[:, p] / m


def test_defaults_and_errors():
    (d,) = hairbsdf.marschner_hair().model_params
    assert d["model"] == "marschner" and d["eta"] == 1.55 and d["eccentricity"] == 0.9
    for kw, msg in [({"eta": 0.9}, r"eta.*\[1.1, 3\]"), ({"beta_r": 0}, r"beta_r.*\[0.005, 0.7\]"),
                    ({"glint_scale": 6}, r"glint_scale.*\[0, 5\]"), ({"sigma_a": -1}, r"sigma_a.*\[0, 10000\]"),
                    ({"eccentricity": 1.2}, r"eccentricity.*\[0.5, 1\]")]:
        with pytest.raises(ValueError, match=msg):
            hairbsdf.marschner_hair(**kw)


def test_r_lobe_closed_form():
    """p = 0: gamma_i = -phi/2, so N_R = F(eta, phi/2) cos(phi/2) / 4 (Marschner §4.1)."""
    c = hairbsdf.marschner_hair(sigma_a=0.0)
    phi = np.linspace(-3.1, 3.1, 301)
    np.testing.assert_allclose(azimuthal_lobe(c, 0, phi)[:, 0], fresnel2(ETA, ETA, phi / 2) * np.cos(phi / 2) / 4,
                               rtol=1e-9)


@pytest.mark.parametrize("sigma", [0.0, 0.7])
def test_tt_root_solve_conserves_the_h_integral(sigma):
    """int N_TT dphi = 1/2 int A(1, h) dh: every root of the cubic phi(gamma) is found once."""
    c = hairbsdf.marschner_hair(sigma_a=sigma)
    phi = np.linspace(-np.pi, np.pi, 200_001)
    n = azimuthal_lobe(c, 1, phi)[:, 0]
    lhs = _trapezoid(n, phi)
    h = np.linspace(-1, 1, 200_001)
    g = np.arcsin(h)
    gt = np.arcsin(h / ETA)
    f = fresnel2(ETA, ETA, g)
    a = (1 - f) ** 2 * np.exp(-2 * sigma * np.cos(gt))
    rhs = 0.5 * _trapezoid(a, h)
    assert abs(lhs - rhs) < 2e-3 * rhs, (lhs, rhs)


def test_trt_caustic_and_eccentricity():
    """Glints: N_TRT near the caustic grows with k_G; eccentricity makes TRT depend on the
    cross-section's orientation (the per-sample normal), a circular fibre does not."""
    phi = np.linspace(-np.pi, np.pi, 721)
    low = azimuthal_lobe(hairbsdf.marschner_hair(sigma_a=0.0, eccentricity=1.0, glint_scale=0.5), 2, phi)[:, 0]
    high = azimuthal_lobe(hairbsdf.marschner_hair(sigma_a=0.0, eccentricity=1.0, glint_scale=5.0), 2, phi)[:, 0]
    assert high.max() > 3 * low.max()
    assert np.all(np.isfinite(high))
    wo, wi = unit(10, 0), unit(-5, 25)
    ecc = hairbsdf.marschner_hair(eccentricity=0.85)
    circ = hairbsdf.marschner_hair(eccentricity=1.0)
    n1, n2 = np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])
    t1, t2 = ecc.eval_lobes(wo, wi, 0.0, normal=n1)[0, 2, 0], ecc.eval_lobes(wo, wi, 0.0, normal=n2)[0, 2, 0]
    assert min(t1, t2) > 1e-3 and abs(t1 - t2) > 0.05 * max(t1, t2), (t1, t2)
    np.testing.assert_allclose(circ.eval_lobes(wo, wi, 0.0, normal=n1), circ.eval_lobes(wo, wi, 0.0, normal=n2),
                               rtol=1e-12)


def test_energy_is_pinned():
    """Not energy conserving as published (d'Eon 2011): with sigma_a = 0 the albedo is about 0.9-1.05
    away from grazing views and reaches about 2 at a grazing view on the side the shifts push
    the lobes towards (1/cos^2 theta_d). Pinned so that changes are seen (docs/models.md §4)."""
    white = hairbsdf.marschner_hair(sigma_a=0.0)
    mid = [unit(t, 0) for t in (0, 30, 45, -60)]
    a_mid = max_albedo(white, mid, hs=(0.0,), max_nodes=1_000_000)
    assert 1.0 < a_mid < 1.07, a_mid
    a_grazing = max_albedo(white, [unit(-89.5, 33)], hs=(0.0,), max_nodes=1_000_000)
    assert 1.9 < a_grazing < 2.2, a_grazing
    glints = max_albedo(hairbsdf.marschner_hair(sigma_a=0.0, glint_scale=5.0), mid, hs=(0.0,), max_nodes=1_000_000)
    assert glints < 1.15, glints


def test_sampling_consistency(rng):
    for kw in (dict(), dict(sigma_a=0.0, beta_r=0.005, eccentricity=0.5, glint_scale=5),
               dict(alpha_r=0.35, beta_r=0.7, sigma_a=(0, 3, 1e4))):
        check_sampling_consistency(hairbsdf.marschner_hair(**kw), rng, normal=rng.normal(size=(20_000, 3)))


def test_pdf_integrates_to_one():
    for kw, wos in ((dict(), (unit(-35, 20), unit(89.9, 0))), (dict(beta_r=0.02, alpha_r=0.35), (unit(80, 0),))):
        c = hairbsdf.marschner_hair(**kw)
        for wo in wos:
            assert abs(testing.pdf_integral(c, wo, 0.0) - 1.0) < 1e-3


def test_chi2():
    cases = []
    for kw, wo in ((dict(), unit(-35, 20)), (dict(), unit(60, 0)), (dict(sigma_a=0.0, beta_r=0.3), unit(20, 40)),
                   (dict(sigma_a=0.2, beta_r=0.05, glint_scale=3), unit(-35, 20))):
        cases.append((hairbsdf.marschner_hair(**kw), wo, 0.0))
    check_chi2_family(cases, samples=200_000)


def test_fuzz(rng):
    for kw in (dict(), dict(sigma_a=0.0, beta_r=0.005, glint_scale=5, caustic_fade=0.0, caustic_limit=1.0),
               dict(eta=3.0, eccentricity=0.5, sigma_a=1e4), dict(eta=1.1, caustic_width=0.01, alpha_r=-0.35)):
        check_fuzz(hairbsdf.marschner_hair(**kw), rng, n=5000, normal=rng.normal(size=(5000, 3)))
