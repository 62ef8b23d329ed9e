"""Cycles' legacy Hair BSDF (docs/models.md §6): eval against a float64 reference written from the
formulas in angles, Cycles' reported sampling pdf, chi-square of both samplers against their exact
densities, furnace bound, fuzzing, defaults and errors. The check against Cycles' own pixels is
blender_tests/test_bsdf_check.py::test_cycles_hair_bsdf_matches_cycles."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf import testing
from zoo_checks import check_fuzz, max_albedo, unit

GUARD = 0.001  # Cycles gives no value within 0.001 rad of the fibre axis


def angles(wo, wi, h):
    """theta_r (viewer), theta_i (light), the azimuth difference phi in (-pi, pi], gamma = asin h."""
    wo = np.atleast_2d(wo) / np.linalg.norm(np.atleast_2d(wo), axis=1)[:, None]
    wi = np.atleast_2d(wi) / np.linalg.norm(np.atleast_2d(wi), axis=1)[:, None]
    theta_r = np.arcsin(np.clip(wo[:, 0], -1, 1))
    theta_i = np.arcsin(np.clip(wi[:, 0], -1, 1))
    phi = np.angle(np.exp(1j * (np.arctan2(wi[:, 2], wi[:, 1]) - np.arctan2(wo[:, 2], wo[:, 1]))))
    return theta_r, theta_i, phi, np.arcsin(np.clip(h, -1, 1))


def theta_density(theta_r, theta_i, r1, offset):
    """Cauchy of scale r1 in theta_h - o (o = -offset, Cycles' stored value), truncated to
    theta_i in [-pi/2, pi/2], per unit solid angle."""
    o = -offset
    a = np.arctan(((np.pi / 2 + theta_r) / 2 - o) / r1)
    b = np.arctan(((-np.pi / 2 + theta_r) / 2 - o) / r1)
    t = (theta_i + theta_r) / 2 - o
    return r1 / (2 * (t * t + r1 * r1) * (a - b) * np.cos(theta_i))


def clamp_r(r):
    return min(max(r, 0.001), 1.0)


def reference_eval_pdf(wo, wi, h, component, ru, rv, offset):
    """Cycles' eval divided by the colour. The shading normal of a tube seen from wo at offset h
    has azimuth phi_o - asin(h); reflection needs wi on its side and cos(phi) >= 0."""
    r1, r2 = clamp_r(ru), clamp_r(rv)
    theta_r, theta_i, phi, gamma = angles(wo, wi, h)
    n_side = np.cos(phi + gamma) >= 0
    ok = np.pi / 2 - np.abs(theta_i) >= GUARD
    if component == "reflection":
        stretched = np.minimum(np.abs(phi) / r2, np.pi)
        p_phi = np.where(n_side & (np.cos(phi) >= 0), np.cos(stretched / 2) / (4 * r2), 0.0)
    else:
        c = 2 * np.arctan(np.pi / (2 * r2))
        p = np.pi - np.abs(phi)
        p_phi = np.where(~n_side, r2 / (c * (p * p + r2 * r2)), 0.0)
    return np.where(ok, p_phi * theta_density(theta_r, theta_i, r1, offset), 0.0)


def sampler_density(wo, wi, component, ru, rv, offset):
    """The exact density of Cycles' sampler: reflection phi = 2 r2 asin(1 - 2u), transmission
    phi = pi + r2 tan(c (u - 1/2)); theta_h - o = r1 tan(B + u (A - B))."""
    r1, r2 = clamp_r(ru), clamp_r(rv)
    theta_r, theta_i, phi, _ = angles(wo, wi, 0.0)
    a = np.abs(phi)
    if component == "reflection":
        p_phi = np.where(a <= np.pi * r2, np.cos(np.minimum(a / r2, np.pi) / 2) / (4 * r2), 0.0)
    else:
        c = 2 * np.arctan(np.pi / (2 * r2))
        p_phi = np.where(a >= np.pi / 2, r2 / (c * ((np.pi - a) ** 2 + r2 * r2)), 0.0)
    ok = np.pi / 2 - np.abs(theta_i) >= GUARD
    return np.where(ok, p_phi * theta_density(theta_r, theta_i, r1, offset), 0.0)


def reported_sample_pdf(wo, wi, component, ru, rv, offset):
    """What Cycles' sampler reports: for reflection cos(phi / 2) / (4 r2) (no 1 / r2 inside)."""
    if component == "transmission":
        return sampler_density(wo, wi, component, ru, rv, offset)
    r1, r2 = clamp_r(ru), clamp_r(rv)
    theta_r, theta_i, phi, _ = angles(wo, wi, 0.0)
    return np.cos(phi / 2) / (4 * r2) * theta_density(theta_r, theta_i, r1, offset)


CASES = [  # (component, roughness_u, roughness_v, offset)
    ("reflection", 0.1, 1.0, 0.0),
    ("reflection", 0.3, 0.4, 0.2),
    ("reflection", 0.05, 0.1, -0.4),
    ("transmission", 0.1, 1.0, 0.0),
    ("transmission", 0.25, 0.3, -0.3),
    ("transmission", 0.6, 0.05, 0.5),
]


def test_defaults_and_errors():
    c = hairbsdf.cycles_hair_bsdf()
    (d,) = c.model_params
    assert d["model"] == "cycles_hair" and d["component"] == "reflection"
    assert d["color"] == [0.8] * 3 and d["offset"] == 0.0 and d["roughness_u"] == 0.1 and d["roughness_v"] == 1.0
    assert hairbsdf.cycles_hair_bsdf(component="TRANSMISSION").model_params[0]["component"] == "transmission"
    assert hairbsdf.cycles_hair_bsdf(roughness_u=0.0).model_params[0]["r1"] == 0.001  # Cycles' clamp
    with pytest.raises(ValueError, match=r"component.*reflection.*transmission"):
        hairbsdf.cycles_hair_bsdf(component="TT")
    with pytest.raises(ValueError, match=r"roughness_u.*\[0, 1\]"):
        hairbsdf.cycles_hair_bsdf(roughness_u=1.5)
    with pytest.raises(ValueError, match=r"roughness_v.*\[0, 1\]"):
        hairbsdf.cycles_hair_bsdf(roughness_v=-0.1)
    with pytest.raises(ValueError, match=r"offset.*\[-1.5708, 1.5708\]"):
        hairbsdf.cycles_hair_bsdf(offset=2.0)
    with pytest.raises(ValueError, match="color"):
        hairbsdf.cycles_hair_bsdf(color=(0.1, -0.2, 0.3))
    with pytest.raises(TypeError):
        hairbsdf.cycles_hair_bsdf(roughness=0.2)


@pytest.mark.parametrize("component,ru,rv,offset", CASES)
def test_eval_matches_reference(component, ru, rv, offset, rng):
    color = (0.9, 0.5, 0.2)
    c = hairbsdf.cycles_hair_bsdf(component=component, color=color, roughness_u=ru, roughness_v=rv, offset=offset)
    n = 4000
    wo = rng.normal(size=(n, 3))
    wi = rng.normal(size=(n, 3))
    h = rng.uniform(-1, 1, n)
    ref = reference_eval_pdf(wo, wi, h, component, ru, rv, offset)
    lobes = c.eval_lobes(wo, wi, h)
    slot = 0 if component == "reflection" else 1
    np.testing.assert_allclose(lobes[:, slot], ref[:, None] * np.asarray(color), rtol=1e-9, atol=1e-14)
    assert np.all(np.delete(lobes, slot, axis=1) == 0)
    np.testing.assert_allclose(c.pdf(wo, wi, h), ref, rtol=1e-9, atol=1e-14)
    assert (ref > 0).mean() > 0.2


def test_offset_moves_the_peak_as_cycles_does():
    """Cycles stores minus the node's Offset: the lobe peaks at theta_i = -theta_o - 2 Offset."""
    theta_i = np.linspace(-1.5, 1.5, 30001)
    for component, phi in (("reflection", -90.0), ("transmission", 90.0)):
        for offset in (-0.3, 0.0, 0.25):
            c = hairbsdf.cycles_hair_bsdf(component=component, roughness_u=0.05, offset=offset)
            wo = unit(20, -90)
            wi = np.stack([np.sin(theta_i), np.cos(theta_i) * np.cos(np.radians(phi)),
                           np.cos(theta_i) * np.sin(np.radians(phi))], axis=1)
            peak = theta_i[np.argmax(c.pdf(wo, wi, 0.0) * np.cos(theta_i))]
            assert abs(peak - (-np.radians(20) - 2 * offset)) < 2e-3, (component, offset, peak)


@pytest.mark.parametrize("component,ru,rv,offset", CASES)
def test_sample_reports_cycles_pdf_and_weight_is_the_color(component, ru, rv, offset, rng):
    color = (0.3, 0.6, 0.9)
    c = hairbsdf.cycles_hair_bsdf(component=component, color=color, roughness_u=ru, roughness_v=rv, offset=offset)
    n = 20_000
    wo = rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1)[:, None]
    h = rng.uniform(-1, 1, n)
    s = c.sample(wo, h, rng.random((n, 3)))
    ok = s.lobe >= 0
    assert ok.mean() > 0.99
    assert np.all(s.lobe[ok] == (0 if component == "reflection" else 1))
    np.testing.assert_allclose(s.weight[ok], np.tile(color, (ok.sum(), 1)), rtol=1e-12)
    np.testing.assert_allclose(s.pdf[ok], reported_sample_pdf(wo[ok], s.wi[ok], component, ru, rv, offset),
                               rtol=1e-9, atol=1e-12)
    # Where eval has value, eval / pdf is the colour too (weight = eval / pdf), and eval's pdf
    # is the sample's wherever Cycles' reported density is exact.
    ev, pdf = c.eval(wo[ok], s.wi[ok], h[ok]), c.pdf(wo[ok], s.wi[ok], h[ok])
    inside = pdf > 0
    assert inside.mean() > 0.3
    np.testing.assert_allclose(ev[inside] / pdf[inside, None], np.tile(color, (inside.sum(), 1)), rtol=1e-12)
    if component == "transmission" or rv == 1.0:
        np.testing.assert_allclose(pdf[inside], s.pdf[ok][inside], rtol=1e-9)


