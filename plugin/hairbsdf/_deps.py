"""Optional dependencies, grouped by the pip extra that installs them. A missing one stops the
command with a message that names the extra; nothing falls back to a weaker substitute."""

import importlib
import sys

# extra -> (import name, pip name)
EXTRAS = {
    "compare": (("OpenImageIO", "OpenImageIO"), ("scipy", "scipy"), ("flip_evaluator", "flip-evaluator"),
                ("matplotlib", "matplotlib>=3.10")),
    "tools": (("scipy", "scipy"), ("matplotlib", "matplotlib")),
    "dask": (("dask", "dask>=2026.8"), ("distributed", "distributed>=2026.8")),
}


class MissingDependency(ImportError):
    pass


def _message(pip_name, extra, what):
    return "%s needs %s: pip install 'hairbsdf[%s]'" % (what, pip_name, extra)


def require(module, extra, what):
    """Imports `module` (e.g. "scipy.stats") or raises MissingDependency naming `extra`."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.split(".")[0]
        pip_name = dict(EXTRAS[extra]).get(top, top)
        raise MissingDependency(_message(pip_name, extra, what)) from exc


def check_extra(extra, what):
    """Raises MissingDependency for the first package of `extra` that does not import."""
    for module, _ in EXTRAS[extra]:
        require(module, extra, what)


def exit_status_for_extra(extra, what):
    """For a command's entry: 0 when every package of `extra` imports, else 1 after printing
    "error: <what> needs <package>: pip install ..." on stderr."""
    try:
        check_extra(extra, what)
    except MissingDependency as exc:
        print("error: %s" % exc, file=sys.stderr)
        return 1
    return 0
