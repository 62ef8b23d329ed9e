"""The path tracer (hairbsdf.render) without Blender: the BSDF-level key check on real
geometry, a furnace, cancellation, bad scenes and determinism."""

import math
import threading
import time

import numpy as np
import pytest

import hairbsdf
from hairbsdf.render import render, validate_scene
from render_checks import assert_differences_average_out

R = 0.05  # strand radius


def _ortho_camera(wo, image_height, resolution, distance=0.25):
    """Orthographic camera at distance * wo looking at the origin; image x = the strand
    axis (+x) projected, image up = wo x image x."""
    x = np.array([1.0, 0.0, 0.0])
    xc = x - np.dot(x, wo) * wo
    xc /= np.linalg.norm(xc)
    yc = np.cross(wo, xc)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = xc, yc, wo, distance * wo
    return {"type": "ORTHO", "matrix_world": m, "resolution": resolution, "sensor_fit": "VERTICAL",
            "ortho_scale": image_height, "clip_start": 0.01, "clip_end": 100.0}, yc


def _integrator(**kw):
    d = {"samples": 1, "seed": 0, "max_bounces": 0, "diffuse_bounces": 0, "glossy_bounces": 0,
         "transmission_bounces": 0, "transparent_bounces": 0, "min_light_bounces": 0,
         "filter_type": "BLACKMAN_HARRIS", "filter_width": 1e-4, "exposure": 1.0, "film_transparent": True,
         "light_sampling_threshold": 0.0, "tilt": "4.2"}
    d.update(kw)
    return d


def _straight_strand(n=9, length=1.0, radius=R):
    pts = np.zeros((n, 4), np.float32)
    pts[:, 0] = np.linspace(-0.5 * length, 0.5 * length, n)
    pts[:, 3] = radius
    return {"points": pts, "curve_offsets": np.array([0, n], np.int32),
            "curve_random": np.array([hairbsdf.cycles_curve_random(0)], np.float32),
            "curve_material": np.array([0], np.int32)}


def _hair_material(**inputs):
    return {"name": "hair", "closures": [{"type": "principled_hair", "weight": (1, 1, 1), "model": "CHIANG",
                                          "parametrization": inputs.pop("parametrization", "MELANIN"),
                                          "inputs": dict(inputs, random=None)}]}


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


# --------------------------------------------------------------------------------------
# (a) the key check: pixels across one strand = strength x eval(wo, wi, h(pixel centre))

@pytest.mark.parametrize("shape,intersector", [("THICK", "EMBREE"), ("THICK", "SWEEP"), ("RIBBONS", "EMBREE")])
@pytest.mark.parametrize("wo,wi,inputs", [
    ((0.3, 0.5, 0.8), (-0.2, -0.7, 0.4), {"melanin": 0.8}),
    ((-0.1, 0.2, 1.0), (0.5, 0.3, 0.6), {"parametrization": "COLOR", "color": (0.5, 0.3, 0.2), "roughness": 0.15,
                                         "offset": 0.06}),
    ((0.6, -0.3, 0.5), (0.1, 0.9, -0.2), {"parametrization": "ABSORPTION", "coat": 0.3, "ior": 1.4,
                                          "random_roughness": 0.5}),
])
@pytest.mark.parametrize("pixel_filter", [("BLACKMAN_HARRIS", 1e-4), ("BLACKMAN_HARRIS", 0.01)], ids=["bh1e-4", "bh0.01"])
def test_strand_pixels_equal_bsdf_eval(shape, intersector, wo, wi, inputs, pixel_filter):
    """At 1 spp the 0.01 px filter (Blender's minimum) gives the pixel-centre value: sample 0 of every pixel
    sits at the pixel centre, as in Cycles (integrate_camera_sample). Both THICK intersectors put the hit, and
    so h, where Embree's round curve is."""
    wo, wi = _unit(wo), _unit(wi)
    height, across = 160, 120  # 120 pixels across the strand diameter
    pixel = 2 * R / across
    camera, yc = _ortho_camera(wo, height * pixel, (4, height))
    strength = 2.5
    scene = {"version": 1, "curves": _straight_strand(), "curve_shape": shape, "curve_subdivisions": 2,
             "curve_intersector": intersector, "materials": [_hair_material(**dict(inputs))], "camera": camera,
             "lights": [{"type": "SUN", "direction": tuple(wi), "strength": (strength,) * 3, "angle": 0.0}],
             "world": {"color": (0, 0, 0)},
             "integrator": _integrator(filter_type=pixel_filter[0], filter_width=pixel_filter[1])}
    out = render(scene)
    img = out["combined"]
    assert out["stats"]["nan_count"] == 0 and not out["stats"]["warnings"]
    # Row y (0 = top) has its centre at s = (H - 1 - y + 0.5 - H/2) * pixel along yc;
    # h = -dot(P - C, Y) / r with Y = normalize(x cross wo).
    rows = np.arange(height)
    s = ((height - 1 - rows) + 0.5 - height / 2) * pixel
    x = np.array([1.0, 0, 0])
    y = _unit(np.cross(x, wo))
    z = np.cross(x, y)
    h = -s * np.dot(yc, y) / R
    inside = np.abs(h) < 0.98
    frame = lambda w: np.array([w @ x, w @ y, w @ z])  # noqa: E731
    params = dict(inputs)
    param = params.pop("parametrization", "MELANIN").lower()
    params["random"] = hairbsdf.cycles_curve_random(0)
    bsdf = hairbsdf.principled_hair(parametrization=param, **params)
    n = int(inside.sum())
    expected = strength * bsdf.eval(np.tile(frame(wo), (n, 1)), np.tile(frame(wi), (n, 1)), h[inside])
    got = img[inside, 1, :3].astype(np.float64)
    rel = np.abs(got - expected) / np.maximum(np.abs(expected), 1e-12)
    assert np.median(rel) <= 1e-5, f"median relative error {np.median(rel):.2e}"
    assert np.all(img[inside, 1, 3] == 1.0)  # coverage
    assert np.all(img[np.abs(h) > 1.05, :, 3] == 0.0)