def chi2_exact_cells(closure, wo, component, ru, rv, offset, samples=200_000, bins=64, seed=0):
    """Pearson chi-square of the sampled (theta_i, phi) against cell probabilities from the exact
    CDFs of the sampler's two independent factors. Cells are uniform in theta (the density per
    solid angle has a 1 / cos theta pole at the axis that Gauss-Legendre cells in sin theta, as
    in hairbsdf.testing.chi2_test, cannot integrate; in theta it is a plain truncated Cauchy)."""
    from scipy.special import gammaincc
    r1, r2 = clamp_r(ru), clamp_r(rv)
    rng = np.random.default_rng(seed)
    s = closure.sample(wo, 0.0, rng.random((samples, 3)))
    ok = s.lobe >= 0
    theta_r, theta_i, phi, _ = angles(np.broadcast_to(wo, s.wi[ok].shape), s.wi[ok], 0.0)
    o = -offset
    a = np.arctan(((np.pi / 2 + theta_r[0]) / 2 - o) / r1)
    b = np.arctan(((-np.pi / 2 + theta_r[0]) / 2 - o) / r1)
    t_edges = np.linspace(-np.pi / 2 + GUARD, np.pi / 2 - GUARD, bins + 1)  # no samples within the guard
    p_edges = np.linspace(-np.pi, np.pi, bins + 1)
    cdf_theta = (np.arctan(((t_edges + theta_r[0]) / 2 - o) / r1) - b) / (a - b)
    if component == "reflection":  # phi = 2 r2 asin(1 - 2u): P(phi < x) = (1 + sin(x / (2 r2))) / 2
        x = np.clip(p_edges / (2 * r2), -np.pi / 2, np.pi / 2)
        cdf_phi = (1 + np.sin(x)) / 2
    else:  # phi = pi + r2 tan(C (u - 1/2)) wrapped to (-pi, pi]: mass on |phi| >= pi/2
        c = 2 * np.arctan(np.pi / (2 * r2))
        neg = np.clip(p_edges + np.pi, 0, np.pi / 2)    # phi in [-pi, -pi/2]: p = phi + pi in [0, pi/2]
        pos = np.clip(p_edges - np.pi, -np.pi / 2, 0)   # phi in [pi/2, pi]: p = phi - pi in [-pi/2, 0]
        cdf_phi = (np.arctan(neg / r2) + np.arctan(pos / r2) + np.arctan(np.pi / (2 * r2))) / c
    expected = np.outer(np.diff(cdf_theta), np.diff(cdf_phi)).ravel() * samples
    ti = np.clip(np.searchsorted(t_edges, theta_i) - 1, 0, bins - 1)
    pj = np.clip(np.searchsorted(p_edges, phi) - 1, 0, bins - 1)
    observed = np.bincount(ti * bins + pj, minlength=bins * bins).astype(float)
    assert not np.any(observed[expected <= 0] > 0), "samples where the density is 0"
    order = np.argsort(expected)
    e, obs = expected[order], observed[order]
    keep = e >= 5
    e_list, o_list = np.append(e[keep], e[~keep].sum()), np.append(obs[keep], obs[~keep].sum())
    e_list = np.append(e_list, max(samples - expected.sum(), 1e-300))  # samples lost to the axis guard
    o_list = np.append(o_list, samples - ok.sum())
    stat = float(np.sum((o_list - e_list) ** 2 / e_list))
    return float(gammaincc((len(e_list) - 1) / 2, stat / 2))


