r"""Non-Lambertian calibrated photometric stereo with isotropic bivariate reflectance models.

For an isotropic BRDF seen from a fixed view ``v = (0, 0, 1)`` under distant lights ``l_k``,
reflectance depends mostly on two angles of the half vector ``h_k = (l_k + v) / |l_k + v|``
(Romeiro, Vasilyev, Zickler 2008): ``cos θ_h = n·h_k`` and ``cos θ_d = l_k·h_k``; the
observation at a pixel is

.. math:: I_k = \max(0, n·l_k)\, \rho(\cos θ_{h,k}, \cos θ_{d,k}) \;(+ \text{noise, shadows}).

The methods here model ``ρ`` by a linear combination of ``K`` basis functions whose weights are
per pixel, so that for a candidate normal the weights follow by (non-negative) least squares
and the normal is the minimiser of the remaining residual (variable projection):

- :func:`bipolynomial` (Shi et al. 2014, "ST14"): ``ρ`` a bi-polynomial in ``cos θ_h`` and
  ``cos θ_d`` fitted to the *low-frequency* observations only (the brightest, specular spike,
  and the darkest, shadowed, are dropped by rank), the normal's azimuth that of the Lambertian
  start and its elevation found by a 1-D search, as in the paper;
- :func:`constrained_bivariate` (Ikehata & Aizawa 2014, "IA14"): the sum of two monotone,
  non-negative piecewise-linear functions of ``n·l`` and ``n·h`` fitted to every lit
  observation, highlights included;
- :func:`shared_bivariate` (Alldrin, Zickler, Kriegman 2008, "AZ08"): a non-parametric table
  ``ρ(θ_h, θ_d)`` shared by the whole object (per-pixel diffuse and specular weights),
  alternating with the normals.

IA14 and AZ08 search the normal alike: Levenberg–Marquardt on the two tangent coordinates of
the normal, the residual's Jacobian analytic (variable projection [6]_), every pixel on its
own until its step falls below :data:`STEP_TOLERANCE` (a compiled per-pixel kernel,
:mod:`brdfkit.vision._bivariate_stereo_kernels`, the pixels split over the cores; their readable
NumPy version, which the tests hold them to, is :mod:`brdfkit.vision.bivariate_reference`),
started from trimmed least squares. Observations darker than ``shadow_threshold`` times a
pixel's 90th-percentile observation are shadows and excluded; this selection does not depend on
the candidate normal, so costs stay comparable.

References
----------
.. [1] B. Shi, P. Tan, Y. Matsushita, K. Ikeuchi, "Bi-polynomial modeling of low-frequency
   reflectances", IEEE TPAMI 36(6), 2014.
.. [2] S. Ikehata, K. Aizawa, "Photometric stereo using constrained bivariate regression for
   general isotropic surfaces", CVPR 2014.
.. [3] N. Alldrin, T. Zickler, D. Kriegman, "Photometric stereo with non-parametric and
   spatially-varying reflectance", CVPR 2008.
.. [4] F. Romeiro, Y. Vasilyev, T. Zickler, "Passive reflectometry", ECCV 2008 (the bivariate
   approximation of isotropic BRDFs).
.. [5] B. Shi, Z. Mo, Z. Wu, D. Duan, S.-K. Yeung, P. Tan, "A benchmark dataset and evaluation
   for non-Lambertian and uncalibrated photometric stereo", IEEE TPAMI 41(2), 2019.
.. [6] G. H. Golub, V. Pereyra, "The differentiation of pseudo-inverses and nonlinear least
   squares problems whose variables separate", SIAM J. Numer. Anal. 10(2), 1973.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._checks import check_count
from brdfkit.errors import ParameterError
from brdfkit.vision.photometric_stereo import (
    BLAS_THREADS,
    Callback,
    PhotometricStereoResult,
    _gray,
    _prepare,
    _result,
    _weighted_least_squares,
)

MAX_ITERATIONS = 200
"""Largest ``iterations`` of the normal search."""

BEST_START_RING = np.radians(12.0)
"""Radius of the ring of 6 normals tried around the best start (:func:`_refine_normals`)."""

STEP_TOLERANCE = 1e-6
"""A pixel's normal search stops when its Levenberg–Marquardt step is below this, in radians
per tangent coordinate (2e-4°: far below any error the methods reach)."""

NO_PRODUCTS = np.empty((0, 6))
"""The ``products`` of a fit that keeps none: an empty array rather than ``None``, so that the
kernels are compiled once for both uses (a ``None`` is a type of its own to numba, and each
such signature costs seconds of compiling on a first run)."""


@dataclass(frozen=True)
class Basis:
    """A reflectance basis of ``size`` functions of ``(cos θ_i, cos θ_h, cos θ_d)``, cosine
    included, as the compiled kernels take it: ``kind`` (``_bivariate_stereo_kernels.BIPOLYNOMIAL``,
    ``RAMPS`` or ``TABLE``), integer parameters ``ints`` and float parameters ``fa``, ``fb``."""

    kind: int
    ints: np.ndarray
    fa: np.ndarray
    fb: np.ndarray
    size: int


_VIEW = np.array([0.0, 0.0, 1.0])


def _half_vectors(lights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit half vectors ``h_k`` of the lights and the view, and ``cos θ_d = l_k·h_k``."""
    half = lights + _VIEW
    half /= np.linalg.norm(half, axis=1, keepdims=True)
    return half, np.sum(lights * half, axis=1)


