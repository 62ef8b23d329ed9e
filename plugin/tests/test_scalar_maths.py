"""hairbsdf.set_scalar_maths: Chiang's scalar path at accuracy "cycles" takes float-accuracy exp, asin and
atan2 by default, glibc's double functions with "double" (the reference of the SIMD kernels' tests,
docs/simd.md); accuracy "exact" ignores the switch."""

import numpy as np
import pytest

import hairbsdf


@pytest.fixture(autouse=True)
def float_maths():
    hairbsdf.set_scalar_maths("float")
    yield
    hairbsdf.set_scalar_maths("float")


def rows(n=2000):
    rng = np.random.default_rng(5)
    wo = rng.normal(size=(n, 3))
    wi = rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    return wo, wi, rng.uniform(-1, 1, n)


def test_float_and_double_maths_agree_and_differ():
    """float64 rows take the scalar path: the two settings agree to 1e-6 of the row set's scale, and not
    bit for bit at "cycles" (the switch takes effect); "exact" is bit for bit the same."""
    wo, wi, h = rows()
    results = {}
    for accuracy in ("cycles", "exact"):
        closure = hairbsdf.principled_hair(accuracy=accuracy, offset=0.05)
        for maths in ("float", "double"):
            assert hairbsdf.set_scalar_maths(maths) == maths == hairbsdf.get_scalar_maths()
            results[accuracy, maths] = np.concatenate([closure.eval(wo, wi, h).ravel(), closure.pdf(wo, wi, h)])
    fast, reference = results["cycles", "float"], results["cycles", "double"]
    assert np.all(np.isfinite(fast))
    scale = np.abs(reference).max()
    assert np.all(np.abs(fast - reference) <= 1e-6 * np.maximum(np.abs(reference), 1e-3 * scale))
    assert np.any(fast != reference)
    np.testing.assert_array_equal(results["exact", "float"], results["exact", "double"])


def test_bad_setting_names_the_argument():
    with pytest.raises(ValueError, match="precision='single' is not allowed"):
        hairbsdf.set_scalar_maths("single")
    assert hairbsdf.get_scalar_maths() == "float"
