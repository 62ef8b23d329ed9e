"""UI of the HAIRBSDF engine: its own settings (scene.hairbsdf) and panel, Cycles' panels
for the settings the engine reads from scene.cycles / scene.cycles_curves, Blender's
generic panels, small material/world/light panels (Cycles' own ones poll on
CyclesButtonsPanel, i.e. on 'CYCLES' only), and the Hair Model Override panel with its reset
operator (the override's properties and export step live in model_override.py)."""

from __future__ import annotations

import bpy

from .._constants import ENGINE_ID  # re-exported: the engine and panels take it from here
from .._param_docs import BOOL, CHOICE, FLOAT, INT
from ..render import schema_choices, schema_default
from ._common import AUTO, SCENE_SETTINGS, TILT_AUTO
from .model_override import PLUGIN_MODEL, fill_params

# Cycles panels whose settings the engine reads (exported by export_scene.export_integrator).
CYCLES_PANELS = (
    "CYCLES_RENDER_PT_sampling",
    "CYCLES_RENDER_PT_sampling_render",
    "CYCLES_RENDER_PT_sampling_advanced",
    "CYCLES_RENDER_PT_light_paths",
    "CYCLES_RENDER_PT_light_paths_max_bounces",
    "CYCLES_RENDER_PT_film",
    "CYCLES_RENDER_PT_film_transparency",
    "CYCLES_RENDER_PT_film_pixel_filter",
    "CYCLES_RENDER_PT_curves",
)
# Generic panels ('BLENDER_RENDER' in COMPAT_ENGINES) that make no sense here.
GENERIC_EXCLUDE_PREFIXES = ("RENDER_PT_eevee", "RENDER_PT_workbench", "RENDER_PT_simplify", "RENDER_PT_freestyle",
                            "VIEWLAYER_PT_eevee", "RENDER_PT_gpencil", "RENDER_PT_opengl", "RENDER_PT_hydra",
                            "DATA_PT_EEVEE", "EEVEE_", "MATERIAL_PT_gpencil", "VIEWLAYER_PT_freestyle",
                            "MATERIAL_PT_freestyle", "DATA_PT_lightprobe")
# Replaced by HAIRBSDF_LIGHT_PT_light, which shows what the exporter reads.
GENERIC_EXCLUDE = ("DATA_PT_light", "DATA_PT_spot")


def _all_panel_classes():
    seen = set()
    stack = list(bpy.types.Panel.__subclasses__())
    while stack:
        cls = stack.pop()
        if cls in seen:
            continue
        seen.add(cls)
        stack.extend(cls.__subclasses__())
        yield cls


_patched = []  # (cls, had_own_attribute, original value)


def _add_engine(cls):
    own = "COMPAT_ENGINES" in cls.__dict__
    original = cls.__dict__.get("COMPAT_ENGINES")
    engines = getattr(cls, "COMPAT_ENGINES", None)
    if engines is None or ENGINE_ID in engines:
        return
    # A per-class copy: Cycles' panels share one set through CyclesButtonsPanel, which
    # must not change (it would switch on every Cycles panel).
    cls.COMPAT_ENGINES = set(engines) | {ENGINE_ID}
    _patched.append((cls, own, original))


def patch_panels():
    for cls in _all_panel_classes():
        engines = getattr(cls, "COMPAT_ENGINES", None)
        if not engines:
            continue
        name = cls.__name__
        if name in CYCLES_PANELS and "CYCLES" in engines:
            _add_engine(cls)
        elif ("BLENDER_RENDER" in engines and not name.startswith(GENERIC_EXCLUDE_PREFIXES)
              and name not in GENERIC_EXCLUDE):
            _add_engine(cls)


def unpatch_panels():
    while _patched:
        cls, own, original = _patched.pop()
        try:
            if own:
                cls.COMPAT_ENGINES = original
            else:
                del cls.COMPAT_ENGINES
        except Exception:  # pragma: no cover
            pass


# ---------------------------------------------------------------------------- settings