def _tangent_frame(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit tangents ``t_1, t_2`` orthogonal to each row of ``normals`` ``(P, 3)``."""
    helper = np.where(np.abs(normals[:, 2:3]) < 0.9, _VIEW, np.array([1.0, 0.0, 0.0]))
    t_1 = np.cross(normals, helper)
    t_1 /= np.linalg.norm(t_1, axis=1, keepdims=True)
    return t_1, np.cross(normals, t_1)


def _kernel_inputs(lights: np.ndarray, basis: Basis) -> tuple:
    """The light-side arguments of the :mod:`~brdfkit.vision._bivariate_stereo_kernels` fits:
    lights, half vectors, ``cos θ_d``, the table's ``θ_d`` node and fraction per light (zeros for
    the other bases), the basis, and whether the non-negative fits start from the pixel's previous
    active set (the ramps' 14 weights: fewer rounds; the table's 2 gain nothing, and cold starts
    keep the reference's answer also where ``ρ_s`` sits within the clamping tolerance of 0)."""
    from brdfkit.vision import _bivariate_stereo_kernels

    lights = np.ascontiguousarray(lights, dtype=np.float64)
    half, cos_theta_d = _half_vectors(lights)
    if basis.kind == _bivariate_stereo_kernels.TABLE:
        column, fraction = _bivariate_stereo_kernels.table_columns(cos_theta_d, int(basis.ints[1]))
    else:
        column, fraction = np.zeros(len(lights), np.int64), np.zeros(len(lights))
    warm = basis.kind == _bivariate_stereo_kernels.RAMPS
    return (
        lights, half, cos_theta_d, column, fraction, basis.kind, basis.ints, basis.fa, basis.fb,
        warm,
    )  # fmt: skip


def _residuals(
    normals: np.ndarray,
    gray: np.ndarray,
    weights: np.ndarray,
    lights: np.ndarray,
    basis: Basis,
    nonnegative: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """Weighted residuals ``(P, N)`` of the best reflectance for ``normals`` ``(P, 3)``, and the
    reflectance weights ``(P, K)``.

    Per pixel, the weights ``c`` minimise ``|sqrt(w) (I - D c)|^2`` (``D`` the ``(N, K)`` design
    of the basis, with a relative ridge of ``1e-9``); with ``nonnegative``, subject to
    ``c >= 0`` by an active-set iteration (Lawson & Hanson 1974, ch. 23): solve on the free
    variables, then clamp the most negative free one, or free the clamped one of steepest
    descent, until none changes (at most ``2 K`` rounds).
    """
    residual, coefficients, _ = _fit(normals, gray, weights, lights, basis, nonnegative)
    return residual, coefficients


def _fit(
    normals: np.ndarray,
    gray: np.ndarray,
    weights: np.ndarray,
    lights: np.ndarray,
    basis: Basis,
    nonnegative: bool,
    free: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_residuals` and the costs ``|residual|^2`` ``(P,)``; ``free`` ``(P, K)`` holds the
    active sets the non-negative fits start from, updated in place (by default all free)."""
    from brdfkit.vision import _bivariate_stereo_kernels

    if free is None:
        free = np.ones((len(gray), basis.size), dtype=bool)
    gray, weights = np.ascontiguousarray(gray), np.ascontiguousarray(weights)
    residual = np.empty(gray.shape)
    coefficients = np.empty((len(gray), basis.size))
    cost = _bivariate_stereo_kernels.fit_pixels(
        np.ascontiguousarray(normals, dtype=np.float64), gray, weights,
        *_kernel_inputs(lights, basis), nonnegative, residual, coefficients, free, NO_PRODUCTS,
    )  # fmt: skip
    return residual, coefficients, cost


def _refine_normals(
    normals: np.ndarray,
    gray: np.ndarray,
    weights: np.ndarray,
    lights: np.ndarray,
    basis: Basis,
    *,
    nonnegative: bool = False,
    iterations: int = 10,
    callback: Callback | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Levenberg–Marquardt on the tangent coordinates of every pixel's normal: the normals
    ``(P, 3)`` and their reflectance weights ``(P, K)`` (as :func:`_residuals` gives them).

    ``normals`` is ``(P, 3)``, or ``(S, P, 3)`` candidate starts: then each pixel starts from
    the candidate of least model cost, or from the best of it and a ring of 6 normals
    :data:`BEST_START_RING` around it (a coarse global step against the local minima a
    highlight puts near a biased least-squares start).

    ``n(u, v) = normalise(n + u t_1 + v t_2)``; the Jacobian of the variable-projection
    residual is analytic (:func:`~brdfkit.vision._bivariate_stereo_kernels._products`), computed
    from the fit that chose the start or accepted a normal and kept through rejected steps (the
    normal and residual did not change); a step (clipped to 0.2 per coordinate) is kept for the
    pixels whose cost falls, and their damping shrinks by 3 (grows by 4 otherwise; within
    [1e-7, 1e7], starting at 1e-3). A pixel stops when its step is below
    :data:`STEP_TOLERANCE`; the search ends after ``iterations`` or when every pixel stopped
    (``callback`` is called after each iteration run).
    """
    from brdfkit.vision import _bivariate_stereo_kernels

    gray, weights = np.ascontiguousarray(gray), np.ascontiguousarray(weights)
    free = np.ones((len(gray), basis.size), dtype=bool)  # each pixel's last active set
    inputs = _kernel_inputs(lights, basis)
    products = np.empty((len(gray), 6))  # J^T J, J^T r of the start's fit, then kept through
    # rejected steps
    if normals.ndim == 3:
        starts = np.ascontiguousarray(normals, dtype=np.float64)
        normals, residual, cost, coefficients = (
            np.empty((len(gray), 3)),
            np.empty(gray.shape),
            np.empty(len(gray)),
            np.empty((len(gray), basis.size)),
        )
        _bivariate_stereo_kernels.best_start(
            starts, BEST_START_RING, gray, weights, *inputs, nonnegative, normals, residual,
            cost, free, coefficients, True, products,
        )  # fmt: skip
    else:
        normals = np.array(normals, dtype=np.float64, order="C")
        residual, coefficients = np.empty(gray.shape), np.empty((len(gray), basis.size))
        cost = _bivariate_stereo_kernels.fit_pixels(
            normals, gray, weights, *inputs, nonnegative, residual, coefficients, free,
            products,
        )  # fmt: skip
    damping = np.full(len(normals), 1e-3)
    active = np.ones(len(normals), dtype=bool)
    for iteration in range(iterations):
        _bivariate_stereo_kernels.lm_step(
            normals, damping, residual, cost, active, free, gray, weights, *inputs,
            nonnegative, STEP_TOLERANCE, products, coefficients,
        )  # fmt: skip
        if callback is not None:
            callback(iteration + 1, iterations)
        if not active.any():
            break
    return normals, coefficients


def _reference(intensities: np.ndarray) -> np.ndarray:
    """Each pixel's reference brightness for the shadow test, ``(P,)`` from ``(P, N)``: its
    90th-percentile observation, not its brightest, so that a sharp highlight (tens of times
    the diffuse level) does not turn the diffuse observations into "shadows"."""
    return np.percentile(intensities, 90, axis=1)


def _ranks(gray: np.ndarray) -> np.ndarray:
    """Each observation's rank in its pixel ``(P, N)`` from ``gray`` ``(N, P)``, in the order
    :func:`~brdfkit.vision.photometric_stereo._trim_weights` sorts them (one sort for every
    trim of :func:`_trimmed`)."""
    order = np.argsort(gray.T, axis=1)
    ranks = np.empty_like(order)
    np.put_along_axis(ranks, order, np.arange(order.shape[1]), axis=1)
    return ranks


def _order(gray: np.ndarray, shadow_threshold: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The :func:`_ranks` ``(P, N)`` of ``gray`` ``(N, P)``, the shadow weights ``(P, N)`` of
    :func:`_start` (1 where brighter than ``shadow_threshold`` times the pixel's
    :func:`_reference`) and ``gray`` transposed to ``(P, N)`` (C order): the same numbers, in
    one pass of the compiled :func:`~brdfkit.vision._bivariate_stereo_kernels.order_statistics`
    (pixels over the cores; ranks counted, and those of pixels with equal observations, whose
    order NumPy's sort algorithm decides, by :func:`_ranks`)."""
    from brdfkit.vision import _bivariate_stereo_kernels

    if not 0 <= shadow_threshold < 1:
        raise ParameterError(f"shadow_threshold must be in [0, 1), got {shadow_threshold}")
    n_lights, n_pixels = gray.shape
    virtual = (n_lights - 1) * np.true_divide(90, 100)  # np.percentile's "linear" index
    previous = int(np.floor(virtual))
    ranks = np.empty((n_pixels, n_lights), dtype=np.intp)
    lit = np.empty((n_pixels, n_lights))
    tied = np.empty(n_pixels, dtype=bool)
    by_pixel = np.empty((n_pixels, n_lights))
    _bivariate_stereo_kernels.order_statistics(
        np.ascontiguousarray(gray), float(shadow_threshold), previous,
        float(virtual - previous), ranks, lit, tied, by_pixel,
    )  # fmt: skip
    if tied.any():
        ranks[tied] = _ranks(gray[:, tied])
    return ranks, lit, by_pixel


def _trimmed(ranks: np.ndarray, dark_fraction: float, bright_fraction: float) -> np.ndarray:
    """:func:`~brdfkit.vision.photometric_stereo._trim_weights` ``(N, P)`` from the
    :func:`_ranks` (the same weights; fractions already checked)."""
    n_lights = ranks.shape[1]
    n_dark = int(np.floor(dark_fraction * n_lights))
    n_bright = int(np.floor(bright_fraction * n_lights))
    return _rank_window(ranks, n_dark, n_bright)


def _rank_window(ranks: np.ndarray, n_dark: int, n_bright: int) -> np.ndarray:
    """Weights ``(N, P)``: 1 for the observations of rank in ``[n_dark, N - n_bright)``."""
    n_lights = ranks.shape[1]
    return ((ranks >= n_dark) & (ranks < n_lights - n_bright)).T.astype(np.float64)


def _start(
    gray: np.ndarray,
    lights: np.ndarray,
    shadow_threshold: float,
    ranks: np.ndarray | None = None,
    lit: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Shadow weights ``(P, N)`` (1 where brighter than ``shadow_threshold`` times the
    pixel's :func:`_reference`) and candidate start normals ``(S, P, 3)``: trimmed least
    squares (:func:`~brdfkit.vision.photometric_stereo._weighted_least_squares` on the
    :func:`_trimmed` weights, by the compiled
    :func:`~brdfkit.vision._bivariate_stereo_kernels.trimmed_starts`, pixels over the cores)
    dropping (dark, bright) fractions (0.25, 0.1), (0.25, 0.4) and (0.1, 0.6) of the observations (a
    broad lobe needs the last, a sharp one the first). ``ranks``, ``lit``: the :func:`_ranks`
    of ``gray`` and the shadow weights, if already known (:func:`_order` gives both)."""
    from brdfkit.vision import _bivariate_stereo_kernels

    if not 0 <= shadow_threshold < 1:
        raise ParameterError(f"shadow_threshold must be in [0, 1), got {shadow_threshold}")
    if lit is None:
        lit = (gray > shadow_threshold * _reference(gray.T)[None, :]).T.astype(np.float64)
    ranks = _ranks(gray) if ranks is None else ranks
    n_lights = len(lights)
    windows = []  # the ranks _trimmed keeps: [n_dark, N - n_bright)
    for dark, bright in ((0.25, 0.1), (0.25, 0.4), (0.1, 0.6)):
        n_dark, n_bright = int(np.floor(dark * n_lights)), int(np.floor(bright * n_lights))
        if n_lights - n_dark - n_bright >= 3:
            windows.append((n_dark, n_lights - n_bright))
    starts = np.empty((len(windows), gray.shape[1], 3))
    _bivariate_stereo_kernels.trimmed_starts(
        np.ascontiguousarray(gray), ranks, np.ascontiguousarray(lights, dtype=np.float64),
        np.array(windows, dtype=np.int64), starts,
    )  # fmt: skip
    return lit, starts


def _finish(
    normals: np.ndarray,
    gray: np.ndarray,
    weights: np.ndarray,
    lights: np.ndarray,
    observations: np.ndarray,
    mask: np.ndarray,
    ranks: np.ndarray | None = None,
) -> PhotometricStereoResult:
    """Result with the diffuse albedo ``ρ_d`` (the Lambertian fit of the darker half of the lit
    observations along the found normals) times the pixel's chromaticity; ``ranks``: the
    :func:`_ranks` of ``gray``, if already known."""
    from brdfkit.vision import _bivariate_stereo_kernels

    ranks = _ranks(gray) if ranks is None else ranks
    n_trim = int(np.floor(0.25 * len(lights)))  # ranks in [N/4, 3N/4): as _trimmed
    use = np.empty(ranks.shape)
    rho = _bivariate_stereo_kernels.diffuse_albedo(
        np.ascontiguousarray(normals, dtype=np.float64), np.ascontiguousarray(gray),
        np.ascontiguousarray(weights), np.ascontiguousarray(lights, dtype=np.float64), ranks,
        n_trim, n_trim, use,
    )  # fmt: skip
    return _result((normals * rho[:, None]).T, observations, mask, use.T)


def _check_iterations(iterations: int) -> int:
    return check_count("iterations", iterations, MAX_ITERATIONS)


def _blas_threads(method: Callable[..., PhotometricStereoResult]) -> Callable:
    """``method`` run with :data:`~brdfkit.vision.photometric_stereo.BLAS_THREADS` BLAS threads.

    Its BLAS products (channel means, the trimmed least-squares starts, the chromaticities) are
    ``(P, N)`` by ``(N, <= 9)``, which a second thread does not speed up; a threaded OpenBLAS
    spins after each call and then competes with the compiled kernels' threads for the cores
    (the numbers are the same on any count of threads)."""

    @functools.wraps(method)
    def run(*args, **kwargs) -> PhotometricStereoResult:
        from threadpoolctl import threadpool_limits

        with threadpool_limits(BLAS_THREADS, user_api="blas"):
            return method(*args, **kwargs)

    return run


# ----------------------------------------------------------------------------------------------
# Shi et al. 2014: bi-polynomial low-frequency reflectance


def _bipolynomial_basis(degree_h: int, degree_d: int) -> Basis:
    """``max(0, cos θ_i) max(0, cos θ_h)^a cos^b θ_d`` for ``a <= degree_h``, ``b <= degree_d``
    (index ``a (degree_d + 1) + b``)."""
    from brdfkit.vision import _bivariate_stereo_kernels

    size = (degree_h + 1) * (degree_d + 1)
    empty = np.zeros(1)
    return Basis(
        _bivariate_stereo_kernels.BIPOLYNOMIAL, np.array([degree_h, degree_d]), empty, empty, size
    )


MIN_KEPT = 18
"""Fewest observations per pixel :func:`bipolynomial`'s rank fractions leave by default (all of
them under fewer lights). Its 1-D search fits two coefficients and the elevation to the middle
ranks, whose span of ``n·l`` narrows as the lights thin out, so that noise moves the elevation.
On renders of a sphere under 16 to 48 DiLiGenT-like lights (matte and Blinn–Phong lobes of
exponent 20 to 200, with noise 0.005 and without), the mean error was least for 18 (0.89°,
against 1.11° for the fractions alone and 0.96° for 24); with noise keeping more helps, without
it fewer. The paper's fractions keep 18 or more from 42 lights up."""


def _low_frequency_window(
    n_lights: int, dark_fraction: float, bright_fraction: float, min_kept: int
) -> tuple[int, int]:
    """How many darkest and brightest observations :func:`bipolynomial` drops per pixel:
    ``floor(fraction N)`` each, both shrunk in their proportion where they would keep fewer
    than ``min(N, min_kept)``."""
    n_dark = int(np.floor(dark_fraction * n_lights))
    n_bright = int(np.floor(bright_fraction * n_lights))
    dropped = min(n_dark + n_bright, n_lights - min(n_lights, min_kept))
    if dropped < n_dark + n_bright:
        n_dark = dropped * n_dark // (n_dark + n_bright)
        n_bright = dropped - n_dark
    return n_dark, n_bright


ELEVATION_GRID = np.radians(1.0)
"""Step of the first pass of :func:`bipolynomial`'s elevation search (each later round searches
±1 step of the previous one at a tenth of it)."""


def _elevation_normals(elevation: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    """Unit normals ``(P, 3)`` of elevation ``θ`` (from the view axis) and azimuth ``φ``:
    ``(sin θ cos φ, sin θ sin φ, cos θ)``."""
    sin = np.sin(elevation)
    return np.stack([sin * np.cos(azimuth), sin * np.sin(azimuth), np.cos(elevation)], axis=1)


def _elevation_search(
    azimuth: np.ndarray,
    gray: np.ndarray,
    weights: np.ndarray,
    lights: np.ndarray,
    basis: Basis,
    rounds: int,
    callback: Callback | None,
) -> np.ndarray:
    """Per pixel, the elevation ``θ`` in ``[0, π/2]`` of least bi-polynomial residual at the
    fixed ``azimuth`` ``(P,)``: a grid of :data:`ELEVATION_GRID`, then ``rounds`` rounds of ±1
    step at a tenth of the last step around the best so far; the normals ``(P, 3)``."""
    n_grid = round(np.pi / 2 / ELEVATION_GRID) + 1
    best = np.zeros(len(azimuth))
    lowest = np.full(len(azimuth), np.inf)
    offsets, step = np.linspace(0.0, np.pi / 2, n_grid), ELEVATION_GRID
    centre = np.zeros(len(azimuth))
    for round_ in range(rounds + 1):
        for offset in offsets:
            elevation = np.clip(centre + offset, 0.0, np.pi / 2)
            _, _, cost = _fit(
                _elevation_normals(elevation, azimuth), gray, weights, lights, basis, False
            )
            better = cost < lowest
            best[better], lowest[better] = elevation[better], cost[better]
        if callback is not None:
            callback(round_ + 1, rounds + 1)
        step /= 10
        offsets, centre = np.arange(-10, 11) * step, best.copy()
    return _elevation_normals(best, azimuth)


@_blas_threads
def bipolynomial(
    images: ArrayLike,
    light_directions: ArrayLike,
    mask: ArrayLike | None = None,
    *,
    degree: tuple[int, int] = (1, 0),
    dark_fraction: float = 0.3,
    bright_fraction: float = 0.3,
    min_kept: int = MIN_KEPT,
    shadow_threshold: float = 0.05,
    iterations: int = 2,
    callback: Callback | None = None,
) -> PhotometricStereoResult:
    r"""Photometric stereo with a bi-polynomial low-frequency reflectance (Shi et al. 2014).

    The low-frequency part of an isotropic BRDF — what remains once the specular spike and the
    shadows are removed — is a bi-polynomial of the cosines of the half-vector angle
    ``θ_h`` (``cos θ_h = n·h``) and the difference angle ``θ_d`` (``cos θ_d = l·h``)::

        I_k = max(0, n·l_k) Σ_{a <= A, b <= B} c_ab (n·h_k)^a (l_k·h_k)^b,

    with the coefficients ``c`` per pixel, linear given the normal. Shi et al.'s photometric
    stereo, step by step:

    1. *Low-frequency observations by rank*: per pixel the ``bright_fraction`` brightest
       observations (the specular spike) and the ``dark_fraction`` darkest (attached and cast
       shadows) are dropped, fewer where that would keep fewer than ``min_kept`` (under sparse
       lights the middle ranks span too little of ``n·l`` to fix the elevation; see
       :data:`MIN_KEPT`); so is anything below ``shadow_threshold`` times the pixel's 90th
       percentile (cast shadows beyond the dark fraction).
    2. *Initial normal*: Lambertian least squares on those observations.
    3. *Azimuth from the initial normal*: for an isotropic BRDF seen along ``v`` a highlight
       lies where ``h`` is near ``n``, i.e. at lights of the normal's own azimuth, so what it
       leaves in the Lambertian estimate is an error in elevation; the azimuth ``φ`` is kept.
    4. *1-D search of the elevation*: ``n(θ) = (sin θ cos φ, sin θ sin φ, cos θ)``, ``θ`` on
       a 1° grid over ``[0°, 90°]`` and ``iterations`` finer rounds (0.1°, 0.01°, …); at each
       ``θ`` the coefficients follow by least squares and ``θ`` minimises the residual.

    ``l·h`` is fixed by the light and the view, not the normal; under DiLiGenT's lights it
    spans only [0.87, 1], where its powers are nearly collinear with the ``n·h`` terms and give
    the residual a second, wrong minimum (measured with ``(3, 1)``: 2 to 20 times the error of
    ``(1, 0)`` on the renders of ``benchmarks/bench_bipolynomial.py``), hence the default
    ``(A, B) = (1, 0)``.

    Claims (tested): noise-free Lambertian data is recovered exactly (the model holds with
    ``c = (ρ, 0, …)``); on a glossy sphere (Lambertian plus Blinn–Phong) under 96
    DiLiGenT-like lights the error is a fraction of least squares'.

    Parameters
    ----------
    images, light_directions, mask : as :func:`~brdfkit.vision.photometric_stereo.least_squares`.
    degree : ``(A, B)``, the orders in ``n·h`` and ``l·h``.
    dark_fraction, bright_fraction : fractions of each pixel's darkest and brightest
        observations dropped, in [0, 1).
    min_kept : the fractions drop fewer observations, in their proportion, where they would
        keep fewer than this (all of them under at most ``min_kept`` lights); 0 keeps the
        fractions as they are.
    shadow_threshold : fraction of a pixel's 90th-percentile observation below which an
        observation is a shadow, in [0, 1).
    iterations : finer rounds of the elevation search after the 1° grid (1 …
        :data:`MAX_ITERATIONS`; 2 reaches 0.01°).
    callback : ``callback(round, rounds)`` after each round of the search.

    Raises
    ------
    brdfkit.errors.ParameterError
        Bad images, lights or mask; a ``degree`` of negative orders or with more coefficients
        than the observations kept; fractions outside [0, 1).
    brdfkit.errors.ResourceError
        ``iterations`` above :data:`MAX_ITERATIONS`, or data that would not fit in memory.

    References
    ----------
    B. Shi, P. Tan, Y. Matsushita, K. Ikeuchi, "Bi-polynomial modeling of low-frequency
    reflectances", IEEE TPAMI 36(6), 2014.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.vision import datasets
    >>> from brdfkit.vision.bivariate_stereo import bipolynomial
    >>> from brdfkit.vision.metrics import angular_error
    >>> from brdfkit.vision.photometric_stereo import sphere_normals
    >>> normals, mask = sphere_normals((16, 16), (7.5, 7.5), 7.0)
    >>> data = datasets.render_synthetic(
    ...     normals, mask, datasets.diligent_like_lights(), albedo=0.5, specular=0.5,
    ...     shininess=20.0)
    >>> result = bipolynomial(data.images, data.light_directions, data.mask)
    >>> bool(angular_error(result.normals, normals, mask)["median"] < 1.0)
    True
    """
    iterations = _check_iterations(iterations)
    observations, lights, mask = _prepare(images, light_directions, mask)
    gray = _gray(observations)
    n_lights = len(lights)
    for name, value in (("dark_fraction", dark_fraction), ("bright_fraction", bright_fraction)):
        if not 0 <= value < 1:
            raise ParameterError(f"{name} must be in [0, 1), got {value}")
    if isinstance(min_kept, bool) or not isinstance(min_kept, (int, np.integer)) or min_kept < 0:
        raise ParameterError(f"min_kept must be a non-negative integer, got {min_kept!r}")
    n_dark, n_bright = _low_frequency_window(n_lights, dark_fraction, bright_fraction, min_kept)
    kept = n_lights - n_dark - n_bright
    if len(degree) != 2 or any(int(d) != d or d < 0 for d in degree):
        raise ParameterError(f"degree must be two non-negative integers (A, B), got {degree}")
    n_terms = (degree[0] + 1) * (degree[1] + 1)
    if kept < max(n_terms + 2, 3):
        raise ParameterError(
            f"degree={tuple(degree)} has {n_terms} coefficients but dark_fraction="
            f"{dark_fraction} and bright_fraction={bright_fraction} keep {kept} of {n_lights} "
            f"observations; need at least {max(n_terms + 2, 3)}: lower the degree or the "
            "fractions"
        )
    ranks, lit, by_pixel = _order(gray, shadow_threshold)
    low_frequency = lit * _rank_window(ranks, n_dark, n_bright).T
    start = _weighted_least_squares(gray, lights, low_frequency.T)
    azimuth = np.arctan2(start[1], start[0])
    basis = _bipolynomial_basis(int(degree[0]), int(degree[1]))
    normals = _elevation_search(
        azimuth, by_pixel, low_frequency, lights, basis, iterations, callback
    )
    return _finish(normals, gray, low_frequency, lights, observations, mask, ranks)


# ----------------------------------------------------------------------------------------------
# Ikehata & Aizawa 2014: constrained bivariate regression


def _sum_of_lobes_basis(knots_i: np.ndarray, knots_h: np.ndarray) -> Basis:
    """``(ramps(n·l), [n·l > 0] ramps(n·h))``: ``g(n·l) + s(n·h)`` with monotone ``g, s``.

    The ramps on knots ``t`` are ``clip((x - t_m) / (t_{m+1} - t_m), 0, 1)``, ``m < M - 1``:
    with non-negative weights their sums are the monotone non-decreasing piecewise-linear
    functions on the knots that vanish below the first."""
    from brdfkit.vision import _bivariate_stereo_kernels

    size = len(knots_i) - 1 + len(knots_h) - 1
    knots_i, knots_h = (np.asarray(k, dtype=np.float64) for k in (knots_i, knots_h))
    return Basis(
        _bivariate_stereo_kernels.RAMPS, np.zeros(2, dtype=np.int64), knots_i, knots_h, size
    )


@_blas_threads
def constrained_bivariate(
    images: ArrayLike,
    light_directions: ArrayLike,
    mask: ArrayLike | None = None,
    *,
    knots: int | None = None,
    shadow_threshold: float = 0.05,
    iterations: int = 12,
    callback: Callback | None = None,
) -> PhotometricStereoResult:
    r"""Photometric stereo by constrained bivariate regression (Ikehata & Aizawa 2014).

    The radiance of an isotropic surface is written as a sum of two lobes, each a monotone
    non-decreasing, non-negative function of one cosine::

        I_k = [n·l_k > 0] ( g(n·l_k) + s(n·h_k) ),   g(0) = 0,

    ``g`` the diffuse-like lobe, ``s`` the specular lobe, both piecewise linear on ``knots``
    knots (``g`` uniform in ``n·l`` on [0, 1]; ``s`` uniform in ``θ_h`` on [0°, 90°], denser
    near the mirror direction in ``n·h``) with non-negative increments: the monotonicity and
    non-negativity constraints that make the regression well posed. Every observation brighter
    than ``shadow_threshold`` times the pixel's 90th percentile is used, highlights included; the
    weights follow by non-negative least squares (batched projected gradient) for each
    candidate normal, the normal by the search of the module docstring.

    Parameters
    ----------
    images, light_directions, mask : as :func:`~brdfkit.vision.photometric_stereo.least_squares`.
    knots : knots per lobe, 3 … 32; by default ``min(8, N // 4 + 1)`` for ``N`` lights (8
        at DiLiGenT's 96; fewer lights afford fewer weights).
    shadow_threshold : fraction of a pixel's 90th-percentile observation below which an
        observation is a shadow.
    iterations : Levenberg–Marquardt iterations (1 … :data:`MAX_ITERATIONS`).
    callback : ``callback(iteration, iterations)`` after each iteration.

    Raises
    ------
    brdfkit.errors.ParameterError
        Bad images, lights or mask; ``knots`` outside 3 … 32 or ``2 (knots - 1) + 2`` above the
        number of lights; ``shadow_threshold`` outside [0, 1).
    brdfkit.errors.ResourceError
        ``iterations`` above :data:`MAX_ITERATIONS`, or data that would not fit in memory.

    References
    ----------
    S. Ikehata, K. Aizawa, "Photometric stereo using constrained bivariate regression for
    general isotropic surfaces", CVPR 2014.
    """
    iterations = _check_iterations(iterations)
    observations, lights, mask = _prepare(images, light_directions, mask)
    if knots is None:
        knots = max(3, min(8, len(lights) // 4 + 1))
    knots = check_count("knots", knots, 32, minimum=3)
    if 2 * (knots - 1) + 2 > len(lights):
        raise ParameterError(
            f"knots={knots} gives {2 * (knots - 1)} weights per pixel, too many for "
            f"{len(lights)} lights; use knots <= {max((len(lights) - 2) // 2 + 1, 1)}"
        )
    gray = _gray(observations)
    ranks, lit, by_pixel = _order(gray, shadow_threshold)
    lit, normals = _start(gray, lights, shadow_threshold, ranks, lit)
    knots_i = np.linspace(0.0, 1.0, knots)
    knots_h = np.cos(np.linspace(np.pi / 2, 0.0, knots))
    basis = _sum_of_lobes_basis(knots_i, knots_h)
    normals, _ = _refine_normals(
        normals,
        by_pixel,
        lit,
        lights,
        basis,
        nonnegative=True,
        iterations=iterations,
        callback=callback,
    )
    return _finish(normals, gray, lit, lights, observations, mask, ranks)


# ----------------------------------------------------------------------------------------------
# Alldrin, Zickler & Kriegman 2008: a non-parametric bivariate BRDF shared by the object


class _Table:
    """A table ``T(θ_h, θ_d)`` on ``[0, π/2]²`` with bilinear interpolation; the ``θ_h`` axis is
    uniform in ``sqrt(θ_h)`` (fine near the mirror direction, where lobes are narrow)."""

    def __init__(self, n_h: int, n_d: int) -> None:
        self.n_h, self.n_d = n_h, n_d
        self.values = np.zeros(n_h * n_d)

    def weights(
        self, cos_h: np.ndarray, cos_d: np.ndarray
    ) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """The 4 flat indices and bilinear weights of each ``(cos θ_h, cos θ_d)``."""
        u = np.sqrt(np.arccos(np.clip(cos_h, 0.0, 1.0)) / (np.pi / 2)) * (self.n_h - 1)
        w = np.arccos(np.clip(cos_d, 0.0, 1.0)) / (np.pi / 2) * (self.n_d - 1)
        i = np.minimum(np.floor(u).astype(np.intp), self.n_h - 2)
        j = np.minimum(np.floor(w).astype(np.intp), self.n_d - 2)
        fu, fw = u - i, w - j
        index = [i * self.n_d + j, (i + 1) * self.n_d + j, i * self.n_d + j + 1]
        index.append((i + 1) * self.n_d + j + 1)
        weight = [(1 - fu) * (1 - fw), fu * (1 - fw), (1 - fu) * fw, fu * fw]
        return index, weight


def _shared_basis(table: _Table) -> Basis:
    """``max(0, n·l) (1, T(θ_h, θ_d))``: per-pixel diffuse and specular weights (the table's
    current values)."""
    from brdfkit.vision import _bivariate_stereo_kernels

    ints = np.array([table.n_h, table.n_d])
    return Basis(
        _bivariate_stereo_kernels.TABLE, ints, np.asarray(table.values, np.float64), np.zeros(1), 2
    )


def _smoothed_solution(
    normal_matrix, rhs: np.ndarray, n_h: int, n_d: int, smoothness: float
) -> np.ndarray:
    """The ``(n_h n_d,)`` table values solving the normal equations ``normal_matrix`` (sparse)
    and ``rhs`` plus a second-difference penalty along both axes of the ``(n_h, n_d)`` grid,
    weighted by ``smoothness`` times the data term's mean diagonal (and a ``1e-9`` ridge);
    clipped at 0 and scaled to a maximum of 1."""
    from scipy import sparse
    from scipy.sparse.linalg import spsolve

    size = n_h * n_d
    grid = np.arange(size).reshape(n_h, n_d)
    differences = []
    for axis in (0, 1):
        a, b, c = (
            np.take(grid, range(k, grid.shape[axis] - 2 + k), axis).ravel() for k in (0, 1, 2)
        )
        m = len(a)
        differences.append(
            sparse.coo_matrix(
                (
                    np.tile([1.0, -2.0, 1.0], m),
                    (np.repeat(np.arange(m), 3), np.stack([a, b, c], 1).ravel()),
                ),
                (m, size),
            )
        )
    penalty = sparse.vstack(differences).tocsr()
    level = normal_matrix.diagonal().mean() + 1e-300
    system = (
        normal_matrix + smoothness * level * (penalty.T @ penalty) + 1e-9 * level * sparse.eye(size)
    )
    values = np.clip(spsolve(system.tocsc(), rhs), 0.0, None)
    peak = values.max()
    return values / peak if peak > 0 else values


def _fit_table(
    table: _Table,
    normals: np.ndarray,
    gray: np.ndarray,
    weights: np.ndarray,
    lights: np.ndarray,
    coefficients: np.ndarray,
    smoothness: float,
) -> None:
    """Least-squares table given normals and per-pixel ``(ρ_d, ρ_s)``, with a second-difference
    smoothness penalty ``smoothness`` (relative to the data term's scale); clipped at 0 and
    scaled to a maximum of 1 (the scale is the pixels' ``ρ_s``)."""
    import numba
    from scipy import sparse

    from brdfkit.vision import _bivariate_stereo_kernels

    lights = np.ascontiguousarray(lights, dtype=np.float64)
    half, cos_theta_d = _half_vectors(lights)
    column, fraction = _bivariate_stereo_kernels.table_columns(cos_theta_d, table.n_d)
    bands, rhs = _bivariate_stereo_kernels.table_normal_equations(
        np.ascontiguousarray(normals, dtype=np.float64),
        np.ascontiguousarray(gray),
        np.ascontiguousarray(weights),
        lights,
        half,
        column,
        fraction,
        table.n_h,
        table.n_d,
        np.ascontiguousarray(coefficients, dtype=np.float64),
        max(1, min(4 * numba.get_num_threads(), len(normals))),  # parallel partial sums
    )
    bands, rhs = bands.sum(axis=0), rhs.sum(axis=0)
    size = table.n_h * table.n_d
    i, j = np.divmod(np.arange(size), table.n_d)
    rows, cols, values = [], [], []
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            inside = (0 <= i + di) & (i + di < table.n_h) & (0 <= j + dj) & (j + dj < table.n_d)
            rows.append(np.flatnonzero(inside))
            cols.append(rows[-1] + di * table.n_d + dj)
            values.append(bands[inside, 1 + di, 1 + dj])
    normal_matrix = sparse.coo_matrix(
        (np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))), (size, size)
    ).tocsr()
    table.values = _smoothed_solution(normal_matrix, rhs, table.n_h, table.n_d, smoothness)


@_blas_threads
def shared_bivariate(
    images: ArrayLike,
    light_directions: ArrayLike,
    mask: ArrayLike | None = None,
    *,
    bins: tuple[int, int] = (24, 6),
    smoothness: float = 1e-2,
    rounds: int = 3,
    shadow_threshold: float = 0.05,
    iterations: int = 6,
    callback: Callback | None = None,
) -> PhotometricStereoResult:
    r"""Photometric stereo with a non-parametric bivariate BRDF shared by the object (AZ08).

    The object's reflectance is a Lambertian term plus one tabulated isotropic lobe
    ``T(θ_h, θ_d)`` common to every pixel, each pixel with its own non-negative weights::

        I_k = max(0, n·l_k) ( ρ_d + ρ_s T(θ_h,k, θ_d,k) ),

    ``T`` a non-negative table of ``bins = (n_h, n_d)`` nodes (bilinear, ``sqrt(θ_h)``-uniform)
    regularised by second differences. Alldrin et al.'s alternation: with the normals fixed, the
    weights (non-negative least squares per pixel) and the table (one sparse least-squares
    solve over the whole object); with the reflectance fixed, the normals (the search of the
    module docstring); ``rounds`` times, from trimmed least squares and a Gaussian lobe.

    Parameters
    ----------
    images, light_directions, mask : as :func:`~brdfkit.vision.photometric_stereo.least_squares`.
    bins : table nodes in ``θ_h`` and ``θ_d`` (2 … 256 each).
    smoothness : weight of the second-difference penalty relative to the data term (>= 0).
    rounds : alternations (1 … 50).
    shadow_threshold : fraction of a pixel's 90th-percentile observation below which an
        observation is a shadow.
    iterations : normal-search iterations per round (1 … :data:`MAX_ITERATIONS`).
    callback : ``callback(round, rounds)`` after each round.

    Raises
    ------
    brdfkit.errors.ParameterError
        Bad images, lights or mask, or parameters outside the ranges above.
    brdfkit.errors.ResourceError
        Counts above their maxima, or data that would not fit in memory.

    References
    ----------
    N. Alldrin, T. Zickler, D. Kriegman, "Photometric stereo with non-parametric and
    spatially-varying reflectance", CVPR 2008 (their method mixes several such tables per
    pixel; here one lobe plus the Lambertian term, the common case of a dielectric object).
    """
    iterations = _check_iterations(iterations)
    rounds = check_count("rounds", rounds, 50)
    n_h, n_d = (check_count(f"bins[{k}]", int(b), 256, minimum=2) for k, b in enumerate(bins))
    if not (np.isfinite(smoothness) and smoothness >= 0):
        raise ParameterError(f"smoothness must be finite and >= 0, got {smoothness}")
    observations, lights, mask = _prepare(images, light_directions, mask)
    gray = _gray(observations)
    ranks, lit, by_pixel = _order(gray, shadow_threshold)
    lit, starts = _start(gray, lights, shadow_threshold, ranks, lit)
    normals = starts[-1]
    table = _Table(n_h, n_d)
    theta_h = (np.linspace(0.0, 1.0, n_h) ** 2) * (np.pi / 2)
    table.values = np.repeat(np.exp(-((theta_h / np.radians(10.0)) ** 2)), n_d)
    _, coefficients = _residuals(normals, by_pixel, lit, lights, _shared_basis(table), True)
    for round_ in range(rounds):
        _fit_table(table, normals, by_pixel, lit, lights, coefficients, smoothness)
        # the search's weights are those of its normals under the table it used (cold-started
        # fits: what a refit would give), the next round's input
        normals, coefficients = _refine_normals(
            starts if round_ == 0 else normals,
            by_pixel,
            lit,
            lights,
            _shared_basis(table),
            nonnegative=True,
            iterations=iterations,
        )
        if callback is not None:
            callback(round_ + 1, rounds)
    return _finish(normals, gray, lit, lights, observations, mask, ranks)


METHODS: dict[str, Callable[..., PhotometricStereoResult]] = {
    "bipolynomial": bipolynomial,
    "constrained_bivariate": constrained_bivariate,
    "shared_bivariate": shared_bivariate,
}
"""The bivariate-reflectance methods by name (``--method`` choices of ``brdfkit ps``)."""
