"""The random walk against exact results: Chandrasekhar's half-space and a slab that only
absorbs (its Fresnel bounces in closed form)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.bssrdf import chandrasekhar_reflectance, random_walk_reflectance, tally_walks
from brdfkit.errors import ParameterError, ResourceError
from brdfkit.fresnel import fresnel_dielectric

CASES = [(albedo, mu) for albedo in (0.5, 0.9, 0.99) for mu in (1.0, 0.5)]
RELATIVE = 0.005


def walks_for(albedo: float, mu: float) -> int:
    """Walks whose three standard errors are 0.5 % of the exact reflectance R:
    N = 9 (1 − R) / (R · 0.005²), the fewest for which both bounds can hold."""
    r = float(chandrasekhar_reflectance(mu, albedo))
    return math.ceil(9 * (1 - r) / (r * RELATIVE**2))


@pytest.fixture(scope="module")
def half_space() -> dict[tuple[float, float], tuple[float, float]]:
    return {
        (albedo, mu): random_walk_reflectance(albedo, 1.0, mu, walks_for(albedo, mu), seed=4)
        for albedo, mu in CASES
    }


@pytest.mark.parametrize(("albedo", "mu"), CASES)
def test_random_walk_equals_chandrasekhar(half_space, albedo, mu):
    value, stderr = half_space[albedo, mu]
    exact = float(chandrasekhar_reflectance(mu, albedo))
    assert abs(value - exact) < 3 * stderr
    assert abs(value - exact) < RELATIVE * exact


def test_an_absorbing_slab_bounces_as_fresnel_says():
    """ω = 0: the refracted beam crosses the slab (transmittance a = e^{−d/μt}) and bounces
    between its faces (internal reflectance F each), so T = Ti a (1−F)/(1 − a²F²) leaves the
    bottom and Ti a² F (1−F)/(1 − a²F²) the top."""
    eta, mu_i, d = 1.5, 0.8, 0.4
    tally = tally_walks(0.0, eta, mu_i, 40_000, seed=3, thickness=d)
    mu_t = math.sqrt(1 - (1 - mu_i**2) / eta**2)
    t_i = 1 - float(fresnel_dielectric(mu_i, eta))
    a, f = math.exp(-d / mu_t), float(fresnel_dielectric(-mu_t, eta))
    transmitted = t_i * a * (1 - f) / (1 - a * a * f * f)
    reflected = t_i * a * a * f * (1 - f) / (1 - a * a * f * f)
    (r, r_err), (t, t_err) = tally.reflectance(), tally.transmittance()
    assert abs(t - transmitted) < 4 * t_err and abs(r - reflected) < 4 * r_err
    assert tally.transmitted_in == pytest.approx(t_i)


def test_a_thick_slab_is_a_half_space_and_a_thin_one_lets_light_through():
    thick = tally_walks(0.9, 1.33, 1.0, 20_000, seed=5, thickness=60.0)
    half = tally_walks(0.9, 1.33, 1.0, 20_000, seed=5)
    assert thick.reflectance() == pytest.approx(half.reflectance(), abs=1e-12)
    thin = tally_walks(0.9, 1.33, 1.0, 20_000, seed=5, thickness=1.0)
    assert thin.transmittance()[0] > 0.3 > half.transmittance()[0] == 0.0
    assert thin.reflectance()[0] < half.reflectance()[0]


def test_the_profile_bins_the_walks_that_leave_the_top():
    edges = np.array([0.0, 0.5, 1.0, 2.0, 4.0, np.inf])
    profile = tally_walks(0.95, 1.33, 1.0, 20_000, seed=6, edges=edges).profile()
    area = np.pi * np.diff(edges**2)
    assert profile.exitance[-1] == 0.0  # an infinite annulus: no density
    assert np.all(np.diff(profile.exitance[:-1]) < 0)  # falls off with the radius
    inside = np.sum(profile.exitance[:-1] * area[:-1])
    assert inside < profile.total and inside > 0.8 * profile.total
    assert np.all(profile.stderr[:-1] > 0) and np.all(profile.stderr[:-1] < profile.exitance[:-1])


def test_the_same_seed_gives_the_same_walks_on_any_path():
    compiled = tally_walks(0.8, 1.2, 0.6, 3000, seed=9, g=0.4, edges=[0, 1, 3])
    reference = tally_walks(0.8, 1.2, 0.6, 3000, seed=9, g=0.4, edges=[0, 1, 3], compiled=False)
    assert compiled.reflected == reference.reflected
    np.testing.assert_array_equal(compiled.counts, reference.counts)
    other = tally_walks(0.8, 1.2, 0.6, 3000, seed=10, g=0.4)
    assert other.reflected != compiled.reflected


@pytest.mark.parametrize(
    ("kwargs", "error", "name"),
    [
        ({"albedo": 1.1}, ParameterError, "albedo"),
        ({"eta": 0.0}, ParameterError, "eta"),
        ({"cos_theta_i": 0.0}, ParameterError, "cos_theta_i"),
        ({"samples": 1}, ParameterError, "samples"),
        ({"samples": 10**12}, ResourceError, "samples"),
        ({"seed": -1}, ParameterError, "seed"),
        ({"g": -1.0}, ParameterError, "g"),
        ({"thickness": 0.0}, ParameterError, "thickness"),
        ({"thickness": "thick"}, ParameterError, "thickness"),
        ({"edges": [1.0, 0.5]}, ParameterError, "edges"),
    ],
)
def test_bad_arguments_are_refused_by_name(kwargs, error, name):
    arguments = {"albedo": 0.5, "eta": 1.0, "cos_theta_i": 1.0, "samples": 100} | kwargs
    with pytest.raises(error, match=rf"^{name} must"):
        tally_walks(**arguments)
