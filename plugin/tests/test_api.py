"""The Python API contract: shapes, broadcasting, dtypes, errors that name the argument,
closure arithmetic, threads and the GIL."""

import threading
import time

import numpy as np
import pytest

import hairbsdf


@pytest.fixture(scope="module")
def hair():
    return hairbsdf.principled_hair(parametrization="melanin", melanin=0.3, coat=0.2)


def directions(rng, n):
    return rng.normal(size=(n, 3))


def test_shapes(hair, rng):
    n = 17
    wo, wi, h, u = directions(rng, n), directions(rng, n), rng.uniform(-1, 1, n), rng.random((n, 3))
    assert hair.eval(wo, wi, h).shape == (n, 3)
    lobes = hair.eval_lobes(wo, wi, h)
    assert lobes.shape == (n, 4, 3)
    np.testing.assert_allclose(lobes.sum(axis=1), hair.eval(wo, wi, h), rtol=1e-12)
    assert hair.pdf(wo, wi, h).shape == (n,)
    s = hair.sample(wo, h, u)
    assert s.wi.shape == (n, 3) and s.weight.shape == (n, 3) and s.pdf.shape == (n,) and s.lobe.shape == (n,)
    assert set(np.unique(s.lobe)) <= {0, 1, 2, 3}
    assert hair.albedo(wo[:2], h[:2]).shape == (2, 3)
    assert hairbsdf.LOBES == ("R", "TT", "TRT", "TRRT+")


def test_broadcasting_and_normalisation(hair, rng):
    wi = directions(rng, 5)
    wo = np.array([0.2, 0.3, 0.9])
    a = hair.eval(wo, wi, 0.25)
    b = hair.eval(np.tile(wo, (5, 1)) * 7.0, wi * 3.0, np.full(5, 0.25))  # lengths do not matter
    np.testing.assert_allclose(a, b, rtol=1e-14)
    assert hair.eval([0, 0, 1], [0, 1, 0], 0.0).shape == (1, 3)  # plain lists


def test_float32_inputs_give_the_same_values(hair, rng):
    """float32 rows of a single Chiang closure run on the float32 batch kernels (docs/simd.md):
    the same values to float precision (test_batch_kernels.py holds them to the issue's bound)."""
    wo, wi, h = directions(rng, 100), directions(rng, 100), rng.uniform(-1, 1, 100)
    wo32, wi32, h32 = wo.astype(np.float32), wi.astype(np.float32), h.astype(np.float32)
    np.testing.assert_allclose(hair.eval(wo32, wi32, h32),
                               hair.eval(wo32.astype(np.float64), wi32.astype(np.float64), h32.astype(np.float64)),
                               rtol=2e-5, atol=1e-9)


@pytest.mark.parametrize("call,arg,value,error,match", [
    ("eval", "wo", np.zeros((4, 2)), ValueError, "wo: shape"),
    ("eval", "wi", np.ones((4, 3), dtype=np.int32), TypeError, "wi: dtype int32"),
    ("eval", "wo", np.ones((4, 3), dtype=complex), TypeError, "wo: dtype complex"),
    ("eval", "wo", np.full((4, 3), np.nan), ValueError, "wo: contains NaN"),
    ("eval", "wi", np.zeros((4, 3)), ValueError, "wi: contains a zero-length"),
    ("eval", "h", np.full(4, np.inf), ValueError, "h: contains NaN or Inf"),
    ("eval", "h", np.full(4, 1.5), ValueError, r"h: values must lie in \[-1, 1\]"),
    ("eval", "h", np.zeros(3), ValueError, "h: 3 rows do not match"),
    ("sample", "u", np.full((4, 3), 1.2), ValueError, r"u: values must lie in \[0, 1\]"),
    ("sample", "u", "abc", TypeError, "u: expected an array"),
])
def test_bad_arrays_name_the_argument(hair, call, arg, value, error, match):
    args = {"wo": np.ones((4, 3)), "wi": np.ones((4, 3)), "h": np.zeros(4), "u": np.full((4, 3), 0.5)}
    args[arg] = value
    with pytest.raises(error, match=match):
        if call == "eval":
            hair.eval(args["wo"], args["wi"], args["h"])
        else:
            hair.sample(args["wo"], args["h"], args["u"])


