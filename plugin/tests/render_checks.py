"""Shared checks of the engine tests: two renders of one scene that may differ only at float rounding."""

import numpy as np


def assert_same_render_at_float_rounding(result, reference, max_pixel_share=0.03):
    """Embree's streams and packets return some hits one rounding step away from single-ray queries:
    the first hits' depth and normal agree to float rounding, and the paths from them give equal bits
    in almost every pixel, the rest within float-rounding effects on the same expected value."""
    np.testing.assert_allclose(result["depth"], reference["depth"], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(result["normal"], reference["normal"], rtol=0, atol=1e-4)
    image, other = reference["combined"], result["combined"]
    differ = np.any(other != image, axis=-1)
    assert differ.mean() <= max_pixel_share, f"{differ.sum()} of {differ.size} pixels differ"
    np.testing.assert_allclose(other, image, rtol=0, atol=1e-3)
    assert abs(float(other.mean()) - float(image.mean())) <= 1e-6 * float(image.mean())
