"""Self-tests of the float64 Chiang/Cycles reference (chiang_reference.py).

Values quoted from docs/cycles.md §2 and docs/validation.md §3.2/§5 are checked against the
reference; special functions are checked against mpmath; model identities (energy, symmetry,
normalisation) are checked by quadrature.
"""

import math

import mpmath
import numpy as np
import pytest
from scipy import integrate

from . import chiang_reference as ref

RNG_SEED = 20261122


def random_directions(rng, n):
    """Uniform unit directions on the sphere."""
    w = rng.normal(size=(n, 3))
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def default_params(beta_m=0.3, beta_n=0.3, sigma_a=(0.0, 0.0, 0.0), eta=1.55, offset=0.0349066,
                   coat_beta=None):
    v = ref.roughness_to_variance(beta_m)
    v_r = v if coat_beta is None else ref.roughness_to_variance(coat_beta)
    return ref.raw_params(sigma_a, v, ref.radial_roughness_to_scale(beta_n), eta, offset, v_r)


# --------------------------------------------------------------------------------------------
# Parameter mapping (docs/cycles.md §2)
# --------------------------------------------------------------------------------------------

def test_roughness_to_variance_and_scale():
    assert ref.roughness_to_variance(0.3) == pytest.approx(0.084611, abs=1e-6)
    assert ref.roughness_to_variance(0.1) == pytest.approx(0.0065157, abs=1e-7)
    assert ref.roughness_to_variance(0.5) == pytest.approx(0.32036, abs=1e-5)
    assert ref.roughness_to_variance(1.0) == pytest.approx(27.44, rel=1e-3)
    assert ref.roughness_to_variance(0.001) == pytest.approx(5.3e-7, rel=1e-2)
    assert ref.radial_roughness_to_scale(0.3) == pytest.approx(0.11716, abs=5e-6)
    assert ref.radial_roughness_to_scale(1.0) == pytest.approx(4.281, abs=5e-4)
    assert ref.SQRT_PI_OVER_8 == pytest.approx(0.6266570686577501, abs=1e-16)


def test_absorption_from_color():
    assert ref.albedo_roughness_scale(0.3) == pytest.approx(5.8884, abs=1e-4)
    default_sigma = ref.absorption_from_color((0.017513, 0.005763, 0.002059), 0.3)
    np.testing.assert_allclose(default_sigma, (0.4718, 0.7668, 1.1035), atol=1e-4)
    np.testing.assert_allclose(ref.absorption_from_color((0.5, 0.3, 0.1), 0.3),
                               (0.013857, 0.041806, 0.152910), atol=1e-6)
    # White gives no absorption, black (or negative, clamped to 0) infinite absorption.
    np.testing.assert_array_equal(ref.absorption_from_color((1.0, 0.0, -0.5), 0.3),
                                  (0.0, np.inf, np.inf))


def test_absorption_from_melanin():
    pheomelanin_only = ref.absorption_from_melanin(0.8, 1.0)
    assert -math.log(1.0 - 0.8) == pytest.approx(1.6094, abs=1e-4)
    np.testing.assert_allclose(pheomelanin_only, 1.6094379 * np.array([0.343, 0.733, 1.924]), rtol=1e-7)
    eumelanin_only = ref.absorption_from_melanin(0.8, 0.0)
    np.testing.assert_allclose(eumelanin_only, 1.6094379 * np.array([0.506, 0.841, 1.653]), rtol=1e-7)
    # Not pbrt's eumelanin-1.3 values: Cycles' constants differ.
    assert not np.allclose(ref.absorption_from_melanin(1.0 - math.exp(-1.3), 0.0), (0.5447, 0.9061, 1.781),
                           atol=1e-2)
    # Random Color: m = 0.8 * (1 + 2 (1 - 0.5) * 0.5) = 1.2 -> -ln(max(-0.2, 1e-4)) = ln(1e4).
    np.testing.assert_allclose(ref.absorption_from_melanin(0.8, 0.5, random=1.0, random_color=0.5),
                               math.log(1e4) * 0.5 * (ref.EUMELANIN_SIGMA + ref.PHEOMELANIN_SIGMA))
    # Random Color is clamped to [0, 1].
    np.testing.assert_array_equal(ref.absorption_from_melanin(0.3, 0.5, random=0.2, random_color=3.0),
                                  ref.absorption_from_melanin(0.3, 0.5, random=0.2, random_color=1.0))
    # Tint adds the direct-coloring absorption with the same radial roughness.
    tinted = ref.absorption_from_melanin(0.8, 1.0, tint=(0.5, 0.3, 0.1), radial_roughness=0.3)
    np.testing.assert_allclose(tinted - pheomelanin_only, (0.013857, 0.041806, 0.152910), atol=1e-6)