@pytest.mark.parametrize("shape", ["THICK", "RIBBONS"])
@pytest.mark.parametrize("component,theta_i,dphi", [("REFLECTION", 15.0, 70.0), ("TRANSMISSION", -20.0, 120.0)])
def test_cycles_hair_strand_pixels_equal_bsdf_eval(shape, component, theta_i, dphi):
    """The legacy Hair BSDF closure in the engine: pixels = strength x Color x eval at the pixel's h, the
    reflection / transmission split following the hit's shading normal (it crosses the strand here:
    the light's azimuth dphi from the viewer's puts the normal's horizon at h = sin(90 - dphi))."""
    wo = _unit((0.2, 0.1, 1.0))
    fy = _unit(np.cross([1.0, 0, 0], wo))
    fz = np.cross([1.0, 0, 0], fy)
    t, p = math.radians(theta_i), math.radians(dphi - 90.0)  # the viewer is at phi = -90 in this frame
    wi = _unit(math.sin(t) * np.array([1.0, 0, 0]) + math.cos(t) * (math.cos(p) * fy + math.sin(p) * fz))
    height, across = 160, 120
    pixel = 2 * R / across
    camera, yc = _ortho_camera(wo, height * pixel, (4, height))
    params = {"component": component, "color": (0.9, 0.5, 0.3), "offset": 0.1, "roughness_u": 0.2,
              "roughness_v": 0.6}
    mat = {"name": "legacy", "closures": [dict(type="cycles_hair", weight=(0.7, 0.7, 0.7), **params)]}
    scene = {"version": 1, "curves": _straight_strand(), "curve_shape": shape, "curve_subdivisions": 2,
             "materials": [mat], "camera": camera,
             "lights": [{"type": "SUN", "direction": tuple(wi), "strength": (2.0,) * 3, "angle": 0.0}],
             "world": {"color": (0, 0, 0)}, "integrator": _integrator(filter_width=0.01)}
    out = render(scene)
    img = out["combined"]
    assert out["stats"]["nan_count"] == 0 and not out["stats"]["warnings"]
    rows = np.arange(height)
    s = ((height - 1 - rows) + 0.5 - height / 2) * pixel
    x = np.array([1.0, 0, 0])
    y = _unit(np.cross(x, wo))
    z = np.cross(x, y)
    h = -s * np.dot(yc, y) / R
    inside = np.abs(h) < 0.98
    frame = lambda w: np.array([w @ x, w @ y, w @ z])  # noqa: E731
    bsdf = hairbsdf.cycles_hair_bsdf(**dict(params, component=component.lower()))
    n = int(inside.sum())
    expected = 2.0 * 0.7 * bsdf.eval(np.tile(frame(wo), (n, 1)), np.tile(frame(wi), (n, 1)), h[inside])
    got = img[inside, 1, :3].astype(np.float64)
    lit = expected[:, 0] > 0
    assert 0.1 < lit.mean() < 0.9, lit.mean()  # the normal split crosses the strand
    np.testing.assert_allclose(got[lit], expected[lit], rtol=1e-5)
    # Away from the split (one pixel either side may fall on the other side of it) dark is dark.
    edge = np.abs(np.diff(lit.astype(int), prepend=lit[0], append=lit[-1]))
    near = np.convolve(edge, np.ones(3), mode="same")[: n] > 0
    assert np.all(got[~lit & ~near[:n]] == 0)


# --------------------------------------------------------------------------------------
# (b) furnace: non-absorbing hair in a uniform white world is invisible

def _clump(n=30, keys=6, seed=3, radius=0.03):
    rng = np.random.default_rng(seed)
    pts, off = [], [0]
    for _ in range(n):
        p0 = rng.uniform(-0.15, 0.15, 3)
        d = _unit(rng.normal(size=3))
        for k in range(keys):
            t = k / (keys - 1) - 0.5
            pts.append([*(p0 + 0.8 * t * d + 0.05 * np.sin(3 * t) * np.cross(d, [0, 0, 1])), radius])
        off.append(len(pts))
    c = len(off) - 1
    return {"points": np.array(pts, np.float32), "curve_offsets": np.array(off, np.int32),
            "curve_random": np.asarray(hairbsdf.cycles_curve_random(np.arange(c)), np.float32),
            "curve_material": np.zeros(c, np.int32)}


@pytest.mark.parametrize("shape", ["THICK", "RIBBONS"])
def test_white_furnace(shape):
    camera = {"type": "PERSP", "matrix_world": np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 2.0], [0, 0, 0, 1]]),
              "resolution": (24, 24), "lens": 50.0, "sensor_width": 36.0, "sensor_fit": "AUTO",
              "clip_start": 0.01, "clip_end": 100.0}
    scene = {"curves": _clump(), "curve_shape": shape,
             "materials": [_hair_material(parametrization="ABSORPTION", absorption_coefficient=(0, 0, 0),
                                          roughness=0.6, radial_roughness=0.6, coat=0.0)],
             "camera": camera, "lights": [], "world": {"color": (1.0, 1.0, 1.0)},
             "integrator": _integrator(samples=64, max_bounces=1000, glossy_bounces=1000,
                                       transmission_bounces=1000, transparent_bounces=8, filter_width=1.5,
                                       film_transparent=False)}
    out = render(scene, threads=2)
    img = out["combined"][..., :3]
    # Coverage from a second, black-world render with a transparent film.
    cov = render(dict(scene, world={"color": (0, 0, 0)}, integrator=dict(scene["integrator"], samples=8,
                                                                         film_transparent=True)))
    alpha = cov["combined"][..., 3]
    hair = alpha > 0.99
    assert hair.sum() > 50
    assert out["stats"]["nan_count"] == 0
    mean = img[hair].mean()
    sem = img[hair].std() / math.sqrt(hair.sum())
    assert abs(mean - 1.0) < max(4 * sem, 0.005), (mean, sem)


# --------------------------------------------------------------------------------------
# (c) cancel stops the render within 0.2 s

def _busy_scene(samples=100000):
    camera, _ = _ortho_camera(_unit((0.2, 0.1, 1.0)), 1.2, (64, 64))
    return {"curves": _clump(n=60), "materials": [_hair_material()], "camera": camera,
            "lights": [{"type": "SUN", "direction": (0.3, 0.2, 1.0), "strength": (2, 2, 2), "angle": 0.1}],
            "world": {"color": (0.3, 0.3, 0.3)},
            "integrator": _integrator(samples=samples, max_bounces=12, glossy_bounces=4, transmission_bounces=12)}


def test_cancel_stops_quickly():
    requested = []

    def cancel():
        # After the first progress report (or 5 s without one): on a loaded machine the scene's
        # set-up alone can take 0.5 s, and a render cancelled at its first poll has reported none yet.
        elapsed = time.perf_counter() - start
        if elapsed > 0.5 and (progress or elapsed > 5):
            if not requested:
                requested.append(time.perf_counter())
            return True
        return False

    progress = []
    start = time.perf_counter()
    out = render(_busy_scene(), cancel=cancel, progress=progress.append, threads=2)
    stopped = time.perf_counter()
    assert requested, "cancel() was never polled"
    assert stopped - requested[0] < 0.2, f"render returned {stopped - requested[0]:.3f} s after cancel"
    assert out["stats"]["cancelled"]
    assert out["stats"]["samples"] < 100000
    assert np.all(np.isfinite(out["combined"]))
    assert progress and all(0.0 <= p <= 1.0 for p in progress)


def test_progress_reaches_one_and_gil_is_released():
    ticks = []
    stop = threading.Event()

    def ticker():  # runs only if render releases the GIL
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.01)

    t = threading.Thread(target=ticker)
    t.start()
    progress = []
    try:
        render(_busy_scene(samples=48), progress=progress.append)
    finally:
        stop.set()
        t.join()
    assert progress[-1] == 1.0
    assert len(ticks) > 3


def test_callback_errors_propagate():
    def cancel():
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        render(_busy_scene(samples=1000), cancel=cancel)


# --------------------------------------------------------------------------------------
# (d) bad scenes: warnings or clear errors, never crashes or NaN pixels

def _one_triangle():
    return {"vertices": np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32),
            "triangles": np.array([[0, 1, 2]], np.int32), "triangle_material": np.array([0], np.int32)}


