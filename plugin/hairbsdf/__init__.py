"""hairbsdf: hair and fur BSDFs that match Blender Cycles' Principled Hair.

    import hairbsdf
    hair = hairbsdf.principled_hair(parametrization="melanin", melanin=0.5)
    value = hair.eval(wo, wi, h)          # (N, 3), includes the cosine factor
    s = hair.sample(wo, h, u)             # s.wi, s.weight, s.pdf, s.lobe

Frames and units: docs/conventions.md in the repository.
"""

from ._platform import load_core

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


__all__ = [
    "Closure", "SampleResult", "LOBES", "principled_hair", "absorption_from_color", "absorption_from_melanin",
    "cycles_curve_random", "chiang_hair_bsdf", "simple_hair_base", "materialx", "set_num_threads",
    "get_num_threads", "PRINCIPLED_HAIR_DEFAULTS", "huang_fallback_normal", "load_plugin", "test_plugin",
    "python_bsdf", "PluginConstructor", "PluginError", "PythonBSDF", "ParamSpec", "PLUGIN_ABI_VERSION",
    "zoo", "kajiya_kay_hair", "epic_hair", "scheuermann_hair", "marschner_hair", "deon_hair", "yan_fur", "cycles_hair_bsdf",
    "make_model", "model_schema", "zoo_model_names", "get_include", "get_cmake_dir", "__version__",
]
