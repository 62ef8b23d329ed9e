"""Huang hair (principled_hair(model="huang")): API, semantics (near / far field, ellipse,
transparency), agreement with the independent float64 reference and with Cycles' stochastic
estimator, the mixture sampler (chi-square, pdf, weights) and the furnace.
Cheap enough for CI (about a minute on 2 cores); the brute-force grid is in test_huang_bruteforce.py (slow: scripts/test --full)."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf import testing
from reference import huang_reference as ref

DEG = np.pi / 180


def unit(theta_deg, phi_deg):
    t, p = theta_deg * DEG, phi_deg * DEG
    return np.array([np.sin(t), np.cos(t) * np.cos(p), np.cos(t) * np.sin(p)])


def huang(**kw):
    base = dict(parametrization="absorption", absorption_coefficient=(0.2, 0.5, 1.0), roughness=0.3, aspect_ratio=1.0)
    base.update(kw)
    return hairbsdf.principled_hair(model="huang", **base)


@pytest.fixture(scope="module")
def tables():
    """The C++ E_glass tables (checked against the reference's own quadrature in
    test_tables_match_reference_albedo)."""
    t = hairbsdf._core.huang_table(0)
    return t[0], t[1]


# --- API ----------------------------------------------------------------------------------------

def test_api_keywords_and_errors():
    c = huang(aspect_ratio=0.8, reflection=0.5, transmission=1.2, secondary_reflection=0.0, coat=0.3)
    p = c.model_params[0]
    assert p["model"] == "huang" and p["aspect_ratio"] == pytest.approx(0.8) and p["factors"] == [0.5, 1.2, 0.0]
    assert "model='huang'" in repr(c)
    assert huang(aspect_ratio=1.25).model_params[0]["aspect_ratio"] == pytest.approx(0.8)  # > 1 is inverted
    assert huang(roughness=3.0).model_params[0]["roughness"] == 1.0
    assert huang(reflection=-2).model_params[0]["factors"][0] == 0.0
    with pytest.raises(TypeError, match="aspect_ratoi"):
        huang(aspect_ratoi=0.5)
    with pytest.raises(TypeError, match="aspect_ratio"):
        hairbsdf.principled_hair(model="chiang", aspect_ratio=0.5)  # Huang-only input
    with pytest.raises(ValueError, match="accuracy"):
        huang(accuracy="exact")
    with pytest.raises(ValueError, match="sampler"):
        huang(sampler="pbrt")
    with pytest.raises(ValueError, match="tilt"):
        huang(tilt="3.4")
    with pytest.raises(ValueError, match="tolerance"):
        huang(tolerance=0.0)
    assert p["glass_albedo_table"] == "4.x"
    c5 = huang(glass_albedo_table="5.x")
    assert c5.model_params[0]["glass_albedo_table"] == "5.x" and "glass_albedo_table='5.x'" in repr(c5)
    with pytest.raises(ValueError, match=r"glass_albedo_table='5.3' is not allowed; choose one of \['4.x', '5.x'\]"):
        huang(glass_albedo_table="5.3")


def test_extra_arrays_shapes_and_defaults(rng):
    c = huang(tolerance=1e-2, trt_points=256)
    n = 6
    wo, wi, h = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), rng.uniform(-0.9, 0.9, n)
    base = c.eval(wo, wi, h)
    same = c.eval(wo, wi, h, normal=np.zeros(3), pixel_coverage=1.0, near_field=False)
    np.testing.assert_array_equal(base, same)
    lobes = c.eval_lobes(wo, wi, h, normal=(0, 1, 0), pixel_coverage=np.full(n, 0.05), near_field=np.ones(n, bool))
    assert lobes.shape == (n, 4, 3)
    np.testing.assert_allclose(lobes.sum(axis=1), c.eval(wo, wi, h, normal=(0, 1, 0), pixel_coverage=0.05,
                                                         near_field=True), rtol=1e-12)
    assert c.pdf(wo, wi, h, near_field=True, pixel_coverage=0.05).shape == (n,)
    s = c.sample(wo, h, rng.random((n, 3)), near_field=True, pixel_coverage=0.05)
    assert s.wi.shape == (n, 3)
    with pytest.raises(ValueError, match="pixel_coverage"):
        c.eval(wo, wi, h, pixel_coverage=-1.0)
    with pytest.raises(TypeError, match="near_field"):
        c.eval(wo, wi, h, near_field=0.5)
    with pytest.raises(ValueError, match="normal"):
        c.eval(wo, wi, h, normal=np.ones((n + 1, 3)))
    # Chiang ignores the new fields.
    chiang = hairbsdf.principled_hair()
    np.testing.assert_array_equal(chiang.eval(wo, wi, h), chiang.eval(wo, wi, h, normal=(0, 1, 0),
                                                                       pixel_coverage=0.01, near_field=True))


def test_projected_radius_and_transparency():
    """r = sqrt(1 - e^2 x^2 / (x^2 + z^2)) of the view direction in the frame of the major axis;
    |h| >= r is transparent: eval 0, no sample (docs/cycles.md §5.1)."""
    b = 0.6
    c = huang(aspect_ratio=b, trt_points=64)
    normal = np.array([0.0, 1.0, 0.0])       # major axis along fibre-frame y
    wo = unit(10, 30)                          # phi measured from the major axis: 30 deg
    d = c.huang_details(wo, [0.0, 0.5, 0.95], normal=normal)
    x = wo[1]                                  # component along the major axis
    z = wo[2]
    r = np.sqrt(1 - (1 - b * b) * x * x / (x * x + z * z))
    np.testing.assert_allclose(d["radius"], r, rtol=1e-12)
    np.testing.assert_array_equal(d["transparent"], [False, 0.5 >= r, 0.95 >= r])
    assert r < 0.95
    assert np.all(c.eval(wo, unit(-10, 100), 0.97, normal=normal) == 0)
    assert c.sample(wo, 0.97, [0.3, 0.3, 0.3], normal=normal).lobe[0] == -1
    # Fallback frame for a zero normal: Cycles' make_orthonormals(tangent).
    np.testing.assert_allclose(hairbsdf.huang_fallback_normal([1.0, 0.0, 0.0]), [0, 1 / np.sqrt(2), 1 / np.sqrt(2)])
    dz = c.huang_details(wo, 0.0)
    dn = c.huang_details(wo, 0.0, normal=hairbsdf.huang_fallback_normal([1.0, 0.0, 0.0]))
    np.testing.assert_allclose(dz["radius"], dn["radius"], rtol=1e-12)


def test_far_field_ignores_h_near_field_uses_it():
    c = huang(trt_points=512)
    wo, wi = unit(20, -90), unit(-25, 40)
    far = c.eval(wo, wi, [0.0, 0.6, -0.9])
    np.testing.assert_array_equal(far[0], far[1])
    np.testing.assert_array_equal(far[0], far[2])
    near = c.eval(wo, wi, [0.0, 0.6], near_field=True, pixel_coverage=1 / 60)
    assert not np.allclose(near[0], near[1], rtol=1e-3)
    # The near field needs r > pixel_coverage: a coverage >= 1 is the far field.
    np.testing.assert_array_equal(c.eval(wo, wi, 0.6, near_field=True, pixel_coverage=1.0), far[1:2])
    d = c.huang_details(wo, [0.0, 0.99], near_field=True, pixel_coverage=1 / 60)
    np.testing.assert_allclose(d["h_lo"], [-1 / 60, 0.99 - 1 / 60])
    np.testing.assert_allclose(d["h_hi"], [1 / 60, 0.999])


# --- against the independent reference ----------------------------------------------------------

def test_tables_match_reference_albedo(rng, tables):
    """24 random table entries against the reference's own quadrature of the GGX glass albedo."""
    for _ in range(24):
        inv, k, j, i = rng.integers(0, 2), rng.integers(0, 16), rng.integers(0, 16), rng.integers(1, 16)
        rough = i / 15
        mu = max(j / 15, 1e-4)
        eta = ref.table_eta(k, bool(inv))
        e = ref.ggx_glass_albedo(rough * rough, mu, eta, nodes=128)
        assert tables[inv][k, j, i] == pytest.approx(e, abs=5e-5), (inv, k, j, i)
    assert np.all(tables[0][:, :, 0] == 1.0) and np.all(tables[1][:, :, 0] == 1.0)


