"""Blender side of hairbsdf: the HAIRBSDF render engine and the scene exporter.

In Blender (or the bpy module):
    import hairbsdf.blender
    hairbsdf.blender.register()          # engine 'HAIRBSDF' + UI; unregister() undoes it
    from hairbsdf.blender.export_scene import export_scene
    desc, report = export_scene(bpy.context.evaluated_depsgraph_get())

The installable add-on (plugin/blender_addon) only puts the staged module on sys.path and
calls register().  The native renderer (hairbsdf.render / hairbsdf._render) is imported
lazily by the engine at render time, never here.
"""

from __future__ import annotations

_registered = False


def register():
    """Registers the engine, its settings and panels.  Safe to call twice."""
    global _registered
    if _registered:
        return
    import bpy

    from . import engine, model_override, passes, ui

    for cls in engine.classes:
        bpy.utils.register_class(cls)
    ui.register()
    passes.register()
    model_override.register()
    _registered = True
    if not bpy.app.binary_path:
        # bpy module: classes still registered at interpreter exit make the process hang in
        # Blender's exit handlers (measured with bpy 4.5.15), so unregister first.
        import atexit

        atexit.register(unregister)


def unregister():
    global _registered
    if not _registered:
        return
    import bpy

    from . import engine, model_override, passes, ui

    model_override.unregister()
    passes.unregister()
    ui.unregister()
    for cls in reversed(engine.classes):
        try:
            bpy.utils.unregister_class(cls)
        except RuntimeError:  # pragma: no cover
            pass
    _registered = False


def is_registered() -> bool:
    return _registered


__all__ = ["register", "unregister", "is_registered"]
