r"""Bivariate photometric stereo in plain NumPy: the readable version of the compiled kernels.

:mod:`brdfkit.vision.bivariate_stereo` runs its per-pixel work in compiled kernels
(:mod:`brdfkit.vision._bivariate_stereo_kernels`), each pixel's observations in cache, the
pixels split over the cores. The functions here compute the same numbers the way the formulas
read, every pixel in lock step as one NumPy array operation; the tests hold each kernel equal to
its function here (to rounding, or exactly where the arithmetic is in integers).

At a pixel of normal ``n`` under lights ``l_k`` (view ``v = (0, 0, 1)``, half vectors
``h_k = (l_k + v) / |l_k + v|``) the model is linear in the reflectance weights ``c``:

.. math:: I_k \approx \sum_j c_j\, D_j(\cos θ_{i,k}, \cos θ_{h,k}, \cos θ_{d,k}),

``D`` the design of a :class:`~brdfkit.vision.bivariate_stereo.Basis` (:func:`design`), ``c``
its weighted least-squares solution (:func:`solve_weights`, non-negative by an active set where
the method asks), and the normal the minimiser of the remaining residual (:func:`residuals`),
found by Levenberg–Marquardt on two tangent coordinates (:func:`refine_normals`) from the best
of several starts (:func:`best_start`).

References
----------
.. [1] C. L. Lawson, R. J. Hanson, *Solving Least Squares Problems*, Prentice-Hall, 1974,
   ch. 23 (the active-set non-negative least squares).
.. [2] G. H. Golub, V. Pereyra, "The differentiation of pseudo-inverses and nonlinear least
   squares problems whose variables separate", SIAM J. Numer. Anal. 10(2), 1973.
.. [3] N. Alldrin, T. Zickler, D. Kriegman, "Photometric stereo with non-parametric and
   spatially-varying reflectance", CVPR 2008 (the shared table).
"""

from __future__ import annotations

import numpy as np

from brdfkit.vision.bivariate_stereo import (
    BEST_START_RING,
    Basis,
    _fit,
    _half_vectors,
    _ranks,
    _reference,
    _smoothed_solution,
    _Table,
    _tangent_frame,
    _trimmed,
)

__all__ = [
    "best_start",
    "design",
    "diffuse_albedo",
    "order",
    "refine_normals",
    "residuals",
    "solve_weights",
    "table_fit",
]


def design(
    basis: Basis, cos_theta_i: np.ndarray, cos_theta_h: np.ndarray, cos_theta_d: np.ndarray
) -> np.ndarray:
    """The design ``D`` ``(P, N, K)`` of ``basis`` at the cosines ``(P, N)`` of every pixel and
    light, shading ``max(0, cos θ_i)`` included.

    - bi-polynomial: ``max(0, cos θ_i) max(0, cos θ_h)^a cos^b θ_d``, index ``a (B + 1) + b``;
    - ramps: ``clip((x - t_m) / (t_{m+1} - t_m), 0, 1)`` of ``x = cos θ_i`` on the knots ``fa``,
      then of ``x = cos θ_h`` on the knots ``fb`` where ``cos θ_i > 0``;
    - table: ``max(0, cos θ_i) (1, T(θ_h, θ_d))``, ``T`` bilinear in the table ``fa``.
    """
    from brdfkit.vision import _bivariate_stereo_kernels

    shading = np.clip(cos_theta_i, 0.0, None)
    if basis.kind == _bivariate_stereo_kernels.BIPOLYNOMIAL:
        cos_theta_h = np.clip(cos_theta_h, 0.0, None)
        a_max, b_max = basis.ints
        terms = [
            shading * cos_theta_h**a * cos_theta_d**b
            for a in range(a_max + 1)
            for b in range(b_max + 1)
        ]
        return np.stack(terms, axis=2)
    if basis.kind == _bivariate_stereo_kernels.RAMPS:

        def ramps(x: np.ndarray, knots: np.ndarray) -> np.ndarray:
            return np.clip((x[..., None] - knots[:-1]) / (knots[1:] - knots[:-1]), 0.0, 1.0)

        front = (cos_theta_i > 0)[..., None]
        return np.concatenate(
            [ramps(cos_theta_i, basis.fa), ramps(cos_theta_h, basis.fb) * front], axis=2
        )
    table = _Table(*basis.ints)
    table.values = basis.fa
    index, weight = table.weights(cos_theta_h, cos_theta_d)
    value = sum(table.values[k] * w for k, w in zip(index, weight, strict=True))
    return np.stack([shading, shading * value], axis=2)


