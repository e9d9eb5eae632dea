"""The Walter et al. (2007) rough dielectric BSDF."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import RoughDielectric
from brdfkit.checks import brdf_sampler, chi2_test
from brdfkit.fresnel import fresnel_dielectric

EXAMPLES = RoughDielectric.examples()
IDS = [m.to_spec()[:70] for m in EXAMPLES]


def _direction(theta: float, phi: float) -> np.ndarray:
    return np.array(
        [math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)]
    )


def _sphere(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.slow
@pytest.mark.parametrize("model", EXAMPLES, ids=IDS)
@pytest.mark.parametrize("side", [1.0, -1.0], ids=["outside", "inside"])
def test_sampler_chi2_and_weight(model, side):
    """χ² over the whole sphere (both lobes) and weight = f·|cos θi|/pdf, from either side."""
    wo = _direction(0.8, 0.4) * np.array([1.0, 1.0, side])

    result = chi2_test(
        *brdf_sampler(model, wo),
        sample_dim=3,
        n_samples=60_000,
        theta_bins=20,
        phi_bins=40,
        test_count=2 * len(EXAMPLES),
    )
    result.assert_passed()
    s = model.sample(np.broadcast_to(wo, (2000, 3)), np.random.default_rng(1).random((2000, 3)))
    ok = s.pdf > 0
    expected = model.eval(s.wi[ok], wo) * np.abs(s.wi[ok, 2:3]) / s.pdf[ok, None]
    np.testing.assert_allclose(s.weight[ok], expected, rtol=1e-10)
    assert np.any(s.wi[ok, 2] * wo[2] < 0) and np.any(s.wi[ok, 2] * wo[2] > 0)


def test_generalised_reciprocity():
    """Radiance mode: f(ωi, ωo)/η_o² = f(ωo, ωi)/η_i²; reflection is plainly reciprocal."""
    eta = 1.5
    model = RoughDielectric(alpha=0.4, eta=eta)
    wo = _sphere(400, 2)
    wo[:, 2] = np.abs(wo[:, 2])  # viewer outside (η_o = 1)
    s = model.sample(wo, np.random.default_rng(3).random((400, 3)))
    ok = s.pdf > 0
    wi = s.wi[ok]
    wo = wo[ok]
    transmitted = wi[:, 2] < 0
    assert transmitted.sum() > 100
    forward, backward = model.eval(wi, wo)[:, 0], model.eval(wo, wi)[:, 0]
    np.testing.assert_allclose(
        forward[transmitted] / 1.0, backward[transmitted] / eta**2, rtol=1e-10
    )
    np.testing.assert_allclose(forward[~transmitted], backward[~transmitted], rtol=1e-10)


def test_modes_differ_by_eta_squared():
    radiance = RoughDielectric(alpha=0.3, eta=1.5)
    importance = RoughDielectric(alpha=0.3, eta=1.5, mode="importance")
    wo = np.array([_direction(0.5, 0.0), -_direction(0.4, 1.0)])
    wi = np.array([-_direction(0.32, 0.1), _direction(0.3, 3.5)])  # both transmission pairs
    eta_i_over_eta_o = np.array([1.5, 1 / 1.5])
    np.testing.assert_allclose(
        importance.eval(wi, wo)[:, 0], radiance.eval(wi, wo)[:, 0] * eta_i_over_eta_o**2, rtol=1e-13
    )
    assert np.all(radiance.eval(wi, wo) > 0)
    up = np.array([_direction(0.7, 2.5)])
    np.testing.assert_allclose(importance.eval(up, wo[:1]), radiance.eval(up, wo[:1]), rtol=1e-15)


@pytest.mark.parametrize("theta_o", [0.2, 1.0, 1.4])
def test_smooth_limit_splits_fresnel(theta_o):
    """α → 0: the reflected part → F(θo) and the transmitted part → (1 − F)/η² (radiance)."""
    eta = 1.5
    model = RoughDielectric(alpha=1e-3, eta=eta)
    wo = _direction(theta_o, 0.3)
    n = 1 << 12
    s = model.sample(np.broadcast_to(wo, (n, 3)), np.random.default_rng(4).random((n, 3)))
    reflected = np.mean(np.where(s.wi[:, 2:3] > 0, s.weight, 0))
    transmitted = np.mean(np.where(s.wi[:, 2:3] < 0, s.weight, 0))
    fresnel = fresnel_dielectric(wo[2], eta)
    assert reflected == pytest.approx(fresnel, rel=0.02, abs=1e-3)
    assert transmitted == pytest.approx((1 - fresnel) / eta**2, rel=0.02)


@pytest.mark.parametrize("alpha", [0.05, 0.3, 0.8, 1.5])
@pytest.mark.parametrize("side", [1.0, -1.0])
def test_energy_in_importance_mode(alpha, side):
    """Flux: reflected + transmitted ≤ 1 (single scattering), and ≈ 1 for a smooth surface."""
    model = RoughDielectric(alpha=alpha, eta=1.5, mode="importance")
    wo = _direction(0.9, 0.2) * np.array([1.0, 1.0, side])
    n = 1 << 13
    s = model.sample(np.broadcast_to(wo, (n, 3)), np.random.default_rng(5).random((n, 3)))
    mean = float(np.mean(s.weight))
    stderr = float(np.std(s.weight) / math.sqrt(n))
    assert mean <= 1 + 4 * stderr
    if alpha <= 0.05:
        assert mean == pytest.approx(1.0, abs=0.01)
    assert model.energy_conserving and not model.reciprocal and model.transmits


@pytest.mark.parametrize(
    ("factory", "match"),
    [
        (lambda: RoughDielectric(masking="v_groove"), "masking must be one of"),
        (lambda: RoughDielectric(eta=0.0), "eta must be in"),
        (lambda: RoughDielectric(eta=[1.5, 1.6, 1.7]), "one value per point"),
        (lambda: RoughDielectric(mode="light"), "mode must be one of"),
        (lambda: RoughDielectric(alpha=-1.0), "alpha must be in"),
        (lambda: RoughDielectric(distribution="blinn"), "distribution must be one of"),
    ],
)
def test_bad_parameters(factory, match):
    with pytest.raises(ValueError, match=match):
        factory()


def test_two_uniforms_are_refused():
    with pytest.raises(ValueError, match="3 uniforms"):
        RoughDielectric().sample(np.array([0.0, 0.0, 1.0]), np.array([0.5, 0.5]))


def test_dtype_and_gradients(backend):
    model = RoughDielectric(alpha=0.3)
    wo = backend(_sphere(32, 6))
    u = backend(np.random.default_rng(7).random((32, 3)))
    s = model.sample(wo, u)
    assert s.wi.dtype == wo.dtype and s.weight.dtype == wo.dtype
    assert model.eval(s.wi, wo).dtype == wo.dtype and model.pdf(s.wi, wo).dtype == wo.dtype
    torch = pytest.importorskip("torch")
    alpha = torch.tensor(0.3, dtype=torch.float64, requires_grad=True)
    eta = torch.tensor(1.5, dtype=torch.float64, requires_grad=True)
    wi_t = torch.as_tensor(np.asarray(s.wi), dtype=torch.float64)
    wo_t = torch.as_tensor(np.asarray(wo), dtype=torch.float64)
    RoughDielectric(alpha=alpha, eta=eta).eval(wi_t, wo_t).sum().backward()
    for p in (alpha, eta):
        assert p.grad is not None and torch.isfinite(p.grad) and p.grad != 0
