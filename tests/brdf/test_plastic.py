"""Plastics: Mitsuba 3's ``plastic`` and ``roughplastic`` as oracles (built by the exporter,
:func:`brdfkit.interop.to_mitsuba_dict`, with ``internal="mitsuba"``, which reproduces
Mitsuba's internal-reflectance numerics), and the physics of the default ``internal="exact"``:
the diffuse albedo ρ(1 − F(θo)) of the smooth coating, the interface identities, and how far
Mitsuba's numerics are from the integrals.

Mitsuba's default ``ext_ior`` is air (1.000277): the exporter gives ``ext_ior = 1``.
"""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import RoughPlastic, SmoothPlastic
from brdfkit.brdf.plastic import diffuse_fresnel_reflectance, rough_coating
from brdfkit.errors import ParameterError
from brdfkit.fresnel import fresnel_dielectric
from brdfkit.interop import to_mitsuba_dict

RTOL = 1e-4
N_PAIRS = 300


def _upper(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = np.abs(v[:, 2])
    return v


def _interaction(mi, wo):
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*map(float, wo))
    si.sh_frame = mi.Frame3f(mi.Normal3f(0, 0, 1))
    return si


def _compare(mi, bsdf, ours, wi, wo) -> None:
    ctx = mi.BSDFContext()
    f_mi, pdf_mi = [], []
    for a, b in zip(wi, wo, strict=True):
        v = mi.Vector3f(*map(float, a))
        f_mi.append(np.array(bsdf.eval(ctx, _interaction(mi, b), v)) / a[2])
        pdf_mi.append(float(bsdf.pdf(ctx, _interaction(mi, b), v)))
    f_mi, pdf_mi = np.array(f_mi), np.array(pdf_mi)
    f = np.broadcast_to(ours.eval(wi, wo), f_mi.shape)
    err_f = np.abs(f - f_mi) / np.maximum(f_mi, 1e-6 * f_mi.max())
    err_pdf = np.abs(ours.pdf(wi, wo) - pdf_mi) / np.maximum(pdf_mi, 1e-6 * pdf_mi.max())
    assert np.percentile(err_f, 99) < RTOL, f"f: p99 {np.percentile(err_f, 99):.2e}"
    assert np.percentile(err_pdf, 99) < RTOL, f"pdf: p99 {np.percentile(err_pdf, 99):.2e}"
    assert err_f.max() < 1e-3 and err_pdf.max() < 1e-3


SMOOTH = [
    {"diffuse_reflectance": [0.8, 0.3, 0.1], "eta": 1.5},
    {"diffuse_reflectance": 0.9, "eta": 2.0, "nonlinear": True},
    {"diffuse_reflectance": [0.2, 0.6, 0.3], "specular_reflectance": 0.5, "eta": 1.33},
]


@pytest.mark.oracle
@pytest.mark.parametrize("params", SMOOTH, ids=[str(p) for p in SMOOTH])
def test_mitsuba_plastic(params):
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    ours = SmoothPlastic(**params, internal="mitsuba")
    bsdf = mi.load_dict(to_mitsuba_dict(ours))
    wi, wo = _upper(N_PAIRS, 1), _upper(N_PAIRS, 2)
    _compare(mi, bsdf, ours, wi, wo)
    # The delta lobe: Mitsuba's sample with u0 = 0 picks the mirror; so does ours.
    u = np.zeros((N_PAIRS, 3))
    s = ours.sample(wo, u)
    assert np.all(s.delta) and np.all(s.pdf == 0)
    for k in range(0, N_PAIRS, 10):
        bs, weight = bsdf.sample(mi.BSDFContext(), _interaction(mi, wo[k]), 0.0, mi.Point2f(0.5))
        np.testing.assert_allclose(s.wi[k], np.array(bs.wo), atol=1e-6)
        np.testing.assert_allclose(
            np.broadcast_to(s.weight[k], (3,)), np.array(weight), rtol=RTOL, atol=1e-7
        )


ROUGH = [
    {"alpha": 0.3, "distribution": "ggx", "diffuse_reflectance": [0.8, 0.3, 0.1], "eta": 1.5},
    {"alpha": 0.05, "distribution": "ggx", "diffuse_reflectance": 0.9, "nonlinear": True},
    {"alpha": 0.2, "distribution": "beckmann", "diffuse_reflectance": [0.2, 0.6, 0.3]},
    {
        "alpha": 0.6,
        "distribution": "beckmann",
        "diffuse_reflectance": 0.4,
        "specular_reflectance": 0.5,
        "eta": 1.8,
    },
]


