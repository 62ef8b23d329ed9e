"""Checks shared by the model-zoo tests (test_kajiya_kay.py, test_epic.py, ...): furnace bound,
sampling consistency, chi-square, pdf normalisation and fuzzing, for any closure."""

import numpy as np

from hairbsdf import testing

DEG = np.pi / 180
TINY = 2.0**-24


def unit(theta_deg, phi_deg):
    t, p = theta_deg * DEG, phi_deg * DEG
    return np.array([np.sin(t), np.cos(t) * np.cos(p), np.cos(t) * np.sin(p)])


def fibre_dirs(sin_theta, phi):
    c = np.sqrt(np.clip(1 - sin_theta**2, 0, None))
    return np.stack([sin_theta, c * np.cos(phi), c * np.sin(phi)], axis=-1)


FURNACE_VIEWS = [unit(t, p) for t, p in [(0, 10), (-30, 80), (45, -100), (70, 170), (88, 0), (-89.5, 33)]]


def max_albedo(closure, views=FURNACE_VIEWS, hs=(0.0, 0.6), **kw):
    """Largest channel of the directional albedo over views x h (deterministic quadrature)."""
    out = 0.0
    for wo in views:
        for h in hs:
            out = max(out, float(closure.albedo(wo, h, **kw).max()))
    return out


def check_sampling_consistency(closure, rng, n=20_000, **extra):
    """sample().pdf == pdf(), weight == eval / pdf, value of a lobe > 0 where sampled."""
    wo = rng.normal(size=(n, 3))
    h = rng.uniform(-1, 1, n)
    u = rng.random((n, 3))
    s = closure.sample(wo, h, u, **extra)
    ok = s.lobe >= 0
    assert ok.mean() > 0.99, ok.mean()
    assert np.all(np.isfinite(s.weight)) and np.all(np.isfinite(s.pdf))
    assert np.all(s.weight[~ok] == 0) and np.all(s.pdf[~ok] == 0)
    sub = {k: (v[ok] if np.ndim(v) else v) for k, v in extra.items()}
    ev = closure.eval(wo[ok], s.wi[ok], h[ok], **sub)
    pdf = closure.pdf(wo[ok], s.wi[ok], h[ok], **sub)
    np.testing.assert_allclose(s.pdf[ok], pdf, rtol=1e-9)
    np.testing.assert_allclose(s.weight[ok], ev / pdf[:, None], rtol=1e-9, atol=1e-14)
    return s


def check_chi2_family(make_and_views, samples=300_000, alpha=0.01):
    """make_and_views: list of (closure, wo, h); one Sidak-corrected family."""
    level = testing.sidak_alpha(alpha, len(make_and_views))
    for k, (closure, wo, h) in enumerate(make_and_views):
        r = testing.chi2_test(closure, wo, h, samples=samples, seed=k)
        assert r.passed(level), (k, closure, r)


def check_fuzz(closure, rng, n=20_000, **extra):
    """Random and degenerate directions: eval, pdf, sample finite, eval >= 0, pdf >= 0."""
    wo = rng.normal(size=(n, 3))
    wi = rng.normal(size=(n, 3))
    # degenerate rows: along the fibre, wi = +-wo, exactly perpendicular
    special = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, 0, 1], [1e-300, 1, 0], [1, 1e-300, 0]], float)
    k = len(special)
    wo[:k * k] = np.repeat(special, k, axis=0)
    wi[:k * k] = np.tile(special, (k, 1))
    wi[k * k:2 * k * k] = wo[k * k:2 * k * k]
    wi[2 * k * k:3 * k * k] = -wo[2 * k * k:3 * k * k]
    h = rng.uniform(-1, 1, n)
    h[:50] = 1.0
    h[50:100] = -1.0
    ev = closure.eval_lobes(wo, wi, h, **extra)
    pdf = closure.pdf(wo, wi, h, **extra)
    assert np.all(np.isfinite(ev)) and np.all(ev >= 0)
    assert np.all(np.isfinite(pdf)) and np.all(pdf >= 0)
    u = rng.random((n, 3))
    u[:n // 4] = 0.0
    u[n // 4:n // 2] = 1.0 - TINY
    u[n // 2:n // 2 + 100] = 1.0
    s = closure.sample(wo, h, u, **extra)
    assert np.all(np.isfinite(s.weight)) and np.all(np.isfinite(s.pdf)) and np.all(np.isfinite(s.wi))
    assert np.all(s.weight >= 0) and np.all(s.pdf >= 0)
    ok = s.lobe >= 0
    np.testing.assert_allclose(np.linalg.norm(s.wi[ok], axis=1), 1.0, atol=1e-9)
