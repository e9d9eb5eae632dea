"""Visibility seen in the images (brdfkit.vision.visibility): shadows observed under the fitted
lights, interpolated over light directions, on scenes whose shadows are known."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.errors import ParameterError
from brdfkit.vision import datasets
from brdfkit.vision.svbrdf import lambertian_relight
from brdfkit.vision.visibility import (
    interpolate_visibility,
    observed_visibility,
    relit_visibility,
    select_visibility,
)


def _towards(azimuth: float, elevation: float) -> np.ndarray:
    a, e = np.radians(azimuth), np.radians(elevation)
    return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])


def _box_scene(lights: np.ndarray, noise: float = 0.0):
    """A flat plane of textured albedo around a 10-pixel box that casts shadows on it: the
    images with the true shadows, the unshadowed Lambertian prediction and the true visibility."""
    size = 48
    height = np.zeros((size, size))
    height[20:28, 20:28] = 10.0
    mask = height == 0
    normals = np.where(mask[..., None], np.array([0.0, 0.0, 1.0]), 0.0)
    columns = np.indices((size, size))[1]
    albedo = (0.4 + 0.2 * np.sin(columns / 5.0))[..., None] * np.ones(3) * mask[..., None]
    truth = datasets.cast_shadows(height, lights)
    plain = lambertian_relight(albedo, normals, mask, lights)
    images = plain * truth[..., None]
    if noise:
        images = images + noise * np.random.default_rng(0).standard_normal(images.shape)
    return images, plain, truth, mask


def test_observed_visibility_is_the_ratio_below_tau_one_above_and_unknown_where_unlit():
    mask = np.ones((1, 4), bool)
    lights = np.array([[0.0, 0.0, 1.0], [0.0, 0.6, 0.8], [0.6, 0.0, 0.8]])
    predicted = np.tile(np.array([0.5, 0.5, 0.5, 0.0])[None, None, :, None], (3, 1, 1, 1))
    images = np.tile(np.array([0.1, 0.4, 0.6, 0.3])[None, None, :, None], (3, 1, 1, 1))
    v, known = observed_visibility(predicted, images, lights, mask, ratio=0.5)
    np.testing.assert_allclose(v[0], [0.2, 1.0, 1.0, 1.0])  # 0.8 and 1.2 are not shadows
    np.testing.assert_array_equal(known[0], [True, True, True, False])  # an attached shadow
    v, _ = observed_visibility(predicted, images, lights, mask, ratio=0.9)
    np.testing.assert_allclose(v[0], [0.2, 0.8, 1.0, 1.0])


def test_interpolation_narrow_is_the_nearest_light_wide_is_the_mean_unknown_is_one():
    lights = np.stack([_towards(0, 45), _towards(90, 45), _towards(180, 45)])
    v = np.array([[0.0, 0.2, 1.0], [1.0, 0.4, 1.0], [0.5, 0.6, 1.0]])
    known = np.array([[True, True, False], [True, True, False], [True, True, False]])
    near = _towards(10, 45)  # 7 degrees from the first light
    narrow = interpolate_visibility(v, known, lights, near, width=0.5)[0]
    np.testing.assert_allclose(narrow, [0.0, 0.2, 1.0], atol=1e-12)
    wide = interpolate_visibility(v, known, lights, near, width=np.inf)[0]
    np.testing.assert_allclose(wide, [0.5, 0.4, 1.0])
    # Far from every light a narrow kernel still averages (no 0/0): the nearest dominates.
    far = interpolate_visibility(v, known, lights, _towards(-90, 10), width=1.0)[0]
    assert np.all(np.isfinite(far)) and far[2] == 1.0
    with pytest.raises(ParameterError, match="width"):
        interpolate_visibility(v, known, lights, near, width=0.0)


def test_a_held_out_light_gets_the_shadow_its_neighbours_saw():
    # 24 lights around the box, 15 degrees apart: a held-out light's shadow lies between its
    # neighbours', so the observed visibility predicts it. The kernel average blurs the shadow's
    # edges (measured: RMS 0.051 -> 0.034, 2.3 % of the pixels on the wrong side of 0.5).
    lights = np.stack([_towards(15 * k, 40.0 + 5 * (k % 2)) for k in range(24)])
    held = [3, 10, 17]
    train = [k for k in range(24) if k not in held]
    images, plain, truth, mask = _box_scene(lights, noise=0.002)
    visibility, choice = relit_visibility(plain[train], images[train], lights[train], mask,
                                          lights[held])  # fmt: skip
    assert choice is not None and choice[0] < 40  # a local width, chosen on the training lights
    without = np.sqrt(np.mean((plain[held][:, mask] - images[held][:, mask]) ** 2))
    relit = plain[held] * visibility[..., None]
    with_ = np.sqrt(np.mean((relit[:, mask] - images[held][:, mask]) ** 2))
    assert with_ < 0.75 * without
    assert np.mean((visibility > 0.5)[:, mask] != truth[held][:, mask]) < 0.05
    shadow = ~truth[held] & mask
    assert shadow.sum() > 100 and visibility[shadow].mean() < 0.5
    assert visibility[truth[held] & mask].mean() > 0.97


def test_images_without_shadows_choose_no_visibility_or_change_nothing():
    lights = np.stack([_towards(30 * k, 60.0) for k in range(12)])
    _, plain, _, mask = _box_scene(lights)
    images = plain + 0.002 * np.random.default_rng(1).standard_normal(plain.shape)  # unshadowed
    choice, scores = select_visibility(plain, images, lights, mask)
    assert None in scores and len(scores) > 1
    visibility, _ = relit_visibility(plain, images, lights, mask, _towards(45, 60.0))
    assert visibility[0][mask].min() > 0.99 or choice is None


def test_bad_ratio_and_predictions_are_named():
    lights = np.stack([_towards(120 * k, 45) for k in range(3)])
    images, plain, _, mask = _box_scene(lights)
    with pytest.raises(ParameterError, match="ratio"):
        observed_visibility(plain, images, lights, mask, ratio=0.0)
    with pytest.raises(ParameterError, match="predicted must have shape"):
        observed_visibility(plain[:2], images, lights, mask)
