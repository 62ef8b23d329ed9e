"""Brute-force path tracing through an explicit rough dielectric fibre, the ground truth for the
Huang far-field model (Huang et al. 2022 validate the same way; docs/validation.md §5.I).

The fibre is an infinite cylinder along y with an elliptical cross-section (semi-axes 1 along x, b
along z) in Huang's local frame. Rays arrive from the viewer direction I uniformly over the
projected width, hit the surface, and scatter at every interface with a rough dielectric
microfacet BSDF around the local *mesonormal* (the geometric normal tilted by the cuticle angle:
+tilt at the entry, -tilt inside), GGX visible-normal sampling with Fresnel choice between
reflection and refraction and weight G2/G1, times the energy compensation 1/E_glass(mu) of the
interface (the same single-scattering interface the model assumes). A scattered ray that leaves on
the wrong side of the geometric (macro) surface is dropped. Inside, rays travel along straight
chords to the next surface point, attenuated by exp(-sigma_a l / cos theta). Paths are classified
by their interface events: R (reflect), TT (refract, refract), TRT (refract, reflect, refract).

Vectorised numpy, float64. `trace(...)` returns per lobe the exit directions and weights; the
callers histogram them in (sin theta, phi) against the model's value integrated over the same bins.
"""

from __future__ import annotations

import numpy as np

from . import huang_reference as ref