def _small_scene():
    camera, _ = _ortho_camera(_unit((0.0, 0.3, 1.0)), 1.2, (16, 16))
    return {"curves": _clump(n=5), "materials": [_hair_material()], "camera": camera,
            "lights": [{"type": "SUN", "direction": (0.3, 0.2, 1.0), "strength": (2, 2, 2)}],
            "world": {"color": (0.2, 0.2, 0.2)},
            "integrator": _integrator(samples=4, max_bounces=4, glossy_bounces=4, transmission_bounces=4)}


def _check_clean(out):
    assert np.all(np.isfinite(out["combined"]))
    assert out["combined"].dtype == np.float32 and out["combined"].shape == (16, 16, 4)


def test_nan_coordinates_and_bad_strands_are_dropped():
    scene = _small_scene()
    c = scene["curves"]
    pts = c["points"].copy()
    pts[0, 0] = np.nan            # curve 0: NaN coordinate
    pts[6:12, 3] = 0.0            # curve 1: zero radius
    pts[12:18, :3] = pts[12, :3]  # curve 2: zero length
    pts[20, 3] = -1.0             # curve 3: one negative radius -> 0
    c["points"] = pts
    c["curve_material"] = np.array([0, 0, 0, 0, 7], np.int32)  # curve 4: bad material
    out = render(scene)
    _check_clean(out)
    w = " | ".join(out["stats"]["warnings"])
    for phrase in ("NaN/Inf coordinates", "zero radius", "zero-length", "negative or NaN radius",
                   "default surface"):
        assert phrase in w, w


def test_empty_scene_and_no_lights_warn():
    scene = _small_scene()
    scene.pop("curves")
    scene["lights"] = []
    scene["world"] = {"color": (0, 0, 0)}
    out = render(scene)
    _check_clean(out)
    w = " | ".join(out["stats"]["warnings"])
    assert "no geometry" in w and "no lights" in w
    assert np.all(out["combined"][..., :3] == 0)


def test_nan_light_and_world_are_removed():
    scene = _small_scene()
    scene["lights"].append({"type": "POINT", "position": (np.nan, 0, 1), "strength": (10, 10, 10)})
    scene["world"] = {"color": (np.inf, 0, 0)}
    out = render(scene)
    _check_clean(out)
    assert any("lights" in w for w in out["stats"]["warnings"])
    assert any("world" in w for w in out["stats"]["warnings"])


def _plane_scene(light, resolution=(16, 16), ortho_scale=4.0):
    """A diffuse plane z = 0 (colour 0.5) seen from above by an orthographic camera, 1 spp at
    the pixel centres, direct light only."""
    return {"version": 1,
            "meshes": {"vertices": np.array([[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]], np.float32),
                       "triangles": np.array([[0, 1, 2], [0, 2, 3]], np.int32),
                       "triangle_material": np.zeros(2, np.int32)},
            "materials": [{"name": "d", "closures": [{"type": "diffuse", "color": (0.5, 0.5, 0.5)}]}],
            "camera": {"type": "ORTHO", "matrix_world": np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 3],
                                                                  [0, 0, 0, 1]], float),
                       "resolution": resolution, "ortho_scale": ortho_scale, "clip_start": 0.01, "clip_end": 10.0},
            "lights": [light], "world": {"color": (0, 0, 0)}, "integrator": _integrator(film_transparent=False)}


def test_spot_cosine_is_cycles_3x_attenuation():
    """spot_cosine (Blender 3.x export) multiplies the spot's attenuation by the cosine of the
    angle to the axis: per pixel, exactly, for a delta spot."""
    spot = {"type": "SPOT", "position": (0.3, -0.2, 2.0), "direction": (0, 0, -1), "strength": (50, 50, 50),
            "radius": 0.0, "spot_size": 2.0, "spot_blend": 0.2}
    a = render(_plane_scene(spot))["combined"][..., 0].astype(np.float64)
    b = render(_plane_scene(dict(spot, spot_cosine=True)))["combined"][..., 0].astype(np.float64)
    n = 16
    xy = (np.arange(n) + 0.5) / n * 4.0 - 2.0  # pixel centres; image row 0 = +y
    px, py = np.meshgrid(xy, xy[::-1])
    d = np.stack([px - 0.3, py + 0.2, np.full_like(px, -2.0)], -1)
    cos_axis = -d[..., 2] / np.linalg.norm(d, axis=-1)
    lit = a > 1e-6
    assert lit.sum() > 50
    np.testing.assert_allclose(b[lit], a[lit] * cos_axis[lit], rtol=2e-5)


def test_smooth_mesh_normals_are_interpolated():
    """meshes.triangle_normals: the diffuse shading normal is the barycentric interpolation of the
    corner normals (Cycles' smooth shading), per pixel for a delta sun; flat without them."""
    sun = {"type": "SUN", "direction": (0.5, 0.2, 1.0), "strength": (1, 1, 1)}
    scene = _plane_scene(sun)
    corner = np.array([[0.3, 0.0, 1.0], [-0.2, 0.4, 1.0], [0.0, -0.3, 1.0], [0.4, 0.4, 1.0]])  # per vertex
    tris = scene["meshes"]["triangles"]
    scene["meshes"]["triangle_normals"] = corner[tris].reshape(-1, 9).astype(np.float32)
    flat = render(_plane_scene(sun))["combined"][..., 0].astype(np.float64)
    smooth = render(scene)["combined"][..., 0].astype(np.float64)
    n = 16
    xy = (np.arange(n) + 0.5) / n * 4.0 - 2.0  # pixel centres; image row 0 = +y
    px, py = np.meshgrid(xy, xy[::-1])
    # Barycentrics on the quad (-5,-5) (5,-5) (5,5) (-5,5): triangle 0 1 2 below the diagonal y = x.
    s_, t_ = (px + 5) / 10, (py + 5) / 10
    lower = t_ <= s_
    w = np.where(lower[..., None], np.stack([1 - s_, s_ - t_, t_], -1), np.stack([1 - t_, s_, t_ - s_], -1))
    v = np.where(lower[..., None, None], corner[[0, 1, 2]][None, None], corner[[0, 2, 3]][None, None])
    normal = (w[..., None] * v).sum(axis=2)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    light = np.array(sun["direction"]) / np.linalg.norm(sun["direction"])
    expected = 0.5 / np.pi * np.maximum(normal @ light, 0.0)
    np.testing.assert_allclose(smooth, expected, rtol=2e-5, atol=1e-7)
    np.testing.assert_allclose(flat, 0.5 / np.pi * light[2], rtol=2e-5)


@pytest.mark.parametrize("visible", [True, False])
def test_lights_visible_to_camera_only_when_set(visible):
    """An area light between the camera and the plane: seen by camera rays only with
    visible_camera (Blender's new lights have it off); it lights the plane either way."""
    m = np.eye(4)
    m[:3, 3] = (0.0, 0.0, 1.0)  # emits along -Z (down), faces away from the camera above it
    m[:3, :3] = np.diag([1.0, -1.0, -1.0])  # flipped: emits along +Z, towards the camera
    area = {"type": "AREA", "matrix_world": m, "shape": "SQUARE", "size_x": 1.0, "strength": (10, 10, 10),
            "visible_camera": visible}
    img = render(_plane_scene(area))["combined"][..., 0]
    centre = float(img[8, 8])
    if visible:
        assert centre == pytest.approx(10.0 / np.pi, rel=1e-5)  # radiance = strength / (pi area)
    else:
        assert centre == 0.0  # the light faces away from the plane, and the camera does not see it


