r"""Robust and consensus photometric stereo in plain NumPy: the readable version of the compiled
kernels.

:func:`~brdfkit.vision.photometric_stereo.sparse_regression`,
:func:`~brdfkit.vision.photometric_stereo.robust_pca` and
:func:`~brdfkit.vision.consensus.consensus` run their iterations in compiled kernels
(:mod:`brdfkit.vision._photometric_stereo_kernels`), pixel by pixel or block by block over the
cores. The functions here compute the same numbers the way the formulas read, on the whole
``(N, P)`` observation matrix at once; the tests hold each kernel equal to its function here
(to rounding, or exactly where the arithmetic is in integers).

References
----------
.. [1] S. Ikehata, D. Wipf, Y. Matsushita, K. Aizawa, "Robust photometric stereo using sparse
   regression", CVPR 2012.
.. [2] L. Wu, A. Ganesh, B. Shi, Y. Matsushita, Y. Wang, Y. Ma, "Robust photometric stereo via
   low-rank matrix completion and recovery", ACCV 2010.
.. [3] Z. Lin, M. Chen, Y. Ma, "The augmented Lagrange multiplier method for exact recovery of
   corrupted low-rank matrices", arXiv:1009.5055, 2010.
.. [4] T. Higo, Y. Matsushita, K. Ikeuchi, "Consensus photometric stereo", CVPR 2010.
"""

from __future__ import annotations

import numpy as np

from brdfkit.vision.bivariate_stereo import _tangent_frame
from brdfkit.vision.consensus import _ranks

__all__ = [
    "consensus_cost",
    "consensus_global_search",
    "consensus_rings",
    "robust_pca",
    "sparse_regression",
]


def sparse_regression(
    gray: np.ndarray, lights: np.ndarray, max_iterations: int = 500, tol: float = 1e-6
) -> tuple[np.ndarray, int]:
    """``b`` ``(3, P)`` of ``min ||e||_1`` subject to ``I = L b + e`` for the observations
    ``gray`` ``(N, P)`` under ``lights`` ``(N, 3)``, and the iterations run.

    ADMM with a penalty ``β`` from ``P N / (4 Σ|I|)``, growing by 5 % an iteration (at most
    1e8): ``b = L⁺ (I - e + y/β)``, ``e = shrink(I - L b + y/β, 1/β)``,
    ``y += β (I - L b - e)``, until ``||I - L b - e||_F <= tol ||I||_F``.
    """
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


def robust_pca(
    data: np.ndarray,
    lights: np.ndarray,
    lam: float,
    shadow_threshold: float = 0.02,
    rank: int = 3,
    max_iterations: int = 200,
    tol: float = 1e-7,
) -> tuple[np.ndarray, int]:
    """``b = L⁺ A`` ``(3, P)`` of the split ``D = A + E`` of ``data`` ``(N, P)`` into a low-rank
    ``A`` and a sparse ``E``, and the iterations run.

    The inexact augmented Lagrange multiplier method: ``A`` the singular-value shrinkage of
    ``D - E + Y/μ`` by ``1/μ`` keeping at most ``rank`` values, ``E`` its soft threshold by
    ``lam/μ`` where observed (brighter than ``shadow_threshold`` times the pixel's brightest)
    and free elsewhere, ``Y += μ (D - A - E)``, ``μ`` growing by 1.5 from ``1.25 / ||D||_2``
    (at most 1e7 times that), until ``||D - A - E||_F <= tol ||D||_F``.
    """

    def shrink(matrix: np.ndarray, tau: float) -> np.ndarray:
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


def consensus_cost(
    normals: np.ndarray, ranks: np.ndarray, lit: np.ndarray, lights: np.ndarray
) -> np.ndarray:
    """The consensus cost ``(P,)`` of per-pixel ``normals`` ``(P, 3)``: ``(1 - ρ_S) / 2`` plus
    the fraction of lights whose visibility disagrees, ``ρ_S`` the Spearman correlation of the
    observations' ``ranks`` ``(P, N)`` and the cosines' ranks over the ``lit`` ones."""
    cosines = normals @ lights.T
    r_c = _ranks(cosines)
    count = np.maximum(lit.sum(axis=1), 1.0)

    def moment(a: np.ndarray, b: np.ndarray | float) -> np.ndarray:
        return (lit * a * b).sum(axis=1) / count

    mean_i, mean_c = moment(ranks, 1.0), moment(r_c, 1.0)
    variance = (moment(ranks, ranks) - mean_i**2) * (moment(r_c, r_c) - mean_c**2)
    rho = (moment(ranks, r_c) - mean_i * mean_c) / np.sqrt(np.maximum(variance, 1e-300))
    return (1 - rho) / 2 + np.abs(lit - (cosines > 0)).mean(axis=1)


def consensus_global_search(
    ranks: np.ndarray, lit: np.ndarray, lights: np.ndarray, candidates: np.ndarray
) -> np.ndarray:
    """Each pixel's candidate ``(P, 3)`` of least :func:`consensus_cost` among ``candidates``
    ``(M, 3)``: the rank moments of every pixel against every candidate as three matrix
    products."""
    cosines = candidates @ lights.T
    candidate_ranks = _ranks(cosines)
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


def consensus_rings(
    normals: np.ndarray,
    ranks: np.ndarray,
    lit: np.ndarray,
    lights: np.ndarray,
    rings: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Hill climbing from ``normals`` ``(P, 3)`` on rings of the radii ``rings``, in turn: six
    trial normals a ring, each kept where its :func:`consensus_cost` is lower; the normals and
    their costs ``(P,)``."""
    cost = consensus_cost(normals, ranks, lit, lights)
    for radius in rings:
        t_1, t_2 = _tangent_frame(normals)
        for azimuth in np.arange(6) * np.pi / 3:
            trial = normals * np.cos(radius) + np.sin(radius) * (
                np.cos(azimuth) * t_1 + np.sin(azimuth) * t_2
            )
            trial_cost = consensus_cost(trial, ranks, lit, lights)
            better = trial_cost < cost
            normals = np.where(better[:, None], trial, normals)
            cost = np.where(better, trial_cost, cost)
    return normals, cost
