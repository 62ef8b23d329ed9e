"""Epic / Unreal 2016 (Karis's course notes; docs/models.md §2): formulas against an independent
reference, energy, the environment variant, the multiple-scattering fake with `shadow`, sampler,
fuzzing."""

import inspect

import numpy as np
import pytest

import hairbsdf
from hairbsdf import testing
from zoo_checks import (FURNACE_VIEWS, check_chi2_family, check_fuzz, check_sampling_consistency, fibre_dirs,
                        max_albedo, unit)

ETA = 1.55


def schlick(x):
    f0 = ((1 - ETA) / (1 + ETA)) ** 2
    return f0 + (1 - f0) * (1 - np.clip(x, 0, 1)) ** 5


def gauss(b, x):
    return np.exp(-0.5 * (x / b) ** 2) / (b * np.sqrt(2 * np.pi))


def reference(wo, wi, C, specular=0.5, scatter=0.0, roughness=0.35, shift=0.035, env=False, shadow=1.0):
    """Per-lobe values written from seed 002's restatement of the course notes (vectorised)."""
    C = np.asarray(C, float)
    si, so = wi[:, 0], wo[:, 0]
    ti, to = np.arcsin(si), np.arcsin(so)
    cd = np.maximum(np.cos(0.5 * (to - ti)), 1e-6)
    pi_ = np.arctan2(wi[:, 2], wi[:, 1]) - np.arctan2(wo[:, 2], wo[:, 1])
    cphi = np.cos(pi_)
    chalf = np.sqrt(np.clip(0.5 + 0.5 * cphi, 0, 1))
    vdl = np.sum(wi * wo, axis=1)
    r2 = roughness**2
    extra = 0.2 if env else 0.0
    b = [max(r2 + extra, 1e-3), max(r2 / 2 + extra, 1e-3), max(2 * r2 + extra, 1e-3)]
    a = [-2 * shift, shift, 4 * shift]
    x = si + so
    R = gauss(b[0], x - a[0]) * 0.25 * chalf * schlick(np.sqrt(np.clip(0.5 + 0.5 * vdl, 0, 1))) * specular / 0.5
    if env:
        R = R * np.clip(vdl + 1, 0, 1)
    ep = 1.19 / cd + 0.36 * cd
    ainv = 1 / ep
    h = (1 + ainv * (0.6 - 0.8 * cphi)) * chalf
    f = schlick(cd * np.sqrt(np.clip(1 - h * h, 0, None)))
    T = C[None, :] ** (np.sqrt(np.clip(1 - (h * ainv) ** 2, 0, None)) / (2 * cd))[:, None]
    TT = (gauss(b[1], x - a[1]) * np.exp(-3.65 * cphi - 3.98) * (1 - f) ** 2)[:, None] * T
    if env:
        TT = TT * 0
    f = schlick(0.5 * cd)
    T = C[None, :] ** (0.8 / cd)[:, None]
    TRT = (gauss(b[2], x - a[2]) * np.exp(17 * cphi - 16.78) * (1 - f) ** 2 * f)[:, None] * T
    n = wo.copy()
    n[:, 0] = 0
    n /= np.linalg.norm(n, axis=1)[:, None]
    luma = 0.2126 * C[0] + 0.7152 * C[1] + 0.0722 * C[2]
    MS = scatter * np.sqrt(C)[None, :] * ((np.sum(n * wi, axis=1) + 1) / (4 * np.pi))[:, None] * (C / luma) ** (1 - shadow)
    return np.stack([np.repeat(R[:, None], 3, 1), TT, TRT, MS], axis=1)


def test_defaults_and_errors():
    (d,) = hairbsdf.epic_hair().model_params
    assert d["model"] == "epic" and d["variant"] == "direct" and d["energy"] == "bounded"
    np.testing.assert_allclose(d["betas"], [0.35**2, 0.35**2 / 2, 2 * 0.35**2])
    for kw, msg in [({"specular": 1.5}, r"specular.*\[0, 1\]"), ({"roughness": -0.1}, r"roughness.*\[0, 1\]"),
                    ({"shift": 0.3}, r"shift.*\[-0.25, 0.25\]"), ({"scatter": 2}, r"scatter.*\[0, 1\]"),
                    ({"base_color": (1, 2, 0)}, r"base_color.*\[0, 1\]"), ({"variant": "ambient"}, "variant"),
                    ({"energy": "clamped"}, r"energy='clamped'.*bounded, published")]:
        with pytest.raises(ValueError, match=msg):
            hairbsdf.epic_hair(**kw)


