"""Tabulated half/difference BRDFs: lookup modes, construction, sampling, backends, colour."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.checks import brdf_sampler, chi2_test
from brdfkit.errors import ParameterError
from brdfkit.geometry import spherical_to_cartesian
from brdfkit.measured import MeasuredSamples, TabulatedBRDF, read_cornell, spectrum_to_rgb_matrix
from brdfkit.measured.tabulated import (
    MAX_HALF_VECTOR_PROBABILITY,
    HalfVectorSampling,
    wavelengths_problem,
    white_sky_weights,
)
from brdfkit.sampling import square_to_cosine_hemisphere, square_to_uniform_hemisphere

GLOSSY = "lambertian(rho=0.2) + ggx(alpha=0.1)"
"""A glossy analytic model to tabulate: a sharp highlight over a diffuse floor."""


def _directions(n: int, seed: int) -> np.ndarray:
    return square_to_uniform_hemisphere(np.random.default_rng(seed).random((n, 2)))


@pytest.mark.parametrize("interpolation", ["bin", "nearest", "linear"])
def test_lambertian_table_is_constant(interpolation):
    table = TabulatedBRDF.from_brdf(
        parse("lambertian(rho=[0.8, 0.5, 0.2])"), (16, 16, 32), interpolation=interpolation
    )
    wi, wo = _directions(500, 1), _directions(500, 2)
    if interpolation != "linear":  # a lone node near the horizon may be unmeasured
        keep = (wi[:, 2] > 0.3) & (wo[:, 2] > 0.3)
        wi, wo = wi[keep], wo[keep]
    expected = np.broadcast_to([0.8, 0.5, 0.2], wi.shape) / math.pi
    np.testing.assert_allclose(table.eval(wi, wo), expected, rtol=1e-12)
    np.testing.assert_array_equal(table.eval(wi * [1, 1, -1], wo), 0.0)


def test_anisotropic_table_reproduces_its_nodes_and_is_anisotropic():
    model = parse("ward(kd=0.1, ks=0.2, alpha_x=0.1, alpha_y=0.3)")
    table = TabulatedBRDF.from_brdf(model, (16, 24, 16, 32), interpolation="nearest")
    assert not table.isotropic and table.shape == (16, 24, 16, 32)
    wi, wo = table.node_directions()
    inner = (slice(1, None), slice(None), slice(1, None), slice(None))
    wi, wo = wi[inner].reshape(-1, 3), wo[inner].reshape(-1, 3)
    ok = (wi[:, 2] > 1e-3) & (wo[:, 2] > 1e-3)
    np.testing.assert_allclose(table.eval(wi[ok], wo[ok]), model.eval(wi[ok], wo[ok]), rtol=1e-9)
    # rotating both directions by 90° about the normal changes an anisotropic lobe
    turn = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])
    a, b = _directions(300, 3), _directions(300, 4)
    assert not np.allclose(table.eval(a, b), table.eval(a @ turn.T, b @ turn.T))


def test_linear_lookup_is_a_convex_combination_and_exact_on_linear_data():
    # values linear in the continuous node index of θd: multilinear lookup is exact there
    shape = (8, 10, 12)
    td = np.arange(shape[1], dtype=float)
    values = np.broadcast_to(td[None, :, None, None], (*shape, 1)).copy()
    table = TabulatedBRDF(values, interpolation="linear")
    theta_d = np.linspace(0.05, 1.3, 40)  # within the nodes (θd < 9 · π/20)
    from brdfkit.geometry import from_half_diff

    wi, wo = from_half_diff(np.full(40, 0.2), np.zeros(40), theta_d, np.full(40, 0.3))
    ok = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    expected = theta_d / (math.pi / 2) * shape[1]
    np.testing.assert_allclose(table.eval(wi[ok], wo[ok])[:, 0], expected[ok], rtol=1e-9)


def test_cosine_sampling_weight_and_albedo():
    table = TabulatedBRDF.from_brdf(parse("lambertian(rho=0.6)"), (8, 8, 16))
    assert table.half_vector_sampling.probability == 0  # no highlight: the cosine alone
    wo = np.broadcast_to(np.array([0.3, 0.1, 0.9]) / np.linalg.norm([0.3, 0.1, 0.9]), (200, 3))
    s = table.sample(wo, np.random.default_rng(0).random((200, 2)))
    f = table.eval(s.wi, wo)
    np.testing.assert_allclose(s.weight, f * s.wi[:, 2:3] / s.pdf[:, None])
    np.testing.assert_allclose(table.pdf(s.wi, wo), s.pdf)
    np.testing.assert_allclose(table.albedo(wo[:1]), [[0.6]], rtol=1e-12)


@pytest.mark.slow
def test_from_samples_reconstructs_a_smooth_brdf():
    model = parse("lambertian(rho=0.3) + ward(kd=0, ks=0.2, alpha_x=0.5)")
    wi, wo = _directions(4000, 5), _directions(4000, 6)
    samples = MeasuredSamples(wi, wo, model.eval(wi, wo), name="smooth")
    table = TabulatedBRDF.from_samples(samples, (16, 16, 16))
    a, b = _directions(2000, 7), _directions(2000, 8)
    f = model.eval(a, b)
    rel = np.sqrt(np.mean((table.eval(a, b) - f) ** 2)) / np.sqrt(np.mean(f**2))
    nearest = TabulatedBRDF.from_samples(samples, (16, 16, 16), method="nearest")
    rel_nearest = np.sqrt(np.mean((nearest.eval(a, b) - f) ** 2)) / np.sqrt(np.mean(f**2))
    assert rel < rel_nearest  # linear scattered interpolation beats nearest neighbours
    assert table.samples is samples


def _wo(theta: float) -> np.ndarray:
    return spherical_to_cartesian(np.array(theta), np.array(0.7))


def _glossy_tables() -> list[TabulatedBRDF]:
    model = parse(GLOSSY)
    ward = parse("lambertian(rho=0.1) + ward(kd=0, ks=0.3, alpha_x=0.08, alpha_y=0.25)")
    return [
        TabulatedBRDF.from_brdf(model, (32, 16, 32)),
        TabulatedBRDF.from_brdf(model, (24, 16, 32), interpolation="bin"),
        TabulatedBRDF.from_brdf(ward, (16, 16, 12, 24), interpolation="nearest"),
    ]


@pytest.mark.parametrize("table", _glossy_tables(), ids=["linear", "bin", "anisotropic"])
def test_half_vector_sampler_matches_its_density(table):
    """χ² of the half vectors alone against p(h) (piecewise constant over the θh × φh cells)."""
    half = table.half_vector_sampling
    result = chi2_test(
        half.sample, half.pdf, sphere=False, binning="theta", n_samples=100_000, max_depth=6
    )
    result.assert_passed()
    n_theta, n_phi = half.density.shape
    edges = (np.arange(n_theta + 1) / n_theta) ** 2 * (math.pi / 2)
    solid_angle = -np.diff(np.cos(edges))[:, None] * (2 * math.pi / n_phi)
    assert np.sum(half.density * solid_angle) == pytest.approx(1.0, rel=1e-12)


def _check_sampler(table: TabulatedBRDF, thetas: tuple[float, ...]) -> None:
    """χ² of sample() against pdf() at each θo, and weight = f·cos θi/pdf for every draw."""
    for theta in thetas:
        wo = _wo(theta)
        drawn = []
        sample_fn, pdf_fn = brdf_sampler(table, wo, record=drawn)
        result = chi2_test(
            sample_fn,
            pdf_fn,
            sphere=False,
            binning="theta",
            n_samples=100_000,
            sample_dim=3,
            test_count=len(thetas),
            max_depth=6,
        )
        result.assert_passed()
        s = drawn[0]
        ok = s.pdf > 0
        assert 0.5 < np.mean(ok) <= 1  # reflections below the horizon fail
        wo_b = np.broadcast_to(wo, s.wi.shape)
        np.testing.assert_allclose(s.pdf, table.pdf(s.wi, wo_b), rtol=1e-12)
        expected = table.eval(s.wi[ok], wo_b[ok]) * (s.wi[ok, 2] / s.pdf[ok])[:, None]
        np.testing.assert_allclose(s.weight[ok], expected, rtol=1e-12)
        np.testing.assert_array_equal(s.weight[~ok], 0.0)


@pytest.mark.slow
@pytest.mark.parametrize("table", _glossy_tables(), ids=["linear", "bin", "anisotropic"])
def test_mixture_sampling_passes_chi2_and_weights_are_consistent(table):
    assert 0.3 < table.half_vector_sampling.probability <= MAX_HALF_VECTOR_PROBABILITY
    _check_sampler(table, (0.0, 0.8, 1.3))


@pytest.mark.slow
@pytest.mark.data
def test_cornell_table_sampling_passes_chi2(shared_data):
    table = read_cornell(shared_data / "measured" / "cornell" / "acryl_blue.brdf")
    _check_sampler(table, (0.4, 0.8, 1.2))


def test_half_vector_sampling_lowers_the_albedo_variance():
    """Directional albedo at θo = 45° of a glossy table: per-sample variance of the estimator
    with the mixture against cosine sampling (weight π f) from the same uniforms."""
    table = TabulatedBRDF.from_brdf(parse(GLOSSY), (32, 16, 32))
    n = 20_000
    u = np.random.default_rng(11).random((n, 2))
    wo = np.broadcast_to(_wo(math.pi / 4), (n, 3))
    mixture = table.sample(wo, u).weight.mean(axis=-1)
    wi = square_to_cosine_hemisphere(u)
    cosine = math.pi * table.eval(wi, wo).mean(axis=-1)
    # the same albedo (to 4 combined standard errors) ...
    tolerance = 4 * math.sqrt((mixture.var() + cosine.var()) / n)
    assert abs(mixture.mean() - cosine.mean()) < tolerance
    # ... with far less variance (measured: about 100 times less)
    assert cosine.var() > 20 * mixture.var()


def test_mixture_probability_follows_the_highlight():
    """No highlight: 0; a sharp highlight without floor: the cap; in between: the share of the
    white-sky albedo above the floor, growing with the highlight's weight."""
    shape = (32, 16, 32)

    def probability(spec: str) -> float:
        return TabulatedBRDF.from_brdf(parse(spec), shape).half_vector_sampling.probability

    assert probability("lambertian(rho=0.5)") == 0
    assert probability("ggx(alpha=0.05)") == MAX_HALF_VECTOR_PROBABILITY
    weak = probability("lambertian(rho=0.7) + 0.05*ggx(alpha=0.1)")
    strong = probability("lambertian(rho=0.3) + 0.3*ggx(alpha=0.1)")
    assert 0 < weak < 0.2 < strong < MAX_HALF_VECTOR_PROBABILITY