def test_cycles5_tables_match_reference_albedo(rng):
    """Cycles 5.x's grid (32^3, y = sqrt(mu)) with refractions leaving upwards rejected: 24 random
    entries against the reference's quadrature, which differs from the 4.x semantics there."""
    t = hairbsdf._core.huang_table(1)
    assert t.shape == (2, 32, 32, 32)
    for _ in range(24):
        inv, k, j, i = rng.integers(0, 2), rng.integers(0, 32), rng.integers(0, 32), rng.integers(1, 32)
        z = min(max(k / 31, 1e-4), 0.99)
        eta = (1 + z * z) / (1 - z * z)
        mu = max((j / 31) ** 2, 1e-4)
        e = ref.ggx_glass_albedo((i / 31) ** 2, mu, 1 / eta if inv else eta, nodes=128, reject_upward_refraction=True)
        assert t[inv][k, j, i] == pytest.approx(e, abs=5e-5), (inv, k, j, i)
    # Where refractions leave upwards (eta < 1, grazing) the two semantics differ by far more than that.
    z = 16 / 31
    eta = (1 + z * z) / (1 - z * z)
    kept = ref.ggx_glass_albedo((20 / 31) ** 2, (4 / 31) ** 2, 1 / eta, nodes=128)
    assert t[1][16, 4, 20] < kept - 0.05


