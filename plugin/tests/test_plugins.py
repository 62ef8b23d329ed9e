"""Hair BSDF plugins (bsdf_core/include/hairbsdf/plugin.h) from Python: load_plugin, the
constructor's schema and validation, the closure API, loading errors, and test_plugin's
verdicts on good and broken plugins. The plugins are compiled here from
bsdf_core/tests/plugins/test_plugin.cpp into tmp dirs (a second each, in parallel)."""

import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from ci import skip_or_fail

import hairbsdf
from hairbsdf import testing

ROOT = Path(__file__).resolve().parents[2]
SOURCE = ROOT / "bsdf_core" / "tests" / "plugins" / "test_plugin.cpp"
VARIANTS = {
    "valid": [],
    "wrong_abi": ["-DTEST_PLUGIN_ABI=999"],
    "no_entry": ["-DTEST_PLUGIN_NO_ENTRY"],
    "null_sample": ["-DTEST_PLUGIN_NULL_SAMPLE"],
    "nan": ["-DTEST_PLUGIN_NAN"],
    "fail": ["-DTEST_PLUGIN_FAIL"],
    "bad_range": ["-DTEST_PLUGIN_BAD_RANGE"],
}

# Small sizes: the battery's statistics on a cheap plugin in about a second.
QUICK = testing.BatteryOptions(theta_panels=64, phi_panels=64, furnace_samples=50_000, consistency_samples=5_000,
                               chi2_samples=100_000, fuzz_samples=5_000)
# Smaller still, for plugins that are meant to fail.
TINY = testing.BatteryOptions(theta_panels=16, phi_panels=16, furnace_samples=10_000, consistency_samples=1_000,
                              chi2_samples=20_000, chi2_bins=(16, 32), fuzz_samples=2_000)


def compiler():
    for name in ("c++", "g++", "clang++"):
        if shutil.which(name):
            return name
    skip_or_fail("no C++ compiler (scripts/setup installs build-essential)")


@pytest.fixture(scope="module")
def plugins(tmp_path_factory):
    out = tmp_path_factory.mktemp("plugins")
    cxx = compiler()
    jobs = {}
    for name, flags in VARIANTS.items():
        target = out / f"test_plugin_{name}.so"
        cmd = [cxx, "-std=c++17", "-O0", "-shared", "-fPIC", "-fvisibility=hidden", f"-I{ROOT / 'bsdf_core' / 'include'}",
               *flags, str(SOURCE), "-o", str(target)]
        jobs[name] = (target, subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True))
    paths = {}
    for name, (target, proc) in jobs.items():
        _, err = proc.communicate()
        assert proc.returncode == 0, f"building {name}: {err}"
        paths[name] = target
    return paths


@pytest.fixture(scope="module")
def ripple(plugins):
    return hairbsdf.load_plugin(plugins["valid"])


def test_a_plain_c_plugin(tmp_path, rng):
    """plugin.h is plain C: a C99 plugin builds pedantically, loads and passes the battery."""
    cc = next((c for c in ("cc", "gcc", "clang") if shutil.which(c)), None)
    if cc is None:
        skip_or_fail("no C compiler (scripts/setup installs build-essential)")
    target = tmp_path / "uniform_c.so"
    cmd = [cc, "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O1", "-shared", "-fPIC",
           f"-I{ROOT / 'bsdf_core' / 'include'}", str(SOURCE.parent / "uniform_plugin.c"), "-o", str(target), "-lm"]
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    plugin = hairbsdf.load_plugin(target)
    assert plugin.name == "uniform_c" and not plugin.has_lobes
    closure = plugin(albedo=0.5)
    lobes = closure.eval_lobes(rng.normal(size=(5, 3)), rng.normal(size=(5, 3)), 0.1)
    np.testing.assert_allclose(lobes[:, 0], 0.5 / (4 * np.pi), rtol=1e-15)  # no lobes: all in R
    assert np.all(lobes[:, 1:] == 0)
    assert hairbsdf.test_plugin(plugin, options=QUICK, verbose=False, albedo=0.5).passed


def fibre(theta, phi):
    return np.array([np.sin(theta), np.cos(theta) * np.cos(phi), np.cos(theta) * np.sin(phi)])


