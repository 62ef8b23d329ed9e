"""integrator.wavefront (issue 29, docs/engine.md "A wavefront engine"): a tile's paths traced together,
each bounce's rays and shadow rays as Embree streams, hits shaded grouped by material, through the same
stage functions as the per-pixel loop. With its rays traced one by one (integrator.wavefront_streams off)
and every hit on the scalar path (integrator.wavefront_kernels off) the image must be the per-pixel image
bit for bit (every pass, the ray count too); with streams it is that image at float rounding, as the
camera-ray stream's (test_camera_ray_stream.py). With the batch kernels (the default) one-closure Chiang
materials are shaded in float32: each path the per-pixel one to float rounding."""

import numpy as np
import pytest

from hairbsdf.render import render
from render_checks import assert_differences_average_out, assert_same_render_at_float_rounding
from test_camera_ray_stream import _scene


def _lit(shape, model, **integrator):
    """The camera-stream scene with every kind of light the NEE and forward-MIS stages handle: a sun, a
    point light with a radius, an area light, an emissive triangle (light-sampled on both sides) and
    the world; Russian roulette from the first bounce, Filter Glossy and clamping on."""
    scene = _scene(shape, model, False)
    mesh = scene["meshes"]
    mesh["vertices"] = np.concatenate([mesh["vertices"], np.array([[0.9, -0.6, 0.7], [1.3, 0.2, 0.8], [0.7, 0.3, 1.1]],
                                                                  np.float32)])
    mesh["triangles"] = np.concatenate([mesh["triangles"], np.array([[4, 5, 6]], np.int32)])
    mesh["triangle_material"] = np.array([0, 0, 2], np.int32)
    scene["materials"].append({"name": "glow", "emission_sampling": "FRONT_BACK",
                               "closures": [{"type": "emission", "color": (1.0, 0.8, 0.6), "strength": 4.0}]})
    area = np.eye(4)
    area[:3, 3] = (-0.5, 0.4, 1.2)
    scene["lights"] += [{"type": "POINT", "position": (0.5, -0.4, 0.8), "strength": (3, 3, 3), "radius": 0.2},
                        {"type": "AREA", "matrix_world": area, "shape": "SQUARE", "size_x": 0.6, "strength": (5, 5, 5)}]
    scene["integrator"].update(min_light_bounces=0, filter_glossy=1.0, clamp_indirect=5.0, **integrator)
    return scene


CASES = {  # id: (curve shape, model, integrator settings)
    "chiang-tree": ("THICK", "CHIANG", {"light_tree": True}),
    "ribbons-lcg-transparent": ("RIBBONS", "CHIANG", {"light_tree": False, "chiang_lcg": True, "film_transparent": True}),
    "huang-tree": ("THICK", "HUANG", {"light_tree": True}),
}


def _wavefront(scene, **settings):
    return render(dict(scene, integrator=dict(scene["integrator"], wavefront=True, **settings)), threads=2)


@pytest.mark.parametrize("case", CASES)
def test_wavefront_is_the_per_pixel_image_bit_for_bit(case):
    """Rays traced one by one (wavefront_streams off): the same hits as the per-pixel loop, so every
    path must draw, shade and add exactly as there."""
    shape, model, settings = CASES[case]
    scene = _lit(shape, model, **settings)
    per_pixel, wavefront = render(scene, threads=2), _wavefront(scene, wavefront_streams=False, wavefront_kernels=False)
    assert float(per_pixel["combined"][..., :3].mean()) > 0.01  # lit: not a comparison of empty images
    for name, value in per_pixel.items():
        if isinstance(value, np.ndarray):
            different = np.any(wavefront[name] != value, axis=-1) if value.ndim == 3 else wavefront[name] != value
            assert not different.any(), f"{name}: {int(different.sum())} of {different.size} pixels differ"
    assert wavefront["stats"]["rays"] == per_pixel["stats"]["rays"]
    assert wavefront["stats"]["nan_count"] == per_pixel["stats"]["nan_count"]


def test_wavefront_traces_a_large_tile_a_group_of_rows_at_a_time_bit_for_bit():
    """One thread on 64 x 32 pixels: 16-pixel tiles, whose passes of 4 samples and more hold more paths than
    the wavefront takes at once (kMaxPaths, wavefront.cpp), so the rows go in groups; still the per-pixel image."""
    scene = _lit("THICK", "CHIANG", light_tree=True, samples=7)
    scene["camera"]["resolution"] = (64, 32)
    per_pixel = render(scene, threads=1)
    wavefront = render(dict(scene, integrator=dict(scene["integrator"], wavefront=True, wavefront_streams=False,
                                                    wavefront_kernels=False)), threads=1)
    assert per_pixel["stats"]["samples"] == 7
    np.testing.assert_array_equal(wavefront["combined"], per_pixel["combined"])
    assert wavefront["stats"]["rays"] == per_pixel["stats"]["rays"]


