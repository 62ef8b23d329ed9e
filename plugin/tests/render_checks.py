"""Shared checks of the engine tests: two renders of one scene that may differ only at float rounding."""

import numpy as np


def assert_differences_average_out(difference, scale, what="the renders"):
    """Paths that went other ways (a hit one rounding step away) carry the same expected value, so their
    differences (one value per pixel) must average out: their mean is within 4 standard errors of zero,
    plus 1e-7 of `scale` (the compared image's mean) for float rounding."""
    difference = np.asarray(difference, np.float64).ravel()
    assert difference.size >= 2, f"{what}: {difference.size} values to compare"
    standard_error = difference.std(ddof=1) / np.sqrt(difference.size)
    assert abs(difference.mean()) <= 4 * standard_error + 1e-7 * abs(scale), (
        f"{what}: mean difference {difference.mean():.3e}, standard error {standard_error:.3e}")


def assert_same_render_at_float_rounding(result, reference, max_pixel_share=0.35):
    """Embree's streams and packets return some hits one rounding step away from single-ray queries:
    the first hits' depth and normal agree to float rounding, and a path goes on from that point with
    its own random numbers, so most pixels are equal bit for bit and the others carry the same expected
    value. How many differ depends on Embree's packet width, so on the CPU: 3 % of the pixels with
    AVX-512, up to 17 % with AVX2 (the wavefront's bounce streams). The differences of the diverged
    paths must average out: their mean is within 4 standard errors of zero."""
    np.testing.assert_allclose(result["depth"], reference["depth"], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(result["normal"], reference["normal"], rtol=0, atol=1e-4)
    image = reference["combined"].astype(np.float64)
    other = result["combined"].astype(np.float64)
    differ = np.any(other != image, axis=-1)
    assert differ.mean() <= max_pixel_share, f"{differ.sum()} of {differ.size} pixels differ"
    assert np.all(np.isfinite(other))
    assert_differences_average_out((other - image)[..., :3].mean(axis=-1), image.mean())