@pytest.mark.parametrize("mutate,error,match", [
    (lambda s: s.pop("camera"), ValueError, r"scene\['camera'\]: missing"),
    (lambda s: s["camera"].update(type="FISHEYE"), ValueError, r"scene\['camera'\]\['type'\].*'PERSP'"),
    (lambda s: s["curves"].update(points=np.zeros((5, 3), np.float32)), ValueError,
     r"scene\['curves'\]\['points'\]: expected shape \(N, 4\)"),
    (lambda s: s["curves"].update(curve_offsets=np.array([0, 3], np.int32)), ValueError,
     r"scene\['curves'\]\['curve_offsets'\]"),
    (lambda s: s["lights"][0].update(strength="bright"), TypeError, r"scene\['lights'\]\[0\]\['strength'\]"),
    (lambda s: s["materials"][0]["closures"][0].update(type="glass"), ValueError,
     r"scene\['materials'\]\[0\]\['closures'\]\[0\]\['type'\]"),
    (lambda s: s["materials"][0]["closures"][0]["inputs"].update(colour=(1, 0, 0)), ValueError,
     r"\['inputs'\]\['colour'\]: unknown input"),
    (lambda s: s["materials"][0]["closures"].__setitem__(0, {"type": "cycles_hair", "component": "BOTH"}),
     ValueError, r"\['closures'\]\[0\]\['component'\].*'REFLECTION'"),
    (lambda s: s["integrator"].update(samples=-1), ValueError, r"scene\['integrator'\]\['samples'\]"),
    (lambda s: s["integrator"].update(filter_type="MITCHELL"), ValueError, r"\['filter_type'\]"),
    (lambda s: s["curves"].update(curve_material=np.array([0.5] * 5)), TypeError, r"\['curve_material'\]"),
    (lambda s: s["integrator"].update(light_tree="yes"), TypeError, r"\['integrator'\]\['light_tree'\]"),
    (lambda s: s["curves"].update(curve_object=np.zeros(5, np.int32)), ValueError,
     r"\['curves'\]\['object_transforms'\]: missing \(required with curve_object\)"),
    (lambda s: s["curves"].update(curve_object=np.array([0, 0, 1, -1, 0], np.int32),
                                  object_transforms=np.eye(3, 4).reshape(1, 12)), ValueError,
     r"\['curves'\]\['curve_object'\]: expected -1 \(world space\) or an index into object_transforms \(0 to 0\)"),
    (lambda s: s["curves"].update(curve_object=np.zeros(5, np.int32), object_transforms=np.zeros((1, 12))),
     ValueError, r"\['curves'\]\['object_transforms'\]\[0\]: expected a finite, invertible"),
    (lambda s: s.update(meshes=dict(_one_triangle(), attributes=[{"name": "<uv>", "data": np.zeros((2, 12))}])),
     ValueError, r"\['meshes'\]\['attributes'\]\[0\]\['data'\]: expected one row of 3 RGBA corners per triangle"),
    (lambda s: (s["curves"].update(attributes=[{"name": "<uv>", "domain": "CURVE", "data": np.zeros((5, 4))}]),
                s.update(meshes=dict(_one_triangle(), attributes=[{"name": "<uv>Other", "data": np.zeros((1, 12))}]))),
     ValueError, r"\['meshes'\]\['attributes'\]\[0\]\['name'\]: expected '<uv>', the curves' attribute 0"),
    (lambda s: s["materials"][0].update(emission_sampling="BOTH"), ValueError,
     r"scene\['materials'\]\[0\]\['emission_sampling'\]: 'BOTH' is not allowed; use one of \['AUTO'"),
    (lambda s: s.update(meshes=dict(_one_triangle(), triangle_object=np.zeros(2, np.int32))), ValueError,
     r"\['meshes'\]\['triangle_object'\]: expected one object id per triangle"),
    (lambda s: s["world"].update(map_resolution=-1), ValueError, r"scene\['world'\]\['map_resolution'\]: must be >= 0"),
    (lambda s: s["world"].update(mis="yes"), TypeError, r"scene\['world'\]\['mis'\]: expected a bool"),
])
def test_structural_errors_name_the_key(mutate, error, match):
    scene = _small_scene()
    mutate(scene)
    with pytest.raises(error, match=match):
        render(scene)


@pytest.mark.parametrize("shape,intersector,silhouette_tolerance", [
    ("THICK", "SWEEP", 0.005), ("THICK", "EMBREE", 0.04), ("RIBBONS", "EMBREE", 0.005)])
def test_curves_in_object_space(shape, intersector, silhouette_tolerance):
    """curve_object: a uniform object transform renders the same strand as its world-space
    copy with the radius scaled (what Cycles' applied transform gives); a scale across the
    strand widens its silhouette by that factor, one along it changes nothing. Embree 3.13's own
    round curves, scaled in an instance, cover some 3 % more pixels around the strand's ends on a
    CPU without AVX-512 (73 of 2 459 here; none with AVX-512); our SWEEP test of the same surface
    gives the world-space silhouette to the pixel on both."""
    camera, _ = _ortho_camera(_unit((0.0, 0.0, 1.0)), 0.6, (256, 256))
    base = {"version": 1, "curve_shape": shape, "curve_subdivisions": 2, "curve_intersector": intersector,
            "materials": [_hair_material()],
            "camera": camera, "lights": [{"type": "SUN", "direction": (0.3, 0.2, 1.0), "strength": (2, 2, 2)}],
            "world": {"color": (0, 0, 0)}, "integrator": _integrator(samples=1)}

    def image(scale, rotation_z=0.0, object_space=True):
        c, s = math.cos(rotation_z), math.sin(rotation_z)
        m = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0]]) @ np.diag([*scale, 1.0])
        strand = _straight_strand(length=0.15, radius=0.02)
        if object_space:
            strand.update(curve_object=np.zeros(1, np.int32), object_transforms=m.reshape(1, 12))
        else:  # Cycles' applied transform: keys to world, radius x |det|^(1/3)
            pts = strand["points"].copy()
            pts[:, :3] = pts[:, :3] @ m[:, :3].T.astype(np.float32) + m[:, 3].astype(np.float32)
            pts[:, 3] *= abs(np.linalg.det(m[:, :3])) ** (1 / 3)
            strand["points"] = pts
        out = render(dict(base, curves=strand))
        assert out["stats"]["nan_count"] == 0 and not out["stats"]["warnings"]
        return out["combined"]

    uniform, applied = image((1.5, 1.5, 1.5), 0.4), image((1.5, 1.5, 1.5), 0.4, object_space=False)
    # Float rounding flips a few pixels (1 spp-like: centred samples): an edge, or a path inside the strand
    # that goes another way (more of them where Embree runs 8-wide, AVX2). The silhouettes agree and the
    # flipped paths where both cover the pixel average out (their differences are not of one sign).
    differ = np.any(np.abs(uniform - applied) > 2e-5, axis=-1)
    assert differ.mean() < 0.005
    assert uniform[..., 3].sum() == pytest.approx(applied[..., 3].sum(), rel=silhouette_tolerance)
    both = (uniform[..., 3] > 0) & (applied[..., 3] > 0)
    assert_differences_average_out((uniform - applied)[both][:, :3].astype(np.float64).sum(axis=-1),
                                   applied[both][:, :3].astype(np.float64).sum(axis=-1).mean(),
                                   "object space against applied transform")
    area = image((1, 1, 1))[..., 3].sum()
    assert image((1, 3, 1))[..., 3].sum() == pytest.approx(3 * area, rel=0.05)  # across the strand (+x)
    assert image((3, 1, 1))[..., 3].sum() == pytest.approx(3 * area, rel=0.05)  # along: 3x longer, as wide
    assert image((1, 1, 3))[..., 3].sum() == pytest.approx(area, rel=0.05)      # along the view: unchanged