R_CASES = [  # (roughness, offset, aspect, normal, theta_o, phi_o, theta_i, phi_i, h, near, coverage, accuracy)
    (0.3, 0.0349, 1.0, None, 20, -90, -30, 120, 0.3, False, 1.0, "cycles"),
    (0.1, -0.05, 1.0, None, -40, 30, 37, 109, -0.6, True, 1 / 60, "cycles"),  # near the R peak -2 asin(h)
    (0.05, 0.02, 1.0, None, 5, 10, -8, 150, 0.1, False, 1.0, "cycles"),
    (0.4, 0.04, 0.7, (0.2, 1.0, 0.3), 25, 60, -20, -100, 0.2, False, 1.0, "cycles"),
    (0.25, 0.03, 0.85, (0.0, 0.3, 1.0), -15, -120, 13, -85, -0.3, True, 0.1, "cycles"),
    (0.3, 0.0349, 1.0, None, 20, -90, -30, 120, 0.3, False, 1.0, "converged"),
    (0.2, 0.03, 0.8, (0.1, 1.0, 0.0), 30, 0, -35, 150, 0.0, False, 1.0, "converged"),
]


@pytest.mark.parametrize("case", R_CASES)
def test_r_lobe_matches_reference(case, tables):
    """The R lobe is deterministic in Cycles too: our value equals the reference to 1e-6."""
    rough, off, asp, nrm, to, po, ti, pi, h, near, cov, acc = case
    c = huang(roughness=rough, offset=off, aspect_ratio=asp, accuracy=acc, trt_points=64, transmission=0,
              secondary_reflection=0)
    kw = dict(near_field=near, pixel_coverage=cov)
    if nrm is not None:
        kw["normal"] = nrm
    ours = c.eval_lobes(unit(to, po), unit(ti, pi), h, **kw)[0, 0]
    params = ref.huang_params(parametrization="absorption", absorption_coefficient=(0.2, 0.5, 1.0), roughness=rough,
                              offset=off, aspect_ratio=asp)
    s = ref.Setup(params, unit(to, po), unit(ti, pi), h, near_field=near, pixel_coverage=cov, normal=nrm, tables=tables)
    theirs = ref.eval_lobes_from_setup(s, h_rule="simpson" if acc == "cycles" else "converged", inner=(1, 1),
                                       h_nodes=512)[0, 0]
    assert ours[0] > 0
    # Converged: the reference integrates the visibility jump of the macro normal with plain
    # Gauss-Legendre nodes (no breakpoints), good to ~1e-3.
    np.testing.assert_allclose(ours, theirs, rtol=2e-6 if acc == "cycles" else 2e-3)