def solve_weights(gram: np.ndarray, rhs: np.ndarray, nonnegative: bool) -> np.ndarray:
    """The weights ``c`` ``(P, K)`` solving ``(G + ε I) c = r`` per pixel (``G`` the Gram
    ``(P, K, K)``, ``r`` ``(P, K)``, ``ε`` a ridge of ``1e-9`` of the mean diagonal); with
    ``nonnegative``, subject to ``c >= 0`` by Lawson & Hanson's active set: solve on the free
    weights, then clamp the most negative free one, or free the clamped one of steepest descent
    (gradient below ``-1e-12`` of the largest ``|r|``), until none changes, at most ``2 K``
    rounds."""
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


def residuals(
    normals: np.ndarray,
    gray: np.ndarray,
    weights: np.ndarray,
    lights: np.ndarray,
    basis: Basis,
    nonnegative: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """The weighted residuals ``sqrt(w) (I - D c)`` ``(P, N)`` of the best weights ``c``
    ``(P, K)`` for ``normals`` ``(P, 3)``, and those weights (:func:`solve_weights` of
    ``D^T W D`` and ``D^T W I``); ``gray`` and ``weights`` are ``(P, N)``."""
    half, cos_theta_d = _half_vectors(lights)
    cos_theta_i = normals @ lights.T
    cos_theta_h = normals @ half.T
    d = design(basis, cos_theta_i, cos_theta_h, np.broadcast_to(cos_theta_d, cos_theta_i.shape))
    weighted = d * weights[..., None]
    gram = np.matmul(weighted.transpose(0, 2, 1), d)
    rhs = np.einsum("pnk,pn->pk", weighted, gray)
    coefficients = solve_weights(gram, rhs, nonnegative)
    model = np.einsum("pnk,pk->pn", d, coefficients)
    return np.sqrt(weights) * (gray - model), coefficients


def refine_normals(
    normals: np.ndarray,
    gray: np.ndarray,
    weights: np.ndarray,
    lights: np.ndarray,
    basis: Basis,
    nonnegative: bool,
    iterations: int,
    epsilon: float,
) -> np.ndarray:
    """Levenberg–Marquardt on the tangent coordinates of every pixel's normal, ``iterations``
    steps from ``normals`` ``(P, 3)``, the Jacobian of the :func:`residuals` by central
    differences of step ``epsilon`` (the kernel's is analytic).

    ``n(u, v) = normalise(n + u t_1 + v t_2)``; the step solves ``(J^T J + λ s I) δ = -J^T r``
    (``s`` the mean diagonal of ``J^T J``), clipped to 0.2 per coordinate; a pixel keeps it if
    its cost falls, and its damping ``λ`` shrinks by 3 (grows by 4 otherwise; within
    [1e-7, 1e7], from 1e-3)."""
    damping = np.full(len(normals), 1e-3)
    residual, _ = residuals(normals, gray, weights, lights, basis, nonnegative)
    cost = np.sum(residual**2, axis=1)
    for _ in range(iterations):
        t_1, t_2 = _tangent_frame(normals)
        columns = []
        for tangent in (t_1, t_2):
            shifted = []
            for sign in (1, -1):
                moved = normals + sign * epsilon * tangent
                moved /= np.linalg.norm(moved, axis=1, keepdims=True)
                shifted.append(residuals(moved, gray, weights, lights, basis, nonnegative)[0])
            columns.append((shifted[0] - shifted[1]) / (2 * epsilon))
        jacobian = np.stack(columns, axis=2)
        jtj = np.matmul(jacobian.transpose(0, 2, 1), jacobian)
        jtr = np.einsum("pnj,pn->pj", jacobian, residual)
        scale = np.trace(jtj, axis1=1, axis2=2)[:, None, None] / 2 + 1e-300
        step = -np.linalg.solve(jtj + damping[:, None, None] * scale * np.eye(2), jtr[..., None])
        step = np.clip(step[..., 0], -0.2, 0.2)
        trial = normals + step[:, :1] * t_1 + step[:, 1:] * t_2
        trial /= np.linalg.norm(trial, axis=1, keepdims=True)
        trial_residual, _ = residuals(trial, gray, weights, lights, basis, nonnegative)
        trial_cost = np.sum(trial_residual**2, axis=1)
        better = trial_cost < cost
        normals = np.where(better[:, None], trial, normals)
        residual = np.where(better[:, None], trial_residual, residual)
        cost = np.where(better, trial_cost, cost)
        damping = np.clip(np.where(better, damping / 3, damping * 4), 1e-7, 1e7)
    return normals


def best_start(
    starts: np.ndarray,
    gray: np.ndarray,
    weights: np.ndarray,
    lights: np.ndarray,
    basis: Basis,
    nonnegative: bool,
    ring: float = BEST_START_RING,
) -> np.ndarray:
    """Each pixel's start normal ``(P, 3)``: the candidate of ``starts`` ``(S, P, 3)`` of least
    model cost, then the best of it and 6 normals on a ring of radius ``ring`` around it, every
    pixel scored against one candidate at a time (the costs of the fits of
    :func:`brdfkit.vision.bivariate_stereo._fit`, which the tests hold to :func:`residuals`)."""

    def pick(candidates: list[np.ndarray]) -> np.ndarray:
        costs = np.stack(
            [_fit(c, gray, weights, lights, basis, nonnegative)[2] for c in candidates]
        )
        best = np.argmin(costs, axis=0)
        return np.stack(candidates)[best, np.arange(len(best))]

    normals = pick(list(starts))
    t_1, t_2 = _tangent_frame(normals)
    ring_normals = [normals]
    for angle in np.arange(6) * np.pi / 3:
        tilted = normals * np.cos(ring) + np.sin(ring) * (np.cos(angle) * t_1 + np.sin(angle) * t_2)
        ring_normals.append(tilted)
    return pick(ring_normals)


def table_fit(
    table: _Table,
    normals: np.ndarray,
    gray: np.ndarray,
    weights: np.ndarray,
    lights: np.ndarray,
    coefficients: np.ndarray,
    smoothness: float,
) -> np.ndarray:
    """The shared table's values ``(n_h n_d,)`` given the normals and each pixel's ``(ρ_d, ρ_s)``
    ``coefficients``: the normal equations of ``I - ρ_d max(0, n·l) = ρ_s max(0, n·l) T(θ_h,
    θ_d)``, every observation coupling its 4 bilinear nodes (assembled as a sparse matrix of
    4 × 4 entries per observation), then the smoothed, clipped and scaled solve of
    :func:`brdfkit.vision.bivariate_stereo._smoothed_solution`."""
    from scipy import sparse

    half, cos_theta_d = _half_vectors(lights)
    shading = np.clip(normals @ lights.T, 0.0, None)
    index, weight = table.weights(normals @ half.T, np.broadcast_to(cos_theta_d, shading.shape))
    scale = shading * coefficients[:, 1:2]
    target = gray - shading * coefficients[:, :1]
    size = table.n_h * table.n_d
    rows, cols, values, rhs = [], [], [], np.zeros(size)
    for a in range(4):
        wa = weights * scale * weight[a]
        rhs += np.bincount(index[a].ravel(), (wa * target).ravel(), size)
        for b in range(4):
            rows.append(index[a].ravel())
            cols.append(index[b].ravel())
            values.append((wa * scale * weight[b]).ravel())
    normal_matrix = sparse.coo_matrix(
        (np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))), (size, size)
    ).tocsr()
    return _smoothed_solution(normal_matrix, rhs, table.n_h, table.n_d, smoothness)