# The engine's settings that are integrator keys of the scene (docs/scene_desc.md): their choices,
# in the scene schema's order, and their defaults are the schema's (its C++ IntegratorSettings);
# an identifier is the scene's name in capitals (the exporter writes it lower-case). A .blend file
# saves an item's position, so the schema's order is part of the file format. Only the prose is
# the UI's: (label, description) per choice; a choice without prose shows its name.
CHOICE_PROSE = {
    "tilt": {
        "4.2": ("Blender 4.2+", "Tilt applied to the view angle (Cycles 4.2 and later)"),
        "3.4": ("Blender 3.4-4.1", "Tilt applied to the light angle (Cycles 3.4 to 4.1)"),
    },
    "accuracy": {
        "cycles": ("Cycles", "Cycles' truncated Bessel series: matches Cycles"),
        "exact": ("Exact", "Exact special functions (differs from Cycles by up to ~5e-3)"),
    },
    "curve_intersector": {
        AUTO: ("Auto", "Sweep, but Embree for grooms too large for Sweep's memory and for curves kept in an object's space "
                        "(docs/scene_desc.md, curve_intersector)"),
        "EMBREE": ("Embree", "Embree's round Catmull-Rom curves, as Cycles traces them"),
        "SWEEP": ("Sweep", "Our exact test of the swept tube over capped-cone proxies: faster, about four times "
                           "the memory of the curves"),
    },
    "huang_sampler": {
        "cycles": ("Cycles", "Cycles' sampler, weight = its energy estimate, pdf 1: Cycles' estimator, so the "
                             "image's expected value is Cycles'"),
        "mixture": ("Mixture", "Lobe mixture with an exact pdf and MIS: converges to the model's own integral, "
                               "which Cycles' sampler does not (multi-bounce differs by ~0.3 %)"),
    },
}


def setting_choices(key: str) -> tuple:
    """EnumProperty items of engine setting `key` (its scene key, _common.SCENE_SETTINGS):
    (identifier, label, description)."""
    prose = CHOICE_PROSE.get(key, {})
    return tuple((name.upper(), *prose.get(name, (name, ""))) for name in schema_choices(SCENE_SETTINGS[key]))


def setting_default(key: str):
    """The scene schema's default of engine setting `key`: an enum's identifier, else the value."""
    default = schema_default(SCENE_SETTINGS[key])
    return default.upper() if isinstance(default, str) else default


class HairBsdfSceneSettings(bpy.types.PropertyGroup):
    threads: bpy.props.IntProperty(
        name="Threads", description="Render threads (0: Blender's Performance > Threads setting, or all cores)",
        default=0, min=0, max=1024)
    tilt: bpy.props.EnumProperty(
        name="Tilt Convention",
        description="Principled Hair cuticle tilt convention (docs/principled_hair.md, section Blender 3.4-4.1)",
        items=(TILT_AUTO,) + setting_choices("tilt"), default=TILT_AUTO[0])
    accuracy: bpy.props.EnumProperty(
        name="Accuracy", description="Special functions of the hair model",
        items=setting_choices("accuracy"), default=setting_default("accuracy"))
    huang_sampler: bpy.props.EnumProperty(
        name="Huang Sampler", description="BSDF sampling of the Huang hair model (docs/huang.md, In the engine)",
        items=setting_choices("huang_sampler"), default=setting_default("huang_sampler"))
    wavefront: bpy.props.BoolProperty(
        name="Wavefront", description="The wavefront path tracer: a tile's paths traced together and their Principled "
        "Hair (Chiang) hits shaded through the float32 SIMD kernels; faster, the same image in expectation. Off: "
        "one path at a time (docs/engine.md, A wavefront engine)", default=setting_default("wavefront"))
    curve_intersector: bpy.props.EnumProperty(
        name="Curve Intersector", description="How rays meet 3D curves (docs/engine.md, Curve intersection)",
        items=setting_choices("curve_intersector"), default=setting_default("curve_intersector"))


class HAIRBSDF_RENDER_PT_settings(bpy.types.Panel):
    bl_label = "hairbsdf"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {ENGINE_ID}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.scene.hairbsdf
        layout.prop(s, "threads")
        layout.prop(s, "tilt")
        layout.prop(s, "accuracy")
        layout.prop(s, "huang_sampler")
        layout.prop(s, "wavefront")
        layout.prop(s, "curve_intersector")


def _node_panel(layout, id_data, output_type, input_name):
    """Cycles' panel_node_draw when importable, else a plain node view."""
    try:
        from cycles.ui import panel_node_draw  # type: ignore
        return panel_node_draw(layout, id_data, output_type, input_name)
    except Exception:
        pass
    if not getattr(id_data, "use_nodes", False):
        layout.prop(id_data, "use_nodes", icon="NODETREE")
        return False
    ntree = id_data.node_tree
    node = ntree.get_output_node("CYCLES") if hasattr(ntree, "get_output_node") else None
    if node is None:
        layout.label(text="No output node")
        return True
    sock = next((s for s in node.inputs if s.name == input_name), None)
    if sock is not None:
        layout.template_node_view(ntree, node, sock)
    return True