def test_principled_hair_params_defaults_and_randomization():
    params = ref.principled_hair_params()
    np.testing.assert_allclose(params["sigma_a"], (0.4718, 0.7668, 1.1035), atol=1e-4)
    assert params["v"] == pytest.approx(0.084611, abs=1e-6)
    assert params["v_R"] == params["v"]
    assert params["s"] == pytest.approx(0.11716, abs=5e-6)
    assert params["eta"] == 1.55 and params["offset"] == 0.0349066

    # Random roughness: factor 1 + 2 (0.9 - 0.5) 0.5 = 1.4 on both roughnesses.
    params = ref.principled_hair_params(roughness=0.5, radial_roughness=0.9, random=0.9,
                                        random_roughness=0.5)
    assert params["v"] == pytest.approx(ref.roughness_to_variance(0.7), rel=1e-14)
    assert params["s"] == pytest.approx(ref.radial_roughness_to_scale(1.0), rel=1e-14)  # 1.26 clamped
    # The colour conversion sees the randomized, unclamped radial roughness 1.26.
    np.testing.assert_allclose(params["sigma_a"],
                               ref.absorption_from_color((0.017513, 0.005763, 0.002059), 1.26), rtol=1e-12)

    # Coat reduces the R roughness before mapping; clamps on coat and on the result.
    params = ref.principled_hair_params(roughness=0.3, coat=0.5)
    assert params["v_R"] == pytest.approx(ref.roughness_to_variance(0.15), rel=1e-14)
    assert params["v"] == pytest.approx(ref.roughness_to_variance(0.3), rel=1e-14)
    params = ref.principled_hair_params(coat=2.0)
    assert params["v_R"] == pytest.approx(ref.roughness_to_variance(0.001), rel=1e-14)

    np.testing.assert_array_equal(ref.principled_hair_params("absorption")["sigma_a"], (0.245531, 0.52, 1.365))
    np.testing.assert_allclose(ref.principled_hair_params("melanin")["sigma_a"],
                               1.6094379 * np.array([0.343, 0.733, 1.924]), rtol=1e-7)
    with pytest.raises(ValueError):
        ref.principled_hair_params("pigment")


def _mix_u32(a, b, c):
    """lookup3 mix() (Bob Jenkins' public description), only to build hashlittle for a test vector."""
    def rot(x, k):
        return ((x << k) | (x >> (32 - k))) & 0xFFFFFFFF
    a = (a - c) & 0xFFFFFFFF; a ^= rot(c, 4); c = (c + b) & 0xFFFFFFFF
    b = (b - a) & 0xFFFFFFFF; b ^= rot(a, 6); a = (a + c) & 0xFFFFFFFF
    c = (c - b) & 0xFFFFFFFF; c ^= rot(b, 8); b = (b + a) & 0xFFFFFFFF
    a = (a - c) & 0xFFFFFFFF; a ^= rot(c, 16); c = (c + b) & 0xFFFFFFFF
    b = (b - a) & 0xFFFFFFFF; b ^= rot(a, 19); a = (a + c) & 0xFFFFFFFF
    c = (c - b) & 0xFFFFFFFF; c ^= rot(b, 4); b = (b + a) & 0xFFFFFFFF
    return a, b, c


