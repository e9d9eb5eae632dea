"""The compiled per-pixel kernels of the iterative photometric-stereo methods against the NumPy
formulations they replaced (copied here as references): the same residuals, reflectance weights,
Levenberg–Marquardt normals, ADMM and consensus hill climbing, to rounding, on small cases."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.vision import bivariate_stereo, consensus, datasets, photometric_stereo
from brdfkit.vision.bivariate_stereo import _half_vectors, _tangent_frame

# ----------------------------------------------------------------------------------------------
# The NumPy references (the code before the kernels, lock step over the pixels)


def _ref_solve_weights(gram, rhs, nonnegative):
    k = gram.shape[-1]
    ridge = 1e-9 * np.trace(gram, axis1=1, axis2=2)[:, None, None] / k + 1e-300
    gram = gram + ridge * np.eye(k)
    if not nonnegative:
        return np.linalg.solve(gram, rhs[..., None])[..., 0]
    free = np.ones(rhs.shape, dtype=bool)
    identity = np.eye(k, dtype=bool)
    weights = np.zeros_like(rhs)
    for _ in range(2 * k):
        both = free[:, :, None] & free[:, None, :]
        reduced = np.where(both, gram, identity)
        weights = np.linalg.solve(reduced, np.where(free, rhs, 0.0)[..., None])[..., 0]
        weights = np.where(free, weights, 0.0)
        negative = free & (weights < 0)
        gradient = np.einsum("pkl,pl->pk", gram, np.maximum(weights, 0.0)) - rhs
        release = ~free & (gradient < -1e-12 * np.abs(rhs).max(axis=1, keepdims=True))
        if not negative.any() and not release.any():
            break
        worst = np.argmin(np.where(negative, weights, np.inf), axis=1)
        steepest = np.argmin(np.where(release, gradient, np.inf), axis=1)
        rows = np.arange(len(free))
        has_negative = negative.any(axis=1)
        free[rows[has_negative], worst[has_negative]] = False
        freeing = ~has_negative & release.any(axis=1)
        free[rows[freeing], steepest[freeing]] = True
    return np.maximum(weights, 0.0)


def _ref_design(basis, cos_i, cos_h, cos_d):
    if basis.kind == 0:
        shading, cos_h = np.clip(cos_i, 0.0, None), np.clip(cos_h, 0.0, None)
        a_max, b_max = basis.ints
        terms = [shading * cos_h**a * cos_d**b for a in range(a_max + 1) for b in range(b_max + 1)]
        return np.stack(terms, axis=2)
    if basis.kind == 1:

        def ramps(x, knots):
            return np.clip((x[..., None] - knots[:-1]) / (knots[1:] - knots[:-1]), 0.0, 1.0)

        front = (cos_i > 0)[..., None]
        return np.concatenate([ramps(cos_i, basis.fa), ramps(cos_h, basis.fb) * front], axis=2)
    table = bivariate_stereo._Table(*basis.ints)
    table.values = basis.fa
    index, weight = table.weights(cos_h, cos_d)
    value = sum(table.values[k] * w for k, w in zip(index, weight, strict=True))
    shading = np.clip(cos_i, 0.0, None)
    return np.stack([shading, shading * value], axis=2)


def _ref_residuals(normals, gray, weights, lights, basis, nonnegative):
    half, cos_theta_d = _half_vectors(lights)
    cos_theta_i = normals @ lights.T
    cos_theta_h = normals @ half.T
    design = _ref_design(
        basis, cos_theta_i, cos_theta_h, np.broadcast_to(cos_theta_d, cos_theta_i.shape)
    )
    weighted = design * weights[..., None]
    gram = np.matmul(weighted.transpose(0, 2, 1), design)
    rhs = np.einsum("pnk,pn->pk", weighted, gray)
    coefficients = _ref_solve_weights(gram, rhs, nonnegative)
    model = np.einsum("pnk,pk->pn", design, coefficients)
    return np.sqrt(weights) * (gray - model), coefficients


def _ref_refine_normals(normals, gray, weights, lights, basis, nonnegative, iterations, epsilon):
    """NumPy's Levenberg–Marquardt with a central-difference Jacobian of step ``epsilon`` (the
    kernel's is analytic)."""
    damping = np.full(len(normals), 1e-3)
    residual, _ = _ref_residuals(normals, gray, weights, lights, basis, nonnegative)
    cost = np.sum(residual**2, axis=1)
    for _ in range(iterations):
        t_1, t_2 = _tangent_frame(normals)
        columns = []
        for tangent in (t_1, t_2):
            shifted = []
            for sign in (1, -1):
                moved = normals + sign * epsilon * tangent
                moved /= np.linalg.norm(moved, axis=1, keepdims=True)
                shifted.append(_ref_residuals(moved, gray, weights, lights, basis, nonnegative)[0])
            columns.append((shifted[0] - shifted[1]) / (2 * epsilon))
        jacobian = np.stack(columns, axis=2)
        jtj = np.matmul(jacobian.transpose(0, 2, 1), jacobian)
        jtr = np.einsum("pnj,pn->pj", jacobian, residual)
        scale = np.trace(jtj, axis1=1, axis2=2)[:, None, None] / 2 + 1e-300
        step = -np.linalg.solve(jtj + damping[:, None, None] * scale * np.eye(2), jtr[..., None])
        step = np.clip(step[..., 0], -0.2, 0.2)
        trial = normals + step[:, :1] * t_1 + step[:, 1:] * t_2
        trial /= np.linalg.norm(trial, axis=1, keepdims=True)
        trial_residual, _ = _ref_residuals(trial, gray, weights, lights, basis, nonnegative)
        trial_cost = np.sum(trial_residual**2, axis=1)
        better = trial_cost < cost
        normals = np.where(better[:, None], trial, normals)
        residual = np.where(better[:, None], trial_residual, residual)
        cost = np.where(better, trial_cost, cost)
        damping = np.clip(np.where(better, damping / 3, damping * 4), 1e-7, 1e7)
    return normals


