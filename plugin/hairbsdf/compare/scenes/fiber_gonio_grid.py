"""fiber_gonio (harness scene): a grid of straight strands at several orientations, one
orthographic camera and one delta sun per variant.  Direct light only, 1 spp at the pixel
centre (Blackman-Harris of width 0.01, see bsdf_check/README.md), so every covered pixel is
one BSDF evaluation and the render is noise-free.  The single-strand builder of the BSDF
check (fiber_gonio.py) is untouched; its helpers are reused.

Only the strands' middles are compared: the harness drops pixels within r|sin e| + 2 px of a
projected strand end (the open tube ends, where the ray sees the end circle edge-on), using
the "gonio_roi" entry of the build info.  Strands are fat (r = 0.2 cell) so that a pixel
covers little of h: 1 spp with a 0.01-px filter still jitters the sample by up to 0.005 px.

Camera frame = world frame: the camera looks along -Z (wo = +Z), image x = +X, image y = +Y.
Strand k has tangent t = (cos e cos a, cos e sin a, sin e): e is its inclination to the
image plane, so theta_o = e.  The 4 x 3 strands sit in a 4 x 3 grid of unit cells; each is
shifted along the view direction (which leaves its image position unchanged) until no strand
lies in another's shadow for the variant's sun (checked here, geometrically).
"""

import math

import bpy  # noqa: F401  (mathutils needs bpy first in module mode)
from mathutils import Vector

import fiber_gonio as fg
import scene_lib as lib

ELEVATIONS = (-50.0, -15.0, 20.0, 55.0)   # theta_o of the strands (columns)
AZIMUTHS = (15.0, 75.0, 135.0)            # in-plane angle of the projected axis (rows)
RADIUS = 0.2
PROJECTED_LENGTH = 0.74
SUNS = {  # direction towards the sun, camera/world frame
    "front": (0.35, 0.45, 0.82),
    "back": (-0.30, 0.25, -0.92),
    "side": (0.90, -0.10, 0.42),
}
SUN_STRENGTH = 2.0

MATERIALS = [
    dict(parametrization="COLOR", color=(0.017513, 0.005763, 0.002059), roughness=0.3, radial_roughness=0.3,
         coat=0.0, ior=1.55, offset=0.035),
    dict(parametrization="MELANIN", melanin=0.8, melanin_redness=1.0, tint=(1.0, 1.0, 1.0), roughness=0.2,
         radial_roughness=0.4, coat=0.0, ior=1.55, offset=0.04, random_color=0.3, random_roughness=0.2),
    dict(parametrization="MELANIN", melanin=0.2, melanin_redness=0.3, tint=(0.9, 0.7, 0.6), roughness=0.45,
         radial_roughness=0.3, coat=0.15, ior=1.7, offset=-0.03),
    dict(parametrization="ABSORPTION", absorption_coefficient=(0.245531, 0.52, 1.365), roughness=0.3,
         radial_roughness=0.3, coat=0.0, ior=1.55, offset=0.02),
    dict(parametrization="ABSORPTION", absorption_coefficient=(0.05, 0.08, 0.12), roughness=0.25,
         radial_roughness=0.5, coat=0.0, ior=1.55, offset=0.05),
    dict(parametrization="COLOR", color=(0.8, 0.6, 0.4), roughness=0.6, radial_roughness=0.3, coat=0.3,
         ior=1.3, offset=0.05),
]


# Huang variants ("huang_front", ...; Blender 4.x): circular and elliptical fibres (the ellipse
# follows the Curves' default minimum-twist normals), lobe factors, near field (camera rays).
# Cycles' Huang eval is stochastic, so these variants are compared statistically (noisy kind).
HUANG_MATERIALS = [
    dict(model="HUANG", parametrization="COLOR", color=(0.017513, 0.005763, 0.002059), roughness=0.3, ior=1.55,
         offset=0.035, aspect_ratio=1.0),
    dict(model="HUANG", parametrization="MELANIN", melanin=0.3, melanin_redness=0.5, tint=(1.0, 1.0, 1.0),
         roughness=0.2, ior=1.55, offset=0.04, random_roughness=0.2, aspect_ratio=0.85),
    dict(model="HUANG", parametrization="ABSORPTION", absorption_coefficient=(0.1, 0.25, 0.6), roughness=0.4,
         ior=1.45, offset=0.02, aspect_ratio=0.6, reflection=0.8, transmission=1.2, secondary_reflection=0.5),
    dict(model="HUANG", parametrization="COLOR", color=(0.8, 0.6, 0.4), roughness=0.5, ior=1.55, offset=-0.03,
         aspect_ratio=1.0),
]


def _ray_segment_distance(p, d, a, b, t_max=50.0, n=80):
    """Minimum distance between the ray p + t d (0 <= t <= t_max) and segment [a, b] (sampled)."""
    best = 1e30
    ab = b - a
    for i in range(n + 1):
        q = a + ab * (i / n)
        t = max(0.0, min(t_max, (q - p).dot(d)))
        best = min(best, (p + d * t - q).length)
    return best


