"""Radial importance sampling and the axis-projection probes (pbrt-v3's Sample_Sp/Pdf_Sp)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from brdfkit.bssrdf import BetterDipole, Medium, NormalizedDiffusion, RadialSampler
from brdfkit.bssrdf.profile_sampling import AXIS_PROBABILITIES, COVERED


@pytest.mark.parametrize("model", [BetterDipole, NormalizedDiffusion])
def test_sampled_radii_follow_the_pdf(model):
    """A χ² test of the sampled radii against the sampler's own pdf, integrated over bins."""
    sampler = model(Medium(0.9, eta=1.33)).sampler()
    u = np.random.default_rng(4).random((40_000, 2))
    radii = sampler.sample(u)
    edges = np.array([sampler.quantile(q) for q in np.linspace(0, 0.99, 21)] + [np.inf])
    observed = np.histogram(radii, edges)[0]
    fine = np.linspace(0, edges[-2], 200_001)
    cdf = np.concatenate([[0.0], np.cumsum(sampler.pdf(fine[:-1]) * np.diff(fine))])
    expected_cdf = np.interp(edges[:-1], fine, cdf)
    expected = np.diff(np.concatenate([expected_cdf, [1.0]])) * len(radii)
    assert stats.chisquare(observed, expected).pvalue > 1e-3


def test_the_pdf_is_the_normalized_radial_density():
    r = np.linspace(0, 40, 4001)
    sampler = RadialSampler(r, r * np.exp(-r))  # a Gamma(2) density
    assert np.trapezoid(sampler.pdf(r[:-1] + 0.005), r[:-1] + 0.005) == pytest.approx(1, rel=1e-3)
    assert sampler.pdf(np.array([-1.0, 41.0])).tolist() == [0.0, 0.0]
    assert sampler.quantile(0.5) == pytest.approx(1.678, abs=2e-3)  # Gamma(2)'s median


def test_probes_project_along_the_chosen_axes():
    sampler = BetterDipole(Medium(0.8, eta=1.33)).sampler()
    probes = sampler.sample_probe(np.random.default_rng(5).random((20_000, 3)))
    axes = np.argmax(np.abs(probes.axis), axis=-1)
    np.testing.assert_allclose(np.bincount(axes) / len(axes), AXIS_PROBABILITIES, atol=0.01)
    # every probe passes the sampled radius away from the axis through x_o
    across = probes.origin - np.sum(probes.origin * probes.axis, -1, keepdims=True) * probes.axis
    np.testing.assert_allclose(np.linalg.norm(across, axis=-1), probes.radius, atol=1e-12)
    r_max = sampler.quantile(COVERED)
    inside = probes.radius < r_max
    np.testing.assert_allclose(
        probes.length[inside], 2 * np.sqrt(r_max**2 - probes.radius[inside] ** 2)
    )


def test_probe_pdf_on_a_plane_is_half_the_radial_area_density():
    """On the plane z = 0 only the normal's probes hit, half of all: the points found have
    area density ½ p_r(r)/(2πr); the fraction of probes hitting an annulus matches it."""
    sampler = NormalizedDiffusion(Medium(0.95, eta=1.33), surface_albedo=0.7).sampler()
    probes = sampler.sample_probe(np.random.default_rng(6).random((100_000, 3)))
    hits = (probes.axis[:, 2] == 1) & (probes.length > 0)
    points = probes.origin[hits] + 0.5 * probes.length[hits, None] * probes.axis[hits]
    assert np.allclose(points[:, 2], 0.0, atol=1e-9)
    a, b = sampler.quantile(0.2), sampler.quantile(0.6)
    r = np.linalg.norm(points[:, :2], axis=-1)
    fraction = np.mean((r >= a) & (r < b)) * hits.mean()
    grid = np.linspace(a, b, 2001)
    offsets = np.stack([grid, np.zeros_like(grid), np.zeros_like(grid)], -1)
    density = sampler.probe_pdf(offsets, np.array([0.0, 0.0, 1.0]))
    predicted = np.trapezoid(density * 2 * np.pi * grid, grid)
    assert fraction == pytest.approx(predicted, rel=0.03)
    assert predicted == pytest.approx(0.5 * 0.4, rel=0.01)
