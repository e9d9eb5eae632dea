"""Bad input to the vision algorithms raises the documented errors, never NaN results."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.errors import ParameterError, ResourceError
from brdfkit.vision import metrics, normal_integration, photometric_stereo, separation
from brdfkit.vision.shape_from_shading import shape_from_shading

NORMALS, MASK = photometric_stereo.sphere_normals((12, 12), (5.5, 5.5), 5.0)
LIGHTS = np.array([[0.0, 0.0, 1.0], [0.5, 0.0, 1.0], [0.0, 0.5, 1.0], [-0.5, -0.5, 1.0]])
IMAGES = np.clip(np.einsum("hwj,nj->nhw", NORMALS, LIGHTS), 0, None)


def _with_nan(array: np.ndarray, index: tuple) -> np.ndarray:
    array = np.array(array, dtype=np.float64)
    array[index] = np.nan
    return array


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: photometric_stereo.least_squares(_with_nan(IMAGES, (0, 6, 6)), LIGHTS, MASK),
         ParameterError, "non-finite"),
        (lambda: photometric_stereo.least_squares(IMAGES, _with_nan(LIGHTS, (1, 0))),
         ParameterError, "light_directions"),
        (lambda: photometric_stereo.robust_pca(IMAGES, LIGHTS, MASK, lam=np.nan),
         ParameterError, "lam"),
        (lambda: photometric_stereo.sparse_regression(IMAGES, LIGHTS, max_iterations=10**9),
         ResourceError, "max_iterations"),
        (lambda: photometric_stereo.sparse_regression(IMAGES, LIGHTS, tol=np.nan),
         ParameterError, "tol"),
        (lambda: photometric_stereo.calibrate_lights_chrome_sphere(
            _with_nan(IMAGES, (0, 6, 6)), MASK), ParameterError, "images"),
        (lambda: photometric_stereo.sphere_normals((10**6, 10**6), (0, 0), 3.0),
         ResourceError, "pixels"),
        (lambda: photometric_stereo.sphere_normals((8, 8), (np.nan, 0), 3.0),
         ParameterError, "centre"),
        (lambda: normal_integration.poisson_dct(_with_nan(NORMALS, (6, 6, 0)), MASK),
         ParameterError, "finite"),
        (lambda: normal_integration.least_squares_integration(
            NORMALS, MASK, np.full((3, 3), np.nan)),
         ParameterError, "camera"),
        (lambda: shape_from_shading(IMAGES[0], [0, 0, 1], MASK, smoothness=np.inf),
         ParameterError, "smoothness"),
        (lambda: shape_from_shading(IMAGES[0], [0, 0, 1], MASK, albedo=np.inf),
         ParameterError, "albedo"),
        (lambda: shape_from_shading(IMAGES[0], [0, 0, 1], MASK,
                                    initial_depth=_with_nan(np.zeros((12, 12)), (6, 6))),
         ParameterError, "initial_depth"),
        (lambda: shape_from_shading(IMAGES[0], [0, 0, 1], MASK, max_iterations=0),
         ParameterError, "max_iterations"),
        (lambda: shape_from_shading(IMAGES[0], [0, 0, 1], MASK, max_iterations=10**9),
         ResourceError, "max_iterations"),
        (lambda: separation.separate_dichromatic(np.ones((4, 4, 3)), sigma_space=1e9),
         ParameterError, "sigma_space"),
        (lambda: separation.separate_dichromatic(np.ones((4, 4, 3)), iterations=10**9),
         ResourceError, "iterations"),
        (lambda: separation.separate_dichromatic(np.ones((4, 4, 3)), dark=np.nan),
         ParameterError, "dark"),
        (lambda: separation.separate_polarization(np.ones((4, 4, 3)), _with_nan(
            np.ones((4, 4, 3)), (0, 0, 0))), ParameterError, "crossed"),
        (lambda: metrics.angular_error(_with_nan(NORMALS, (6, 6, 0)), NORMALS, MASK),
         ParameterError, "normals"),
        (lambda: metrics.angular_error_map(NORMALS, NORMALS, np.zeros((12, 12), bool)),
         ParameterError, "mask"),
    ],
)  # fmt: skip
def test_bad_input_raises_documented_errors(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_nan_outside_the_mask_is_ignored():
    normals = _with_nan(NORMALS, (0, 0, 0))
    assert not MASK[0, 0]
    error = metrics.angular_error(normals, NORMALS, MASK)
    assert error["mean"] == pytest.approx(0.0, abs=1e-6)
    assert np.all(np.isfinite(normal_integration.poisson_dct(normals, MASK)[MASK]))