def test_light_tree_changes_only_the_noise_with_delta_lights():
    """Direct light from zero-radius point lights has no MIS, so the estimator is unbiased for
    any pick: Cycles' light tree (integrator light_tree) and the uniform pick agree in the mean."""
    camera, _ = _ortho_camera(_unit((0.2, 0.1, 1.0)), 1.2, (32, 32))
    lights = [{"type": "POINT", "position": p, "strength": (w, w, w), "radius": 0.0}
              for p, w in (((1.0, 0.5, 1.5), 20.0), ((-1.5, 0.2, 0.8), 5.0), ((0.3, -2.0, 2.0), 40.0),
                           ((0.0, 0.0, -1.5), 10.0))]
    lights.append({"type": "SUN", "direction": (0.3, 0.2, 1.0), "strength": (1, 1, 1)})
    scene = {"curves": _clump(n=30), "materials": [_hair_material()], "camera": camera, "lights": lights,
             "world": {"color": (0, 0, 0)}, "integrator": _integrator(samples=256, film_transparent=True)}
    imgs = [render(dict(scene, integrator=dict(scene["integrator"], light_tree=tree)), threads=2)["combined"]
            for tree in (False, True)]
    assert not np.array_equal(imgs[0], imgs[1])  # the setting reaches the renderer
    hair = (imgs[0][..., 3] > 0.99) & (imgs[1][..., 3] > 0.99)
    assert hair.sum() > 50
    # Paired per pixel: the difference has no spatial variation, only the two renders' noise.
    d = (imgs[1][..., :3] - imgs[0][..., :3])[hair].mean(axis=1)
    mean = imgs[0][..., :3][hair].mean()
    assert abs(d.mean()) < 4 * d.std() / math.sqrt(d.size) + 1e-6, (d.mean() / mean, d.std() / math.sqrt(d.size) / mean)


def _curtain(n=40, layers=2, radius=0.008, spacing=0.0125):
    """`layers` rows of n straight parallel strands along -z (x spacing `spacing`, rows 0.02 apart)."""
    pts, off = [], [0]
    for layer in range(layers):
        for k in range(n):
            x = -0.5 * n * spacing + (k + 0.5) * spacing
            pts += [[x, 0.02 * layer, 0.35 - 0.7 * j / 13, radius] for j in range(14)]
            off.append(len(pts))
    c = len(off) - 1
    return {"points": np.array(pts, np.float32), "curve_offsets": np.array(off, np.int32),
            "curve_random": np.asarray(hairbsdf.cycles_curve_random(np.arange(c)), np.float32),
            "curve_material": np.zeros(c, np.int32)}


def test_chiang_lcg_changes_only_paths_with_two_or_more_scatters():
    """integrator.chiang_lcg (Cycles < 3.6) draws Chiang's longitudinal numbers from a per-hit LCG
    whose seed moves by 16 per bounce: each number is uniform, so light after one scatter keeps its
    expectation, but successive scatters are correlated, which changes light after two or more (here
    between two rows of parallel strands: about +40 % at three bounces; Blender 3.4's ribbons_vs_3d
    +4 % at two, docs/engine.md)."""
    camera, _ = _ortho_camera(_unit((0.1, -1.0, 0.05)), 0.5, (32, 32))
    lights = [{"type": "SUN", "direction": tuple(_unit((-0.8, -1.0, 0.8))), "strength": (3, 3, 3)}]
    material = _hair_material(parametrization="COLOR", color=(0.35, 0.2, 0.1), roughness=0.25,
                              radial_roughness=0.3, coat=0.1, offset=0.0349066)

    def relative_difference(bounces):
        integ = _integrator(samples=512, film_transparent=True, tilt="3.4", max_bounces=bounces,
                            glossy_bounces=bounces, transmission_bounces=bounces)
        scene = {"curves": _curtain(), "curve_shape": "RIBBONS", "materials": [material], "camera": camera,
                 "lights": lights, "world": {"color": (0, 0, 0)}, "integrator": integ}
        imgs = [render(dict(scene, integrator=dict(integ, chiang_lcg=on)), threads=2)["combined"]
                for on in (False, True)]
        hair = (imgs[0][..., 3] > 0.99) & (imgs[1][..., 3] > 0.99)
        assert hair.sum() > 500
        d = (imgs[1][..., :3] - imgs[0][..., :3])[hair].mean(axis=1)
        mean = imgs[0][..., :3][hair].mean()
        return d.mean() / mean, d.std() / math.sqrt(d.size) / mean

    one, one_se = relative_difference(1)
    assert abs(one) < 4 * one_se, (one, one_se)
    three, three_se = relative_difference(3)
    assert three > 5 * three_se and three > 0.2, (three, three_se)


def test_light_tree_nee_and_forward_pdfs_agree_on_a_diffuse_clump():
    """A diffuse closure's pdf is its sampling density, so with MIS the image is unbiased for any
    light pick, provided NEE and the BSDF ray's hit use the same selection pdf: lights with a
    radius, an area and a sun with an angle (all MIS), no transmission (the light tree's back-face
    culls on). Tree and uniform pick agree in the mean."""
    camera, _ = _ortho_camera(_unit((0.2, 0.1, 1.0)), 1.2, (32, 32))
    lights = [{"type": "POINT", "position": p, "strength": (w, w, w), "radius": r}
              for p, w, r in (((0.6, 0.3, 0.5), 8.0, 0.3), ((-0.8, 0.2, 0.4), 4.0, 0.2), ((0.2, -0.9, 0.9), 15.0, 0.4))]
    lights.append({"type": "AREA", "matrix_world": np.array([[1, 0, 0, 0.0], [0, 1, 0, 0.0], [0, 0, 1, 1.0],
                                                              [0, 0, 0, 1]]),
                   "strength": (6, 6, 6), "shape": "SQUARE", "size_x": 0.8})
    lights.append({"type": "SUN", "direction": (0.3, 0.2, 1.0), "strength": (1, 1, 1), "angle": 0.3})
    scene = {"curves": _clump(n=30), "camera": camera, "lights": lights, "world": {"color": (0, 0, 0)},
             "materials": [{"name": "d", "closures": [{"type": "diffuse", "color": (0.8, 0.8, 0.8)}]}],
             "integrator": _integrator(samples=64, max_bounces=1, diffuse_bounces=1, film_transparent=True)}
    imgs = [render(dict(scene, integrator=dict(scene["integrator"], light_tree=tree)), threads=2)["combined"]
            for tree in (False, True)]
    hair = (imgs[0][..., 3] > 0.99) & (imgs[1][..., 3] > 0.99)
    assert hair.sum() > 50
    # Paired per pixel: the difference has no spatial variation, only the two renders' noise.
    d = (imgs[1][..., :3] - imgs[0][..., :3])[hair].mean(axis=1)
    mean = imgs[0][..., :3][hair].mean()
    assert abs(d.mean()) < 4 * d.std() / math.sqrt(d.size) + 1e-6, (d.mean() / mean, d.std() / math.sqrt(d.size) / mean)


