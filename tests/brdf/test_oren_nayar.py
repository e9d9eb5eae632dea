"""Oren–Nayar: the Lambertian limit, the paper's formulas in angles, reciprocity, measured energy,
the sampler, backends and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import Lambertian, OrenNayar
from brdfkit.checks import assert_chi2, brdf_sampler
from brdfkit.sampling import hemisphere_pairs, square_to_uniform_hemisphere


def _angles(wi: np.ndarray, wo: np.ndarray):
    theta_i, theta_r = np.arccos(wi[:, 2]), np.arccos(wo[:, 2])
    delta_phi = np.arctan2(wo[:, 1], wo[:, 0]) - np.arctan2(wi[:, 1], wi[:, 0])
    return np.maximum(theta_i, theta_r), np.minimum(theta_i, theta_r), np.cos(delta_phi)


@pytest.mark.parametrize("model", ["qualitative", "full"])
def test_sigma_zero_is_lambertian(model):
    wi, wo = hemisphere_pairs(1000)
    rho = [0.9, 0.5, 0.1]
    np.testing.assert_allclose(
        OrenNayar(rho, 0.0, model).eval(wi, wo), Lambertian(rho).eval(wi, wo), rtol=1e-12, atol=0
    )


def test_qualitative_is_the_lecture_formula():
    wi, wo = hemisphere_pairs(1000, seed=1)
    rho, sigma = 0.7, 0.4
    alpha, beta, cos_dphi = _angles(wi, wo)
    a = 1 - 0.5 * sigma**2 / (sigma**2 + 0.33)
    b = 0.45 * sigma**2 / (sigma**2 + 0.09)
    expected = rho / math.pi * (a + b * np.maximum(0, cos_dphi) * np.sin(alpha) * np.tan(beta))
    np.testing.assert_allclose(OrenNayar(rho, sigma).eval(wi, wo)[:, 0], expected, rtol=1e-9)


def test_full_is_the_papers_formula():
    wi, wo = hemisphere_pairs(1000, seed=2)
    rho, sigma = 0.8, 0.5
    s2 = sigma**2
    alpha, beta, cos_dphi = _angles(wi, wo)
    c1 = 1 - 0.5 * s2 / (s2 + 0.33)
    c2 = (
        0.45
        * s2
        / (s2 + 0.09)
        * np.where(cos_dphi >= 0, np.sin(alpha), np.sin(alpha) - (2 * beta / math.pi) ** 3)
    )
    c3 = 0.125 * s2 / (s2 + 0.09) * (4 * alpha * beta / math.pi**2) ** 2
    l1 = (
        rho
        / math.pi
        * (
            c1
            + cos_dphi * c2 * np.tan(beta)
            + (1 - np.abs(cos_dphi)) * c3 * np.tan((alpha + beta) / 2)
        )
    )
    l2 = 0.17 * rho**2 / math.pi * s2 / (s2 + 0.13) * (1 - cos_dphi * (2 * beta / math.pi) ** 2)
    value = OrenNayar(rho, sigma, "full").eval(wi, wo)[:, 0]
    np.testing.assert_allclose(value, l1 + l2, rtol=1e-9)


def test_full_model_is_clamped_where_the_published_fit_is_negative():
    # Grazing forward scattering with a large σ: the published formula gives a negative value.
    theta = math.radians(89.9)
    wi = np.array([math.sin(theta), 0.0, math.cos(theta)])
    wo = np.array([-wi[0], 0.0, wi[2]])
    rho, sigma = 0.05, 1.5
    s2 = sigma**2
    alpha = beta = theta
    c1 = 1 - 0.5 * s2 / (s2 + 0.33)
    c2 = 0.45 * s2 / (s2 + 0.09) * (math.sin(alpha) - (2 * beta / math.pi) ** 3)
    published = rho / math.pi * (c1 - c2 * math.tan(beta)) + 0.17 * rho**2 / math.pi * s2 / (
        s2 + 0.13
    ) * (1 + (2 * beta / math.pi) ** 2)
    assert published < 0
    assert OrenNayar(rho, sigma, "full").eval(wi, wo)[0] == 0
    assert OrenNayar(rho, 0.5, "full").eval(wi, wo)[0] > 0


@pytest.mark.parametrize("model", ["qualitative", "full"])
def test_reciprocal(model):
    wi, wo = hemisphere_pairs(2000, seed=3)
    brdf = OrenNayar([0.9, 0.4], [0.2, 1.1], model)
    np.testing.assert_allclose(brdf.eval(wi, wo), brdf.eval(wo, wi), rtol=1e-6, atol=0)
    assert brdf.reciprocal


def test_backscatter_is_brighter_than_forward():
    # Rough surfaces look brighter towards the source (retro-reflection): cos Δφ = 1 vs −1.
    theta = 1.0
    wi = np.array([math.sin(theta), 0.0, math.cos(theta)])
    back, forward = wi, np.array([-wi[0], 0.0, wi[2]])
    for model in ("qualitative", "full"):
        brdf = OrenNayar(0.8, 0.5, model)
        assert brdf.eval(wi, back)[0] > 0.8 / math.pi * 1.05
        assert brdf.eval(wi, back)[0] > brdf.eval(wi, forward)[0]


# --------------------------------------------------------------------------- energy
def _albedo(brdf, theta: float):
    wo = np.array([[math.sin(theta), 0.0, math.cos(theta)]])
    mean, stderr = brdf.albedo_estimate(wo, samples=1 << 16)
    return mean[0, 0], stderr[0, 0]


@pytest.mark.parametrize("model, sigma, peak", [("qualitative", 0.2, 1.015), ("full", 0.3, 1.05)])
def test_energy_is_not_conserved(model, sigma, peak):
    brdf = OrenNayar(1.0, sigma, model)
    grazing, grazing_error = _albedo(brdf, math.radians(89.95))
    normal, normal_error = _albedo(brdf, 0.0)
    assert grazing - 4 * grazing_error > 1  # more light out than in at grazing view
    assert abs(grazing - peak) < 0.01  # the peak quoted in the docstring
    assert normal + 4 * normal_error < 1  # and less at normal incidence
    assert not OrenNayar.energy_conserving


def test_sampler_chi2_and_weights():
    brdf = OrenNayar([0.9, 0.6, 0.3], 0.8, "full")
    wo = np.array([0.6, 0.0, 0.8])

    assert_chi2(
        *brdf_sampler(brdf, wo),
        n_samples=200_000,
        binning="cos",
        theta_bins=10,
        phi_bins=20,
    )
    s = brdf.sample(np.broadcast_to(wo, (1000, 3)), np.random.default_rng(4).random((1000, 2)))
    ok = s.pdf > 0
    np.testing.assert_allclose(s.weight[ok], math.pi * brdf.eval(s.wi, wo)[ok], rtol=1e-6)
    assert brdf.sampling_weight(wo[None])[0] == pytest.approx(0.6)


# --------------------------------------------------------------------------- backends
def test_texture_parameters_broadcast():
    rng = np.random.default_rng(5)
    rho = rng.uniform(0, 1, (3, 4, 3))
    sigma = rng.uniform(0, 1, (3, 4, 1))
    wi, wo = (square_to_uniform_hemisphere(rng.random((3, 4, 2))) for _ in range(2))
    value = OrenNayar(rho, sigma, "full").eval(wi, wo)
    assert value.shape == (3, 4, 3)
    single = OrenNayar(rho[1, 2], sigma[1, 2], "full").eval(wi[1, 2], wo[1, 2])
    np.testing.assert_allclose(value[1, 2], single, rtol=1e-14)


@pytest.mark.parametrize("model", ["qualitative", "full"])
def test_float32_is_kept(model):
    wi, wo = (a.astype(np.float32) for a in hemisphere_pairs(50, seed=6))
    brdf = OrenNayar(0.5, 0.4, model)
    assert brdf.eval(wi, wo).dtype == np.float32
    s = brdf.sample(wo, np.random.default_rng(7).random((50, 2)).astype(np.float32))
    assert s.weight.dtype == s.pdf.dtype == np.float32


@pytest.mark.parametrize("model", ["qualitative", "full"])
def test_torch_gradients_flow_to_parameters(model):
    torch = pytest.importorskip("torch")
    wi, wo = (torch.tensor(a) for a in hemisphere_pairs(64, seed=8))
    sigma = torch.tensor(0.5, dtype=torch.float64, requires_grad=True)
    rho = torch.tensor([0.7, 0.3], dtype=torch.float64, requires_grad=True)
    OrenNayar(rho, sigma, model).eval(wi, wo).sum().backward()
    assert torch.isfinite(sigma.grad) and sigma.grad != 0
    assert torch.all(rho.grad > 0)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"sigma": -0.1}, ["sigma", "-0.1"]),
        ({"sigma": 2.0}, ["sigma", "2", "1.57"]),
        ({"rho": 1.5}, ["rho", "1.5", "allow_unphysical"]),
        ({"model": "exact"}, ["model", "exact"]),
        ({"rho": [0.5, 0.5], "sigma": [0.1, 0.2, 0.3]}, ["channels"]),
    ],
)
def test_bad_parameters_raise(kwargs, words):
    with pytest.raises(ValueError) as info:
        OrenNayar(**kwargs)
    for word in words:
        assert word in str(info.value)
