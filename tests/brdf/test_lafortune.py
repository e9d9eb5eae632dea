"""Lafortune lobes: equivalence with modified Phong, reciprocity, anisotropy, energy,
samplers, per-channel/texture parameters, backends and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import Lafortune, ModifiedPhong
from brdfkit.checks import assert_chi2, brdf_sampler
from brdfkit.sampling import hemisphere_pairs, square_to_uniform_hemisphere


def _rotate_z(w: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.stack([c * w[..., 0] - s * w[..., 1], s * w[..., 0] + c * w[..., 1], w[..., 2]], -1)


def test_mirror_lobe_is_modified_phong():
    wi, wo = hemisphere_pairs(1000)
    rho_s, n = 0.6, 25.0
    c = (rho_s * (n + 2) / (2 * math.pi)) ** (1 / n)
    lafortune = Lafortune(0.3, [-c], [-c], [c], [n])
    np.testing.assert_allclose(
        lafortune.eval(wi, wo), ModifiedPhong(0.3, rho_s, n).eval(wi, wo), rtol=1e-12
    )


def test_is_the_papers_sum_of_lobes():
    wi, wo = hemisphere_pairs(500, seed=1)
    cx, cy, cz, n = [-1.1, 0.7], [-0.6, 0.7], [1.0, 0.7], [10.0, 3.0]
    expected = 0.2 / math.pi + sum(
        np.clip(
            cx[k] * wi[:, 0] * wo[:, 0] + cy[k] * wi[:, 1] * wo[:, 1] + cz[k] * wi[:, 2] * wo[:, 2],
            0,
            None,
        )
        ** n[k]
        for k in range(2)
    )
    value = Lafortune(0.2, cx, cy, cz, n).eval(wi, wo)[:, 0]
    np.testing.assert_allclose(value, expected, rtol=1e-12)


def test_reciprocal_with_per_channel_lobes():
    wi, wo = hemisphere_pairs(1000, seed=2)
    model = Lafortune(
        [0.2, 0.1, 0.05],
        [[-1.0, -0.9, -0.8]],
        [[-0.5, -0.6, -0.7]],
        [[0.9, 1.0, 1.1]],
        [[5.0, 10.0, 20.0]],
    )
    assert model.channels == 3
    np.testing.assert_allclose(model.eval(wi, wo), model.eval(wo, wi), rtol=1e-6, atol=0)


def test_anisotropy_follows_cx_cy():
    wi, wo = hemisphere_pairs(500, seed=3)
    aniso = Lafortune(0.0, [-1.1], [-0.6], [1.0], [10.0])
    iso = Lafortune(0.0, [-0.9], [-0.9], [1.0], [10.0])
    angle = 0.8
    rotated = (_rotate_z(wi, angle), _rotate_z(wo, angle))
    np.testing.assert_allclose(iso.eval(*rotated), iso.eval(wi, wo), rtol=1e-12)
    assert np.max(np.abs(aniso.eval(*rotated) - aniso.eval(wi, wo))) > 1e-2
    assert iso.isotropic and not aniso.isotropic


def test_energy_is_not_conserved_in_general():
    # One lobe Cx = Cy = −1, Cz = 1, n = 1: at normal incidence ∫cos²θ dω = 2π/3 > 1.
    model = Lafortune(0.0, [-1.0], [-1.0], [1.0], [1.0])
    mean, stderr = model.albedo_estimate(np.array([[0.0, 0.0, 1.0]]), samples=1 << 15)
    assert abs(mean[0, 0] - 2 * math.pi / 3) <= 4 * stderr[0, 0]
    assert not Lafortune.energy_conserving


@pytest.mark.parametrize(
    "model, wo",
    [
        (Lafortune(0.1, [-1.1], [-0.6], [1.0], [10.0]), [0.5, 0.5, math.sqrt(0.5)]),
        (
            Lafortune(0.2, [-1.0, 0.9], [-1.0, 0.9], [1.0, 0.9], [40.0, 8.0]),
            [0.9, 0.0, math.sqrt(0.19)],
        ),
    ],
)
def test_sampler_chi2(model, wo):
    assert_chi2(
        *brdf_sampler(model, np.asarray(wo)),
        n_samples=200_000,
        binning="theta",
        theta_bins=20,
        phi_bins=40,
    )


def test_texture_parameters_broadcast():
    rng = np.random.default_rng(5)
    kd = rng.uniform(0, 0.5, (3, 4, 3))
    cz = rng.uniform(0.8, 1.2, (1, 3, 4, 1))  # one lobe, per pixel
    wi, wo = (square_to_uniform_hemisphere(rng.random((3, 4, 2))) for _ in range(2))
    model = Lafortune(kd, [-1.0], [-1.0], cz, [15.0])
    value = model.eval(wi, wo)
    assert value.shape == (3, 4, 3)
    single = Lafortune(kd[2, 1], [-1.0], [-1.0], [cz[0, 2, 1, 0]], [15.0]).eval(wi[2, 1], wo[2, 1])
    np.testing.assert_allclose(value[2, 1], single, rtol=1e-14)


def test_float32_is_kept():
    wi, wo = (a.astype(np.float32) for a in hemisphere_pairs(50, seed=6))
    model = Lafortune()
    assert model.eval(wi, wo).dtype == np.float32
    s = model.sample(wo, np.random.default_rng(7).random((50, 2)).astype(np.float32))
    assert s.wi.dtype == s.weight.dtype == s.pdf.dtype == np.float32


def test_torch_gradients_flow_to_parameters():
    torch = pytest.importorskip("torch")
    wi, wo = (torch.tensor(a) for a in hemisphere_pairs(64, seed=8))
    cx = torch.tensor([-1.0], dtype=torch.float64, requires_grad=True)
    n = torch.tensor([12.0], dtype=torch.float64, requires_grad=True)
    Lafortune(0.2, cx, [-1.0], [1.0], n).eval(wi, wo).sum().backward()
    assert torch.isfinite(cx.grad).all() and cx.grad[0] != 0
    assert torch.isfinite(n.grad).all() and n.grad[0] != 0


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"n": [-2.0]}, ["n", "-2"]),
        ({"cx": -1.0}, ["cx", "lobe axis"]),
        ({"cx": [-1.0, -1.0]}, ["same number of lobes"]),
        ({"kd": 1.2}, ["kd", "1.2"]),
        ({"kd": [0.1, 0.2], "cz": [[1.0, 1.0, 1.0]]}, ["channels"]),
    ],
)
def test_bad_parameters_raise(kwargs, words):
    with pytest.raises(ValueError) as info:
        Lafortune(**kwargs)
    for word in words:
        assert word in str(info.value)
