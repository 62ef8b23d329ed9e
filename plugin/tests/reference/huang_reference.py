"""Independent float64 reference of Blender Cycles 4.5's Principled Hair "Huang" model
(Huang, Hullin, Hanika 2022, "A Microfacet-based Hair Scattering Model").

Written from docs/cycles.md §2.5 and §5 (cited as "docs/cycles.md §x") and the Cycles 4.5
semantics recorded in docs/huang.md; it shares no code with the C++ module (hairbsdf._core),
which it is used to test. Slow and simple on purpose: numpy, float64, vectorised over rows.

Frames (docs/huang.md §1):
  * the public API uses the fibre frame of docs/conventions.md (x = tangent, wo = viewer, wi = light);
  * the model works in Huang's local frame: y = tangent, x = ellipse major axis (for a circular
    cross-section x = normalize(tangent x wo), so that phi(wo) = 0), z = normalize(x x y);
    sin(theta) = w.y, phi = atan2(w.x, w.z). In this frame Cycles' "wi" is our wo (the viewer)
    and Cycles' "wo" is our wi (the light): below, I = wo (view) and O = wi (light).

What is computed:
  * `cycles_estimate(...)`: ONE stochastic evaluation exactly as Cycles 4.5's eval does it
    (composite Simpson over h with steps 0.7 alpha (R) and 0.8 alpha (TT/TRT/TRRT+), one random
    GGX visible-normal sample per node for the residual). Averaging many calls gives Cycles'
    expected value;
  * `expected_eval_lobes(...)`: the expected value by deterministic quadrature: the inner
    microfacet integrals (over the entry and internal half vectors) by tensor Gauss-Legendre in the
    visible-normal sampling space, the h integral either with Cycles' Simpson nodes
    (h_rule="simpson") or converged (h_rule="converged", Gauss-Legendre in gamma);
  * `ggx_glass_albedo(...)` / `energy_tables()`: the GGX glass directional albedo (the energy
    compensation table E_glass), by quadrature over the microfacet normal - a different method from
    the C++ table generator (lab/huang_tables.cpp), so that the two check each other.

NaN policy: rows whose inputs make Cycles' formulas non-finite return 0.
"""

from __future__ import annotations

import os
from functools import lru_cache

import numpy as np

from . import chiang_reference as chiang

ROUGHNESS_MIN = 0.001
H_CLAMP = 0.999              # Cycles clamps the r-normalised integration interval to +-0.999
R_STEP = 0.7                 # Simpson step of the R lobe, in units of alpha
RESIDUAL_STEP = 0.8          # Simpson step of TT / TRT / TRRT+, in units of alpha
TIR_EPSILON = 1e-5           # Cycles' "dot(wo, wt) >= 1/eta - 1e-5" exit test
ROUGHNESS_SQ_SINGULAR = 2e-10  # BSDF_ROUGHNESS_SQ_THRESH: below it the microfacet BSDF is a mirror
TABLE_SIZE = 16


# ---------------------------------------------------------------------------------------------
# Parameters (docs/cycles.md §2.2, §2.3, §2.5)
# ---------------------------------------------------------------------------------------------

def huang_params(parametrization="color", color=(0.017513, 0.005763, 0.002059), melanin=0.8,
                 melanin_redness=1.0, tint=(1.0, 1.0, 1.0), absorption_coefficient=(0.245531, 0.52, 1.365),
                 roughness=0.3, ior=1.55, offset=0.0349066, random_color=0.0, random_roughness=0.0,
                 random=0.0, aspect_ratio=0.85, reflection=1.0, transmission=1.0,
                 secondary_reflection=1.0, radial_roughness=None, coat=None):
    """Node inputs -> Huang closure parameters as Cycles' SVM path maps them.

    Radial Roughness and Coat are ignored (the colour conversion uses the randomized Roughness).
    Returns a dict: sigma_a (3,), alpha (clamped GGX roughness), tilt (= -offset), eta, b (aspect
    ratio after the > 1 swap), factors (R, TT, TRT clamped >= 0).
    """
    factor = 1.0 + 2.0 * (random - 0.5) * random_roughness
    rough = roughness * factor
    if parametrization == "color":
        sigma_a = chiang.absorption_from_color(color, rough)
    elif parametrization == "melanin":
        sigma_a = chiang.absorption_from_melanin(melanin, melanin_redness, tint, rough, random, random_color)
    elif parametrization == "absorption":
        sigma_a = np.asarray(absorption_coefficient, dtype=np.float64)
    else:
        raise ValueError(f"unknown parametrization {parametrization!r}")
    b = float(aspect_ratio)
    if b > 1.0:
        b = 1.0 / b
    return {
        "sigma_a": np.broadcast_to(np.asarray(sigma_a, dtype=np.float64), (3,)).copy(),
        "alpha": float(np.clip(rough, ROUGHNESS_MIN, 1.0)),
        "tilt": -float(offset),
        "eta": float(ior),
        "b": b,
        "factors": (max(reflection, 0.0), max(transmission, 0.0), max(secondary_reflection, 0.0)),
    }


# ---------------------------------------------------------------------------------------------
# Vector helpers (last axis = xyz)
# ---------------------------------------------------------------------------------------------

def _dot(a, b):
    return np.sum(a * b, axis=-1)


def _cross(a, b):
    return np.cross(a, b)


def _normalize(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, v / np.where(n > 0, n, 1.0), 0.0)


def _vec(x, y, z):
    return np.stack(np.broadcast_arrays(x, y, z), axis=-1)


