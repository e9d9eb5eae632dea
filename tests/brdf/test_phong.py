"""Phong-family models: the lecture formulas, reciprocity (or its violation), normalisation
constants against quadrature, energy over parameter sweeps, samplers, backends, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from brdfkit.brdf import BlinnPhong, ModifiedPhong, Phong
from brdfkit.brdf.phong import blinn_phong_normalization
from brdfkit.checks import assert_chi2, brdf_sampler
from brdfkit.sampling import hemisphere_pairs, square_to_uniform_hemisphere


def _view(theta: float, phi: float = 0.3) -> np.ndarray:
    return np.array(
        [math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)]
    )


def _chi2(model, wo: np.ndarray) -> None:
    assert_chi2(
        *brdf_sampler(model, wo),
        n_samples=200_000,
        binning="theta",
        theta_bins=20,
        phi_bins=40,
    )


# --------------------------------------------------------------------------- formulas
def test_phong_is_the_lecture_formula():
    wi, wo = hemisphere_pairs(500)
    kd, ks, n = 0.2, 0.7, 13.0
    r = 2 * wi[:, 2:3] * np.array([0.0, 0.0, 1.0]) - wi  # r = 2(n·ωi)n − ωi
    cos_theta_r = np.clip(np.sum(wo * r, axis=-1, keepdims=True), 0, None)
    expected = kd + ks * cos_theta_r**n / wi[:, 2:3]
    np.testing.assert_allclose(Phong(kd, ks, n).eval(wi, wo), expected, rtol=1e-12)


def test_phong_violates_reciprocity_by_its_cosine_factor():
    wi, wo = hemisphere_pairs(500, seed=1)
    model = Phong(0.1, 0.5, 4.0)
    difference = model.eval(wi, wo) - model.eval(wo, wi)
    lobe = np.clip(np.sum(wi * np.stack([-wo[:, 0], -wo[:, 1], wo[:, 2]], -1), -1), 0, None) ** 4
    expected = 0.5 * lobe * (1 / wi[:, 2] - 1 / wo[:, 2])
    np.testing.assert_allclose(difference[:, 0], expected, rtol=1e-9, atol=1e-12)
    assert np.max(np.abs(difference)) > 0.1
    assert not Phong.reciprocal and not Phong.energy_conserving


@pytest.mark.parametrize(
    "model",
    [
        ModifiedPhong(0.3, 0.6, 25.0),
        BlinnPhong(0.3, 0.6, 25.0),
        BlinnPhong(0.1, 0.8, 7.0, normalization="rtr"),
    ],
)
def test_plausible_models_are_reciprocal(model):
    wi, wo = hemisphere_pairs(1000, seed=2)
    np.testing.assert_allclose(model.eval(wi, wo), model.eval(wo, wi), rtol=1e-6, atol=0)
    assert model.reciprocal


def test_modified_phong_is_the_lecture_formula():
    wi, wo = hemisphere_pairs(500, seed=3)
    kd, ks, n = 0.4, 0.5, 30.0
    mirror = np.stack([-wo[:, 0], -wo[:, 1], wo[:, 2]], -1)
    cos_alpha = np.clip(np.sum(wi * mirror, -1, keepdims=True), 0, None)
    expected = kd / math.pi + (n + 2) / (2 * math.pi) * ks * cos_alpha**n
    np.testing.assert_allclose(ModifiedPhong(kd, ks, n).eval(wi, wo), expected, rtol=1e-12)


@pytest.mark.parametrize("n", [0.0, 1.0, 3.5, 10.0, 100.0])
def test_blinn_phong_exact_normalization_integrates_to_one(n):
    # ∫ cosⁿθh cos θi dωi at normal incidence: θi = 2θh, dωi = 4 cos θh dωh.
    def integrand(theta_h):
        return (
            math.cos(theta_h) ** n
            * math.cos(2 * theta_h)
            * 4
            * math.cos(theta_h)
            * 2
            * math.pi
            * math.sin(theta_h)
        )

    value, _ = integrate.quad(integrand, 0, math.pi / 4, epsabs=1e-13, epsrel=1e-12)
    assert float(blinn_phong_normalization(n)) * value == pytest.approx(1.0, rel=1e-10)


def test_blinn_phong_n0_is_lambertian():
    wi, wo = hemisphere_pairs(200, seed=4)
    value = BlinnPhong(0.3, 0.5, 0.0).eval(wi, wo)
    np.testing.assert_allclose(value, np.full((200, 1), 0.8 / math.pi), rtol=1e-14)


# --------------------------------------------------------------------------- energy
@pytest.mark.parametrize(
    "make",
    [
        lambda n: ModifiedPhong(0.0, 1.0, n),
        lambda n: ModifiedPhong(0.5, 0.5, n),
        lambda n: BlinnPhong(0.0, 1.0, n),
        lambda n: BlinnPhong(0.4, 0.6, n),
    ],
)
def test_albedo_at_most_one_over_a_sweep(make):
    thetas = np.radians([0, 20, 40, 60, 75, 85, 89, 89.9])
    wo = np.stack([_view(t) for t in thetas])
    for n in [0.0, 1.0, 5.0, 30.0, 300.0]:
        mean, stderr = make(n).albedo_estimate(wo, samples=1 << 14)
        assert np.all(mean <= 1 + 3 * stderr + 1e-12), (n, mean.ravel())


@pytest.mark.parametrize("n", [2.0, 10.0, 40.0])
def test_specular_albedo_is_exactly_rho_s_at_normal_incidence(n):
    wo = np.array([[0.0, 0.0, 1.0]])
    for model in (ModifiedPhong(0.0, 0.8, n), BlinnPhong(0.0, 0.8, n)):
        mean, stderr = model.albedo_estimate(wo, samples=1 << 15)
        assert abs(mean[0, 0] - 0.8) <= 4 * stderr[0, 0] + 1e-9


def test_rtr_normalization_overshoots_energy():
    n = 10.0
    model = BlinnPhong(0.0, 1.0, n, normalization="rtr")
    mean, stderr = model.albedo_estimate(np.array([[0.0, 0.0, 1.0]]), samples=1 << 15)
    ratio = float(blinn_phong_normalization(n, "rtr") / blinn_phong_normalization(n))
    assert ratio > 1.07
    assert abs(mean[0, 0] - ratio) <= 4 * stderr[0, 0]
    assert mean[0, 0] - 4 * stderr[0, 0] > 1
    assert not model.energy_conserving and BlinnPhong().energy_conserving


def test_original_phong_can_reflect_more_than_it_receives():
    model = Phong(1 / math.pi, 2.0, 1.0)
    mean, stderr = model.albedo_estimate(np.array([[0.0, 0.0, 1.0]]), samples=1 << 14)
    expected = 1 + 2.0 * 2 * math.pi / 2  # π·kd + ks·∫cosⁿα dω = π·kd + ks·2π/(n+1)
    assert abs(mean[0, 0] - expected) <= 4 * stderr[0, 0]


# --------------------------------------------------------------------------- sampling
@pytest.mark.parametrize(
    "model, theta",
    [
        (Phong(0.05, 0.3, 5.0), 1.2),
        (ModifiedPhong(0.2, 0.7, 60.0), 1.45),
        (BlinnPhong(0.3, 0.6, 20.0), 1.0),
    ],
)
def test_sampler_chi2(model, theta):
    _chi2(model, _view(theta))


# --------------------------------------------------------------------------- backends
def test_texture_parameters_broadcast():
    rng = np.random.default_rng(6)
    kd = rng.uniform(0, 0.5, (4, 5, 3))
    wi, wo = (square_to_uniform_hemisphere(rng.random((4, 5, 2))) for _ in range(2))
    model = ModifiedPhong(kd, 0.4, 20.0)
    value = model.eval(wi, wo)
    assert value.shape == (4, 5, 3)
    single = ModifiedPhong(kd[2, 3], 0.4, 20.0).eval(wi[2, 3], wo[2, 3])
    np.testing.assert_allclose(value[2, 3], single, rtol=1e-14)
    assert model.sample(wo, rng.random((4, 5, 2))).weight.shape == (4, 5, 3)


@pytest.mark.parametrize("model", [Phong(), ModifiedPhong(), BlinnPhong()])
def test_float32_is_kept(model):
    wi, wo = (a.astype(np.float32) for a in hemisphere_pairs(50, seed=7))
    u = np.random.default_rng(8).random((50, 2)).astype(np.float32)
    assert model.eval(wi, wo).dtype == np.float32
    assert model.pdf(wi, wo).dtype == np.float32
    s = model.sample(wo, u)
    assert s.wi.dtype == s.weight.dtype == s.pdf.dtype == np.float32


def test_torch_gradients_flow_to_parameters():
    torch = pytest.importorskip("torch")
    wi, wo = (torch.tensor(a) for a in hemisphere_pairs(64, seed=9))
    n = torch.tensor(20.0, dtype=torch.float64, requires_grad=True)
    ks = torch.tensor(0.5, dtype=torch.float64, requires_grad=True)
    for model in (ModifiedPhong(0.3, ks, n), BlinnPhong(0.3, ks, n), Phong(0.1, ks, n)):
        n.grad = ks.grad = None
        model.eval(wi, wo).sum().backward()
        assert torch.isfinite(n.grad) and n.grad != 0
        assert torch.isfinite(ks.grad) and ks.grad > 0


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "make, words",
    [
        (lambda: ModifiedPhong(0.5, 0.3, -1.0), ["n", "-1"]),
        (lambda: ModifiedPhong(0.7, 0.5, 10.0), ["kd + ks", "1.2", "[0.0, 1.0]"]),
        (lambda: BlinnPhong(-0.1, 0.3), ["kd", "-0.1"]),
        (lambda: BlinnPhong(0.1, 0.3, normalization="fast"), ["normalization", "fast"]),
        (lambda: Phong(0.5, 0.1), ["kd", "0.5"]),
        (lambda: Phong(0.1, -2.0), ["ks", "-2"]),
        (lambda: ModifiedPhong([0.1, 0.2], [0.1, 0.2, 0.3]), ["channels"]),
    ],
)
def test_bad_parameters_raise(make, words):
    with pytest.raises(ValueError) as info:
        make()
    for word in words:
        assert word in str(info.value)


def test_allow_unphysical_admits_large_albedos():
    model = ModifiedPhong(0.7, 0.5, 10.0, allow_unphysical=True)
    mean, _ = model.albedo_estimate(np.array([[0.0, 0.0, 1.0]]), samples=1 << 12)
    assert mean[0, 0] > 1.1
    assert not model.energy_conserving and ModifiedPhong().energy_conserving
