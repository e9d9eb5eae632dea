"""The Moon and rough dusty surfaces: Lommel–Seeliger, Minnaert and Hapke.

The full-Moon test renders a sphere lit from the camera (the phase angle is 0 at every pixel)
and compares the brightness profile with each law's closed form: flat for Lommel–Seeliger and
Minnaert k = ½, Hapke's w/(8π){(1 + B0)p(0) + H(μ)² − 1}, and limb-dark μ ρ/π for Lambertian.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import Hapke, Lambertian, LommelSeeliger, Minnaert
from brdfkit.brdf.hapke import chandrasekhar_h, henyey_greenstein
from brdfkit.brdf.lommel_seeliger import lommel_seeliger_albedo
from brdfkit.compiled import compile
from brdfkit.geometry import spherical_to_cartesian
from brdfkit.light import DirectionalLight
from brdfkit.render import render_sphere

RESOLUTION = 65
IRRADIANCE = 2.0
VIEW = (1.0, 0.0, 0.0)  # the default camera looks along −x from +x


def _full_moon(model) -> tuple[np.ndarray, np.ndarray]:
    """(μ = cos θ of each lit pixel, its radiance) of a sphere lit from the camera."""
    image = render_sphere(model, DirectionalLight(VIEW, IRRADIANCE), resolution=RESOLUTION)
    c = (np.arange(RESOLUTION) + 0.5) * 2 / RESOLUTION - 1  # pixel centres in [−1, 1]
    x, y = np.meshgrid(c, c)
    r2 = x * x + y * y
    inside = r2 < 0.98  # clear of the rim pixels
    return np.sqrt(1 - r2[inside]), image[..., 0][inside]


def _hapke_full_moon(model: Hapke, mu: np.ndarray) -> np.ndarray:
    w = model.w
    h = chandrasekhar_h(mu[:, None], np.asarray([w]))[:, 0]
    p0 = henyey_greenstein(np.asarray(1.0), np.asarray(model.xi))
    return IRRADIANCE * w / (8 * math.pi) * ((1 + model.b0) * p0 + h * h - 1)


def test_full_moon_is_a_flat_disk_for_lommel_seeliger_and_hapke_unlike_lambert():
    mu, ls = _full_moon(LommelSeeliger(0.4))
    np.testing.assert_allclose(ls, IRRADIANCE * 0.4 / (8 * math.pi), rtol=1e-12)

    hapke = Hapke(w=0.25, xi=-0.25, b0=1.0, h=0.06)
    mu, moon = _full_moon(hapke)
    np.testing.assert_allclose(moon, _hapke_full_moon(hapke, mu), rtol=1e-9)
    _, lambert = _full_moon(Lambertian(0.3))
    np.testing.assert_allclose(lambert, IRRADIANCE * 0.3 / math.pi * mu, rtol=1e-12)

    # The profile: limb (μ < 0.3) against centre (μ > 0.95).
    limb, centre = mu < 0.3, mu > 0.95
    assert np.ptp(moon) / moon.max() < 0.05  # flat within 5 % across the disk
    assert moon[limb].mean() / moon[centre].mean() > 0.95
    assert lambert[limb].mean() / lambert[centre].mean() < 0.25


def test_minnaert_full_moon_profile_is_mu_to_2k_minus_1():
    for k in (0.5, 0.8):
        mu, value = _full_moon(Minnaert(0.5, k))
        expected = IRRADIANCE * 0.5 * (k + 1) / (2 * math.pi) * mu ** (2 * k - 1)
        np.testing.assert_allclose(value, expected, rtol=1e-12)


def test_minnaert_k1_is_lambertian():
    rng = np.random.default_rng(0)
    wi = spherical_to_cartesian(rng.random(200) * 1.5, rng.random(200) * 6)
    wo = spherical_to_cartesian(rng.random(200) * 1.5, rng.random(200) * 6)
    np.testing.assert_allclose(Minnaert(0.7, 1.0).eval(wi, wo), Lambertian(0.7).eval(wi, wo))


def _quadrature_albedo(model, theta_o: float, n: int = 256) -> np.ndarray:
    """∫ f cos θi dωi by Gauss–Legendre in cos θi and the trapezoid rule in φ (periodic)."""
    x, wx = np.polynomial.legendre.leggauss(n)
    mu_i, w_mu = 0.5 * (x + 1), 0.5 * wx
    phi = np.arange(2 * n) * math.pi / n
    mu_i_g, phi_g = np.meshgrid(mu_i, phi, indexing="ij")
    s = np.sqrt(1 - mu_i_g**2)
    wi = np.stack([s * np.cos(phi_g), s * np.sin(phi_g), mu_i_g], axis=-1)
    wo = spherical_to_cartesian(np.array(theta_o), np.array(0.0))
    f = model.eval(wi, wo)
    return np.einsum("i,ijc->c", w_mu * mu_i, f) * (math.pi / n)


@pytest.mark.parametrize("theta_o", [0.0, 0.7, 1.3])
def test_closed_form_albedos_match_quadrature(theta_o):
    wo = spherical_to_cartesian(np.array(theta_o), np.array(0.0))
    for model in (LommelSeeliger(0.8), Minnaert(0.6, 0.7), Minnaert(0.9, 2.0)):
        np.testing.assert_allclose(
            model.albedo(wo), _quadrature_albedo(model, theta_o), rtol=2e-4, err_msg=repr(model)
        )


def test_lommel_seeliger_albedo_limits():
    w = np.asarray([1.0])
    assert lommel_seeliger_albedo(w, np.asarray([1.0]))[0] == pytest.approx((1 - math.log(2)) / 2)
    assert lommel_seeliger_albedo(w, np.asarray([1e-9]))[0] == pytest.approx(0.5, rel=1e-6)


def _exact_h(w: float, x: np.ndarray, n: int = 200) -> np.ndarray:
    """Chandrasekhar's H for isotropic scattering, by iterating H = 1/(1 − (w/2) x ∫ H/(x+x'))
    (the form that converges for w = 1) on a Gauss–Legendre grid, then at ``x``."""
    t, wt = np.polynomial.legendre.leggauss(n)
    nodes, weights = 0.5 * (t + 1), 0.5 * wt
    h = np.ones(n)
    for _ in range(20000):
        new = 1 / (1 - 0.5 * w * nodes * np.sum(weights * h / (nodes[:, None] + nodes), axis=1))
        if np.max(np.abs(new - h)) < 1e-13:
            break
        h = new
    return 1 / (1 - 0.5 * w * x * np.sum(weights * h / (x[:, None] + nodes), axis=1))


@pytest.mark.parametrize("w", [0.1, 0.5, 0.9, 1.0])
def test_hapke_2002_h_function_is_within_one_percent_of_chandrasekhar(w):
    x = np.linspace(0.0, 1.0, 41)
    exact = _exact_h(w, x)
    approx = chandrasekhar_h(x[:, None], np.asarray([w]))[:, 0]
    assert np.max(np.abs(approx / exact - 1)) < 0.01


def test_hapke_conservative_isotropic_half_space_reflects_everything():
    """w = 1, isotropic particles, no surge: no absorption, so ρ(θo) = 1 with the exact H.

    Hapke's approximate H is ≤ 1 % low, and H(μ0)H(μ) compounds it: measured 0.9856 at
    θo = 0 rising to 0.9912 at θo = 1.5 rad.
    """
    model = Hapke(w=1.0, xi=0.0, b0=0.0)
    for theta_o in (0.0, 0.6, 1.2, 1.5):
        assert 0.98 < _quadrature_albedo(model, theta_o)[0] <= 1.0


def test_hapke_opposition_surge_and_retroreflection():
    model = Hapke(w=0.3, xi=0.0, b0=1.0, h=0.05)
    no_surge = Hapke(w=0.3, xi=0.0, b0=0.0, h=0.05)
    theta = 0.6
    wo = spherical_to_cartesian(np.array(theta), np.array(0.0))
    # At g = 0 the single-scattering term doubles (1 + B0); at tan(g/2) = h it rises by half.
    wi_g = spherical_to_cartesian(np.array(theta + 2 * math.atan(0.05)), np.array(0.0))
    for wi, surge in ((wo, 1.0), (wi_g, 0.5)):
        mu0, mu = wi[2], wo[2]
        single = 0.3 / (4 * math.pi) / (mu0 + mu)
        extra = model.eval(wi, wo)[0] - no_surge.eval(wi, wo)[0]
        assert extra == pytest.approx(single * surge, rel=1e-12)
    # Brightest towards the light: the retro direction beats the mirror direction.
    mirror = wo * np.array([-1.0, -1.0, 1.0])
    assert model.eval(wo, wo)[0] > 1.6 * model.eval(mirror, wo)[0]  # measured 1.71


def test_hapke_without_multiple_scattering_terms_is_lommel_seeliger_times_phase():
    """w → 0: H → 1, so f → p(g) w/(4π(μ0 + μ)) (the multiple-scattering term is O(w²))."""
    rng = np.random.default_rng(3)
    wi = spherical_to_cartesian(rng.random(100) * 1.5, rng.random(100) * 6)
    wo = spherical_to_cartesian(rng.random(100) * 1.5, rng.random(100) * 6)
    w, xi = 1e-6, -0.3
    p = henyey_greenstein(np.sum(wi * wo, axis=-1, keepdims=True), np.asarray(xi))
    expected = p * LommelSeeliger(w).eval(wi, wo)
    np.testing.assert_allclose(Hapke(w=w, xi=xi, b0=0.0).eval(wi, wo), expected, rtol=1e-5)


@pytest.mark.parametrize(
    "model", [LommelSeeliger([0.3, 0.2, 0.1]), Minnaert(0.5, 0.6), Hapke()], ids=repr
)
def test_compiled_path_matches_numpy(model):
    rng = np.random.default_rng(4)
    wi = spherical_to_cartesian(rng.random(500) * 1.55, rng.random(500) * 6)
    wo = spherical_to_cartesian(rng.random(500) * 1.55, rng.random(500) * 6)
    compiled = compile(model, dtype=np.float64)
    np.testing.assert_allclose(compiled.eval(wi, wo), model.eval(wi, wo), rtol=1e-10)
    np.testing.assert_allclose(compiled.pdf(wi, wo), model.pdf(wi, wo), rtol=1e-10)
    u = rng.random((500, 2))
    ours, theirs = compiled.sample(wo, u), model.sample(wo, u)
    np.testing.assert_allclose(ours.wi, theirs.wi, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(ours.weight, theirs.weight, rtol=1e-9)


@pytest.mark.parametrize("model", [LommelSeeliger(0.5), Minnaert(0.5, 0.6), Hapke()], ids=repr)
@pytest.mark.slow  # XLA compiles the whole model: 5–40 s on 2 busy cores
def test_jax_matches_numpy_with_finite_gradients(model):
    jax = pytest.importorskip("jax")
    jnp = jax.numpy
    rng = np.random.default_rng(5)
    wi = spherical_to_cartesian(rng.random(64) * 1.5, rng.random(64) * 6)
    wo = spherical_to_cartesian(rng.random(64) * 1.5, rng.random(64) * 6)
    wi_j, wo_j = jnp.asarray(wi, dtype=jnp.float32), jnp.asarray(wo, dtype=jnp.float32)
    value = jax.jit(model.eval)(wi_j, wo_j)  # one compilation, not one per operation
    np.testing.assert_allclose(np.asarray(value), model.eval(wi, wo), rtol=2e-5, atol=1e-7)
    grad = jax.jit(jax.grad(lambda w: model.eval(w, wo_j).sum()))(wi_j)
    assert bool(jnp.all(jnp.isfinite(grad)))
