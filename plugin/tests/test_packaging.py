"""What the wheel promises, checked on the installed package: one version everywhere, the
extras and their messages, the glibc requirement, the plugin headers and the package data.
The wheel itself, installed outside the checkout: blender_tests/test_wheel.py."""

import ast
import importlib.metadata
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import hairbsdf
from hairbsdf import _deps

ROOT = Path(__file__).resolve().parents[2]
ADDON = ROOT / "plugin" / "blender_addon"


def run_py(code, *args):
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=120)


# --------------------------------------------------------------------------- one version

def source_version():
    text = (ROOT / "plugin" / "hairbsdf" / "_version.py").read_text()
    return re.search(r'^__version__ = "([0-9]+\.[0-9]+\.[0-9]+)"$', text, re.M).group(1)


def test_version_python_and_metadata():
    assert hairbsdf.__version__ == source_version()
    assert importlib.metadata.version("hairbsdf") == source_version()


def test_version_addon_literals():
    """bl_info and the manifest need literals; they must equal hairbsdf/_version.py."""
    tree = ast.parse((ADDON / "__init__.py").read_text())
    bl_info = next(ast.literal_eval(n.value) for n in tree.body if isinstance(n, ast.Assign)
                   and any(getattr(t, "id", None) == "bl_info" for t in n.targets))
    manifest = tomllib.loads((ADDON / "blender_manifest.toml").read_text())
    assert ".".join(map(str, bl_info["version"])) == source_version(), "bl_info['version'] != _version.py"
    assert manifest["version"] == source_version(), "blender_manifest.toml version != _version.py"
    assert manifest["license"] == ["SPDX:GPL-3.0-or-later"]
    assert "GNU GENERAL PUBLIC LICENSE" in (ROOT / "LICENSE").read_text()[:200]


def test_version_cmake_reads_the_one_source():
    text = (ROOT / "CMakeLists.txt").read_text()
    assert "plugin/hairbsdf/_version.py" in text and "project(hairbsdf VERSION ${HAIRBSDF_VERSION}" in text
    assert "0.1.0" not in text


def test_version_command():
    r = subprocess.run([sys.executable, "-m", "hairbsdf.cli", "--version"], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.strip() == "hairbsdf " + source_version()


# --------------------------------------------------------------------------- extras

def test_extras_match_pyproject():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    for name, pkgs in _deps.EXTRAS.items():
        assert sorted(p for _, p in pkgs) == sorted(extras[name]), name


BLOCK = "import sys; sys.modules[%r] = None; "


@pytest.mark.parametrize("module", ["scipy", "OpenImageIO", "flip_evaluator", "matplotlib"])
def test_compare_without_a_dependency_names_the_extra(module, tmp_path):
    r = run_py(BLOCK % module + "from hairbsdf.cli import main; sys.exit(main(sys.argv[1:]))",
               "compare", "--scene", "swatch", "--ci", "--out", str(tmp_path))
    assert r.returncode == 1, r.stderr
    assert "hairbsdf[compare]" in r.stderr and module.split("_")[0].lower() in r.stderr.lower()


def test_student_t_tail_needs_scipy():
    """The Welch test's tail: no normal-tail substitute without SciPy."""
    r = run_py(BLOCK % "scipy" + "from hairbsdf.compare import metrics; metrics.t_sf([2.0], [3.0])")
    assert r.returncode != 0 and "MissingDependency" in r.stderr and "hairbsdf[compare]" in r.stderr


def test_plot_without_matplotlib_names_the_extra(tmp_path):
    r = run_py(BLOCK % "matplotlib" + "from hairbsdf.cli import main; sys.exit(main(sys.argv[1:]))",
               "plot", "principled_hair()", "--out", str(tmp_path))
    assert r.returncode == 1 and "hairbsdf[tools]" in r.stderr, r.stderr


# --------------------------------------------------------------------------- platform

def test_old_glibc_names_the_requirement():
    r = run_py("import os; os.confstr = lambda name: 'glibc 2.31'; import hairbsdf")
    assert r.returncode != 0 and "glibc >= 2.34" in r.stderr and "glibc 2.31" in r.stderr, r.stderr


def test_broken_native_module_names_the_requirement():
    r = run_py("import sys; sys.modules['hairbsdf._core'] = None; import hairbsdf")
    assert r.returncode != 0 and "Linux x86-64 with glibc >= 2.34" in r.stderr, r.stderr


# --------------------------------------------------------------------------- package contents

def test_plugin_headers_and_cmake_config():
    inc, cmake_dir = Path(hairbsdf.get_include()), Path(hairbsdf.get_cmake_dir())
    assert (inc / "hairbsdf" / "plugin.h").read_bytes() == \
        (ROOT / "bsdf_core" / "include" / "hairbsdf" / "plugin.h").read_bytes()
    assert (cmake_dir / "hairbsdfConfig.cmake").is_file() and (cmake_dir / "hairbsdfConfigVersion.cmake").is_file()
    assert 'set(PACKAGE_VERSION "%s")' % source_version() in (cmake_dir / "hairbsdfConfigVersion.cmake").read_text()


def test_package_data():
    from hairbsdf.compare.runner import default_thresholds, load_catalog, scenes_dir
    catalog, default = load_catalog()
    assert default in catalog and all((scenes_dir() / (m["module"] + ".py")).is_file() for m in catalog.values())
    assert default_thresholds().is_file()
    lic = Path(hairbsdf.__file__).parent / "licenses"
    assert {"embree.copyright", "tbb.copyright", "Apache-2.0.txt"} <= {p.name for p in lic.iterdir()}