def test_bad_node_inputs_name_the_parameter():
    with pytest.raises(TypeError, match="'rougness'.*did you mean 'roughness'"):
        hairbsdf.principled_hair(rougness=0.3)
    assert repr(hairbsdf.principled_hair(model="huang")).startswith("principled_hair(model='huang'")  # issue 6
    with pytest.raises(ValueError, match="model='marschner' is not allowed"):
        hairbsdf.principled_hair(model="marschner")
    with pytest.raises(ValueError, match="parametrization='colour' is not allowed"):
        hairbsdf.principled_hair(parametrization="colour")
    with pytest.raises(ValueError, match="accuracy='fast'"):
        hairbsdf.principled_hair(accuracy="fast")
    with pytest.raises(ValueError, match="tilt='4.5'"):
        hairbsdf.principled_hair(tilt="4.5")
    with pytest.raises(ValueError, match="melanin: must be finite"):
        hairbsdf.principled_hair(melanin=float("nan"))
    with pytest.raises(TypeError, match="roughness: expected a number"):
        hairbsdf.principled_hair(roughness="0.3")
    with pytest.raises(ValueError, match="color: expected an RGB triple"):
        hairbsdf.principled_hair(color=(1, 2))
    with pytest.raises(ValueError, match="tint: contains NaN"):
        hairbsdf.principled_hair(tint=(1, float("inf"), 1))


def test_core_reads_node_inputs_by_the_scene_schemas_rows():
    """_core.principled_chiang / principled_huang take the node's inputs as a dict, read by the scene
    schema's input rows (the one table of Principled Hair's inputs); an unknown key names its path."""
    from hairbsdf import _core
    from hairbsdf.principled import HUANG_OPTION_DEFAULTS, HUANG_OPTIONS, PARAMETRIZATIONS

    given = {"absorption_coefficient": (1.0, 2.0, 3.0), "ior": 1.7, "offset": 0.1}
    chiang = _core.principled_chiang((PARAMETRIZATIONS["absorption"], given, 0, 0)).model_params()[0]
    np.testing.assert_array_equal(chiang["sigma_a"], given["absorption_coefficient"])
    assert (chiang["eta"], chiang["tilt"]) == (1.7, 0.1)
    options = {name: HUANG_OPTIONS[name]["choices"].index(value) if HUANG_OPTIONS[name]["type"] == "choice" else value
               for name, value in HUANG_OPTION_DEFAULTS.items()}
    huang = _core.principled_huang(PARAMETRIZATIONS["absorption"], dict(given, aspect_ratio=0.7), options)
    huang = huang.model_params()[0]
    np.testing.assert_array_equal(huang["sigma_a"], given["absorption_coefficient"])
    assert (huang["eta"], huang["offset"], huang["aspect_ratio"]) == (1.7, 0.1, 0.7)
    with pytest.raises(ValueError, match=r"inputs\['rougness'\]: not a Principled Hair input; allowed: color, "):
        _core.principled_chiang((0, {"rougness": 0.3}, 0, 0))