def make_orthonormals(n):
    """Cycles' make_orthonormals(N) -> (a, b): a = normalize((1,1,1) x N) (or (-1,1,1) x N when
    N.x == N.y == N.z), b = N x a."""
    n = np.asarray(n, dtype=np.float64)
    same = (n[..., 0] == n[..., 1]) & (n[..., 0] == n[..., 2])
    a1 = _vec(n[..., 2] - n[..., 1], n[..., 0] - n[..., 2], n[..., 1] - n[..., 0])
    a2 = _vec(n[..., 2] - n[..., 1], n[..., 0] + n[..., 2], -n[..., 1] - n[..., 0])
    a = _normalize(np.where(same[..., None], a2, a1))
    return a, _cross(n, a)


# ---------------------------------------------------------------------------------------------
# Microfacet pieces (GGX, isotropic)
# ---------------------------------------------------------------------------------------------

def ggx_d(alpha2, cos_nh):
    c2 = np.minimum(cos_nh * cos_nh, 1.0)
    return alpha2 / (np.pi * (1.0 - c2 + alpha2 * c2) ** 2)


def ggx_lambda(alpha2, cos_n):
    with np.errstate(divide="ignore"):
        t2 = np.maximum(1.0 / (cos_n * cos_n) - 1.0, 0.0)
    return 0.5 * (np.sqrt(1.0 + alpha2 * t2) - 1.0)


def ggx_g2(alpha2, cos_i, cos_o):
    return 1.0 / (1.0 + ggx_lambda(alpha2, cos_i) + ggx_lambda(alpha2, cos_o))


def ggx_g_over_g1(alpha2, cos_i, cos_o):
    """G2 / G1(i): the shadowing of the exit direction given the entry one."""
    li = ggx_lambda(alpha2, cos_i)
    return (1.0 + li) / (1.0 + li + ggx_lambda(alpha2, cos_o))


def fresnel(cos_i, eta):
    """Unpolarised dielectric Fresnel (1 under total internal reflection) and the cosine of the
    refracted ray relative to the normal (negative; NaN under TIR)."""
    cos_i = np.asarray(cos_i, dtype=np.float64)
    g = eta * eta - (1.0 - cos_i * cos_i)
    tir = g <= 0.0
    c = np.abs(cos_i)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_t = -np.sqrt(np.where(tir, np.nan, g)) / eta
        rs = (c + eta * cos_t) / (c - eta * cos_t)
        rp = (cos_t + eta * c) / (eta * c - cos_t)
        f = 0.5 * (rs * rs + rp * rp)
    return np.where(tir, 1.0, f), cos_t


def refract(incident, normal, cos_t, inv_eta):
    """Refracted direction for an incident direction pointing away from the surface."""
    return (inv_eta * _dot(normal, incident) + cos_t)[..., None] * normal - inv_eta * incident


def reflect(incident, normal):
    return incident - 2.0 * _dot(incident, normal)[..., None] * normal


def microfacet_sample(v, m, alpha, u1, u2, mapping="vndf"):
    """A microfacet normal for the uniform point (u1, u2) of [0,1]^2 and its weight, such that
    E[g(wh) weight] over uniform (u1, u2) is the mean of g under the visible-normal distribution of
    v around m (the distribution Cycles samples). mapping:
      "vndf":  Heitz 2018 with a polar disk (r = sqrt(u1)), weight 1 (what Cycles' sampler does);
      "vndf_linear": the same with r = u1 and weight 2 u1 (smoother at the disk centre);
      "ggx": microfacet normals with D cos flattened (tan^2 = alpha^2 u1 / (1 - u1)), weight =
             G1(v) max(v.wh, 0) / ((v.m) cos theta_h)."""
    if mapping == "vndf":
        return sample_vndf(v, m, alpha, u1, u2), np.ones(np.shape(u1))
    if mapping == "vndf_linear":
        return sample_vndf(v, m, alpha, u1 * u1, u2), 2.0 * u1
    if mapping == "ggx":
        s_, t_ = make_orthonormals(m)
        tan2 = alpha * alpha * u1 / np.maximum(1.0 - u1, 1e-300)
        ct = 1.0 / np.sqrt(1.0 + tan2)
        st = np.sqrt(np.maximum(1.0 - ct * ct, 0.0))
        ang = 2.0 * np.pi * u2
        wh = (st * np.cos(ang))[..., None] * s_ + (st * np.sin(ang))[..., None] * t_ + ct[..., None] * m
        cos_vm = _dot(v, m)
        g1 = 1.0 / (1.0 + ggx_lambda(alpha * alpha, cos_vm))
        with np.errstate(divide="ignore", invalid="ignore"):
            w = np.where(cos_vm > 0, g1 * np.maximum(_dot(v, wh), 0.0) / (cos_vm * ct), 0.0)
        return wh, w
    raise ValueError(mapping)


def sample_vndf(v, m, alpha, u1, u2):
    """GGX visible-normal sample (Heitz 2018) around the unit normal m for the unit direction v.
    u1, u2 in [0, 1); polar disk mapping (the distribution, not the mapping, is what matters)."""
    s, t = make_orthonormals(m)
    vl = _vec(_dot(v, s), _dot(v, t), _dot(v, m))
    vh = _normalize(_vec(alpha * vl[..., 0], alpha * vl[..., 1], vl[..., 2]))
    lensq = vh[..., 0] ** 2 + vh[..., 1] ** 2
    big = lensq > 1e-14
    inv = 1.0 / np.sqrt(np.where(big, lensq, 1.0))
    t1 = np.where(big[..., None], _vec(-vh[..., 1] * inv, vh[..., 0] * inv, 0.0), _vec(1.0, 0.0, 0.0))
    t2 = _cross(vh, t1)
    r = np.sqrt(u1)
    ang = 2.0 * np.pi * u2
    p1 = r * np.cos(ang)
    p2 = r * np.sin(ang)
    w = 0.5 * (1.0 + vh[..., 2])
    p2 = (1.0 - w) * np.sqrt(np.maximum(1.0 - p1 * p1, 0.0)) + w * p2
    p3 = np.sqrt(np.maximum(1.0 - p1 * p1 - p2 * p2, 0.0))
    nh = p1[..., None] * t1 + p2[..., None] * t2 + p3[..., None] * vh
    ne = _normalize(_vec(alpha * nh[..., 0], alpha * nh[..., 1], np.maximum(nh[..., 2], 0.0)))
    return ne[..., 0:1] * s + ne[..., 1:2] * t + ne[..., 2:3] * m


