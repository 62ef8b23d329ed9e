"""shading_network: hair whose inputs come from node networks the engine evaluates per hit
(docs/shading_vm.md): Melanin from a ColorRamp (B-spline, coloured stops, so the colour ->
float conversion is the luminance) on Hair Info > Intercept, Roughness from a clamped Map Range
on Hair Info > Random.  The swatch's strands, area light and dim world."""

import scene_lib as lib
import swatch

MATERIAL = dict(parametrization="MELANIN", melanin=0.5, melanin_redness=0.5, tint=(1.0, 1.0, 1.0), roughness=0.3,
                radial_roughness=0.3, coat=0.0, ior=1.55, offset=0.0349066, random_color=0.0,
                random_roughness=0.0)
# ColorRamp stops (position, RGB): dark roots, lighter tips
MELANIN_STOPS = [(0.0, (0.85, 0.8, 0.75)), (0.45, (0.45, 0.4, 0.3)), (1.0, (0.15, 0.12, 0.1))]
ROUGHNESS_RANGE = (0.15, 0.45)  # Map Range of Random 0..1 -> this, clamped


def network_material(name):
    mat = lib.hair_material(name, MATERIAL)
    nt = mat.node_tree
    hair = nt.nodes["Hair"]
    info = nt.nodes.new("ShaderNodeHairInfo")
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    cr = ramp.color_ramp
    cr.interpolation = "B_SPLINE"
    while len(cr.elements) < len(MELANIN_STOPS):
        cr.elements.new(0.5)
    for el, (pos, col) in zip(cr.elements, MELANIN_STOPS):
        el.position = pos
        el.color = tuple(col) + (1.0,)
    nt.links.new(info.outputs["Intercept"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], lib.fg.node_input(hair, "Melanin"))
    mr = nt.nodes.new("ShaderNodeMapRange")
    mr.clamp = True
    mr.inputs["To Min"].default_value, mr.inputs["To Max"].default_value = ROUGHNESS_RANGE
    nt.links.new(info.outputs["Random"], mr.inputs["Value"])
    nt.links.new(mr.outputs["Result"], lib.fg.node_input(hair, "Roughness"))
    return mat


def build(scene, cfg):
    w, h = cfg["res"]
    lib.parity_settings(scene, width=w, height=h, spp=cfg["spp"], seed=cfg["seed"], threads=cfg.get("threads", 0),
                        curve_shape="THICK", subdivisions=3, osl=cfg.get("osl", False))
    lib.set_world(scene, (0.08, 0.09, 0.1), 1.0)
    lines, radii = swatch.strands()
    lib.curves_from_polylines(scene, "NetworkSwatch", lines, radii, network_material("NetworkHair"))
    lib.perspective_camera(scene, (0.0, -2.2, 0.05), (0.0, 0.0, 0.0), lens=50.0)
    lib.area_light(scene, (1.2, -1.5, 1.0), (0.0, 0.0, 0.0), energy=60.0, size=0.8)
    return dict(strands=len(lines), material=MATERIAL, melanin_stops=MELANIN_STOPS, roughness_range=ROUGHNESS_RANGE)