def _ref_sparse_regression(gray, lights, max_iterations=500, tol=1e-6):
    pseudo_inverse = np.linalg.pinv(lights)
    scale = np.linalg.norm(gray)
    beta = gray.size / (4.0 * np.abs(gray).sum())
    error, dual = np.zeros_like(gray), np.zeros_like(gray)
    for iterations in range(1, max_iterations + 1):  # noqa: B007 (the count is returned)
        b = pseudo_inverse @ (gray - error + dual / beta)
        residual = gray - lights @ b
        x = residual + dual / beta
        error = np.sign(x) * np.maximum(np.abs(x) - 1.0 / beta, 0.0)
        gap = residual - error
        dual += beta * gap
        beta = min(beta * 1.05, 1e8)
        if np.linalg.norm(gap) <= tol * scale:
            break
    return b, iterations


def _ref_consensus_cost(normals, ranks, lit, lights):
    """Consensus cost ``(P,)`` of per-pixel ``normals`` ``(P, 3)``."""
    cosines = normals @ lights.T
    r_c = consensus._ranks(cosines)
    count = np.maximum(lit.sum(axis=1), 1.0)

    def moment(a: np.ndarray, b: np.ndarray | float) -> np.ndarray:
        return (lit * a * b).sum(axis=1) / count

    mean_i, mean_c = moment(ranks, 1.0), moment(r_c, 1.0)
    variance = (moment(ranks, ranks) - mean_i**2) * (moment(r_c, r_c) - mean_c**2)
    rho = (moment(ranks, r_c) - mean_i * mean_c) / np.sqrt(np.maximum(variance, 1e-300))
    return (1 - rho) / 2 + np.abs(lit - (cosines > 0)).mean(axis=1)


def _ref_robust_pca(data, lights, lam, shadow_threshold=0.02, rank=3, max_iterations=200, tol=1e-7):
    def shrink(matrix, tau):
        eigenvalues, u = np.linalg.eigh(matrix @ matrix.T)
        s = np.sqrt(np.maximum(eigenvalues, 0.0))
        factor = np.where(s > tau, (s - tau) / np.where(s > 0, s, 1.0), 0.0)
        factor[: max(len(s) - rank, 0)] = 0.0
        return (u * factor) @ (u.T @ matrix)

    observed = data > shadow_threshold * data.max(axis=0, keepdims=True)
    data_norm = np.linalg.norm(data)
    norm_two = np.sqrt(np.linalg.eigvalsh(data @ data.T)[-1])
    dual = data / max(norm_two, np.abs(data).max() / lam)
    mu = 1.25 / norm_two
    mu_max = mu * 1e7
    sparse = np.zeros_like(data)
    for iterations in range(1, max_iterations + 1):  # noqa: B007 (the count is returned)
        low_rank = shrink(data - sparse + dual / mu, 1.0 / mu)
        target = data - low_rank + dual / mu
        soft = np.sign(target) * np.maximum(np.abs(target) - lam / mu, 0.0)
        sparse = np.where(observed, soft, target)
        gap = data - low_rank - sparse
        dual += mu * gap
        mu = min(mu * 1.5, mu_max)
        if np.linalg.norm(gap) <= tol * data_norm:
            break
    return np.linalg.pinv(lights) @ low_rank, iterations