def test_core_dict_readers_name_an_unknown_key_and_the_allowed_ones():
    """The bindings read a dict into a struct by table rows with one helper (module.cpp's read_by_rows): an unknown
    key is an error naming it and the allowed names; Huang's options not given take their table's defaults."""
    from hairbsdf import _core
    from hairbsdf.principled import HUANG_OPTIONS, PARAMETRIZATIONS

    with pytest.raises(ValueError, match=r"chiang_hair_bsdf\['bogus'\]: not an input; allowed: .*absorption_coefficient"):
        _core.materialx_chiang({"bogus": 1.0})
    with pytest.raises(ValueError, match=r"options\['sampel'\]: not an option of .*; allowed: accuracy, sampler, "):
        _core.principled_huang(PARAMETRIZATIONS["color"], {}, {"sampel": 0})
    with pytest.raises(ValueError, match=r"sampler=5: must be in \[0, 1\]"):
        _core.principled_huang(PARAMETRIZATIONS["color"], {}, {"sampler": 5})
    with pytest.raises(ValueError, match=r"color_roughness=2: must be in \[0, 1\]"):
        _core.principled_huang(PARAMETRIZATIONS["color"], {}, {"color_roughness": 2})
    defaults = _core.principled_huang(PARAMETRIZATIONS["color"], {}, {}).model_params()[0]
    assert {name: defaults[name] for name in HUANG_OPTIONS if name in defaults} == {
        name: row["default"] for name, row in HUANG_OPTIONS.items() if name in defaults}


def test_blender_enum_names_are_accepted():
    a = hairbsdf.principled_hair(parametrization="MELANIN").eval([0, 0, 1], [0, 1, 0], 0.1)
    b = hairbsdf.principled_hair(parametrization="melanin").eval([0, 0, 1], [0, 1, 0], 0.1)
    np.testing.assert_array_equal(a, b)


def test_out_of_range_inputs_follow_cycles_clamps():
    """Roughness clamps to [0.001, 1] and Coat to [0, 1] as in Cycles (docs/principled_hair.md)."""
    wo, wi = [0.2, 0.1, 0.9], [-0.3, 0.5, 0.8]
    np.testing.assert_array_equal(hairbsdf.principled_hair(roughness=5.0).eval(wo, wi, 0.3),
                                  hairbsdf.principled_hair(roughness=1.0).eval(wo, wi, 0.3))
    np.testing.assert_array_equal(hairbsdf.principled_hair(roughness=-1.0).eval(wo, wi, 0.3),
                                  hairbsdf.principled_hair(roughness=0.0).eval(wo, wi, 0.3))
    np.testing.assert_array_equal(hairbsdf.principled_hair(coat=3.0).eval(wo, wi, 0.3),
                                  hairbsdf.principled_hair(coat=1.0).eval(wo, wi, 0.3))


def test_ior_below_one_gives_zero_not_nan(rng):
    """Where Cycles' formula is NaN (sqrt(eta^2 - sin^2 theta_o) < 0) the value is 0."""
    hair = hairbsdf.principled_hair(ior=0.8)
    wo = np.array([[0.95, 0.1, 0.3]])  # sin theta_o = 0.95 > eta
    assert np.all(hair.eval(wo, directions(rng, 1), 0.3) == 0)
    assert np.all(np.isfinite(hair.eval(directions(rng, 1000), directions(rng, 1000), rng.uniform(-1, 1, 1000))))


def test_closure_sums_weight_and_mix(rng):
    a = hairbsdf.principled_hair(melanin=0.2, parametrization="melanin")
    b = hairbsdf.principled_hair(melanin=0.9, parametrization="melanin", roughness=0.6)
    mix = 0.25 * a + (0.5, 0.75, 1.0) * b
    assert mix.weights == [(0.25, 0.25, 0.25), (0.5, 0.75, 1.0)]
    wo, wi, h = directions(rng, 50), directions(rng, 50), rng.uniform(-1, 1, 50)
    np.testing.assert_allclose(mix.eval(wo, wi, h), 0.25 * a.eval(wo, wi, h) + np.array([0.5, 0.75, 1.0]) * b.eval(wo, wi, h),
                               rtol=1e-12)
    sa, sb = 0.25, 0.75  # |average(weight)|
    np.testing.assert_allclose(mix.pdf(wo, wi, h), (sa * a.pdf(wo, wi, h) + sb * b.pdf(wo, wi, h)) / (sa + sb), rtol=1e-12)
    s = mix.sample(wo, h, rng.random((50, 3)))
    ok = s.lobe >= 0
    np.testing.assert_allclose(s.weight[ok], mix.eval(wo[ok], s.wi[ok], h[ok]) / mix.pdf(wo[ok], s.wi[ok], h[ok])[:, None],
                               rtol=1e-9)
    assert "principled_hair" in repr(mix)
    with pytest.raises(TypeError):
        _ = a + 1.0


