"""The MaterialX part of `hairbsdf scenes export` (hairbsdf.compare.portable), on hand-made scene
descriptions: what MaterialX cannot express is listed per material, and the document written for
a scene without limits validates and loads back to Cycles' closure (tilt 3.4, exact functions)."""

import numpy as np
import pytest

from hairbsdf import materialx, principled_hair
from hairbsdf.compare.portable import materialx_limits, write_materialx

HAIR = dict(melanin=0.4, melanin_redness=0.7, tint=(1.0, 0.9, 0.8), roughness=0.3, radial_roughness=0.4, coat=0.0,
            ior=1.55, offset=0.0, random_color=0.0, random_roughness=0.0, random=None)


def desc(*materials, tilt="4.2"):
    return dict(integrator=dict(tilt=tilt), materials=list(materials))


def hair(name="hair", model="CHIANG", **inputs):
    return dict(name=name, closures=[dict(type="principled_hair", weight=(1.0, 1.0, 1.0), model=model,
                                          parametrization="MELANIN", inputs=dict(HAIR, **inputs))])


@pytest.mark.parametrize("material, limit", [
    (hair(coat=0.3), "Coat"),
    (hair(offset=0.035), "the tilt convention"),
    (hair(model="HUANG"), "the Huang model"),
    (hair(random_roughness=0.2), "per-strand Random"),
    (hair(coat={"register": 3}), "Coat"),
    (dict(name="legacy", closures=[dict(type="cycles_hair", weight=(1.0, 1.0, 1.0), component="REFLECTION")]),
     "the legacy Hair BSDF"),
    (dict(hair(), program=dict(code=np.zeros(1, np.int32), constants=np.zeros(1, np.float32), registers=1)),
     "node networks"),
    (dict(name="mix", closures=[dict(hair()["closures"][0], weight=(0.5, 0.5, 0.5)),
                                dict(type="diffuse", weight=(0.5, 0.5, 0.5), color=(0.2, 0.2, 0.2))]),
     "Mix / Add of closures"),
])
def test_limits_are_listed(material, limit):
    limits = materialx_limits(desc(material))[material["name"]]
    assert any(x.startswith(limit) for x in limits), limits


def test_exact_materials_have_no_limits():
    d = desc(hair(), dict(name="floor", closures=[dict(type="diffuse", weight=(1.0, 1.0, 1.0), color=(0.5, 0.5, 0.5))]))
    assert materialx_limits(d) == {"hair": [], "floor": []}
    # Blender 3.4's tilt is chiang_hair_bsdf's: an Offset is then exact
    assert materialx_limits(desc(hair(offset=0.035), tilt="3.4")) == {"hair": []}


def test_document_validates_and_loads_back(tmp_path):
    d = desc(hair(), dict(name="floor", closures=[dict(type="diffuse", weight=(1.0, 1.0, 1.0), color=(0.5, 0.5, 0.5))]),
             dict(name="lamp", closures=[dict(type="emission", weight=(1.0, 1.0, 1.0), color=(1.0, 0.5, 0.25),
                                              strength=2.0)]))
    path = tmp_path / "materials.mtlx"
    write_materialx(d, path)
    text = path.read_text()
    assert "chiang_hair_bsdf" in text and "oren_nayar_diffuse_bsdf" in text and "uniform_edf" in text
    closure = materialx.load(path, node="hair_bsdf")
    inputs = {k: v for k, v in HAIR.items() if k != "random"}
    want = principled_hair(parametrization="melanin", tilt="3.4", accuracy="exact", **inputs)
    rng = np.random.default_rng(3)
    wo, wi, h = rng.normal(size=(64, 3)), rng.normal(size=(64, 3)), rng.uniform(-1, 1, 64)
    np.testing.assert_allclose(closure.eval_lobes(wo, wi, h), want.eval_lobes(wo, wi, h), rtol=1e-9, atol=1e-300)


def test_missing_colours_are_cycles_default_surface(tmp_path):
    """A material without closures and a diffuse without a colour are written with Cycles' default
    surface colour, the one the scene loader gives closures[].color (render/scene.h)."""
    from hairbsdf import _core
    from hairbsdf.render import scene_schema

    grey = _core.DEFAULT_SURFACE_COLOR
    row = next(k for k in scene_schema() if k["path"] == "materials[].closures[].color")
    assert row["default"] == "(" + ", ".join(f"{c:g}" for c in grey) + ")"
    plain = dict(type="diffuse", weight=(1.0, 1.0, 1.0))
    d = desc(dict(name="bare", closures=[]), dict(name="plain", closures=[plain]))
    path = tmp_path / "materials.mtlx"
    write_materialx(d, path)
    text = path.read_text()
    written = ", ".join(repr(float(c)) for c in grey)
    assert text.count(f'value="{written}"') == 2, text


def test_missing_keys_take_the_schemas_defaults():
    """A description without a key reads it as the renderer does: the scene schema's default. Principled Hair's
    Offset defaults to Blender's 2 degrees, so a hair without "offset" is tilted (a limit under tilt 4.2), and a
    description without a tilt has the schema's."""
    from hairbsdf.render import schema_default

    untold = hair()
    del untold["closures"][0]["inputs"]["offset"]
    assert schema_default("materials[].closures[].inputs.offset") != 0.0
    assert any(x.startswith("the tilt convention") for x in materialx_limits(desc(untold))["hair"])
    assert materialx_limits(desc(untold, tilt="3.4")) == {"hair": []}
    assert schema_default("integrator.tilt") == "4.2"
    assert any(x.startswith("the tilt convention") for x in materialx_limits(dict(materials=[untold]))["hair"])


def test_render_settings_fill_the_schemas_defaults():
    from hairbsdf.compare.portable import render_settings
    from hairbsdf.render import schema_default

    d = dict(integrator=dict(samples=4, filter_type="GAUSSIAN", filter_width=1.5, clamp_direct=2.0),
             camera=dict(resolution=(8, 6)), lights=[dict(type="SUN")], world={})
    s = render_settings(d, {}, [0], [0], [4, 5, 0])
    assert s["clamp"] == dict(direct=2.0, indirect=schema_default("integrator.clamp_indirect"))
    assert s["exposure"]["film_exposure"] == schema_default("integrator.exposure")
    assert s["light_sampling"]["multiple_importance_sampling"] == {"SUN_0": schema_default("lights[].use_mis")}
    assert s["curves"] == dict(shape=schema_default("curve_shape"), subdivisions=schema_default("curve_subdivisions"),
                               backface_culling=schema_default("curve_backface_culling"))