class _MaterialPanel:
    """The Material tab's panels of this engine: shown for a (non Grease Pencil) material."""
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"
    COMPAT_ENGINES = {ENGINE_ID}

    @classmethod
    def poll(cls, context):
        mat = context.material
        return mat is not None and not getattr(mat, "grease_pencil", None) and context.engine in cls.COMPAT_ENGINES


class HAIRBSDF_MATERIAL_PT_surface(_MaterialPanel, bpy.types.Panel):
    bl_label = "Surface"

    def draw(self, context):
        mat = context.material
        if not _node_panel(self.layout, mat, "OUTPUT_MATERIAL", "Surface"):
            self.layout.prop(mat, "diffuse_color")


class HAIRBSDF_WORLD_PT_surface(bpy.types.Panel):
    bl_label = "Surface"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "world"
    COMPAT_ENGINES = {ENGINE_ID}

    @classmethod
    def poll(cls, context):
        return context.world is not None and context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        world = context.world
        if not _node_panel(self.layout, world, "OUTPUT_WORLD", "Surface"):
            self.layout.prop(world, "color")


class HAIRBSDF_LIGHT_PT_light(bpy.types.Panel):
    bl_label = "Light"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "data"
    COMPAT_ENGINES = {ENGINE_ID}

    @classmethod
    def poll(cls, context):
        return context.light is not None and context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        light = context.light
        layout = self.layout
        layout.row().prop(light, "type", expand=True)
        layout.use_property_split = True
        col = layout.column()
        col.prop(light, "color")
        col.prop(light, "energy")
        if light.type in ("POINT", "SPOT"):
            col.prop(light, "shadow_soft_size", text="Radius")
            if hasattr(light, "use_soft_falloff"):
                col.prop(light, "use_soft_falloff")
        elif light.type == "SUN":
            col.prop(light, "angle")
        elif light.type == "AREA":
            col.prop(light, "shape")
            sub = col.column(align=True)
            if light.shape in ("SQUARE", "DISK"):
                sub.prop(light, "size")
            else:
                sub.prop(light, "size", text="Size X")
                sub.prop(light, "size_y", text="Y")
            if hasattr(light, "spread"):
                col.prop(light, "spread")
        if light.type == "SPOT":
            col.prop(light, "spot_size")
            col.prop(light, "spot_blend")


class HAIRBSDF_OT_model_override_reset(bpy.types.Operator):
    """Reset the hair model's parameters to their defaults"""

    bl_idname = "hairbsdf.model_override_reset"
    bl_label = "Reset Parameters"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return getattr(context, "material", None) is not None

    def execute(self, context):
        fill_params(context.material.hairbsdf, keep=False)
        return {"FINISHED"}


class HAIRBSDF_MATERIAL_PT_model_override(_MaterialPanel, bpy.types.Panel):
    bl_label = "Hair Model Override"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.material.hairbsdf
        layout.prop(s, "override")
        if s.override == "NONE":
            return
        if s.override == PLUGIN_MODEL:
            layout.prop(s, "plugin_path")
        if s.schema_error:
            box = layout.box()
            box.alert = True
            box.label(text=s.schema_error[:200], icon="ERROR")
            return
        col = layout.column()
        for p in s.params:
            row = col.row()
            row.alert = not p.in_range()
            text = p.name.replace("_", " ").title()
            if p.optional:
                head = row.row(align=True)
                head.prop(p, "use", text="")
                row = head
                row.active = p.use
            prop = {FLOAT: "value", INT: "number", CHOICE: "choice", BOOL: "flag"}.get(p.kind)
            if prop is None:
                prop = "color" if p.max <= 1.0 else "vector"
            row.prop(p, prop, text=text)
        layout.operator(HAIRBSDF_OT_model_override_reset.bl_idname, icon="LOOP_BACK")
        layout.label(text="Replaces each Principled Hair closure; other closures stay.", icon="INFO")


classes = (HairBsdfSceneSettings, HAIRBSDF_RENDER_PT_settings, HAIRBSDF_MATERIAL_PT_surface,
           HAIRBSDF_WORLD_PT_surface, HAIRBSDF_LIGHT_PT_light, HAIRBSDF_OT_model_override_reset,
           HAIRBSDF_MATERIAL_PT_model_override)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.hairbsdf = bpy.props.PointerProperty(type=HairBsdfSceneSettings)
    patch_panels()


def unregister():
    unpatch_panels()
    if hasattr(bpy.types.Scene, "hairbsdf"):
        del bpy.types.Scene.hairbsdf
    for cls in reversed(classes):
        try:
            bpy.utils.unregister_class(cls)
        except RuntimeError:  # pragma: no cover
            pass
