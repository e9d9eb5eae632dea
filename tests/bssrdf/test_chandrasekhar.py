"""Chandrasekhar's H-function and the exact plane albedo, against independent results."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate

from brdfkit.bssrdf import chandrasekhar_reflectance, h_function
from brdfkit.errors import ParameterError


def h_from_integral(mu: float, albedo: float) -> float:
    """Chandrasekhar's closed-form representation (Radiative Transfer, §28, with
    t = tan θ): ln H(μ) = −(μ/π) ∫₀^{π/2} ln(1 − ω θ cot θ) / (cos²θ + μ² sin²θ) dθ."""

    def integrand(theta: float) -> float:
        return np.log(1 - albedo * theta / np.tan(theta)) / (
            np.cos(theta) ** 2 + mu**2 * np.sin(theta) ** 2
        )

    value, _ = integrate.quad(integrand, 0, np.pi / 2, limit=200, epsabs=1e-13)
    return float(np.exp(-mu / np.pi * value))


@pytest.mark.parametrize("albedo", [0.2, 0.5, 0.9, 0.99, 0.9999])
@pytest.mark.parametrize("mu", [0.05, 0.5, 1.0])
def test_h_equals_its_closed_form_integral(albedo, mu):
    assert float(h_function(mu, albedo)) == pytest.approx(h_from_integral(mu, albedo), rel=1e-9)


def test_h_matches_chandrasekhars_table_for_conservative_scattering():
    """Radiative Transfer, Table XI (ω = 1): H(0.1) = 1.2474, H(0.5) = 2.0128, H(1) = 2.9078."""
    np.testing.assert_allclose(
        h_function([0.1, 0.5, 1.0], 1.0), [1.2474, 2.0128, 2.9078], atol=6e-5
    )


@pytest.mark.parametrize("albedo", [0.3, 0.8, 1.0])
def test_h_moments(albedo):
    """The zeroth moment α₀ = ∫H dμ = (2/ω)(1 − √(1−ω)) (Chandrasekhar §27, eq. 46), and at
    ω = 1 the first, α₁ = ∫Hμ dμ = 2/√3."""
    a0, _ = integrate.quad(lambda m: float(h_function(m, albedo)), 0, 1)
    assert a0 == pytest.approx(2 / albedo * (1 - np.sqrt(1 - albedo)), rel=1e-8)
    if albedo == 1.0:
        a1, _ = integrate.quad(lambda m: m * float(h_function(m, 1.0)), 0, 1)
        assert a1 == pytest.approx(2 / np.sqrt(3), rel=1e-8)


def test_reflectance_limits_and_monotonicity():
    assert float(chandrasekhar_reflectance(0.7, 0.0)) == pytest.approx(0.0, abs=1e-15)
    assert float(chandrasekhar_reflectance(0.7, 1.0)) == pytest.approx(1.0)
    albedos = np.linspace(0.1, 0.99, 8)
    r = np.array([float(chandrasekhar_reflectance(1.0, a)) for a in albedos])
    assert np.all(np.diff(r) > 0)
    # grazing light is reflected more than normal light
    assert float(chandrasekhar_reflectance(0.2, 0.8)) > float(chandrasekhar_reflectance(1.0, 0.8))


def test_bad_arguments_are_named():
    with pytest.raises(ParameterError, match=r"^albedo must"):
        chandrasekhar_reflectance(1.0, 1.5)
    with pytest.raises(ParameterError, match=r"^mu must"):
        h_function(-0.2, 0.5)
