"""MaterialX chiang_hair_bsdf and its support nodes: names and defaults against the
nodedefs in the `materialx` wheel, check values from docs/materialx.md, and the closure's
equivalence with Principled Hair in Blender 3.4's tilt convention."""

import math

import numpy as np
import pytest
from ci import require_module

import hairbsdf
from hairbsdf import materialx as hmx
from hairbsdf import testing

mx = require_module("MaterialX")


@pytest.fixture(scope="module")
def stdlib():
    doc = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), doc)
    return doc


def nodedef_defaults(doc, name):
    nd = doc.getNodeDef(name)
    assert nd is not None, name
    out = {}
    for inp in nd.getActiveInputs():
        if inp.getDefaultGeomPropString():
            continue  # normal / curve_direction come from geometry
        value = inp.getValue()
        out[inp.getName()] = tuple(value.asTuple()) if hasattr(value, "asTuple") else float(value)
    return out


@pytest.mark.parametrize("nodedef,ours", [
    ("ND_chiang_hair_bsdf", hmx.CHIANG_HAIR_BSDF_DEFAULTS),
    ("ND_chiang_hair_roughness", hmx.CHIANG_HAIR_ROUGHNESS_DEFAULTS),
    ("ND_chiang_hair_absorption_from_color", hmx.CHIANG_HAIR_ABSORPTION_FROM_COLOR_DEFAULTS),
    ("ND_deon_hair_absorption_from_melanin", hmx.DEON_HAIR_ABSORPTION_FROM_MELANIN_DEFAULTS),
])
def test_names_and_defaults_match_the_nodedefs(stdlib, nodedef, ours):
    expected = nodedef_defaults(stdlib, nodedef)
    assert set(expected) == set(ours)
    for key, value in expected.items():
        np.testing.assert_allclose(np.atleast_1d(ours[key]), np.atleast_1d(value), rtol=1e-6, err_msg=key)


def test_node_tables_reject_unknown_names():
    with pytest.raises(ValueError, match="not a MaterialX node"):
        hairbsdf._core.materialx_schema("chiang_hair")
    with pytest.raises(ValueError, match="allowed: longitudinal, azimuthal, scale_TT, scale_TRT"):
        hairbsdf._core.materialx_roughness({"longitudinal": 0.1, "roughness": 0.2})


def test_geometry_inputs_exist(stdlib):
    names = {i.getName(): i.getDefaultGeomPropString() for i in stdlib.getNodeDef("ND_chiang_hair_bsdf").getActiveInputs()}
    assert names["normal"] == "Nworld" and names["curve_direction"] == "Tworld"


def test_support_node_check_values():
    r = hmx.chiang_hair_roughness()
    np.testing.assert_allclose(r.roughness_R, (0.00651572, 0.100760), rtol=1e-5)
    np.testing.assert_allclose(r.roughness_TT, (0.00162893, 0.100760), rtol=1e-5)
    np.testing.assert_allclose(r.roughness_TRT, (0.0260629, 0.100760), rtol=1e-5)
    np.testing.assert_allclose(hmx.chiang_hair_roughness(1.0, 1.0).roughness_R, (27.4366, 6.83100), rtol=1e-5)
    np.testing.assert_allclose(hmx.deon_hair_absorption_from_melanin(), (0.0871677, 0.157794, 0.348095), rtol=1e-5)
    np.testing.assert_allclose(hmx.deon_hair_absorption_from_melanin(0.5, 0.5), (0.210024, 0.380191, 0.838708), rtol=1e-5)
    np.testing.assert_allclose(hmx.chiang_hair_absorption_from_color(), (0, 0, 0), atol=1e-12)
    np.testing.assert_allclose(hmx.chiang_hair_absorption_from_color((0.5, 0.3, 0.1), 0.3),
                               (0.0138565, 0.0418058, 0.152910), rtol=1e-5)
    np.testing.assert_allclose(hmx.chiang_hair_absorption_from_color((0, 0, 0), 0.2), (1.34765,) * 3, rtol=1e-5)


def fibre(theta, dphi, phi_o=-np.pi / 2):
    return np.array([np.sin(theta), np.cos(theta) * np.cos(phi_o + dphi), np.cos(theta) * np.sin(phi_o + dphi)])


