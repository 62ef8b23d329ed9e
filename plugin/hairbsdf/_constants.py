"""Names shared by the Blender side, the harness and scripts/install_blender_addon. This module imports
nothing (no bpy, no _core), so each of them can read it: the package imports it, the install script
runs it with runpy, and the harness passes its values to the job script in job.json."""

ENGINE_ID = "HAIRBSDF"  # the render engine's bl_idname (`blender -E ...`); ui.py re-exports it