def _hashlittle(data, initval):
    """lookup3 hashlittle() for a non-empty byte string, using the reference's final()."""
    a = b = c = (0xDEADBEEF + len(data) + initval) & 0xFFFFFFFF
    while len(data) > 12:
        words = np.frombuffer(data[:12], dtype="<u4")
        a, b, c = ((x + int(w)) & 0xFFFFFFFF for x, w in zip((a, b, c), words))
        a, b, c = _mix_u32(a, b, c)
        data = data[12:]
    words = np.frombuffer(data.ljust(12, b"\0"), dtype="<u4")
    a, b, c = ((x + int(w)) & 0xFFFFFFFF for x, w in zip((a, b, c), words))
    _, _, c = ref.lookup3_final(*(np.array([x], dtype=np.uint32) for x in (a, b, c)))
    return int(c[0])


def test_lookup3_final_and_curve_random():
    # Bob Jenkins' published lookup3 driver values exercise final().
    text = b"Four score and seven years ago"
    assert _hashlittle(text, 0) == 0x17770551
    assert _hashlittle(text, 1) == 0xCD628161
    values = ref.cycles_curve_random(np.arange(1000))
    assert values.shape == (1000,) and np.all((values >= 0.0) & (values <= 1.0))
    assert abs(values.mean() - 0.5) < 0.05
    assert ref.cycles_curve_random(7) == values[7]
    assert isinstance(ref.cycles_curve_random(0), float)


# --------------------------------------------------------------------------------------------
# Special functions (docs/cycles.md §4.3)
# --------------------------------------------------------------------------------------------

def test_bessel_series_matches_mpmath_where_converged():
    x = np.array([0.0, 0.1, 0.5, 1.0, 2.0, 3.0])
    expected = np.array([float(mpmath.besseli(0, xi)) for xi in x])
    np.testing.assert_allclose(ref.bessel_i0_cycles(x), expected, rtol=1e-10)
    np.testing.assert_allclose(ref.log_bessel_i0_cycles(x), np.log(expected), rtol=1e-10, atol=1e-14)
    # Cycles' truncation: about -2.0% just below the switch at 12, about -0.57% just above it.
    exact_12 = float(mpmath.besseli(0, 12))
    assert ref.bessel_i0_cycles(12.0) / exact_12 - 1 == pytest.approx(-0.020, abs=1e-3)
    assert math.exp(ref.log_bessel_i0_cycles(12.0 + 1e-9)) / exact_12 - 1 == pytest.approx(-0.0057, abs=2e-4)


@pytest.mark.parametrize("theta_i,theta_o,v", [(0.1, -0.2, 0.0065), (-0.4, 0.35, 0.0846),
                                               (1.2, -1.0, 0.32), (0.3, 0.9, 3.1), (-1.5, 0.2, 27.4),
                                               (0.02, -0.01, 0.0016)])
def test_exact_longitudinal_matches_mpmath(theta_i, theta_o, v):
    mpmath.mp.dps = 40
    ti, to, vv = mpmath.mpf(theta_i), mpmath.mpf(theta_o), mpmath.mpf(v)
    a = mpmath.cos(ti) * mpmath.cos(to) / vv
    b = mpmath.sin(ti) * mpmath.sin(to) / vv
    expected = mpmath.exp(-b) * mpmath.besseli(0, a) / (2 * vv * mpmath.sinh(1 / vv))
    got = ref.longitudinal_scattering(math.sin(theta_i), math.cos(theta_i), math.sin(theta_o),
                                      math.cos(theta_o), v, "exact")
    assert float(got) == pytest.approx(float(expected), rel=1e-11)


def _longitudinal_integral(v, theta_o, accuracy):
    def integrand(theta_i):
        return ref.longitudinal_scattering(math.sin(theta_i), math.cos(theta_i), math.sin(theta_o),
                                           math.cos(theta_o), v, accuracy) * math.cos(theta_i)
    points = [-theta_o] if abs(theta_o) < math.pi / 2 else None
    return integrate.quad(integrand, -math.pi / 2, math.pi / 2, points=points, limit=400,
                          epsabs=1e-13, epsrel=1e-12)[0]


@pytest.mark.parametrize("v", [0.0016, 0.0065, 0.0316, 0.0846, 0.32, 3.1, 27.4])
def test_exact_longitudinal_normalised(v):
    for theta_o in (0.0, 0.45, -1.05, 1.5):
        assert _longitudinal_integral(v, theta_o, "exact") == pytest.approx(1.0, abs=1e-6)


