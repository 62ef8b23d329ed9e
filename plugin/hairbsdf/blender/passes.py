"""Render passes of the HAIRBSDF engine besides Combined.

Blender's own view-layer switches: Data > Z (Depth: camera-space depth of the first hit,
1e10 on the background) and Data > Normal (world-space shading normal of the first hit), both
averaged over the pixel's samples. The engine's own (view_layer.hairbsdf, panel "hairbsdf
Passes" in the View Layer properties):
  Hair Lobes  "Hair R", "Hair TT", "Hair TRT", "Hair TRRT", "Hair TTs", "Hair TRTs": the light
              leaving the camera ray's first hair hit, split by the lobe of that hit (they add up
              to that part of Combined; TTs / TRTs are yan_fur's medulla-scattered lobes, 0 for
              other models; Cycles has no such passes);
  Variance    the variance of each pixel's mean (squared standard error, per channel), for
              noise-aware comparisons.
The passes show as Render Layers outputs in the compositor and in multilayer EXRs.
"""

from __future__ import annotations

import functools

import bpy

from .._constants import ENGINE_ID

# The passes of the renderer's table (_core.render_passes()) that Blender's own view-layer
# switches ask for; each other one is the engine's property `pass_<name>` below.
BLENDER_SWITCHES = {"depth": "use_pass_z", "normal": "use_pass_normal"}
_SOCKET_TYPES = {"RGB": "COLOR", "XYZ": "VECTOR", "Z": "VALUE"}  # a Blender pass's socket, by its channel ids


@functools.cache
def render_passes() -> dict:
    """{pass name: its images [{"key", "blender_name", "channel_ids", "channels"}]}, in the
    renderer's order (plugin/bindings/render_passes.h)."""
    from hairbsdf import _core
    return {p["name"]: p["images"] for p in _core.render_passes()}


class HairBsdfViewLayerSettings(bpy.types.PropertyGroup):
    pass_hair_lobes: bpy.props.BoolProperty(
        name="Hair Lobes", default=False,
        description="Passes Hair R, TT, TRT, TRRT (and yan_fur's TTs, TRTs): the light leaving the first "
                    "hair hit, split by lobe")
    pass_variance: bpy.props.BoolProperty(
        name="Variance", default=False,
        description="Variance of each pixel's mean (squared standard error), for noise-aware comparisons")


def _layer_settings(view_layer):
    return getattr(view_layer, "hairbsdf", None) if view_layer is not None else None


def requested(view_layer) -> list:
    """The integrator's pass names (hairbsdf.render.PASSES) this view layer asks for."""
    if view_layer is None:
        return []
    s = _layer_settings(view_layer)
    out = []
    for name in render_passes():
        switch = BLENDER_SWITCHES.get(name)
        if getattr(view_layer, switch, False) if switch else (s is not None and getattr(s, "pass_" + name)):
            out.append(name)
    return out


def blender_passes(names):
    """[(result key, pass name, channels, chan_id, socket type)] for the requested passes."""
    return [(im["key"], im["blender_name"], im["channels"], im["channel_ids"], _SOCKET_TYPES[im["channel_ids"]])
            for name in names for im in render_passes().get(name, [])]


def register_passes(engine, scene, view_layer):
    """RenderEngine.update_render_passes: the compositor's Render Layers sockets."""
    engine.register_pass(scene, view_layer, "Combined", 4, "RGBA", "COLOR")
    for _, label, channels, chan_id, kind in blender_passes(requested(view_layer)):
        engine.register_pass(scene, view_layer, label, channels, chan_id, kind)


class HAIRBSDF_VIEWLAYER_PT_passes(bpy.types.Panel):
    bl_label = "hairbsdf Passes"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "view_layer"
    COMPAT_ENGINES = {ENGINE_ID}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        view_layer = context.view_layer
        col = layout.column(heading="Include")
        col.prop(view_layer, "use_pass_z", text="Depth")
        col.prop(view_layer, "use_pass_normal", text="Normal")
        col.prop(view_layer.hairbsdf, "pass_hair_lobes")
        col.prop(view_layer.hairbsdf, "pass_variance")


classes = (HairBsdfViewLayerSettings, HAIRBSDF_VIEWLAYER_PT_passes)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.ViewLayer.hairbsdf = bpy.props.PointerProperty(type=HairBsdfViewLayerSettings)


def unregister():
    if hasattr(bpy.types.ViewLayer, "hairbsdf"):
        del bpy.types.ViewLayer.hairbsdf
    for cls in reversed(classes):
        try:
            bpy.utils.unregister_class(cls)
        except RuntimeError:  # pragma: no cover
            pass
