"""Independent float64 reference of Blender Cycles' Principled Hair BSDF (Chiang 2016 model).

Written from the formulas in docs/cycles.md (cited as "docs/cycles.md §x") and the
frame/sign conventions in docs/conventions.md (cited as "conventions"). It is the oracle the C++
module is tested against, so it deliberately shares no code with it.

Conventions (see docs/conventions.md):
  * directions are unit vectors in the fibre frame: x = tangent (root -> tip), sin(theta) = w.x,
    cos(theta) = sqrt(w.y^2 + w.z^2), phi = atan2(w.z, w.y);
  * wo points to the viewer, wi to the light; h in [-1, 1], gamma_o = asin(h);
  * eval returns sum_p A_p M_p N_p, i.e. it INCLUDES the cosine factor (no 1/|cos theta_i|).

Every model function is vectorised over rows: wo, wi are (N, 3); h is (N,) or a scalar; each
entry of the params dict may be a scalar (or (3,) for sigma_a) or per-row ((N,) / (N, 3)).

Switches of the model functions:
  accuracy="cycles": M_p exactly as Cycles computes it (docs/cycles.md §4.3: v <= 0.1 log branch with the
                     constant 0.6931, 10-term I0 series, crude log-I0 asymptote above 12).
  accuracy="exact":  the mathematically exact M_p, normalised so that int M_p cos(theta_i) dtheta_i = 1.
  tilt="4.2":        cuticle tilt applied to the view angle theta_o (docs/cycles.md §4.3, Blender 4.2+).
  tilt="3.4":        cuticle tilt applied to the light angle theta_i (docs/cycles.md §5b, Blender 3.4-4.1).

NaN policy: Cycles has no NaN guards (docs/cycles.md §4.5). Wherever its formulas produce NaN for a row
(e.g. eta < 1 with sin^2(theta_o) > eta^2, where sqrt(eta^2 - sin^2 theta_o) is NaN, or
0 * inf in the absorption), this reference returns 0 for the whole row (all lobes, all channels).
"""

import numpy as np
from scipy import special

# Luminance weights used for the lobe-selection probabilities (docs/cycles.md §4.2, Rec.709 rgb_to_y).
LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])

# sqrt(pi/8), docs/cycles.md §2.4 step 4.
SQRT_PI_OVER_8 = np.sqrt(np.pi / 8.0)

# Melanin absorption coefficients used by Cycles (docs/cycles.md §2.3; NOT pbrt-v3's values).
EUMELANIN_SIGMA = np.array([0.506, 0.841, 1.653])
PHEOMELANIN_SIGMA = np.array([0.343, 0.733, 1.924])

ROUGHNESS_MIN = 0.001
ROUGHNESS_MAX = 1.0

# Number of terms of Cycles' truncated I0 power series (k = 0..9), docs/cycles.md §4.3.
CYCLES_I0_TERMS = 10
# Above this argument Cycles switches log I0 to its asymptotic form, docs/cycles.md §4.3.
CYCLES_LOG_I0_SWITCH = 12.0
# Cycles' rounded ln(2) in the low-variance branch of M_p, docs/cycles.md §4.3.
CYCLES_LN2 = 0.6931


# ---------------------------------------------------------------------------------------------
# Parameter mapping (docs/cycles.md §2)
# ---------------------------------------------------------------------------------------------

def roughness_to_variance(beta):
    """Longitudinal variance v = (0.726 b + 0.812 b^2 + 3.7 b^20)^2 (docs/cycles.md §2.4 step 3). No clamp."""
    beta = np.asarray(beta, dtype=np.float64)
    return (0.726 * beta + 0.812 * beta**2 + 3.7 * beta**20) ** 2


