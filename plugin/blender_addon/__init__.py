"""hairbsdf add-on: registers the HAIRBSDF render engine.

A thin wrapper that finds the hairbsdf package and calls hairbsdf.blender.register(). The same
folder is packaged three ways (docs/blender.md):
  * the extension zip (scripts/build_extension, Blender 4.2+): Blender installs its bundled wheels
    into its own site-packages, so `import hairbsdf` just works;
  * the legacy add-on zip (Blender 3.4-4.1): the wheel's contents ride along in _vendor/;
  * developer mode (scripts/install_blender_addon): the checkout's staged module, whose path the
    installer records in _site_path.txt.

Where the package is looked up, first match wins:
  1. $HAIRBSDF_SITE (a folder containing the hairbsdf package);
  2. the path recorded in _site_path.txt (developer mode);
  3. _vendor/ next to this file (the legacy add-on zip);
  4. an importable hairbsdf (the extension's wheels);
  5. ../../build/blender_site/current when the add-on is used from the repository.
When the package or its native module cannot load (for example a glibc older than the wheel needs),
enabling the add-on prints one line naming the requirement and shows it in the add-on's preferences,
instead of a traceback; the engine is then not registered.
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
import textwrap

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
    yield os.path.join(_HERE, "_vendor")
    yield None  # whatever `import hairbsdf` finds: the extension's wheels
    yield os.path.normpath(os.path.join(_HERE, "..", "..", "build", "blender_site", "current"))


def _importable():
    import importlib.util
    return importlib.util.find_spec("hairbsdf") is not None


def _ensure_module_path():
    global _added_path
    tried = []
    for site in _candidate_sites():
        if site is None:
            tried.append("the installed wheels")
            if _importable():
                return "installed"
            continue
        tried.append(site)
        if os.path.isfile(os.path.join(site, "hairbsdf", "__init__.py")):
            if site not in sys.path:
                sys.path.insert(0, site)
                _added_path = site
            return site
    raise ImportError("hairbsdf: the hairbsdf package was not found (looked in: %s). Install the extension "
                      "built by scripts/build_extension, or run scripts/setup and scripts/install_blender_addon, "
                      "or set HAIRBSDF_SITE." % ", ".join(tried))


_unavailable = None  # why the engine could not be registered, shown in the add-on's preferences


def _preferences_class():
    import bpy

    class HairbsdfAddonPreferences(bpy.types.AddonPreferences):
        bl_idname = __package__ or __name__

        def draw(self, context):
            col = self.layout.column()
            col.label(text="hairbsdf is not available:", icon="ERROR")
            for line in textwrap.wrap(_unavailable or "", 90):
                col.label(text=line)

    return HairbsdfAddonPreferences


def register():
    global _unavailable
    try:
        _ensure_module_path()
        import hairbsdf.blender
    except ImportError as exc:
        # A report naming the requirement, not a traceback (hairbsdf/_platform.py words it).
        _unavailable = str(exc)
        print("hairbsdf: the hairbsdf engine is not available: %s" % _unavailable, file=sys.stderr, flush=True)
        import bpy
        bpy.utils.register_class(_preferences_class())
        return
    _unavailable = None
    hairbsdf.blender.register()


def unregister():
    global _added_path, _unavailable
    if _unavailable is not None:
        import bpy
        cls = getattr(bpy.types, "HairbsdfAddonPreferences", None)
        if cls is not None:
            bpy.utils.unregister_class(cls)
        _unavailable = None
        return
    try:
        import hairbsdf.blender
    except ImportError:
        return
    hairbsdf.blender.unregister()
    if _added_path and _added_path in sys.path:
        sys.path.remove(_added_path)
    _added_path = None