def _shadows(seg_a, seg_b, wi, margin):
    """True when some shadow ray from strand A towards the sun passes strand B."""
    a0, a1 = seg_a
    for i in range(9):
        p = a0 + (a1 - a0) * (i / 8)
        if _ray_segment_distance(p, wi, *seg_b) < 2 * RADIUS + margin:
            return True
    return False


def strand_layout(variant):
    wi = Vector(SUNS[variant]).normalized()
    wo = Vector((0.0, 0.0, 1.0))
    ncols, nrows = len(ELEVATIONS), len(AZIMUTHS)
    strands, placed = [], []
    depth_tries = [0.0] + [s * k * 0.6 for k in range(1, 12) for s in (1, -1)]
    for row, a in enumerate(AZIMUTHS):
        for col, e in enumerate(ELEVATIONS):
            er, ar = math.radians(e), math.radians(a)
            t = Vector((math.cos(er) * math.cos(ar), math.cos(er) * math.sin(ar), math.sin(er)))
            length = PROJECTED_LENGTH / math.cos(er)
            centre_xy = Vector((col - (ncols - 1) / 2.0, (nrows - 1) / 2.0 - row, 0.0))
            for dz in depth_tries:
                c = centre_xy + Vector((0.0, 0.0, dz))
                seg = (c - t * (length / 2), c + t * (length / 2))
                if not any(_shadows(seg, s, wi, 0.05) or _shadows(s, seg, wi, 0.05) for s in placed):
                    break
            else:
                raise RuntimeError("fiber_gonio: no shadow-free placement for strand %d" % len(strands))
            placed.append(seg)
            # Cycles' frame at this strand: X = t, Y = normalize(X x wo), Z = X x Y
            X = t
            Y = X.cross(wo).normalized()
            Z = X.cross(Y)
            phi_o = math.atan2(wo.dot(Z), wo.dot(Y))
            phi_i = math.atan2(wi.dot(Z), wi.dot(Y))
            dphi = math.degrees((phi_i - phi_o + math.pi) % (2 * math.pi) - math.pi)
            strands.append(dict(index=len(strands), row=row, col=col, elevation=e, azimuth=a,
                                tangent=list(t), centre=list(c), length=length, depth=dz,
                                theta_o=math.degrees(math.asin(max(-1, min(1, t.dot(wo))))),
                                theta_i=math.degrees(math.asin(max(-1, min(1, t.dot(wi))))),
                                dphi=dphi, material=len(strands) % len(MATERIALS)))
    return strands, wi


def build(scene, cfg):
    variant = cfg.get("variant") or "front"
    huang = variant.startswith("huang_")
    if huang:
        variant = variant[len("huang_"):]
    materials = HUANG_MATERIALS if huang else MATERIALS
    w, h = cfg["res"]
    lib.parity_settings(scene, width=w, height=h, spp=cfg["spp"], seed=cfg["seed"], threads=cfg.get("threads", 0),
                        bounces=dict(max_bounces=0, diffuse_bounces=0, glossy_bounces=0,
                                     transmission_bounces=0, volume_bounces=0, transparent_max_bounces=0),
                        curve_shape="THICK", subdivisions=3, pixel_filter="BLACKMAN_HARRIS",
                        filter_width=0.01, film_transparent=True, osl=cfg.get("osl", False))
    lib.set_world(scene, (0.0, 0.0, 0.0), 0.0)
    strands, wi = strand_layout(variant)
    for st in strands:
        st["material"] = st["index"] % len(materials)
    mats = [lib.hair_material("GonioMat%d" % k, p) for k, p in enumerate(materials)]
    for s in strands:
        t = Vector(s["tangent"])
        c = Vector(s["centre"])
        n = 9
        pts = [tuple(c + t * (s["length"] * (i / (n - 1) - 0.5))) for i in range(n)]
        lib.curves_from_polylines(scene, "GonioStrand%02d" % s["index"], [pts], RADIUS, mats[s["material"]])
    # The camera just in front of the nearest strand point: float32 ray origins far away blur h
    # (bsdf_check/README.md, "Precision").
    zmax = max(s["centre"][2] + abs(s["tangent"][2]) * s["length"] / 2 for s in strands) + RADIUS
    width = float(len(ELEVATIONS))
    lib.ortho_camera(scene, (0.0, 0.0, zmax + 0.5), (0.0, 0.0, 0.0), ortho_scale=width)
    lib.sun_light(scene, tuple(wi), SUN_STRENGTH, angle_deg=0.0, name="GonioSun")
    roi = []
    for s in strands:
        t = s["tangent"]
        pl = math.hypot(t[0], t[1])
        half = s["length"] * pl / 2 - RADIUS * abs(t[2])
        roi.append(dict(centre=s["centre"][:2], axis=[t[0] / pl, t[1] / pl], half_length=half, radius=RADIUS))
    return dict(variant=("huang_" if huang else "") + variant, sun_direction=list(wi), sun_strength=SUN_STRENGTH,
                strands=strands, materials=materials, tilt=fg.default_tilt_convention(), camera_z=zmax + 0.5,
                gonio_roi=dict(image_width=width, end_margin_px=2, strands=roi))