@pytest.mark.parametrize("tree", [False, True])
def test_emissive_mesh_nee_and_forward_pdfs_agree_on_a_diffuse_clump(tree):
    """Emissive triangles light-sampled (Cycles' mesh lights) or reached by BSDF rays only give
    the same mean on a diffuse closure (its pdf is its sampling density) only if NEE and the
    BSDF ray's hit of a triangle use the same light pdf and selection pdf: with Cycles 3.x's
    distribution (lamps half, triangles half by area) and with the light tree's mesh subtrees.
    Light sampling must also lower the noise."""
    camera, _ = _ortho_camera(_unit((0.2, 0.1, 1.0)), 1.2, (32, 32))
    quad = np.array([[-0.6, -0.4, 1.0], [0.5, -0.5, 1.1], [0.6, 0.5, 0.9], [-0.4, 0.6, 1.0],
                     [0.9, -0.2, 0.2], [1.2, 0.3, 0.3], [0.8, 0.4, 0.1]], np.float32)
    meshes = {"vertices": quad, "triangles": np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6]], np.int32),
              "triangle_material": np.array([1, 1, 1], np.int32), "triangle_object": np.array([0, 0, 1], np.int32)}
    glow = {"name": "glow", "closures": [{"type": "emission", "color": (1.0, 0.9, 0.8), "strength": 3.0}]}
    scene = {"curves": _clump(n=30), "camera": camera, "meshes": meshes, "world": {"color": (0, 0, 0)},
             "lights": [{"type": "POINT", "position": (0.6, 0.3, 0.5), "strength": (4, 4, 4), "radius": 0.3}],
             "materials": [{"name": "d", "closures": [{"type": "diffuse", "color": (0.8, 0.8, 0.8)}]}, glow],
             "integrator": _integrator(samples=192, max_bounces=1, diffuse_bounces=1, film_transparent=True,
                                       light_tree=tree)}
    imgs = []
    for sampling in ("NONE", "FRONT_BACK"):
        scene["materials"][1] = dict(glow, emission_sampling=sampling)
        imgs.append(render(scene, threads=2)["combined"])
    hair = (imgs[0][..., 3] > 0.99) & (imgs[1][..., 3] > 0.99) & (imgs[0][..., 1] > 0)
    assert hair.sum() > 50
    d = (imgs[1][..., :3] - imgs[0][..., :3])[hair].mean(axis=1)
    mean = imgs[0][..., :3][hair].mean()
    assert abs(d.mean()) < 4 * d.std() / math.sqrt(d.size) + 1e-6, (d.mean() / mean, d.std() / math.sqrt(d.size) / mean)
    # light-sampled triangles: less pixel noise than BSDF hits alone (paired-neighbour estimate)
    def noise(img):
        g = img[..., 1]
        m = hair[:-1, :] & hair[1:, :]
        return float(np.std((g[1:, :] - g[:-1, :])[m]))
    assert noise(imgs[1]) < noise(imgs[0]), (noise(imgs[1]), noise(imgs[0]))


def test_bad_arguments():
    with pytest.raises(TypeError, match="cancel"):
        render(_small_scene(), cancel=5)
    with pytest.raises(ValueError, match="threads"):
        render(_small_scene(), threads=-2)
    with pytest.raises(TypeError, match="scene"):
        render([1, 2])


def test_import_hairbsdf_does_not_load_tbb():
    import subprocess
    import sys
    code = ("import hairbsdf, sys; maps = open('/proc/self/maps').read(); "
            "sys.exit(1 if ('libtbb' in maps or 'embree' in maps or 'hairbsdf._render' in sys.modules) else 0)")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


# --------------------------------------------------------------------------------------
# (e) determinism

def test_same_image_for_any_thread_count():
    scene = _busy_scene(samples=6)
    a = render(scene, threads=1)["combined"]
    b = render(scene, threads=2)["combined"]
    c = render(scene, threads=3)["combined"]
    assert np.array_equal(a, b) and np.array_equal(a, c)
    d = render(dict(scene, integrator=dict(scene["integrator"], seed=1)), threads=2)["combined"]
    assert not np.array_equal(a, d)


def test_validate_scene_normalises_dtypes():
    s = _small_scene()
    s["curves"]["points"] = s["curves"]["points"].astype(np.float64)
    s["curves"]["curve_offsets"] = list(s["curves"]["curve_offsets"])
    v = validate_scene(s)
    assert v["curves"]["points"].dtype == np.float32
    assert v["curves"]["curve_offsets"].dtype == np.int32


# --------------------------------------------------------------------------------------
# Huang in the engine: near field with the camera ray's footprint, the curve normal as the
# ellipse's major axis, and the transparent continuation outside the projected ellipse.

HUANG_INPUTS = dict(parametrization="COLOR", color=(0.6, 0.4, 0.25), roughness=0.35, aspect_ratio=0.5)


def _huang_strand_scene(wo, height, across, lights, world):
    """One straight elliptical Huang strand (HUANG_INPUTS) seen along wo by an orthographic camera
    `across` pixels per diameter, its major axis towards the viewer (projected width b).
    Returns (scene without integrator, pixel size, camera up vector, curve normal)."""
    pixel = 2 * R / across
    camera, yc = _ortho_camera(wo, height * pixel, (2, height))
    x = np.array([1.0, 0, 0])
    normal = _unit(wo - np.dot(wo, x) * x)
    strand = _straight_strand()
    strand["normals"] = np.tile(normal, (len(strand["points"]), 1)).astype(np.float32)
    material = {"name": "huang", "closures": [{"type": "principled_hair", "weight": (1, 1, 1), "model": "HUANG",
                                               "parametrization": "COLOR",
                                               "inputs": {k: v for k, v in HUANG_INPUTS.items()
                                                          if k != "parametrization"} | {"random": None}}]}
    scene = {"version": 1, "curves": strand, "curve_shape": "THICK", "curve_subdivisions": 2,
             "materials": [material], "camera": camera, "lights": lights, "world": {"color": world}}
    return scene, pixel, yc, normal


