# The one version of hairbsdf: read by CMakeLists.txt, pyproject.toml (scikit-build-core's regex
# provider) and hairbsdf.__version__; plugin/tests/test_version.py checks the add-on's literals.
__version__ = "0.1.0"