def test_schema_and_constructor(ripple):
    assert ripple.name == "test_ripple"
    assert ripple.abi_version == hairbsdf.PLUGIN_ABI_VERSION == 1
    assert ripple.has_lobes
    assert list(ripple.params) == ["albedo", "ripple"]
    assert ripple.params["albedo"] == hairbsdf.ParamSpec("albedo", "rgb", (0.5, 0.5, 0.5), 0.0, 1.0, "directional albedo")
    assert ripple.params["ripple"].default == 0.5 and ripple.params["ripple"].type == "float"
    assert "ripple (float, default 0.5, range [-1, 1])" in ripple.__doc__
    closure = ripple(albedo=0.25, ripple=-0.5)
    assert isinstance(closure, hairbsdf.Closure)
    assert repr(closure) == "test_ripple(albedo=0.25, ripple=-0.5)"
    assert closure.model_params[0]["params"] == {"albedo": (0.25, 0.25, 0.25), "ripple": -0.5}


def test_values_follow_the_formula_and_closure_api(ripple, rng):
    closure = ripple(albedo=(0.9, 0.5, 0.2), ripple=-0.7)
    n = 200
    wo, wi, h = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), rng.uniform(-1, 1, n)
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    dphi = np.arctan2(wi[:, 2], wi[:, 1]) - np.arctan2(wo[:, 2], wo[:, 1])
    f = np.sqrt(1 - wi[:, 0] ** 2) / math.pi**2
    want = (f * (1 - 0.7 * np.cos(dphi)))[:, None] * np.array([0.9, 0.5, 0.2])
    np.testing.assert_allclose(closure.eval(wo, wi, h), want, rtol=1e-12, atol=1e-15)
    lobes = closure.eval_lobes(wo, wi, h, random=rng.random(n))
    np.testing.assert_allclose(lobes[:, 3], want, rtol=1e-12, atol=1e-15)
    assert np.all(lobes[:, :3] == 0)
    np.testing.assert_allclose(closure.pdf(wo, wi, h), f, rtol=1e-12, atol=1e-15)
    s = closure.sample(wo, h, rng.random((n, 3)))
    assert np.all(s.lobe == 3)
    np.testing.assert_allclose(s.pdf, closure.pdf(wo, s.wi, h), rtol=1e-12)
    np.testing.assert_allclose(closure.albedo(fibre(0.3, 1.0), 0.2), [[0.9, 0.5, 0.2]], rtol=1e-4)
    # OSL-style arithmetic with the built-ins.
    mix = 0.5 * closure + 0.5 * hairbsdf.principled_hair()
    np.testing.assert_allclose(mix.eval(wo, wi, h),
                               0.5 * closure.eval(wo, wi, h) + 0.5 * hairbsdf.principled_hair().eval(wo, wi, h),
                               rtol=1e-12, atol=1e-15)


def test_helpers_work_on_plugin_closures(ripple):
    closure = ripple(ripple=0.8)
    result = testing.chi2_test(closure, fibre(0.4, 0.0), 0.3, samples=100_000, theta_bins=32, phi_bins=64)
    assert result.passed(0.01), result
    assert testing.pdf_integral(closure, fibre(0.4, 0.0), 0.3) == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_allclose(testing.sampled_furnace(closure, fibre(0.4, 0.0), 0.3, samples=100_000), 0.5, atol=5e-3)


@pytest.mark.parametrize("kwargs,error,match", [
    ({"ripple": 1.5}, ValueError, r"ripple=1.5 is out of range; allowed \[-1, 1\]"),
    ({"albedo": (0.5, 1.2, 0.5)}, ValueError, r"albedo: channel g = 1.2 is out of range; allowed \[0, 1\]"),
    ({"albedo": (0.5, 0.5)}, ValueError, r"albedo: expected an RGB triple"),
    ({"ripple": "high"}, TypeError, "ripple: expected a number"),
    ({"ripple": float("nan")}, ValueError, "ripple: must be finite"),
    ({"ripples": 0.1}, TypeError, r"unknown keyword 'ripples' \(did you mean 'ripple'\?\); allowed: albedo, ripple"),
])
def test_parameter_errors_name_the_parameter_and_range(ripple, kwargs, error, match):
    with pytest.raises(error, match=match):
        ripple(**kwargs)


def test_create_failure_is_reported(ripple):
    with pytest.raises(hairbsdf.PluginError, match="create failed: ripple 0.25 is refused"):
        ripple(ripple=0.25)