@pytest.mark.parametrize("kw", [dict(), dict(base_color=(0.6, 0.4, 0.2), specular=0.8, scatter=0.7, roughness=0.2,
                                             shift=-0.05), dict(variant="environment", base_color=0.9, scatter=1.0)])
def test_eval_matches_reference(kw, rng):
    c = hairbsdf.epic_hair(energy="published", **kw)
    n = 3000
    wo = rng.normal(size=(n, 3))
    wi = rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1)[:, None]
    wi /= np.linalg.norm(wi, axis=1)[:, None]
    shadow = rng.random(n)
    ref_kw = {k: v for k, v in kw.items() if k != "variant"}
    ref_kw.setdefault("base_color", inspect.signature(hairbsdf.epic_hair).parameters["base_color"].default)
    C = ref_kw.pop("base_color")
    ref = reference(wo, wi, np.broadcast_to(C, 3), env=kw.get("variant") == "environment", shadow=shadow[:, None],
                    **ref_kw)
    got = c.eval_lobes(wo, wi, 0.0, shadow=shadow)
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-14)


def test_shadow_changes_only_the_multiple_scattering_colour(rng):
    c = hairbsdf.epic_hair(base_color=(0.6, 0.3, 0.1), scatter=1.0, energy="published")
    wo, wi = rng.normal(size=(100, 3)), rng.normal(size=(100, 3))
    lit = c.eval_lobes(wo, wi, 0.0)  # default shadow = 1: no extra colour
    dark = c.eval_lobes(wo, wi, 0.0, shadow=0.0)
    np.testing.assert_array_equal(lit[:, :3], dark[:, :3])
    luma = 0.2126 * 0.6 + 0.7152 * 0.3 + 0.0722 * 0.1
    np.testing.assert_allclose(dark[:, 3], lit[:, 3] * (np.array([0.6, 0.3, 0.1]) / luma), rtol=1e-12)
    with pytest.raises(ValueError, match="shadow"):
        c.eval(wo, wi, 0.0, shadow=1.5)


def test_multiple_scattering_albedo_is_closed_form():
    """int (n.wi + 1) / (4 pi) = 1: the fake's albedo is Scatter sqrt(C) (C / Luma)^(1 - Shadow)."""
    C = np.array([0.5, 0.3, 0.1])
    c = hairbsdf.epic_hair(base_color=C, specular=0.0, scatter=0.8, roughness=1.0, energy="published") * 1.0
    only_ms = hairbsdf.epic_hair(base_color=0.0, specular=0.0, scatter=0.8)
    for wo in FURNACE_VIEWS[:3]:
        np.testing.assert_allclose(only_ms.albedo(wo, 0.0), 0.0, atol=1e-15)
    # with C, evaluate the MS lobe alone by quadrature
    x, w = np.polynomial.legendre.leggauss(64)
    ph = (np.arange(256) + 0.5) / 256 * 2 * np.pi
    S, P = np.meshgrid(x, ph, indexing="ij")
    wi = fibre_dirs(S.ravel(), P.ravel())
    for shadow in (1.0, 0.25):
        ms = c.eval_lobes(unit(30, 10), wi, 0.0, shadow=shadow)[:, 3].reshape(64, 256, 3)
        alb = np.einsum("i,ijc->c", w, ms) * 2 * np.pi / 256
        luma = 0.2126 * C[0] + 0.7152 * C[1] + 0.0722 * C[2]
        np.testing.assert_allclose(alb, 0.8 * np.sqrt(C) * (C / luma) ** (1 - shadow), rtol=1e-9)


