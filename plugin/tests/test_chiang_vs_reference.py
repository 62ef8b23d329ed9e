"""The module against the independent float64 reference (plugin/tests/reference) on random
configurations: every input of the node, both accuracy modes, both tilt conventions."""

import numpy as np
import pytest

import hairbsdf
from reference import chiang_reference as ref

PARAM_SETS_PER_COMBO = 12_500  # x 4 combos = 50,000 random configurations
COMBOS = [("cycles", "4.2"), ("exact", "4.2"), ("cycles", "3.4"), ("exact", "3.4")]
PARAMETRIZATIONS = ("color", "melanin", "absorption")


def random_unit(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def random_inputs(rng):
    """One random set of node inputs spanning the whole socket ranges, and a bit beyond."""
    return dict(
        color=rng.uniform(0.0, 1.0, 3),
        melanin=rng.uniform(0.0, 1.0),
        melanin_redness=rng.uniform(0.0, 1.0),
        tint=rng.uniform(0.2, 1.0, 3),
        absorption_coefficient=10 ** rng.uniform(-3, 1.3, 3),
        roughness=rng.uniform(0.0, 0.06) if rng.uniform() < 0.1 else rng.uniform(0.0, 1.0),
        radial_roughness=rng.uniform(0.0, 0.06) if rng.uniform() < 0.1 else rng.uniform(0.0, 1.0),
        coat=rng.uniform(0.0, 1.0),
        ior=rng.uniform(0.6, 1.0) if rng.uniform() < 0.05 else rng.uniform(1.0, 2.5),
        offset=rng.uniform(-0.12, 0.12),
        random_color=rng.uniform(0.0, 1.0),
        random_roughness=rng.uniform(0.0, 1.0),
        random=rng.uniform(0.0, 1.0),
    )


def stack_params(param_dicts):
    """Per-row reference parameters from a list of dicts."""
    return {key: np.array([p[key] for p in param_dicts]) for key in param_dicts[0]}


@pytest.mark.parametrize("accuracy,tilt", COMBOS)
def test_eval_and_pdf_match_reference(accuracy, tilt, rng):
    n = PARAM_SETS_PER_COMBO
    wo, wi = random_unit(rng, n), random_unit(rng, n)
    h = rng.uniform(-1, 1, n)
    got_lobes = np.empty((n, 4, 3))
    got_pdf = np.empty(n)
    ref_params, cases = [], []
    for i in range(n):
        parametrization = PARAMETRIZATIONS[i % 3]
        inputs = random_inputs(rng)
        ours = hairbsdf.principled_hair(parametrization=parametrization, accuracy=accuracy, tilt=tilt,
                                        **{k: (tuple(v) if np.ndim(v) else float(v)) for k, v in inputs.items()})
        got_lobes[i] = ours.eval_lobes(wo[i], wi[i], h[i])[0]
        got_pdf[i] = ours.pdf(wo[i], wi[i], h[i])[0]
        ref_params.append(ref.principled_hair_params(parametrization=parametrization, **inputs))
        cases.append((parametrization, inputs))
    params = stack_params(ref_params)
    expected = ref.chiang_eval_lobes(params, wo, wi, h, accuracy=accuracy, tilt=tilt)
    expected_pdf = ref.chiang_pdf(params, wo, wi, h, accuracy=accuracy, tilt=tilt)

    err = (np.abs(got_lobes - expected) / (np.abs(expected) + 1e-12)).reshape(n, -1).max(axis=1)
    perr = np.abs(got_pdf - expected_pdf) / (np.abs(expected_pdf) + 1e-12)
    print(f"{accuracy}/{tilt}: worst relative error eval {err.max():.2e}, pdf {perr.max():.2e}; "
          f"non-zero rows {np.count_nonzero(expected.sum(axis=(1, 2)))} of {n}")
    worst = int(np.argmax(np.maximum(err, perr)))
    assert err.max() < 1e-4 and perr.max() < 1e-4, (cases[worst], wo[worst], wi[worst], h[worst],
                                                      got_lobes[worst], expected[worst])


def test_parameter_mapping_matches_reference(rng):
    for i in range(2000):
        parametrization = PARAMETRIZATIONS[i % 3]
        inputs = random_inputs(rng)
        ours = hairbsdf.principled_hair(parametrization=parametrization,
                                        **{k: (tuple(v) if np.ndim(v) else float(v)) for k, v in inputs.items()})
        mapped = ours.model_params[0]
        expected = ref.principled_hair_params(parametrization=parametrization, **inputs)
        np.testing.assert_allclose(mapped["sigma_a"], expected["sigma_a"], rtol=1e-12)
        np.testing.assert_allclose(mapped["v"], [expected["v_R"], expected["v"] / 4, 4 * expected["v"],
                                                 4 * expected["v"]], rtol=1e-12)
        np.testing.assert_allclose(mapped["s"][0], expected["s"], rtol=1e-12)


def test_curve_random_matches_reference():
    idx = np.arange(0, 5000, dtype=np.int64)
    np.testing.assert_allclose(hairbsdf.cycles_curve_random(idx), ref.cycles_curve_random(idx), rtol=1e-7)