def test_cycles_longitudinal_deficit_matches_peer_table():
    # docs/validation.md §3.2 ("pbrt-style" column = Cycles' code).
    assert _longitudinal_integral(0.0846, 0.0, "cycles") == pytest.approx(0.9869, abs=1e-4)
    assert _longitudinal_integral(0.0316, 0.0, "cycles") == pytest.approx(0.9979, abs=1e-4)
    assert _longitudinal_integral(0.0065, math.radians(60), "cycles") == pytest.approx(0.9983, abs=1e-4)
    assert _longitudinal_integral(0.32, 0.7, "cycles") == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("accuracy", ["cycles", "exact"])
def test_longitudinal_symmetries(accuracy):
    theta = np.linspace(-1.55, 1.55, 41)
    ti, to = np.meshgrid(theta, theta, indexing="ij")
    for v in (0.0016, 0.05, 0.0846, 0.5, 27.4):
        m = ref.longitudinal_scattering(np.sin(ti), np.cos(ti), np.sin(to), np.cos(to), v, accuracy)
        assert np.all(np.isfinite(m)) and np.all(m >= 0)
        np.testing.assert_allclose(m, m.T, rtol=1e-12, atol=1e-300)
        np.testing.assert_allclose(m, m[::-1, ::-1], rtol=1e-12, atol=1e-300)


@pytest.mark.parametrize("s", [0.01, 0.11716, 1.0, 4.281])
def test_trimmed_logistic_normalised(s):
    total = integrate.quad(lambda x: ref.trimmed_logistic(x, s), -math.pi, math.pi, points=[0.0],
                           limit=200, epsabs=1e-13)[0]
    assert total == pytest.approx(1.0, abs=1e-9)


def test_fresnel():
    assert ref.fresnel_dielectric(1.0, 1.55) == pytest.approx(0.046521, abs=1e-6)
    assert ref.fresnel_dielectric(0.0, 1.55) == pytest.approx(1.0, abs=1e-15)
    assert ref.fresnel_dielectric(0.2, 1 / 1.55) == 1.0  # total internal reflection
    # Same as Walter et al.'s closed form of the unpolarised Fresnel term.
    cos_i = np.linspace(0.01, 1.0, 50)
    for eta in (1.3, 1.55, 2.0, 0.8):
        g2 = eta**2 - 1 + cos_i**2
        g = np.sqrt(np.maximum(g2, 0))
        walter = 0.5 * ((g - cos_i) / (g + cos_i)) ** 2 * (
            1 + ((cos_i * (g + cos_i) - 1) / (cos_i * (g - cos_i) + 1)) ** 2)
        np.testing.assert_allclose(ref.fresnel_dielectric(cos_i, eta), np.where(g2 > 0, walter, 1.0),
                                   rtol=1e-12)


# --------------------------------------------------------------------------------------------
# Model (docs/cycles.md §4)
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("eta", [1.55, 1.3, 2.0])
def test_attenuations_sum_to_one_without_absorption(eta):
    rng = np.random.default_rng(RNG_SEED)
    wo = random_directions(rng, 500)
    h = rng.uniform(-1, 1, 500)
    attenuation = ref.chiang_attenuation(default_params(eta=eta), wo, h)
    np.testing.assert_allclose(attenuation.sum(axis=1), 1.0, atol=1e-12)
    assert np.all((attenuation >= 0) & (attenuation <= 1))
    absorbing = ref.chiang_attenuation(default_params(eta=eta, sigma_a=(0.25, 0.5, 1.0)), wo, h).sum(axis=1)
    assert np.all(np.diff(absorbing, axis=1) <= 1e-15)  # more absorption, less energy