# ---------------------------------------------------------------------------------------------
# E_glass: directional albedo of the GGX glass BSDF (reflection + refraction, single scattering)
# ---------------------------------------------------------------------------------------------

def ggx_glass_albedo(alpha, mu, eta, nodes=64, reject_upward_refraction=False):
    """Albedo of Cycles' GGX glass BSDF as the generator of Cycles 4.5's tables estimated it: E over
    visible normals of F G2/G1 (reflection above the surface) + (1 - F) G2/G1 (refraction, not
    rejected when it leaves above the surface; Cycles 5.x's tables reject it:
    `reject_upward_refraction=True`). Quadrature over
    the microfacet normal in (u, phi), with tan^2 theta_m = alpha^2 u / (1 - u) so that
    D cos theta_m dw = du dphi / (2 pi). Scalars in, scalar out."""
    alpha2 = alpha * alpha
    if alpha2 <= ROUGHNESS_SQ_SINGULAR:
        return 1.0
    x, w = np.polynomial.legendre.leggauss(nodes)
    s = 0.5 * (x + 1.0)
    ws = 0.5 * w
    # u in segments that get finer towards u -> 1 (grazing microfacets, the masking tail).
    edges = np.array([0.0, 0.5, 0.9, 0.99, 0.999, 0.9999, 0.99999, 1.0])
    u = np.concatenate([a + (b - a) * s for a, b in zip(edges[:-1], edges[1:])])
    wu = np.concatenate([(b - a) * ws for a, b in zip(edges[:-1], edges[1:])])
    xp, wp = np.polynomial.legendre.leggauss(8)   # phi: 8-point panels (the integrand has kinks in phi)
    panels = 6 * nodes // 8
    phi = np.concatenate([np.pi * (k + 0.5 * (xp + 1.0)) / panels for k in range(panels)])
    wphi = np.tile(np.pi * 0.5 * wp / panels, panels)
    U, P = np.meshgrid(u, phi, indexing="ij")
    W = np.outer(wu, wphi) * 2.0 / (2.0 * np.pi)
    tan2 = alpha2 * U / (1.0 - U)
    cos_m = 1.0 / np.sqrt(1.0 + tan2)
    sin_m = np.sqrt(np.maximum(1.0 - cos_m * cos_m, 0.0))
    m = _vec(sin_m * np.cos(P), sin_m * np.sin(P), cos_m)
    v = np.array([np.sqrt(max(1.0 - mu * mu, 0.0)), 0.0, mu])
    cos_vm = _dot(m, v)
    ok = cos_vm > 0
    f, cos_t = fresnel(cos_vm, eta)
    wr = 2.0 * cos_vm[..., None] * m - v
    lam_i = ggx_lambda(alpha2, mu)
    with np.errstate(invalid="ignore"):
        wt = refract(v, m, cos_t, 1.0 / eta)
    g_r = 1.0 / (1.0 + lam_i + ggx_lambda(alpha2, wr[..., 2]))
    wt_z = np.nan_to_num(wt[..., 2], nan=1.0)
    if abs(eta - 1.0) < 1e-4:
        g_t = np.full_like(wt_z, 1.0 / (1.0 + lam_i))   # Cycles treats the refraction as specular
    else:
        g_t = 1.0 / (1.0 + lam_i + ggx_lambda(alpha2, wt_z))
    reflected = f * g_r * (wr[..., 2] > 0)
    # Refractions are not rejected when they leave above the surface: Cycles 4.5's shipped table
    # (its eta < 1 half differs at grazing incidence otherwise; docs/huang.md §3).
    refracted = (1.0 - f) * g_t * (f < 1.0)
    if reject_upward_refraction:
        refracted = refracted * (wt_z < 0.0)
    integrand = np.where(ok, cos_vm / (mu * cos_m) * (reflected + refracted), 0.0)
    return float(np.clip(np.sum(integrand * W), 0.0, 1.0))


def table_coordinates(i):
    """Grid value of index i in [0, 15] as Cycles' precompute uses it (before its clamps)."""
    return i / (TABLE_SIZE - 1.0)


def table_eta(zi, inverse):
    t = min(max(table_coordinates(zi), 1e-4), 0.99)
    f0 = t ** 4
    eta = (1.0 + np.sqrt(f0)) / (1.0 - np.sqrt(f0))
    return 1.0 / eta if inverse else eta


@lru_cache(maxsize=None)
def energy_tables(nodes=128):
    """The two 16^3 tables (eta >= 1 and eta < 1), indexed [z][mu][rough] like Cycles'
    lookup_table_read_3D. Cached on disk under build/ (they take a while in numpy)."""
    cache = os.path.join(os.path.dirname(__file__), "..", "..", "..", "build", "huang_reference_tables_%d.npz" % nodes)
    cache = os.path.abspath(cache)
    if os.path.exists(cache):
        d = np.load(cache)
        return d["E"], d["inv_E"]
    tables = []
    for inverse in (False, True):
        t = np.zeros((TABLE_SIZE,) * 3)
        for zi in range(TABLE_SIZE):
            eta = table_eta(zi, inverse)
            for yi in range(TABLE_SIZE):
                mu = min(max(table_coordinates(yi), 1e-4), 1.0)
                for xi in range(TABLE_SIZE):
                    rough = min(max(table_coordinates(xi), 1e-4), 1.0)
                    t[zi, yi, xi] = ggx_glass_albedo(rough * rough, mu, eta, nodes)
        tables.append(t)
    os.makedirs(os.path.dirname(cache), exist_ok=True)
    np.savez(cache, E=tables[0], inv_E=tables[1])
    return tables[0], tables[1]