def test_chi2_both_samplers():
    """Directions of both samplers against their exact distributions (one Sidak family)."""
    cases = [(component, ru, rv, offset, wo) for component, ru, rv, offset in CASES
             for wo in (unit(-35, 20), unit(60, 0))]
    level = testing.sidak_alpha(0.01, len(cases))
    for k, (component, ru, rv, offset, wo) in enumerate(cases):
        c = hairbsdf.cycles_hair_bsdf(component=component, roughness_u=ru, roughness_v=rv, offset=offset)
        p = chi2_exact_cells(c, wo, component, ru, rv, offset, seed=k)
        assert p > level, (k, component, ru, rv, offset, p)


def test_chi2_rejects_a_wrong_distribution():
    """The chi-square above can fail: samples drawn with r2 = 0.4 are rejected against the
    distribution of r2 = 0.6."""
    c = hairbsdf.cycles_hair_bsdf(component="reflection", roughness_u=0.3, roughness_v=0.4)
    p = chi2_exact_cells(c, unit(-35, 20), "reflection", 0.3, 0.6, 0.0, seed=99)
    assert p < 1e-6


def test_exact_sampler_density_is_normalised():
    """Midpoint rule in (theta, phi) with d omega = cos theta d theta d phi (smooth in theta)."""
    n = 800
    dt, dp = np.pi / n, 2 * np.pi / n
    t = -np.pi / 2 + dt * (np.arange(n) + 0.5)
    p = -np.pi + dp * (np.arange(n) + 0.5)
    T, P = np.meshgrid(t, p, indexing="ij")
    wi = np.stack([np.sin(T), np.cos(T) * np.cos(P), np.cos(T) * np.sin(P)], axis=-1).reshape(-1, 3)
    for component, ru, rv, offset in CASES:
        density = sampler_density(np.broadcast_to(unit(25, 40), wi.shape), wi, component, ru, rv, offset)
        total = (density * np.cos(T).ravel()).sum() * dt * dp
        assert abs(total - 1) < 3e-3, (component, ru, rv, offset, total)


