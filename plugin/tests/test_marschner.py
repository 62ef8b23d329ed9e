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
    assert d["model"] == "marschner" and d["eta"] == 1.55 and d["eccentricity"] == 0.9 and d["energy"] == "bounded"
    for kw, msg in [({"eta": 0.9}, r"eta.*\[1.1, 3\]"), ({"beta_r": 0}, r"beta_r.*\[0.005, 0.7\]"),
                    ({"glint_scale": 6}, r"glint_scale.*\[0, 5\]"), ({"sigma_a": -1}, r"sigma_a.*\[0, 10000\]"),
                    ({"eccentricity": 1.2}, r"eccentricity.*\[0.5, 1\]"),
                    ({"energy": "clamped"}, r"energy='clamped'.*bounded, published")]:
        with pytest.raises(ValueError, match=msg):
            hairbsdf.marschner_hair(**kw)


def test_r_lobe_closed_form():
    """p = 0: gamma_i = -phi/2, so N_R = F(eta, phi/2) cos(phi/2) / 4 (Marschner §4.1)."""
    c = hairbsdf.marschner_hair(sigma_a=0.0, energy="published")
    phi = np.linspace(-3.1, 3.1, 301)
    np.testing.assert_allclose(azimuthal_lobe(c, 0, phi)[:, 0], fresnel2(ETA, ETA, phi / 2) * np.cos(phi / 2) / 4,
                               rtol=1e-9)


@pytest.mark.parametrize("sigma", [0.0, 0.7])
def test_tt_root_solve_conserves_the_h_integral(sigma):
    """int N_TT dphi = 1/2 int A(1, h) dh: every root of the cubic phi(gamma) is found once."""
    c = hairbsdf.marschner_hair(sigma_a=sigma, energy="published")
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
    pub = dict(sigma_a=0.0, eccentricity=1.0, energy="published")
    low = azimuthal_lobe(hairbsdf.marschner_hair(glint_scale=0.5, **pub), 2, phi)[:, 0]
    high = azimuthal_lobe(hairbsdf.marschner_hair(glint_scale=5.0, **pub), 2, phi)[:, 0]
    assert high.max() > 3 * low.max()
    assert np.all(np.isfinite(high))
    wo, wi = unit(10, 0), unit(-5, 25)
    ecc = hairbsdf.marschner_hair(eccentricity=0.85, energy="published")
    circ = hairbsdf.marschner_hair(eccentricity=1.0, energy="published")
    n1, n2 = np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])
    t1, t2 = ecc.eval_lobes(wo, wi, 0.0, normal=n1)[0, 2, 0], ecc.eval_lobes(wo, wi, 0.0, normal=n2)[0, 2, 0]
    assert min(t1, t2) > 1e-3 and abs(t1 - t2) > 0.05 * max(t1, t2), (t1, t2)
    np.testing.assert_allclose(circ.eval_lobes(wo, wi, 0.0, normal=n1), circ.eval_lobes(wo, wi, 0.0, normal=n2),
                               rtol=1e-12)


def test_energy_is_pinned():
    """energy="published": not energy conserving (d'Eon 2011): with sigma_a = 0 the albedo is about
    0.9-1.05 away from grazing views and reaches about 2 at a grazing view on the side the shifts
    push the lobes towards (1/cos^2 theta_d). Pinned so that changes are seen (docs/models.md §4)."""
    white = hairbsdf.marschner_hair(sigma_a=0.0, energy="published")
    mid = [unit(t, 0) for t in (0, 30, 45, -60)]
    a_mid = max_albedo(white, mid, hs=(0.0,), max_nodes=1_000_000)
    assert 1.0 < a_mid < 1.07, a_mid
    a_grazing = max_albedo(white, [unit(-89.5, 33)], hs=(0.0,), max_nodes=1_000_000)
    assert 1.9 < a_grazing < 2.2, a_grazing
    glints = max_albedo(hairbsdf.marschner_hair(sigma_a=0.0, glint_scale=5.0, energy="published"), mid, hs=(0.0,),
                        max_nodes=1_000_000)
    assert glints < 1.15, glints


# A theta_o sweep (between the table's nodes too) and the grazing views of the pinned test.
BOUNDED_VIEWS = [unit(t, 20) for t in np.linspace(-88, 88, 23)] + [unit(-89.5, 33), unit(89.5, 0), unit(-86, 0)]
# sigma_a = 0 with every gain at its maximum and the width / shift extremes, with the lowest bounded
# albedo allowed where the published one exceeds 1: 0.99 as a rule; the narrow-glint and the
# narrow, strongly shifted cases are within 2 % and 4 % (the table's quadrature and interpolation
# error there, docs/models.md §4). The floor (<= 1.01) holds for all.
WHITE_CASES = [(dict(), 0.99), (dict(glint_scale=5.0), 0.99), (dict(beta_r=0.7), 0.99), (dict(eta=1.3), 0.99),
               (dict(eccentricity=0.85, glint_scale=5.0), 0.99), (dict(eccentricity=1.0), 0.99),
               (dict(beta_r=0.02, alpha_r=-0.35), 0.96), (dict(beta_r=0.02, alpha_r=0.35), 0.96),
               (dict(glint_scale=5.0, caustic_width=0.05, caustic_fade=0.0), 0.98)]


