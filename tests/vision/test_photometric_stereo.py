"""Photometric stereo: exactness on Lambertian data, robustness on a DiLiGenT-layout render of
real ground-truth normals, chrome-sphere calibration and the real psm gray sphere."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.vision import datasets
from brdfkit.vision.metrics import angular_error
from brdfkit.vision.photometric_stereo import (
    METHODS,
    calibrate_lights_chrome_sphere,
    fit_circle,
    least_squares,
    robust_pca,
    sparse_regression,
    sphere_normals,
    trimmed_least_squares,
)


def _sphere(size: int = 40) -> tuple[np.ndarray, np.ndarray]:
    normals, inside = sphere_normals((size, size), ((size - 1) / 2, (size - 1) / 2), size / 2.2)
    return normals, inside


def test_least_squares_is_exact_on_lambertian_images():
    normals, mask = _sphere()
    rng = np.random.default_rng(1)
    lights = datasets.diligent_like_lights(4, 3, np.radians(30))
    albedo = rng.uniform(0.2, 0.9, (*mask.shape, 3))
    # Only the pixels every light reaches: there the model is exactly linear.
    lit = mask & np.all(normals @ lights.T > 0, axis=-1)
    data = datasets.render_synthetic(normals, lit, lights, albedo=albedo)
    result = least_squares(data.images, data.light_directions, lit)
    assert angular_error(result.normals, normals, lit)["mean"] < 1e-6
    np.testing.assert_allclose(result.albedo[lit], albedo[lit], rtol=1e-5)
    assert np.all(result.normals[~lit] == 0)
    trimmed = trimmed_least_squares(data.images, data.light_directions, lit)
    assert angular_error(trimmed.normals, normals, lit)["mean"] < 1e-6


@pytest.mark.parametrize("method", list(METHODS))
def test_every_method_is_close_on_lambertian_images(method):
    normals, mask = _sphere(32)
    lights = datasets.diligent_like_lights(6, 4, np.radians(35))
    lit = mask & np.all(normals @ lights.T > 0, axis=-1)
    data = datasets.render_synthetic(normals, lit, lights, albedo=0.5)
    result = METHODS[method](data.images, data.light_directions, lit)
    # Rank-3 data without outliers: every method recovers it (robust ones to solver tolerance).
    assert angular_error(result.normals, normals, lit)["mean"] < 0.05


@pytest.fixture(scope="module")
def bear(shared_data, tmp_path_factory):
    """A DiLiGenT-layout data set on disk: real bear normals (1/4 size), Lambertian plus a
    Blinn-Phong lobe, attached and cast shadows, noise, 96 lights of unequal intensities."""
    gt = datasets.load_normal_integration(shared_data / "normal_integration" / "diligent" / "bear")
    step = 4
    normals, mask, depth = (a[::step, ::step] for a in (gt.normals, gt.mask, gt.depth))
    lights = datasets.diligent_like_lights()
    pixel_size = np.nanmean(depth) / gt.camera[0, 0] * step  # mm per pixel on the object
    lit = datasets.cast_shadows(-depth, lights, pixel_size)
    rng = np.random.default_rng(0)
    intensities = rng.uniform(0.6, 1.0, (len(lights), 3))
    folder = tmp_path_factory.mktemp("bearPNG")
    glossy = datasets.render_synthetic(
        normals,
        mask,
        lights,
        albedo=[0.7, 0.5, 0.4],
        specular=0.5,
        shininess=50.0,
        lit=lit,
        light_intensities=intensities,
        noise=0.002,
        rng=rng,
    )
    datasets.save_diligent(glossy, folder / "glossy")
    matte = datasets.render_synthetic(
        normals, mask, lights, albedo=[0.7, 0.5, 0.4], light_intensities=intensities
    )
    datasets.save_diligent(matte, folder / "matte")
    return folder


def test_lambertian_diligent_layout_is_exact_for_least_squares(bear):
    data = datasets.load_diligent(bear / "matte")
    lit = data.mask & np.all(data.normals @ data.light_directions.T > 0, axis=-1)
    result = least_squares(data.images, data.light_directions, lit)
    errors = angular_error(result.normals, data.normals, lit)
    # Exact up to the 16-bit quantisation of the PNGs (measured 1e-4°).
    assert errors["mean"] < 2e-3
    np.testing.assert_allclose(
        result.albedo[lit], np.broadcast_to([0.7, 0.5, 0.4], (lit.sum(), 3)), rtol=1e-3
    )


def test_robust_methods_beat_least_squares_on_glossy_shadowed_data(bear):
    data = datasets.load_diligent(bear / "glossy")
    errors = {
        name: angular_error(
            method(data.images, data.light_directions, data.mask).normals, data.normals, data.mask
        )
        for name, method in METHODS.items()
    }
    # Measured (mean / median °): least squares 8.0 / 4.8, trimmed 5.7 / 1.6, sparse
    # regression 4.0 / 0.46, robust PCA 4.7 / 2.2.
    assert errors["least_squares"]["mean"] > 6
    for name in ("sparse_regression", "robust_pca"):
        assert errors[name]["mean"] < 0.7 * errors["least_squares"]["mean"]
        assert errors[name]["median"] < 0.6 * errors["least_squares"]["median"]
    assert errors["sparse_regression"]["median"] < 0.2 * errors["least_squares"]["median"]


def test_chrome_sphere_calibration_on_a_render():
    size = 121
    normals, mask = sphere_normals((size, size), (60.0, 60.0), 55.0)
    lights = datasets.diligent_like_lights(4, 3, np.radians(40))
    # A mirror-like sphere: a very sharp Blinn-Phong lobe, no diffuse term.
    data = datasets.render_synthetic(
        normals, mask, lights, albedo=0.0, specular=1.0, shininess=1000.0
    )
    estimate = calibrate_lights_chrome_sphere(data.images, mask)
    angles = np.degrees(np.arccos(np.clip(np.sum(estimate * lights, axis=1), -1, 1)))
    # The highlight spans a few pixels of a 55-pixel sphere: measured max 0.46°.
    assert angles.max() < 0.6
    np.testing.assert_allclose(np.linalg.norm(estimate, axis=1), 1.0, rtol=1e-12)


@pytest.fixture(scope="module")
def psm_lights(shared_data):
    chrome = datasets.load_psm(shared_data / "photometric_stereo" / "psm" / "chrome")
    return calibrate_lights_chrome_sphere(chrome.images, chrome.mask)


def test_chrome_calibration_agrees_with_the_shipped_lights(shared_data, psm_lights):
    shipped = datasets.load_psm(shared_data / "photometric_stereo" / "psm" / "gray", step=8)
    angles = np.degrees(np.arccos(np.clip(np.sum(psm_lights * shipped.light_directions, 1), -1, 1)))
    # lights.txt is a student's calibration, 1-9° off (README); measured median 2.0°, max 8.5°.
    assert np.median(angles) < 3.0
    assert angles.max() < 10.0


def test_real_gray_sphere_with_chrome_calibrated_lights(shared_data, psm_lights):
    data = datasets.load_psm(
        shared_data / "photometric_stereo" / "psm" / "gray", light_directions=psm_lights, step=2
    )
    result = least_squares(data.images, data.light_directions, data.mask)
    errors = angular_error(result.normals, data.normals, data.mask)
    # Measured 6.4° mean, 5.3° median at full resolution (real images, 12 lights, attached
    # shadows included; ground truth from the mask's circle).
    assert errors["mean"] < 7.5
    assert errors["median"] < 6.5
    robust = sparse_regression(data.images, data.light_directions, data.mask)
    assert angular_error(robust.normals, data.normals, data.mask)["median"] < errors["median"]


def test_fit_circle_and_sphere_normals():
    normals, inside = sphere_normals((64, 80), (37.3, 30.6), 21.0)
    c_x, c_y, radius = fit_circle(inside)
    assert (c_x, c_y) == pytest.approx((37.3, 30.6), abs=0.1)
    assert radius == pytest.approx(21.0, abs=0.1)
    np.testing.assert_allclose(np.linalg.norm(normals[inside], axis=1), 1.0)
    # Right of the centre points right, above it points up (rows go down).
    assert normals[30, 58, 0] == pytest.approx((58 - 37.3) / 21.0)
    assert normals[12, 37, 1] == pytest.approx((30.6 - 12) / 21.0)
    assert normals[12, 37, 2] == pytest.approx(np.sqrt(1 - (0.3 / 21) ** 2 - (18.6 / 21) ** 2))


def test_bad_input_is_named():
    images = np.ones((4, 8, 8))
    lights = datasets.diligent_like_lights(2, 2, np.radians(30))
    with pytest.raises(ValueError, match="at least 3 lights"):
        least_squares(images[:2], lights[:2])
    with pytest.raises(ValueError, match=r"light_directions must have shape \(4, 3\)"):
        sparse_regression(images, lights[:3])
    with pytest.raises(ValueError, match="mask must have shape"):
        robust_pca(images, lights, np.ones((8, 9), bool))
    with pytest.raises(ValueError, match="no pixels"):
        least_squares(images, lights, np.zeros((8, 8), bool))
    with pytest.raises(ValueError, match="images must have shape"):
        least_squares(np.ones((4, 8)), lights)
    with pytest.raises(ValueError, match="dark_fraction"):
        trimmed_least_squares(images, lights, dark_fraction=0.5, bright_fraction=0.3)
    with pytest.raises(ValueError, match="threshold"):
        calibrate_lights_chrome_sphere(images, np.ones((8, 8), bool), threshold=0.0)