@pytest.mark.parametrize("shape", [(8, 8, 16), (32, 32, 32), (8, 6, 8, 16)])
def test_white_sky_weights_sum_to_pi(shape):
    """A constant table c has white-sky albedo π c."""
    table = TabulatedBRDF(np.ones((*shape, 1)))
    total = np.sum(np.broadcast_to(white_sky_weights(table), shape))
    assert total == pytest.approx(math.pi, rel=2e-3)


def test_half_vector_sampling_is_built_once_and_a_zero_table_samples_the_cosine():
    table = TabulatedBRDF.from_brdf(parse(GLOSSY), (8, 8, 16))
    assert table.half_vector_sampling is table.half_vector_sampling
    zero = TabulatedBRDF(np.zeros((4, 4, 4, 1)))
    assert zero.half_vector_sampling.probability == 0
    with pytest.raises(ValueError, match="zero everywhere"):
        HalfVectorSampling(zero).sample(np.full((1, 2), 0.5))
    wo = np.broadcast_to(_wo(0.5), (10, 3))
    s = zero.sample(wo, np.random.default_rng(0).random((10, 3)))
    np.testing.assert_allclose(s.pdf, s.wi[:, 2] / math.pi)
    np.testing.assert_array_equal(s.weight, 0.0)


def test_sampling_backends_agree(backend):
    table = TabulatedBRDF.from_brdf(parse(GLOSSY), (16, 16, 32))
    wo, u = _directions(200, 12), np.random.default_rng(13).random((200, 3))
    s, reference = table.sample(backend(wo), backend(u)), table.sample(wo, u)
    assert s.wi.dtype == s.weight.dtype == s.pdf.dtype == backend(wo).dtype
    single = s.wi.dtype == np.float32
    np.testing.assert_allclose(np.asarray(s.wi), reference.wi, atol=1e-5 if single else 1e-12)
    pdf = table.pdf(s.wi, backend(wo))
    np.testing.assert_allclose(np.asarray(s.pdf), np.asarray(pdf), rtol=1e-6 if single else 1e-12)
    if not single:
        np.testing.assert_allclose(np.asarray(s.pdf), reference.pdf, rtol=1e-12)
        np.testing.assert_allclose(np.asarray(s.weight), reference.weight, rtol=1e-12)


