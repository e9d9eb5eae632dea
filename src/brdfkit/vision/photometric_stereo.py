"""Photometric stereo: surface normals and albedo from images under known (or unknown) lights.

Image formation (Lambertian, distant light ``l_k``, unit normal ``n``, albedo ``rho``)::

    I_k = rho * max(0, l_k . n) = l_k . b,   b = rho * n        (where lit)

Stacking ``N >= 3`` lights gives, for every pixel, the linear system ``I = L b`` with
``L`` the ``(N, 3)`` matrix of light directions. Every method here works on all the pixels of the
mask at once: the images become an ``(N, P)`` matrix and the per-pixel solves are batched matrix
products, never Python loops over pixels.

Frame: x right, y up, z towards the camera (see :mod:`brdfkit.vision`). Colour images are
reduced to their channel mean to estimate the normals; the albedo keeps one value per channel.

References
----------
.. [1] R. J. Woodham, "Photometric method for determining surface orientation from multiple
   images", Optical Engineering 19(1), 139-144, 1980.
.. [2] S. Ikehata, D. Wipf, Y. Matsushita, K. Aizawa, "Robust photometric stereo using sparse
   regression", CVPR 2012.
.. [3] L. Wu, A. Ganesh, B. Shi, Y. Matsushita, Y. Wang, Y. Ma, "Robust photometric stereo via
   low-rank matrix completion and recovery", ACCV 2010.
.. [4] B. Shi, Z. Mo, Z. Wu, D. Duan, S.-K. Yeung, P. Tan, "A benchmark dataset and evaluation
   for non-Lambertian and uncalibrated photometric stereo", IEEE TPAMI 41(2), 2019.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._array import check_param
from brdfkit._checks import as_float_array, check_count, check_image_shape, check_memory
from brdfkit.errors import ParameterError

MAX_ITERATIONS = 100_000
"""Largest ``max_iterations`` of the iterative solvers."""

ADMM_BLOCK = 16
"""Iterations :func:`sparse_regression` runs per pass over the pixels."""

BLAS_THREADS: int | None = 1
"""BLAS threads of :func:`robust_pca`'s iterations (``None``: the process's own). Its products
are ``N x N`` Grams and eigendecompositions (``N`` the lights), which threads barely speed up; on
a busy machine a threaded OpenBLAS spins and makes them many times slower. The pixels are split
over the cores by the compiled kernels instead."""

MAX_PIXELS = 2**28
"""Most pixels :func:`sphere_normals` makes (a 16384 × 16384 image)."""

Callback = Callable[[int, int], None]
"""Progress callback ``callback(iteration, max_iterations)`` of the iterative solvers."""


@dataclass(frozen=True)
class PhotometricStereoResult:
    """Output of a photometric-stereo method.

    Attributes
    ----------
    normals : (H, W, 3) unit normals in the camera frame (x right, y up, z towards the camera);
        zero outside ``mask``.
    albedo : (H, W, C) albedo per channel (``|b|`` times the pixel's chromaticity); zero outside.
    mask : (H, W) bool, the pixels that were solved.
    """

    normals: np.ndarray
    albedo: np.ndarray
    mask: np.ndarray


def _prepare(
    images: ArrayLike, light_directions: ArrayLike, mask: ArrayLike | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate inputs; return observations ``(N, P, C)``, unit lights ``(N, 3)`` and the mask.

    Raises
    ------
    brdfkit.errors.ParameterError
        Shapes that disagree, fewer than 3 lights, non-numeric images, NaN or infinity in the
        lights or in the images inside the mask, or an empty mask.
    brdfkit.errors.ResourceError
        The float64 observations would not fit in memory.
    """
    images = np.asarray(images)
    if images.dtype.kind not in "biuf":
        raise ParameterError(f"images must hold real numbers; got dtype {images.dtype}")
    if images.ndim not in (3, 4):
        raise ParameterError(
            f"images must have shape (N, H, W) or (N, H, W, C), got shape {images.shape}"
        )
    if images.ndim == 3:
        images = images[..., None]
    n_lights, height, width = images.shape[:3]
    if n_lights < 3:
        raise ParameterError(f"photometric stereo needs at least 3 lights, got {n_lights} images")
    lights = as_float_array("light_directions", light_directions)
    if lights.shape != (n_lights, 3):
        raise ParameterError(
            f"light_directions must have shape ({n_lights}, 3) to match {n_lights} images, "
            f"got shape {lights.shape}"
        )
    length = np.linalg.norm(lights, axis=1)
    if not np.all(np.isfinite(length)) or np.any(length == 0):
        raise ParameterError("light_directions must be finite and non-zero, got " + repr(lights))
    if mask is None:
        mask = np.ones((height, width), dtype=bool)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != (height, width):
        raise ParameterError(f"mask must have shape {(height, width)}, got shape {mask.shape}")
    if not mask.any():
        raise ParameterError("mask has no pixels set: nothing to solve")
    check_memory(
        f"photometric stereo on {images.shape} images",
        8 * n_lights * int(mask.sum()) * images.shape[3],
    )
    flat = images.reshape(n_lights, height * width, images.shape[3])
    # take() keeps the (N, P, C) memory order that boolean indexing on axis 1 would transpose.
    observations = (flat if mask.all() else np.take(flat, np.flatnonzero(mask), axis=1)).astype(
        np.float64
    )
    if not np.isfinite(observations.sum()):  # a NaN or infinity anywhere makes the sum one
        raise ParameterError("images contain non-finite values inside the mask")
    return observations, lights / length[:, None], mask


def _trim_weights(gray: np.ndarray, dark_fraction: float, bright_fraction: float) -> np.ndarray:
    """Per-pixel 0/1 weights dropping the darkest and brightest observations, ``(N, P)``."""
    for name, value in (("dark_fraction", dark_fraction), ("bright_fraction", bright_fraction)):
        if not 0 <= value < 1:
            raise ParameterError(f"{name} must be in [0, 1), got {value}")
    n_lights = gray.shape[0]
    n_dark = int(np.floor(dark_fraction * n_lights))
    n_bright = int(np.floor(bright_fraction * n_lights))
    if n_lights - n_dark - n_bright < 3:
        raise ParameterError(
            f"dark_fraction={dark_fraction} and bright_fraction={bright_fraction} leave "
            f"{n_lights - n_dark - n_bright} of {n_lights} observations; at least 3 are needed"
        )
    order = np.argsort(gray.T, axis=1)  # (P, N): sorting along contiguous rows is fast
    weights = np.zeros(order.shape)
    np.put_along_axis(weights, order[:, n_dark : n_lights - n_bright], 1.0, axis=1)
    return weights.T


def _gray(observations: np.ndarray) -> np.ndarray:
    """Channel mean ``(N, P)`` of ``(N, P, C)`` observations (a matrix-vector product)."""
    channels = observations.shape[2]
    return observations @ np.full(channels, 1.0 / channels)


def _weighted_least_squares(
    gray: np.ndarray, lights: np.ndarray, weights: np.ndarray
) -> np.ndarray:
    """Per-pixel weighted least squares ``b_p = (L^T W_p L)^{-1} L^T W_p I_p``, ``(3, P)``."""
    outer = (lights[:, :, None] * lights[:, None, :]).reshape(len(lights), 9)
    normal_matrix = (weights.T @ outer).reshape(-1, 3, 3)
    normal_matrix += 1e-12 * np.eye(3)
    rhs = (weights * gray).T @ lights
    return np.linalg.solve(normal_matrix, rhs[..., None])[..., 0].T


def _result(
    b: np.ndarray,
    observations: np.ndarray,
    mask: np.ndarray,
    chroma_weights: np.ndarray | None,
) -> PhotometricStereoResult:
    """Assemble maps from ``b = rho n`` (3, P); per-channel albedo = ``|b|`` times chromaticity.

    The chromaticity of a pixel is ``sum_k w_k I_kc / sum_k w_k I_k`` with ``I_k`` the channel
    mean and ``w`` the trimmed weights (shadows and highlights excluded), or all ones when
    ``chroma_weights`` is ``None``.
    """
    height, width = mask.shape
    channels = observations.shape[2]
    rho = np.linalg.norm(b, axis=0)
    normals = np.zeros((height, width, 3))
    normals[mask] = (b / np.where(rho > 0, rho, 1.0)).T
    if chroma_weights is None:
        n_lights = len(observations)  # a (N,) x (N, P C) product: BLAS, no copy
        channel_sum = (np.ones(n_lights) @ observations.reshape(n_lights, -1)).reshape(-1, channels)
    else:
        channel_sum = np.einsum("np,npc->pc", chroma_weights, observations)
    gray_sum = channel_sum.mean(axis=1)
    chroma = channel_sum / np.where(gray_sum > 0, gray_sum, 1.0)[:, None]
    albedo = np.zeros((height, width, channels))
    albedo[mask] = rho[:, None] * chroma
    return PhotometricStereoResult(normals=normals, albedo=albedo, mask=mask)


def least_squares(
    images: ArrayLike, light_directions: ArrayLike, mask: ArrayLike | None = None
) -> PhotometricStereoResult:
    """Calibrated Lambertian photometric stereo by least squares (Woodham 1980).

    ``b = L^+ I`` for every pixel at once (``L^+`` the pseudo-inverse of the ``(N, 3)`` light
    matrix), ``n = b / |b|``, ``rho = |b|``. Shadows and highlights bias it: see
    :func:`trimmed_least_squares`, :func:`sparse_regression` and :func:`robust_pca`.

    Parameters
    ----------
    images : (N, H, W) or (N, H, W, C) linear images divided by the light intensities.
    light_directions : (N, 3) directions towards the lights (normalised here).
    mask : (H, W) bool, pixels to solve; all pixels when omitted.

    Raises
    ------
    brdfkit.errors.ParameterError
        Shapes that disagree, fewer than 3 lights, NaN or infinity in the lights or in the
        images inside the mask, or an empty mask.
    brdfkit.errors.ResourceError
        The data would not fit in memory.

    References
    ----------
    R. J. Woodham, Optical Engineering 19(1), 139-144, 1980.

    Examples
    --------
    A Lambertian sphere (albedo 0.6) under four lights: where every light reaches, the normals
    and the albedo ρ/π come back exactly:

    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> from brdfkit.vision.metrics import angular_error
    >>> from brdfkit.vision.synthesis import render_brdf
    >>> normals, inside = sphere_normals((9, 9), centre=(4.0, 4.0), radius=4.5)
    >>> lights = np.array([[0, 0, 1.0], [0.6, 0, 0.8], [0, 0.6, 0.8], [-0.6, 0, 0.8]])
    >>> images = render_brdf(normals, inside, lights, Lambertian(rho=0.6))
    >>> lit = inside & np.all(np.einsum("kc,hwc->khw", lights, normals) > 0, axis=0)
    >>> result = least_squares(images, lights, lit)
    >>> error = angular_error(result.normals, normals, lit)
    >>> round(error["mean"], 6), round(error["median"], 6)
    (0.0, 0.0)
    >>> float((result.albedo[4, 4, 0] * np.pi).round(12))
    0.6
    """
    observations, lights, mask = _prepare(images, light_directions, mask)
    b = np.linalg.pinv(lights) @ _gray(observations)
    return _result(b, observations, mask, None)


def trimmed_least_squares(
    images: ArrayLike,
    light_directions: ArrayLike,
    mask: ArrayLike | None = None,
    *,
    dark_fraction: float = 0.25,
    bright_fraction: float = 0.1,
) -> PhotometricStereoResult:
    """Least squares after per-pixel rejection of the darkest and brightest observations.

    At each pixel the ``floor(dark_fraction N)`` darkest observations (likely shadowed) and the
    ``floor(bright_fraction N)`` brightest (likely specular) are dropped and ``b`` solves the
    weighted normal equations ``(L^T W L) b = L^T W I`` with ``W`` the 0/1 selection.

    References
    ----------
    R. J. Woodham 1980 (the model); the order-statistics rejection of shadows and highlights is
    the baseline used e.g. by S. Ikehata et al., CVPR 2012, and B. Shi et al., TPAMI 2019.
    """
    observations, lights, mask = _prepare(images, light_directions, mask)
    gray = _gray(observations)
    weights = _trim_weights(gray, dark_fraction, bright_fraction)
    return _result(_weighted_least_squares(gray, lights, weights), observations, mask, weights)


def sparse_regression(
    images: ArrayLike,
    light_directions: ArrayLike,
    mask: ArrayLike | None = None,
    *,
    max_iterations: int = 500,
    tol: float = 1e-6,
    callback: Callback | None = None,
) -> PhotometricStereoResult:
    """Robust photometric stereo by sparse regression, ℓ1 variant (Ikehata et al. 2012).

    Shadows and specularities are a sparse error ``e`` on the Lambertian model::

        min_{b, e} ||e||_1   subject to   I = L b + e,

    solved by the augmented Lagrangian method (ADMM) with a penalty ``beta`` growing by 5 % per
    iteration: ``b = L^+ (I - e + y / beta)``, ``e = shrink(I - L b + y / beta, 1 / beta)``,
    ``y += beta (I - L b - e)``. The pixels share only ``beta``'s schedule and the stopping test,
    so a compiled kernel (:mod:`brdfkit.vision._photometric_stereo_kernels`) runs blocks of
    :data:`ADMM_BLOCK` iterations pixel by pixel (each pixel's rows in cache), keeping every
    iteration's ``b`` and gap of the block, and the first iteration that passes the test ends it.

    Parameters
    ----------
    max_iterations, tol : stop when ``||I - L b - e||_F <= tol ||I||_F`` or after the count
        (at most :data:`MAX_ITERATIONS`).
    callback : called as ``callback(iteration, max_iterations)`` after each iteration.

    Raises
    ------
    brdfkit.errors.ParameterError
        Bad images, lights or mask (see :func:`least_squares`), or ``tol`` not finite and >= 0.
    brdfkit.errors.ResourceError
        ``max_iterations`` above :data:`MAX_ITERATIONS`, or data that would not fit in memory.

    References
    ----------
    S. Ikehata, D. Wipf, Y. Matsushita, K. Aizawa, "Robust photometric stereo using sparse
    regression", CVPR 2012 (the ℓ1 relaxation; their SBL variant is not implemented).
    """
    max_iterations = check_count("max_iterations", max_iterations, MAX_ITERATIONS)
    check_param("tol", tol, 0.0)
    observations, lights, mask = _prepare(images, light_directions, mask)
    from brdfkit.vision import _photometric_stereo_kernels

    gray = _gray(observations)
    pseudo_inverse = np.linalg.pinv(lights)
    scale = np.linalg.norm(gray)
    beta = gray.size / (4.0 * np.abs(gray).sum()) if scale > 0 else 1.0
    betas = np.minimum(beta * 1.05 ** np.arange(max_iterations), 1e8)
    pixels = np.ascontiguousarray(gray.T)  # (P, N): each pixel's observations contiguous
    error, dual = np.zeros_like(pixels), np.zeros_like(pixels)
    for start in range(0, max_iterations, ADMM_BLOCK):
        block = betas[start : start + ADMM_BLOCK]
        bs = np.empty((len(block), 3, len(pixels)))
        gap2 = np.empty((len(block), len(pixels)))
        _photometric_stereo_kernels.admm_chunk(
            pixels, error, dual, pseudo_inverse, lights, block, bs, gap2
        )
        done = np.flatnonzero(np.sqrt(gap2.sum(axis=1)) <= tol * scale)
        last = done[0] if len(done) else len(block) - 1
        b = bs[last]
        if callback is not None:
            for iteration in range(start, start + last + 1):
                callback(iteration + 1, max_iterations)
        if len(done):
            break
    weights = _trim_weights(gray, 0.25, 0.1)
    return _result(b, observations, mask, weights)


def _shrinkage_factors(
    gram: np.ndarray, tau: float, rank: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Singular-value shrinkage ``U max(S - tau, 0) V^T = M @ right @ left.T`` of the tall
    ``M`` ``(P, N)`` from its Gram ``gram = M^T M`` ``(N, N)``; with ``rank``, only the
    ``rank`` largest singular values are kept (the rest set to 0).

    With ``M^T M = V S^2 V^T`` the shrunk matrix is ``M V diag(max(s - tau, 0) / s) V^T``: one
    ``N x N`` eigendecomposition instead of a full SVD. Returns ``left = V_k diag(f_k)`` and
    ``right = V_k`` ``(N, k)`` for the ``k`` non-zero factors.
    """
    eigenvalues, u = np.linalg.eigh(gram)  # ascending
    s = np.sqrt(np.maximum(eigenvalues, 0.0))
    factor = np.where(s > tau, (s - tau) / np.where(s > 0, s, 1.0), 0.0)
    if rank is not None:
        factor[: max(len(s) - rank, 0)] = 0.0
    kept = np.flatnonzero(factor)
    return np.ascontiguousarray(u[:, kept] * factor[kept]), np.ascontiguousarray(u[:, kept])


def robust_pca(
    images: ArrayLike,
    light_directions: ArrayLike,
    mask: ArrayLike | None = None,
    *,
    lam: float | None = None,
    shadow_threshold: float = 0.02,
    rank: int | None = 3,
    max_iterations: int = 200,
    tol: float = 1e-7,
    callback: Callback | None = None,
) -> PhotometricStereoResult:
    """Robust photometric stereo by low-rank matrix recovery (Wu et al. 2010).

    The ``(N, P)`` observation matrix is split as ``D = A + E``, ``A`` low rank (rank 3 for a
    Lambertian scene) and ``E`` sparse (highlights, shadows), by the convex program::

        min ||A||_* + lam ||P_Omega(E)||_1   subject to   D = A + E,

    solved with the inexact augmented Lagrange multiplier method of Lin, Chen & Ma; entries
    outside ``Omega`` (observations below ``shadow_threshold`` times the pixel's brightest, taken
    as shadows) are free, i.e. completed. The normals are then ``b = L^+ A``.

    Wu et al.'s low-rank matrix is the Lambertian one, of rank 3. The nuclear norm alone does not
    enforce that on glossy data: with the default ``lam`` the recovered ``A`` keeps 4th-6th
    singular values of a few per cent of the first (the highlights leak into them, as on a
    render of the DiLiGenT bear) and the normals inherit the error. ``rank=3`` keeps only the
    three largest singular values in each singular-value shrinkage (the rank-constrained step of
    GoDec-style robust PCA), which removes it.

    Parameters
    ----------
    lam : weight of the sparse term; ``1 / sqrt(max(N, P))`` (Candès et al. 2011) by default.
    shadow_threshold : fraction of a pixel's maximum below which an observation is missing
        (a shadow, completed rather than fitted, as Wu et al. do); 0 keeps every observation.
    rank : the most singular values ``A`` keeps (3, the Lambertian rank, by default); ``None``
        solves the convex program alone.
    max_iterations, tol : stop when ``||D - A - E||_F <= tol ||D||_F`` or after the count
        (at most :data:`MAX_ITERATIONS`).
    callback : called as ``callback(iteration, max_iterations)`` after each iteration.

    Raises
    ------
    brdfkit.errors.ParameterError
        Bad images, lights or mask (see :func:`least_squares`), ``lam`` not finite and
        positive, ``tol`` not finite and >= 0, ``shadow_threshold`` outside [0, 1), ``rank``
        not a positive integer, or images that are zero inside the mask.
    brdfkit.errors.ResourceError
        ``max_iterations`` above :data:`MAX_ITERATIONS`, or data that would not fit in memory.

    References
    ----------
    L. Wu, A. Ganesh, B. Shi, Y. Matsushita, Y. Wang, Y. Ma, "Robust photometric stereo via
    low-rank matrix completion and recovery", ACCV 2010.
    Z. Lin, M. Chen, Y. Ma, "The augmented Lagrange multiplier method for exact recovery of
    corrupted low-rank matrices", arXiv:1009.5055, 2010.
    E. J. Candès, X. Li, Y. Ma, J. Wright, "Robust principal component analysis?", J. ACM 58(3),
    2011.
    T. Zhou, D. Tao, "GoDec: randomized low-rank & sparse matrix decomposition in noisy case",
    ICML 2011 (the rank-constrained low-rank step).
    """
    max_iterations = check_count("max_iterations", max_iterations, MAX_ITERATIONS)
    check_param("tol", tol, 0.0)
    if rank is not None:
        rank = check_count("rank", rank, MAX_ITERATIONS)
    observations, lights, mask = _prepare(images, light_directions, mask)
    if not 0 <= shadow_threshold < 1:
        raise ParameterError(f"shadow_threshold must be in [0, 1), got {shadow_threshold}")
    data = _gray(observations)
    if lam is None:
        lam = 1.0 / np.sqrt(max(data.shape))
    check_param("lam", lam, 0.0, lo_open=True)
    observed = data > shadow_threshold * data.max(axis=0, keepdims=True)
    data_norm = np.linalg.norm(data)
    from threadpoolctl import threadpool_limits

    from brdfkit.vision import _photometric_stereo_kernels

    with threadpool_limits(BLAS_THREADS, user_api="blas"):
        norm_two = np.sqrt(np.linalg.eigvalsh(data @ data.T)[-1])
        if norm_two == 0:
            raise ParameterError("images are all zero inside the mask")
        pixels = np.ascontiguousarray(data.T)  # (P, N): the per-pixel updates run on rows
        observed = np.ascontiguousarray(observed.T)
        dual = pixels / max(norm_two, np.abs(data).max() / lam)
        mu = 1.25 / norm_two
        mu_max = mu * 1e7
        sparse = np.zeros_like(pixels)
        matrix = pixels + dual / mu
        for iteration in range(max_iterations):
            left, right = _shrinkage_factors(matrix.T @ matrix, 1.0 / mu, rank)
            mu_next = min(mu * 1.5, mu_max)
            z = np.empty((len(pixels), left.shape[1]))  # M V_k, so A = z left^T
            gap2 = _photometric_stereo_kernels.rpca_step(
                pixels, sparse, dual, observed, left, right, mu, mu_next, lam, z, matrix
            )
            mu = mu_next
            if callback is not None:
                callback(iteration + 1, max_iterations)
            if np.sqrt(gap2) <= tol * data_norm:
                break
        b = (np.linalg.pinv(lights) @ left) @ z.T  # L^+ A
    return _result(b, observations, mask, _trim_weights(data, 0.25, 0.1))


METHODS: dict[str, Callable[..., PhotometricStereoResult]] = {
    "least_squares": least_squares,
    "trimmed": trimmed_least_squares,
    "sparse_regression": sparse_regression,
    "robust_pca": robust_pca,
}
"""The calibrated methods by name (the ``--method`` choices of ``brdfkit ps``)."""


# ----------------------------------------------------------------------------------------------
# Light calibration from a mirror sphere


def fit_circle(mask: ArrayLike) -> tuple[float, float, float]:
    """Centre and radius of the disc a sphere's mask covers (orthographic view).

    ``(c_x, c_y) = mean`` of the mask's pixel centres (column, row) and ``r = sqrt(A / pi)`` with
    ``A`` the mask's area in pixels: moment estimates that use every pixel, not just the
    boundary, so a ragged hand-drawn edge averages out.

    Returns
    -------
    (c_x, c_y, r) : centre column, centre row and radius, in pixels.

    References
    ----------
    R. Szeliski, *Computer Vision: Algorithms and Applications*, 2nd ed., 2022, §13.1 (chrome
    sphere calibration of photometric stereo).

    Examples
    --------
    >>> _, inside = sphere_normals((64, 64), centre=(30.0, 33.0), radius=20.0)
    >>> [round(value, 1) for value in fit_circle(inside)]  # the radius from the area
    [30.0, 33.0, 19.9]
    """
    mask = np.asarray(mask, dtype=bool)
    if mask.ndim != 2:
        raise ParameterError(f"mask must be a 2-D array, got shape {mask.shape}")
    rows, columns = np.nonzero(mask)
    if rows.size == 0:
        raise ParameterError("mask has no pixels set: cannot fit a circle")
    return float(columns.mean()), float(rows.mean()), float(np.sqrt(rows.size / np.pi))


def sphere_normals(
    shape: tuple[int, int], centre: tuple[float, float], radius: float
) -> tuple[np.ndarray, np.ndarray]:
    """Normals of a sphere seen orthographically, and the disc it covers.

    ``x = (u - c_x) / r``, ``y = -(v - c_y) / r`` (rows go down, y goes up),
    ``n = (x, y, sqrt(1 - x^2 - y^2))`` inside the disc ``x^2 + y^2 < 1``.

    Returns
    -------
    normals : (H, W, 3), zero outside the disc.
    inside : (H, W) bool.

    Raises
    ------
    brdfkit.errors.ParameterError
        ``radius`` not finite and positive, a non-finite ``centre``, or a bad ``shape``.
    brdfkit.errors.ResourceError
        More than :data:`MAX_PIXELS` pixels, or more than the memory available.

    References
    ----------
    B. K. P. Horn, *Robot Vision*, MIT Press 1986, ch. 10 (the Gaussian sphere).

    Examples
    --------
    >>> normals, inside = sphere_normals((5, 5), centre=(2.0, 2.0), radius=2.5)
    >>> inside.astype(int).tolist()
    [[0, 1, 1, 1, 0], [1, 1, 1, 1, 1], [1, 1, 1, 1, 1], [1, 1, 1, 1, 1], [0, 1, 1, 1, 0]]
    >>> normals[2, 2].tolist(), normals[0, 2].round(4).tolist()  # the centre; the top row: up
    ([0.0, -0.0, 1.0], [0.0, 0.8, 0.6])
    """
    check_param("radius", radius, 0.0, lo_open=True)
    if as_float_array("centre", centre).shape != (2,):
        raise ParameterError(f"centre must be (c_x, c_y); got {centre}")
    height, width = check_image_shape(shape, MAX_PIXELS)
    check_memory(f"sphere normals of shape {shape}", 6 * 8 * 3 * height * width)
    rows, columns = np.indices((height, width), dtype=np.float64)
    x = (columns - centre[0]) / radius
    y = -(rows - centre[1]) / radius
    rho2 = x**2 + y**2
    inside = rho2 < 1
    z = np.sqrt(np.clip(1 - rho2, 0, None))
    normals = np.where(inside[..., None], np.stack([x, y, z], axis=-1), 0.0)
    return normals, inside


def calibrate_lights_chrome_sphere(
    images: ArrayLike, mask: ArrayLike, *, threshold: float = 0.9
) -> np.ndarray:
    """Light directions from the highlights on a mirror (chrome) sphere.

    The sphere's centre and radius come from ``mask`` (:func:`fit_circle`). In each image the
    highlight is the set of mask pixels at least ``threshold`` times the image's brightest; the
    intensity-weighted mean of their sphere normals (:func:`sphere_normals`), normalised, is the
    normal ``n`` at the highlight (averaging normals rather than image positions avoids the
    bias of the foreshortened rim), and the
    light is the mirror reflection of the view direction ``v = (0, 0, 1)`` (orthographic
    camera) about it: ``l = 2 (n . v) n - v``.

    Parameters
    ----------
    images : (N, H, W) or (N, H, W, C) images of the sphere.
    mask : (H, W) bool, the sphere.
    threshold : relative brightness that selects the highlight, in (0, 1].

    Returns
    -------
    (N, 3) unit light directions (x right, y up, z towards the camera).

    Raises
    ------
    brdfkit.errors.ParameterError
        Shapes that disagree, NaN or infinity in ``images``, a ``threshold`` outside (0, 1],
        an empty mask, or an image with no highlight on the sphere.

    References
    ----------
    R. Szeliski, *Computer Vision: Algorithms and Applications*, 2nd ed., 2022, §13.1;
    W. Zhou, C. Kambhamettu, "Estimation of illuminant direction and intensity of multiple light
    sources", ECCV 2002.
    """
    if not 0 < threshold <= 1:
        raise ParameterError(f"threshold must be in (0, 1], got {threshold}")
    images = as_float_array("images", images)
    if images.ndim == 4:
        images = images.mean(axis=3)
    if images.ndim != 3:
        raise ParameterError(
            f"images must have shape (N, H, W) or (N, H, W, C), got {images.shape}"
        )
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != images.shape[1:]:
        raise ParameterError(f"mask must have shape {images.shape[1:]}, got shape {mask.shape}")
    c_x, c_y, radius = fit_circle(mask)
    gray = np.where(mask, images, 0.0)
    peak = gray.reshape(len(gray), -1).max(axis=1)
    if np.any(peak <= 0):
        raise ParameterError(f"no highlight on the sphere in image(s) {np.flatnonzero(peak <= 0)}")
    weight = np.where(gray >= threshold * peak[:, None, None], gray, 0.0)
    normals, _ = sphere_normals(mask.shape, (c_x, c_y), radius)
    normal = np.einsum("nhw,hwj->nj", weight, normals)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return 2 * normal[:, 2:3] * normal - np.array([0.0, 0.0, 1.0])
