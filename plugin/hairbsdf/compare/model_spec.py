"""`--model` of hairbsdf compare: which hair model our engine renders in place of Principled Hair.

    NAME[:MAPPING.py]              a zoo model (kajiya_kay, epic, scheuermann, marschner, deon, yan_fur)
    plugin:PATH[:MAPPING.py]       a BSDF plugin library (docs/plugins.md)

MAPPING.py defines `map_inputs(inputs: dict) -> dict`: a Principled Hair node's inputs (the keys of
docs/scene_desc.md's principled_hair `inputs` plus `model` and `parametrization`) -> the model's
parameters. Without it the model's defaults are used. The plugin is never loaded here: only the
render processes load it, so a plugin that crashes fails its own renders, not the harness.
"""

from __future__ import annotations

import os


class ModelSpecError(ValueError):
    pass


def parse_model_spec(text: str) -> dict:
    """{"model", "path" (plugin), "mapping" (or None), "label"} with absolute paths that exist."""
    from hairbsdf.zoo import PLUGIN_MODEL, zoo_model_names

    names = zoo_model_names()
    plugin_prefix = PLUGIN_MODEL + ":"
    rest = text
    mapping = None
    if rest.endswith(".py") and ":" in rest:
        rest, mapping = rest.rsplit(":", 1)
    if rest.startswith(plugin_prefix):
        model, path = PLUGIN_MODEL, rest[len(plugin_prefix):]
        if not path:
            raise ModelSpecError("%sPATH needs the path of the plugin library" % plugin_prefix)
        path = os.path.abspath(path)
        if not os.path.isfile(path):
            raise ModelSpecError("plugin library %s: no such file" % path)
    elif rest in names:
        model, path = rest, None
    else:
        raise ModelSpecError("%r is not a model; use one of %s, or %sPATH[:mapping.py]"
                             % (text, ", ".join(names), plugin_prefix))
    if mapping is not None:
        mapping = os.path.abspath(mapping)
        if not os.path.isfile(mapping):
            raise ModelSpecError("mapping %s: no such file" % mapping)
    label = plugin_prefix + os.path.basename(path) if model == PLUGIN_MODEL else model
    if mapping:
        label += " (mapping %s)" % os.path.basename(mapping)
    return dict(model=model, path=path, mapping=mapping, label=label)