@pytest.mark.parametrize("kw, lowest", WHITE_CASES, ids=[str(k) for k, _ in WHITE_CASES])
def test_bounded_furnace_white(kw, lowest):
    """energy="bounded" (the default), sigma_a = 0: <= 1.01 everywhere (docs/validation.md §5.D); where the
    published albedo exceeds 1 the bounded one is about 1 (>= `lowest`: the table matches the
    quadrature); elsewhere it is the published one, or (where the table's E is just above 1 by its
    error) a little below it. (eta < 1.155 gives TT its own caustics, whose spikes make the
    published albedo depend on the quadrature grid: albedo() reads 1.41 at theta_o = 0 for eta 1.1
    where a finer grid gives 0.90; the table integrates TT over h, free of them.)"""
    b = hairbsdf.marschner_hair(sigma_a=0.0, **kw)
    p = hairbsdf.marschner_hair(sigma_a=0.0, energy="published", **kw)
    for wo in BOUNDED_VIEWS:
        ap, ab = p.albedo(wo, 0.0, max_nodes=400_000)[0], b.albedo(wo, 0.0, max_nodes=400_000)[0]
        assert ab.max() <= 1.01, (wo, ap, ab)
        if ap.max() > 1.0:
            assert ab.max() >= lowest, (wo, ap, ab)
        else:
            assert np.all(ab <= ap * (1 + 1e-12)) and np.all(ab >= 0.97 * ap), (wo, ap, ab)


def test_bounded_is_published_for_absorbing_fibres(rng):
    """The defaults (Principled Hair's absorption) and other coloured fibres do not reach albedo 1
    away from grazing views (|theta_o| <= 80 deg; nearer the axis 1 / cos^2 theta_d can push the
    red channel past 1, docs/models.md §4): there bounded == published (to 1e-6)."""
    wo = fibre_dirs(np.sin(np.radians(rng.uniform(-80, 80, 4000))), rng.uniform(-np.pi, np.pi, 4000))
    wi = rng.normal(size=(4000, 3))
    normal = rng.normal(size=(4000, 3))
    for kw in (dict(), dict(sigma_a=(0.3, 0.6, 1.2), glint_scale=5.0), dict(sigma_a=0.5, beta_r=0.3)):
        b = hairbsdf.marschner_hair(**kw).eval_lobes(wo, wi, 0.0, normal=normal)
        p = hairbsdf.marschner_hair(energy="published", **kw).eval_lobes(wo, wi, 0.0, normal=normal)
        np.testing.assert_allclose(b, p, rtol=1e-6, atol=0)


def sphere_albedo(c, wo, normal, n_theta=400, n_phi=720):
    """Dense brute-force albedo with a per-sample normal (the closure's albedo() has none)."""
    x, w = np.polynomial.legendre.leggauss(n_theta)
    t = 0.5 * np.pi * x
    ph = (np.arange(n_phi) + 0.5) / n_phi * 2 * np.pi - np.pi
    T, P = np.meshgrid(t, ph, indexing="ij")
    wi = np.stack([np.sin(T), np.cos(T) * np.cos(P), np.cos(T) * np.sin(P)], -1).reshape(-1, 3)
    ev = c.eval(wo, wi, 0.0, normal=normal).reshape(n_theta, n_phi, 3)
    return np.einsum("i,ijc->c", 0.5 * np.pi * w * np.cos(t), ev) * 2 * np.pi / n_phi


@pytest.mark.parametrize("eccentricity, tol", [(0.85, 0.01), (0.5, 0.015)])
def test_bounded_follows_the_cross_section_orientation(eccentricity, tol):
    """E depends on the major axis through TRT's eta*(phi_h) (eccentricity); the table has 9 nodes in
    phi_major over [0, pi/2] for Table 1's range (0.85-1) and 25 at the schema's extreme 0.5, linear
    in between. Between the nodes too, a white fibre with glint_scale 5 stays <= 1 + tol and reaches
    >= 1 - tol where the published one exceeds 1 (brute-force quadrature): within 1 % for 0.85; 0.5
    reaches 1.012 (1.02 with 9 nodes; 49 nodes do not lower it: the rest is the table's quadrature)."""
    kw = dict(sigma_a=0.0, eccentricity=eccentricity, glint_scale=5.0)
    b, p = hairbsdf.marschner_hair(**kw), hairbsdf.marschner_hair(energy="published", **kw)
    seen_over = 0
    for theta in (45.0, -87.0, 10.0):
        wo = unit(theta, 0)
        for angle in (0.0, 15.0, 35.0, 60.0, 80.0):  # the major axis from the frame's y towards z
            a = np.radians(angle)
            # the frame of wo = unit(theta, 0): y = x cross wo = (0, 0, cos theta) / |.|, z = x cross y
            normal = np.array([0.0, -np.sin(a), np.cos(a)])
            ap, ab = sphere_albedo(p, wo, normal), sphere_albedo(b, wo, normal)
            assert ab.max() <= 1 + tol, (theta, angle, ap, ab)
            if ap.max() > 1.0:
                seen_over += 1
                assert ab.max() >= 1 - tol, (theta, angle, ap, ab)
    assert seen_over >= 3


def test_make_model_and_schema_accept_energy():
    (spec,) = [q for q in hairbsdf.model_schema("marschner") if q["name"] == "energy"]
    assert spec["type"] == "choice" and spec["default"] == "bounded" and list(spec["choices"]) == ["bounded", "published"]
    wo, wi = unit(-85, 0), unit(80, 170)
    a = hairbsdf.make_model("marschner", {"sigma_a": 0.0, "energy": "published"}).eval(wo, wi, 0.0)
    b = hairbsdf.marschner_hair(sigma_a=0.0, energy="published").eval(wo, wi, 0.0)
    np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="energy"):
        hairbsdf.make_model("marschner", {"energy": 1.0})


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