@pytest.mark.parametrize("case", [R_CASES[0], R_CASES[1], R_CASES[3], R_CASES[4]])
def test_tt_matches_reference(case, tables):
    """TT (adaptive cubature here, a 48 x 48 Gauss-Legendre rule in the reference) to 2e-3 of the
    total."""
    rough, off, asp, nrm, to, po, ti, pi, h, near, cov, acc = case
    ti, pi = -to + 5, po + 170  # a backlit direction where TT matters
    c = huang(roughness=rough, offset=off, aspect_ratio=asp, tolerance=1e-4, trt_points=64, secondary_reflection=0)
    kw = dict(near_field=near, pixel_coverage=cov)
    if nrm is not None:
        kw["normal"] = nrm
    ours = c.eval_lobes(unit(to, po), unit(ti, pi), h, **kw)[0]
    params = ref.huang_params(parametrization="absorption", absorption_coefficient=(0.2, 0.5, 1.0), roughness=rough,
                              offset=off, aspect_ratio=asp, secondary_reflection=0.0)
    s = ref.Setup(params, unit(to, po), unit(ti, pi), h, near_field=near, pixel_coverage=cov, normal=nrm, tables=tables)
    theirs = ref.eval_lobes_from_setup(s, h_rule="simpson", inner=(48, 1), mapping="vndf_linear")[0]
    total = theirs.sum(axis=0)[1]
    assert theirs[1, 1] > 0.05 * total
    assert abs(ours[1, 1] - theirs[1, 1]) <= 2e-3 * total + 1e-12


def test_reference_estimator_matches_ours(tables):
    """The reference's own (numpy) Cycles estimator, averaged, against our deterministic eval: all
    lobes agree within 4 standard errors plus 1% of the total (TRT and TRRT+ use quasi-Monte Carlo
    with a few-% error, docs/huang.md §4)."""
    rng = np.random.default_rng(5)
    params = ref.huang_params(parametrization="absorption", absorption_coefficient=(0.2, 0.5, 1.0), roughness=0.35,
                              offset=0.03, aspect_ratio=1.0)
    c = huang(roughness=0.35, offset=0.03, tolerance=1e-4)
    wo = unit(15, -90)
    wi = np.array([unit(-20, -90 + d) for d in (35, 100, 165)])
    ours = c.eval_lobes(wo, wi, 0.2, near_field=True, pixel_coverage=1 / 60)
    s = ref.Setup(params, wo, wi, 0.2, near_field=True, pixel_coverage=1 / 60, tables=tables)
    runs = np.stack([ref.cycles_estimate(s, rng, samples=200) for _ in range(10)])  # 2000 samples in 10 batches
    mean, err = runs.mean(axis=0), runs.std(axis=0, ddof=1) / np.sqrt(len(runs))
    total = ours.sum(axis=1)[:, 1]
    for lobe in range(4):
        assert np.all(np.abs(ours[:, lobe, 1] - mean[:, lobe, 1]) <= 4 * err[:, lobe, 1] + 1e-2 * total), lobe


def test_cycles_estimator_mean_equals_eval():
    """Our Cycles-style stochastic estimator (C++) averages to the deterministic eval: the
    expected value of Cycles' eval, Simpson nodes included (far and near field, ellipse)."""
    for kw, ckw in [(dict(), dict()), (dict(near_field=True, pixel_coverage=1 / 60), dict()),
                    (dict(normal=(0.3, 1.0, 0.2)), dict(aspect_ratio=0.75, roughness=0.45))]:
        c = huang(tolerance=1e-4, **ckw)
        wo = unit(20, -90)
        wi = np.array([unit(-30, -90 + d) for d in (30, 150)])
        ours = c.eval_lobes(wo, wi, 0.3, **kw)
        runs = np.stack([c.cycles_estimate(wo, wi, 0.3, samples=4000, seed=seed, **kw) for seed in range(5)])
        mc, err = runs.mean(axis=0), runs.std(axis=0, ddof=1) / np.sqrt(len(runs))
        total = ours.sum(axis=1)[:, 1]
        # R is deterministic in Cycles; the stochastic eval sums it in float lanes (docs/simd.md): 3.3e-6 measured
        np.testing.assert_allclose(ours[:, 0], mc[:, 0], rtol=2e-5)
        assert np.all(np.abs(ours[:, 1:, 1] - mc[:, 1:, 1]) <= 4 * err[:, 1:, 1] + 5e-3 * total[:, None])


# --- sampling -----------------------------------------------------------------------------------

CHI2_CASES = [(0.3, 1.0, 0.035, unit(20, -90), 0.3, False), (0.1, 0.8, 0.05, unit(-50, 40), -0.7, False),
              (0.6, 0.7, -0.03, unit(60, 10), 0.1, True), (0.15, 1.0, 0.0, unit(0, 90), 0.5, True)]


