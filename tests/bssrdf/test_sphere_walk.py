"""The reference sphere render against closed forms: a purely absorbing, index-matched sphere
is Beer–Lambert along each chord, and a non-absorbing one under a uniform sky is white."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.bssrdf import Medium
from brdfkit.bssrdf.sphere_walk import random_walk_sphere
from brdfkit.errors import ParameterError, ResourceError
from brdfkit.light import DirectionalLight, EnvironmentMap

SKY = EnvironmentMap(np.ones((4, 8, 1)))


def test_an_absorbing_index_matched_sphere_is_beer_lambert():
    """ω = 0, η = 1: a camera path crosses the chord 2x unscattered with probability
    exp(−σt·2x) and otherwise ends at its first collision (weight ω = 0)."""
    sigma_t, resolution = 1.5, 16
    image, _ = random_walk_sphere(Medium(0.0, sigma_t, eta=1.0), SKY, resolution, 64, seed=3)
    centres = (np.arange(resolution) + 0.5) / resolution * 2 - 1
    r2 = centres[:, None] ** 2 + centres[None, :] ** 2
    inner = r2 < (1 - 2 / resolution) ** 2  # pixels wholly on the sphere
    # the pixel mean of exp(−2σt·x) over its area, x = sqrt(1 − y² − z²), by a fine grid
    fine = (np.arange(resolution * 8) + 0.5) / (resolution * 8) * 2 - 1
    x = np.sqrt(np.maximum(1 - fine[:, None] ** 2 - fine[None, :] ** 2, 0))
    exact = np.exp(-2 * sigma_t * x).reshape(resolution, 8, resolution, 8).mean(axis=(1, 3))
    image, exact = image[inner, 0], exact[inner]
    z = (image - exact) / np.sqrt(exact * (1 - exact) / 64)  # each path's value is 0 or 1
    assert np.all(np.abs(z) < 5)
    assert abs(np.mean(z)) < 4 / np.sqrt(z.size)


def test_light_is_scattered_not_lost_and_absorption_darkens():
    white = Medium(1.0, 4.0, eta=1.5)
    grey = Medium(0.8, 4.0, eta=1.5)
    bright, _ = random_walk_sphere(white, SKY, 8, 8, seed=1)
    dark, _ = random_walk_sphere(grey, SKY, 8, 8, seed=1)
    assert np.allclose(bright[2:6, 2:6], 1.0)  # pixels wholly on the sphere
    assert np.all(dark[3:5, 3:5] < 0.9)


def test_a_delta_light_a_coloured_medium_or_too_many_paths_are_refused():
    with pytest.raises(ParameterError, match="light"):
        random_walk_sphere(Medium(0.5), DirectionalLight((0.0, 0.0, 1.0)), 4, 4)
    with pytest.raises(ParameterError, match="albedo"):
        random_walk_sphere(Medium([0.5, 0.6, 0.7]), SKY, 4, 4)
    with pytest.raises(ResourceError, match="paths"):
        random_walk_sphere(Medium(0.5), SKY, 2048, 1 << 16)
