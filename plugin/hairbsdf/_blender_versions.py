"""The Blender versions at which something the exporter, the harness or the library scenes follow changes,
each named once. This module imports nothing (no bpy): the package imports it, and the library scenes, which
run inside Blender without the package, load it by its path (compare/scenes/fiber_gonio.py)."""

# Cycles before 3.6 seeds Chiang's per-hit LCG with hash(x, y) ^ seed (blender/cycles 598483b43, first
# released in 3.6): the exporter reproduces it, the harness gives those Blenders seeds that differ in all bits.
CHIANG_LCG_BEFORE = (3, 6, 0)
# Blender versions before this one cull back faces of 3D curves (their Embree 3 build; 3.6 moved
# to Embree 4, which reports the inner wall to rays starting inside a tube).
CURVE_CULLING_BEFORE = (3, 6, 0)
# ShaderNodeBsdfHairPrincipled has its model enum (CHIANG / HUANG) from 4.0.
HAIR_MODEL_ENUM_FROM = (4, 0, 0)
# Cycles 4.0 changed the lights' semantics (export_lights.py's docstring); 3.x lights are converted.
LIGHTS_4_FROM = (4, 0, 0)
# Cycles picks next-event lights with its light tree from 4.0 (on by default); 3.x has none.
LIGHT_TREE_FROM = (4, 0, 0)
# Material Settings > Emission Sampling from 4.0; 3.x has Multiple Importance (on: both sides).
EMISSION_SAMPLING_FROM = (4, 0, 0)
# `hairbsdf scenes export` needs the bpy module from 4.0 (its USD export).
SCENES_EXPORT_FROM = (4, 0, 0)
# Cycles 5.x renders Huang hair with regenerated energy-compensation tables (32^3, sqrt(mu) axis); measured
# in 5.3 (docs/blender5.md); 5.0 assumed, not checked.
HUANG_GLASS_TABLES_5_FROM = (5, 0, 0)
# From 5.0 a world always renders its node tree (use_nodes is deprecated and ignores False).
WORLD_ALWAYS_NODES_FROM = (5, 0, 0)
# Principled Hair's cuticle tilt applies to the view angle from 4.2, to the light angle before (3.4 to 4.1).
TILT_ON_VIEW_FROM = (4, 2, 0)


def tilt_convention(version) -> str:
    """The Principled Hair tilt convention of a Blender version: '4.2' or '3.4' (docs/principled_hair.md)."""
    return "4.2" if tuple(version) >= TILT_ON_VIEW_FROM else "3.4"
