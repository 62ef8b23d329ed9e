"""The options that lab's one-render tools share (profile_render.py, curve_intersectors.py): samples per pixel,
render threads, and a folder of native modules to use instead of the installed ones."""

import importlib.machinery
import importlib.util
import os
import sys


def add_render_arguments(parser, samples_default):
    """--samples (default `samples_default`), --threads (default 1) and --modules DIR."""
    parser.add_argument("--samples", type=int, default=samples_default,
                        help=f"samples per pixel (default {samples_default})")
    parser.add_argument("--threads", type=int, default=1, help="render threads (default 1)")
    parser.add_argument("--modules", default="", help="a folder holding hairbsdf's _core and _render native "
                        "modules to use instead of the installed ones: a profiling build's plugin/ (lab/README.md)")


def use_native_modules(folder, ap):
    """Loads hairbsdf._core and hairbsdf._render from `folder`, before hairbsdf is imported, so that
    the package uses them (its Python files stay the installed ones)."""
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    for name in ("_core", "_render"):
        path = os.path.join(folder, name + suffix)
        if not os.path.isfile(path):
            ap.error(f"--modules: no {name + suffix} in {folder} (build it: lab/README.md, 'A profiling build')")
        spec = importlib.util.spec_from_file_location("hairbsdf." + name, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        sys.modules[spec.name] = module