# ----------------------------------------------------------------------------------------------


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
    ref_residual, ref_weights = _ref_residuals(normals, gray.T, lit, lights, basis, nonnegative)
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
    reference = _ref_refine_normals(starts[0], gray.T, lit, lights, basis, nonnegative, 6, epsilon)
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
    b, iterations = _ref_sparse_regression(gray, lights)
    assert len(steps) == iterations and steps == list(range(1, iterations + 1))
    normals = (b / np.linalg.norm(b, axis=0)).T
    np.testing.assert_allclose(result.normals[0], normals, atol=1e-8)


def test_consensus_rings_match_numpy(glossy):
    gray, lights, _, _ = glossy
    intensities = gray.T
    lit = (intensities > 0.05 * bivariate_stereo._reference(intensities)[:, None]).astype(float)
    ranks = consensus._ranks(intensities)
    normals, order = consensus._global_search(ranks, lit, lights, consensus._hemisphere(200))
    reference = normals.copy()
    cost = _ref_consensus_cost(reference, ranks, lit, lights)
    for radius in consensus._RINGS:
        t_1, t_2 = _tangent_frame(reference)
        for azimuth in np.arange(6) * np.pi / 3:
            trial = reference * np.cos(radius) + np.sin(radius) * (
                np.cos(azimuth) * t_1 + np.sin(azimuth) * t_2
            )
            trial_cost = _ref_consensus_cost(trial, ranks, lit, lights)
            better = trial_cost < cost
            reference = np.where(better[:, None], trial, reference)
            cost = np.where(better, trial_cost, cost)
    from brdfkit.vision import _photometric_stereo_kernels

    found = np.empty(len(normals))
    _photometric_stereo_kernels.consensus_rings(
        normals, found, order, ranks, lit, lights, np.empty(0), True
    )
    np.testing.assert_allclose(found, _ref_consensus_cost(normals, ranks, lit, lights), atol=1e-12)
    _photometric_stereo_kernels.consensus_rings(
        normals, found, order, ranks, lit, lights, consensus._RINGS, False
    )
    assert np.abs(normals - reference).max() < 1e-9
    np.testing.assert_allclose(found, cost, atol=1e-12)  # the kept costs are the normals'


def _ref_global_search(ranks, lit, lights, candidates):
    """The consensus global search in NumPy (three matrix products a block of pixels)."""
    cosines = candidates @ lights.T
    candidate_ranks = consensus._ranks(cosines)
    front = (cosines > 0).astype(np.float64)
    count = np.maximum(lit.sum(axis=1, keepdims=True), 1.0)
    mean_i = (lit * ranks).sum(axis=1, keepdims=True) / count
    var_i = (lit * ranks * ranks).sum(axis=1, keepdims=True) / count - mean_i**2
    mean_c = (lit @ candidate_ranks.T) / count
    var_c = (lit @ (candidate_ranks**2).T) / count - mean_c**2
    covariance = ((lit * ranks) @ candidate_ranks.T) / count - mean_i * mean_c
    rho = covariance / np.sqrt(np.maximum(var_i * var_c, 1e-300))
    disagree = (lit.sum(axis=1, keepdims=True) + front.sum(axis=1) - 2 * lit @ front.T) / len(
        lights
    )
    return candidates[np.argmin((1 - rho) / 2 + disagree, axis=1)]


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
    reference = _ref_global_search(ranks, lit, lights, candidates)
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
    b, iterations = _ref_robust_pca(gray, lights, lam, max_iterations=max_iterations)
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
    np.testing.assert_array_equal(found, _ref_global_search(ranks, lit, lights, candidates))