def radial_roughness_to_scale(beta_n):
    """Logistic scale s = (0.265 b + 1.194 b^2 + 5.372 b^22) sqrt(pi/8) (docs/cycles.md §2.4 step 4). No clamp."""
    beta_n = np.asarray(beta_n, dtype=np.float64)
    return (0.265 * beta_n + 1.194 * beta_n**2 + 5.372 * beta_n**22) * SQRT_PI_OVER_8


def albedo_roughness_scale(beta_n):
    """Chiang's P(x) = 5.969 - 0.215x + 2.532x^2 - 10.73x^3 + 5.574x^4 + 0.245x^5 (docs/cycles.md §2.3)."""
    x = np.asarray(beta_n, dtype=np.float64)
    return 5.969 - 0.215 * x + 2.532 * x**2 - 10.73 * x**3 + 5.574 * x**4 + 0.245 * x**5


def absorption_from_color(color, radial_roughness):
    """Direct coloring: sigma = (ln(max(C, 0)) / P(beta_n))^2, square of the whole quotient (docs/cycles.md §2.3).

    A zero (or negative) channel gives ln(0) = -inf and thus sigma = +inf.
    """
    color = np.asarray(color, dtype=np.float64)
    with np.errstate(divide="ignore"):
        log_color = np.log(np.maximum(color, 0.0))
    return (log_color / albedo_roughness_scale(radial_roughness)) ** 2


def absorption_from_melanin(melanin, melanin_redness, tint=(1.0, 1.0, 1.0), radial_roughness=0.3,
                            random=0.0, random_color=0.0):
    """Melanin parametrization (docs/cycles.md §2.3), with Cycles' constants and the Random Color factor."""
    random_color_factor = 1.0 + 2.0 * (random - 0.5) * np.clip(random_color, 0.0, 1.0)
    melanin = melanin * random_color_factor
    melanin = -np.log(np.maximum(1.0 - melanin, 1e-4))
    eumelanin = melanin * (1.0 - melanin_redness)
    pheomelanin = melanin * melanin_redness
    sigma_tint = absorption_from_color(tint, radial_roughness)  # white tint gives 0
    return eumelanin * EUMELANIN_SIGMA + pheomelanin * PHEOMELANIN_SIGMA + sigma_tint


def _rotate_left_u32(value, bits):
    return (value << np.uint32(bits)) | (value >> np.uint32(32 - bits))


def lookup3_final(a, b, c):
    """Bob Jenkins' lookup3 `final` mix of three uint32 arrays; returns the mixed (a, b, c)."""
    with np.errstate(over="ignore"):
        c = (c ^ b) - _rotate_left_u32(b, 14)
        a = (a ^ c) - _rotate_left_u32(c, 11)
        b = (b ^ a) - _rotate_left_u32(a, 25)
        c = (c ^ b) - _rotate_left_u32(b, 16)
        a = (a ^ c) - _rotate_left_u32(c, 4)
        b = (b ^ a) - _rotate_left_u32(a, 14)
        c = (c ^ b) - _rotate_left_u32(b, 24)
    return a, b, c


def cycles_curve_random(index):
    """Blender's per-curve 'Random' attribute: hash_uint2_to_float(index, 0) (docs/cycles.md §2.2).

    lookup3 with a = b = c = 0xdeadbeef + (2 << 2) + 13, a += index, b += 0, then final();
    the result is c / 0xFFFFFFFF (computed here in float64; Cycles divides in float32).
    Returns a float for a scalar index, else an array of the index's shape.
    """
    index_array = np.asarray(index)
    indices = np.atleast_1d(index_array).astype(np.uint64).astype(np.uint32)
    start = np.uint32((0xDEADBEEF + (2 << 2) + 13) & 0xFFFFFFFF)
    with np.errstate(over="ignore"):
        a = np.full(indices.shape, start, dtype=np.uint32) + indices
    b = np.full(indices.shape, start, dtype=np.uint32)
    c = np.full(indices.shape, start, dtype=np.uint32)
    _, _, c = lookup3_final(a, b, c)
    result = c.astype(np.float64) / float(0xFFFFFFFF)
    return float(result[0]) if index_array.ndim == 0 else result.reshape(index_array.shape)


