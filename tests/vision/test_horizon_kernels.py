"""The compiled horizon march (:mod:`brdfkit.vision._horizon_kernels`) against its readable
NumPy version (:func:`brdfkit.vision.datasets.horizon_excess_reference`): the same numbers."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.vision import datasets


@pytest.mark.parametrize("seed", range(4))
def test_the_kernel_is_the_numpy_march(seed):
    """Rough height fields with holes, every kind of light: above at any elevation, at the
    zenith, below the horizon; several pixel sizes."""
    rng = np.random.default_rng(seed)
    height = rng.normal(size=(23, 37)).cumsum(0).cumsum(1) * rng.uniform(0.05, 0.5)
    height[rng.random(height.shape) < 0.15] = np.nan
    lights = datasets.diligent_like_lights()
    extra = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, -0.8], [0.0, -1.0, 0.0], [0.99, 0.1, 0.02]])
    lights = np.vstack([lights, extra / np.linalg.norm(extra, axis=1, keepdims=True)])
    for pixel_size in (0.3, 1.0, 4.0):
        compiled = datasets.horizon_excess(height, lights, pixel_size)
        np.testing.assert_array_equal(
            compiled, datasets.horizon_excess_reference(height, lights, pixel_size)
        )
        assert np.isfinite(compiled).any() and np.isneginf(compiled[len(lights) - 4]).all()


def test_the_kernel_is_the_numpy_march_on_a_real_object(shared_data):
    """DiLiGenT's bear (its real depth, 96 DiLiGenT-like lights), as the renders use it."""
    gt = datasets.load_normal_integration(shared_data / "normal_integration" / "diligent" / "bear")
    height = -np.where(gt.mask, gt.depth, np.nan)[::4, ::4]
    pixel_size = np.nanmean(gt.depth) / gt.camera[0, 0] * 4
    lights = datasets.diligent_like_lights()
    compiled = datasets.horizon_excess(height, lights, pixel_size)
    np.testing.assert_array_equal(
        compiled, datasets.horizon_excess_reference(height, lights, pixel_size)
    )
    assert (compiled > 0).any()  # some cast shadows, so the march found occluders