def _scalar_eval_exact(params, wo, wi, h):
    """Straight-line mpmath re-statement of docs/cycles.md §4 for one row (exact M_p, tilt 4.2)."""
    mpmath.mp.dps = 30
    sin_o, sin_i = mpmath.mpf(wo[0]), mpmath.mpf(wi[0])
    cos_o, cos_i = mpmath.sqrt(wo[1] ** 2 + wo[2] ** 2), mpmath.sqrt(wi[1] ** 2 + wi[2] ** 2)
    theta_o, theta_i = mpmath.atan2(sin_o, cos_o), mpmath.atan2(sin_i, cos_i)
    dphi = mpmath.atan2(wi[2], wi[1]) - mpmath.atan2(wo[2], wo[1])
    eta, v, s, offset = (mpmath.mpf(params[k]) for k in ("eta", "v", "s", "offset"))
    gamma_o = mpmath.asin(h)
    sin_t = sin_o / eta
    cos_t = mpmath.sqrt(1 - sin_t**2)
    sin_gt = h * cos_o / mpmath.sqrt(eta**2 - sin_o**2)
    gamma_t = mpmath.asin(sin_gt)
    c = cos_o * mpmath.cos(gamma_o)
    ct = mpmath.sqrt(1 - (1 - c**2) / eta**2)
    f = ((c - eta * ct) ** 2 / (c + eta * ct) ** 2 + (eta * c - ct) ** 2 / (eta * c + ct) ** 2) / 2

    def m_p(t_i, t_o, var):
        a = mpmath.cos(t_i) * abs(mpmath.cos(t_o)) / var
        b = mpmath.sin(t_i) * mpmath.sin(t_o) / var
        return mpmath.exp(-b) * mpmath.besseli(0, a) / (2 * var * mpmath.sinh(1 / var))

    def n_p(x):
        x = (x + mpmath.pi) % (2 * mpmath.pi) - mpmath.pi
        logistic = lambda y: mpmath.exp(-abs(y) / s) / (s * (1 + mpmath.exp(-abs(y) / s)) ** 2)
        return logistic(x) / (1 - 2 / (1 + mpmath.exp(mpmath.pi / s)))

    result = []
    for sigma in params["sigma_a"]:
        t = mpmath.exp(-sigma * 2 * mpmath.cos(gamma_t) / cos_t)
        a_p = [f, (1 - f) ** 2 * t, (1 - f) ** 2 * t * t * f]
        a_p.append(a_p[2] * t * f / (1 - t * f))
        total = 0
        for p, (var, tilt) in enumerate(((v, 2), (v / 4, -1), (4 * v, -4))):
            phi_p = 2 * p * gamma_t - 2 * gamma_o + p * mpmath.pi
            total += a_p[p] * m_p(theta_i, theta_o + tilt * offset, var) * n_p(dphi - phi_p)
        total += a_p[3] * m_p(theta_i, theta_o, 4 * v) / (2 * mpmath.pi)
        result.append(float(total))
    return np.array(result)


def test_eval_matches_scalar_mpmath_restatement():
    rng = np.random.default_rng(RNG_SEED)
    params = default_params(beta_m=0.25, beta_n=0.4, sigma_a=(0.2, 0.7, 1.5), eta=1.55, offset=0.06)
    wo, wi = random_directions(rng, 12), random_directions(rng, 12)
    h = rng.uniform(-0.99, 0.99, 12)
    got = ref.chiang_eval(params, wo, wi, h, accuracy="exact")
    expected = np.array([_scalar_eval_exact(params, wo[k], wi[k], h[k]) for k in range(12)])
    np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-300)
    np.testing.assert_allclose(got, ref.chiang_eval_lobes(params, wo, wi, h, accuracy="exact").sum(axis=1),
                               rtol=1e-12)


@pytest.mark.parametrize("accuracy", ["cycles", "exact"])
@pytest.mark.parametrize("tilt", ["4.2", "3.4"])
def test_mirror_and_rotation_symmetry(accuracy, tilt):
    # Negating z maps phi -> -phi (so dphi -> -dphi); h -> -h maps gamma_o, gamma_t and Phi_p to
    # their negatives (p*pi is unchanged modulo 2 pi); the logistic is even, so N_p is unchanged.
    rng = np.random.default_rng(RNG_SEED)
    params = default_params(sigma_a=(0.3, 0.6, 1.2), offset=0.05)
    wo, wi = random_directions(rng, 400), random_directions(rng, 400)
    h = rng.uniform(-1, 1, 400)
    mirror = np.array([1.0, 1.0, -1.0])
    base = ref.chiang_eval_lobes(params, wo, wi, h, accuracy, tilt)
    np.testing.assert_allclose(ref.chiang_eval_lobes(params, wo * mirror, wi * mirror, -h, accuracy, tilt),
                               base, rtol=1e-10, atol=1e-300)
    angle = 1.234
    rotation = np.array([[1, 0, 0], [0, math.cos(angle), -math.sin(angle)],
                         [0, math.sin(angle), math.cos(angle)]])
    np.testing.assert_allclose(ref.chiang_eval_lobes(params, wo @ rotation.T, wi @ rotation.T, h, accuracy, tilt),
                               base, rtol=1e-9, atol=1e-300)
    np.testing.assert_allclose(ref.chiang_pdf(params, wo * mirror, wi * mirror, -h, accuracy, tilt),
                               ref.chiang_pdf(params, wo, wi, h, accuracy, tilt), rtol=1e-10, atol=1e-300)


