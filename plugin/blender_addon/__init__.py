"""hairbsdf add-on: registers the HAIRBSDF render engine.

A thin wrapper: it puts the staged hairbsdf module (a copy made by scripts/setup in
build/blender_site/current, never an editable install) on sys.path and calls
hairbsdf.blender.register().  Works as a legacy add-on (bl_info, Blender 3.4-4.1 and
later) and as a 4.2+ extension (blender_manifest.toml); install both ways with
scripts/install_blender_addon.

Where the module is looked up, first match wins:
  1. $HAIRBSDF_SITE (a folder containing the hairbsdf package);
  2. the path recorded in _site_path.txt next to this file (written by the installer);
  3. ../../build/blender_site/current when the add-on is used from the repository.
"""

bl_info = {
    "name": "hairbsdf",
    "author": "hairbsdf developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Render > Render Engine > hairbsdf",
    "description": "Hair render engine matching Cycles' Principled Hair",
    "category": "Render",
}

import os
import sys

_HERE = os.path.dirname(os.path.abspath(__file__))
_added_path = None


def _candidate_sites():
    env = os.environ.get("HAIRBSDF_SITE")
    if env:
        yield env
    rec = os.path.join(_HERE, "_site_path.txt")
    if os.path.exists(rec):
        with open(rec) as f:
            path = f.read().strip()
        if path:
            yield path
    yield os.path.normpath(os.path.join(_HERE, "..", "..", "build", "blender_site", "current"))


def _ensure_module_path():
    global _added_path
    tried = []
    for site in _candidate_sites():
        tried.append(site)
        if os.path.isfile(os.path.join(site, "hairbsdf", "__init__.py")):
            if site not in sys.path:
                sys.path.insert(0, site)
                _added_path = site
            return site
    raise ImportError("hairbsdf: the staged module was not found (looked in: %s). Run scripts/setup and "
                      "scripts/install_blender_addon, or set HAIRBSDF_SITE." % ", ".join(tried))


def register():
    _ensure_module_path()
    import hairbsdf.blender

    hairbsdf.blender.register()


def unregister():
    global _added_path
    try:
        import hairbsdf.blender
    except ImportError:
        return
    hairbsdf.blender.unregister()
    if _added_path and _added_path in sys.path:
        sys.path.remove(_added_path)
    _added_path = None
