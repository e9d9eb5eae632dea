"""The homogeneous medium: its validation, derived coefficients and phase function."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate

from brdfkit.bssrdf import Medium, henyey_greenstein, sample_henyey_greenstein
from brdfkit.errors import ParameterError


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"albedo": -0.1}, "albedo"),
        ({"albedo": float("nan")}, "albedo"),
        ({"albedo": 0.5, "sigma_t": 0.0}, "sigma_t"),
        ({"albedo": 0.5, "g": 1.0}, "g"),
        ({"albedo": 0.5, "eta": -1.33}, "eta"),
        ({"albedo": "milk"}, "albedo"),
    ],
)
def test_bad_parameters_are_refused_by_name(kwargs, name):
    with pytest.raises(ParameterError, match=rf"^{name} must"):
        Medium(**kwargs)


def test_mean_free_path_is_the_reciprocal_of_extinction():
    medium = Medium.from_mean_free_path([0.9, 0.5], [0.5, 2.0], g=0.3, eta=1.4)
    np.testing.assert_allclose(medium.sigma_t, [2.0, 0.5])
    np.testing.assert_allclose(medium.mean_free_path, [0.5, 2.0])
    with pytest.raises(ParameterError, match=r"^mean_free_path must"):
        Medium.from_mean_free_path(0.5, 0.0)


def test_reduced_coefficients_follow_similarity_theory():
    medium = Medium(albedo=[0.99, 0.6], sigma_t=3.0, g=0.8)
    np.testing.assert_allclose(medium.sigma_s + medium.sigma_a, 3.0)
    np.testing.assert_allclose(medium.reduced_sigma_s, 0.2 * medium.sigma_s)
    expected = 0.2 * 0.99 / (0.2 * 0.99 + 0.01)
    np.testing.assert_allclose(medium.reduced_albedo[0], expected)
    # an isotropic medium is its own reduced medium
    iso = Medium(albedo=0.7, sigma_t=2.0)
    assert float(iso.reduced_albedo) == pytest.approx(0.7)


@pytest.mark.parametrize("g", [-0.7, 0.0, 0.3, 0.9])
def test_henyey_greenstein_is_normalised_with_mean_cosine_g(g):
    total, _ = integrate.quad(lambda c: 2 * np.pi * henyey_greenstein(c, g), -1, 1, points=[1])
    mean, _ = integrate.quad(lambda c: 2 * np.pi * c * henyey_greenstein(c, g), -1, 1)
    assert total == pytest.approx(1.0, abs=1e-9)
    assert mean == pytest.approx(g, abs=1e-9)


@pytest.mark.parametrize("g", [-0.5, 0.0, 0.6])
def test_sampled_cosines_follow_the_phase_function(g):
    """The sampler inverts the CDF: the fraction of samples below c is the integral of p."""
    cosines = sample_henyey_greenstein(np.random.default_rng(3).random(200_000), g)
    for c in (-0.5, 0.0, 0.5, 0.9):
        cdf, _ = integrate.quad(lambda t: 2 * np.pi * henyey_greenstein(t, g), -1, c)
        assert np.mean(cosines < c) == pytest.approx(cdf, abs=4e-3)
    assert np.mean(cosines) == pytest.approx(g, abs=5e-3)