def _lerp_axis(table, x, axis_size):
    x = np.clip(x, 0.0, 1.0) * (axis_size - 1)
    i = np.minimum(x.astype(int), axis_size - 1)
    j = np.minimum(i + 1, axis_size - 1)
    return i, j, x - i


def lookup_3d(table, x, y, z):
    """Cycles' lookup_table_read_3D: trilinear, coordinates saturated to [0, 1]."""
    xi, xj, xt = _lerp_axis(table, np.asarray(x, dtype=np.float64), TABLE_SIZE)
    yi, yj, yt = _lerp_axis(table, np.asarray(y, dtype=np.float64), TABLE_SIZE)
    zi, zj, zt = _lerp_axis(table, np.asarray(z, dtype=np.float64), TABLE_SIZE)

    def plane(zk):
        row = lambda yk: (1 - xt) * table[zk, yk, xi] + xt * table[zk, yk, xj]
        return (1 - yt) * row(yi) + yt * row(yj)
    return (1 - zt) * plane(zi) + zt * plane(zj)


def energy_scale(rough_sqrt, mu, eta, tables):
    """1 / E_glass(sqrt(alpha), mu, eta): the eta < 1 table is used for eta < 1 (docs/cycles.md §5.3)."""
    eta = np.asarray(eta, dtype=np.float64)
    z = np.sqrt(np.abs((eta - 1.0) / (eta + 1.0)))
    e = np.where(eta < 1.0, lookup_3d(tables[1], rough_sqrt, mu, z), lookup_3d(tables[0], rough_sqrt, mu, z))
    return 1.0 / e


# ---------------------------------------------------------------------------------------------
# Frames and ellipse geometry (docs/cycles.md §5.1)
# ---------------------------------------------------------------------------------------------

def huang_frame(wo, b, normal=None):
    """Huang's local frame (x, y, z) per row, in fibre-frame coordinates (tangent T = +x).

    Circular fibres: x = normalize(T x wo). Elliptical fibres: x = the curve normal made
    orthogonal to T (normalize(T x normalize(N x T))); Cycles' axis swap for b > 1 cancels out
    (docs/huang.md). A zero / parallel normal falls back to make_orthonormals(T): z = a, x = T x a.
    """
    wo = np.atleast_2d(np.asarray(wo, dtype=np.float64))
    n_rows = wo.shape[0]
    t = np.broadcast_to(np.array([1.0, 0.0, 0.0]), (n_rows, 3))
    if b == 1.0 or normal is None:
        x = _normalize(_cross(t, wo)) if b == 1.0 else np.zeros((n_rows, 3))
    else:
        nrm = np.broadcast_to(np.asarray(normal, dtype=np.float64), (n_rows, 3))
        x = _normalize(_cross(t, _normalize(_cross(nrm, t))))
    bad = ~(np.linalg.norm(x, axis=-1) > 0.5)
    za, xa = make_orthonormals(t)           # Cycles: make_orthonormals(Y, &Z, &N)
    z = _normalize(_cross(x, t))
    x = np.where(bad[:, None], xa, x)
    z = np.where(bad[:, None], za, z)
    return x, t, z


def to_local(w, frame):
    x, y, z = frame
    return _vec(_dot(w, x), _dot(w, y), _dot(w, z))


def sin_theta(w):
    return w[..., 1]


def cos_theta(w):
    return np.sqrt(w[..., 0] ** 2 + w[..., 2] ** 2)


def dir_phi(w):
    return np.arctan2(w[..., 0], w[..., 2])


def to_phi(gamma, b):
    return gamma if b == 1.0 else np.arctan2(b * np.sin(gamma), np.cos(gamma))


def to_gamma(phi, b):
    return phi if b == 1.0 else np.arctan2(np.sin(phi), b * np.cos(phi))


def phi_to_h(phi, b, w):
    if b == 1.0:
        return -np.sin(phi)
    g = to_gamma(phi, b)
    c = cos_theta(w)
    return -(w[..., 2] / c) * np.sin(g) + b * (w[..., 0] / c) * np.cos(g)


def h_to_gamma(h_div_r, b, w):
    if b == 1.0:
        return -np.arcsin(h_div_r)
    return np.arctan2(w[..., 2], -b * w[..., 0]) - np.arccos(-h_div_r)


def dgamma_dh(w, gamma, b):
    """|d gamma / d h| (Cycles' d_gamma_d_h, safe divide -> 0)."""
    if b == 1.0:
        d = np.cos(gamma)
    else:
        c = cos_theta(w)
        d = (w[..., 2] / c) * np.cos(gamma) + b * (w[..., 0] / c) * np.sin(gamma)
    with np.errstate(divide="ignore"):
        return np.where(d != 0.0, 1.0 / np.where(d != 0.0, d, 1.0), 0.0)


def to_point(gamma, b):
    return np.stack([np.sin(gamma), b * np.cos(gamma)], axis=-1)


