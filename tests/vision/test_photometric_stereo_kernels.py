"""The compiled per-pixel kernels of the iterative photometric-stereo methods against their
readable NumPy versions (:mod:`brdfkit.vision.bivariate_reference`,
:mod:`brdfkit.vision.photometric_stereo_reference`): the same residuals, reflectance weights,
Levenberg–Marquardt normals, ADMM and consensus hill climbing, to rounding, on small cases."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.vision import (
    bivariate_reference,
    bivariate_stereo,
    consensus,
    datasets,
    photometric_stereo,
)
from brdfkit.vision import photometric_stereo_reference as reference_ps


@pytest.fixture(scope="module")
def glossy():
    """A 24-pixel glossy sphere under 96 DiLiGenT-like lights, and its shadow weights."""
    normals, mask = photometric_stereo.sphere_normals((24, 24), (11.5, 11.5), 11.0)
    lights = datasets.diligent_like_lights()
    data = datasets.render_synthetic(
        normals, mask, lights, albedo=[0.6, 0.4, 0.3], specular=1.0, shininess=30.0,
        noise=0.002, rng=np.random.default_rng(1),
    )  # fmt: skip
    gray = data.images.mean(axis=3)[:, mask]  # (N, P)
    lit, starts = bivariate_stereo._start(gray, data.light_directions, 0.05)
    return gray, data.light_directions, lit, starts


def _bases():
    table = bivariate_stereo._Table(12, 4)
    theta_h = (np.linspace(0.0, 1.0, 12) ** 2) * (np.pi / 2)
    table.values = np.repeat(np.exp(-((theta_h / np.radians(10.0)) ** 2)), 4)
    return {
        "bipolynomial": (bivariate_stereo._bipolynomial_basis(3, 1), False),
        "ramps": (
            bivariate_stereo._sum_of_lobes_basis(
                np.linspace(0.0, 1.0, 8), np.cos(np.linspace(np.pi / 2, 0.0, 8))
            ),
            True,
        ),
        "table": (bivariate_stereo._shared_basis(table), True),
    }


@pytest.mark.parametrize("name", ["bipolynomial", "ramps", "table"])
def test_residuals_and_weights_match_numpy(glossy, name):
    gray, lights, lit, starts = glossy
    basis, nonnegative = _bases()[name]
    rng = np.random.default_rng(2)
    normals = starts[0] + 0.1 * rng.standard_normal(starts[0].shape)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    residual, weights = bivariate_stereo._residuals(
        normals, gray.T, lit, lights, basis, nonnegative
    )
    ref_residual, ref_weights = bivariate_reference.residuals(
        normals, gray.T, lit, lights, basis, nonnegative
    )
    scale = np.abs(gray).max()
    np.testing.assert_allclose(residual, ref_residual, atol=1e-9 * scale)
    np.testing.assert_allclose(weights, ref_weights, atol=1e-7 * np.abs(ref_weights).max())
    if nonnegative:
        assert weights.min() >= 0 and (weights == 0).any()  # the constraint is active somewhere


@pytest.mark.parametrize("name", ["bipolynomial", "ramps", "table"])
def test_levenberg_marquardt_matches_numpy(glossy, name):
    gray, lights, lit, starts = glossy
    basis, nonnegative = _bases()[name]
    kwargs = {"nonnegative": nonnegative, "iterations": 6}
    normals, weights = bivariate_stereo._refine_normals(
        starts[0], gray.T, lit, lights, basis, **kwargs
    )
    # the weights returned are those of the normals returned: a refit's where the fits start
    # cold (warm-started ramps may settle on other weights of the same residual)
    _, refit, _ = bivariate_stereo._fit(normals, gray.T, lit, lights, basis, nonnegative)
    if not bivariate_stereo._kernel_inputs(lights, basis)[-1]:
        np.testing.assert_allclose(weights, refit, atol=1e-9 * np.abs(refit).max())
    # the step of the reference's central differences: the bi-polynomial's residual is smooth
    # but goes through a Gram of condition ~1e9 (rounding dominates below ~1e-4); the ramps'
    # and the table's are piecewise linear in the normal (a step of 1e-4 crosses their kinks)
    epsilon = 1e-4 if name == "bipolynomial" else 1e-6
    reference = bivariate_reference.refine_normals(
        starts[0], gray.T, lit, lights, basis, nonnegative, 6, epsilon
    )
    angle = np.degrees(np.arccos(np.clip(np.sum(normals * reference, axis=1), -1, 1)))
    moved = np.degrees(np.arccos(np.clip(np.sum(starts[0] * reference, axis=1), -1, 1)))
    assert moved.max() > 1.0  # the search did move the normals
    # A numerical Jacobian of a variable projection through a Gram of condition ~1e9 (the
    # bi-polynomial's powers of cos θ_h are nearly collinear) turns rounding-order differences
    # into ~1e-4° per iteration; NumPy's own result moves as much with the BLAS summation order.
    assert np.median(angle) < 1e-3 and angle.max() < 0.05, (np.median(angle), angle.max())


def test_sparse_regression_matches_numpy(glossy):
    gray, lights, _, _ = glossy
    steps = []
    image = np.zeros((len(gray), 1, gray.shape[1]))
    image[:, 0] = gray
    result = photometric_stereo.sparse_regression(
        image, lights, callback=lambda done, total: steps.append(done)
    )
    b, iterations = reference_ps.sparse_regression(gray, lights)
    assert len(steps) == iterations and steps == list(range(1, iterations + 1))
    normals = (b / np.linalg.norm(b, axis=0)).T
    np.testing.assert_allclose(result.normals[0], normals, atol=1e-8)


def test_consensus_rings_match_numpy(glossy):
    gray, lights, _, _ = glossy
    intensities = gray.T
    lit = (intensities > 0.05 * bivariate_stereo._reference(intensities)[:, None]).astype(float)
    ranks = consensus._ranks(intensities)
    normals, order = consensus._global_search(ranks, lit, lights, consensus._hemisphere(200))
    reference, cost = reference_ps.consensus_rings(
        normals.copy(), ranks, lit, lights, consensus._RINGS
    )
    from brdfkit.vision import _photometric_stereo_kernels

    found = np.empty(len(normals))
    _photometric_stereo_kernels.consensus_rings(
        normals, found, order, ranks, lit, lights, np.empty(0), True
    )
    np.testing.assert_allclose(
        found, reference_ps.consensus_cost(normals, ranks, lit, lights), atol=1e-12
    )
    _photometric_stereo_kernels.consensus_rings(
        normals, found, order, ranks, lit, lights, consensus._RINGS, False
    )
    assert np.abs(normals - reference).max() < 1e-9
    np.testing.assert_allclose(found, cost, atol=1e-12)  # the kept costs are the normals'


def test_consensus_global_search_matches_numpy(glossy):
    gray, lights, _, _ = glossy
    intensities = gray.T
    lit = (intensities > 0.05 * bivariate_stereo._reference(intensities)[:, None]).astype(float)
    lit[:40] = 1.0  # all lit: the kernel sums over the (empty) unlit list
    lit[40:60, : len(lights) // 2 + 10] = 0.0  # mostly unlit: it sums over the lit list
    ranks = consensus._ranks(intensities)
    candidates = consensus._hemisphere(300)
    found, order = consensus._global_search(ranks, lit, lights, candidates)
    cosines = np.take_along_axis(found @ lights.T, order, axis=1)
    assert np.all(np.diff(cosines, axis=1) >= 0)  # each pixel's lights sorted by cosine
    reference = reference_ps.consensus_global_search(ranks, lit, lights, candidates)
    np.testing.assert_array_equal(found, reference)  # integer sums: the same choice exactly
    assert len(np.unique(found, axis=0)) > 50  # the pixels did choose different candidates


@pytest.mark.parametrize("max_iterations", [5, pytest.param(200, marks=pytest.mark.slow)])
def test_robust_pca_matches_numpy(glossy, max_iterations):
    gray, lights, _, _ = glossy
    image = gray[:, None, :]
    steps = []
    result = photometric_stereo.robust_pca(
        image, lights, max_iterations=max_iterations, callback=lambda d, t: steps.append(d)
    )
    lam = 1.0 / np.sqrt(max(gray.shape))
    b, iterations = reference_ps.robust_pca(gray, lights, lam, max_iterations=max_iterations)
    assert len(steps) == iterations
    if max_iterations == 200:
        assert iterations < 200  # converged, not cut off
    normals = (b / np.linalg.norm(b, axis=0)).T
    np.testing.assert_allclose(result.normals[0], normals, atol=1e-8)


@pytest.mark.slow  # compiles the double-precision specialisation of the kernel
def test_consensus_global_search_many_lights_matches_numpy():
    """Above 256 lights a rank product can pass 2^24: the search multiplies in double."""
    rng = np.random.default_rng(3)
    lights = rng.standard_normal((300, 3))
    lights[:, 2] = np.abs(lights[:, 2]) + 0.2
    lights /= np.linalg.norm(lights, axis=1, keepdims=True)
    normals = rng.standard_normal((40, 3))
    normals[:, 2] = np.abs(normals[:, 2]) + 0.5
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    intensities = np.clip(normals @ lights.T, 0.0, None) ** 2 + 1e-3 * rng.random((40, 300))
    lit = (intensities > 0.05).astype(float)
    ranks = consensus._ranks(intensities)
    candidates = consensus._hemisphere(100)
    found, _ = consensus._global_search(ranks, lit, lights, candidates)
    np.testing.assert_array_equal(
        found, reference_ps.consensus_global_search(ranks, lit, lights, candidates)
    )
