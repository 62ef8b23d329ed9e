"""Calibration scenes for the path tracer's units: each case is plain data that both
`scene_desc(case)` (our renderer, hand-written scene_desc) and `cycles_render.py` (bpy,
Cycles) build the same scene from. No bpy import here.

Geometry is given in world space with identity object transforms; lights by their object
matrix (Blender: a sun shines along its local -Z, i.e. its +Z points to the sun; spot and
area lights emit along local -Z).
"""

from __future__ import annotations

import math

import numpy as np

WIDTH = 48
HEIGHT = 48


def rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    C = 1 - c
    return np.array([[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
                     [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
                     [z * x * C - y * s, z * y * C + x * s, c + z * z * C]])


def matrix(rot=np.eye(3), loc=(0, 0, 0), scale=(1, 1, 1)):
    m = np.eye(4)
    m[:3, :3] = rot @ np.diag(scale)
    m[:3, 3] = loc
    return m


def plane(size=2.0, z=0.0):
    v = np.array([[-size, -size, z], [size, -size, z], [size, size, z], [-size, size, z]], np.float32)
    t = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    return v, t


def hair_patch(n=60, keys=8, radius=0.02, seed=1):  # noqa: D401
    """Strands with roots on [-0.8, 0.8]^2 at z = 0, arcing up to ~0.3 and over, crossing
    each other. Returns points (P, 4) float32 and offsets (C + 1,) int32."""
    rng = np.random.default_rng(seed)
    pts, off = [], [0]
    for _ in range(n):
        root = np.array([*rng.uniform(-0.8, 0.8, 2), 0.0])
        phi = rng.uniform(0, 2 * math.pi)
        length = rng.uniform(0.6, 1.0)
        d = np.array([math.cos(phi), math.sin(phi), 0.0])
        for k in range(keys):
            s = k / (keys - 1)
            p = root + d * (length * s) + np.array([0, 0, 0.3 * math.sin(math.pi * s * 0.9) + 0.02])
            p[:2] += 0.05 * math.sin(3 * s + phi) * np.array([-d[1], d[0]])
            pts.append([*p, radius * (1.0 - 0.5 * s)])
        off.append(len(pts))
    return np.array(pts, np.float32), np.array(off, np.int32)


DIFFUSE = {"type": "diffuse", "color": (0.8, 0.8, 0.8)}
HAIR = {"type": "principled_hair", "model": "CHIANG", "parametrization": "MELANIN",
        "inputs": {"melanin": 0.3, "melanin_redness": 0.5, "roughness": 0.35, "radial_roughness": 0.4,
                   "coat": 0.0, "ior": 1.55, "offset": math.radians(2.0), "random_roughness": 0.2,
                   "random_color": 0.0}}

TOP_CAMERA = {"type": "ORTHO", "matrix": matrix(loc=(0, 0, 0.5)), "ortho_scale": 3.0}
HAIR_CAMERA = {"type": "ORTHO", "matrix": matrix(loc=(0, 0, 0.5)), "ortho_scale": 2.2}
PERSP_CAMERA = {"type": "PERSP", "matrix": matrix(rotation((1, 0, 0), math.radians(35)), loc=(0, -1.3, 1.9)),
                "lens": 35.0}


def _case(name, lights, world=0.0, hair=False, samples=64, bounces=(0, 0, 0, 0, 0), camera=TOP_CAMERA,
          shape="THICK", plane=True, hair_material="hair", film_transparent=False, filter_glossy=0.0,
          clamp=(0.0, 0.0), light_threshold=0.0):
    return {"name": name, "lights": lights, "world": world, "hair": hair, "samples": samples,
            "bounces": bounces, "camera": camera, "shape": shape, "plane": plane, "hair_material": hair_material,
            "film_transparent": film_transparent, "filter_glossy": filter_glossy, "clamp": clamp,
            "light_threshold": light_threshold}


def _tilt(deg_x, deg_y=0.0):
    return rotation((0, 1, 0), math.radians(deg_y)) @ rotation((1, 0, 0), math.radians(deg_x))


CASES = [
    _case("sun_delta", [{"type": "SUN", "energy": 3.0, "matrix": matrix(_tilt(30, 20)), "angle": 0.0}]),
    _case("sun_disc", [{"type": "SUN", "energy": 3.0, "matrix": matrix(_tilt(30, 20)), "angle": 0.5}]),
    _case("point_zero", [{"type": "POINT", "energy": 40.0, "loc": (0.3, 0.2, 1.0), "radius": 0.0}]),
    _case("point_soft", [{"type": "POINT", "energy": 40.0, "loc": (0.3, 0.2, 1.0), "radius": 0.3,
                          "soft_falloff": True}]),
    _case("point_sphere", [{"type": "POINT", "energy": 40.0, "loc": (0.3, 0.2, 1.0), "radius": 0.3,
                            "soft_falloff": False}]),
    _case("spot_soft", [{"type": "SPOT", "energy": 150.0, "matrix": matrix(_tilt(-20, 10), loc=(-0.2, 0.1, 1.3)),
                         "radius": 0.1, "spot_size": math.radians(50), "spot_blend": 0.3, "soft_falloff": True}]),
    _case("spot_sphere_scaled", [{"type": "SPOT", "energy": 150.0,
                                  "matrix": matrix(_tilt(-20, 10), loc=(-0.2, 0.1, 1.3), scale=(1.5, 0.8, 1.0)),
                                  "radius": 0.15, "spot_size": math.radians(60), "spot_blend": 0.1,
                                  "soft_falloff": False}]),
    _case("area_square", [{"type": "AREA", "energy": 30.0, "matrix": matrix(_tilt(20), loc=(0.1, 0, 1.0)),
                           "shape": "SQUARE", "size_x": 0.6}]),
    _case("area_rect_spread", [{"type": "AREA", "energy": 30.0, "matrix": matrix(_tilt(-15, 10), loc=(0, 0.2, 1.0)),
                                "shape": "RECTANGLE", "size_x": 0.8, "size_y": 0.3, "spread": math.radians(60)}]),
    _case("area_disk_scaled", [{"type": "AREA", "energy": 30.0,
                                "matrix": matrix(_tilt(10), loc=(0, 0, 0.9), scale=(1.3, 0.7, 1)),
                                "shape": "DISK", "size_x": 0.5}]),
    _case("area_ellipse_spread", [{"type": "AREA", "energy": 30.0, "matrix": matrix(_tilt(0), loc=(0.2, 0, 1.0)),
                                   "shape": "ELLIPSE", "size_x": 0.7, "size_y": 0.3, "spread": math.radians(100)}]),
    _case("world", [], world=0.7),
    # Framing: non-square perspective image, VERTICAL sensor fit, lens shift; the spot's
    # pattern on the plane makes the 4 x 4 blocks sensitive to where pixels look.
    dict(_case("persp_shift_spot", [{"type": "SPOT", "energy": 150.0, "matrix": matrix(_tilt(-20, 10), loc=(-0.2, 0.1, 1.3)),
                                     "radius": 0.05, "spot_size": math.radians(40), "spot_blend": 0.2}],
               camera={"type": "PERSP", "matrix": matrix(rotation((1, 0, 0), math.radians(20)), loc=(0.1, -0.6, 2.2)),
                       "lens": 30.0, "sensor_fit": "VERTICAL", "shift_x": 0.12, "shift_y": -0.05}),
         resolution=(64, 40)),
    # Hair over the plane: multiple scattering with Blender's default bounce budgets
    # (max 12, diffuse 4, glossy 4, transmission 12, transparent 8), sun disc + world.
    _case("hair_sun_world", [{"type": "SUN", "energy": 2.0, "matrix": matrix(_tilt(35, -25)), "angle": 0.2}],
          world=0.3, hair=True, samples=64, bounces=(12, 4, 4, 12, 8), camera=HAIR_CAMERA),
    _case("hair_area_persp", [{"type": "AREA", "energy": 60.0, "matrix": matrix(_tilt(25), loc=(0, 0.6, 1.2)),
                               "shape": "SQUARE", "size_x": 0.8}],
          world=0.1, hair=True, samples=64, bounces=(12, 4, 4, 12, 8), camera=PERSP_CAMERA),
    # Cycles' defaults for the settings that change the expected value: Filter Glossy 1,
    # Clamp Indirect 10 (strong light so that clamping bites), light threshold 0.01.
    _case("hair_cycles_defaults", [{"type": "SUN", "energy": 8.0, "matrix": matrix(_tilt(35, -25)), "angle": 0.2}],
          world=0.5, hair=True, samples=64, bounces=(12, 4, 4, 12, 8), camera=HAIR_CAMERA,
          filter_glossy=1.0, clamp=(0.0, 10.0), light_threshold=0.01),
    _case("hair_ribbons_point", [{"type": "POINT", "energy": 30.0, "loc": (0.4, -0.3, 1.0), "radius": 0.1}],
          world=0.15, hair=True, samples=64, bounces=(6, 2, 3, 6, 8), camera=HAIR_CAMERA, shape="RIBBONS"),
]
CASE_NAMES = [c["name"] for c in CASES]

# Speed benchmark (not part of the test): a denser patch, 160 x 160 px, Blender's default
# bounce budgets; `hair_patch` arguments in "patch".
BENCH_CASES = [
    dict(_case("bench_hair", [{"type": "SUN", "energy": 2.0, "matrix": matrix(_tilt(35, -25)), "angle": 0.1}],
               world=0.3, hair=True, samples=32, bounces=(12, 4, 4, 12, 8), camera=HAIR_CAMERA),
         patch={"n": 1500, "keys": 12, "radius": 0.006, "seed": 2}, resolution=(160, 160)),
]


def case(name):
    return next(c for c in CASES + BENCH_CASES if c["name"] == name)


def light_desc(l):
    """One scene_desc light from a case light (Blender's raw values)."""
    strength = tuple(float(l["energy"]) * c for c in l.get("color", (1.0, 1.0, 1.0)))
    m = l.get("matrix", matrix(loc=l.get("loc", (0, 0, 0))))
    if l["type"] == "SUN":
        z = m[:3, 2] / np.linalg.norm(m[:3, 2])
        return {"type": "SUN", "direction": tuple(z), "strength": strength, "angle": l.get("angle", 0.0)}
    if l["type"] == "POINT":
        return {"type": "POINT", "position": tuple(m[:3, 3]), "strength": strength, "radius": l.get("radius", 0.0),
                "soft_falloff": l.get("soft_falloff", True)}
    if l["type"] == "SPOT":
        d = -m[:3, 2] / np.linalg.norm(m[:3, 2])
        return {"type": "SPOT", "position": tuple(m[:3, 3]), "direction": tuple(d), "strength": strength,
                "radius": l.get("radius", 0.0), "soft_falloff": l.get("soft_falloff", True),
                "spot_size": l["spot_size"], "spot_blend": l["spot_blend"], "matrix_world": m}
    return {"type": "AREA", "matrix_world": m, "shape": l["shape"], "size_x": l["size_x"],
            "size_y": l.get("size_y", l["size_x"]), "strength": strength, "spread": l.get("spread", math.pi)}


def scene_desc(c, samples=None, seed=0):
    """Our renderer's scene_desc for case `c` (hand-written, equivalent to cycles_render.py)."""
    import hairbsdf

    v, t = plane()
    if not c.get("plane", True):
        v, t = np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32)
    materials = [{"name": "plane", "closures": [dict(DIFFUSE, weight=(1, 1, 1))]}]
    scene = {
        "version": 1,
        "meshes": {"vertices": v, "triangles": t, "triangle_material": np.zeros(len(t), np.int32)},
        "materials": materials,
        "lights": [light_desc(l) for l in c["lights"]],
        "world": {"color": (c["world"],) * 3},
    }
    if c["hair"]:
        pts, off = hair_patch(**c.get("patch", {}))
        n = len(off) - 1
        if c.get("hair_material", "hair") == "hair":
            closure = dict(HAIR, weight=(1, 1, 1), inputs=dict(HAIR["inputs"], random=None))
        elif c.get("hair_material") == "black":
            closure = dict(DIFFUSE, weight=(1, 1, 1), color=(0.0, 0.0, 0.0))
        else:
            closure = dict(DIFFUSE, weight=(1, 1, 1))
        materials.append({"name": "hair", "closures": [closure]})
        scene["curves"] = {"points": pts, "curve_offsets": off,
                           "curve_random": np.asarray(hairbsdf.cycles_curve_random(np.arange(n)), np.float32),
                           "curve_material": np.ones(n, np.int32)}
        scene["curve_shape"] = c["shape"]
        scene["curve_subdivisions"] = 2
    cam = c["camera"]
    scene["camera"] = {"type": cam["type"], "matrix_world": cam["matrix"], "resolution": c.get("resolution", (WIDTH, HEIGHT)),
                       "pixel_aspect": 1.0, "sensor_fit": cam.get("sensor_fit", "AUTO"), "sensor_width": 36.0,
                       "sensor_height": 24.0, "lens": cam.get("lens", 50.0), "ortho_scale": cam.get("ortho_scale", 1.0),
                       "shift_x": cam.get("shift_x", 0.0), "shift_y": cam.get("shift_y", 0.0), "clip_start": 0.01,
                       "clip_end": 100.0}
    b = c["bounces"]
    scene["integrator"] = {"samples": samples or c["samples"], "seed": seed, "max_bounces": b[0],
                           "diffuse_bounces": b[1], "glossy_bounces": b[2], "transmission_bounces": b[3],
                           "transparent_bounces": b[4], "min_light_bounces": 0, "filter_type": "BLACKMAN_HARRIS",
                           "filter_width": 1.5, "exposure": 1.0, "film_transparent": c.get("film_transparent", False),
                           "light_sampling_threshold": c.get("light_threshold", 0.0),
                           "filter_glossy": c.get("filter_glossy", 0.0), "clamp_direct": c.get("clamp", (0, 0))[0],
                           "clamp_indirect": c.get("clamp", (0, 0))[1], "tilt": "4.2"}
    return scene
