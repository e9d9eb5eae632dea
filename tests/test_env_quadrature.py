"""Deterministic environment-map quadrature against the Monte Carlo renderer."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.data import default_envmap_path
from brdfkit.env_quadrature import error_estimate, quadrature_sphere
from brdfkit.lights import DirectionalLight, EnvironmentMap
from brdfkit.mitsuba_scenes import interior_mask, relative_rmse
from brdfkit.render import render_sphere

RES = 24
BOUND = 0.005
"""Allowed relative RMSE (quadrature − MC) beyond three times MC's own estimated noise."""


@pytest.fixture(scope="module")
def env() -> EnvironmentMap:
    return EnvironmentMap.from_file(default_envmap_path())


MODELS = [
    "ggx(alpha=0.2, material='Au')",
    "phong(kd=0.0, ks=0.02, n=100.0)",
    "blinn_phong(kd=0.0, ks=1.0, n=1000.0)",
    "oren_nayar(rho=0.5, sigma=0.3)",
    "rough_dielectric(alpha=0.1, eta=1.5)",
    "plastic(diffuse_reflectance=0.5, specular_reflectance=1.0, eta=1.49)",
    "hapke(w=0.6, xi=0.3, b0=0.5, h=0.2)",
    "ggx(alpha=0.3, material='Cu') + lambertian(rho=0.3)",
]


@pytest.mark.slow
@pytest.mark.parametrize("spec", MODELS)
def test_matches_monte_carlo(env, spec):
    model = parse(spec)
    mask = interior_mask(RES)
    q = quadrature_sphere(model, env, RES)
    a = render_sphere(model, env, RES, samples=256, seed=1)
    b = render_sphere(model, env, RES, samples=256, seed=2)
    noise = relative_rmse(a, b, mask) / 2  # of the mean (a + b)/2
    error = relative_rmse(q.image, (a + b) / 2, mask)
    assert error <= 3 * noise + BOUND, (error, noise)
    assert q.error <= 0.01  # the goal
    outside = np.hypot(*np.meshgrid(*(2 * [(np.arange(RES) + 0.5) * 2 / RES - 1]))) >= 1
    assert np.all(q.image[outside] == 0)


def test_refining_lowers_the_error(env):
    model = parse("blinn_phong(kd=0.0, ks=1.0, n=1000.0)")
    mask = interior_mask(RES)
    images = [quadrature_sphere(model, env, RES, level=lv).image for lv in range(4)]
    steps = [relative_rmse(images[i], images[i + 1], mask) for i in range(3)]
    assert steps[2] < steps[1] < steps[0]


def test_error_estimate_trusts_a_rate_only_once_the_steps_shrink():
    assert error_estimate(0.004, None) == 0.008  # one step: twice it
    assert error_estimate(0.01, 0.005) == 0.02  # growing: twice it
    assert error_estimate(0.01, 0.1) == pytest.approx(0.01 / 3)  # rate floored at 1/4
    assert error_estimate(0.006, 0.01) == pytest.approx(0.006 * 0.6 / 0.4)  # slow: > the step


@pytest.mark.slow
@pytest.mark.parametrize(
    "spec", ["blinn_phong(kd=0.0, ks=1.0, n=1000.0)", "modified_phong(kd=0.0, ks=1.0, n=500.0)"]
)
def test_the_image_returned_is_within_the_goal_of_the_next_level(env, spec):
    model = parse(spec)
    mask = interior_mask(48)
    q = quadrature_sphere(model, env, 48)
    finer = quadrature_sphere(model, env, 48, level=q.level + 1).image
    assert relative_rmse(q.image, finer, mask) <= 0.01


def test_lambertian_is_exact(env):
    model = parse("lambertian(rho=0.5)")
    q = quadrature_sphere(model, env, RES)
    mc = render_sphere(model, env, RES, samples=1)  # its irradiance table: no noise
    assert q.nodes == 0
    np.testing.assert_allclose(q.image, mc, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize(
    "spec", ["ggx(alpha=0.1, alpha_u=0.05, alpha_v=0.3)", "mirror(reflectance=1.0)"]
)
def test_refuses_anisotropic_and_delta(env, spec):
    with pytest.raises(ValueError, match="isotropic model without delta lobes"):
        quadrature_sphere(parse(spec), env, RES)


def test_refuses_other_lights():
    with pytest.raises(ValueError, match="EnvironmentMap"):
        quadrature_sphere(parse("phong(ks=0.5, n=10.0)"), DirectionalLight(), RES)


@pytest.mark.parametrize("level", [0, 2])
def test_a_grey_kernel_serves_every_channel_of_the_map(env, level):
    # a grey model's kernel is transformed once and meets each channel of the map's spectrum:
    # the image of the same model with three equal channels, to rounding
    grey = parse("ggx(alpha=0.3, eta=1.5)")
    rgb = parse("ggx(alpha=0.3, eta=[1.5, 1.5, 1.5])")
    assert (grey.channels, rgb.channels, env.channels) == (1, 3, 3)
    a = quadrature_sphere(grey, env, RES, level=level)
    b = quadrature_sphere(rgb, env, RES, level=level)
    assert a.image.shape == b.image.shape == (RES, RES, 3) and a.nodes == b.nodes
    assert np.ptp(a.image[RES // 2, RES // 2]) > 0  # the map's colour reaches the image
    np.testing.assert_allclose(a.image, b.image, rtol=1e-12, atol=1e-15)
