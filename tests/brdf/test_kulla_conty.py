"""Kulla–Conty energy compensation, checked by quadrature and against Heitz et al.'s random walk."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from brdfkit import accel
from brdfkit.brdf import KullaConty
from brdfkit.brdf.kulla_conty import albedo_table, ggx_albedo
from brdfkit.brdf.random_walk import random_walk_albedo
from brdfkit.errors import ParameterError
from brdfkit.geometry import spherical_to_cartesian

ALPHAS = (0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 0.85, 1.0)
THETAS = np.radians([0.0, 20.0, 40.0, 60.0, 75.0, 80.0, 84.9])


def _multiple_albedo(model: KullaConty, theta_o: float, n: int = 128) -> np.ndarray:
    """∫ (f − f_ss) cos θi dωi by Gauss–Legendre in √μi (the added lobe is isotropic in φi)."""
    x, w = np.polynomial.legendre.leggauss(n)
    s, w = (x + 1) / 2, w / 2
    mu_i = s * s
    wi = np.stack([np.sqrt(1 - mu_i**2), np.zeros_like(mu_i), mu_i], axis=-1)
    wo = spherical_to_cartesian(np.array(theta_o), np.array(1.3))
    added = model.eval(wi, wo) - model._single.eval(wi, wo)
    return 2 * math.pi * np.sum((w * 2 * s * mu_i)[:, None] * added, axis=0)  # dμ = 2s ds


@pytest.mark.slow
def test_white_furnace_compensated_albedo_is_one():
    """F = 1: single scattering (an independent, finer quadrature) + the added lobe = 1."""
    worst = 0.0
    for alpha in ALPHAS:
        model = KullaConty(alpha=alpha)
        single = ggx_albedo(alpha, np.cos(THETAS), nodes=(192, 128))[:, 0]
        for theta, e in zip(THETAS, single, strict=True):
            total = e + _multiple_albedo(model, theta)[0]
            worst = max(worst, abs(total - 1))
    assert worst < 0.005, worst  # measured 1.9e-4 (α = 0.2, θo = 0)


def test_albedo_table_is_cached_and_matches_known_values():
    coefficients, e_avg = albedo_table(1.0)
    assert albedo_table(1.0)[0] is coefficients
    # GGX α = 1, F = 1 at normal incidence reflects 1 − ln 2 (the RoughConductor docstring).
    e_normal = KullaConty(alpha=1.0).E(np.array([[1.0]]))[0, 0]
    assert e_normal == pytest.approx(1 - math.log(2), abs=2e-4)
    assert 0 < e_avg < 1


def test_random_walk_single_order_is_the_single_scattering_albedo():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # 0 ** negative in the masking
        for alpha in (0.2, 0.6, 1.0):
            for theta in (0.0, 1.2):
                wo = spherical_to_cartesian(np.array(theta), np.array(0.0))
                walk = random_walk_albedo(alpha, wo, paths=1 << 16, seed=1)
                e = ggx_albedo(alpha, np.array([math.cos(theta)]))[0]
                sigma = math.sqrt(e[0] * (1 - e[0]) / (1 << 16))
                assert abs(walk.single[0] - e[0]) < 4 * sigma + 1e-4
                # F = 1: every path leaves eventually, all the light comes back.
                assert walk.albedo[0] == pytest.approx(1.0, abs=1e-3)


AGREEING = [
    ("none", 1.0, (0.0, 45.0, 80.0)),
    ("Au", 0.2, (0.0, 45.0)),
    ("Cu", 0.35, (0.0, 45.0)),
    ("Ag", 0.5, (0.0, 45.0, 80.0)),
    ("Al", 0.75, (0.0, 45.0, 80.0)),
]


@pytest.mark.parametrize(("material", "alpha", "thetas"), AGREEING)
def test_compensated_albedo_agrees_with_the_random_walk(material, alpha, thetas):
    """Within 2 % per channel where Kulla–Conty's F_avg approximation holds (see the next
    test for where it does not)."""
    model = KullaConty(alpha=alpha, material=material)
    fresnel = model._single.fresnel_term
    for degrees in thetas:
        theta = math.radians(degrees)
        wo = spherical_to_cartesian(np.array(theta), np.array(0.0))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            walk = random_walk_albedo(alpha, wo, fresnel=fresnel, paths=1 << 16, seed=2)
        ours = model.albedo(wo, samples=1 << 14)
        np.testing.assert_allclose(ours, walk.albedo, rtol=0.02, err_msg=f"θo = {degrees}°")


def test_coloured_rough_conductors_lose_multiple_scattering_a_walk_keeps():
    """The documented gap: with a coloured Fresnel term the added lobe uses F_avg, but rays
    that scatter several times hit facets obliquely, where F is larger; for gold at α = 1,
    θo = 57°, the compensated albedo is below the walk's by 1.6 % (red), 6.3 % (green) and
    7.5 % (blue), and at grazing view (80°) by 3–5 % even at α = 0.1–0.5 in the blue channel
    (measured, not asserted here)."""
    model = KullaConty(alpha=1.0, material="Au")
    wo = spherical_to_cartesian(np.array(1.0), np.array(0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        walk = random_walk_albedo(1.0, wo, fresnel=model._single.fresnel_term, paths=1 << 16)
    single = ggx_albedo(1.0, np.array([wo[2]]), fresnel=model._single.fresnel_term)[0]
    ours = single + _multiple_albedo(model, 1.0)
    gap = 1 - ours / walk.albedo
    assert np.all(gap > 0) and np.all(gap[1:] > 0.03) and np.all(gap < 0.1), gap


def test_spatially_varying_alpha_is_refused():
    with pytest.raises(ParameterError, match="alpha"):
        KullaConty(alpha=np.full((2, 2, 1), 0.3))


def test_compiled_path_matches_numpy():
    model = KullaConty(alpha=0.4, material="Cu")
    rng = np.random.default_rng(4)
    wi = spherical_to_cartesian(rng.random(500) * 1.55, rng.random(500) * 6)
    wo = spherical_to_cartesian(rng.random(500) * 1.55, rng.random(500) * 6)
    compiled = accel.compile(model, dtype=np.float64)
    np.testing.assert_allclose(compiled.eval(wi, wo), model.eval(wi, wo), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(compiled.pdf(wi, wo), model.pdf(wi, wo), rtol=1e-9, atol=1e-12)
    u = rng.random((500, 2))
    ours, theirs = compiled.sample(wo, u), model.sample(wo, u)
    np.testing.assert_allclose(ours.wi, theirs.wi, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(ours.weight, theirs.weight, rtol=1e-9, atol=1e-12)


@pytest.mark.slow  # XLA compiles the whole model: 5–40 s on 2 busy cores
def test_jax_matches_numpy_with_finite_gradients():
    jax = pytest.importorskip("jax")
    jnp = jax.numpy
    model = KullaConty(alpha=0.6, material="Au")
    rng = np.random.default_rng(5)
    wi = spherical_to_cartesian(rng.random(64) * 1.5, rng.random(64) * 6)
    wo = spherical_to_cartesian(rng.random(64) * 1.5, rng.random(64) * 6)
    wi_j, wo_j = jnp.asarray(wi, dtype=jnp.float32), jnp.asarray(wo, dtype=jnp.float32)
    value = jax.jit(model.eval)(wi_j, wo_j)  # one compilation, not one per operation
    np.testing.assert_allclose(np.asarray(value), model.eval(wi, wo), rtol=1e-4, atol=1e-6)
    grad = jax.jit(jax.grad(lambda w: model.eval(w, wo_j).sum()))(wi_j)
    assert bool(jnp.all(jnp.isfinite(grad)))