def test_furnace_published():
    """energy="published": defaults <= 1.01. A white fibre (C = 1, the analogue of sigma_a = 0) as
    published gains energy: Karis's fit reaches 1.042 at Specular 0.5 and 1.139 at Specular 1
    (theta_o = 45 deg; docs/models.md §2 lists the lobes); the test pins those measured maxima so
    that a change is seen."""
    views = [unit(0, 10), unit(30, 0), unit(45, 0), unit(70, 170), unit(-89.5, 33)]
    pub = dict(energy="published")
    assert max_albedo(hairbsdf.epic_hair(**pub), views, hs=(0.0,)) <= 1.01
    assert max_albedo(hairbsdf.epic_hair(variant="environment", specular=1.0, base_color=1.0, **pub), views,
                      hs=(0.0,)) <= 1.01
    white = max_albedo(hairbsdf.epic_hair(base_color=1.0, **pub), views, hs=(0.0,))
    white_max = max(max_albedo(hairbsdf.epic_hair(base_color=1.0, specular=1.0, roughness=r, **pub), views, hs=(0.0,))
                    for r in (0.1, 0.35))
    assert 1.035 < white < 1.045, white
    assert 1.13 < white_max < 1.16, white_max


# Views of the bounded furnace: a sweep in theta_o (between the table's nodes too) and grazing ones.
BOUNDED_VIEWS = [unit(t, 20) for t in np.linspace(-89.5, 89.5, 47)] + [unit(-89.5, 33), unit(88, 0), unit(66, 0)]


def bounded_scale(kw, wo, shadow):
    """The per-view factor of energy="bounded" (bounded / published eval, checked constant over
    omega_i), per channel."""
    S, P = np.meshgrid(np.linspace(-0.995, 0.995, 200), np.linspace(-np.pi, np.pi, 32), indexing="ij")
    wi = fibre_dirs(S.ravel(), P.ravel())
    b = hairbsdf.epic_hair(**kw).eval(wo, wi, 0.0, shadow=shadow)
    p = hairbsdf.epic_hair(**kw, energy="published").eval(wo, wi, 0.0, shadow=shadow)
    ok = p > 1e-12
    if not ok.any():  # nothing scattered
        return 1.0
    scale = b[ok] / p[ok]
    np.testing.assert_allclose(scale, scale.max(), rtol=1e-12)  # one factor per view (and channel here)
    return scale.max()


def test_furnace_bounded():
    """energy="bounded" (the default): a white fibre with every gain at its maximum stays <= 1.01,
    for both variants, shift +-0.25, roughness 0.1 and 0.35, Scatter 0 and 1, Shadow 0 and 1
    (docs/validation.md §5.D). The albedo at Shadow s is the per-view scale times the published one:
    R + TT + TRT by quadrature plus the multiple-scattering term's closed form
    (test_multiple_scattering_albedo_is_closed_form; for C = 1 it is Scatter for every Shadow)."""
    worst = 0.0
    for variant in ("direct", "environment"):
        for roughness in (0.1, 0.35):
            for shift in (-0.25, 0.035, 0.25):
                kw = dict(base_color=1.0, specular=1.0, roughness=roughness, shift=shift, variant=variant)
                single = hairbsdf.epic_hair(**kw, energy="published")
                for wo in BOUNDED_VIEWS[::4] + BOUNDED_VIEWS[-3:]:
                    a = single.albedo(wo, 0.0)[0]
                    worst = max(worst, (bounded_scale(kw, wo, 1.0) * a).max())
                    for shadow in (0.0, 1.0):
                        scale = bounded_scale({**kw, "scatter": 1.0}, wo, shadow)
                        worst = max(worst, (scale * (a + 1.0)).max())
    assert worst <= 1.01, worst


def test_bounded_is_published_where_no_energy_is_created(rng):
    """Defaults (a dark fibre) and coloured fibres with albedo < 1: bounded == published."""
    wo, wi = rng.normal(size=(4000, 3)), rng.normal(size=(4000, 3))
    for kw in (dict(), dict(base_color=(0.6, 0.4, 0.2), roughness=0.2), dict(variant="environment", base_color=0.9)):
        b = hairbsdf.epic_hair(**kw).eval_lobes(wo, wi, 0.0)
        p = hairbsdf.epic_hair(energy="published", **kw).eval_lobes(wo, wi, 0.0)
        np.testing.assert_allclose(b, p, rtol=1e-6, atol=0)


