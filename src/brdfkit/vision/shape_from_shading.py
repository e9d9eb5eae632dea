r"""Shape from shading: depth and normals of a Lambertian surface from one image.

The image of a Lambertian surface :math:`z(x, y)` of constant albedo under a distant light
``l`` seen orthographically along −z is its reflectance map (Horn 1970, 1977)

.. math:: I(x, y) = \rho\,\max\!\Big(0, \frac{-p\,l_x - q\,l_y + l_z}{\sqrt{1 + p^2 + q^2}}\Big),
          \qquad p = z_x,\ q = z_y,\ n = \frac{(-p, -q, 1)}{\sqrt{1 + p^2 + q^2}},

one equation for two unknown slopes per pixel. Horn's variational approach (Horn & Brooks
1986; Horn 1989) makes it well posed by minimising the brightness error plus a smoothness
term, and Horn (1989) couples the slopes to a depth map so that they are integrable. Here the
unknown *is* the depth, so integrability holds by construction, and the energy

.. math:: \mathcal E(z) = \sum_{\text{cells}} \big(R(p, q) - I\big)^2
          + \lambda \sum_{\text{pixels}} (\Delta z)^2

(p, q and I at the centre of every 2 × 2 block of pixels inside the mask; Δ the 5-point
Laplacian, Horn's "departure from smoothness" of the slopes) is minimised as a sparse non-linear
least-squares problem (trust-region Gauss–Newton with the exact Jacobian, ``scipy.optimize.
least_squares``), which converges in tens of iterations where Horn's own relaxation needs
thousands. Above 4096 mask pixels the start comes from the solution at half the resolution
(recursively, cascadic multigrid), and the finer levels take a few Levenberg–Marquardt steps
on the assembled sparse normal matrix, solved by Jacobi-preconditioned conjugate gradients with
NumPy reductions (BLAS's threaded dot products spin on shared cores), so the cost grows about
linearly with the pixels (see ``benchmarks/bench_sfs.py``). Like every variational SfS method
it needs a start on the right side of the convex/concave ambiguity: by default a tent ``z₀ ∝``
the distance to the mask's boundary (objects bulge towards the viewer inside their occluding
contour, Ikeuchi & Horn 1981).

Accuracy (48-pixel renders, λ = 1e-4; mean / median normal error, depth RMSE over its range):
a sphere under a frontal light 0.65° / 0.22° / 0.09 %, under a light 17° off the view 3.8° /
1.1° / 3.3 %; a vase frontal 2.2° / 0.7° / 1.6 %, oblique 9.6° / 5.7° / 9 % (its concave neck
is on the wrong side of the convex start); the real psm gray sphere (light ≈ 6° off the view)
7.2° / 6.0°. Larger λ flattens strongly curved parts; λ = 0 leaves the problem ill-posed.

Frame (as :mod:`brdfkit.vision`): x right, y up, z towards the camera; pixel spacing is the
unit of x, y *and* z, so a sphere of radius r pixels comes back r pixels deep. Rows go down.

References
----------
.. [1] B. K. P. Horn, "Height and gradient from shading", IJCV 5(1), 1990, pp. 37–75 (MIT AI
   Memo 1105, 1989).
.. [2] B. K. P. Horn and M. J. Brooks, "The variational approach to shape from shading",
   CVGIP 33(2), 1986, pp. 174–208.
.. [3] K. Ikeuchi and B. K. P. Horn, "Numerical shape from shading and occluding boundaries",
   Artificial Intelligence 17, 1981, pp. 141–184.
.. [4] R. Zhang, P.-S. Tsai, J. E. Cryer and M. Shah, "Shape from shading: a survey", IEEE
   TPAMI 21(8), 1999, pp. 690–706.
.. [5] M. A. Branch, T. F. Coleman and Y. Li, "A subspace, interior, and conjugate gradient
   method for large-scale bound-constrained minimization problems", SIAM J. Sci. Comput. 21(1),
   1999 (the trust-region reflective solver).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._array import check_param
from brdfkit._checks import as_float_array, check_count
from brdfkit.errors import ParameterError, ResourceError

__all__ = ["MAX_ITERATIONS", "MAX_PIXELS", "ShapeFromShading", "shape_from_shading"]

MAX_ITERATIONS = 100_000
"""Largest ``max_iterations`` of :func:`shape_from_shading`."""

_CG_ITERATIONS = 60
"""Conjugate-gradient iterations per Levenberg–Marquardt step of :func:`_solve_large`."""

_FINE_ITERATIONS = 12
"""Residual evaluations at each level above the coarsest of the cascade."""

_COARSE = 4096
"""Mask pixels above which the start comes from the half-resolution solution."""

MAX_PIXELS = 2**18
"""Most mask pixels :func:`shape_from_shading` solves for (512 × 512; downsample larger
images)."""


@dataclass(frozen=True)
class ShapeFromShading:
    """Result of :func:`shape_from_shading`.

    Attributes
    ----------
    depth : (H, W) height towards the camera in pixel units, 0 at the lowest mask pixel,
        NaN outside the mask.
    normals : (H, W, 3) unit normals from the depth (x right, y up, z towards the camera),
        zero outside the mask.
    albedo : the ρ used (given, or estimated as the brightest value).
    iterations : evaluations of the residuals (Gauss–Newton steps tried).
    rms : RMS brightness residual over the cells, relative to ρ.
    """

    depth: np.ndarray
    normals: np.ndarray
    albedo: float
    iterations: int
    rms: float


def _operators(mask: np.ndarray):
    """Sparse maps from the mask pixels' depths to cell slopes p, q, and the Laplacian."""
    from scipy import sparse

    index = -np.ones(mask.shape, dtype=np.int64)
    index[mask] = np.arange(mask.sum())
    # Cells: 2×2 blocks (i, j), (i, j+1), (i+1, j), (i+1, j+1) all inside the mask.
    cell = mask[:-1, :-1] & mask[:-1, 1:] & mask[1:, :-1] & mask[1:, 1:]
    ci, cj = np.nonzero(cell)
    top_left, top_right = index[ci, cj], index[ci, cj + 1]
    bottom_left, bottom_right = index[ci + 1, cj], index[ci + 1, cj + 1]
    rows = np.repeat(np.arange(ci.size), 4)
    n = int(mask.sum())
    corners = np.stack([top_left, top_right, bottom_left, bottom_right], axis=1).ravel()
    # p = ∂z/∂x (columns), q = ∂z/∂y with y up (rows go down), averaged over the two edges.
    d_x = sparse.csr_matrix(
        (np.tile([-0.5, 0.5, -0.5, 0.5], ci.size), (rows, corners)), shape=(ci.size, n)
    )
    d_y = sparse.csr_matrix(
        (np.tile([0.5, 0.5, -0.5, -0.5], ci.size), (rows, corners)), shape=(ci.size, n)
    )
    average = sparse.csr_matrix((np.full(4 * ci.size, 0.25), (rows, corners)), shape=(ci.size, n))
    # 5-point Laplacian at pixels whose 4 neighbours are all in the mask.
    inner = mask.copy()
    inner[0, :] = inner[-1, :] = inner[:, 0] = inner[:, -1] = False
    inner &= np.roll(mask, 1, 0) & np.roll(mask, -1, 0) & np.roll(mask, 1, 1) & np.roll(mask, -1, 1)
    li, lj = np.nonzero(inner)
    neighbours = [index[li, lj], index[li - 1, lj], index[li + 1, lj], index[li, lj - 1]]
    neighbours.append(index[li, lj + 1])
    laplacian = sparse.csr_matrix(
        (
            np.tile([-4.0, 1.0, 1.0, 1.0, 1.0], li.size),
            (np.repeat(np.arange(li.size), 5), np.stack(neighbours, axis=1).ravel()),
        ),
        shape=(li.size, n),
    )
    return d_x, d_y, average, laplacian


