"""Scheuermann (ATI) 2004 (docs/models.md §3): eval against the slides' shader formulas, the
normalisation (each colour is its lobe's largest albedo), furnace bound, sampler, fuzzing."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf import testing
from zoo_checks import check_chi2_family, check_fuzz, check_sampling_consistency, max_albedo, unit


def reference(wo, wi, p, norms):
    """ShiftTangent / StrandSpecular of the slides, fibre frame (T = x), N in the plane of T and V."""
    T = np.array([1.0, 0, 0])
    n = wo.copy()
    n[:, 0] = 0
    n /= np.linalg.norm(n, axis=1)[:, None]
    H = wi + wo
    H /= np.linalg.norm(H, axis=1)[:, None]
    out = []
    for k, (col, shift, exp_) in enumerate([(p["primary_color"], p["primary_shift"], p["primary_exponent"]),
                                            (np.asarray(p["secondary_color"]) * p["noise"], p["secondary_shift"],
                                             p["secondary_exponent"])]):
        t1 = T[None, :] + (shift + p["shift_texture"] - 0.5) * n
        t1 /= np.linalg.norm(t1, axis=1)[:, None]
        th = np.sum(t1 * H, axis=1)
        x = np.clip(th + 1, 0, 1)
        dir_atten = x * x * (3 - 2 * x)  # smoothstep(-1, 0, T.H)
        spec = dir_atten * np.sqrt(np.clip(1 - th * th, 0, None)) ** exp_
        out.append(spec[:, None] * np.asarray(col)[None, :] / norms[k])
    return out


def test_defaults_and_errors():
    (d,) = hairbsdf.scheuermann_hair().model_params
    assert d["model"] == "scheuermann" and d["primary_exponent"] == 240 and d["noise"] == 1.0
    for kw, msg in [({"primary_exponent": -1}, r"primary_exponent.*\[0, 10000\]"),
                    ({"secondary_shift": 2}, r"secondary_shift.*\[-1, 1\]"), ({"noise": 1.5}, r"noise.*\[0, 1\]"),
                    ({"shift_texture": -0.1}, r"shift_texture.*\[0, 1\]"),
                    ({"primary_color": 0.8, "secondary_color": 0.5}, "primary_color \\+ secondary_color")]:
        with pytest.raises(ValueError, match=msg):
            hairbsdf.scheuermann_hair(**kw)


@pytest.mark.parametrize("kw", [dict(), dict(primary_color=(0.2, 0.3, 0.4), secondary_color=(0.6, 0.2, 0.1),
                                             primary_exponent=7, secondary_exponent=1500, primary_shift=-0.4,
                                             secondary_shift=0.3, shift_texture=0.8, noise=0.4)])
def test_eval_matches_reference(kw, rng):
    c = hairbsdf.scheuermann_hair(**kw)
    (p,) = c.model_params
    n = 3000
    wo, wi = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1)[:, None]
    wi /= np.linalg.norm(wi, axis=1)[:, None]
    lobes = c.eval_lobes(wo, wi, 0.0)
    r1, r2 = reference(wo, wi, p, p["norms"])
    np.testing.assert_allclose(lobes[:, 0], r1, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(lobes[:, 2], r2, rtol=1e-9, atol=1e-15)
    assert np.all(lobes[:, 1] == 0) and np.all(lobes[:, 3] == 0)


@pytest.mark.parametrize("p,shift", [(0.0, 0.0), (240.0, 0.035), (1000.0, -0.5)])
def test_colour_is_the_largest_albedo(p, shift):
    """The normalisation N(p) is the largest albedo over views: sweeping the view over the fibre's
    latitudes reaches 1 for colour 1 and never exceeds it."""
    c = hairbsdf.scheuermann_hair(primary_color=1.0, secondary_color=0.0, primary_exponent=p, primary_shift=shift)
    views = [unit(t, 30) for t in np.linspace(-88, 88, 23)]
    albedos = [float(c.albedo(wo, 0.0, max_nodes=1_000_000)[0, 0]) for wo in views]
    assert max(albedos) <= 1.0 + 2e-3
    assert max(albedos) >= 0.99


def test_furnace_bound():
    """Defaults and every gain at its maximum (colours summing to 1, noise 1): <= 1.01."""
    for kw in (dict(), dict(primary_color=1.0, secondary_color=0.0), dict(primary_color=0.0, secondary_color=1.0),
               dict(primary_color=0.5, secondary_color=0.5, primary_exponent=0, secondary_exponent=0)):
        assert max_albedo(hairbsdf.scheuermann_hair(**kw), hs=(0.0,)) <= 1.01


def test_sampling_consistency(rng):
    for kw in (dict(), dict(primary_exponent=0, secondary_exponent=10000, noise=0.2),
               dict(primary_shift=1.0, secondary_shift=-1.0, shift_texture=0.0)):
        check_sampling_consistency(hairbsdf.scheuermann_hair(**kw), rng)


def test_sampled_furnace_matches_quadrature():
    c = hairbsdf.scheuermann_hair()
    for wo in (unit(0, 10), unit(-50, 80)):
        est = testing.sampled_furnace(c, wo, 0.0, samples=200_000)
        np.testing.assert_allclose(est, c.albedo(wo, 0.0)[0], rtol=1e-2)


def test_pdf_integrates_to_one():
    for kw in (dict(), dict(primary_exponent=0, secondary_exponent=2000, shift_texture=0.9)):
        c = hairbsdf.scheuermann_hair(**kw)
        for wo in (unit(-35, 20), unit(80, 0), unit(89.9, 0)):
            assert abs(testing.pdf_integral(c, wo, 0.0) - 1.0) < 1e-3


def test_chi2():
    cases = []
    for kw in (dict(), dict(primary_exponent=0, secondary_exponent=1), dict(primary_exponent=2000, noise=0.3,
                                                                            shift_texture=0.9)):
        c = hairbsdf.scheuermann_hair(**kw)
        for wo in (unit(-35, 20), unit(60, 0)):
            cases.append((c, wo, 0.0))
    check_chi2_family(cases, samples=200_000)


def test_fuzz(rng):
    for kw in (dict(), dict(primary_exponent=0, secondary_exponent=10000, primary_shift=1, secondary_shift=-1),
               dict(primary_color=0, secondary_color=0), dict(noise=0.0, shift_texture=1.0)):
        check_fuzz(hairbsdf.scheuermann_hair(**kw), rng, n=5000)
