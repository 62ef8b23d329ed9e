"""MaterialX documents: hairbsdf.materialx.load evaluates the graph feeding chiang_hair_bsdf
(support nodes, nodegraph interfaces, nodedef instances), export writes the equivalent document
for Principled Hair, and the round trip gives the same closure values within 1e-6."""

import math

import numpy as np
import pytest
from ci import require_module

import hairbsdf
from hairbsdf import materialx as hmx

mx = require_module("MaterialX")


def directions(rng, n=300):
    wo, wi = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    return wo, wi, rng.uniform(-1, 1, n)


def assert_same(a, b, rng):
    wo, wi, h = directions(rng)
    np.testing.assert_allclose(a.eval_lobes(wo, wi, h), b.eval_lobes(wo, wi, h), rtol=1e-6, atol=1e-300)


CASES = [
    {},
    {"parametrization": "melanin", "melanin": 0.4, "melanin_redness": 0.7, "roughness": 0.35, "offset": 0.05},
    {"parametrization": "color", "color": (0.5, 0.3, 0.1), "radial_roughness": 0.6, "ior": 1.7, "offset": -0.03},
    {"parametrization": "absorption", "absorption_coefficient": (0.2, 0.9, 2.0), "roughness": 0.8, "offset": 0.0,
     "random_roughness": 0.3, "random": 0.8},
]


@pytest.mark.parametrize("inputs", CASES)
def test_export_then_load_equals_principled_hair(tmp_path, inputs, rng):
    path = tmp_path / "hair.mtlx"
    text = hmx.export(path, **inputs)
    assert path.read_text() == text and "<chiang_hair_bsdf" in text and "<surfacematerial" in text
    loaded = hmx.load(path)
    blender = hairbsdf.principled_hair(**inputs, tilt="3.4", accuracy="exact")
    assert_same(loaded, blender, rng)
    # ... and a second round trip changes nothing.
    again = tmp_path / "again.mtlx"
    hmx.export(again, loaded)
    assert_same(hmx.load(again), loaded, rng)


def test_round_trip_keeps_tints_and_coat_values(tmp_path, rng):
    tinted = hmx.chiang_hair_bsdf(tint_R=(0.5, 1, 1), tint_TT=(1, 0.25, 1), tint_TRT=(1, 1, 0.1),
                                  absorption_coefficient=(0.2, 0.3, 0.4), cuticle_angle=0.52)
    hmx.export(tmp_path / "t.mtlx", tinted)
    assert_same(hmx.load(tmp_path / "t.mtlx"), tinted, rng)
    # Coat changes R's roughness for eval (exported) and sampling (not expressible: dropped).
    coat = {"coat": 0.4, "roughness": 0.5}
    hmx.export(tmp_path / "c.mtlx", **coat)
    blender = hairbsdf.principled_hair(**coat, tilt="3.4", accuracy="exact")
    wo, wi, h = directions(rng)
    np.testing.assert_allclose(hmx.load(tmp_path / "c.mtlx").eval(wo, wi, h), blender.eval(wo, wi, h), rtol=1e-6)


def test_exported_document_validates_against_the_standard_library(tmp_path):
    hmx.export(tmp_path / "v.mtlx", parametrization="melanin", melanin=0.6)
    doc = mx.createDocument()
    mx.readFromXmlFile(doc, str(tmp_path / "v.mtlx"))
    doc.importLibrary(hmx._stdlib())
    ok, message = doc.validate()
    assert ok, message
    assert doc.getNode("hair_bsdf").getNodeDef().getName() == "ND_chiang_hair_bsdf"