def sphg_dir(theta, gamma, b):
    """Mesonormal with longitudinal tilt theta at ellipse parameter gamma."""
    st, ct = np.sin(theta), np.cos(theta)
    sg, cg = np.sin(gamma), np.cos(gamma)
    if b == 1.0:
        sp, cp = sg, cg
    else:
        norm = np.sqrt(cg * cg + b * b * sg * sg)
        small = np.abs(cg) < 1e-6   # Cycles keeps (sin, cos) of gamma there
        sp = np.where(small, sg, b * sg / norm)
        cp = np.where(small, cg, cg / norm)
    return _vec(sp * ct, np.broadcast_to(st, np.shape(sp)), cp * ct)


def arc_length(e2, gamma):
    return 1.0 if e2 == 0.0 else np.sqrt(1.0 - e2 * np.sin(gamma) ** 2)


def projected_radius(b, wl):
    e2 = 1.0 - b * b
    if e2 == 0.0:
        return np.ones(wl.shape[:-1])
    return np.sqrt(1.0 - e2 * wl[..., 0] ** 2 / (wl[..., 0] ** 2 + wl[..., 2] ** 2))


# ---------------------------------------------------------------------------------------------
# Per-row setup: local directions, integration interval (docs/cycles.md §5.2)
# ---------------------------------------------------------------------------------------------

class Setup:
    """Everything per row that eval needs before integrating over h."""

    def __init__(self, params, wo, wi, h, near_field=False, pixel_coverage=1.0, normal=None, tables=None):
        wo = np.atleast_2d(np.asarray(wo, dtype=np.float64))
        wi = np.atleast_2d(np.asarray(wi, dtype=np.float64))
        n = max(len(wo), len(wi))
        wo = np.broadcast_to(wo, (n, 3))
        wi = np.broadcast_to(wi, (n, 3))
        self.n = n
        self.p = params
        self.b = params["b"]
        self.e2 = 1.0 - self.b ** 2
        self.alpha = params["alpha"]
        self.eta = params["eta"]
        self.tilt = params["tilt"]
        self.tables = tables if tables is not None else energy_tables()
        frame = huang_frame(wo, self.b, normal)
        self.I = to_local(wo, frame)      # Cycles' wi: the viewer
        self.O = to_local(wi, frame)      # Cycles' wo: the light
        h = np.broadcast_to(np.asarray(h, dtype=np.float64), (n,))
        self.r = projected_radius(self.b, self.I)
        self.transparent = np.abs(h) >= self.r
        near = np.broadcast_to(np.asarray(near_field, dtype=bool), (n,)) & (
            self.r > np.broadcast_to(np.asarray(pixel_coverage, dtype=np.float64), (n,)))
        pc = np.broadcast_to(np.asarray(pixel_coverage, dtype=np.float64), (n,))
        tan_tilt = np.tan(self.tilt)
        with np.errstate(divide="ignore", invalid="ignore"):
            tan_o = sin_theta(self.O) / cos_theta(self.O)
            tan_i = sin_theta(self.I) / cos_theta(self.I)
            valid = ~(tan_tilt * tan_o < -1.0)
            half_span = np.arccos(np.maximum(-tan_tilt * tan_i, 0.0))
        valid &= ~np.isnan(half_span)
        half_span = np.nan_to_num(half_span)
        phi_i = np.zeros(n) if self.b == 1.0 else dir_phi(self.I)
        lo = phi_to_h(phi_i + half_span, self.b, self.I)
        hi = phi_to_h(phi_i - half_span, self.b, self.I)
        dh = np.full(n, 2.0)
        near_lo = np.maximum(-self.r, h - pc)
        near_hi = np.minimum(self.r, h + pc)
        dh = np.where(near, (near_hi - near_lo) / self.r, dh)
        lo = np.where(near, np.maximum(lo, near_lo), lo)
        hi = np.where(near, np.minimum(hi, near_hi), hi)
        lo = np.maximum(lo / self.r, -H_CLAMP)
        hi = np.minimum(hi / self.r, H_CLAMP)
        valid &= lo < hi
        valid &= ~self.transparent
        self.valid = valid
        self.h_lo = np.where(valid, lo, 0.0)
        self.h_hi = np.where(valid, hi, 0.0)
        self.dh = dh
        self.near = near
        with np.errstate(divide="ignore", invalid="ignore"):
            self.norm = np.where(valid, 1.0 / (cos_theta(self.I) * dh), 0.0)
        self.wh = _normalize(self.I + self.O)
        self.f_r = fresnel(_dot(self.I, self.wh), self.eta)[0]
        self.sincos_phi_i = None

    def intervals(self, step):
        """Cycles' Simpson node count (even) and node spacing for a step of step * alpha."""
        length = self.h_hi - self.h_lo
        count = 2 * np.ceil(length / (step * self.alpha) * 0.5).astype(int)
        count = np.where(self.valid, np.maximum(count, 0), 0)
        with np.errstate(invalid="ignore", divide="ignore"):
            res = np.where(count > 0, length / np.maximum(count, 1), 0.0)
        return count, res


# ---------------------------------------------------------------------------------------------
# Integrands at given h (rows broadcast against a trailing sample axis K)
# ---------------------------------------------------------------------------------------------

def _row(a):
    return np.asarray(a)[:, None]


def r_integrand(s, h):
    """The R-lobe integrand at h (N, K) including |d gamma/dh|, without Simpson weights and without
    the factor R * F / 4 (applied by the caller)."""
    I = s.I[:, None, :]
    O = s.O[:, None, :]
    wh = s.wh[:, None, :]
    b = s.b
    gamma = h_to_gamma(h, b, I)
    wm = sphg_dir(s.tilt, gamma, b)
    macro = wm * np.array([1.0, 0.0, 1.0])
    vis = (_dot(I, wh) > 0) & (_dot(I, macro) > 0) & (_dot(O, wh) > 0) & (_dot(O, macro) > 0)
    a2 = s.alpha ** 2
    cos_mi = _dot(wm, I)
    val = (dgamma_dh(I, gamma, b) * ggx_d(a2, _dot(wm, wh)) * ggx_g2(a2, cos_mi, _dot(wm, O))
           * arc_length(s.e2, gamma) * energy_scale(np.sqrt(s.alpha), cos_mi, s.eta, s.tables))
    return np.where(vis, val, 0.0)


