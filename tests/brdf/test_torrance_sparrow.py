"""Torrance–Sparrow, Cook–Torrance and rough-conductor microfacet BRDFs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import (
    BeckmannConductor,
    CookTorrance,
    GGXConductor,
    Lambertian,
    RoughConductor,
    TorranceSparrow,
)
from brdfkit.brdf.microfacet import Beckmann, TorranceSparrowGaussian
from brdfkit.brdf.spec import parse
from brdfkit.checks import brdf_sampler, chi2_test
from brdfkit.fresnel import conductor, f0_from_ior, fresnel_conductor, fresnel_dielectric

CLASSES = [TorranceSparrow, CookTorrance, RoughConductor, GGXConductor, BeckmannConductor]
EXAMPLES = [model for cls in CLASSES for model in cls.examples()]
EXAMPLE_IDS = [model.to_spec()[:60] for model in EXAMPLES]


def _direction(theta: float, phi: float) -> np.ndarray:
    return np.array(
        [math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)]
    )


def _upper_directions(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = np.abs(v[:, 2])
    return v


def test_registered_names_and_spec():
    model = parse("ggx(alpha=0.2, material='Au')")
    assert isinstance(model, GGXConductor)
    assert model.channels == 3
    again = parse(model.to_spec())
    wi, wo = _upper_directions(20, 1), _upper_directions(20, 2)
    np.testing.assert_array_equal(again.eval(wi, wo), model.eval(wi, wo))
    assert isinstance(parse("beckmann(alpha=0.3)"), BeckmannConductor)
    assert isinstance(parse("rough_conductor(alpha_u=0.1, alpha_v=0.3)"), RoughConductor)
    assert isinstance(parse("cook_torrance + lambertian"), object)
    assert isinstance(parse("torrance_sparrow(m=0.3, diffuse=0.5)"), TorranceSparrow)


def test_cook_torrance_closed_form_at_the_normal():
    """wi = wo = n: h = n, D = 1/(π m²), G = 1, so f = F0/(4π m²) (normalised 1/4 form)."""
    m, eta = 0.3, 1.5
    n = np.array([0.0, 0.0, 1.0])
    f = CookTorrance(m=m, eta=eta).eval(n, n)[0]
    assert f == pytest.approx(f0_from_ior(eta) / (4 * math.pi * m * m), rel=1e-14)


def test_torrance_sparrow_closed_form():
    """A general pair against D F G / (4 cos cos) written out by hand (lecture formula)."""
    m = 0.35
    wi, wo = _direction(0.9, 0.3), _direction(0.5, 2.9)
    h = (wi + wo) / np.linalg.norm(wi + wo)
    alpha_h = math.acos(h[2])
    c = TorranceSparrowGaussian(m).normalization(np.zeros(1))[0]
    d = c * math.exp(-((alpha_h / m) ** 2))
    g = min(1.0, 2 * h[2] * wo[2] / (wo @ h), 2 * h[2] * wi[2] / (wo @ h))
    fresnel = fresnel_dielectric(wi @ h, 1.5)
    expected = fresnel * g * d / (4 * wi[2] * wo[2]) + 0.3 / math.pi
    assert TorranceSparrow(m=m, eta=1.5, diffuse=0.3).eval(wi, wo)[0] == pytest.approx(
        expected, rel=1e-13
    )


def test_rough_conductor_closed_form_gold():
    """GGX + Au + height-correlated Smith against the formula written out by hand."""
    alpha = 0.25
    wi, wo = _direction(0.7, 0.1), _direction(1.1, 2.0)
    h = (wi + wo) / np.linalg.norm(wi + wo)
    d = 1 / (math.pi * alpha**2 * h[2] ** 4 * (1 + (1 - h[2] ** 2) / h[2] ** 2 / alpha**2) ** 2)

    def lam(w):
        return (-1 + math.sqrt(1 + alpha**2 * (1 - w[2] ** 2) / w[2] ** 2)) / 2

    g = 1 / (1 + lam(wi) + lam(wo))
    eta, k = conductor("Au")
    fresnel = fresnel_conductor(wi @ h, np.array(eta), np.array(k))
    expected = d * g * fresnel / (4 * wi[2] * wo[2])
    np.testing.assert_allclose(
        GGXConductor(alpha=alpha, material="Au").eval(wi, wo), expected, rtol=1e-13
    )


def test_ggx_albedo_at_normal_incidence_is_one_minus_ln2():
    """GGX, α = 1, F = 1, height-correlated Smith, normal incidence: ρ = 1 − ln 2."""
    model = RoughConductor(alpha=1.0, masking="smith_correlated")
    mean, stderr = model.albedo_estimate(np.array([0.0, 0.0, 1.0]), samples=1 << 14)
    assert abs(mean[0] - (1 - math.log(2))) <= 4 * stderr[0] + 1e-12


@pytest.mark.parametrize("model", EXAMPLES, ids=EXAMPLE_IDS)
def test_reciprocity(model):
    wi, wo = _upper_directions(500, 3), _upper_directions(500, 4)
    f, g = model.eval(wi, wo), model.eval(wo, wi)
    np.testing.assert_allclose(f, g, rtol=1e-6, atol=0)
    assert np.all(f >= 0)


ENERGY_MODELS = [
    *(
        RoughConductor(alpha=a, distribution=d, masking=mk)
        for a in (0.05, 0.3, 0.7, 1.0, 1.5)
        for d in ("ggx", "beckmann")
        for mk in ("smith_correlated", "smith_separable", "v_groove")
    ),
    *(CookTorrance(m=a, fresnel="none") for a in (0.1, 0.5, 1.0)),
    *(TorranceSparrow(m=a, fresnel="none") for a in (0.1, 0.5, 1.0)),
]


def test_albedo_at_most_one_with_unit_fresnel():
    """F = 1: ρ(ωo) ≤ 1 over a sweep of roughness, masking and incidence (to MC error)."""
    theta = np.array([0.0, 0.6, 1.2, 1.45, 1.56])
    wo = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=-1)
    for model in ENERGY_MODELS:
        assert model.energy_conserving
        mean, stderr = model.albedo_estimate(wo, samples=1 << 12)
        assert np.all(mean <= 1 + 4 * stderr + 1e-12), model.to_spec()


def test_smooth_limit_albedo_is_fresnel():
    """α → 0: the albedo tends to the Fresnel reflectance of the mirror direction."""
    wo = _direction(0.8, 0.4)
    model = GGXConductor(alpha=1e-3, material="Cu")
    eta, k = conductor("Cu")
    mean, _ = model.albedo_estimate(wo, samples=1 << 10)
    np.testing.assert_allclose(
        mean, fresnel_conductor(wo[2], np.array(eta), np.array(k)), rtol=1e-4
    )


def test_anisotropy_follows_the_tangent():
    """alpha_u is along the tangent x: a highlight stretched along x is wider along x."""
    model = RoughConductor(alpha_u=0.4, alpha_v=0.05)
    assert not model.isotropic and RoughConductor(alpha=0.2).isotropic
    wo = _direction(0.5, 0.0)
    off_x = model.eval(_direction(0.5 + 0.2, math.pi), wo)[0]  # tilt in the xz-plane
    off_y = model.eval(
        np.array([-math.sin(0.5), 0.2, math.cos(0.5)])
        / np.linalg.norm([-math.sin(0.5), 0.2, math.cos(0.5)]),
        wo,
    )[0]
    assert off_x > 10 * off_y


@pytest.mark.slow
@pytest.mark.parametrize("model", EXAMPLES, ids=EXAMPLE_IDS)
def test_sampler_chi2_and_weight(model):
    """χ² of sample() against pdf(); weight = f·cos/pdf; the pdf integrates to ≤ 1."""
    wo = _direction(0.9, 0.3)
    n = 60_000

    result = chi2_test(
        *brdf_sampler(model, wo), sample_dim=3, n_samples=n, test_count=len(EXAMPLES)
    )
    result.assert_passed()
    u = np.random.default_rng(5).random((2000, 3))
    s = model.sample(np.broadcast_to(wo, (2000, 3)), u)
    ok = s.pdf > 0
    expected = model.eval(s.wi[ok], wo) * s.wi[ok, 2:3] / s.pdf[ok, None]
    np.testing.assert_allclose(s.weight[ok], expected, rtol=1e-10)
    np.testing.assert_allclose(s.pdf[ok], model.pdf(s.wi[ok], wo), rtol=1e-10)
    assert np.all(s.weight[~ok] == 0)
    assert not np.any(s.delta)


@pytest.mark.slow
def test_plain_sampling_option():
    """sample_visible=False samples D cos θh; the same BRDF, a different but exact pdf."""
    wo = _direction(1.0, 0.0)
    for model in (
        RoughConductor(alpha=0.3, sample_visible=False),
        CookTorrance(m=0.3, sample_visible=False),
    ):
        result = chi2_test(
            *brdf_sampler(model, wo),
            n_samples=60_000,
            test_count=2,
        )
        result.assert_passed()


def test_diffuse_base_is_a_lambertian_lobe():
    wi, wo = _upper_directions(50, 6), _upper_directions(50, 7)
    with_diffuse = CookTorrance(m=0.3, diffuse=[0.5, 0.2, 0.1])
    expected = CookTorrance(m=0.3).eval(wi, wo) + Lambertian([0.5, 0.2, 0.1]).eval(wi, wo)
    np.testing.assert_allclose(with_diffuse.eval(wi, wo), expected, rtol=1e-14)
    assert not with_diffuse.energy_conserving


def test_beckmann_options_reach_the_distribution():
    model = BeckmannConductor(alpha_u=0.2, alpha_v=0.5, approximate_g1=True)
    assert isinstance(model.ndf, Beckmann)
    assert model.ndf.approximate_g1
    w = _direction(1.3, 0.5)
    assert model.ndf.smith_lambda(w)[0] == pytest.approx(
        Beckmann(0.2, 0.5, approximate_g1=True).smith_lambda(w)[0], rel=1e-15
    )


@pytest.mark.parametrize(
    ("factory", "match"),
    [
        (lambda: RoughConductor(alpha=0.0), "alpha must be in"),
        (lambda: RoughConductor(alpha=-0.1), "alpha must be in"),
        (lambda: RoughConductor(alpha_u=0.1), "alpha_u and alpha_v must be given together"),
        (lambda: RoughConductor(alpha_u=0.1, alpha_v=0.0), "alpha_v must be in"),
        (lambda: RoughConductor(distribution="phong"), "distribution must be one of"),
        (lambda: GGXConductor(distribution="beckmann"), "distribution must be 'ggx'"),
        (lambda: RoughConductor(masking="smith"), "masking must be one of"),
        (lambda: RoughConductor(material="Au", eta=0.2), "material and eta are exclusive"),
        (lambda: RoughConductor(eta=-1.0), "eta must be in"),
        (lambda: RoughConductor(eta=0.2, k=-1.0), "k must be in"),
        (lambda: RoughConductor(k=2.0), "k needs eta"),
        (lambda: RoughConductor(material="Xx"), "Xx"),
        (lambda: RoughConductor(alpha=[0.1, 0.2, 0.3], material="Au", k=None), None),
        (lambda: RoughConductor(alpha=[0.1, 0.2], material="Au"), "channels"),
        (lambda: CookTorrance(m=0.0), "m must be in"),
        (lambda: CookTorrance(diffuse=1.5), "diffuse must be in"),
        (lambda: CookTorrance(fresnel="dielectric", material="Au"), "must be 'conductor'"),
        (lambda: TorranceSparrow(m=-0.2), "m must be in"),
        (lambda: TorranceSparrow(fresnel="schlick", f0=2.0), "f0 must be in"),
    ],
)
def test_bad_parameters(factory, match):
    if match is None:
        assert factory().channels == 3
        return
    with pytest.raises(ValueError, match=match):
        factory()


@pytest.mark.parametrize("cls", [TorranceSparrow, CookTorrance, RoughConductor])
def test_dtype_kept(cls, backend):
    model = cls.examples()[1]
    wi = backend(_upper_directions(16, 8))
    wo = backend(_upper_directions(16, 9))
    u = backend(np.random.default_rng(2).random((16, 3)))
    assert model.eval(wi, wo).dtype == wi.dtype
    assert model.pdf(wi, wo).dtype == wi.dtype
    s = model.sample(wo, u)
    assert s.wi.dtype == wi.dtype and s.weight.dtype == wi.dtype
    assert np.all(np.isfinite(np.asarray(s.weight)))


def test_torch_gradients_flow():
    torch = pytest.importorskip("torch")
    wi = torch.tensor(_upper_directions(32, 10))
    wo = torch.tensor(_upper_directions(32, 11))
    alpha = torch.tensor(0.3, dtype=torch.float64, requires_grad=True)
    eta = torch.tensor([0.2, 0.5, 1.2], dtype=torch.float64, requires_grad=True)
    k = torch.tensor([3.0, 2.5, 1.8], dtype=torch.float64, requires_grad=True)
    RoughConductor(alpha=alpha, eta=eta, k=k).eval(wi, wo).sum().backward()
    for p in (alpha, eta, k):
        assert p.grad is not None and bool(torch.all(torch.isfinite(p.grad)))
        assert bool(torch.all(p.grad != 0))
    m = torch.tensor(0.3, dtype=torch.float64, requires_grad=True)
    eta_d = torch.tensor(1.5, dtype=torch.float64, requires_grad=True)
    (
        TorranceSparrow(m=m, eta=eta_d).eval(wi, wo).sum()
        + CookTorrance(m=m, eta=eta_d).eval(wi, wo).sum()
    ).backward()
    assert m.grad is not None and torch.isfinite(m.grad) and m.grad != 0
    assert eta_d.grad is not None and torch.isfinite(eta_d.grad) and eta_d.grad != 0
    # Gradients also flow through a sampled path (weight depends on α through G).
    alpha.grad = None
    u = torch.rand(64, 3, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    s = RoughConductor(alpha=alpha).sample(wo[:1].expand(64, 3), u)
    s.weight.sum().backward()
    assert alpha.grad is not None and torch.isfinite(alpha.grad) and alpha.grad != 0


def test_slightly_non_unit_directions_do_not_break_the_fresnel_term():
    """wi·h can exceed 1 for directions unit only to a few 1e-3 (typed-in vectors): F clamps."""
    from brdfkit.brdf import RoughConductor

    gold = RoughConductor(alpha=0.2, material="Au")
    wi, wo = np.array([0.3, 0.0, 0.95]), np.array([-0.3, 0.1, 0.95])  # |wo| = 1.00125
    value = gold.eval(wi, wo)
    unit = gold.eval(wi / np.linalg.norm(wi), wo / np.linalg.norm(wo))
    assert np.all(np.isfinite(value)) and np.allclose(value, unit, rtol=0.02)
    assert np.all(np.isfinite(gold.albedo(wo, samples=256)))