def test_tilt_variants():
    rng = np.random.default_rng(RNG_SEED)
    wo, wi = random_directions(rng, 200), random_directions(rng, 200)
    h = rng.uniform(-1, 1, 200)
    untilted = default_params(sigma_a=(0.3, 0.6, 1.2), offset=0.0)
    np.testing.assert_allclose(ref.chiang_eval(untilted, wo, wi, h, tilt="4.2"),
                               ref.chiang_eval(untilted, wo, wi, h, tilt="3.4"), rtol=1e-12, atol=1e-300)
    # Per-lobe shifts: 4.2 tilts theta_o, 3.4 tilts theta_i, by +2, -1, -4 times Offset (R, TT, TRT);
    # the residual is untilted. Ratio tilted/untilted isolates M_p (A_p and N_p do not depend on tilt).
    offset = 0.05
    tilted = default_params(sigma_a=(0.3, 0.6, 1.2), offset=offset)
    sin_o, cos_o = wo[:, 0], np.hypot(wo[:, 1], wo[:, 2])
    sin_i, cos_i = wi[:, 0], np.hypot(wi[:, 1], wi[:, 2])
    theta_o, theta_i = np.arctan2(sin_o, cos_o), np.arctan2(sin_i, cos_i)
    for tilt in ("4.2", "3.4"):
        ratio = (ref.chiang_eval_lobes(tilted, wo, wi, h, "exact", tilt)[:, :, 0]
                 / ref.chiang_eval_lobes(untilted, wo, wi, h, "exact", tilt)[:, :, 0])
        for lobe, (multiple, variance) in enumerate(zip((2, -1, -4), (1, 0.25, 4))):
            v = variance * untilted["v"]
            if tilt == "4.2":
                shifted_o = theta_o + multiple * offset
                m_tilted = ref.longitudinal_scattering(sin_i, cos_i, np.sin(shifted_o), np.abs(np.cos(shifted_o)),
                                                       v, "exact")
            else:
                shifted_i = theta_i + multiple * offset
                m_tilted = ref.longitudinal_scattering(np.sin(shifted_i), np.abs(np.cos(shifted_i)), sin_o, cos_o,
                                                       v, "exact")
            m_untilted = ref.longitudinal_scattering(sin_i, cos_i, sin_o, cos_o, v, "exact")
            np.testing.assert_allclose(ratio[:, lobe], m_tilted / m_untilted, rtol=1e-9)
        np.testing.assert_allclose(ratio[:, 3], 1.0, rtol=1e-12)
    # The R highlight moves toward the root: for small v, M_R peaks near theta_i = -theta_o - 2 offset.
    params = default_params(beta_m=0.1, offset=offset)
    theta_grid = np.linspace(-1.5, 1.5, 30001)
    wo_rows = np.broadcast_to(ref.direction_from_angles(0.4, 0.0), (theta_grid.size, 3))
    wi_rows = ref.direction_from_angles(theta_grid, 0.0)
    for tilt in ("4.2", "3.4"):
        r_lobe = ref.chiang_eval_lobes(params, wo_rows, wi_rows, 0.0, "exact", tilt)[:, 0, 0]
        assert theta_grid[np.argmax(r_lobe)] == pytest.approx(-0.4 - 2 * offset, abs=5e-3)