def _surface_normal(p, b):
    """Outward geometric normal of the ellipse x^2 + (z/b)^2 = 1 at points p (x, z)."""
    n = np.stack([p[..., 0], p[..., 1] / (b * b)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def _mesonormal(n2, tilt):
    """3D mesonormal from a unit 2D normal (x, z) of the cross-section and a longitudinal tilt."""
    return np.stack([n2[..., 0] * np.cos(tilt), np.full(n2.shape[:-1], np.sin(tilt)), n2[..., 1] * np.cos(tilt)],
                    axis=-1)


def _chord_exit(p, d, b):
    """The second intersection of the ray p + t d (2D, inside the ellipse) with its boundary."""
    # ((px + t dx)^2 + (pz + t dz)^2 / b^2 = 1, one root at t = 0 (p on the boundary).
    a = d[..., 0] ** 2 + d[..., 1] ** 2 / (b * b)
    bb = 2.0 * (p[..., 0] * d[..., 0] + p[..., 1] * d[..., 1] / (b * b))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -bb / a
    return p + t[..., None] * d, t


def _scatter(v, m, macro, alpha, eta, u, tables, sqrt_alpha, force=None):
    """One interface event for the incident direction v (pointing away from the surface, on the
    side macro points to), mesonormal m, geometric normal macro (both on v's side), relative IOR
    eta (other side / v's side). Returns (new direction, weight, refracted flag, valid).
    force="reflect" / "refract" takes that branch with the Fresnel probability as a weight instead
    of choosing it at random (splitting: the same expectation, every ray in the wanted lobe)."""
    a2 = alpha * alpha
    h = ref.sample_vndf(v, m, alpha, u[:, 0], u[:, 1])
    cos_vh = ref._dot(v, h)
    f, cos_t = ref.fresnel(cos_vh, eta)
    branch = np.ones_like(f)
    if force is None:
        refract = u[:, 2] >= f
    elif force == "reflect":
        refract, branch = np.zeros(len(f), bool), f
    else:
        refract, branch = np.ones(len(f), bool), 1.0 - f
    with np.errstate(invalid="ignore"):
        wt = ref.refract(v, h, np.nan_to_num(cos_t), 1.0 / eta)
    wr = 2.0 * cos_vh[:, None] * h - v
    out = np.where(refract[:, None], wt, wr)
    cos_vm = ref._dot(v, m)
    g = ref.ggx_g_over_g1(a2, cos_vm, ref._dot(out, m))
    e = ref.energy_scale(sqrt_alpha, cos_vm, eta, tables)
    side = ref._dot(out, macro)
    valid = (cos_vh > 0) & (cos_vm > 0) & (ref._dot(v, macro) > 0) & np.where(refract, side < 0, side > 0)
    valid = valid & (branch > 0)
    return out, np.where(valid, g * e * branch, 0.0), refract, valid


def trace(I, alpha, eta, sigma_a, tilt=0.0, b=1.0, n=1_000_000, rng=None, tables=None, lobe=None):
    """Traces n rays arriving from the unit direction I (local frame, propagation -I) uniformly over
    the projected width. Returns {"R": (dirs, weights), "TT": ..., "TRT": ...} with RGB weights;
    lobe="R" | "TT" | "TRT" forces every interface event onto that lobe's path (Fresnel factors as
    weights) and returns that lobe alone, with all n rays in it (far less noise per ray);
    the weights are normalised so that a histogram density of them estimates the far-field BSDF
    value per unit solid angle times cos theta_I... exactly eval(I, O) in Cycles' convention."""
    rng = rng or np.random.default_rng(0)
    tables = tables if tables is not None else ref.energy_tables()
    sqrt_alpha = np.sqrt(alpha)
    sigma = np.asarray(sigma_a, dtype=np.float64)
    I = np.asarray(I, dtype=np.float64)
    # Hit points: uniform over the projected width of the ellipse seen along -I (2D problem in x, z).
    d2 = -I[[0, 2]] / np.linalg.norm(I[[0, 2]])
    perp = np.array([-d2[1], d2[0]])
    # Projected half-width of the ellipse along perp: support function sqrt(px^2 + b^2 pz^2).
    half = np.sqrt(perp[0] ** 2 + (b * perp[1]) ** 2)
    s = (rng.random(n) * 2.0 - 1.0) * half
    # Entry point: the first intersection of the line s perp + t d2 with the ellipse.
    o = s[:, None] * perp[None, :] - 3.0 * d2[None, :]
    a = d2[0] ** 2 + d2[1] ** 2 / b ** 2
    bq = 2.0 * (o[:, 0] * d2[0] + o[:, 1] * d2[1] / b ** 2)
    c = o[:, 0] ** 2 + o[:, 1] ** 2 / b ** 2 - 1.0
    disc = np.maximum(bq * bq - 4 * a * c, 0.0)
    t = (-bq - np.sqrt(disc)) / (2 * a)
    p = o + t[:, None] * d2[None, :]
    out = {}
    v = np.broadcast_to(I, (n, 3)).copy()
    n2 = _surface_normal(p, b)
    macro = np.stack([n2[:, 0], np.zeros(n), n2[:, 1]], axis=-1)
    m = _mesonormal(n2, tilt)
    u = rng.random((n, 3))
    events = {"R": ("reflect",), "TT": ("refract", "refract"), "TRT": ("refract", "reflect", "refract")}
    plan = events[lobe] if lobe is not None else (None, None, None)
    d, w, refr, ok = _scatter(v, m, macro, alpha, eta, u, tables, sqrt_alpha, force=plan[0])
    out["R"] = (d[ok & ~refr], np.repeat(w[ok & ~refr, None], 3, axis=1))
    if lobe == "R":
        return out, n
    keep = ok & refr
    d, w, p = d[keep], np.repeat(w[keep, None], 3, axis=1), p[keep]
    tt, trt = [], []
    for bounce in range(2):
        # Travel inside to the next boundary point.
        d2i = d[:, [0, 2]]
        len2 = np.linalg.norm(d2i, axis=1)
        q, tt_ = _chord_exit(p, d2i / len2[:, None], b)
        chord = tt_  # 2D length
        cos_theta = len2
        w = w * np.exp(-sigma[None, :] * (chord / cos_theta)[:, None])
        p = q
        n2 = _surface_normal(p, b)
        inward = -np.stack([n2[:, 0], np.zeros(len(p)), n2[:, 1]], axis=-1)
        m = _mesonormal(-n2, -tilt)
        u = rng.random((len(p), 3))
        force = plan[bounce + 1] if bounce + 1 < len(plan) else "refract"
        dn, wn, refr, ok = _scatter(-d, m, inward, alpha, 1.0 / eta, u, tables, sqrt_alpha, force=force)
        # Refracting out: TT after the first internal event, TRT after the second.
        leave = ok & refr
        (tt if bounce == 0 else trt).append((dn[leave], w[leave] * wn[leave, None]))
        stay = ok & ~refr
        d, w, p = dn[stay], w[stay] * wn[stay, None], p[stay]
    out["TT"] = tt[0]
    out["TRT"] = trt[0]
    if lobe is not None:
        return {lobe: out[lobe]}, n
    # Weights: each ray carries the projected width 2 half (far field: the BSDF averages over the
    # width, Cycles divides by cos theta_I dh with dh = 2 in r-normalised units); the histogram
    # density per unit solid angle of the mean weight is eval(I, O).
    return out, n