def principled_hair_params(parametrization="color", color=(0.017513, 0.005763, 0.002059),
                           melanin=0.8, melanin_redness=1.0, tint=(1.0, 1.0, 1.0),
                           absorption_coefficient=(0.245531, 0.52, 1.365), roughness=0.3,
                           radial_roughness=0.3, coat=0.0, ior=1.55, offset=0.0349066,
                           random_color=0.0, random_roughness=0.0, random=0.0):
    """Blender node inputs -> Chiang closure parameters (4.2+ SVM path, docs/cycles.md §2.2-2.4).

    Returns a dict: sigma_a (3,), v (longitudinal variance), v_R (coat-reduced variance of the
    R lobe), s (logistic scale incl. sqrt(pi/8)), eta (= ior, unclamped), offset (radians, as given;
    the model functions apply the per-lobe tilt themselves).
    """
    # Random roughness factor, no clamp (docs/cycles.md §2.2).
    roughness_factor = 1.0 + 2.0 * (random - 0.5) * random_roughness
    randomized_roughness = roughness * roughness_factor
    randomized_radial = radial_roughness * roughness_factor

    # Decision: the colour/tint -> sigma conversions use the randomized but UNCLAMPED radial
    # roughness. Reason: docs/cycles.md §2.3 defines beta_N as "the randomized radial roughness", computed
    # in the SVM node (docs/cycles.md §2.2/2.3, svm/closure.h), whereas the [0.001, 1] clamp of docs/cycles.md §2.4
    # happens later, in bsdf_hair_chiang_setup (the closure header), which only sees the
    # roughness values after sigma_a has already been computed.
    if parametrization == "color":
        sigma_a = absorption_from_color(color, randomized_radial)
    elif parametrization == "melanin":
        sigma_a = absorption_from_melanin(melanin, melanin_redness, tint, randomized_radial,
                                          random, random_color)
    elif parametrization == "absorption":
        sigma_a = np.asarray(absorption_coefficient, dtype=np.float64)
    else:
        # Cycles falls back to a fixed pigment concentration here (docs/cycles.md §2.3); we refuse instead.
        raise ValueError(f"unknown parametrization {parametrization!r}")

    # Closure setup (docs/cycles.md §2.4): clamp, coat on the R roughness before mapping, then map.
    beta_m = np.clip(randomized_roughness, ROUGHNESS_MIN, ROUGHNESS_MAX)
    beta_n = np.clip(randomized_radial, ROUGHNESS_MIN, ROUGHNESS_MAX)
    coat_roughness = np.clip((1.0 - np.clip(coat, 0.0, 1.0)) * beta_m, ROUGHNESS_MIN, ROUGHNESS_MAX)
    return {
        "sigma_a": np.broadcast_to(np.asarray(sigma_a, dtype=np.float64), (3,)).copy(),
        "v": roughness_to_variance(beta_m),
        "v_R": roughness_to_variance(coat_roughness),
        "s": radial_roughness_to_scale(beta_n),
        "eta": np.float64(ior),
        "offset": np.float64(offset),
    }


# ---------------------------------------------------------------------------------------------
# Special functions (docs/cycles.md §4.3)
# ---------------------------------------------------------------------------------------------

def bessel_i0_cycles(x):
    """Cycles' truncated I0: sum_{k=0..9} (x^2/4)^k / (k!)^2, stopping once a term no longer changes
    the sum (docs/cycles.md §4.3)."""
    x = np.asarray(x, dtype=np.float64)
    quarter_x2 = 0.25 * x * x
    total = np.ones_like(quarter_x2)
    term = np.ones_like(quarter_x2)
    still_changing = np.ones(quarter_x2.shape, dtype=bool)
    for k in range(1, CYCLES_I0_TERMS):
        term = term * quarter_x2 / (k * k)
        new_total = total + term
        still_changing &= new_total != total
        total = np.where(still_changing, new_total, total)
    return total