def test_nan_rows_are_zero():
    params = default_params(eta=0.8, sigma_a=(0.1, 0.2, 0.3))
    theta_o = np.array([1.2, 0.3])                   # sin(1.2) = 0.93 > eta: sqrt of a negative
    wo = ref.direction_from_angles(theta_o, 0.0)
    wi = ref.direction_from_angles(np.array([-1.0, -0.2]), 2.0)
    lobes = ref.chiang_eval_lobes(params, wo, wi, 0.3)
    assert np.all(lobes[0] == 0.0)
    assert np.all(np.isfinite(lobes[1])) and lobes[1].sum() > 0
    pdf = ref.chiang_pdf(params, wo, wi, 0.3)
    assert pdf[0] == 0.0 and pdf[1] > 0


def _sphere_quadrature(n_sin=192, n_phi=768):
    """Gauss-Legendre nodes in sin(theta_i) x midpoint rule in phi_i (the integrand is periodic)."""
    nodes, weights = np.polynomial.legendre.leggauss(n_sin)
    phi = -np.pi + 2 * np.pi * (np.arange(n_phi) + 0.5) / n_phi
    sin_theta, phi = np.meshgrid(nodes, phi, indexing="ij")
    cos_theta = np.sqrt(1 - sin_theta**2)
    directions = np.stack([sin_theta, cos_theta * np.cos(phi), cos_theta * np.sin(phi)], -1).reshape(-1, 3)
    return directions, (weights[:, None] * np.full(n_phi, 2 * np.pi / n_phi)).ravel()


@pytest.mark.parametrize("beta_m", [0.3, 0.6, 1.0])
def test_white_furnace_exact(beta_m):
    wi, weights = _sphere_quadrature()
    params = default_params(beta_m=beta_m, beta_n=0.3, offset=0.05)
    for h, theta_o in ((0.0, 0.0), (0.7, 0.6), (-0.95, -1.3), (0.3, 1.5)):
        wo = ref.direction_from_angles(theta_o, 0.3)[None]
        albedo = weights @ ref.chiang_eval(params, wo, wi, h, accuracy="exact", tilt="4.2")
        np.testing.assert_allclose(albedo, 1.0, atol=1e-3)
        density_total = weights @ ref.chiang_sampling_density(params, wo, wi, h)
        assert density_total == pytest.approx(1.0, abs=1e-3)


def test_pdf_variants():
    rng = np.random.default_rng(RNG_SEED)
    wo, wi = random_directions(rng, 300), random_directions(rng, 300)
    h = rng.uniform(-1, 1, 300)
    params = default_params(sigma_a=(0.3, 0.6, 1.2), offset=0.05)
    np.testing.assert_allclose(ref.chiang_sampling_density(params, wo, wi, h),
                               ref.chiang_pdf(params, wo, wi, h, accuracy="exact"), rtol=1e-12)
    coated = default_params(sigma_a=(0.3, 0.6, 1.2), offset=0.05, coat_beta=0.15)
    assert not np.allclose(ref.chiang_sampling_density(coated, wo, wi, h),
                           ref.chiang_pdf(coated, wo, wi, h, accuracy="exact"))
    np.testing.assert_allclose(ref.chiang_sampling_density(coated, wo, wi, h),
                               ref.chiang_sampling_density(params, wo, wi, h), rtol=1e-12)


