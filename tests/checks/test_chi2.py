"""The χ² goodness-of-fit test of samplers (brdfkit.checks.chi2): it passes, fails and reports."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from brdfkit.checks import (
    Chi2Result,
    assert_chi2,
    assert_chi2_planar,
    brdf_sampler,
    chi2_test,
    chi2_test_planar,
)
from brdfkit.sampling import (
    square_to_cosine_hemisphere,
    square_to_cosine_hemisphere_pdf,
    square_to_uniform_cone,
    square_to_uniform_cone_pdf,
    square_to_uniform_hemisphere,
    square_to_uniform_hemisphere_pdf,
    square_to_uniform_sphere,
    square_to_uniform_sphere_pdf,
)


def _phong_pdf(exponent: float):
    """The normalised cosine-power lobe (n + 1)/(2π) cosⁿθ on the upper hemisphere."""

    def pdf(v):
        return (exponent + 1) / (2 * math.pi) * np.clip(v[..., 2], 0, None) ** exponent

    return pdf


def test_a_correct_sampler_passes():
    result = chi2_test(square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf)
    assert isinstance(result, Chi2Result)
    assert result.passed, str(result)
    assert result.observed.shape == result.expected.shape == (10, 20)
    assert result.observed.sum() == result.n_samples == 1_000_000
    assert result.pdf_integral == pytest.approx(1.0, abs=1e-9)
    # Half the sphere has zero density and is left out: 100 cells, 99 degrees of freedom.
    assert result.dof == 99
    assert result.statistic == pytest.approx(stats.chi2.isf(result.p_value, result.dof))


def test_the_wrong_pdf_fails():
    # Uniform hemisphere samples against the cosine-weighted pdf.
    result = chi2_test(square_to_uniform_hemisphere, square_to_cosine_hemisphere_pdf)
    assert not result.passed
    assert result.p_value < 1e-12
    with pytest.raises(AssertionError, match=r"χ² test FAILED") as info:
        assert_chi2(square_to_uniform_hemisphere, square_to_cosine_hemisphere_pdf)
    message = str(info.value)
    assert "largest standardised residuals" in message and "residual map" in message
    # Grazing cells have too many samples for a cosine pdf: positive residuals in the last row of
    # the upper hemisphere (1 − cos θ in [0.8, 1)), negative ones in the first.
    assert np.all(result.residuals()[4] > 3) and np.all(result.residuals()[0] < -3)


def _sample_phong(exponent: float):
    """Directions with density (n + 1)/(2π) cosⁿθ: cos θ = u₁^(1/(n+1)), φ = 2π u₀."""

    def sample(u):
        cos_theta = u[:, 1] ** (1 / (exponent + 1))
        sin_theta = np.sqrt(1 - cos_theta**2)
        phi = 2 * math.pi * u[:, 0]
        return np.stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), cos_theta], axis=1)

    return sample


def test_sparse_cells_are_pooled():
    # A narrow lobe leaves most cells with an expectation below 5: they are pooled, and the
    # test still accepts the right pdf and rejects a slightly wrong exponent.
    options = {"n_samples": 50_000, "binning": "theta", "sphere": False}
    result = assert_chi2(_sample_phong(60.0), _phong_pdf(60.0), **options)
    assert result.pooled_in > 0 and 0 < result.pooled_out < result.pooled_in
    assert not chi2_test(_sample_phong(60.0), _phong_pdf(50.0), **options).passed


def test_a_slightly_wrong_pdf_fails():
    # cos^1.1 against cosine samples: a 10 % error in the exponent is detected with 10⁶ samples.
    result = chi2_test(square_to_cosine_hemisphere, _phong_pdf(1.1))
    assert not result.passed and result.p_value < 1e-6
    assert result.pdf_integral == pytest.approx(1.0, abs=1e-6)


def test_a_pdf_that_integrates_above_one_fails():
    result = chi2_test(
        square_to_cosine_hemisphere, lambda v: 1.02 * square_to_cosine_hemisphere_pdf(v)
    )
    assert not result.passed
    assert result.pdf_integral == pytest.approx(1.02, abs=1e-9)
    assert any("integrates to 1.02" in m for m in result.messages)


def test_p_values_are_uniform_for_a_correct_sampler():
    # Under the null hypothesis the p-value is uniform on [0, 1]: the test is neither
    # conservative nor liberal.
    p_values = [
        chi2_test(
            square_to_uniform_sphere,
            square_to_uniform_sphere_pdf,
            n_samples=20_000,
            theta_bins=6,
            phi_bins=12,
            seed=seed,
        ).p_value
        for seed in range(40)
    ]
    assert stats.kstest(p_values, "uniform").pvalue > 1e-3


def test_invalid_samples_are_accounted_for():
    # Uniform sphere samples of which those below the surface are invalid: the density of the
    # valid ones is 1/(4π) on the upper hemisphere and integrates to the valid fraction 1/2.
    def sample(u):
        v = square_to_uniform_sphere(u)
        valid = v[:, 2] > 0
        return np.where(valid[:, None], v, 0.0), valid  # failed samples hold zero vectors

    def half(v):
        return 0.5 * square_to_uniform_hemisphere_pdf(v)

    result = assert_chi2(sample, half)
    assert result.pdf_integral == pytest.approx(0.5, abs=1e-9)
    assert result.outside_expected == pytest.approx(result.n_samples / 2, rel=1e-6)
    assert abs(result.outside_observed - result.n_samples / 2) < 5 * math.sqrt(result.n_samples)
    # Claiming the valid samples have density 1/(2π) (integral 1) contradicts the failures.
    assert not chi2_test(sample, square_to_uniform_hemisphere_pdf).passed

    # A sampler that fails 40 % of the time where its pdf says 50 % is rejected.
    def sample_too_often_valid(u):
        v = square_to_uniform_sphere(u)
        return v, (v[:, 2] > 0) | (v[:, 2] < -0.8)

    def pdf_too_often_valid(v):
        return np.where(np.abs(v[:, 2] + 0.9) <= 0.1, 1 / (4 * math.pi), half(v))

    assert assert_chi2(sample_too_often_valid, pdf_too_often_valid).passed
    assert not chi2_test(sample_too_often_valid, half).passed


def test_samples_where_the_pdf_is_zero_fail():
    # Uniform sphere samples, all valid, against the hemisphere pdf (0 below the surface).
    result = chi2_test(square_to_uniform_sphere, square_to_uniform_hemisphere_pdf)
    assert not result.passed
    assert any("where the pdf is 0 (in cells of zero density)" in m for m in result.messages)
    # On the hemisphere-only histogram, those samples fall outside the domain.
    result = chi2_test(square_to_uniform_sphere, square_to_uniform_hemisphere_pdf, sphere=False)
    assert not result.passed
    assert any("outside the domain or invalid" in m for m in result.messages)


def test_hemisphere_histogram_and_theta_binning():
    result = assert_chi2(
        square_to_cosine_hemisphere,
        square_to_cosine_hemisphere_pdf,
        sphere=False,
        binning="theta",
        theta_bins=12,
        phi_bins=8,
    )
    assert result.dof == 12 * 8 - 1
    np.testing.assert_allclose(result.edges[0], np.linspace(0, math.pi / 2, 13))
    # Row i holds ∫ cosθ sinθ dθ dφ / π over its band: sin²θ differences over the φ cells.
    sin2 = np.sin(result.edges[0]) ** 2
    np.testing.assert_allclose(
        result.expected.sum(axis=1), result.n_samples * np.diff(sin2), rtol=1e-9
    )


def test_discontinuous_pdf_is_integrated_within_the_reported_error():
    cos_cutoff = 0.37  # not on a cell edge, nor on a sub-cell edge
    result = assert_chi2(
        lambda u: square_to_uniform_cone(u, cos_cutoff),
        lambda v: square_to_uniform_cone_pdf(v, cos_cutoff),
    )
    assert abs(result.pdf_integral - 1) <= result.quadrature_error
    assert result.quadrature_error < 1e-3


def test_non_unit_or_non_finite_samples_fail():
    result = chi2_test(lambda u: 1.01 * square_to_uniform_sphere(u), square_to_uniform_sphere_pdf)
    assert not result.passed
    assert any("not unit vectors" in m for m in result.messages)

    def with_nan(u):
        v = square_to_uniform_sphere(u)
        v[0] = np.nan
        return v

    result = chi2_test(with_nan, square_to_uniform_sphere_pdf, n_samples=10_000)
    assert not result.passed
    assert any("1 valid samples are not finite" in m for m in result.messages)


def test_sidak_correction():
    result = chi2_test(
        square_to_uniform_sphere, square_to_uniform_sphere_pdf, significance=0.05, test_count=10
    )
    assert result.threshold == pytest.approx(1 - 0.95 ** (1 / 10), rel=1e-14)


def test_conditioned_sampler_by_closure_and_three_uniforms():
    # A two-lobe mixture chosen by the third uniform, the lobe's axis set by a closure: a cone
    # around +z with probability 0.3, else the cosine lobe.
    weight, cos_cutoff = 0.3, 0.8

    def sample(u):
        cone = square_to_uniform_cone(u[:, :2], cos_cutoff)
        return np.where(u[:, 2:] < weight, cone, square_to_cosine_hemisphere(u[:, :2]))

    def pdf(v):
        return weight * square_to_uniform_cone_pdf(v, cos_cutoff) + (
            1 - weight
        ) * square_to_cosine_hemisphere_pdf(v)

    assert_chi2(sample, pdf, sample_dim=3, binning="theta")


def test_torch_samplers_through_convert():
    torch = pytest.importorskip("torch")
    seen = []

    def sample(u):
        seen.append(u.dtype)
        return square_to_cosine_hemisphere(u)

    result = assert_chi2(
        sample,
        square_to_cosine_hemisphere_pdf,
        n_samples=200_000,
        convert=lambda a: torch.tensor(a, dtype=torch.float32),
    )
    assert seen == [torch.float32]
    assert result.pdf_integral == pytest.approx(1.0, abs=1e-6)


def test_planar_test_passes_and_fails():
    def uniform(u):
        return u

    def unit_square(p):
        return np.ones(p.shape[0])

    result = assert_chi2_planar(uniform, unit_square, bins=(8, 5))
    assert result.observed.shape == (8, 5) and result.axes == ("x", "y")

    def tent(p):
        return 4 * p[:, 0] * p[:, 1]

    assert not chi2_test_planar(uniform, tent, bins=(8, 5)).passed
    # Points sampled on [0, 1]² against a density on [0, 2]² with zero mass outside the square.
    assert_chi2_planar(
        uniform, lambda p: np.where(np.all(p <= 1, axis=1), 1.0, 0.0), bounds=((0, 2), (0, 2))
    )


def test_bad_arguments_are_rejected():
    args = (square_to_uniform_sphere, square_to_uniform_sphere_pdf)
    with pytest.raises(ValueError, match=r"significance must be in \(0\.0, 1\.0\); got 0"):
        chi2_test(*args, significance=0)
    with pytest.raises(ValueError, match=r"theta_bins must be a positive integer; got 0"):
        chi2_test(*args, theta_bins=0)
    with pytest.raises(ValueError, match=r"binning must be 'cos' or 'theta'; got 'phi'"):
        chi2_test(*args, binning="phi")
    with pytest.raises(ValueError, match=r"order must be an integer ≥ 3; got 2"):
        chi2_test(*args, order=2)
    with pytest.raises(ValueError, match=r"n_samples must be a positive integer"):
        chi2_test(*args, n_samples=0)
    with pytest.raises(ValueError, match=r"last axis of length 3"):
        chi2_test(lambda u: u, square_to_uniform_sphere_pdf, n_samples=100)
    with pytest.raises(ValueError, match=r"bounds must be"):
        chi2_test_planar(lambda u: u, lambda p: p[:, 0], bounds=((1, 0), (0, 1)))


def test_brdf_sampler_adapts_a_brdf_to_chi2_and_records_samples():
    from brdfkit.brdf import Lambertian, SmoothDielectric

    wo = np.array([0.6, 0.0, 0.8])
    drawn = []
    sample_fn, pdf_fn = brdf_sampler(Lambertian(0.5), wo, record=drawn)
    assert_chi2(sample_fn, pdf_fn, n_samples=50_000)
    assert len(drawn) == 1 and drawn[0].wi.shape == (50_000, 3)
    wi = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    np.testing.assert_allclose(pdf_fn(wi), [1 / np.pi, 0.0])
    # Delta-lobe samples are not valid for the histogram, whatever their pdf field says.
    _, valid = brdf_sampler(SmoothDielectric(1.5), wo)[0](np.full((4, 3), 0.3))
    assert not np.any(valid)