def test_bounded_white_fibre_is_one_where_published_exceeds_one():
    """A white fibre is scaled to albedo 1 (within 1 %) wherever the published one exceeds 1, over a
    dense theta_o sweep (between the table's nodes too): the table matches the quadrature."""
    for kw in (dict(base_color=1.0), dict(base_color=1.0, specular=1.0, roughness=0.1),
               dict(base_color=1.0, specular=1.0, shift=-0.25)):
        b, p = hairbsdf.epic_hair(**kw), hairbsdf.epic_hair(energy="published", **kw)
        for wo in BOUNDED_VIEWS[::3] + BOUNDED_VIEWS[-3:]:
            ap, ab = p.albedo(wo, 0.0)[0], b.albedo(wo, 0.0)[0]
            if ap.max() > 1.0:
                assert 0.99 <= ab.max() <= 1.01, (kw, wo, ap, ab)
            else:
                np.testing.assert_allclose(ab, ap, rtol=1e-12)


def test_make_model_and_schema_accept_energy():
    (spec,) = [p for p in hairbsdf.model_schema("epic") if p["name"] == "energy"]
    assert spec["type"] == "choice" and spec["default"] == "bounded" and list(spec["choices"]) == ["bounded", "published"]
    wo, wi = unit(45, 0), unit(-40, 170)
    a = hairbsdf.make_model("epic", {"base_color": 1.0, "energy": "published"}).eval(wo, wi, 0.0)
    b = hairbsdf.epic_hair(base_color=1.0, energy="published").eval(wo, wi, 0.0)
    np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="energy"):
        hairbsdf.make_model("epic", {"energy": "conserving"})


def test_sampled_furnace_matches_quadrature():
    c = hairbsdf.epic_hair(base_color=(0.9, 0.7, 0.5), scatter=0.3)
    for wo in FURNACE_VIEWS[:3]:
        est = testing.sampled_furnace(c, wo, 0.0, samples=200_000)
        np.testing.assert_allclose(est, c.albedo(wo, 0.0)[0], rtol=1e-2)


def test_sampling_consistency(rng):
    for kw in (dict(), dict(base_color=1.0, scatter=1.0, roughness=0.05),
               dict(variant="environment", base_color=(0.3, 0.2, 0.1), scatter=0.5)):
        check_sampling_consistency(hairbsdf.epic_hair(**kw), rng, shadow=rng.random(20_000))


def test_pdf_integrates_to_one():
    for kw in (dict(), dict(base_color=1.0, scatter=1.0, roughness=0.1), dict(variant="environment")):
        c = hairbsdf.epic_hair(**kw)
        for wo in (unit(-35, 20), unit(80, 0), unit(89.9, 0)):
            assert abs(testing.pdf_integral(c, wo, 0.0) - 1.0) < 1e-3


def test_chi2():
    cases = []
    for kw in (dict(base_color=1.0), dict(base_color=(0.5, 0.3, 0.1), scatter=1.0), dict(roughness=0.15, base_color=0.8),
               dict(variant="environment", base_color=0.7, scatter=0.5), dict(shift=0.25, base_color=1.0, roughness=0.6)):
        c = hairbsdf.epic_hair(**kw)
        for wo in (unit(-35, 20), unit(60, 0)):
            cases.append((c, wo, 0.0))
    check_chi2_family(cases, samples=200_000)


def test_fuzz(rng):
    for kw in (dict(), dict(roughness=0.0, base_color=1.0, specular=1.0, scatter=1.0), dict(base_color=0.0),
               dict(roughness=1.0, shift=-0.25, variant="environment", base_color=(1, 0, 0.5), scatter=1.0)):
        check_fuzz(hairbsdf.epic_hair(**kw), rng, n=5000, shadow=rng.random(5000))
