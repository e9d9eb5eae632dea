"""Tabulated half/difference BRDFs: lookup modes, construction, sampling, backends, colour."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.measured import MeasuredSamples, TabulatedBRDF, spectrum_to_rgb_matrix
from brdfkit.sampling import square_to_uniform_hemisphere


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
