"""Huang's `tolerance` (docs/huang.md §4): the default meets 1 % of the row's total against a
converged reference on a few rows, the per-call keyword is validated, and the albedo estimator
agrees with the quadrature. Fast (seconds on 2 cores)."""

import numpy as np
import pytest

import hairbsdf

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
DEG = np.pi / 180


def unit(theta_deg, phi_deg):
    t, p = theta_deg * DEG, phi_deg * DEG
    return np.array([np.sin(t), np.cos(t) * np.cos(p), np.cos(t) * np.sin(p)])


def huang(**kw):
    base = dict(parametrization="absorption", absorption_coefficient=(0.2, 0.5, 1.0), roughness=0.3)
    base.update(kw)
    return hairbsdf.principled_hair(model="huang", **base)


# Rows (theta_o, theta_i, dphi in degrees): R-, TT- and TRT-heavy (TRT + TRRT+ 65 % of the total at
# (10, -15, 60)); near field (3 Simpson nodes at alpha 0.3: a cheap converged reference). Rows that TRT
# dominates (> 90 %) miss 1 % at the default (docs/huang.md §4) and are not among them.
ROWS = [(20, -20, 0), (20, -30, 150), (10, -15, 60), (30, -50, 170), (-15, 25, 120), (-20, 10, 140)]


def test_default_tolerance_meets_one_percent_of_the_total():
    wo = np.array([unit(a, 0) for a, _, _ in ROWS])
    wi = np.array([unit(b, d) for _, b, d in ROWS])
    kw = dict(near_field=True, pixel_coverage=1 / 60)
    reference = huang(trt_points=65536, tolerance=1e-4, max_evaluations=100_000_000).eval(wo, wi, 0.3, **kw)
    ours = huang().eval_lobes(wo, wi, 0.3, **kw)
    ref_l, ours_l = reference @ LUMINANCE, ours.sum(axis=1) @ LUMINANCE
    trt_share = (ours[:, 2:] @ LUMINANCE).sum(axis=1) / ours_l
    assert trt_share.max() > 0.5  # a row that TRT + TRRT+ dominate is among them
    error = np.abs(ours_l - ref_l) / ref_l
    assert np.all(error <= 1e-2), error


def test_tolerance_keyword_is_validated():
    c = huang()
    wo, wi = unit(20, 0), unit(-20, 40)
    for call in (lambda t: c.eval(wo, wi, 0.0, tolerance=t), lambda t: c.eval_lobes(wo, wi, 0.0, tolerance=t),
                 lambda t: c.pdf(wo, wi, 0.0, tolerance=t), lambda t: c.albedo(wo, 0.0, tolerance=t),
                 lambda t: huang(tolerance=t)):
        for bad in (0.0, 1.0, -1e-3, 1e-9):
            with pytest.raises(ValueError, match=r"tolerance=.* is out of range; allowed: \[1e-06, 0.5\]"):
                call(bad)
        with pytest.raises(TypeError, match="tolerance"):
            call("1e-2")
    # pdf (the mixture's, exact) does not depend on it; eval does, within its tolerance.
    assert c.pdf(wo, wi, 0.0, tolerance=0.3) == c.pdf(wo, wi, 0.0)
    loose, default = c.eval(wo, wi, 0.0, tolerance=0.3) @ LUMINANCE, c.eval(wo, wi, 0.0) @ LUMINANCE
    assert loose != default and abs(loose - default) <= 0.3 * default


def test_albedo_estimate_matches_an_independent_estimate(rng):
    """The albedo (default for Huang: Cycles' stochastic eval over the mixture pdf, C++, Sobol' points)
    against the same expectation estimated here with independent random numbers (20 000 samples)."""
    c = huang()
    wo = unit(25, 0)
    estimate = c.albedo(wo, 0.2)[0]
    s = c.sample_directions(wo, 0.2, rng.random((20_000, 3)))
    ok = s.lobe >= 0
    f = c.cycles_estimate(np.broadcast_to(wo, s.wi[ok].shape), s.wi[ok], 0.2, samples=1, seed=11).sum(axis=1)
    w = np.zeros((len(s.pdf), 3))
    w[ok] = f / s.pdf[ok, None]
    mean, error = w.mean(axis=0), w.std(axis=0) / np.sqrt(len(w))
    assert np.all(np.abs(estimate - mean) <= 4 * error + 1e-2 * mean), (estimate, mean, error)


def test_numerical_defaults_are_the_cpp_ones():
    """tolerance, max_evaluations and trt_points: written once, in C++ HuangHairParams (huang.h)."""
    cpp = hairbsdf._core.huang_option_defaults()
    params = huang().model_params[0]
    assert params["tolerance"] == cpp["tolerance"] and params["trt_points"] == cpp["trt_points"]
    assert (cpp["tolerance"], cpp["trt_points"]) == (1e-2, 0)  # the documented defaults (docs/huang.md §4)


@pytest.mark.parametrize("points, error, message", [
    (8, ValueError, r"trt_points=8: must be 0 \(points set by `tolerance`\) or an integer >= 16"),
    (-1, ValueError, r"trt_points=-1: must be in \[0, "),
    (16.0, TypeError, r"trt_points: expected an integer, got 16\.0"),
    (True, TypeError, r"trt_points: expected an integer, got True"),
])
def test_trt_points_rule_is_checked_by_the_core(points, error, message):
    """trt_points is 0 (set by tolerance) or an integer >= 16 (models/huang.h's kMinFixedTrtPoints): the core's
    options check (module.cpp's huang_options) says so, naming the option; Python keeps no copy of the rule."""
    with pytest.raises(error, match=message):
        huang(trt_points=points)
    assert huang(trt_points=16).model_params[0]["trt_points"] == 16 and huang(trt_points=0)