def test_export_from_a_blender_node(tmp_path, rng):
    """A stand-in for bpy's Principled Hair node: sockets with names and default values."""
    from types import SimpleNamespace as NS
    sockets = [NS(name="Melanin", default_value=0.3, is_linked=False),
               NS(name="Roughness", default_value=0.45, is_linked=False),
               NS(name="Tint", default_value=(1.0, 0.8, 0.8, 1.0), is_linked=False),
               NS(name="Offset", default_value=0.02, is_linked=False),
               NS(name="Random Roughness", default_value=0.5, is_linked=True)]  # linked: not a constant
    node = NS(parametrization="MELANIN", model="CHIANG", inputs=sockets)
    assert hmx.principled_inputs_from_node(node) == {"parametrization": "melanin", "melanin": 0.3, "roughness": 0.45,
                                                     "tint": (1.0, 0.8, 0.8), "offset": 0.02}
    hmx.export(tmp_path / "n.mtlx", node)
    blender = hairbsdf.principled_hair(parametrization="melanin", melanin=0.3, roughness=0.45, tint=(1.0, 0.8, 0.8),
                                       offset=0.02, tilt="3.4", accuracy="exact")
    assert_same(hmx.load(tmp_path / "n.mtlx"), blender, rng)
    with pytest.raises(ValueError, match="model 'HUANG' is not allowed"):
        hmx.export(None, NS(parametrization="COLOR", model="HUANG", inputs=[]))


SIMPLE_HAIR = """<?xml version="1.0"?>
<materialx version="1.39">
  <nodedef name="ND_my_hair" node="my_hair">
    <input name="melaninConcentration" type="float" value="0.5" />
    <input name="melaninRedness" type="float" value="0.5" />
    <input name="melaninMix" type="float" value="1.0" />
    <input name="baseColor" type="color3" value="1, 1, 1" />
    <input name="longitudinalRoughness" type="float" value="0.1" />
    <input name="azimuthalRoughness" type="float" value="0.1" />
    <input name="cuticleAngle" type="float" value="0.5" />
    <input name="tint_R" type="color3" value="1, 1, 1" />
    <input name="ior" type="float" value="1.55" />
    <output name="out" type="surfaceshader" />
  </nodedef>
  <nodegraph name="NG_my_hair" nodedef="ND_my_hair">
    <deon_hair_absorption_from_melanin name="melanin" type="vector3">
      <input name="melanin_concentration" type="float" interfacename="melaninConcentration" />
      <input name="melanin_redness" type="float" interfacename="melaninRedness" />
    </deon_hair_absorption_from_melanin>
    <chiang_hair_absorption_from_color name="from_color" type="vector3">
      <input name="color" type="color3" interfacename="baseColor" />
    </chiang_hair_absorption_from_color>
    <mix name="mixed" type="vector3">
      <input name="fg" type="vector3" nodename="melanin" />
      <input name="bg" type="vector3" nodename="from_color" />
      <input name="mix" type="float" interfacename="melaninMix" />
    </mix>
    <chiang_hair_roughness name="rough" type="multioutput">
      <input name="longitudinal" type="float" interfacename="longitudinalRoughness" />
      <input name="azimuthal" type="float" interfacename="azimuthalRoughness" />
    </chiang_hair_roughness>
    <chiang_hair_bsdf name="bsdf" type="BSDF">
      <input name="tint_R" type="color3" interfacename="tint_R" />
      <input name="ior" type="float" interfacename="ior" />
      <input name="roughness_R" type="vector2" nodename="rough" output="roughness_R" />
      <input name="roughness_TT" type="vector2" nodename="rough" output="roughness_TT" />
      <input name="roughness_TRT" type="vector2" nodename="rough" output="roughness_TRT" />
      <input name="cuticle_angle" type="float" interfacename="cuticleAngle" />
      <input name="absorption_coefficient" type="vector3" nodename="mixed" />
    </chiang_hair_bsdf>
    <surface name="shader" type="surfaceshader">
      <input name="bsdf" type="BSDF" nodename="bsdf" />
    </surface>
    <output name="out" type="surfaceshader" nodename="shader" />
  </nodegraph>
  <my_hair name="instance" type="surfaceshader">%s
  </my_hair>
  <surfacematerial name="hair" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="instance" />
  </surfacematerial>
</materialx>
"""