def test_backends_agree(backend):
    table = TabulatedBRDF.from_brdf(parse("ward(kd=0.2, ks=0.3, alpha_x=0.2)"), (16, 16, 32))
    wi, wo = _directions(100, 9), _directions(100, 10)
    value = table.eval(backend(wi), backend(wo))
    assert value.dtype == backend(wi).dtype
    rtol = 1e-5 if value.dtype == np.float32 else 1e-12
    np.testing.assert_allclose(np.asarray(value), table.eval(wi, wo), rtol=rtol, atol=1e-6)


def test_spectrum_to_rgb_white_and_bad_input():
    wl = np.arange(400, 701, 10.0)
    white = np.ones(wl.size) @ spectrum_to_rgb_matrix(wl)
    np.testing.assert_allclose(white, 1.0, atol=1e-3)
    with pytest.raises(ValueError, match="wavelengths"):
        spectrum_to_rgb_matrix([500.0])
    with pytest.raises(ValueError, match="wavelengths"):
        spectrum_to_rgb_matrix([700.0, 400.0])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"values": np.zeros((3, 3))}, "values must have shape"),
        ({"values": np.zeros((2, 2, 2, 3)), "scale": [1, 2]}, "scale"),
        ({"values": np.zeros((2, 2, 2, 1)), "interpolation": "cubic"}, "interpolation"),
    ],
)
def test_bad_tables(kwargs, message):
    with pytest.raises(ValueError, match=message):
        TabulatedBRDF(**kwargs)


