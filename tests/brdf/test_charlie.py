"""The Charlie sheen (Estevez & Kulla 2017): the paper's formulas, and the claims its docstring
makes (normalised D, a continuous Λ fit, reciprocity unless the terminator is softened, an
albedo above 1 at grazing views of sharp sheens)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import Charlie
from brdfkit.brdf.charlie import charlie_lambda


def _hemisphere(n: int = 200):
    x, w = np.polynomial.legendre.leggauss(n)
    mu, w_mu = 0.5 * (x + 1), 0.5 * w
    phi = 2 * np.pi * (np.arange(2 * n) + 0.5) / (2 * n)
    m, p = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - m**2)
    directions = np.stack([s * np.cos(p), s * np.sin(p), m], axis=-1)
    return directions, np.outer(w_mu, np.full(2 * n, np.pi / n))


@pytest.mark.parametrize("r", [0.01, 0.1, 0.5, 1.0])
def test_distribution_is_normalised_and_is_the_papers(r):
    wh, weights = _hemisphere()
    model = Charlie(roughness=r)
    d = model.D(wh)[..., 0]
    np.testing.assert_allclose(np.sum(d * wh[..., 2] * weights), 1.0, rtol=1e-6)
    sin_theta = np.sqrt(1 - wh[..., 2] ** 2)
    np.testing.assert_allclose(d, (2 + 1 / r) * sin_theta ** (1 / r) / (2 * math.pi), rtol=1e-12)


def test_lambda_fit_is_continuous_and_decreasing():
    for r in (0.0, 0.3, 1.0):
        below = charlie_lambda(np.array([0.5 - 1e-9]), np.array(r))
        above = charlie_lambda(np.array([0.5 + 1e-9]), np.array(r))
        np.testing.assert_allclose(below, above, rtol=1e-6)
        mu = np.linspace(0.01, 1, 200)
        assert np.all(np.diff(charlie_lambda(mu, np.array(r))) < 0)  # less shadowing upwards


def test_eval_is_the_microfacet_form():
    rng = np.random.default_rng(1)
    wi, wo = rng.normal(size=(2, 100, 3))
    wi[:, 2], wo[:, 2] = np.abs(wi[:, 2]), np.abs(wo[:, 2])
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    r = 0.3
    model = Charlie(color=0.7, roughness=r)
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=-1, keepdims=True)
    d = (2 + 1 / r) * (1 - h[:, 2] ** 2) ** (0.5 / r) / (2 * math.pi)
    g = 1 / (1 + charlie_lambda(wi[:, 2], np.array(r)) + charlie_lambda(wo[:, 2], np.array(r)))
    np.testing.assert_allclose(
        model.eval(wi, wo)[:, 0], 0.7 * d * g / (4 * wi[:, 2] * wo[:, 2]), rtol=1e-12
    )


def test_albedo_exceeds_one_at_grazing_for_sharp_sheen():
    model = Charlie(roughness=0.01)
    assert not model.energy_conserving
    theta = math.radians(89)
    mean, err = model.albedo_estimate(np.array([math.sin(theta), 0, math.cos(theta)]), 1 << 16)
    assert mean[0] - 4 * err[0] > 1.2
    # ... while at moderate angles it reflects far less than it receives.
    mean, err = model.albedo_estimate(np.array([0.5, 0.0, math.sqrt(0.75)]), 1 << 14)
    assert mean[0] + 4 * err[0] < 0.2


def test_terminator_softening_breaks_reciprocity():
    soft = Charlie(roughness=0.3, terminator_softening=True)
    assert not soft.reciprocal and Charlie().reciprocal
    wi = np.array([0.9, 0.0, math.sqrt(1 - 0.81)])
    wo = np.array([-0.3, 0.1, math.sqrt(0.9)])
    assert abs(soft.eval(wi, wo)[0] / soft.eval(wo, wi)[0] - 1) > 1e-3
    # It only ever darkens (Λ > 1 at the grazing light, raised to a power > 1).
    assert soft.eval(wi, wo)[0] <= Charlie(roughness=0.3).eval(wi, wo)[0]


@pytest.mark.slow
def test_compiled_path_matches_numpy():
    from brdfkit.compiled import compile

    rng = np.random.default_rng(2)
    wi, wo = rng.normal(size=(2, 512, 3))
    wi[:, 2], wo[:, 2] = np.abs(wi[:, 2]), np.abs(wo[:, 2])
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    model = Charlie(color=[0.9, 0.4, 0.5], roughness=0.2)
    compiled = compile(model, dtype=np.float64)
    np.testing.assert_allclose(compiled.eval(wi, wo), model.eval(wi, wo), rtol=1e-12)
    u = rng.random((512, 3))
    np.testing.assert_allclose(
        compiled.sample(wo, u).weight, model.sample(wo, u).weight, rtol=1e-10, atol=1e-14
    )