@pytest.mark.parametrize("overrides", [{}, {"melaninMix": 0.3, "baseColor": (0.5, 0.3, 0.1), "cuticleAngle": 0.55,
                                            "longitudinalRoughness": 0.3, "tint_R": (1.0, 0.5, 0.5)}])
def test_load_evaluates_a_nodedef_graph_like_simple_hair(tmp_path, overrides, rng):
    def fmt(v):
        return ", ".join(str(x) for x in v) if isinstance(v, tuple) else str(v)
    types = {"baseColor": "color3", "tint_R": "color3"}
    inputs = "".join(f'\n    <input name="{k}" type="{types.get(k, "float")}" value="{fmt(v)}" />'
                     for k, v in overrides.items())
    path = tmp_path / "my_hair.mtlx"
    path.write_text(SIMPLE_HAIR % inputs)
    loaded = hmx.load(path)
    assert_same(loaded, hmx.simple_hair_default(**overrides), rng)


def test_load_document_level_nodes_and_arithmetic(tmp_path, rng):
    path = tmp_path / "flat.mtlx"
    path.write_text("""<?xml version="1.0"?>
<materialx version="1.39">
  <chiang_hair_roughness name="rough" type="multioutput">
    <input name="longitudinal" type="float" value="0.25" />
  </chiang_hair_roughness>
  <constant name="half" type="float"><input name="value" type="float" value="0.5" /></constant>
  <deon_hair_absorption_from_melanin name="mel" type="vector3" />
  <multiply name="scaled" type="vector3">
    <input name="in1" type="vector3" nodename="mel" />
    <input name="in2" type="float" nodename="half" />
  </multiply>
  <chiang_hair_bsdf name="hair" type="BSDF">
    <input name="roughness_R" type="vector2" nodename="rough" output="roughness_R" />
    <input name="roughness_TRT" type="vector2" nodename="rough" output="roughness_TRT" />
    <input name="absorption_coefficient" type="vector3" nodename="scaled" />
  </chiang_hair_bsdf>
</materialx>
""")
    r = hmx.chiang_hair_roughness(0.25)
    want = hmx.chiang_hair_bsdf(roughness_R=r.roughness_R, roughness_TRT=r.roughness_TRT,
                                absorption_coefficient=tuple(0.5 * hmx.deon_hair_absorption_from_melanin()))
    assert_same(hmx.load(path), want, rng)
    assert hmx.load_inputs(path)["roughness_TT"] == (0.05, 0.05)  # the nodedef default


def test_load_errors_say_where(tmp_path):
    def doc(body):
        path = tmp_path / "e.mtlx"
        path.write_text(f'<?xml version="1.0"?>\n<materialx version="1.39">\n{body}\n</materialx>\n')
        return path

    with pytest.raises(hmx.MaterialXLoadError, match="no chiang_hair_bsdf node"):
        hmx.load(doc('<surface name="s" type="surfaceshader" />'))
    two = doc('<chiang_hair_bsdf name="a" type="BSDF" />\n<chiang_hair_bsdf name="b" type="BSDF" />')
    with pytest.raises(hmx.MaterialXLoadError, match=r"2 chiang_hair_bsdf nodes \(a, b\); pick one with node="):
        hmx.load(two)
    assert hmx.load_inputs(two, node="b")["ior"] == 1.55
    with pytest.raises(hmx.MaterialXLoadError, match=r"node 'n' of category 'noise3d' is not supported"):
        hmx.load(doc('<noise3d name="n" type="float" />\n<chiang_hair_bsdf name="h" type="BSDF">'
                     '<input name="ior" type="float" nodename="n" /></chiang_hair_bsdf>'))
    with pytest.raises(hmx.MaterialXLoadError, match=r"node 'h' \(chiang_hair_bsdf\) input 'ior': cannot read"):
        hmx.load(doc('<chiang_hair_bsdf name="h" type="BSDF"><input name="ior" type="float" value="abc" />'
                     '</chiang_hair_bsdf>'))
    with pytest.raises(hmx.MaterialXLoadError, match="cannot read the MaterialX document"):
        hmx.load(tmp_path / "missing.mtlx")