def test_loading_errors_are_clear(plugins, tmp_path):
    with pytest.raises(hairbsdf.PluginError, match=r"ABI version 999 found, 1 expected"):
        hairbsdf.load_plugin(plugins["wrong_abi"])
    with pytest.raises(hairbsdf.PluginError, match=r"test_plugin_no_entry.so': missing symbol 'hairbsdf_plugin_entry'"):
        hairbsdf.load_plugin(plugins["no_entry"])
    with pytest.raises(hairbsdf.PluginError, match=r"plugin 'test_ripple' \(.*\): missing function 'sample'"):
        hairbsdf.load_plugin(plugins["null_sample"])
    with pytest.raises(hairbsdf.PluginError, match=r"parameter 1 \('ripple'\): the range \[1, -1\] is empty"):
        hairbsdf.load_plugin(plugins["bad_range"])
    with pytest.raises(hairbsdf.PluginError, match="no such file"):
        hairbsdf.load_plugin(tmp_path / "missing.so")
    text = tmp_path / "not_a_library.so"
    text.write_text("hello")
    with pytest.raises(hairbsdf.PluginError, match="cannot load the shared library"):
        hairbsdf.load_plugin(text)
    with pytest.raises(TypeError, match="path: expected a file path"):
        hairbsdf.load_plugin(3)
    assert issubclass(hairbsdf.PluginError, RuntimeError)


def test_a_rebuilt_plugin_loads_anew(plugins, tmp_path):
    """Same path, new file: the new code runs (dlopen alone would return the old library)."""
    import os
    path = tmp_path / "mine.so"
    shutil.copyfile(plugins["valid"], path)
    first = hairbsdf.load_plugin(path)
    assert hairbsdf.load_plugin(path)._library is first._library  # unchanged file: loaded once
    grazing = (fibre(0.0, 0.0), np.array([0.995, np.sqrt(1 - 0.995**2), 0.0]), 0.0)
    assert np.all(np.isfinite(first().eval(*grazing)))
    # "Rebuild" as linkers do: a new file replaces the old one (writing into a loaded library's
    # file in place would change the code under the running process).
    shutil.copyfile(plugins["nan"], tmp_path / "new.so")
    os.replace(tmp_path / "new.so", path)
    second = hairbsdf.load_plugin(path)
    assert np.isnan(second().eval(*grazing)[0, 1])
    assert np.all(np.isfinite(first().eval(*grazing)))  # the old library stays loaded for its closures


def test_battery_passes_a_good_plugin(ripple, capsys):
    result = hairbsdf.test_plugin(ripple, options=QUICK, ripple=-0.4)
    out = capsys.readouterr().out
    assert result.passed, str(result)
    names = [c.name for c in result.checks]
    assert names == ["furnace", "sampled furnace", "weight = eval/pdf", "sample pdf = pdf()", "pdf normalised", "chi2",
                     "fuzz"]
    for name in names:
        assert f"PASS  {name}" in out
    assert "PASSED" in out


def test_battery_reports_nan_and_errors_without_crashing(plugins, capsys):
    nan = hairbsdf.test_plugin(plugins["nan"], options=TINY, verbose=False)
    assert not nan.passed
    assert not nan["fuzz"].passed and "eval not finite" in nan["fuzz"].detail
    assert not nan["furnace"].passed and "not finite" in nan["furnace"].detail
    failing = hairbsdf.test_plugin(plugins["fail"], options=TINY, ripple=-0.5)
    assert not failing.passed and not failing["fuzz"].passed
    assert "FAIL  fuzz" in capsys.readouterr().out


def test_battery_detects_energy_gain_and_a_wrong_pdf():
    """A Python BSDF that reflects 1.2 of the light and one whose pdf is off by 10%."""
    def bright(wo, wi, h):
        return np.repeat((1.2 / (4 * np.pi)) * np.ones(len(wo))[:, None], 3, axis=1)
    result = hairbsdf.test_plugin(hairbsdf.python_bsdf(bright, name="bright"), options=TINY, verbose=False)
    assert not result["furnace"].passed and "exceeds 1.01" in result["furnace"].detail
    assert result["chi2"].passed

    def sample(wo, h, u):
        z = 1 - 2 * u[:, 0]
        r = np.sqrt(1 - z * z)
        wi = np.stack([z, r * np.cos(2 * np.pi * u[:, 1]), r * np.sin(2 * np.pi * u[:, 1])], axis=1)
        return wi, np.full((len(wo), 3), 0.5), np.full(len(wo), 1.1 / (4 * np.pi)), np.zeros(len(wo), np.int32)

    def pdf(wo, wi, h):
        return np.full(len(wo), 1.1 / (4 * np.pi))

    def half(wo, wi, h):
        return np.full((len(wo), 3), 0.5 / (4 * np.pi))
    wrong = hairbsdf.test_plugin(hairbsdf.python_bsdf(half, sample, pdf, name="wrong_pdf"), options=TINY,
                                 verbose=False)
    assert not wrong["pdf normalised"].passed
    assert not wrong["weight = eval/pdf"].passed
