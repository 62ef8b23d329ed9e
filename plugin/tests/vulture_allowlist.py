"""Names that test_dead_code.py's vulture run must not report (vulture's whitelist format: each
line uses a name). Only names that Blender, pytest or a script run inside Blender use, which
vulture cannot see; each with the reason. This file is parsed, never imported."""

_ = None  # vulture only reads the attribute names below

# Blender calls these on registered classes (bpy.types.Panel / Operator / RenderEngine).
_.poll  # Panel.poll / Operator.poll: Blender asks whether to show or enable it
_.draw  # Panel.draw: Blender draws the panel
_.execute  # Operator.execute: Blender runs the operator
_.update_render_passes  # RenderEngine.update_render_passes: Blender asks for the engine's passes

# Class attributes Blender reads when a class is registered.
_.bl_space_type  # Panel: the editor it appears in
_.bl_region_type  # Panel: the region of that editor
_.bl_context  # Panel: the Properties tab
_.bl_options  # Operator: e.g. {"REGISTER", "UNDO"}
_.bl_use_preview  # RenderEngine: renders material previews
_.bl_use_postprocess  # RenderEngine: the compositor runs after it
_.bl_use_shading_nodes_custom  # RenderEngine: keeps Cycles' node editor
_.bl_use_eevee_viewport  # RenderEngine: EEVEE draws the viewport

# bpy.props annotations, read by name (UILayout.prop(settings, "huang_sampler"), the exporter's _get).
_.huang_sampler

# Blender RNA properties that the code sets for Blender to read.
_.use_property_split  # UILayout: label and value in two columns
_.use_property_decorate  # UILayout: the keyframe decorator column
_.alert  # UILayout: draws the row in red
_.use_animated_seed  # scene.cycles: the harness sets the seed itself
_.shading_system  # scene.cycles: SVM or OSL
_.device  # scene.cycles: CPU
_.file_format  # image settings of the render output
_.color_mode  # image settings of the render output
_.color_depth  # image settings of the render output
_.exr_codec  # image settings of the render output
_.use_file_extension  # render output path
_.rotation_mode  # Object (lab/light_tree_toggle.py aims its lights)
_.rotation_quaternion  # Object (lab/light_tree_toggle.py aims its lights)
_.rotation_euler  # Object (the user_scene builder turns its emitters and the glowing quad)

# Used from code that runs inside Blender, passed as a string (blender_tests/test_engine_render.py).
_.request_cancel  # hairbsdf.blender.engine: stops a running render as Esc would

# pytest reads it: hairbsdf.plugins.test_plugin is not a test when imported into a test module.
_.__test__

# Blender RNA properties the library scenes (hairbsdf/compare/scenes) set so that Cycles and our engine
# render with the settings parity needs; Blender reads them, no Python does.
_.blur_glossy
_.caustics_reflective
_.caustics_refractive
_.compute_device_type
_.diffuse_bounces
_.display_device
_.display_method
_.distribution
_.emit_from
_.factor_random
_.filepath_raw
_.film_exposure
_.glossy_bounces
_.hair_length
_.hide_render
_.hide_viewport
_.light_sampling_threshold
_.look
_.min_light_bounces
_.min_transparent_bounces
_.normal_factor
_.sample_clamp_direct
_.sample_clamp_indirect
_.spline_type
_.transform_space
_.transmission_bounces
_.transparent_max_bounces
_.use_adaptive_sampling
_.use_advanced_hair
_.use_border
_.use_curve_mapping
_.use_denoising
_.use_emit_random
_.use_even_distribution
_.use_hair_bspline
_.use_persistent_data
_.use_simplify
_.use_smooth
_.view_transform
_.volume_bounces

# Read by name: runner.load_catalog takes the catalog's DEFAULT_SCENE from its namespace.
_.DEFAULT_SCENE

# Read by libraries outside the repository.
_.binary_location  # selenium's ChromeOptions: ChromeDriver starts this browser (lab/report_picture.py)

# Cut-offs the library scenes read by name from hairbsdf/_blender_versions.py (fiber_gonio.VERSIONS, runpy).
_.HAIR_MODEL_ENUM_FROM
_.WORLD_ALWAYS_NODES_FROM
# inspect.signature reads a function's __signature__ (hairbsdf.zoo's constructors built from their tables).
_.__signature__
# The view layer's pass switches, read by name: getattr(settings, "pass_" + name) for each pass of the
# renderer's table (blender/passes.py).
_.pass_hair_lobes
_.pass_variance
