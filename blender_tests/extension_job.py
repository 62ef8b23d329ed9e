"""Installs hairbsdf the way an artist does, in the (fresh) Blender user folders named by
BLENDER_USER_*, enables it, and renders one harness job with the installed package alone.
Run by test_extension.py:

    blender -b --factory-startup --python extension_job.py -- spec.json     (Blender 3.4: legacy zip)
    python -S extension_job.py spec.json                                    (bpy 4.5 / 5.x: extension zip)

spec.json: {package, site_packages (bpy module: the venv's site-packages, added without its .pth
files, so the checkout's editable hairbsdf is invisible), job (blender_job.py's render job, without
scenes_dir: it comes from the installed package), plant_import_error, out}
Writes `out` (JSON): the engine's registration, where hairbsdf was imported from, the render's meta.
"""

import json
import os
import sys


def _argv():
    return sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]


with open(_argv()[0]) as f:
    SPEC = json.load(f)
if SPEC.get("site_packages"):
    sys.path.append(SPEC["site_packages"])

import bpy  # noqa: E402
import addon_utils  # noqa: E402


class _PlantedImportError:
    """A test fault: hairbsdf's native module fails to load as it does on a too old glibc."""

    def find_spec(self, name, path=None, target=None):
        if name == "hairbsdf._core":
            raise ImportError("/lib/x86_64-linux-gnu/libc.so.6: version `GLIBC_2.34' not found "
                              "(required by _core.cpython-311-x86_64-linux-gnu.so)")
        return None


def engines():
    return [getattr(c, "bl_idname", None) for c in bpy.types.RenderEngine.__subclasses__()]


def install(package):
    """Blender's own install path. Returns the add-on's module name."""
    if bpy.app.version >= (4, 2, 0):
        repos = bpy.context.preferences.extensions.repos
        assert any(r.module == "user_default" for r in repos), [r.module for r in repos]
        bpy.ops.extensions.package_install_files(filepath=package, repo="user_default", enable_on_install=True)
        return "bl_ext.user_default.hairbsdf_blender"
    bpy.ops.preferences.addon_install(filepath=package, overwrite=True)
    addon_utils.modules_refresh()
    bpy.ops.preferences.addon_enable(module="hairbsdf_blender")
    return "hairbsdf_blender"


def main():
    out = dict(blender=bpy.app.version_string, user_resources=bpy.utils.resource_path("USER"))
    if SPEC.get("plant_import_error"):
        sys.meta_path.insert(0, _PlantedImportError())
    module = install(SPEC["package"])
    out["module"] = module
    out["enabled"] = bool(addon_utils.check(module)[1])
    out["engine_registered"] = "HAIRBSDF" in engines()
    mod = sys.modules.get(module)
    out["unavailable"] = getattr(mod, "_unavailable", None)
    hb = sys.modules.get("hairbsdf")
    out["hairbsdf_file"] = getattr(hb, "__file__", None)
    if out["engine_registered"] and SPEC.get("job"):
        import hairbsdf
        compare_dir = os.path.join(os.path.dirname(hairbsdf.__file__), "compare")
        sys.path.insert(0, compare_dir)
        import blender_job  # the installed package's copy
        job = dict(SPEC["job"], scenes_dir=os.path.join(compare_dir, "scenes"), sites=[])
        out["job_script"] = blender_job.__file__
        out["render"] = blender_job.do_render(job)
    with open(SPEC["out"], "w") as f:
        json.dump(out, f, indent=1, default=str)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)  # the bpy module can hang at exit with classes registered


main()
