"""Delta lobes: the ideal mirror, the smooth conductor and the smooth dielectric."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import Mirror, SmoothConductor, SmoothDielectric
from brdfkit.brdf.spec import parse
from brdfkit.fresnel import conductor, fresnel_conductor, fresnel_dielectric, schlick


def _upper(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = np.abs(v[:, 2])
    return v


WO = _upper(100, 0)
U = np.random.default_rng(1).random((100, 2))


@pytest.mark.parametrize(
    "model", [*Mirror.examples(), *SmoothConductor.examples()], ids=lambda m: m.to_spec()
)
def test_delta_reflectors(model):
    """Mirror direction, zero eval/pdf, delta flag, weight = albedo = R·F(cos θo)."""
    s = model.sample(WO, U)
    np.testing.assert_array_equal(s.wi, WO * np.array([-1, -1, 1]))
    assert np.all(s.delta) and np.all(s.pdf == 0)
    assert np.all(model.eval(s.wi, WO) == 0) and np.all(model.pdf(s.wi, WO) == 0)
    np.testing.assert_array_equal(s.weight, model.albedo(WO))
    assert s.weight.shape == (100, model.channels)
    assert np.all((s.weight >= 0) & (s.weight <= 1))
    below = WO * np.array([1, 1, -1])
    assert np.all(model.sample(below, U).weight == 0)


def test_mirror_fresnel_options():
    cos = WO[:, 2:3]
    np.testing.assert_allclose(
        Mirror(reflectance=[0.9, 0.5, 0.1]).albedo(WO),
        np.broadcast_to([0.9, 0.5, 0.1], (100, 3)),
        rtol=0,
    )
    np.testing.assert_allclose(
        Mirror(fresnel="dielectric", eta=1.5).albedo(WO), fresnel_dielectric(cos, 1.5), rtol=1e-15
    )
    np.testing.assert_allclose(
        Mirror(fresnel="schlick", f0=0.2, reflectance=0.5).albedo(WO),
        0.5 * schlick(cos, 0.2),
        rtol=1e-15,
    )
    eta, k = conductor("Au")
    gold = fresnel_conductor(cos, np.array(eta), np.array(k))
    np.testing.assert_allclose(Mirror(material="Au").albedo(WO), gold, rtol=1e-15)
    np.testing.assert_allclose(SmoothConductor(material="Au").albedo(WO), gold, rtol=1e-15)
    # Normal incidence of a conductor: ((η−1)² + k²)/((η+1)² + k²).
    n = np.array([0.0, 0.0, 1.0])
    eta_a, k_a = np.array(eta), np.array(k)
    np.testing.assert_allclose(
        SmoothConductor(material="Au").albedo(n),
        ((eta_a - 1) ** 2 + k_a**2) / ((eta_a + 1) ** 2 + k_a**2),
        rtol=1e-12,
    )
    assert isinstance(parse("mirror(material='Ag')"), Mirror)
    assert isinstance(parse("smooth_conductor(material='Cu')"), SmoothConductor)


@pytest.mark.parametrize("eta", [1.5, 2.419, 1 / 1.33])
@pytest.mark.parametrize("side", [1.0, -1.0])
def test_smooth_dielectric_snell_and_lobes(eta, side):
    wo = WO * np.array([1, 1, side])
    model = SmoothDielectric(eta=eta)
    fresnel = fresnel_dielectric(wo[:, 2], eta)
    u_reflect = np.stack([0.999 * fresnel, U[:, 1]], axis=-1)
    u_refract = np.stack([fresnel + 0.999 * (1 - fresnel), U[:, 1]], axis=-1)
    r, t = model.sample(wo, u_reflect), model.sample(wo, u_refract)
    assert np.all(r.delta) and np.all(t.delta) and np.all(r.pdf == 0)
    reflect_only = fresnel >= 1  # total internal reflection
    np.testing.assert_allclose(r.wi, wo * np.array([-1, -1, 1]), atol=1e-15)
    np.testing.assert_allclose(r.weight[:, 0], 1.0)
    refr = ~reflect_only
    # Snell: η_o sin θo = η_i sin θi, opposite side, opposite azimuth, unit length.
    eta_o = np.where(wo[:, 2] > 0, 1.0, eta)
    eta_i = np.where(wo[:, 2] > 0, eta, 1.0)
    sin_o = np.hypot(wo[:, 0], wo[:, 1])
    sin_i = np.hypot(t.wi[:, 0], t.wi[:, 1])
    np.testing.assert_allclose((eta_o * sin_o)[refr], (eta_i * sin_i)[refr], rtol=1e-12)
    assert np.all(t.wi[refr, 2] * wo[refr, 2] < 0)
    np.testing.assert_allclose(np.linalg.norm(t.wi[refr], axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(
        t.wi[refr, :2] * sin_o[refr, None], -wo[refr, :2] * sin_i[refr, None], atol=1e-12
    )
    # Radiance scaling (η_o/η_i)² on refraction; the reflected lobe under TIR.
    np.testing.assert_allclose(t.weight[refr, 0], (eta_o / eta_i)[refr] ** 2, rtol=1e-12)
    np.testing.assert_allclose(t.wi[reflect_only], wo[reflect_only] * np.array([-1, -1, 1]))
    np.testing.assert_allclose(model.albedo(wo)[:, 0], fresnel, rtol=1e-15)


def test_total_internal_reflection_beyond_the_critical_angle():
    eta = 1.5
    critical = math.asin(1 / eta)
    theta = np.array([critical - 0.05, critical + 0.01, 1.2])
    wo = np.stack([np.sin(theta), np.zeros(3), -np.cos(theta)], axis=-1)  # viewer inside
    s = SmoothDielectric(eta=eta).sample(wo, np.full((3, 2), 0.99))
    assert s.wi[0, 2] > 0  # below the critical angle: refracts out (u = 0.99 > F)
    assert np.all(s.wi[1:, 2] < 0) and np.all(s.weight[1:] == 1)


def test_unbiased_lobe_choice_and_energy():
    """E[weight] over u: importance mode (flux) gives exactly 1; radiance F + (1−F)(η_o/η_i)²."""
    wo = np.array([math.sin(0.7), 0.0, math.cos(0.7)])
    n = 100_000
    u = np.stack([(np.arange(n) + 0.5) / n, np.zeros(n)], axis=-1)
    f = fresnel_dielectric(wo[2], 1.5)
    importance = SmoothDielectric(eta=1.5, mode="importance").sample(wo, u)
    assert np.mean(importance.weight) == pytest.approx(1.0, abs=1e-4)
    radiance = SmoothDielectric(eta=1.5).sample(wo, u)
    assert np.mean(radiance.weight) == pytest.approx(f + (1 - f) / 1.5**2, abs=1e-4)
    reflected = np.mean(np.where(radiance.wi[:, 2:3] > 0, radiance.weight, 0))
    assert reflected == pytest.approx(f, abs=1e-4)


def test_properties_and_bad_parameters():
    assert SmoothDielectric.has_delta and SmoothDielectric.transmits
    assert not SmoothDielectric.reciprocal and Mirror.reciprocal and Mirror.has_delta
    with pytest.raises(ValueError, match="reflectance must be in"):
        Mirror(reflectance=1.2)
    with pytest.raises(ValueError, match="fresnel must be one of"):
        Mirror(fresnel="metal")
    with pytest.raises(ValueError, match="material and eta are exclusive"):
        SmoothConductor(material="Au", eta=0.3)
    with pytest.raises(ValueError, match="k needs eta"):
        SmoothConductor(k=1.0)
    with pytest.raises(ValueError, match="eta must be in"):
        SmoothDielectric(eta=-1.5)
    with pytest.raises(ValueError, match="one value per point"):
        SmoothDielectric(eta=[1.5, 1.52, 1.54])
    with pytest.raises(ValueError, match="mode must be one of"):
        SmoothDielectric(mode="flux")


def test_dtype_and_gradients(backend):
    wo = backend(WO)
    u = backend(U)
    for model in (Mirror(material="Au"), SmoothDielectric()):
        s = model.sample(wo, u)
        assert s.wi.dtype == wo.dtype and s.weight.dtype == wo.dtype
        assert model.eval(s.wi, wo).dtype == wo.dtype
    torch = pytest.importorskip("torch")
    eta = torch.tensor(1.5, dtype=torch.float64, requires_grad=True)
    wo_t = torch.tensor(WO)
    model = SmoothDielectric(eta=eta)
    (model.albedo(wo_t).sum() + model.sample(wo_t, torch.tensor(U)).weight.sum()).backward()
    assert eta.grad is not None and torch.isfinite(eta.grad) and eta.grad != 0
    k = torch.tensor([3.0, 2.0, 1.5], dtype=torch.float64, requires_grad=True)
    SmoothConductor(eta=[0.2, 0.5, 1.0], k=k).albedo(wo_t).sum().backward()
    assert bool(torch.all(k.grad != 0))
