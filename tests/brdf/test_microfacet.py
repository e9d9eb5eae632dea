"""Microfacet distributions, Smith masking, visible-normal sampling and Fresnel terms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, special

from brdfkit.brdf.microfacet import (
    GGX,
    Beckmann,
    FresnelTerm,
    TorranceSparrowGaussian,
    masking_shadowing,
)
from brdfkit.checks import chi2_test
from brdfkit.fresnel import conductor, fresnel_conductor, fresnel_dielectric, schlick

DISTRIBUTIONS = [
    GGX(0.05),
    GGX(0.3),
    GGX(1.0),
    GGX(0.1, 0.5),
    Beckmann(0.05),
    Beckmann(0.3),
    Beckmann(1.0),
    Beckmann(0.6, 0.15),
    TorranceSparrowGaussian(0.05),
    TorranceSparrowGaussian(0.4),
    TorranceSparrowGaussian(1.2),
]
IDS = [f"{type(d).__name__}-{i}" for i, d in enumerate(DISTRIBUTIONS)]


def _direction(theta: float, phi: float) -> np.ndarray:
    return np.array(
        [math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)]
    )


def _hemisphere_integral(f, n_theta: int = 512, n_phi: int = 256) -> float:
    """∫ f(ω) dω over the upper hemisphere: Gauss–Legendre in θ, midpoint rule in φ."""
    x, w = np.polynomial.legendre.leggauss(n_theta)
    theta = (x + 1) * math.pi / 4
    w_theta = w * math.pi / 4
    phi = (np.arange(n_phi) + 0.5) * 2 * math.pi / n_phi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    omega = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)
    return float(np.sum(f(omega) * np.sin(t) * w_theta[:, None]) * 2 * math.pi / n_phi)


@pytest.mark.parametrize("dist", DISTRIBUTIONS, ids=IDS)
def test_projected_area_is_one(dist):
    """∫ D(ωm) cos θm dωm = 1 (the microfacets project onto the macro-surface)."""
    total = _hemisphere_integral(lambda m: dist.D(m)[..., 0] * m[..., 2])
    assert total == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("dist", DISTRIBUTIONS, ids=IDS)
@pytest.mark.parametrize("theta_o", [0.0, 0.7, 1.4])
def test_weak_white_furnace(dist, theta_o):
    """∫ G1(ωo, ωm) D(ωm) max(0, ωo·ωm) dωm = cos θo (Heitz 2014 eq. 74)."""
    wo = _direction(theta_o, 0.7)

    def integrand(m):
        return dist.G1(wo, m)[..., 0] * dist.D(m)[..., 0] * np.maximum(m @ wo, 0.0)

    assert _hemisphere_integral(integrand) == pytest.approx(wo[2], rel=1e-6)


@pytest.mark.parametrize(
    "dist",
    [Beckmann(1.0), GGX(0.4), TorranceSparrowGaussian(0.8)],
    ids=["Beckmann", "GGX", "Gaussian"],
)
def test_v_groove_passes_the_white_furnace(dist):
    """The V-groove G1 = min(1, 2 cos θh cos θo / (ωo·h)) is Heitz's V-cavity: its weak
    white-furnace integral is cos θo for any D."""
    wo = _direction(1.25, 0.4)

    def integrand(m):
        wo_m = m @ wo
        g1 = np.minimum(1.0, 2 * m[..., 2] * wo[2] / np.where(wo_m > 0, wo_m, 1.0))
        return np.where(wo_m > 0, g1 * dist.D(m)[..., 0] * wo_m, 0.0)

    assert _hemisphere_integral(integrand) == pytest.approx(wo[2], rel=1e-9)


def test_gaussian_normalisation_against_scipy_quad():
    """c(m) from the built-in quadrature equals an independent adaptive quadrature."""
    for m in (0.02, 0.3, 1.0, 4.0):
        integral, _ = integrate.quad(
            lambda t, m=m: math.exp(-((t / m) ** 2)) * math.cos(t) * math.sin(t),
            0,
            math.pi / 2,
            epsabs=0,
            epsrel=1e-13,
            points=[m],
        )
        c = TorranceSparrowGaussian(m).normalization(np.zeros(1))[0]
        assert c == pytest.approx(1 / (2 * math.pi * integral), rel=1e-12)
    # Small-angle limit: Beckmann's 1/(π m²).
    assert TorranceSparrowGaussian(1e-3).normalization(np.zeros(1))[0] * math.pi * 1e-6 == (
        pytest.approx(1.0, rel=1e-5)
    )


def test_closed_forms_of_lambda():
    """GGX and Beckmann Λ against their closed forms in a = 1/(α tan θ)."""
    theta = np.linspace(0.05, 1.5, 30)
    w = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=-1)
    alpha = 0.4
    a = 1 / (alpha * np.tan(theta))
    ggx = GGX(alpha).smith_lambda(w)[..., 0]
    np.testing.assert_allclose(ggx, (-1 + np.sqrt(1 + 1 / a**2)) / 2, rtol=1e-12)
    beckmann = Beckmann(alpha).smith_lambda(w)[..., 0]
    expected = (special.erf(a) - 1) / 2 + np.exp(-a * a) / (2 * a * math.sqrt(math.pi))
    np.testing.assert_allclose(beckmann, expected, rtol=1e-10, atol=1e-300)
    # Walter's rational G1 (Mitsuba's) is within 0.35 % of the exact one.
    g_exact = 1 / (1 + beckmann)
    g_rational = 1 / (1 + Beckmann(alpha, approximate_g1=True).smith_lambda(w)[..., 0])
    assert np.max(np.abs(g_rational / g_exact - 1)) < 0.0035
    assert np.max(np.abs(g_rational / g_exact - 1)) > 1e-4  # it is an approximation


def test_ggx_one_division_forms_equal_the_textbook_ones():
    """GGX's D and G1 are computed in forms with fewer divisions; they equal the formulas as
    written (Walter et al. 2007 eqs. 33-34) to rounding, anisotropic and near grazing."""
    rng = np.random.default_rng(7)
    theta = np.concatenate([rng.uniform(0, 1.5, 200), [1e-6, 1.5707]])
    phi = rng.uniform(0, 2 * math.pi, theta.size)
    w = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)
    ax, ay = 0.15, 0.6
    dist = GGX(ax, ay)
    tan2 = np.tan(theta) ** 2
    slope = np.cos(phi) ** 2 / ax**2 + np.sin(phi) ** 2 / ay**2
    d = 1 / (math.pi * ax * ay * np.cos(theta) ** 4 * (1 + tan2 * slope) ** 2)
    np.testing.assert_allclose(dist.D(w)[..., 0], d, rtol=1e-12)
    alpha2 = ax**2 * np.cos(phi) ** 2 + ay**2 * np.sin(phi) ** 2
    g1 = 1 / (1 + (-1 + np.sqrt(1 + alpha2 * tan2)) / 2)
    np.testing.assert_allclose(dist.smith_G1(w)[..., 0], g1, rtol=1e-12)
    below = w * np.array([1.0, 1.0, -1.0])  # G1 is even in cos θ
    np.testing.assert_allclose(dist.smith_G1(below)[..., 0], g1, rtol=1e-12)
    horizon = np.array([[1.0, 0.0, 0.0]])
    assert dist.smith_G1(horizon)[0, 0] == 0.0 and dist.D(horizon)[0, 0] == 0.0


def test_anisotropic_lambda_uses_projected_roughness():
    """Λ of (αx, αy) along azimuth φ equals the isotropic Λ with α(φ)² = αx²cos²φ + αy²sin²φ."""
    ax, ay, theta, phi = 0.2, 0.7, 1.1, 0.9
    w = _direction(theta, phi)
    alpha_phi = math.sqrt(ax**2 * math.cos(phi) ** 2 + ay**2 * math.sin(phi) ** 2)
    for cls in (GGX, Beckmann):
        assert cls(ax, ay).smith_lambda(w)[0] == pytest.approx(
            cls(alpha_phi).smith_lambda(w)[0], rel=1e-12
        )


def test_per_channel_roughness():
    """Channel-valued α gives per-channel D and Λ; samplers use the channel mean."""
    alphas = np.array([0.1, 0.3, 0.5])
    dist = GGX(alphas)
    m = _direction(0.3, 0.2)
    w = _direction(1.0, 2.0)
    for c, a in enumerate(alphas):
        assert dist.D(m)[c] == pytest.approx(GGX(a).D(m)[0], rel=1e-14)
        assert dist.smith_lambda(w)[c] == pytest.approx(GGX(a).smith_lambda(w)[0], rel=1e-14)
    assert dist.pdf(m) == pytest.approx(GGX(0.3).pdf(m), rel=1e-14)
    assert dist.pdf_visible(w, m) == pytest.approx(GGX(0.3).pdf_visible(w, m), rel=1e-14)


CHI2_CASES = [d for d in DISTRIBUTIONS if not (isinstance(d, TorranceSparrowGaussian))]


@pytest.mark.parametrize("dist", CHI2_CASES, ids=[type(d).__name__ for d in CHI2_CASES])
def test_chi2_plain_and_visible_sampling(dist):
    """χ² of D·cos sampling and of visible-normal sampling (3 incidences) against their pdfs."""
    dist.sample(np.full((1, 2), 0.5))
    result = chi2_test(
        dist.sample, dist.pdf, sphere=False, binning="theta", n_samples=100_000, test_count=4
    )
    result.assert_passed()
    for w in (_direction(0.0, 0.0), _direction(0.9, 0.4), _direction(1.55, 2.5)):
        result = chi2_test(
            lambda u, w=w: dist.sample_visible(w, u),
            lambda m, w=w: dist.pdf_visible(w, m),
            sphere=False,
            binning="theta",
            n_samples=100_000,
            test_count=4,
        )
        result.assert_passed()


@pytest.mark.slow
@pytest.mark.parametrize("m", [0.1, 0.8])
def test_chi2_gaussian_sampling(m):
    """χ² of the Torrance–Sparrow D·cos sampler (numerical CDF inversion) against its pdf."""
    dist = TorranceSparrowGaussian(m)
    result = chi2_test(
        dist.sample, dist.pdf, sphere=False, binning="theta", n_samples=50_000, test_count=2
    )
    result.assert_passed()


def test_gaussian_sampler_inverts_the_cdf():
    """The sampled θm solves CDF(θm) = u1 to rounding, also near u1 = 1."""
    dist = TorranceSparrowGaussian(0.5)
    u = np.stack([np.array([1e-9, 0.1, 0.5, 0.9, 0.999999]), np.full(5, 0.3)], axis=-1)
    theta = np.arccos(dist.sample(u)[..., 2])
    for t, target in zip(theta, u[:, 0], strict=True):
        cdf, _ = integrate.quad(
            lambda s: dist.pdf(_direction(s, 0.0)) * 2 * math.pi * math.sin(s),
            0,
            t,
            epsabs=1e-15,
            epsrel=1e-12,
        )
        assert cdf == pytest.approx(target, rel=1e-9, abs=1e-12)


def test_masking_shadowing_variants():
    """V-groove as the lectures write it; separable = G1·G1; correlated ≥ separable."""
    dist = Beckmann(0.4)
    wi, wo = _direction(1.45, 0.0), _direction(0.9, 0.2)
    h = (wi + wo) / np.linalg.norm(wi + wo)
    v = masking_shadowing(dist, wi, wo, h, "v_groove")[0]
    expected = min(1.0, 2 * h[2] * wo[2] / (wo @ h), 2 * h[2] * wi[2] / (wo @ h))
    assert v == pytest.approx(expected, rel=1e-14)
    assert expected < 1  # the test pair is really masked
    separable = masking_shadowing(dist, wi, wo, h, "smith_separable")[0]
    assert separable == pytest.approx(dist.G1(wi, h)[0] * dist.G1(wo, h)[0], rel=1e-14)
    correlated = masking_shadowing(dist, wi, wo, h, "smith_correlated")[0]
    lam_i, lam_o = dist.smith_lambda(wi)[0], dist.smith_lambda(wo)[0]
    assert correlated == pytest.approx(1 / (1 + lam_i + lam_o), rel=1e-14)
    assert correlated > separable
    # A back-facing microfacet is invisible.
    assert masking_shadowing(dist, wi, wo, -h, "smith_correlated")[0] == 0


def test_correlated_transmission_is_a_beta_function():
    """For ωi below the surface the height-correlated G2 is B(1 + Λi, 1 + Λo) (Heitz 2014 §6.2)."""
    dist = GGX(0.5)
    wo = _direction(0.8, 0.0)
    wi = -_direction(0.6, 0.4)
    m = np.array([0.1, 0.05, 1.0]) / np.linalg.norm([0.1, 0.05, 1.0])
    value = masking_shadowing(dist, wi, wo, m, "smith_correlated")[0]
    lam_i, lam_o = dist.smith_lambda(wi)[0], dist.smith_lambda(wo)[0]
    assert value == pytest.approx(special.beta(1 + lam_i, 1 + lam_o), rel=1e-12)


def test_fresnel_term_kinds():
    cos = np.linspace(0.01, 1, 7)[:, None]
    assert np.all(FresnelTerm.from_options("none")(cos) == 1)
    np.testing.assert_allclose(
        FresnelTerm.from_options("dielectric", eta=1.5)(cos),
        fresnel_dielectric(cos, 1.5),
        rtol=1e-15,
    )
    np.testing.assert_allclose(
        FresnelTerm.from_options("schlick", f0=0.1)(cos), schlick(cos, 0.1), rtol=1e-15
    )
    gold = FresnelTerm.from_options("conductor", material="Au")
    eta, k = conductor("Au")
    assert gold.channels == 3
    np.testing.assert_allclose(
        gold(cos), fresnel_conductor(cos, np.array(eta), np.array(k)), rtol=1e-15
    )


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"kind": "metal"}, "fresnel must be one of"),
        ({"kind": "dielectric", "eta": -1.0}, "eta must be in"),
        ({"kind": "conductor", "k": -0.1}, "k must be in"),
        ({"kind": "schlick", "f0": 1.5}, "f0 must be in"),
        ({"kind": "dielectric", "material": "Au"}, "fresnel must be 'conductor'"),
        ({"kind": "conductor", "material": "Unobtainium"}, "Unobtainium"),
    ],
)
def test_fresnel_term_rejects_bad_options(kwargs, match):
    kind = kwargs.pop("kind")
    with pytest.raises(ValueError, match=match):
        FresnelTerm.from_options(kind, **kwargs)


def test_bad_parameters_raise():
    with pytest.raises(ValueError, match="alpha_x must be in"):
        GGX(0.0)
    with pytest.raises(ValueError, match="alpha_y must be in"):
        Beckmann(0.1, -0.2)
    with pytest.raises(ValueError, match="m must be in"):
        TorranceSparrowGaussian(-0.1)
    with pytest.raises(ValueError, match="masking must be one of"):
        masking_shadowing(
            GGX(0.1), _direction(0.1, 0), _direction(0.2, 1), _direction(0, 0), "smith"
        )


@pytest.mark.parametrize("cls", [GGX, Beckmann, TorranceSparrowGaussian])
def test_backends_dtype_and_gradient(cls, backend):
    """float32 stays float32; torch gradients w.r.t. the roughness flow and are finite."""
    u = backend(np.random.default_rng(1).random((64, 2)))
    w = backend(_direction(0.8, 0.3))
    dist = cls(0.3)
    m = dist.sample(u)
    assert m.dtype == u.dtype
    for value in (dist.D(m), dist.smith_lambda(m), dist.pdf(m), dist.G1(w, m)):
        assert value.dtype == u.dtype
    if dist.supports_visible_sampling:
        mv = dist.sample_visible(w, u)
        assert mv.dtype == u.dtype
        assert np.all(np.isfinite(np.asarray(mv)))
    torch = pytest.importorskip("torch")
    alpha = torch.tensor(0.3, dtype=torch.float64, requires_grad=True)
    m_t = torch.as_tensor(np.asarray(m), dtype=torch.float64)
    w_t = torch.as_tensor(np.asarray(w), dtype=torch.float64)
    dist_t = cls(alpha)
    total = dist_t.D(m_t).sum() + dist_t.smith_lambda(w_t).sum() + dist_t.pdf(m_t).sum()
    total.backward()
    assert alpha.grad is not None and torch.isfinite(alpha.grad) and alpha.grad != 0


def _gaussian_with_order(monkeypatch, name: str, order: int) -> None:
    """Set the Gauss–Legendre order ``name`` of TorranceSparrowGaussian (for references)."""
    import brdfkit.brdf.microfacet as microfacet

    monkeypatch.setattr(microfacet, name, order)


def test_gaussian_cdf_quadrature_is_exact_to_rounding():
    """The 24-point CDF ∫_0^θ e^{-(s/m)²} sin 2s ds of the Gaussian D agrees with a 512-point
    rule to 1e-13 relative over its whole domain (m ∈ [10⁻⁴, 10], θ ∈ (0, π/2])."""
    dist = TorranceSparrowGaussian(0.3)
    m, theta = np.meshgrid(np.geomspace(1e-4, 10, 81), np.linspace(0, math.pi / 2, 121)[1:])
    m, theta = m.ravel(), theta.ravel()
    value = dist._partial_integral(m, theta)
    reference = dist._partial_integral(m, theta, 512)
    assert np.max(np.abs(value - reference) / reference) < 1e-13
    # and the reference itself against adaptive quadrature at a few points
    for mi, ti in [(1e-3, 0.5), (0.05, 0.2), (0.4, 1.0), (1.2, math.pi / 2), (10.0, 1.3)]:
        expected, _ = integrate.quad(
            lambda s, mi=mi: math.exp(-((s / mi) ** 2)) * math.sin(2 * s),
            0,
            ti,
            epsabs=0,
            epsrel=1e-13,
            points=[mi],
            limit=200,
        )
        got = dist._partial_integral(np.array([mi]), np.array([ti]))[0]
        assert got == pytest.approx(expected, rel=1e-12)


def test_gaussian_smith_lambda_quadrature_matches_reference(monkeypatch):
    """The 32-point Λ of the Gaussian D agrees with a 512-point rule: |ΔΛ|/(1+Λ) < 1e-12
    for m ∈ [10⁻⁴, 10] and θ from 0 to 10⁻⁸ below grazing (the measured maximum is 7e-14)."""
    theta = np.concatenate(
        [
            np.linspace(0, math.pi / 2, 120, endpoint=False),
            math.pi / 2 - np.geomspace(1e-8, 1e-2, 12),
        ]
    )
    w = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=-1)
    ms = np.geomspace(1e-4, 10, 25)
    value = np.array([TorranceSparrowGaussian(m).smith_lambda(w)[:, 0] for m in ms])
    _gaussian_with_order(monkeypatch, "_GAUSSIAN_LAMBDA_NODES", 512)
    reference = np.array([TorranceSparrowGaussian(m).smith_lambda(w)[:, 0] for m in ms])
    assert np.all(np.isfinite(reference)) and np.all(reference >= 0)
    assert np.max(np.abs(value - reference) / (1 + reference)) < 1e-12


def _gaussian_sampler_cdf_error(m: float, u1: np.ndarray, dtype=np.float64) -> np.ndarray:
    """|CDF(θm) − u1| of the ``dtype`` sampler, the CDF by the 512-point rule in float64."""
    dist = TorranceSparrowGaussian(dtype(m))
    u = np.stack([u1, np.full_like(u1, 0.3)], axis=-1).astype(dtype)
    wm = dist.sample(u).astype(np.float64)
    theta = np.arctan2(np.hypot(wm[..., 0], wm[..., 1]), wm[..., 2])  # accurate at small θ
    mm = np.full_like(theta, float(dtype(m)))
    total = dist._partial_integral(mm[:1], np.full(1, math.pi / 2), 512)[0]
    cdf = dist._partial_integral(mm, theta, 512) / total
    u_max = 1 - max(1e-12, float(np.finfo(dtype).eps))
    return np.abs(cdf - np.clip(u[:, 0].astype(np.float64), 0, u_max))


@pytest.mark.parametrize("m", [1e-3, 0.05, 0.3, 1.2, 10.0])
def test_gaussian_sampler_solves_the_reference_cdf(m):
    """The fixed-step Newton sampler solves the 512-point CDF to rounding for 20,000 u1."""
    u1 = np.random.default_rng(7).random(20_000)
    assert np.max(_gaussian_sampler_cdf_error(m, u1)) < 1e-13


def _gaussian_scan_u(rng: np.random.Generator) -> np.ndarray:
    """u1 for the sampler scans: uniform, and geometric towards 0 and 1 (both included)."""
    return np.concatenate(
        [
            rng.random(1000),
            1 - np.geomspace(1e-12, 0.5, 150),
            np.geomspace(1e-18, 0.5, 150),
            [0.0, 0.5, 1.0],
        ]
    )


@pytest.mark.slow
def test_gaussian_sampler_steps_reach_rounding_over_the_domain():
    """The Newton steps of _GAUSSIAN_NEWTON_STEPS reach rounding over m ∈ [10⁻⁴, 10] and
    u1 ∈ [0, 1]: |ΔCDF| < 1e-14 in float64 (measured 5.9e-15), < 4e-7 in float32 (3e-7,
    ~2.5 ulp of u1), also at u1 = 1, which the float32 sampler clamps to 1 − 2⁻²³."""
    u1 = _gaussian_scan_u(np.random.default_rng(11))
    for m in np.geomspace(1e-4, 10, 41):
        assert np.max(_gaussian_sampler_cdf_error(m, u1)) < 1e-14, m
        assert np.max(_gaussian_sampler_cdf_error(m, u1, np.float32)) < 4e-7, m


def test_gaussian_float32_sampler_near_one():
    """u1 near and at 1 in float32 (1 − 1e-12 rounds to 1 there): the CDF still matches."""
    u1 = np.array([0.999, 1 - 1e-6, np.nextafter(np.float32(1), np.float32(0)), 1.0])
    for m in (1e-3, 0.3, 1.2, 8.0):
        assert np.max(_gaussian_sampler_cdf_error(m, u1, np.float32)) < 4e-7, m


def test_gaussian_lambda_of_a_broadcast_direction_is_made_once_with_the_same_values():
    """A fixed ωo broadcast over a batch (a quadrature ring, a sampler's checks): Λ is made
    once (a stride-0 view comes back) and equals Λ of the batch written out."""
    ndf = TorranceSparrowGaussian(0.3)
    w = np.array([0.5, -0.2, 0.7])
    w = np.broadcast_to(w / np.linalg.norm(w), (257, 3))
    once = ndf.smith_lambda(w)
    assert once.shape == (257, 1) and once.strides[0] == 0
    np.testing.assert_array_equal(once, ndf.smith_lambda(np.ascontiguousarray(w)))


def test_correlated_masking_of_one_sided_pairs_equals_their_values_in_a_mixed_batch():
    """Pairs all on one side skip the Beta function (NumPy): the values of the same pairs
    where the batch also holds transmission pairs, bitwise."""
    rng = np.random.default_rng(5)
    wi, wo = rng.normal(size=(2, 400, 3))
    wi, wo = (
        wi / np.linalg.norm(wi, axis=-1, keepdims=True),
        wo / np.linalg.norm(wo, axis=-1, keepdims=True),
    )
    wo[:, 2] = np.abs(wo[:, 2])
    h = wi + wo
    h = np.where(h[:, 2:3] < 0, -h, h) / np.linalg.norm(h, axis=-1, keepdims=True)
    for dist in (GGX(0.3), Beckmann(0.2, 0.5)):
        mixed = masking_shadowing(dist, wi, wo, h, "smith_correlated")
        above = wi[:, 2] > 0
        assert 0 < np.count_nonzero(above) < len(wi)
        one_sided = masking_shadowing(dist, wi[above], wo[above], h[above], "smith_correlated")
        np.testing.assert_array_equal(one_sided, mixed[above])


def test_visible_sampling_of_a_broadcast_view_stays_per_direction_with_the_same_values():
    """One ωo below the surface broadcast over many samples: flipped once (still a stride-0
    view), and the normals and their density are bitwise those of the batch written out."""
    from brdfkit.brdf._microfacet_sampling import _upper, normal_pdf, sample_normal

    wo = np.broadcast_to(np.array([0.6, 0.0, -0.8]), (500, 3))
    up = _upper(wo)
    assert up.strides[0] == 0
    np.testing.assert_array_equal(up, np.broadcast_to([-0.6, -0.0, 0.8], (500, 3)))
    u = np.random.default_rng(8).random((500, 2))
    for ndf in (GGX(0.3, 0.1), Beckmann(0.2)):
        h = sample_normal(ndf, True, wo, u)
        np.testing.assert_array_equal(h, sample_normal(ndf, True, np.array(wo), u))
        np.testing.assert_array_equal(
            normal_pdf(ndf, True, wo, h), normal_pdf(ndf, True, np.array(wo), h)
        )