def test_huang_strand_pixels_equal_bsdf_eval():
    wo, wi = _unit((0.2, 0.3, 1.0)), _unit((-0.3, 0.6, 0.7))
    height, across = 96, 72
    strength = 2.0
    scene, pixel, yc, normal = _huang_strand_scene(
        wo, height, across, [{"type": "SUN", "direction": tuple(wi), "strength": (strength,) * 3, "angle": 0.0}],
        (0, 0, 0))
    x = np.array([1.0, 0, 0])
    inputs = HUANG_INPUTS
    scene["integrator"] = _integrator(samples=256, transparent_bounces=4)
    out = render(scene)
    img = out["combined"]
    assert out["stats"]["nan_count"] == 0 and not out["stats"]["warnings"]
    rows = np.arange(height)
    s = ((height - 1 - rows) + 0.5 - height / 2) * pixel
    y = _unit(np.cross(x, wo))
    z = np.cross(x, y)
    h = -s * np.dot(yc, y) / R
    frame = lambda w: np.array([w @ x, w @ y, w @ z])  # noqa: E731
    bsdf = hairbsdf.principled_hair(model="huang", random=hairbsdf.cycles_curve_random(0), **inputs)
    r = float(np.ravel(bsdf.huang_details(frame(wo), 0.0, normal=frame(normal))["radius"])[0])
    assert 0.45 < r < 0.55
    # outside the projected ellipse the ray goes on (transparent): nothing behind, alpha 0
    outside = (np.abs(h) > r + 0.03) & (np.abs(h) < 0.95)
    assert outside.sum() > 10 and np.all(img[outside, :, 3] == 0.0)
    inside = np.abs(h) < r - 0.03
    n = int(inside.sum())
    expected = strength * bsdf.eval(np.tile(frame(wo), (n, 1)), np.tile(frame(wi), (n, 1)), h[inside],
                                    normal=frame(normal), pixel_coverage=0.5 * pixel / R, near_field=True)
    got = img[inside, :, :3].astype(np.float64).mean(axis=1)
    assert np.all(img[inside, :, 3] == 1.0)
    total = abs(got.sum() / expected.sum() - 1)
    assert total < 0.02, f"strand total off by {total:.3%}"
    rel = np.abs(got - expected) / np.maximum(np.abs(expected), 1e-3 * expected.max())
    assert np.median(rel) < 0.05, f"median relative error {np.median(rel):.2e}"


def test_huang_sampler_setting_picks_the_estimator():
    """One Huang strand in a uniform white world, one bounce: each pixel is the mean BSDF-sample
    weight at its h (a uniform world is reached by BSDF rays only). With huang_sampler "cycles"
    (the default) that is the mean of Cycles' sampler weight, which is NOT the directional albedo
    of the eval: Cycles' weight is an energy estimate of the traced path, about 4 % above the
    integral of its own eval here (docs/huang.md §10). With "mixture" (exact pdf) it is the albedo."""
    wo = _unit((0.0, 0.6, 0.8))
    height, across = 64, 48
    scene, pixel, yc, normal = _huang_strand_scene(wo, height, across, [], (1.0, 1.0, 1.0))
    scene["integrator"] = _integrator(samples=512, max_bounces=1, glossy_bounces=1, transparent_bounces=4)
    x = np.array([1.0, 0, 0])
    inputs = HUANG_INPUTS
    rows = np.arange(height)
    h = -(((height - 1 - rows) + 0.5 - height / 2) * pixel) * np.dot(yc, _unit(np.cross(x, wo))) / R
    inside = np.abs(h) < 0.45
    totals = {}
    for sampler in ("cycles", "mixture"):
        scene["integrator"]["huang_sampler"] = sampler
        img = render(scene)["combined"]
        totals[sampler] = img[inside, :, :3].astype(np.float64).mean(axis=1).sum(axis=0)

    y = _unit(np.cross(x, wo))
    frame = lambda w: np.array([w @ x, w @ y, w @ (np.cross(x, y))])  # noqa: E731
    rng = np.random.default_rng(5)
    n_per_row = 4000
    hs = np.repeat(h[inside], n_per_row)
    kw = dict(normal=frame(normal), pixel_coverage=0.5 * pixel / R, near_field=True)
    wo_rows = np.tile(frame(wo), (len(hs), 1))
    cycles = hairbsdf.principled_hair(model="huang", sampler="cycles", random=hairbsdf.cycles_curve_random(0),
                                      **inputs)
    s = cycles.sample(wo_rows, hs, rng.random((len(hs), 3)), **kw)
    weight = np.where(s.lobe[:, None] >= 0, s.weight, 0.0)
    expected_cycles = weight.reshape(-1, n_per_row, 3).mean(axis=1).sum(axis=0)
    # the albedo of the eval: uniform directions over the sphere, Cycles' unbiased eval estimator
    z = rng.uniform(-1, 1, len(hs))
    phi = rng.uniform(0, 2 * np.pi, len(hs))
    wi = np.stack([z, np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi)], axis=1)
    f = cycles.cycles_estimate(wo_rows, wi, hs, samples=1, seed=9, **kw).sum(axis=1) * 4 * np.pi
    expected_albedo = f.reshape(-1, n_per_row, 3).mean(axis=1).sum(axis=0)

    np.testing.assert_allclose(totals["cycles"], expected_cycles, rtol=0.01)
    np.testing.assert_allclose(totals["mixture"], expected_albedo, rtol=0.025)
    ratio = totals["cycles"] / totals["mixture"]
    assert np.all(ratio > 1.02), f"Cycles' estimator should be brighter here, ratio {ratio}"


# --------------------------------------------------------------------------------------
# Passes: hair lobes of the first hair hit, depth, normal, variance of the pixel mean

def _lobe_scene(wo, wi, shape="THICK", passes=("hair_lobes", "depth", "normal"), **integrator):
    height, across = 120, 90
    pixel = 2 * R / across
    camera, yc = _ortho_camera(wo, height * pixel, (3, height))
    scene = {"version": 1, "curves": _straight_strand(), "curve_shape": shape,
             "materials": [_hair_material(melanin=0.3, roughness=0.25)], "camera": camera,
             "lights": [{"type": "SUN", "direction": tuple(wi), "strength": (2.0,) * 3, "angle": 0.0}],
             "world": {"color": (0, 0, 0)}, "integrator": _integrator(passes=list(passes), **integrator)}
    rows = np.arange(height)
    s = ((height - 1 - rows) + 0.5 - height / 2) * pixel
    return scene, s, yc