@pytest.mark.parametrize("coherent_camera_rays", [False, True])
def test_wavefront_streams_are_the_per_pixel_image_at_float_rounding(coherent_camera_rays):
    """Rays as Embree streams (the default): Embree's packets return some hits a rounding step away
    (the first hits' depth and normal show it), and a path goes on from there."""
    scene = _lit("THICK", "CHIANG", light_tree=True)
    per_pixel = render(scene, threads=2)
    stream = _wavefront(scene, camera_ray_stream=coherent_camera_rays, wavefront_kernels=False)
    assert_same_render_at_float_rounding(stream, per_pixel)
    assert abs(stream["stats"]["rays"] - per_pixel["stats"]["rays"]) <= 1e-3 * per_pixel["stats"]["rays"]


def _kernel_scene(**integrator):
    """_lit's Chiang scene with every hair hit for the batch kernels (no lobe passes, Filter Glossy off);
    its hair with Random Roughness (the curve's Random goes to the kernels per row) and a coloured weight."""
    scene = _lit("THICK", "CHIANG", light_tree=True, samples=4, **integrator)
    scene["integrator"].update(filter_glossy=0.0, passes=["depth", "normal"])
    hair = scene["materials"][1]["closures"][0]
    hair["weight"] = (0.9, 0.8, 0.7)
    hair["inputs"]["random_roughness"] = 0.5
    return scene


def _assert_same_paths_at_float_precision(result, reference):
    """Every path of `result` is `reference`'s with its hair shaded in float32 instead of double: the same
    camera rays and first hits (depth, normal), every image within 1e-3 of the reference's value (relative to
    the pixel's largest channel plus 1e-3) but for paths that went another way at a rounding step (a sampled
    direction or a roulette decision), at most 1 % of the pixels; and their differences average out."""
    np.testing.assert_array_equal(result["depth"], reference["depth"])
    np.testing.assert_array_equal(result["normal"], reference["normal"])
    for name, value in reference.items():
        if not isinstance(value, np.ndarray) or name in ("depth", "normal"):
            continue
        image, other = value.astype(np.float64), result[name].astype(np.float64)
        assert np.all(np.isfinite(other)), name
        if image.ndim == 2:
            image, other = image[..., None], other[..., None]
        scale = np.abs(image).max(axis=-1) + 1e-3
        apart = np.abs(other - image).max(axis=-1) > 1e-3 * scale
        assert apart.mean() <= 0.01, f"{name}: {int(apart.sum())} of {apart.size} pixels differ by more than 1e-3"
        assert_differences_average_out((other - image).mean(axis=-1), image.mean(), what=name)


def test_wavefront_kernels_shade_the_hair_as_the_scalar_path():
    """All hair hits through the kernels (Random Roughness per row, a coloured closure weight, the light
    samples' evals and the BSDF samples): each path is the per-pixel loop's to float precision."""
    scene = _kernel_scene()
    per_pixel = render(scene, threads=2)
    kernels = _wavefront(scene, wavefront_streams=False)
    assert per_pixel["stats"]["kernel_hits"] == 0
    assert kernels["stats"]["kernel_hits"] > 1000  # the hair's hits: 1 735 at 4 spp
    assert float(per_pixel["combined"][..., :3].mean()) > 0.01
    _assert_same_paths_at_float_precision(kernels, per_pixel)
    assert kernels["stats"]["rays"] == per_pixel["stats"]["rays"]
    assert kernels["stats"]["nan_count"] == 0


def test_wavefront_kernels_leave_blurred_hits_and_lobe_passes_to_the_scalar_path():
    """Filter Glossy's blurred hits and the lobe passes' first hair hits go the scalar way (the hair-lobe
    passes need each lobe's value), the others through the kernels; with Cycles < 3.6's LCG every hit goes
    the scalar way, and the image is the per-pixel one bit for bit."""
    scene = _lit("THICK", "CHIANG", light_tree=True)
    per_pixel = render(scene, threads=2)
    kernels = _wavefront(scene, wavefront_streams=False)
    assert 0 < kernels["stats"]["kernel_hits"]
    _assert_same_paths_at_float_precision(kernels, per_pixel)

    lcg = _lit("THICK", "CHIANG", light_tree=True, chiang_lcg=True)
    per_pixel, kernels = render(lcg, threads=2), _wavefront(lcg, wavefront_streams=False)
    assert kernels["stats"]["kernel_hits"] == 0
    np.testing.assert_array_equal(kernels["combined"], per_pixel["combined"])
