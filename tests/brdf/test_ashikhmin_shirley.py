"""Ashikhmin–Shirley: the paper's formula, its normalised half-vector density, the diffuse
term's closed-form albedo, energy conservation over a sweep, anisotropy and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import AshikhminShirley
from brdfkit.brdf.ashikhmin_shirley import (
    ashikhmin_shirley_diffuse,
    ashikhmin_shirley_half_vector_pdf,
)
from brdfkit.errors import ParameterError
from brdfkit.geometry import spherical_to_cartesian
from brdfkit.sampling import hemisphere_pairs


def _paper(wi, wo, rd, rs, nu, nv):
    """Ashikhmin & Shirley (2000), eqs. 4–5, written with the half vector's angles."""
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=-1, keepdims=True)
    cos_h = h[:, 2]
    phi_h = np.arctan2(h[:, 1], h[:, 0])
    k_h = np.sum(wi * h, axis=-1)
    fresnel = rs + (1 - rs) * (1 - k_h) ** 5
    exponent = nu * np.cos(phi_h) ** 2 + nv * np.sin(phi_h) ** 2
    specular = (
        math.sqrt((nu + 1) * (nv + 1))
        / (8 * math.pi)
        * cos_h**exponent
        / (k_h * np.maximum(wi[:, 2], wo[:, 2]))
        * fresnel
    )
    diffuse = (
        28
        * rd
        / (23 * math.pi)
        * (1 - rs)
        * (1 - (1 - wi[:, 2] / 2) ** 5)
        * (1 - (1 - wo[:, 2] / 2) ** 5)
    )
    return specular + diffuse


@pytest.mark.parametrize(("nu", "nv"), [(10.0, 10.0), (5.0, 800.0), (3000.0, 20.0)])
def test_eval_is_the_paper_formula(nu, nv):
    wi, wo = hemisphere_pairs(2000, seed=3)
    model = AshikhminShirley(0.4, 0.07, nu, nv)
    np.testing.assert_allclose(
        model.eval(wi, wo)[:, 0], _paper(wi, wo, 0.4, 0.07, nu, nv), rtol=1e-10
    )


def _hemisphere_grid(n: int = 800):
    """Midpoint grid on (cos θ, φ) with its solid-angle weights."""
    c = (np.arange(n) + 0.5) / n
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * math.pi
    cc, pp = np.meshgrid(c, phi, indexing="ij")
    s = np.sqrt(1 - cc**2)
    w = np.stack([s * np.cos(pp), s * np.sin(pp), cc], axis=-1)
    return w, (1 / n) * (2 * math.pi / (2 * n))


@pytest.mark.parametrize(("nu", "nv"), [(0.0, 0.0), (10.0, 10.0), (4.0, 60.0), (100.0, 2.0)])
def test_half_vector_density_integrates_to_one(nu, nv):
    h, dw = _hemisphere_grid()
    pdf = ashikhmin_shirley_half_vector_pdf(h, np.full(h.shape[:-1], nu), np.full(h.shape[:-1], nv))
    assert abs(pdf.sum() * dw - 1) < 2e-3


@pytest.mark.parametrize("theta_o", [0.0, 40.0, 80.0])
def test_diffuse_albedo_is_the_closed_form(theta_o):
    wi, dw = _hemisphere_grid(600)
    cos_o = math.cos(math.radians(theta_o))
    f = ashikhmin_shirley_diffuse(wi[..., 2], cos_o, 0.7, 0.2)
    albedo = np.sum(f * wi[..., 2]) * dw
    expected = 0.7 * (1 - 0.2) * (1 - (1 - cos_o / 2) ** 5)
    assert abs(albedo - expected) < 1e-5


@pytest.mark.parametrize("rs", [0.0, 0.05, 0.5, 1.0])
@pytest.mark.parametrize(("nu", "nv"), [(1.0, 1.0), (100.0, 100.0), (1e4, 1e4), (1.0, 1000.0)])
def test_albedo_at_most_one_with_full_diffuse(rs, nu, nv):
    # R_d = 1, the largest diffuse share, up to θo = 89.9°: the sum stays ≤ 1 (max ≈ 0.9996 at
    # R_s = 1, n = 10⁴, normal view).
    theta = np.radians([0.0, 30.0, 60.0, 80.0, 89.0, 89.9])
    wo = spherical_to_cartesian(theta, np.full_like(theta, 0.7))
    mean, stderr = AshikhminShirley(1.0, rs, nu, nv).albedo_estimate(wo, samples=1 << 14)
    assert np.all(mean - 3 * stderr <= 1.0), mean[:, 0]
    assert np.all(mean > 0.05)


def test_isotropic_default_and_anisotropy_rotates():
    wi, wo = hemisphere_pairs(500, seed=5)
    iso = AshikhminShirley(0.3, 0.1, 50.0)
    assert iso.isotropic and "nv" not in iso.params()
    np.testing.assert_array_equal(
        iso.eval(wi, wo), AshikhminShirley(0.3, 0.1, 50.0, 50.0).eval(wi, wo)
    )
    a, b = AshikhminShirley(0.3, 0.1, 5.0, 500.0), AshikhminShirley(0.3, 0.1, 500.0, 5.0)
    assert not a.isotropic
    rotate = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90° about z
    np.testing.assert_allclose(a.eval(wi, wo), b.eval(wi @ rotate.T, wo @ rotate.T), rtol=1e-10)


def test_spec_round_trip():
    from brdfkit.brdf import parse

    model = AshikhminShirley([0.5, 0.4, 0.3], 0.04, 20.0, 200.0)
    again = parse(model.to_spec())
    wi, wo = hemisphere_pairs(100, seed=6)
    np.testing.assert_array_equal(again.eval(wi, wo), model.eval(wi, wo))


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [({"rs": 1.5}, "rs"), ({"rd": -0.1}, "rd"), ({"nu": -1.0}, "nu"), ({"nv": "x"}, "nv")],
)
def test_bad_parameters_name_themselves(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        AshikhminShirley(**kwargs)