def order(gray: np.ndarray, shadow_threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """Each observation's rank in its pixel ``(P, N)`` (NumPy's sort of ``gray`` ``(N, P)``)
    and the shadow weights ``(P, N)``: 1 where brighter than ``shadow_threshold`` times the
    pixel's 90th-percentile observation (``np.percentile``), else 0."""
    lit = gray > shadow_threshold * _reference(gray.T)[None, :]
    return _ranks(gray), lit.T.astype(np.float64)


def diffuse_albedo(
    normals: np.ndarray,
    gray: np.ndarray,
    weights: np.ndarray,
    lights: np.ndarray,
    ranks: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The diffuse albedo ``ρ_d`` ``(P,)`` along the found normals, and the observations it
    used ``(P, N)``: the Lambertian fit ``ρ_d = Σ w c I / Σ w c²`` (``c = max(0, n·l)``) over
    the lit observations (``c > 0.1``) of middle rank (``[N/4, 3N/4)``), or over every lit one
    where none is of middle rank."""
    cos_theta_i = np.clip(normals @ lights.T, 0.0, None)
    lit = weights * (cos_theta_i > 0.1)
    trim = _trimmed(ranks, 0.25, 0.25).T * lit
    use = np.where(trim.sum(axis=1, keepdims=True) > 0, trim, lit)
    numerator = np.sum(use * cos_theta_i * gray.T, axis=1)
    return numerator / np.maximum(np.sum(use * cos_theta_i**2, axis=1), 1e-300), use