def residual_integrand(s, h, u1, u2, mapping="vndf"):
    """TT, TRT and TRRT+ sums at h (N, K) for the microfacet samples u1 = (N, K, 2) (entry) and
    u2 (internal reflection), including |d gamma/dh| and the lobe factors, without Simpson
    weights. Returns three arrays (N, K, 3): S_tt, S_trt, S_trrt (the latter before M N 2/pi)."""
    I = s.I[:, None, :]
    O = s.O[:, None, :]
    b = s.b
    alpha = s.alpha
    a2 = alpha * alpha
    ra = np.sqrt(alpha)
    eta = s.eta
    inv_eta = 1.0 / eta
    sigma = np.asarray(s.p["sigma_a"])
    f_r, f_tt, f_trt = s.p["factors"]
    shape = np.broadcast_shapes(np.shape(h), u1.shape[:-1])
    zero = np.zeros(shape + (3,))
    if f_tt <= 0 and f_trt <= 0:
        return zero, zero, zero
    gmi = h_to_gamma(h, b, I)
    wmi = sphg_dir(s.tilt, gmi, b)
    wmi_ = sphg_dir(0.0, gmi, b)
    wh1, mw1 = microfacet_sample(np.broadcast_to(I, wmi.shape), wmi, alpha, u1[..., 0], u1[..., 1], mapping)
    cos_hi1 = _dot(I, wh1)
    ok = cos_hi1 > 0
    cos_mi1 = _dot(I, wmi)
    f1, cos_t1 = fresnel(cos_hi1, eta)
    t1 = 1.0 - f1
    scale1 = energy_scale(ra, cos_mi1, eta, s.tables)
    with np.errstate(invalid="ignore"):
        wt = refract(np.broadcast_to(I, wh1.shape), wh1, cos_t1, inv_eta)
    phi_t = dir_phi(wt)
    gmt = 2.0 * to_phi(phi_t, b) - gmi
    wmt = sphg_dir(-s.tilt, gmt, b)
    wmt_ = sphg_dir(0.0, gmt, b)
    cos_mo1 = _dot(-wt, wmi)
    cos_mi2 = _dot(-wt, wmt)
    g1o = ggx_g_over_g1(a2, cos_mi1, cos_mo1)
    ok &= (_dot(I, wmi) > 0) & (_dot(-wt, wh1) > 0) & (cos_mo1 > 0)
    ok &= (_dot(I, wmi_) > 0) & (_dot(-wt, wmi_) > 0)
    weight = dgamma_dh(I, gmi, b) * mw1
    if b == 1.0:
        path_t = -2.0 * np.cos(gmi - phi_t)
    else:
        path_t = np.linalg.norm(to_point(gmi, b) - to_point(gmt + np.pi, b), axis=-1)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        a_t = np.exp(-sigma * (path_t / cos_theta(wt))[..., None])
    scale2 = energy_scale(ra, cos_mi2, inv_eta, s.tables)

    s_tt = zero.copy()
    if f_tt > 0:
        wh2u = -wt + inv_eta * O
        inv_len = 1.0 / np.linalg.norm(wh2u, axis=-1)
        wh2 = wh2u * inv_len[..., None]
        cos_mh2 = _dot(wmt, wh2)
        tt_ok = ok & (_dot(O, wt) >= inv_eta - TIR_EPSILON) & (cos_mh2 >= 0)
        cos_hi2 = _dot(-wt, wh2)
        cos_ho2 = _dot(-O, wh2)
        cos_mo2 = _dot(-O, wmt)
        t2 = (1.0 - fresnel(cos_hi2, inv_eta)[0]) * scale2
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            scalar = (weight * t1 * scale1 * t2 * ggx_d(a2, cos_mh2) * g1o * ggx_g2(a2, cos_mi2, cos_mo2)
                      / cos_mo1 * cos_mi1 * cos_hi2 * cos_ho2 * inv_len ** 2 * arc_length(s.e2, gmt))
            res = f_tt * scalar[..., None] * a_t
        good = tt_ok[..., None] & np.all(np.isfinite(res), axis=-1, keepdims=True)
        s_tt = np.where(good, res, 0.0)

    s_trt = zero.copy()
    s_trrt = zero.copy()
    if f_trt > 0:
        wh2, mw2 = microfacet_sample(-wt, wmt, alpha, u2[..., 0], u2[..., 1], mapping)
        cos_hi2 = _dot(-wt, wh2)
        ok2 = ok & (cos_hi2 > 0)
        r2 = fresnel(cos_hi2, inv_eta)[0]
        wtr = -reflect(wt, wh2)
        tir = _dot(-wtr, O) < inv_eta - TIR_EPSILON
        vis2 = (_dot(-wt, wmt) > 0) & (_dot(-wtr, wh2) > 0) & (_dot(-wtr, wmt) > 0) & \
               (_dot(-wt, wmt_) > 0) & (_dot(-wtr, wmt_) > 0)
        phi_tr = dir_phi(wtr)
        gmtr = gmi - 2.0 * (to_phi(phi_t, b) - to_phi(phi_tr, b)) + np.pi
        wmtr = sphg_dir(-s.tilt, gmtr, b)
        wmtr_ = sphg_dir(0.0, gmtr, b)
        wh3u = wtr + inv_eta * O
        inv_len3 = 1.0 / np.linalg.norm(wh3u, axis=-1)
        wh3 = wh3u * inv_len3[..., None]
        cos_mh3 = _dot(wmtr, wh3)
        exit_ok = (cos_mh3 >= 0) & (_dot(wtr, wh3) > 0) & (_dot(wtr, wmtr) > 0) & (_dot(-O, wh3) > 0) & \
                  (_dot(-O, wmtr) > 0) & (_dot(wtr, wmtr_) > 0) & (_dot(-O, wmtr_) > 0)
        # TRRT+ geometric series (added on TIR, on a failed exit and after a valid TRT).
        t_avg = np.maximum(1.0 - r2, 1e-5)
        with np.errstate(over="ignore", invalid="ignore"):
            trrt = (t1 * r2 * r2 * t_avg)[..., None] * a_t ** 3 / (1.0 - a_t * (1.0 - t_avg)[..., None])
        add_trrt = ok2 & (tir | (vis2 & ~tir))
        s_trrt = np.where(add_trrt[..., None], (weight * mw2)[..., None] * trrt, 0.0)
        trt_ok = ok2 & ~tir & vis2 & exit_ok
        cos_hi3 = _dot(wh3, wtr)
        cos_ho3 = _dot(wh3, -O)
        cos_mi3 = _dot(wmtr, wtr)
        t3 = (1.0 - fresnel(cos_hi3, inv_eta)[0]) * energy_scale(ra, cos_mi3, inv_eta, s.tables)
        if b == 1.0:
            path_tr = 2.0 * np.abs(np.cos(phi_tr - gmt))
        else:
            path_tr = np.linalg.norm(to_point(gmtr, b) - to_point(gmt, b), axis=-1)
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            a_tr = np.exp(-sigma * (path_tr / cos_theta(wtr))[..., None])
            cos_mo2 = _dot(wmt, -wtr)
            scalar = (weight * mw2 * t1 * scale1 * r2 * scale2 * t3 * ggx_d(a2, cos_mh3) * g1o
                      * ggx_g_over_g1(a2, cos_mi2, cos_mo2) * ggx_g2(a2, cos_mi3, _dot(wmtr, -O))
                      / (cos_mo1 * cos_mo2) * cos_mi1 * cos_mi2 * cos_hi3 * cos_ho3 * inv_len3 ** 2
                      * arc_length(s.e2, gmtr))
            res = f_trt * scalar[..., None] * a_t * a_tr
        good = trt_ok[..., None] & np.all(np.isfinite(res), axis=-1, keepdims=True)
        s_trt = np.where(good, res, 0.0)
        s_trrt = np.where(np.isfinite(s_trrt), s_trrt, 0.0)
    return s_tt, s_trt, s_trrt