def _sample_cycles_42(params, wo, h, u):
    """Re-statement of Cycles' 4.2+ sampler (docs/cycles.md §4.4) for one wo/h, many random triples u."""
    attenuation = ref.chiang_attenuation(params, wo[None], h)[0]
    energy = attenuation @ ref.LUMINANCE_WEIGHTS
    energy[0] = attenuation[0, 0]
    weights = energy / energy.sum()
    cumulative = np.concatenate([[0.0], np.cumsum(weights)])
    z = u[:, 2]
    lobe = np.minimum(np.searchsorted(cumulative, z, side="right") - 1, 3)
    z = np.maximum((z - cumulative[lobe]) / weights[lobe], 1e-5)
    v = params["v"]
    variance = np.array([v, v / 4, 4 * v, 4 * v])[lobe]
    shift = np.array([2.0, -1.0, -4.0, 0.0])[lobe] * params["offset"]
    theta_o = math.atan2(wo[0], math.hypot(wo[1], wo[2]))
    sin_o, cos_o = np.sin(theta_o + shift), np.abs(np.cos(theta_o + shift))
    fac = 1 + variance * np.log(z + (1 - z) * np.exp(-2 / variance))
    sin_i = -fac * sin_o + np.sqrt(np.maximum(0, 1 - fac**2)) * np.cos(2 * np.pi * u[:, 1]) * cos_o
    # Azimuth: Phi_p + trimmed-logistic inverse CDF of u0, or uniform for the residual.
    eta = params["eta"]
    gamma_o = math.asin(h)
    gamma_t = math.asin(h * math.hypot(wo[1], wo[2]) / math.sqrt(eta**2 - wo[0] ** 2))
    s = params["s"]
    low, high = (1 / (1 + np.exp(np.pi / s)), 1 / (1 + np.exp(-np.pi / s)))
    cdf = u[:, 0] * (high - low) + low
    logistic_sample = -s * np.log(1 / cdf - 1)
    shift_phi = 2 * lobe * gamma_t - 2 * gamma_o + lobe * np.pi
    dphi = np.where(lobe < 3, shift_phi + logistic_sample, 2 * np.pi * u[:, 0])
    return np.clip(sin_i, -1, 1), ref.wrap_angle(dphi)


def test_sampling_density_matches_sampler_histogram_with_coat():
    # Histogram of the notes' sampler vs the claimed true density, and vs the reported pdf, with
    # Coat > 0: only the former must fit (coat quirk, docs/cycles.md §4.4).
    rng = np.random.default_rng(RNG_SEED)
    params = default_params(beta_m=0.4, beta_n=0.5, sigma_a=(0.1, 0.2, 0.4), offset=0.06, coat_beta=0.2)
    wo = ref.direction_from_angles(0.5, 0.0)
    h = 0.35
    n_samples = 400_000
    sin_i, dphi = _sample_cycles_42(params, wo, h, rng.uniform(size=(n_samples, 3)))
    bins_sin, bins_phi = 20, 40
    counts, _, _ = np.histogram2d(sin_i, dphi, bins=(bins_sin, bins_phi), range=((-1, 1), (-np.pi, np.pi)))

    # Expected cell probabilities by 6x6 Gauss-Legendre per cell.
    nodes, weights = np.polynomial.legendre.leggauss(6)
    edges_sin, edges_phi = np.linspace(-1, 1, bins_sin + 1), np.linspace(-np.pi, np.pi, bins_phi + 1)
    half_sin, half_phi = np.diff(edges_sin)[0] / 2, np.diff(edges_phi)[0] / 2
    sin_nodes = ((edges_sin[:-1] + half_sin)[:, None] + half_sin * nodes).ravel()
    phi_nodes = ((edges_phi[:-1] + half_phi)[:, None] + half_phi * nodes).ravel()
    grid_sin, grid_phi = np.meshgrid(sin_nodes, phi_nodes, indexing="ij")
    cos_grid = np.sqrt(1 - grid_sin**2)
    wi = np.stack([grid_sin, cos_grid * np.cos(grid_phi), cos_grid * np.sin(grid_phi)], -1).reshape(-1, 3)
    cell_weight = np.outer(np.tile(weights, bins_sin), np.tile(weights, bins_phi)) * half_sin * half_phi

    def expected_counts(density):
        per_node = density.reshape(grid_sin.shape) * cell_weight
        return per_node.reshape(bins_sin, 6, bins_phi, 6).sum(axis=(1, 3)) * n_samples

    def chi_square(expected):
        keep = expected > 5
        return np.sum((counts[keep] - expected[keep]) ** 2 / expected[keep]), keep.sum() - 1

    true_chi2, dof = chi_square(expected_counts(ref.chiang_sampling_density(params, wo[None], wi, h)))
    reported_chi2, _ = chi_square(expected_counts(ref.chiang_pdf(params, wo[None], wi, h, accuracy="exact")))
    # chi^2 with ~800 dof: mean dof, sd sqrt(2 dof); allow 5 sd.
    assert true_chi2 < dof + 5 * math.sqrt(2 * dof)
    assert reported_chi2 > dof + 20 * math.sqrt(2 * dof)