def _normals_from_depth(depth: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Unit normals ``(−z_x, −z_y, 1)/|…|`` by central differences (one-sided at the mask edge)."""
    z = np.where(mask, depth, np.nan)

    def slope(forward: np.ndarray, backward: np.ndarray) -> np.ndarray:
        mean = np.where(
            np.isnan(forward),
            backward,
            np.where(np.isnan(backward), forward, (forward + backward) / 2),
        )
        return np.nan_to_num(mean)

    pad = np.pad(z, 1, constant_values=np.nan)
    z_x = slope(pad[1:-1, 2:] - z, z - pad[1:-1, :-2])
    z_y = slope(pad[:-2, 1:-1] - z, z - pad[2:, 1:-1])
    normals = np.stack([-z_x, -z_y, np.ones_like(z_x)], axis=-1)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    return np.where(mask[..., None], normals, 0.0)


def shape_from_shading(
    image: ArrayLike,
    light: ArrayLike,
    mask: ArrayLike | None = None,
    *,
    albedo: float | None = None,
    smoothness: float = 1e-4,
    initial_depth: ArrayLike | None = None,
    max_iterations: int = 200,
) -> ShapeFromShading:
    r"""Depth and normals of a Lambertian surface under a known distant light (Horn's energy).

    Minimises :math:`\sum_{\text{cells}} (R(p, q) - I)^2 + \lambda \sum (\Delta z)^2` over the
    depth of the mask pixels by trust-region Gauss–Newton (``scipy.optimize.least_squares``)
    with the exact sparse Jacobian (see the module docstring). ``R = ρ max(0, n·l)``.

    Parameters
    ----------
    image : (H, W) or (H, W, C) linear image; colour is averaged to grey.
    light : (3,) direction towards the light (x right, y up, z towards the camera), l_z > 0.
    mask : (H, W) bool, the object; all pixels by default.
    albedo : ρ times the light's irradiance over π, i.e. the brightness of a pixel facing the
        light; by default the 99.9th percentile of the image in the mask (assumes some pixel
        faces the light, as most SfS methods do).
    smoothness : λ; larger values give smoother but flatter shapes.
    initial_depth : (H, W) start; by default the tent ``d / 2`` with ``d`` the Euclidean
        distance to the nearest pixel outside the mask (convex, 26.6° slopes: a generic
        "bulges towards the viewer" start, not the answer).
    max_iterations : limit on residual evaluations, 1 … :data:`MAX_ITERATIONS`.

    Returns
    -------
    ShapeFromShading

    Raises
    ------
    brdfkit.errors.ParameterError
        Shapes that disagree; NaN, infinity or negative values in ``image``; a zero, non-finite
        or back-facing ``light``; ``albedo``, ``smoothness`` or ``initial_depth`` (inside the
        mask) not finite or out of range; a mask without a 2 × 2 block.
    brdfkit.errors.ResourceError
        ``max_iterations`` above :data:`MAX_ITERATIONS` or more than :data:`MAX_PIXELS` mask
        pixels.

    References
    ----------
    .. [1] B. K. P. Horn, "Height and gradient from shading", IJCV 5(1), 1990.
    .. [2] B. K. P. Horn and M. J. Brooks, CVGIP 33(2), 1986.
    .. [3] R. Zhang et al., "Shape from shading: a survey", IEEE TPAMI 21(8), 1999.
    """
    max_iterations = check_count("max_iterations", max_iterations, MAX_ITERATIONS)
    check_param("smoothness", smoothness, 0.0)
    image = as_float_array("image", image, finite=False)
    if image.ndim == 3:
        image = image.mean(axis=-1)
    if image.ndim != 2:
        raise ParameterError(f"image must have shape (H, W) or (H, W, C); got shape {image.shape}")
    if not np.all(np.isfinite(image)) or np.any(image < 0):
        raise ParameterError("image must hold finite, non-negative linear values")
    light = as_float_array("light", light, finite=False)
    if light.shape != (3,) or not np.linalg.norm(light) > 0 or not np.all(np.isfinite(light)):
        raise ParameterError(f"light must be a non-zero 3-vector; got {light!r}")
    light = light / np.linalg.norm(light)
    if light[2] <= 0:
        raise ParameterError(f"light must point towards the camera side (l_z > 0); got {light}")
    mask = np.ones(image.shape, bool) if mask is None else np.asarray(mask, dtype=bool)
    if mask.shape != image.shape:
        raise ParameterError(f"mask must have shape {image.shape}; got shape {mask.shape}")
    if mask.sum() > MAX_PIXELS:
        raise ResourceError(
            f"the mask has {mask.sum()} pixels, more than MAX_PIXELS = {MAX_PIXELS}: downsample"
        )
    operators = _operators(mask)
    if operators[0].shape[0] < 1:
        raise ParameterError("mask must contain at least one 2×2 block of pixels")
    if albedo is None:
        albedo = float(np.percentile(image[mask], 99.9))
    if not albedo > 0:
        raise ParameterError(f"albedo must be positive (the image is black?); got {albedo!r}")
    check_param("albedo", albedo, 0.0, lo_open=True)
    if initial_depth is None:
        z, iterations, rms = _cascade(image / albedo, mask, light, smoothness, max_iterations)
    else:
        z0 = as_float_array("initial_depth", initial_depth, finite=False)
        if z0.shape != image.shape:
            raise ParameterError(
                f"initial_depth must have shape {image.shape}; got shape {z0.shape}"
            )
        if not np.all(np.isfinite(z0[mask])):
            raise ParameterError("initial_depth must be finite inside the mask")
        z, iterations, rms = _solve(
            image / albedo, mask, operators, light, smoothness, z0, max_iterations
        )
    depth = np.full(image.shape, np.nan)
    depth[mask] = z - z.min()
    return ShapeFromShading(depth, _normals_from_depth(depth, mask), albedo, iterations, rms)


def _downsample(image: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """2 × 2 block means of ``image`` and the blocks wholly inside ``mask`` (odd edges cropped)."""
    h, w = (n // 2 * 2 for n in mask.shape)
    blocks = image[:h, :w].reshape(h // 2, 2, w // 2, 2).mean(axis=(1, 3))
    inside = mask[:h, :w].reshape(h // 2, 2, w // 2, 2).all(axis=(1, 3))
    return blocks, inside


def _upsample(depth: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """A coarse depth (NaN outside its mask) at twice the resolution on ``mask``'s grid:
    holes filled from the nearest known coarse value, then bilinear interpolation (fine pixel
    ``r`` sits at coarse coordinate ``(r - 1/2) / 2``), depth doubled (pixel units)."""
    from scipy.ndimage import distance_transform_edt, map_coordinates

    missing = np.isnan(depth)
    if missing.all():
        return np.zeros(mask.shape)
    _, (rows, columns) = distance_transform_edt(missing, return_indices=True)
    filled = depth[rows, columns]
    r, c = np.indices(mask.shape, dtype=np.float64)
    coordinates = np.stack([(r - 0.5) / 2, (c - 0.5) / 2])
    return 2 * map_coordinates(filled, coordinates, order=1, mode="nearest")


class _Energy:
    """Horn's energy on the mask pixels' depths ``z``: the brightness residuals
    ``max(0, u)/s − I`` per cell (``u = −p l_x − q l_y + l_z``, ``s = √(1 + p² + q²)``), the
    smoothness residuals ``√λ Δz`` and the Jacobian of the former, ``diag(r_p) D_x +
    diag(r_q) D_y`` — the one source of both solvers."""

    def __init__(self, image, mask, operators, light, smoothness):
        self.d_x, self.d_y, average, laplacian = operators
        self.brightness = average @ image[mask]
        self.smooth = np.sqrt(smoothness) * laplacian
        self.light = light

    def residuals(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Brightness and smoothness residuals."""
        p, q = self.d_x @ z, self.d_y @ z
        u = -p * self.light[0] - q * self.light[1] + self.light[2]
        return np.maximum(u, 0) / np.sqrt(1 + p * p + q * q) - self.brightness, self.smooth @ z

    def slopes_derivatives(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``r_p = ∂R/∂p`` and ``r_q = ∂R/∂q`` per cell (zero where the cell is in shadow)."""
        p, q = self.d_x @ z, self.d_y @ z
        s = np.sqrt(1 + p * p + q * q)
        u = -p * self.light[0] - q * self.light[1] + self.light[2]
        lit = u > 0
        r_p = np.where(lit, -self.light[0] / s - u * p / s**3, 0.0)
        r_q = np.where(lit, -self.light[1] / s - u * q / s**3, 0.0)
        return r_p, r_q

    def jacobian(self, z: np.ndarray):
        """Sparse Jacobian of the brightness residuals."""
        from scipy import sparse

        r_p, r_q = self.slopes_derivatives(z)
        return (sparse.diags(r_p) @ self.d_x + sparse.diags(r_q) @ self.d_y).tocsr()


def _solve_small(
    image: np.ndarray,
    mask: np.ndarray,
    operators: tuple,
    light: np.ndarray,
    smoothness: float,
    initial_depth: np.ndarray,
    max_iterations: int,
) -> tuple[np.ndarray, int, float]:
    """Minimise Horn's energy with the :func:`_operators` of ``mask`` by scipy's trust-region
    reflective solver (robust from a far start; its LSMR steps grow slow beyond a few thousand
    unknowns): depths of the mask pixels, iterations, RMS."""
    from scipy import sparse
    from scipy.optimize import least_squares

    energy = _Energy(image, mask, operators, light, smoothness)
    result = least_squares(
        lambda z: np.concatenate(energy.residuals(z)),
        initial_depth[mask],
        jac=lambda z: sparse.vstack([energy.jacobian(z), energy.smooth]).tocsr(),
        method="trf",
        tr_solver="lsmr",
        x_scale="jac",
        max_nfev=max_iterations,
    )
    rms = float(np.sqrt(np.mean(result.fun[: energy.brightness.size] ** 2)))
    return result.x, int(result.nfev), rms


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """``a · b`` as a NumPy reduction: BLAS's threaded ``ddot`` on long vectors spins badly when
    the cores are shared, and slows the whole solve several times."""
    return float(np.multiply(a, b).sum())


def _conjugate_gradients(
    matrix, rhs: np.ndarray, inverse_diagonal: np.ndarray, rtol: float = 1e-4
) -> np.ndarray:
    """At most :data:`_CG_ITERATIONS` iterations of conjugate gradients on ``matrix x = rhs``
    from ``x = 0``, preconditioned by the inverse diagonal (Jacobi), until the residual falls
    below ``rtol`` times ``|rhs|`` (Hestenes & Stiefel 1952)."""
    x = np.zeros_like(rhs)
    residual = rhs.copy()
    z = inverse_diagonal * residual
    direction = z.copy()
    rz = _dot(residual, z)
    stop = rtol**2 * _dot(rhs, rhs)
    for _ in range(_CG_ITERATIONS):
        product = matrix @ direction
        curvature = _dot(direction, product)
        if not curvature > 0:
            break
        alpha = rz / curvature
        x += alpha * direction
        residual -= alpha * product
        if _dot(residual, residual) <= stop:
            break
        z = inverse_diagonal * residual
        rz, previous = _dot(residual, z), rz
        direction = z + (rz / previous) * direction
    return x


def _solve_large(
    image: np.ndarray,
    mask: np.ndarray,
    operators: tuple,
    light: np.ndarray,
    smoothness: float,
    initial_depth: np.ndarray,
    max_iterations: int,
) -> tuple[np.ndarray, int, float]:
    """Minimise Horn's energy with the :func:`_operators` of ``mask`` from a near start:
    depths of the mask pixels, iterations, RMS.

    Levenberg–Marquardt: each step solves ``(JᵀJ + λ LᵀL + μ D) δ = −Jᵀr − λ LᵀL z`` with ``D``
    the diagonal of the normal matrix (Marquardt's scaling), assembled as one sparse matrix, by
    :func:`_conjugate_gradients` (the start comes from the coarser level of :func:`_cascade`,
    so only short wavelengths remain to be corrected, which CG resolves quickly). A step is kept
    when the energy falls (``μ`` shrinks), otherwise ``μ`` grows; it stops when the energy's
    relative decrease falls below ``1e-8`` twice in a row or after ``max_iterations`` residual
    evaluations.
    """
    from scipy import sparse

    energy = _Energy(image, mask, operators, light, smoothness)
    smooth_normal = (energy.smooth.T @ energy.smooth).tocsr()

    def cost(parts: tuple[np.ndarray, np.ndarray]) -> float:
        return _dot(parts[0], parts[0]) + _dot(parts[1], parts[1])

    z = initial_depth[mask].astype(np.float64)
    parts = energy.residuals(z)
    current = cost(parts)
    mu, evaluations, small = 1e-3, 1, 0
    while evaluations < max_iterations:
        jacobian = energy.jacobian(z)
        normal = (jacobian.T @ jacobian + smooth_normal).tocsr()
        gradient = jacobian.T @ parts[0] + energy.smooth.T @ parts[1]
        diagonal = normal.diagonal()
        diagonal = np.maximum(diagonal, 1e-12 * max(diagonal.max(), 1e-300))
        decrease = 0.0
        while evaluations < max_iterations and mu <= 1e12:
            damped = normal + sparse.diags(mu * diagonal)
            trial = z + _conjugate_gradients(damped, -gradient, 1.0 / (diagonal * (1 + mu)))
            trial_parts = energy.residuals(trial)
            trial_cost = cost(trial_parts)
            evaluations += 1
            if trial_cost < current:
                decrease = (current - trial_cost) / max(current, 1e-300)
                z, parts, current = trial, trial_parts, trial_cost
                mu = max(mu / 3, 1e-9)
                break
            mu *= 4
        else:
            break
        small = small + 1 if decrease < 1e-8 else 0  # scipy's default ftol, twice in a row
        if small == 2:
            break
    return z, evaluations, float(np.sqrt(np.mean(parts[0] ** 2)))


def _solve(
    image: np.ndarray,
    mask: np.ndarray,
    operators: tuple,
    light: np.ndarray,
    smoothness: float,
    initial_depth: np.ndarray,
    max_iterations: int,
) -> tuple[np.ndarray, int, float]:
    """:func:`_solve_small` up to :data:`_COARSE` mask pixels, :func:`_solve_large` beyond."""
    solver = _solve_small if mask.sum() <= _COARSE else _solve_large
    return solver(image, mask, operators, light, smoothness, initial_depth, max_iterations)


def _cascade(
    image: np.ndarray, mask: np.ndarray, light: np.ndarray, smoothness: float, max_iterations: int
) -> tuple[np.ndarray, int, float]:
    """:func:`_solve` from the tent start ``d / 2`` or — above :data:`_COARSE` mask pixels —
    from the solution at half the resolution, upsampled (cascadic multigrid: each level
    corrects the short wavelengths its coarser level cannot represent). Returns the depths of
    the mask pixels, the evaluations summed over the levels, and the finest level's RMS."""
    from scipy.ndimage import distance_transform_edt

    coarse_image, coarse_mask = _downsample(image, mask)
    evaluations = 0
    if mask.sum() > _COARSE and _operators(coarse_mask)[0].shape[0] >= 1:
        coarse_depth, evaluations, _ = _cascade(
            coarse_image, coarse_mask, light, smoothness, max_iterations
        )
        depth = np.full(coarse_mask.shape, np.nan)
        depth[coarse_mask] = coarse_depth
        initial_depth = _upsample(depth, mask)
        # From the coarse solution only short wavelengths remain: a few steps correct them.
        max_iterations = min(max_iterations, _FINE_ITERATIONS)
    else:
        initial_depth = distance_transform_edt(mask) / 2
    z, count, rms = _solve(
        image, mask, _operators(mask), light, smoothness, initial_depth, max_iterations
    )
    return z, evaluations + count, rms