def test_bsdf_check_values_and_tilt_sign():
    """Values from docs/materialx.md §5 (spec form, sigma_a = 0, theta_o = 0.3, h = 0.3)."""
    wo = fibre(0.3, 0.0)
    lobes = hmx.chiang_hair_bsdf().eval_lobes(wo, fibre(-0.3, -0.6), 0.3)[0, :, 0]
    np.testing.assert_allclose(lobes, [0.250734, 2.0636e-37, 0.000834531, 0.000325186], rtol=1e-4)
    tt = hmx.chiang_hair_bsdf().eval_lobes(wo, fibre(-0.3, 2.9), 0.3)[0, 1, 0]
    assert tt == pytest.approx(13.1986, rel=1e-4)
    # cuticle_angle 0.6 (alpha = 0.1 pi) moves the R peak to theta_i = -theta_o - 2 alpha.
    tilted = hmx.chiang_hair_bsdf(cuticle_angle=0.6)
    assert tilted.eval_lobes(wo, fibre(-0.3 - 0.2 * np.pi, -0.6), 0.3)[0, 0, 0] == pytest.approx(0.250734, rel=1e-4)
    assert tilted.eval(wo, fibre(-0.3 - 0.2 * np.pi, -0.6), 0.3)[0, 0] == pytest.approx(0.251287, rel=1e-4)


def test_equals_principled_hair_in_blender34_convention(rng):
    """chiang_hair_bsdf fed by chiang_hair_roughness is Principled Hair with the 3.4 tilt
    and exact special functions (docs/materialx.md §3.2)."""
    for _ in range(200):
        beta_m, beta_n = rng.uniform(0.05, 1.0, 2)
        offset = rng.uniform(-0.1, 0.1)
        sigma = tuple(rng.uniform(0, 3, 3))
        ior = rng.uniform(1.2, 2.0)
        r = hmx.chiang_hair_roughness(beta_m, beta_n)
        ours = hmx.chiang_hair_bsdf(roughness_R=r.roughness_R, roughness_TT=r.roughness_TT,
                                    roughness_TRT=r.roughness_TRT, cuticle_angle=0.5 + offset / math.pi,
                                    absorption_coefficient=sigma, ior=ior)
        blender = hairbsdf.principled_hair(parametrization="absorption", absorption_coefficient=sigma,
                                           roughness=beta_m, radial_roughness=beta_n, offset=offset, ior=ior,
                                           tilt="3.4", accuracy="exact")
        wo = rng.normal(size=(50, 3))
        wi = rng.normal(size=(50, 3))
        h = rng.uniform(-1, 1, 50)
        np.testing.assert_allclose(ours.eval_lobes(wo, wi, h), blender.eval_lobes(wo, wi, h), rtol=1e-9, atol=1e-300)


def test_tints_scale_their_lobes_and_trrt_uses_trt_tint():
    wo, wi, h = fibre(0.2, 0.0), fibre(-0.1, 2.0), 0.1
    base = hmx.chiang_hair_bsdf(absorption_coefficient=(0.2, 0.3, 0.4)).eval_lobes(wo, wi, h)[0]
    tinted = hmx.chiang_hair_bsdf(absorption_coefficient=(0.2, 0.3, 0.4), tint_R=(0.5, 1, 1), tint_TT=(1, 0.25, 1),
                                  tint_TRT=(1, 1, 0.1)).eval_lobes(wo, wi, h)[0]
    np.testing.assert_allclose(tinted / base, [[0.5, 1, 1], [1, 0.25, 1], [1, 1, 0.1], [1, 1, 0.1]], rtol=1e-12)
    negative = hmx.chiang_hair_bsdf(tint_R=(-1, 0.5, 0.5)).eval_lobes(wo, wi, h)[0]
    assert negative[0, 0] == 0.0  # tints are floored at 0


def test_glsl_compat_divides_by_pi():
    wo, wi = fibre(0.3, 0.0), fibre(-0.3, -0.6)
    np.testing.assert_allclose(hmx.chiang_hair_bsdf(glsl_compat=True).eval(wo, wi, 0.3) * np.pi,
                               hmx.chiang_hair_bsdf().eval(wo, wi, 0.3), rtol=1e-12)