@pytest.mark.oracle
@pytest.mark.parametrize("params", ROUGH, ids=[str(p) for p in ROUGH])
def test_mitsuba_roughplastic(params):
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    ours = RoughPlastic(**params, internal="mitsuba", approximate_g1=True)
    bsdf = mi.load_dict(to_mitsuba_dict(ours))
    wo = _upper(N_PAIRS, 3)
    wi = _upper(N_PAIRS, 4)
    drawn = ours.sample(wo, np.random.default_rng(5).random((N_PAIRS, 3)))
    wi[N_PAIRS // 2 :] = drawn.wi[N_PAIRS // 2 :]  # half near the specular peak
    keep = wi[:, 2] > 1e-3
    _compare(mi, bsdf, ours, wi[keep], wo[keep])


def test_diffuse_fresnel_reflectance():
    """Against a 20000-point midpoint rule; the interface identity F̄(1/η) = 1 − η²(1 − F̄(η))
    against direct quadrature of the internal Fresnel (split at the critical angle); Mitsuba's
    fits within their stated 0.1 %."""
    for eta in (1.2, 1.5, 2.0):
        mu = (np.arange(20000) + 0.5) / 20000
        direct = np.mean(fresnel_dielectric(mu, eta) * 2 * mu)
        assert abs(diffuse_fresnel_reflectance(eta) - direct) < 1e-7
        internal = np.mean(fresnel_dielectric(mu, 1 / eta) * 2 * mu)
        assert abs(diffuse_fresnel_reflectance(1 / eta) - internal) < 1e-5
        for value in (eta, 1 / eta):
            exact = diffuse_fresnel_reflectance(value)
            assert abs(diffuse_fresnel_reflectance(value, "mitsuba") / exact - 1) < 1e-3


def _hemisphere_quadrature(n: int = 96):
    x, w = np.polynomial.legendre.leggauss(n)
    mu, w_mu = 0.5 * (x + 1), 0.5 * w
    phi = 2 * np.pi * (np.arange(2 * n) + 0.5) / (2 * n)
    mu_g, phi_g = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - mu_g**2)
    wi = np.stack([s * np.cos(phi_g), s * np.sin(phi_g), mu_g], axis=-1)
    weights = np.outer(w_mu, np.full(2 * n, 2 * np.pi / (2 * n)))  # dω = dμ dφ
    return wi, weights


@pytest.mark.parametrize("nonlinear", [False, True])
def test_smooth_plastic_albedo_is_the_layer_closed_form(nonlinear):
    """∫ f cos θi dωi + s F(θo) = s F + (1 − F) ρ (linear), or (1 − F) ρ(1 − F̄int)/(1 − ρF̄int)
    (the inter-reflection series), with the exact F̄int."""
    rho, eta = 0.7, 1.5
    model = SmoothPlastic(diffuse_reflectance=rho, eta=eta, nonlinear=nonlinear)
    wi, weights = _hemisphere_quadrature()
    for theta in (0.2, 0.8, 1.3):
        wo = np.array([np.sin(theta), 0.0, np.cos(theta)])
        diffuse = np.sum(model.eval(wi, wo)[..., 0] * wi[..., 2] * weights)
        f_o = float(fresnel_dielectric(np.cos(theta), eta))
        f_int = diffuse_fresnel_reflectance(1 / eta)
        expected = rho * (1 - f_int) / (1 - rho * f_int) if nonlinear else rho
        np.testing.assert_allclose(diffuse, (1 - f_o) * expected, rtol=1e-9)


def test_rough_coating_tables():
    """T(μ) ≤ 1 − (its reflectance) and tends to the smooth 1 − F as α → 0; the exact internal
    reflectance tends to the smooth F̄int; Mitsuba's rectangle rule lies 1–2 % below it (the
    documented difference of ``internal="mitsuba"``)."""
    eta = 1.5
    mu = np.maximum(1e-6, np.linspace(0, 1, 64))
    table, f_int = rough_coating("ggx", 0.01, eta)
    inner = slice(16, None)  # μ > 0.25: nearer grazing the facets still tilt towards ωi
    np.testing.assert_allclose(table[inner], 1 - fresnel_dielectric(mu[inner], eta), atol=2e-3)
    assert abs(f_int - diffuse_fresnel_reflectance(1 / eta)) < 5e-3
    for distribution, alpha in (("ggx", 0.3), ("beckmann", 0.2)):
        table, exact = rough_coating(distribution, alpha, eta)
        _, mitsuba = rough_coating(distribution, alpha, eta, internal="mitsuba")
        assert np.all((table >= 0) & (table <= 1))
        assert 0.005 < (exact - mitsuba) / exact < 0.03


def test_parameters_are_checked():
    with pytest.raises(ParameterError, match="eta"):
        SmoothPlastic(eta=1.0)
    with pytest.raises(ParameterError, match="alpha"):
        RoughPlastic(alpha=[0.1, 0.2, 0.3])
    with pytest.raises(ParameterError, match="internal"):
        RoughPlastic(internal="table")
    with pytest.raises(ParameterError, match="distribution"):
        RoughPlastic(distribution="phong")


@pytest.mark.slow
def test_compiled_path_matches_numpy():
    """(~1 min: numba compiles eval, pdf and sample of both models; the table lookup traces as
    63 ramps.)"""
    from brdfkit.compiled import compile

    wi, wo = _upper(512, 8), _upper(512, 9)
    u = np.random.default_rng(10).random((512, 3))
    for model in (SmoothPlastic(**SMOOTH[0]), RoughPlastic(**ROUGH[0])):
        compiled = compile(model, dtype=np.float64)
        np.testing.assert_allclose(compiled.eval(wi, wo), model.eval(wi, wo), rtol=1e-12)
        np.testing.assert_allclose(compiled.pdf(wi, wo), model.pdf(wi, wo), rtol=1e-12)
        ours, reference = compiled.sample(wo, u), model.sample(wo, u)
        np.testing.assert_allclose(ours.weight, reference.weight, rtol=1e-10, atol=1e-14)


def test_table_interpolation_traced_equals_gathered():
    jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp

    from brdfkit.brdf.plastic import _lerp_table

    table, _ = rough_coating("ggx", 0.3, 1.5)
    cos = np.linspace(-0.1, 1.1, 1001)[:, None]
    gathered = _lerp_table(table, cos)
    traced = jax.jit(lambda c: _lerp_table(table, c))(jnp.asarray(cos))
    np.testing.assert_allclose(np.asarray(traced), gathered, rtol=1e-13, atol=1e-15)
    nodes = np.linspace(0.0, 1.0, table.size)[:, None]
    np.testing.assert_allclose(_lerp_table(table, nodes)[:, 0], table, rtol=1e-12)