def test_a_table_has_no_spec():
    with pytest.raises(ValueError, match="no spec string"):
        TabulatedBRDF(np.zeros((2, 2, 2, 1))).to_spec()


@pytest.mark.parametrize(
    ("wavelengths", "message"),
    [
        (np.arange(400, 451, 10.0)[:5], "at least 6 within"),  # colour-science: AssertionError
        (np.linspace(400, 402.5, 6), "whole nanometres"),  # colour-science: broadcast error
        (np.arange(300, 356, 10.0), "at least 6 within"),  # all outside the observer
        ([400, 410, np.nan, 430, 440, 450], "finite"),
        ([], "increasing"),
    ],
)
def test_unconvertible_wavelengths_raise_parameter_error(wavelengths, message):
    assert message in wavelengths_problem(wavelengths)
    with pytest.raises(ParameterError, match=message):
        spectrum_to_rgb_matrix(wavelengths)


@pytest.mark.parametrize(
    "wavelengths", [np.arange(400, 451, 10.0), [350, 400, 450, 500, 600, 700, 800, 900]]
)
def test_convertible_wavelengths(wavelengths):
    assert wavelengths_problem(wavelengths) == ""
    assert np.all(np.isfinite(spectrum_to_rgb_matrix(wavelengths)))


def test_clamped_counts_negative_values():
    values = np.ones((4, 4, 4, 3))
    values[0, 0, 0] = -1.0
    values[1, 2, 3, 1] = -0.5
    assert TabulatedBRDF(values).clamped == 4
    assert TabulatedBRDF(np.ones((4, 4, 4, 3))).clamped == 0


def test_samples_spanning_no_volume_resample_by_nearest():
    theta = np.linspace(0.1, 1.2, 10)
    wi = spherical_to_cartesian(theta, np.zeros_like(theta))
    samples = MeasuredSamples(wi, wi, theta[:, None])  # θd = 0 for all: a flat point set
    table = TabulatedBRDF.from_samples(samples, (8, 8, 8))
    nearest = TabulatedBRDF.from_samples(samples, (8, 8, 8), method="nearest")
    np.testing.assert_array_equal(table.values, nearest.values)
