"""The BSSRDF sphere beside the BRDF sphere: the same where light is uniform, softer at the
terminator."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.bssrdf import BetterDipole, Medium, NormalizedDiffusion
from brdfkit.bssrdf.sphere import diffusion_sphere, subsurface_spheres
from brdfkit.errors import ParameterError, ResourceError
from brdfkit.fresnel import fresnel_dielectric
from brdfkit.light import DirectionalLight, EnvironmentMap


@pytest.fixture(scope="module")
def spheres():
    model = NormalizedDiffusion(Medium(0.99, sigma_t=40.0, eta=1.33), surface_albedo=[0.8, 0.3])
    return subsurface_spheres(model, light=(0.0, 1.0, 0.0), resolution=40, samples=128)


def test_lit_interior_matches_the_brdf_and_the_terminator_softens(spheres):
    brdf, bssrdf = spheres
    assert brdf.shape == bssrdf.shape == (40, 40, 2)
    lit = brdf[18:22, 30:34]  # n·l ≈ 0.6: the light varies slowly on the profile's scale
    np.testing.assert_allclose(bssrdf[18:22, 30:34], lit, rtol=0.03)
    dark = (slice(18, 22), slice(17, 20))  # just past the terminator
    assert np.all(brdf[dark] == 0) and np.all(bssrdf[dark] > 0)
    # a longer mean free path carries more light across
    wider = NormalizedDiffusion(Medium(0.99, sigma_t=10.0, eta=1.33), surface_albedo=[0.8, 0.3])
    _, blurred = subsurface_spheres(wider, light=(0.0, 1.0, 0.0), resolution=40, samples=128)
    assert np.all(blurred[dark] > bssrdf[dark])
    # light moves across the terminator, none is made: the BSSRDF image's total stays close
    assert bssrdf.sum() == pytest.approx(brdf.sum(), rel=0.03)
    assert bssrdf[0, 0].tolist() == [0.0, 0.0]  # outside the sphere


def test_bad_arguments_are_named():
    model = NormalizedDiffusion(Medium(0.5), surface_albedo=0.5)
    with pytest.raises(ResourceError, match=r"^resolution must"):
        subsurface_spheres(model, resolution=10**6)
    with pytest.raises(ParameterError, match=r"^light must"):
        subsurface_spheres(model, light=(np.nan, 0.0, 1.0))


def test_under_a_uniform_sky_the_diffusion_sphere_is_specular_plus_rho():
    """A uniform unit sky: every entry point takes in E_t = π c, so each pixel is the exit's
    F(μ_o) plus (1 − F(μ_o)) ρ — the tabulated E_t and the exit's normalisation c agree."""
    medium = Medium(0.8, sigma_t=20.0, eta=1.33)
    model = BetterDipole(medium)
    image = diffusion_sphere(model, EnvironmentMap(np.ones((8, 16, 1))), 16, 32)
    centres = (np.arange(16) + 0.5) / 8 - 1
    mu = np.sqrt(np.maximum(1 - centres[:, None] ** 2 - centres[None, :] ** 2, 0))
    f = fresnel_dielectric(mu, 1.33)
    expected = np.where(mu > 0, f + (1 - f) * float(model.total_reflectance()[0]), 0)
    np.testing.assert_allclose(image[..., 0], expected, atol=2e-3)


def test_the_diffusion_sphere_refuses_a_delta_light():
    with pytest.raises(ParameterError, match="light"):
        diffusion_sphere(BetterDipole(Medium(0.5)), DirectionalLight((0.0, 0.0, 1.0)))