def test_closure_sum_holds_at_most_sixteen_closures(rng):
    """ClosureSum's shading point has a fixed capacity (no allocation per call): 16 closures evaluate, a 17th is a
    clear error naming the limit."""
    a = hairbsdf.principled_hair()
    total = a
    for _ in range(15):
        total = total + a
    wo, wi, h = directions(rng, 5), directions(rng, 5), rng.uniform(-1, 1, 5)
    np.testing.assert_allclose(total.eval(wo, wi, h), 16 * a.eval(wo, wi, h), rtol=1e-12)
    with pytest.raises(ValueError, match="at most 16 closures, got 17"):
        _ = total + a


def test_batch_equals_row_by_row_and_threads_do_not_change_results(rng):
    hair = hairbsdf.principled_hair(offset=0.05, random_roughness=0.3, random=0.7)
    n = 50_000
    wo, wi, h, u = directions(rng, n), directions(rng, n), rng.uniform(-1, 1, n), rng.random((n, 3))
    try:
        hairbsdf.set_num_threads(1)
        one = (hair.eval(wo, wi, h), hair.sample(wo, h, u).weight)
        hairbsdf.set_num_threads(2)
        two = (hair.eval(wo, wi, h), hair.sample(wo, h, u).weight)
    finally:
        hairbsdf.set_num_threads(2)
    np.testing.assert_array_equal(one[0], two[0])
    np.testing.assert_array_equal(one[1], two[1])
    rows = np.array([hair.eval(wo[i], wi[i], h[i])[0] for i in range(0, n, 997)])
    np.testing.assert_allclose(rows, one[0][::997], rtol=1e-6)
    with pytest.raises(ValueError, match="threads"):
        hairbsdf.set_num_threads(0)


def test_batch_calls_release_the_gil(rng):
    """While a long batch eval runs in a thread, Python code keeps running."""
    hair = hairbsdf.principled_hair()
    n = 2_000_000
    wo, wi, h = directions(rng, n), directions(rng, n), rng.uniform(-1, 1, n)
    hairbsdf.set_num_threads(1)
    try:
        worker = threading.Thread(target=hair.eval, args=(wo, wi, h))
        ticks = 0
        start = time.perf_counter()
        worker.start()
        time.sleep(0.05)  # let the worker get into C++
        while worker.is_alive():
            ticks += 1
            time.sleep(0.001)
        elapsed = time.perf_counter() - start
    finally:
        hairbsdf.set_num_threads(2)
    assert elapsed > 0.1, "the batch was too quick to tell"
    assert ticks > 20, f"only {ticks} ticks of Python ran during a {elapsed:.2f} s batch"


def test_absorption_helpers_match_node_semantics():
    np.testing.assert_allclose(hairbsdf.absorption_from_color((0.5, 0.3, 0.1), 0.3), (0.013857, 0.041806, 0.152910),
                               rtol=5e-5)
    sigma = hairbsdf.absorption_from_melanin(0.8, 1.0)
    np.testing.assert_allclose(sigma, 1.6094379 * np.array([0.343, 0.733, 1.924]), rtol=1e-6)
    tinted = hairbsdf.absorption_from_melanin(0.8, 1.0, tint=(0.5, 0.3, 0.1))
    np.testing.assert_allclose(tinted - sigma, (0.013857, 0.041806, 0.152910), rtol=5e-5)
    assert hairbsdf.cycles_curve_random(0) == pytest.approx(0.8603127598762512)
    with pytest.raises(TypeError, match="curve_index"):
        hairbsdf.cycles_curve_random(1.5)
