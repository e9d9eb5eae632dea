"""The diffusion profiles: their Fresnel moments, totals, scaling, albedo inversion, and the
known behaviours against the random walk (cheap runs; the full table is in the benchmark)."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.bssrdf import (
    BetterDipole,
    ClassicalDipole,
    Medium,
    NormalizedDiffusion,
    PhotonBeamDiffusion,
    fresnel_moment,
    invert_albedo,
    tally_walks,
)
from brdfkit.bssrdf.diffusion import RADII
from brdfkit.bssrdf.random_walk import entry
from brdfkit.errors import ParameterError

MODELS = [ClassicalDipole, BetterDipole, PhotonBeamDiffusion, NormalizedDiffusion]


def pbrt_moments(eta: float) -> tuple[float, float]:
    """pbrt-v3's polynomial fits FresnelMoment1 and FresnelMoment2 (η > 1), src/core/bssrdf.cpp."""
    e2, e3, e4, e5 = eta**2, eta**3, eta**4, eta**5
    m1 = -4.61686 + 11.1136 * eta - 10.4646 * e2 + 5.11455 * e3 - 1.27198 * e4 + 0.12746 * e5
    r, r2, r3 = 1 / eta, 1 / e2, 1 / e3
    m2 = (
        -547.033 + 45.3087 * r3 - 218.725 * r2 + 458.843 * r + 404.557 * eta
        - 189.519 * e2 + 54.9327 * e3 - 9.00603 * e4 + 0.63942 * e5
    )  # fmt: skip
    return m1, m2


@pytest.mark.parametrize("eta", [1.1, 1.33, 1.5, 2.0])
def test_fresnel_moments_match_pbrt_fits_and_egan_hilgeman(eta):
    m1, m2 = pbrt_moments(eta)
    assert float(fresnel_moment(1, eta)) == pytest.approx(m1, abs=2e-3)
    assert float(fresnel_moment(2, eta)) == pytest.approx(m2, abs=2e-3)
    egan_hilgeman = -1.440 / eta**2 + 0.710 / eta + 0.668 + 0.0636 * eta  # Jensen et al. 2001
    assert float(2 * fresnel_moment(1, eta)) == pytest.approx(egan_hilgeman, abs=1e-2)


@pytest.mark.parametrize("model", [ClassicalDipole, BetterDipole])
@pytest.mark.parametrize("albedo", [0.2, 0.8, 0.995])
def test_closed_form_totals_equal_the_integrated_profile(model, albedo):
    m = model(Medium(albedo, eta=1.4))
    integrated = np.trapezoid(2 * np.pi * RADII * m.profile(RADII)[:, 0], RADII)
    assert float(m.total_reflectance()[0]) == pytest.approx(integrated, rel=3e-3)


@pytest.mark.parametrize("model", MODELS)
def test_profiles_are_positive_decreasing_and_scale_with_the_mean_free_path(model):
    r = np.geomspace(0.01, 20, 40)
    unit = model(Medium([0.5, 0.95], sigma_t=1.0, g=0.3, eta=1.33))
    dense = model(Medium([0.5, 0.95], sigma_t=4.0, g=0.3, eta=1.33))
    values = unit.profile(r)
    assert values.shape == (40, 2) and np.all(values > 0)
    assert np.all(np.diff(values, axis=0) < 0)
    np.testing.assert_allclose(dense.profile(r / 4), 16 * values, rtol=1e-12)
    np.testing.assert_allclose(dense.total_reflectance(), unit.total_reflectance(), rtol=1e-9)
    assert np.all(unit.total_reflectance() < 1) and np.all(unit.total_reflectance() > 0)


@pytest.mark.parametrize("model", [ClassicalDipole, BetterDipole, PhotonBeamDiffusion])
def test_albedo_inversion_round_trips(model):
    colour = [0.7, 0.4, 0.1]
    omega = invert_albedo(model, colour, eta=1.33, g=0.2)
    assert np.all(np.diff(omega) < 0) and np.all((omega > 0) & (omega < 1))
    back = model(Medium(omega, g=0.2, eta=1.33)).total_reflectance()
    np.testing.assert_allclose(back, colour, atol=1e-9)
    with pytest.raises(ParameterError, match=r"^diffuse_albedo must be in"):
        invert_albedo(model, 1.2, eta=1.5)


def test_normalized_diffusion_keeps_its_colour():
    model = NormalizedDiffusion(Medium(0.9, eta=1.33), surface_albedo=[0.8, 0.2])
    np.testing.assert_allclose(model.total_reflectance(), [0.8, 0.2])
    integrated = model.sampler(1).quantile(1.0)  # the table reaches the profile's tail
    assert integrated > 0
    default = NormalizedDiffusion(Medium(0.9, eta=1.33))
    np.testing.assert_allclose(
        default.total_reflectance(), PhotonBeamDiffusion(Medium(0.9, eta=1.33)).total_reflectance()
    )
    with pytest.raises(ParameterError, match=r"^surface_albedo must"):
        NormalizedDiffusion(Medium(0.9), surface_albedo=1.5)


@pytest.fixture(scope="module")
def absorbing_walk():
    """A strongly absorbing medium under a water-like boundary (ω = 0.3, η = 1.33)."""
    return tally_walks(0.3, 1.33, 1.0, 200_000, seed=8, edges=[0.0, 0.05, 0.5, 1.0, 2.0])


def test_the_classical_dipole_fails_at_high_absorption_and_near_the_source(absorbing_walk):
    """Known behaviours (d'Eon 2012; Habel et al. 2013): at high absorption the classical
    dipole's total is off by more than the better dipole's, and near r → 0, where single
    scattering dominates, both dipoles miss most of the light while photon beam diffusion
    (which adds single scattering exactly) does not."""
    medium = Medium(0.3, eta=1.33)
    t_i, _ = entry(1.0, 1.33)
    value, stderr = absorbing_walk.reflectance()
    classical = float(ClassicalDipole(medium).total_reflectance()[0]) * t_i
    better = float(BetterDipole(medium).total_reflectance()[0]) * t_i
    assert abs(classical - value) > 0.15 * value > abs(better - value) + 3 * stderr
    profile = absorbing_walk.profile()
    near = profile.exitance[0]
    for model in (ClassicalDipole, BetterDipole):
        assert model(medium).profile(profile.radii[:1])[0, 0] * t_i < 0.2 * near
    pbd = PhotonBeamDiffusion(medium).profile(profile.radii[:1])[0, 0] * t_i
    assert pbd == pytest.approx(near, rel=0.1)