def log_bessel_i0_cycles(x):
    """Cycles' log I0: x + (1/(8x) - ln(2 pi) - ln x)/2 for x > 12, else ln of the series (docs/cycles.md §4.3)."""
    x = np.asarray(x, dtype=np.float64)
    large = x > CYCLES_LOG_I0_SWITCH
    safe_large_x = np.where(large, x, 1.0)
    asymptote = safe_large_x + 0.5 * (1.0 / (8.0 * safe_large_x) - np.log(2.0 * np.pi)
                                      - np.log(safe_large_x))
    series = np.log(bessel_i0_cycles(np.where(large, 0.0, x)))
    return np.where(large, asymptote, series)


def _longitudinal_cycles(sin_i, cos_i, sin_o, cos_o, v):
    """M_p exactly as Cycles' longitudinal_scattering (docs/cycles.md §4.3)."""
    a = cos_i * cos_o / v
    b = sin_i * sin_o / v
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        low_v = np.exp(log_bessel_i0_cycles(a) - b - 1.0 / v + CYCLES_LN2 + np.log(1.0 / (2.0 * v)))
        high_v = np.exp(-b) * bessel_i0_cycles(a) / (2.0 * v * np.sinh(1.0 / v))
    return np.where(v <= 0.1, low_v, high_v)


def _longitudinal_exact(sin_i, cos_i, sin_o, cos_o, v):
    """Exact M_p = exp(-b) I0(a) / (2 v sinh(1/v)), evaluated in log space with i0e (d'Eon 2011)."""
    a = cos_i * cos_o / v
    b = sin_i * sin_o / v
    with np.errstate(divide="ignore", invalid="ignore"):
        log_i0 = np.log(special.i0e(a)) + np.abs(a)
        # ln(2 v sinh(1/v)) = ln v + 1/v + ln(1 - exp(-2/v))
        log_norm = np.log(v) + 1.0 / v + np.log(-np.expm1(-2.0 / v))
        return np.exp(log_i0 - b - log_norm)


def longitudinal_scattering(sin_i, cos_i, sin_o, cos_o, v, accuracy="cycles"):
    """Longitudinal term M_p(theta_i, theta_o; v), symmetric in its two angles (docs/cycles.md §4.3)."""
    args = [np.asarray(t, dtype=np.float64) for t in (sin_i, cos_i, sin_o, cos_o, v)]
    if accuracy == "cycles":
        return _longitudinal_cycles(*args)
    if accuracy == "exact":
        return _longitudinal_exact(*args)
    raise ValueError(f"unknown accuracy {accuracy!r}")


def logistic_cdf(x, s):
    """CDF of the logistic with scale s; Cycles returns 0 when -x/s > 88 (docs/cycles.md §4.3)."""
    x = np.asarray(x, dtype=np.float64)
    with np.errstate(over="ignore"):
        cdf = 1.0 / (1.0 + np.exp(-x / s))
    return np.where(-x / s > 88.0, 0.0, cdf)


def trimmed_logistic(x, s):
    """Logistic density e^{-|x|/s} / (s (1 + e^{-|x|/s})^2), normalised on [-pi, pi] by
    1 - 2 CDF(-pi) (docs/cycles.md §4.3)."""
    x = np.asarray(x, dtype=np.float64)
    e = np.exp(-np.abs(x) / s)
    density = e / (s * (1.0 + e) ** 2)
    return density / (1.0 - 2.0 * logistic_cdf(-np.pi, s))


def wrap_angle(angle):
    """Wrap an angle into [-pi, pi)."""
    return np.remainder(angle + np.pi, 2.0 * np.pi) - np.pi