def trrt_longitudinal(s):
    """Chiang's M(theta_I, theta_O; v = 4 alpha) with Cycles' truncated Bessel series, times
    1/(2 pi) * 2/pi (the TRRT+ factor of eval_residual)."""
    m = chiang.longitudinal_scattering(sin_theta(s.I), cos_theta(s.I), sin_theta(s.O), cos_theta(s.O),
                                       4.0 * s.alpha, accuracy="cycles")
    return m / (2.0 * np.pi) * (2.0 / np.pi)


# ---------------------------------------------------------------------------------------------
# Quadrature over h
# ---------------------------------------------------------------------------------------------

def _simpson_nodes(s, step, trrt_factor=None):
    """Cycles' composite Simpson nodes h (N, K), weights including 2/3 res (N, K) and a mask.
    End nodes on the edge where the mesonormal turns away from the viewer (tilt-limited interval)
    are moved inside by 1e-9; their TRRT+ counts half (Cycles' float rounding decides; docs/huang.md
    §4): `trrt_factor` (a dict) receives that factor per node."""
    count, res = s.intervals(step)
    k_max = int(count.max()) + 1 if s.n else 1
    k = np.arange(k_max)[None, :]
    h = s.h_lo[:, None] + k * res[:, None]
    first = k == 0
    last = k == count[:, None]
    gam = h_to_gamma(np.clip(h, -1, 1), s.b, s.I[:, None, :])
    edge = (first | last) & ~(_dot(sphg_dir(s.tilt, gam, s.b), s.I[:, None, :]) > 1e-7)
    h = np.where(edge & first, h + 1e-9, np.where(edge & last, h - 1e-9, h))
    if trrt_factor is not None:
        trrt_factor["value"] = np.where(edge, 0.5, 1.0)
    w = np.where((k == 0) | (k == count[:, None]), 0.5, np.where(k % 2 == 1, 2.0, 1.0))
    mask = (k <= count[:, None]) & s.valid[:, None]
    w = np.where(mask, w * (2.0 / 3.0) * res[:, None], 0.0)
    return np.where(mask, h, 0.0), w


@lru_cache(maxsize=None)
def _leggauss(n):
    return np.polynomial.legendre.leggauss(n)


