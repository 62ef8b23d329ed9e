"""Per-row node inputs (`inputs=`) on the float32 batch kernels of a Chiang closure (docs/simd.md)
against the scalar double path with the same per-row inputs, which is principled_hair built row by
row: eval, pdf and sample in both accuracy modes, both tilt conventions and the three
parametrizations; the chi-square test and edge rows on the per-row kernels; arguments and errors."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf import testing
from test_batch_kernels import DEG, ISAS, _edge_rows, assert_close, reference, relative_errors, rows, scalar_path

# Every test starts and ends on the best instruction set (the fixture is in conftest.py).
pytestmark = pytest.mark.usefixtures("best_kernel")
N = 100_000
# The closure's uniform inputs; random_roughness and random_color make `random` matter.
UNIFORM = dict(random_roughness=0.3, random_color=0.4, melanin_redness=0.6, tint=(0.9, 0.7, 0.8),
               color=(0.3, 0.15, 0.05), offset=3 * DEG)
CASES = [("color", "cycles", "4.2"), ("melanin", "exact", "3.4"), ("absorption", "exact", "4.2"),
         ("melanin", "cycles", "3.4")]


def hair(parametrization, accuracy, tilt):
    return hairbsdf.principled_hair(parametrization=parametrization, accuracy=accuracy, tilt=tilt, **UNIFORM)


def row_inputs(n=N, seed=5):
    """Every per-row input, float32. Roughness from 0.08 (0.056 after Random Roughness; the uniform
    tests' smoothest case is 0.05), the others over their whole range."""
    rng = np.random.default_rng(seed)
    return {"roughness": rng.uniform(0.08, 0.9, n).astype(np.float32),
            "radial_roughness": rng.uniform(0.05, 1.0, n).astype(np.float32),
            "coat": rng.uniform(0.0, 1.0, n).astype(np.float32),
            "random": rng.random(n).astype(np.float32),
            "melanin": rng.random(n).astype(np.float32),
            "absorption_coefficient": rng.uniform(0.0, 4.0, (n, 3)).astype(np.float32)}


def subset(inputs, mask):
    return {k: v[mask] for k, v in inputs.items()}


_REFERENCE = {}


def eval_reference(case, wo, wi, h, inputs):
    """The scalar path's eval and pdf of a case on the standard rows (computed once per case)."""
    if case not in _REFERENCE:
        closure = hair(*case)
        _REFERENCE[case] = (reference(lambda: closure.eval(wo, wi, h, inputs=inputs)),
                            reference(lambda: closure.pdf(wo, wi, h, inputs=inputs)))
    return _REFERENCE[case]


@pytest.mark.parametrize("isa", ISAS)
@pytest.mark.parametrize("case", CASES, ids="-".join)
def test_per_row_eval_and_pdf_match_the_scalar_path(case, isa):
    closure = hair(*case)
    wo, wi, h, _ = rows()
    inputs = row_inputs()
    ref_value, ref_pdf = eval_reference(case, wo, wi, h, inputs)
    assert hairbsdf.set_batch_kernel(isa) == isa
    value = closure.eval(wo, wi, h, inputs=inputs)
    pdf = closure.pdf(wo, wi, h, inputs=inputs)
    assert value.dtype == np.float32 and pdf.dtype == np.float32
    assert_close(value, ref_value, f"per-row eval [{isa}]")
    assert_close(pdf, ref_pdf, f"per-row pdf [{isa}]")


@pytest.mark.parametrize("case", CASES, ids="-".join)
def test_per_row_sample_matches_the_scalar_path(case):
    """As test_batch_kernels' sample test (the same bounds), with per-row inputs."""
    closure = hair(*case)
    wo, _, h, u = rows(seed=2)
    inputs = row_inputs(seed=6)
    ref = reference(lambda: closure.sample(wo, h, u, inputs=inputs))
    got = closure.sample(wo, h, u, inputs=inputs)
    for field in got:
        assert np.all(np.isfinite(field)), "sample: NaN or Inf"
    same = got.lobe == ref.lobe
    assert np.mean(~same) < 1e-4, f"per-row sample: {np.sum(~same)} rows picked another lobe"
    # The same 99.9th percentile as the uniform test. Its worst-row bound (1e-2) becomes a count:
    # strongly absorbing rows (absorption up to 4) leave TRRT+ a tiny weight, so u[2] near 1 is
    # rescaled by a small lobe weight and float's rounding of u[2] minus the weights before it is
    # magnified (measured: 1 row in 10^5 at 0.027, the next at 1.4e-3).
    drift = np.linalg.norm(got.wi[same] - ref.wi[same], axis=1)
    assert np.quantile(drift, 0.999) <= 5e-5, np.quantile(drift, 0.999)
    assert np.mean(drift > 1e-2) < 1e-4 and drift.max() <= 0.1, (np.sum(drift > 1e-2), drift.max())
    ok = got.lobe >= 0
    wi = got.wi[ok].astype(np.float64)
    ok_inputs = subset(inputs, ok)
    ref_pdf = reference(lambda: closure.pdf(wo[ok], wi, h[ok], inputs=ok_inputs))
    ref_value = reference(lambda: closure.eval(wo[ok], wi, h[ok], inputs=ok_inputs))
    assert_close(got.pdf[ok], ref_pdf, "per-row sample pdf", p999_bound=1e-4)
    assert_close(got.weight[ok], ref_value / ref_pdf[:, None], "per-row sample weight")


@pytest.mark.parametrize("parametrization", ["color", "melanin", "absorption"])
def test_scalar_path_is_principled_hair_row_by_row(parametrization):
    """The reference itself: row i of the per-row scalar path is principled_hair with row i's inputs
    (and the closure weight), bit for bit."""
    n = 24
    wo, wi, h, u = (a.astype(np.float64) for a in rows(seed=7, n=n))
    inputs = {k: v.astype(np.float64) for k, v in row_inputs(n=n, seed=8).items()}
    closure = (0.5, 2.0, 1.0) * hair(parametrization, "cycles", "4.2")
    value = closure.eval(wo, wi, h, inputs=inputs)
    pdf = closure.pdf(wo, wi, h, inputs=inputs)
    s = closure.sample(wo, h, u, inputs=inputs)
    for i in range(n):
        row = {k: (tuple(v[i]) if v.ndim == 2 else float(v[i])) for k, v in inputs.items()}
        one = (0.5, 2.0, 1.0) * hairbsdf.principled_hair(parametrization=parametrization, **dict(UNIFORM, **row))
        np.testing.assert_array_equal(value[i], one.eval(wo[i], wi[i], h[i])[0])
        np.testing.assert_array_equal(pdf[i], one.pdf(wo[i], wi[i], h[i])[0])
        r = one.sample(wo[i], h[i], u[i])
        for got, want in zip(s, r):
            np.testing.assert_array_equal(got[i], want[0])


def test_per_row_inputs_change_the_result_and_constant_rows_match_the_closure():
    """Guards against a vacuous pass: per-row inputs move eval (they are not ignored), and per-row
    arrays holding the closure's own values give the uniform kernels' result (float rounding apart:
    the per-row path prepares in float)."""
    wo, wi, h, _ = rows(n=20_000)
    closure = hair("melanin", "cycles", "4.2")
    uniform = closure.eval(wo, wi, h)
    varied = closure.eval(wo, wi, h, inputs=row_inputs(n=20_000))
    assert np.mean(np.abs(varied - uniform) > 1e-3 * np.abs(uniform)) > 0.9
    same = {"roughness": np.full(20_000, 0.3, np.float32), "radial_roughness": np.full(20_000, 0.3, np.float32),
            "coat": np.zeros(20_000, np.float32), "random": np.zeros(20_000, np.float32),
            "melanin": np.full(20_000, 0.8, np.float32)}
    assert_close(closure.eval(wo, wi, h, inputs=same), uniform, "constant per-row inputs")


def test_per_row_dtypes_weights_and_out():
    closure = 2.0 * hair("absorption", "cycles", "4.2")
    wo, wi, h, _ = rows(n=1000)
    inputs = row_inputs(n=1000)
    value32 = closure.eval(wo, wi, h, inputs=inputs)
    assert value32.dtype == np.float32
    # float64 per-row inputs with float32 rows: converted to float32 at the boundary.
    inputs64 = {k: v.astype(np.float64) for k, v in inputs.items()}
    np.testing.assert_array_equal(closure.eval(wo, wi, h, inputs=inputs64), value32)
    # float64 rows: the scalar path (its default maths); with float64="float32" the kernels, converted, float64 out.
    rows64 = (wo.astype(np.float64), wi.astype(np.float64), h.astype(np.float64))
    value64 = closure.eval(*rows64, inputs=inputs64)
    assert value64.dtype == np.float64
    np.testing.assert_array_equal(value64, scalar_path(lambda: closure.eval(*rows64, inputs=inputs64)))
    hairbsdf.set_batch_kernel("best", float64="float32")
    np.testing.assert_array_equal(closure.eval(*rows64, inputs=inputs64), value32.astype(np.float64))
    hairbsdf.set_batch_kernel("best")
    # The closure weight applies: twice the unweighted closure.
    half = hair("absorption", "cycles", "4.2").eval(wo, wi, h, inputs=inputs)
    np.testing.assert_allclose(value32, 2 * half, rtol=1e-6)
    out = np.empty((1000, 3), np.float32)
    assert closure.eval(wo, wi, h, inputs=inputs, out=out) is out
    np.testing.assert_array_equal(out, value32)
    pdf_out = np.empty(1000, np.float32)
    assert closure.pdf(wo, wi, h, inputs=inputs, out=pdf_out) is pdf_out
    # A number for a per-row input broadcasts (scalar path), and h may be a number.
    got = closure.eval(wo[:5], wi[:5], 0.25, inputs={"roughness": 0.4})
    want = (2.0 * hairbsdf.principled_hair(parametrization="absorption", **dict(UNIFORM, roughness=0.4))).eval(
        wo[:5].astype(np.float64), wi[:5].astype(np.float64), 0.25)
    np.testing.assert_array_equal(got, want)


def test_per_row_errors_name_the_argument():
    closure = hair("melanin", "cycles", "4.2")
    wo, wi, h, u = rows(n=50)
    inputs = row_inputs(n=50)
    with pytest.raises(ValueError, match="inputs: 'ior' cannot vary per row; allowed: roughness, radial_roughness"):
        closure.eval(wo, wi, h, inputs={"ior": np.ones(50)})
    bad = dict(inputs, coat=inputs["coat"].copy())
    bad["coat"][3] = np.nan
    with pytest.raises(ValueError, match="inputs: coat: contains NaN or Inf"):
        closure.pdf(wo, wi, h, inputs=bad)
    with pytest.raises(ValueError, match=r"inputs: roughness: shape \(50, 2\) is not allowed"):
        closure.eval(wo, wi, h, inputs={"roughness": np.ones((50, 2))})
    with pytest.raises(ValueError, match="absorption_coefficient: shape"):
        closure.eval(wo, wi, h, inputs={"absorption_coefficient": np.ones((50, 2))})
    with pytest.raises(ValueError, match="roughness: 49 rows do not match the others"):
        closure.eval(wo, wi, h, inputs={"roughness": np.ones(49, np.float32)})
    with pytest.raises(TypeError, match="inputs: expected a dict"):
        closure.eval(wo, wi, h, inputs=[0.3])
    with pytest.raises(ValueError, match="inputs: per-row node inputs do not combine with normal="):
        closure.sample(wo, h, u, inputs=inputs, random=0.5)
    for other in (closure + closure, hairbsdf.kajiya_kay_hair(), hairbsdf.principled_hair(model="huang")):
        with pytest.raises(ValueError, match=r"inputs: per-row node inputs need a single principled_hair\(model='chiang'\)"):
            other.eval(wo, wi, h, inputs=inputs)
    # Rows the kernels cannot take go to the validating path, which names them.
    far = h.copy()
    far[2] = 1.5
    with pytest.raises(ValueError, match="h: values must lie in"):
        closure.eval(wo, wi, far, inputs=inputs)
    high = u.copy()
    high[1, 0] = -0.5
    with pytest.raises(ValueError, match="u: values must lie in"):
        closure.sample(wo, h, high, inputs=inputs)


class _PerRowKernelRows:
    """chi2_test's sample and pdf on the per-row kernels: one wo as float32 rows, and per-row input
    arrays of as many rows (one value each, so that the test's single distribution is defined)."""

    def __init__(self, closure, inputs):
        self.closure = closure
        self.inputs = inputs
        self.model_params = closure.model_params

    def _args(self, wo, h, n):
        return (np.ascontiguousarray(np.broadcast_to(np.asarray(wo, np.float32), (n, 3))),
                np.full(n, h, dtype=np.float32),
                {k: np.full((n, 3) if k == "absorption_coefficient" else n, v, np.float32)
                 for k, v in self.inputs.items()})

    def sample(self, wo, h, u):
        wo_rows, h_rows, inputs = self._args(wo, h, len(u))
        return self.closure.sample(wo_rows, h_rows, np.asarray(u, np.float32), inputs=inputs)

    def pdf(self, wo, wi, h):
        wo_rows, h_rows, inputs = self._args(wo, h, len(wi))
        return self.closure.pdf(wo_rows, np.asarray(wi, np.float32), h_rows, inputs=inputs).astype(np.float64)


@pytest.mark.parametrize("tilt,offset_deg", [("4.2", 3.0), ("3.4", 0.0)])
def test_chi2_per_row_kernel_sample_matches_kernel_pdf(tilt, offset_deg):
    # model_params (the chi-square's resolution) come from the closure, whose uniform inputs are
    # the per-row values here. No coat: Cycles samples R with the un-coated variance, so with a coat
    # sample's density is not pdf; nor with a tilt under 3.4, whose sampler is the one #114780
    # replaced (as in test_batch_kernels' chi-square cases).
    values = dict(roughness=0.35, radial_roughness=0.3, coat=0.0, random=0.7, absorption_coefficient=(0.3, 0.6, 1.2))
    closure = hairbsdf.principled_hair(parametrization="absorption", accuracy="exact", tilt=tilt,
                                       offset=offset_deg * DEG, random_roughness=0.3, **values)
    t, p = np.radians((-35, 20))
    wo = np.array([np.sin(t), np.cos(t) * np.cos(p), np.cos(t) * np.sin(p)])
    result = testing.chi2_test(_PerRowKernelRows(closure, values), wo, 0.4, samples=1_000_000)
    assert result.passed(testing.sidak_alpha(0.01, 2)), result


def test_fuzz_per_row_edge_inputs_are_finite_and_match():
    """Edge rows (test_batch_kernels' special directions and h) with per-row inputs at the ends of
    their ranges and beyond (clamped as Cycles clamps): no NaN or Inf, eval within 1e-3 of the
    scalar path except for wi exactly on the fibre axis (see that module's fuzz test)."""
    wo, wi, h = _edge_rows()
    n = len(wo)
    rng = np.random.default_rng(9)
    pick = lambda *values: rng.choice(np.array(values, np.float32), n)  # noqa: E731
    inputs = {"roughness": pick(0.0, 0.001, 0.05, 1.0, 1.5), "radial_roughness": pick(0.0, 0.02, 1.0, 2.0),
              "coat": pick(-1.0, 0.0, 1.0, 2.0), "random": pick(0.0, 1.0), "melanin": pick(0.0, 1.0, 0.9999),
              "absorption_coefficient": rng.choice(np.array([0.0, 1e-4, 50.0], np.float32), (n, 3))}
    u = rng.random((n, 3)).astype(np.float32)
    for parametrization, accuracy, tilt in (("melanin", "cycles", "4.2"), ("absorption", "exact", "3.4"),
                                            ("color", "exact", "4.2")):
        closure = hair(parametrization, accuracy, tilt)
        value, pdf = closure.eval(wo, wi, h, inputs=inputs), closure.pdf(wo, wi, h, inputs=inputs)
        s = closure.sample(wo, h, u, inputs=inputs)
        for name, arr in (("eval", value), ("pdf", pdf)) + tuple(zip(s._fields, s)):
            assert np.all(np.isfinite(arr)), f"{name}: NaN or Inf"
        off_axis = (wi[:, 1] != 0) | (wi[:, 2] != 0)
        ref = reference(lambda: closure.eval(wo[off_axis], wi[off_axis], h[off_axis],
                                             inputs=subset(inputs, off_axis)))
        err = relative_errors(value[off_axis], ref).max(axis=1)
        worst = int(np.argmax(err))
        # 2e-3, not 1e-3: at roughness 0 (beta 0.001) with wo and wi 1e-4 from the axis and h = -0.999999,
        # `exact` / 3.4 gives 1.3e-3 on the uniform kernels as well (same float value per row).
        assert err[worst] <= 2e-3, (parametrization, err[worst], worst)


@pytest.mark.parametrize("accuracy,tilt", [("cycles", "4.2"), ("exact", "3.4")])
def test_per_row_kernels_match_the_independent_reference(accuracy, tilt):
    """The per-row kernels against plugin/tests/reference (an independent float64 implementation with
    per-row parameters, as test_chiang_vs_reference runs it on the scalar path): every row its own
    roughness, radial roughness, coat, random, melanin and absorption, the three parametrizations.
    Bound, in the issue's measure: the kernels' 99.9th percentile at most the scalar double path's own
    against this reference plus 2e-5, every element <= 1e-3. On these rows the scalar path itself is
    1.5e-4 to 2.1e-4 (99.9th percentile) and 7.2e-4 (worst, a coat of 0.95) from the reference in `cycles`
    mode; that gap is the scalar path's (see test_chiang_vs_reference), not the kernels'."""
    from reference import chiang_reference as ref

    n = 6000
    wo, wi, h, _ = rows(seed=11, n=n)
    inputs = row_inputs(n=n, seed=12)
    for parametrization in ("color", "melanin", "absorption"):
        closure = hair(parametrization, accuracy, tilt)
        value = closure.eval(wo, wi, h, inputs=inputs)
        pdf = closure.pdf(wo, wi, h, inputs=inputs)
        per_row = [ref.principled_hair_params(parametrization=parametrization, **dict(
            UNIFORM, **{k: (tuple(float(x) for x in v[i]) if v.ndim == 2 else float(v[i])) for k, v in inputs.items()}))
            for i in range(n)]
        params = {key: np.array([p[key] for p in per_row]) for key in per_row[0]}
        rows64 = (wo.astype(np.float64), wi.astype(np.float64), h.astype(np.float64))
        expected = ref.chiang_eval_lobes(params, *rows64, accuracy=accuracy, tilt=tilt).sum(axis=1)
        expected_pdf = ref.chiang_pdf(params, *rows64, accuracy=accuracy, tilt=tilt)
        inputs64 = {k: v.astype(np.float64) for k, v in inputs.items()}
        scalar_value = closure.eval(*rows64, inputs=inputs64)
        scalar_pdf = closure.pdf(*rows64, inputs=inputs64)
        for what, got, scalar, want in (("eval", value, scalar_value, expected), ("pdf", pdf, scalar_pdf, expected_pdf)):
            bound = np.quantile(relative_errors(scalar, want), 0.999) + 2e-5
            assert_close(got, want, f"{parametrization} {what} against the reference", p999_bound=bound)