def test_furnace_is_one_without_tilt_and_measured_with_tilt():
    wo_h = [(fibre(0.0, 0.0), 0.0), (fibre(0.6, 0.0), 0.3), (fibre(-1.2, 0.0), 0.8)]
    untilted = hmx.chiang_hair_bsdf(roughness_R=(0.0846, 0.3), roughness_TT=(0.0212, 0.3), roughness_TRT=(0.338, 0.3))
    for wo, h in wo_h:
        assert untilted.albedo(wo, h)[0, 0] == pytest.approx(1.0, abs=1e-3)
    tilted = hmx.chiang_hair_bsdf(roughness_R=(0.0846, 0.3), roughness_TT=(0.0212, 0.3), roughness_TRT=(0.338, 0.3),
                                  cuticle_angle=0.5 + 2 / 180)
    values = [tilted.albedo(wo, h)[0, 0] for wo, h in wo_h]
    # The spec tilts theta_i, which breaks M_p's normalisation (docs/materialx.md §3.2).
    assert 0.985 < min(values) < 0.995 and 1.015 < max(values) < 1.03, values


@pytest.mark.parametrize("h", [-0.6, 0.4])
def test_chi2_without_tilt(h):
    closure = hmx.chiang_hair_bsdf(absorption_coefficient=(0.3, 0.5, 0.9), roughness_R=(0.05, 0.3),
                                   roughness_TT=(0.02, 0.2), roughness_TRT=(0.2, 0.4))
    result = testing.chi2_test(closure, fibre(0.4, 0.0), h, samples=500_000)
    assert result.passed(testing.sidak_alpha(0.01, 2)), result


def test_simple_hair_default_graph():
    closure = hmx.simple_hair_default()
    p = closure.model_params[0]
    np.testing.assert_allclose(p["sigma_a"], (0.210024, 0.380191, 0.838708), rtol=1e-5)
    np.testing.assert_allclose(p["v"], (0.00651572, 0.00162893, 0.0260629, 0.0260629), rtol=1e-5)
    np.testing.assert_allclose(p["s"], np.full(3, 0.03844 * math.sqrt(math.pi / 8)), rtol=1e-4)
    assert p["tilt"] == 0.0


def test_simple_hair_base_reads_the_proposal_as_meant():
    default = hmx.simple_hair_base()
    p = default.model_params[0]
    np.testing.assert_allclose(p["sigma_a"], (2.79073, 5.05187, 11.1445), rtol=1e-5)  # melanin 1.0, redness 0.5
    v = hmx.chiang_hair_roughness(0.1).roughness_R[0]
    np.testing.assert_allclose(p["v"], (v, v / 4, 4 * v, 4 * v), rtol=1e-12)  # only v is scaled
    s = hmx.chiang_hair_roughness(0.1, 0.1).roughness_R[1] * math.sqrt(math.pi / 8)
    np.testing.assert_allclose(p["s"], (s, s, s), rtol=1e-12)  # s from the fit, not the variance
    colored = hmx.simple_hair_base(base_color=(0.5, 0.3, 0.1), specular_reflection_anisotropic_roughness=True,
                                   specular_reflection_azimuthal_roughness=0.3, specular_reflection_shift=0.6)
    q = colored.model_params[0]
    np.testing.assert_allclose(q["sigma_a"], hmx.chiang_hair_absorption_from_color((0.5, 0.3, 0.1), 0.3), rtol=1e-12)
    assert q["tilt"] == pytest.approx(0.1 * math.pi)
    assert hmx.simple_hair_base(specular_reflection_ior=0.5).model_params[0]["eta"] == pytest.approx(1 + 1e-5)


def test_bad_inputs_name_the_parameter():
    with pytest.raises(TypeError, match="roughnes_R"):
        hmx.chiang_hair_bsdf(roughnes_R=(0.1, 0.1))
    with pytest.raises(ValueError, match="roughness_TT"):
        hmx.chiang_hair_bsdf(roughness_TT=(0.1, 0.1, 0.1))
    with pytest.raises(ValueError, match="roughness_R"):
        hmx.chiang_hair_bsdf(roughness_R=(-0.1, 0.1))
    with pytest.raises(ValueError, match="cuticle_angle"):
        hmx.chiang_hair_bsdf(cuticle_angle=float("nan"))