def test_hair_lobe_passes_are_the_lobes_of_the_eval():
    """Direct light only, one delta sun, 1 spp at the pixel centre: each lobe pass is the sun
    strength times that lobe of eval(wo, wi, h), and the four add up to Combined."""
    wo, wi = _unit((0.0, 0.45, 0.9)), _unit((0.3, -0.6, 0.5))
    scene, s, yc = _lobe_scene(wo, wi)
    out = render(scene)
    x = np.array([1.0, 0, 0])
    y = _unit(np.cross(x, wo))
    z = np.cross(x, y)
    h = -s * np.dot(yc, y) / R
    inside = np.abs(h) < 0.98
    frame = lambda w: np.array([w @ x, w @ y, w @ z])  # noqa: E731
    bsdf = hairbsdf.principled_hair(parametrization="melanin", melanin=0.3, roughness=0.25,
                                    random=hairbsdf.cycles_curve_random(0))
    n = int(inside.sum())
    lobes = 2.0 * bsdf.eval_lobes(np.tile(frame(wo), (n, 1)), np.tile(frame(wi), (n, 1)), h[inside])
    for k, name in enumerate(("hair_r", "hair_tt", "hair_trt", "hair_trrt")):
        got = out[name][inside, 1].astype(np.float64)
        want = lobes[:, :, k] if lobes.shape[1] == 3 else lobes[:, k, :]
        scale = max(float(np.abs(want).max()), 1e-12)
        assert np.max(np.abs(got - want)) <= 1e-4 * scale, (name, np.max(np.abs(got - want)), scale)
    total = sum(out[n][..., :3] for n in ("hair_r", "hair_tt", "hair_trt", "hair_trrt"))
    np.testing.assert_allclose(total, out["combined"][..., :3], rtol=1e-5, atol=1e-7)
    # Depth and normal of the hit: wo is perpendicular to the strand, so the surface point
    # at offset h is sqrt(1 - h^2) radii in front of the axis, 0.25 from the camera.
    depth = out["depth"][inside, 1]
    np.testing.assert_allclose(depth, 0.25 - R * np.sqrt(1 - h[inside] ** 2), atol=2e-6)
    assert np.all(out["depth"][np.abs(h) > 1.05, 1] == 1e10)  # background
    normal = out["normal"][inside, 1]
    np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, atol=1e-5)
    np.testing.assert_allclose(normal @ x, 0.0, atol=1e-5)
    np.testing.assert_allclose(normal @ wo, np.sqrt(1 - h[inside] ** 2), atol=1e-4)


@pytest.mark.parametrize("shape", ["THICK", "RIBBONS"])
def test_hair_lobe_passes_add_up_to_combined_with_bounces(shape):
    """With multiple scattering, a world and a transparent film every contribution comes after
    the camera ray's first hair hit, so the lobe passes add up to Combined pixel by pixel; TRT
    and TRRT+ are not empty."""
    camera, _ = _ortho_camera(_unit((0.2, 0.1, 1.0)), 1.2, (24, 24))
    scene = {"curves": _clump(), "curve_shape": shape, "materials": [_hair_material(melanin=0.2)],
             "camera": camera, "lights": [{"type": "SUN", "direction": (0.3, 0.2, 0.9), "strength": (2.0,) * 3,
                                           "angle": 0.1}],
             "world": {"color": (0.2, 0.25, 0.3)},
             "integrator": _integrator(samples=8, max_bounces=8, glossy_bounces=8, transmission_bounces=8,
                                       filter_width=1.5, passes=["hair_lobes"])}
    out = render(scene, threads=2)
    total = sum(out[n] for n in ("hair_r", "hair_tt", "hair_trt", "hair_trrt"))
    combined = out["combined"][..., :3]
    assert combined.max() > 0.05
    np.testing.assert_allclose(total, combined, rtol=1e-4, atol=1e-6)
    for name in ("hair_r", "hair_tt", "hair_trt", "hair_trrt"):
        assert out[name].sum() > 0.002 * combined.sum(), name
    assert "depth" not in out and "variance" not in out  # only what was asked for


def test_variance_pass_is_the_variance_of_the_pixel_mean():
    """The variance pass of one render predicts the spread of the pixel means over independent
    seeds (averaged over the pixels: ratio within 15 %)."""
    camera, _ = _ortho_camera(_unit((0.2, 0.1, 1.0)), 1.2, (16, 16))
    scene = {"curves": _clump(), "materials": [_hair_material(melanin=0.2)], "camera": camera,
             "lights": [{"type": "POINT", "position": (0.5, 0.4, 1.0), "strength": (20.0,) * 3, "radius": 0.3}],
             "world": {"color": (0.1, 0.1, 0.1)},
             "integrator": _integrator(samples=16, max_bounces=4, glossy_bounces=4, transmission_bounces=4,
                                       filter_width=1.5, film_transparent=False, passes=["variance"])}
    means, predicted = [], []
    for seed in range(12):
        out = render(dict(scene, integrator=dict(scene["integrator"], seed=seed)), threads=2)
        means.append(out["combined"][..., :3])
        predicted.append(out["variance"])
    observed = np.var(np.array(means), axis=0, ddof=1)
    pred = np.mean(np.array(predicted), axis=0)
    busy = pred > np.percentile(pred, 50)  # pixels with noise
    ratio = observed[busy].mean() / pred[busy].mean()
    assert 0.85 < ratio < 1.15, ratio
    assert np.all(np.array(predicted) >= 0)


def test_each_pass_of_the_table_gives_its_images():
    """The pass table (_core.render_passes(), plugin/bindings/render_passes.h) is what the scene
    schema allows, and a render asking for every pass returns exactly its images, (H, W) for one
    channel and (H, W, channels) otherwise; render()'s docstring names each."""
    from hairbsdf import _core, _render
    from hairbsdf.render import PASSES
    table = _core.render_passes()
    assert tuple(p["name"] for p in table) == PASSES
    scene, _, _ = _lobe_scene(_unit((0, 0.4, 0.9)), _unit((0.3, -0.6, 0.5)), passes=PASSES)
    out = render(scene)
    height, width = out["combined"].shape[:2]
    images = {im["key"]: im["channels"] for p in table for im in p["images"]}
    assert set(out) - {"combined", "stats"} == set(images)
    for key, channels in images.items():
        assert out[key].shape == ((height, width) if channels == 1 else (height, width, channels)), key
        assert f"'{key}'" in _render.render.__doc__, key


def test_unknown_pass_names_the_key():
    scene, _, _ = _lobe_scene(_unit((0, 0.4, 0.9)), _unit((0.3, -0.6, 0.5)), passes=("hair_lobes", "mist"))
    with pytest.raises(ValueError, match=r"\['passes'\]\[1\].*'mist' is not allowed"):
        render(scene)


def test_huang_glass_albedo_table_setting_reaches_the_model():
    """integrator.huang_glass_albedo_table picks Cycles 4.x's or 5.x's energy-compensation tables
    (docs/blender5.md): the same render (same samples) with 5.x's is brighter on this back-lit strand,
    where light leaves the fibre by refraction; an unknown value names the key and the allowed ones."""
    wo = _unit((0.0, 0.6, 0.8))
    scene, _, _, _ = _huang_strand_scene(wo, 16, 12, [], (1.0, 1.0, 1.0))
    scene["integrator"] = _integrator(samples=16, max_bounces=1, glossy_bounces=1, transparent_bounces=4)
    means = {}
    for table in ("4.x", "5.x"):
        scene["integrator"]["huang_glass_albedo_table"] = table
        means[table] = float(render(scene)["combined"][..., :3].astype(np.float64).mean())
    assert means["5.x"] > means["4.x"] * 1.0005, means
    scene["integrator"]["huang_glass_albedo_table"] = "5.3"
    with pytest.raises(ValueError, match=r"huang_glass_albedo_table.*'5.3' is not allowed.*'4.x', '5.x'"):
        render(scene)
