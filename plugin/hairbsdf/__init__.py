"""hairbsdf: hair and fur BSDFs that match Blender Cycles' Principled Hair.

    import hairbsdf
    hair = hairbsdf.principled_hair(parametrization="melanin", melanin=0.5)
    value = hair.eval(wo, wi, h)          # (N, 3), includes the cosine factor
    s = hair.sample(wo, h, u)             # s.wi, s.weight, s.pdf, s.lobe

Frames and units: docs/conventions.md in the repository.
"""

from ._platform import load_core
from . import _validate

_core = load_core()
from .closure import LOBES, Closure, SampleResult
from .principled import (PRINCIPLED_HAIR_DEFAULTS, absorption_from_color, absorption_from_melanin,
                         cycles_curve_random, huang_fallback_normal, principled_hair)
from . import materialx
from .materialx import chiang_hair_bsdf, simple_hair_base
from .plugins import (PLUGIN_ABI_VERSION, ParamSpec, PluginConstructor, PluginError, PythonBSDF, load_plugin,
                      python_bsdf, test_plugin)
from . import zoo
from .zoo import (cycles_hair_bsdf, deon_hair, epic_hair, kajiya_kay_hair, make_model, marschner_hair, model_schema,
                  scheuermann_hair, yan_fur, zoo_model_names)

from ._version import __version__


def _installed_dir(name: str) -> str:
    import os
    for base in __path__:  # an editable install lists the source folder and the installed one
        path = os.path.join(base, name)
        if os.path.isdir(path):
            return path
    raise FileNotFoundError("hairbsdf/%s is missing from this installation (reinstall hairbsdf)" % name)


def get_include() -> str:
    """The folder that holds hairbsdf/plugin.h, for building a BSDF plugin (docs/plugins.md)."""
    return _installed_dir("include")


def get_cmake_dir() -> str:
    """The folder of hairbsdfConfig.cmake: cmake -Dhairbsdf_DIR=... then find_package(hairbsdf)."""
    return _installed_dir("cmake")


def set_num_threads(n: int) -> None:
    """Threads used by batch calls (default: all cores)."""
    if not isinstance(n, int) or n < 1:
        raise ValueError("n: the number of threads must be an integer >= 1")
    _core.set_num_threads(n)


def get_num_threads() -> int:
    return _core.get_num_threads()


BATCH_KERNELS = ("best", "avx512", "avx2", "sse2", "scalar")
FLOAT64_POLICIES = ("double", "float32")


def set_batch_kernel(name: str = "best", *, float64: str = "double") -> str:
    """Which code runs batch eval / pdf / sample of a single Chiang closure (docs/simd.md): the
    float32 SIMD kernels on the best instruction set ("best"), on a given one ("avx512", "avx2",
    "sse2"; the best available when this CPU lacks it), or the scalar double path ("scalar", the
    reference). float32 rows go to the kernels; float64 rows stay on the double path
    (float64="double") or are converted to float32 at the boundary (float64="float32", float64
    results). Returns the one now in use."""
    convert = _validate.choice("float64", float64, FLOAT64_POLICIES) == "float32"
    return _core.set_batch_kernel(_validate.choice("name", name, BATCH_KERNELS), convert)


def get_batch_kernel() -> str:
    """The batch kernel in use: "avx512", "avx2", "sse2" or "scalar"."""
    return _core.get_batch_kernel()


SCALAR_MATHS = ("float", "double")


def set_scalar_maths(precision: str = "float") -> str:
    """exp, asin and atan2 of Chiang's scalar path at accuracy "cycles": inlined to float accuracy or
    better ("float", the default; Cycles' kernel computes in float) or glibc's double functions
    ("double", the reference the float32 SIMD kernels are tested against). Accuracy "exact" is
    always double. Process-wide; returns the one now in use."""
    return _core.set_scalar_maths(_validate.choice("precision", precision, SCALAR_MATHS) == "float")


def get_scalar_maths() -> str:
    """exp, asin and atan2 of the scalar path at accuracy "cycles": "float" or "double"."""
    return _core.get_scalar_maths()


__all__ = [
    "Closure", "SampleResult", "LOBES", "principled_hair", "absorption_from_color", "absorption_from_melanin",
    "cycles_curve_random", "chiang_hair_bsdf", "simple_hair_base", "materialx", "set_num_threads",
    "get_num_threads", "set_batch_kernel", "get_batch_kernel", "BATCH_KERNELS", "set_scalar_maths", "get_scalar_maths",
    "SCALAR_MATHS", "PRINCIPLED_HAIR_DEFAULTS", "huang_fallback_normal", "load_plugin", "test_plugin",
    "python_bsdf", "PluginConstructor", "PluginError", "PythonBSDF", "ParamSpec", "PLUGIN_ABI_VERSION",
    "zoo", "kajiya_kay_hair", "epic_hair", "scheuermann_hair", "marschner_hair", "deon_hair", "yan_fur", "cycles_hair_bsdf",
    "make_model", "model_schema", "zoo_model_names", "get_include", "get_cmake_dir", "__version__",
]