def fresnel_dielectric(cos_i, eta):
    """Exact unpolarised dielectric Fresnel reflectance; 1 under total internal reflection."""
    cos_i = np.abs(np.asarray(cos_i, dtype=np.float64))
    eta = np.asarray(eta, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        cos_t_sq = 1.0 - (1.0 - cos_i * cos_i) / (eta * eta)
        tir = cos_t_sq <= 0.0
        cos_t = np.sqrt(np.where(tir, 1.0, cos_t_sq))
        r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
        r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
        reflectance = 0.5 * (r_perp**2 + r_par**2)
    return np.where(tir, 1.0, reflectance)


# ---------------------------------------------------------------------------------------------
# Geometry helpers (conventions: fibre frame)
# ---------------------------------------------------------------------------------------------

def _direction_angles(w):
    """(sin theta, cos theta, phi) of unit directions w in the fibre frame (conventions)."""
    w = np.asarray(w, dtype=np.float64)
    sin_theta = w[..., 0]
    cos_theta = np.sqrt(w[..., 1] ** 2 + w[..., 2] ** 2)
    phi = np.arctan2(w[..., 2], w[..., 1])
    return sin_theta, cos_theta, phi


def _shift_angle(sin_theta, cos_theta, shift):
    """sin(theta + shift) and |cos(theta + shift)| (cosines taken as |cos|, docs/cycles.md §4.3)."""
    sin_shift, cos_shift = np.sin(shift), np.cos(shift)
    return (sin_theta * cos_shift + cos_theta * sin_shift,
            np.abs(cos_theta * cos_shift - sin_theta * sin_shift))


# Per-lobe tilt multiples of Offset for R, TT, TRT (docs/cycles.md §4.3 and §5b): +2, -1, -4.
TILT_MULTIPLES = (2.0, -1.0, -4.0)


def _row_param(params, key, n_rows):
    return np.broadcast_to(np.asarray(params[key], dtype=np.float64), (n_rows,))


def _prepare(params, wo, wi, h):
    """Everything that depends only on the view direction, h and the parameters (docs/cycles.md §4.2)."""
    wo = np.atleast_2d(np.asarray(wo, dtype=np.float64))
    wi = np.atleast_2d(np.asarray(wi, dtype=np.float64))
    n_rows = max(wo.shape[0], wi.shape[0])
    wo = np.broadcast_to(wo, (n_rows, 3))
    wi = np.broadcast_to(wi, (n_rows, 3))
    h = np.broadcast_to(np.asarray(h, dtype=np.float64), (n_rows,))
    q = {
        "n": n_rows,
        "h": h,
        "eta": _row_param(params, "eta", n_rows),
        "v": _row_param(params, "v", n_rows),
        "v_R": _row_param(params, "v_R" if "v_R" in params else "v", n_rows),
        "s": _row_param(params, "s", n_rows),
        "offset": _row_param(params, "offset", n_rows),
        "sigma_a": np.broadcast_to(np.asarray(params["sigma_a"], dtype=np.float64), (n_rows, 3)),
    }
    q["sin_o"], q["cos_o"], phi_o = _direction_angles(wo)
    q["sin_i"], q["cos_i"], phi_i = _direction_angles(wi)
    q["delta_phi"] = phi_i - phi_o
    return q


def _attenuation(q):
    """A_p for p = 0..3, shape (N, 4, 3), plus gamma_o, gamma_t and the Fresnel factor (docs/cycles.md §4.2)."""
    eta, h, sin_o, cos_o = q["eta"], q["h"], q["sin_o"], q["cos_o"]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        sin_t = sin_o / eta
        cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin_t**2))          # cos_from_sin: safe sqrt
        gamma_o = np.arcsin(np.clip(h, -1.0, 1.0))                  # safe_asin
        # NaN for eta < 1 at grazing view angles (no guard in Cycles, docs/cycles.md §4.2).
        sin_gamma_t = h * cos_o / np.sqrt(eta**2 - sin_o**2)
        cos_gamma_t = np.sqrt(np.maximum(0.0, 1.0 - sin_gamma_t**2))
        # Assumption: gamma_t uses a safe (clamped) asin, like gamma_o; NaN stays NaN.
        gamma_t = np.arcsin(np.clip(sin_gamma_t, -1.0, 1.0))
        path = 2.0 * cos_gamma_t / cos_t
        transmittance = np.exp(-q["sigma_a"] * path[:, None])
        fresnel = fresnel_dielectric(cos_o * np.cos(gamma_o), eta)[:, None]

        a0 = np.broadcast_to(fresnel, transmittance.shape)
        a1 = (1.0 - fresnel) ** 2 * transmittance
        a2 = a1 * transmittance * fresnel
        denominator = 1.0 - transmittance * fresnel
        a3 = np.where(denominator != 0.0, a2 * transmittance * fresnel / np.where(
            denominator != 0.0, denominator, 1.0), 0.0)              # safe divide
    return np.stack([a0, a1, a2, a3], axis=1), gamma_o, gamma_t, fresnel[:, 0]


