"""The example plugin examples/plugins/kajiya_kay: it builds stand-alone with CMake against an
installed copy of hairbsdf/plugin.h, loads, passes hairbsdf.test_plugin, and has the albedo its
normalisation promises. The build is the `kk_path` fixture of conftest.py (set
HAIRBSDF_KAJIYA_KAY_PLUGIN to a built .so to skip it)."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf import testing

def fibre(theta, phi=-np.pi / 2):
    return np.array([np.sin(theta), np.cos(theta) * np.cos(phi), np.cos(theta) * np.sin(phi)])


def test_builds_stand_alone_and_loads(kk_path, kk):
    assert kk_path.exists()
    assert kk.name == "kajiya_kay"
    assert list(kk.params) == ["color", "specular_color", "specular", "exponent"]
    assert kk.params["exponent"].min == 1 and kk.params["exponent"].max == 10000
    assert kk.has_lobes


def test_albedo_is_the_lobe_weights_at_normal_incidence(kk):
    """Both lobes integrate to 1 at theta_o = 0 and to less elsewhere."""
    hair = kk(color=(0.8, 0.5, 0.2), specular_color=(1.0, 0.9, 0.8), specular=0.4, exponent=60)
    a0 = hair.albedo(fibre(0.0), 0.3, panels_per_scale=0.25)[0]  # lobes far wider than 0.02 rad
    np.testing.assert_allclose(a0, 0.6 * np.array([0.8, 0.5, 0.2]) + 0.4 * np.array([1.0, 0.9, 0.8]), rtol=2e-4)
    a1 = hair.albedo(fibre(1.0), 0.3, panels_per_scale=0.25)[0]
    assert np.all(a1 < a0)
    # The specular lobe peaks on the mirror cone theta_i = -theta_o and reports as R, the diffuse as TRRT+.
    lobes = hair.eval_lobes(fibre(0.5), np.array([fibre(-0.5, 0.3), fibre(0.2, 0.3)]), 0.0)
    assert lobes[0, 0, 0] > 10 * lobes[1, 0, 0]
    assert np.all(lobes[:, 1:3] == 0) and np.all(lobes[:, 3] > 0)


@pytest.mark.parametrize("params", [{}, {"specular": 0.8, "exponent": 200.0, "color": (1.0, 1.0, 1.0)}])
def test_passes_test_plugin(kk, params, capsys):
    options = testing.BatteryOptions(theta_panels=96, phi_panels=64, furnace_samples=100_000,
                                     consistency_samples=10_000, chi2_samples=150_000, fuzz_samples=10_000)
    result = hairbsdf.test_plugin(kk, options=options, **params)
    assert result.passed, str(result)
    assert "PASSED" in capsys.readouterr().out


def test_parameter_errors(kk):
    with pytest.raises(ValueError, match=r"exponent=0.5 is out of range; allowed \[1, 10000\]"):
        kk(exponent=0.5)
    with pytest.raises(TypeError, match=r"did you mean 'specular'"):
        kk(speculr=0.5)