def test_albedo_closed_forms():
    """h = 0: the normal is the viewer's perpendicular. Reflection r2 = 1 keeps the bump's
    |phi| <= pi/2 part: sin(pi/4); r2 <= 1/2 keeps all of it: 1. Transmission lives on the far
    half: 1. (The longitudinal Cauchy loses only the 0.001 rad guard at the axis.)"""
    for component, rv, expected in (("reflection", 1.0, np.sin(np.pi / 4)), ("reflection", 0.5, 1.0),
                                    ("transmission", 1.0, 1.0), ("transmission", 0.2, 1.0)):
        c = hairbsdf.cycles_hair_bsdf(component=component, color=1.0, roughness_u=0.3, roughness_v=rv)
        for wo in (unit(0, -90), unit(-50, 30)):
            assert abs(c.albedo(wo, 0.0)[0, 0] - expected) < 3e-3, (component, rv)


@pytest.mark.parametrize("component", ["reflection", "transmission"])
def test_furnace_bound(component):
    """White colour, defaults and the roughness / offset extremes: albedo <= 1.01."""
    assert max_albedo(hairbsdf.cycles_hair_bsdf(component=component, color=1.0)) <= 1.01
    for ru, rv, offset in ((0.01, 0.001, 0.0), (1.0, 1.0, np.pi / 2), (1.0, 0.001, -np.pi / 2),
                           (0.01, 1.0, np.pi / 2)):
        c = hairbsdf.cycles_hair_bsdf(component=component, color=1.0, roughness_u=ru, roughness_v=rv, offset=offset)
        assert max_albedo(c, views=[unit(0, 10), unit(45, -100), unit(-89.5, 33)]) <= 1.01, (ru, rv, offset)


def test_fuzz(rng):
    for component in ("reflection", "transmission"):
        for ru, rv, offset in ((0.0, 0.0, 0.0), (1.0, 1.0, np.pi / 2), (0.1, 1.0, -np.pi / 2), (1e-9, 0.5, 0.3)):
            c = hairbsdf.cycles_hair_bsdf(component=component, roughness_u=ru, roughness_v=rv, offset=offset)
            check_fuzz(c, rng, n=5000)