@pytest.mark.parametrize("case", CHI2_CASES)
def test_chi2_mixture_sampler(case):
    rough, asp, off, wo, h, near = case
    c = huang(roughness=rough, aspect_ratio=asp, offset=off)
    kw = dict(normal=(0.0, 1.0, 0.3), near_field=near, pixel_coverage=0.05)

    class Directions:  # the sampler's directions and density (no BSDF evaluation needed)
        def sample(self, wo_, h_, u):
            return c.sample_directions(wo_, h_, u, **kw)

        def pdf(self, wo_, wi, h_):
            return c.pdf(wo_, wi, h_, **kw)

    r = testing.chi2_test(Directions(), wo, h, samples=1_000_000, theta_bins=64, phi_bins=128, nodes=4)
    assert r.passed(testing.sidak_alpha(0.01, len(CHI2_CASES))), r


def test_pdf_integrates_to_the_sampled_fraction(rng):
    c = huang(roughness=0.25, aspect_ratio=0.8)
    wo, h = unit(30, 20), 0.4
    kw = dict(normal=(0.0, 1.0, 0.0))
    s = c.sample_directions(wo, h, rng.random((200_000, 3)), **kw)
    produced = np.mean(s.lobe >= 0)

    class Pdf:
        model_params = None

        def pdf(self, wo_, wi, h_):
            return c.pdf(wo_, wi, h_, **kw)
    integral = testing.pdf_integral(Pdf(), wo, h, theta_panels=128, phi_panels=256)
    assert integral <= 1.0 + 1e-3
    assert integral == pytest.approx(produced, abs=3e-3)


def test_sample_weight_is_eval_over_pdf(rng):
    c = huang(roughness=0.35, aspect_ratio=0.85, trt_points=256, tolerance=1e-2)
    n = 40
    wo = rng.normal(size=(n, 3))
    h = rng.uniform(-0.8, 0.8, n)
    kw = dict(normal=(0.0, 0.4, 1.0), near_field=True, pixel_coverage=0.05)
    s = c.sample(wo, h, rng.random((n, 3)), **kw)
    ok = s.lobe >= 0
    assert ok.mean() > 0.8
    pdf = c.pdf(wo[ok], s.wi[ok], h[ok], **kw)
    np.testing.assert_allclose(s.pdf[ok], pdf, rtol=1e-12)
    ev = c.eval(wo[ok], s.wi[ok], h[ok], **kw)
    np.testing.assert_allclose(s.weight[ok], ev / pdf[:, None], rtol=1e-9, atol=1e-15)


def test_cycles_sampler_reports_pdf_one(rng):
    c = huang(sampler="cycles", trt_points=64)
    wo = unit(20, -90)
    s = c.sample(wo, 0.3, rng.random((2000, 3)))
    ok = s.lobe >= 0
    assert ok.mean() > 0.5
    assert np.all(s.pdf[ok] == 1.0) and np.all(c.pdf(wo, s.wi[ok][:5], 0.3) == 1.0)


def test_white_furnace(rng):
    """sigma_a = 0: the directional albedo as the mean of eval/pdf over the mixture sampler, with
    eval from Cycles' unbiased estimator. Cycles 4.5's model is NOT energy conserving: its TRRT+
    series counts light that total internal reflection traps inside the fibre while the TRT path
    still carries it, and in the far field Cycles' Simpson rule overweights the grazing ends of h
    (|d gamma/dh| -> 22 at h = 0.999) for TRRT+, which has no masking term. Measured (docs/huang.md
    §6): about 1.7 (far field, Cycles' Simpson) and 1.2 (converged h) at roughness 0.3; the near
    field at h = 0.2 has no grazing ends. Checked here with Cycles' estimator (Simpson nodes): the
    far-field albedo exceeds 1.5, the near-field one lies in [0.9, 1.1]."""
    values = {}
    for near in (False, True):
        c = huang(absorption_coefficient=0.0, roughness=0.3)
        wo = unit(25, -90)
        kw = dict(near_field=near, pixel_coverage=1 / 30)
        s = c.sample_directions(wo, 0.2, rng.random((60_000, 3)), **kw)
        ok = s.lobe >= 0
        f = c.cycles_estimate(np.broadcast_to(wo, s.wi[ok].shape), s.wi[ok], 0.2, samples=1, seed=7,
                              **kw).sum(axis=1)[:, 1]
        w = np.zeros(len(s.pdf))
        w[ok] = f / s.pdf[ok]
        values[near] = (w.mean(), w.std() / np.sqrt(len(w)))
    assert values[False][0] > 1.5
    assert 0.9 < values[True][0] < 1.1
    print("white furnace albedo (mean, standard error):", values)
