"""integrator.camera_ray_stream (issue 29's first wavefront step, docs/engine.md "A wavefront engine"):
camera rays traced as one coherent Embree stream per tile give the per-pixel path tracer's image at
float rounding, on curves (round and ribbons), a mesh, and Huang's transparent bounces. Not bit for bit:
Embree 3's packet traversal returns some hits one float rounding away from rtcIntersect1's (the depth
and normal passes show it), and a path continues from that point; every path keeps its own random
numbers, so the images agree pixel by pixel except where such a hit changes the path."""

import numpy as np
import pytest

import hairbsdf
from hairbsdf.render import render
from render_checks import assert_same_render_at_float_rounding


def _clump(n=40, keys=6, seed=3, radius=0.03):
    rng = np.random.default_rng(seed)
    pts, off = [], [0]
    for _ in range(n):
        p0 = rng.uniform(-0.3, 0.3, 3) * (1, 1, 0.3) + (0, 0, 0.2)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        for k in range(keys):
            t = k / (keys - 1) - 0.5
            pts.append([*(p0 + 0.8 * t * d), radius * (1 - 0.5 * (t + 0.5))])
        off.append(len(pts))
    c = len(off) - 1
    return {"points": np.array(pts, np.float32), "curve_offsets": np.array(off, np.int32),
            "curve_random": np.asarray(hairbsdf.cycles_curve_random(np.arange(c)), np.float32),
            "curve_material": np.ones(c, np.int32)}


def _scene(shape, model, stream):
    camera = np.array([[1, 0, 0, 0], [0, 0.8, -0.6, -1.6], [0, 0.6, 0.8, 2.0], [0, 0, 0, 1]], float)
    return {
        "curves": _clump(), "curve_shape": shape,
        "meshes": {"vertices": np.array([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]], np.float32),
                   "triangles": np.array([[0, 1, 2], [0, 2, 3]], np.int32),
                   "triangle_material": np.zeros(2, np.int32)},
        "materials": [{"name": "plane", "closures": [{"type": "diffuse", "weight": (1, 1, 1), "color": (0.8, 0.8, 0.8)}]},
                      {"name": "hair", "closures": [{"type": "principled_hair", "weight": (1, 1, 1), "model": model,
                                                     "parametrization": "MELANIN",
                                                     "inputs": {"melanin": 0.3, "roughness": 0.3, "random": None}}]}],
        "camera": {"type": "PERSP", "matrix_world": camera, "resolution": (40, 28), "lens": 35.0,
                   "sensor_width": 36.0, "sensor_fit": "AUTO", "clip_start": 0.01, "clip_end": 100.0},
        "lights": [{"type": "SUN", "direction": (0.3, -0.2, 1.0), "strength": (2, 2, 2), "angle": 0.1}],
        "world": {"color": (0.3, 0.3, 0.3)},
        "integrator": {"samples": 3, "seed": 5, "max_bounces": 6, "diffuse_bounces": 2, "glossy_bounces": 3,
                       "transmission_bounces": 6, "transparent_bounces": 8, "min_light_bounces": 0,
                       "filter_type": "BLACKMAN_HARRIS", "filter_width": 1.5, "exposure": 1.0,
                       "film_transparent": False, "light_sampling_threshold": 0.0, "tilt": "4.2",
                       "passes": ["hair_lobes", "depth", "normal"], "camera_ray_stream": stream,
                       "wavefront": False},  # the per-pixel loop (the default is the wavefront)
    }


@pytest.mark.parametrize("shape,model", [("THICK", "CHIANG"), ("RIBBONS", "CHIANG"), ("THICK", "HUANG")])
def test_camera_ray_stream_is_the_per_pixel_image(shape, model):
    per_pixel = render(_scene(shape, model, False), threads=2)
    stream = render(_scene(shape, model, True), threads=2)
    assert float(per_pixel["combined"][..., :3].mean()) > 0.01  # lit: the comparison is not of empty images
    assert_same_render_at_float_rounding(stream, per_pixel)