def chiang_attenuation(params, wo, h):
    """Attenuations A_p, shape (N, 4, 3) for R, TT, TRT, TRRT+ (docs/cycles.md §4.2). Depends on wo only."""
    q = _prepare(params, wo, wo, h)
    return _attenuation(q)[0]


def _lobe_weights(attenuation, fresnel):
    """Lobe-selection probabilities a_p (docs/cycles.md §4.2): a_0 = f, a_p = luminance(A_p), normalised
    by their sum (safe divide: all zero if the sum is 0)."""
    energy = attenuation @ LUMINANCE_WEIGHTS
    energy[:, 0] = fresnel
    total = energy.sum(axis=1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(total != 0.0, energy / np.where(total != 0.0, total, 1.0), 0.0)


def _azimuthal(q, gamma_o, gamma_t):
    """N_p for p = 0..2 (trimmed logistic at wrap(dphi - Phi_p)) and N_3 = 1/(2 pi); shape (N, 4)."""
    lobes = []
    for p in range(3):
        shift = 2.0 * p * gamma_t - 2.0 * gamma_o + p * np.pi
        lobes.append(trimmed_logistic(wrap_angle(q["delta_phi"] - wrap_angle(shift)), q["s"]))
    lobes.append(np.full(q["n"], 1.0 / (2.0 * np.pi)))
    return np.stack(lobes, axis=1)


def _longitudinal(q, accuracy, tilt, r_lobe_variance="v_R"):
    """M_p for p = 0..3, shape (N, 4), with the per-lobe cuticle tilt and variances (docs/cycles.md §2.4 step 5)."""
    variances = (q[r_lobe_variance], q["v"] / 4.0, 4.0 * q["v"])
    lobes = []
    for variance, multiple in zip(variances, TILT_MULTIPLES):
        shift = multiple * q["offset"]
        if tilt == "4.2":      # tilt the view angle (docs/cycles.md §4.3)
            sin_o, cos_o = _shift_angle(q["sin_o"], q["cos_o"], shift)
            sin_i, cos_i = q["sin_i"], q["cos_i"]
        elif tilt == "3.4":    # tilt the light angle (docs/cycles.md §5b)
            sin_i, cos_i = _shift_angle(q["sin_i"], q["cos_i"], shift)
            sin_o, cos_o = q["sin_o"], q["cos_o"]
        else:
            raise ValueError(f"unknown tilt {tilt!r}")
        lobes.append(longitudinal_scattering(sin_i, cos_i, sin_o, cos_o, variance, accuracy))
    # Residual TRRT+: untilted, variance 4v.
    lobes.append(longitudinal_scattering(q["sin_i"], q["cos_i"], q["sin_o"], q["cos_o"],
                                         4.0 * q["v"], accuracy))
    return np.stack(lobes, axis=1)


def _zero_nan_rows(values):
    """Rows where Cycles' formulas give NaN are returned as 0 (module docstring, NaN policy)."""
    flat = values.reshape(values.shape[0], -1)
    bad = np.isnan(flat).any(axis=1)
    values = values.copy()
    values[bad] = 0.0
    return values


# ---------------------------------------------------------------------------------------------
# Public model functions (docs/cycles.md §4)
# ---------------------------------------------------------------------------------------------

def chiang_eval_lobes(params, wo, wi, h, accuracy="cycles", tilt="4.2"):
    """Per-lobe values A_p M_p N_p, shape (N, 4, 3): R, TT, TRT, TRRT+ (docs/cycles.md §4.3).

    Includes the cosine factor (no division by |cos theta_i|; conventions "What eval returns").
    """
    q = _prepare(params, wo, wi, h)
    attenuation, gamma_o, gamma_t, _ = _attenuation(q)
    with np.errstate(invalid="ignore", over="ignore"):
        lobes = attenuation * (_longitudinal(q, accuracy, tilt) * _azimuthal(q, gamma_o, gamma_t))[:, :, None]
    return _zero_nan_rows(lobes)


def chiang_eval(params, wo, wi, h, accuracy="cycles", tilt="4.2"):
    """Cycles' eval (N, 3) = sum over the four lobes (docs/cycles.md §4.3)."""
    return chiang_eval_lobes(params, wo, wi, h, accuracy, tilt).sum(axis=1)


def _mixture_density(params, wo, wi, h, accuracy, tilt, r_lobe_variance):
    q = _prepare(params, wo, wi, h)
    attenuation, gamma_o, gamma_t, fresnel = _attenuation(q)
    with np.errstate(invalid="ignore", over="ignore"):
        weights = _lobe_weights(attenuation, fresnel)
        terms = weights * _longitudinal(q, accuracy, tilt, r_lobe_variance) * _azimuthal(q, gamma_o, gamma_t)
    return _zero_nan_rows(terms).sum(axis=1)


def chiang_pdf(params, wo, wi, h, accuracy="cycles", tilt="4.2"):
    """The pdf Cycles reports (per unit solid angle): sum_p a_p M_p N_p with the same M_p as eval
    (R lobe with v_R) and N_3 = 1/(2 pi) (docs/cycles.md §4.2, §4.3)."""
    return _mixture_density(params, wo, wi, h, accuracy, tilt, "v_R")


def chiang_sampling_density(params, wo, wi, h, tilt="4.2"):
    """TRUE density (per unit solid angle) of directions drawn by Cycles' 4.2+ sampler (docs/cycles.md §4.4).

    The d'Eon sampler draws theta_i exactly from the exact M_p, so M_p uses exact Bessel functions;
    the R lobe is sampled with the un-coated v, not v_R (the "coat quirk"). The clamp of the
    rescaled random number to >= 1e-5 is ignored (it only moves probability 1e-5 within a tail).
    """
    if tilt != "4.2":
        raise NotImplementedError("only the Blender 4.2+ sampler is modelled")
    return _mixture_density(params, wo, wi, h, "exact", tilt, "v")


def raw_params(sigma_a, v, s, eta=1.55, offset=0.0, v_R=None):
    """Build a params dict directly from model quantities (v_R defaults to v, i.e. no coat)."""
    return {"sigma_a": np.asarray(sigma_a, dtype=np.float64), "v": v,
            "v_R": v if v_R is None else v_R, "s": s, "eta": eta, "offset": offset}


def direction_from_angles(theta, phi):
    """Unit direction(s) in the fibre frame from theta (from the normal plane) and phi (conventions)."""
    theta = np.asarray(theta, dtype=np.float64)
    phi = np.asarray(phi, dtype=np.float64)
    return np.stack(np.broadcast_arrays(np.sin(theta), np.cos(theta) * np.cos(phi),
                                        np.cos(theta) * np.sin(phi)), axis=-1)