def _converged_nodes(s, nodes):
    """Gauss-Legendre in gamma over the interval: h(gamma) nodes and weights including the
    1 / |d gamma / dh| that cancels the integrand's Jacobian (integrates without the 1/cos
    singularity at the interval ends)."""
    x, w = _leggauss(nodes)
    g_lo = h_to_gamma(s.h_hi, s.b, s.I)    # gamma decreases with h
    g_hi = h_to_gamma(s.h_lo, s.b, s.I)
    g = 0.5 * (g_lo + g_hi)[:, None] + 0.5 * (g_hi - g_lo)[:, None] * x[None, :]
    wg = 0.5 * np.abs(g_hi - g_lo)[:, None] * w[None, :]
    if s.b == 1.0:
        h = -np.sin(g)
    else:
        c = cos_theta(s.I)[:, None]
        h = -(s.I[:, 2][:, None] / c) * np.sin(g) + s.b * (s.I[:, 0][:, None] / c) * np.cos(g)
        h = h / s.r[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        jac = dgamma_dh(s.I[:, None, :], g, s.b)
        # The integrand carries |d gamma / dh| of the un-normalised h while Cycles integrates over
        # h / r, so d(h / r) = d gamma / (r |d gamma / dh|).
        scale = jac * s.r[:, None]
        wh = np.where(jac != 0, wg / np.where(jac != 0, scale, 1.0), 0.0)
    return np.where(s.valid[:, None], h, 0.0), np.where(s.valid[:, None], wh, 0.0)


def _h_rule(s, h_rule, step, nodes):
    if h_rule == "simpson":
        return _simpson_nodes(s, step)
    if h_rule == "converged":
        return _converged_nodes(s, nodes)
    raise ValueError(h_rule)


def _gauss_square(n):
    """Tensor Gauss-Legendre nodes on [0,1]^2: (n*n, 2) points and weights."""
    x, w = np.polynomial.legendre.leggauss(n)
    x = 0.5 * (x + 1.0)
    w = 0.5 * w
    X, Y = np.meshgrid(x, x, indexing="ij")
    return np.stack([X.ravel(), Y.ravel()], axis=-1), np.outer(w, w).ravel()


def eval_lobes_from_setup(s, h_rule="simpson", inner=(16, 8), h_nodes=256, mapping="vndf"):
    """Expected value of Cycles' eval, (N, 4, 3) per lobe (R, TT, TRT, TRRT+), by deterministic
    quadrature: inner = (n1, n2) Gauss-Legendre points per axis of the entry / internal
    visible-normal samples."""
    out = np.zeros((s.n, 4, 3))
    if not np.any(s.valid):
        return out
    f_r = s.p["factors"][0]
    # R lobe.
    h, w = _h_rule(s, h_rule, R_STEP, h_nodes)
    if f_r > 0:
        r = np.sum(w * r_integrand(s, h), axis=1)
        out[:, 0, :] = (f_r * 0.25 * s.f_r * r * s.norm)[:, None]
    # Residual.
    if s.p["factors"][1] <= 0 and s.p["factors"][2] <= 0:
        out[~s.valid] = 0.0
        return np.nan_to_num(out)
    trrt_factor = {"value": None}
    if h_rule == "simpson":
        h, w = _simpson_nodes(s, RESIDUAL_STEP, trrt_factor)
    else:
        h, w = _h_rule(s, h_rule, RESIDUAL_STEP, h_nodes)
    n1, n2 = inner
    p1, w1 = _gauss_square(n1)
    p2, w2 = _gauss_square(n2)
    acc = np.zeros((s.n, 3, 3))
    for k in range(h.shape[1]):
        hk = h[:, k:k + 1]
        if not np.any(w[:, k]):
            continue
        # All (u1, u2) pairs for this node: (N, n1^2 * n2^2)
        u1 = np.broadcast_to(np.repeat(p1, len(p2), axis=0)[None], (s.n, len(p1) * len(p2), 2))
        u2 = np.broadcast_to(np.tile(p2, (len(p1), 1))[None], (s.n, len(p1) * len(p2), 2))
        wu = np.repeat(w1, len(w2)) * np.tile(w2, len(w1))
        tt, trt, trrt = residual_integrand(s, hk, u1, u2, mapping)
        acc[:, 0] += w[:, k, None] * np.einsum("nkc,k->nc", tt, wu)
        acc[:, 1] += w[:, k, None] * np.einsum("nkc,k->nc", trt, wu)
        tf = 1.0 if trrt_factor["value"] is None else trrt_factor["value"][:, k, None]
        acc[:, 2] += tf * w[:, k, None] * np.einsum("nkc,k->nc", trrt, wu)
    inv_eta2 = 1.0 / s.eta ** 2
    out[:, 1] = acc[:, 0] * inv_eta2 * s.norm[:, None]
    out[:, 2] = acc[:, 1] * inv_eta2 * s.norm[:, None]
    out[:, 3] = acc[:, 2] * (trrt_longitudinal(s) * s.norm)[:, None]
    out[~s.valid] = 0.0
    return np.nan_to_num(out)


def cycles_estimate(s, rng, samples=1):
    """Mean of `samples` independent evaluations of Cycles' stochastic eval (R deterministic
    Simpson, one visible-normal sample per Simpson node for the residual), per lobe (N, 4, 3)."""
    out = np.zeros((s.n, 4, 3))
    if not np.any(s.valid):
        return out
    f_r = s.p["factors"][0]
    h, w = _simpson_nodes(s, R_STEP)
    if f_r > 0:
        out[:, 0, :] = (f_r * 0.25 * s.f_r * np.sum(w * r_integrand(s, h), axis=1) * s.norm)[:, None]
    h, w = _simpson_nodes(s, RESIDUAL_STEP)
    acc = np.zeros((s.n, 3, 3))
    for _ in range(samples):
        u1 = rng.random(h.shape + (2,))
        u2 = rng.random(h.shape + (2,))
        tt, trt, trrt = residual_integrand(s, h, u1, u2)
        acc[:, 0] += np.einsum("nk,nkc->nc", w, tt)
        acc[:, 1] += np.einsum("nk,nkc->nc", w, trt)
        acc[:, 2] += np.einsum("nk,nkc->nc", w, trrt)
    acc /= samples
    inv_eta2 = 1.0 / s.eta ** 2
    out[:, 1] = acc[:, 0] * inv_eta2 * s.norm[:, None]
    out[:, 2] = acc[:, 1] * inv_eta2 * s.norm[:, None]
    out[:, 3] = acc[:, 2] * (trrt_longitudinal(s) * s.norm)[:, None]
    out[~s.valid] = 0.0
    return np.nan_to_num(out)
