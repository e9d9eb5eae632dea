r"""Photometric stereo by inverse rendering: normals and a microfacet reflectance fitted jointly.

The images are rendered from the current shape and reflectance and compared with the
observations, as in Taniai & Maehara's inverse-rendering photometric stereo (IRPS [1]_), without
its neural network: the reflectance is a physically based BRDF, a diffuse term plus a few
GGX microfacet lobes whose roughnesses ``α_j`` are shared by the object (and fitted with it),
each pixel ``p`` with its own non-negative weights (Goldman et al.'s shared basis BRDFs [2]_):

.. math::

    \hat I_{kp} = V_{kp}\, \max(0, n_p·l_k)\,\Big(\rho_p\,\big(1 + (F_{D90} - 1)
        (1 - n_p·l_k)^5\big) + \sum_j c_{jp}\,
        \frac{D_{α_j}(h_k)\, G_{α_j}(l_k, v, h_k)}{4\,(n_p·l_k)(n_p·v)}\Big),
    \qquad \rho_p, c_{jp} \ge 0,

with ``v = (0, 0, 1)`` the orthographic view, ``h_k`` the half vector, ``D`` the GGX
distribution and ``G`` the height-correlated Smith masking-shadowing of
:class:`~brdfkit.brdf.GGXConductor` (Fresnel factor 1: a grey lobe whose Fresnel level is in the
weight) [5]_, the diffuse term Burley's [7]_: Lambert's law with its grazing factor ``F_D90``
shared by the object (1: Lambertian; below 1 the darkening at grazing incidence of a coated
or smooth base, above 1 the brightening of a rough one; Burley's factor for the view, the
same for every light of a pixel, is in ``ρ_p``), ``max(0, n·l)`` the attached shadows and
``V`` the cast shadows of the current shape: the normals integrated to a depth map and each
light's shadow marched over it (:func:`~brdfkit.vision.svbrdf.shadow_visibility`, its bias
chosen by the cost as :func:`~brdfkit.vision.svbrdf.select_shadow_bias` chooses it). The fit
minimises the robust cost

.. math:: \sum_{k,p} w_{kp}\,(I_{kp} - \hat I_{kp})^2

over the normals, the weights, the roughnesses and the grazing factor:

- the weights by variable projection [3]_: for a candidate normal they are the per-pixel
  non-negative least-squares solution (active set [6]_);
- each normal by Levenberg–Marquardt on its two tangent coordinates (forward differences of
  the rendering with the weights held, every pixel on its own, all at once in NumPy);
- the roughnesses chosen from :data:`ROUGHNESS_GRID` by greedy forward selection on the cost,
  at the start and after the first round; ``F_D90`` from :data:`GRAZING_GRID` after the
  first round (the grid's value nearest 1 before: Lambert's law by default), each candidate's
  cost taken once the normals have been searched again with it (the normals lean to make up
  for a wrong diffuse shape: at fixed normals the cost would keep the shape they were found
  with);
- ``w`` zero for the observations darker than :data:`SHADOW_THRESHOLD` of the pixel's
  90th-percentile one (shadows, attached or cast by what the integrated shape misses: a
  rendering that puts light there would pull the normal towards a lobe-only fit), else Cauchy
  weights of the residuals (iteratively reweighted least squares [4]_, scale from the median
  absolute residual), so that what the model cannot render (inter-reflections) loses its pull.

Each round recomputes the cast shadows from the current normals and (after the first, a plain
least-squares round: a start's misfit is no outlier) the robust weights, then runs the normal
search. The start is, per pixel, the best by this cost of
:func:`~brdfkit.vision.bivariate_stereo.shared_bivariate`'s normals, trimmed least squares',
ST14's (:func:`~brdfkit.vision.bivariate_stereo.bipolynomial`) and the half vector of the
pixel's brightest light.

Claims (tests in ``tests/vision/test_inverse_rendering_stereo.py``): where the object's lobe is
a GGX lobe the rendering is exact and the normals come back to the noise level; on a glossy
sphere it beats least squares by a wide margin. Limits: an orthographic view, distant lights,
isotropic lobes with a per-pixel weight (no Fresnel colour shift over ``θ_d``), one diffuse
shape for the object; shadows only as good as the integrated depth.

Measured on the renders of ``benchmarks/bench_ps_materials.py`` (bear, cat, pot1 and the
sphere of DiLiGenT's size, every 8th pixel; mean error over the objects): Lambert's law and
three starts → the grazing factor → ST14's start as well. The Cornell acryl_blue, krylon_blue
and garnet_red paints 5.03° → 3.87° → 3.86°, 3.29° → 2.01° → 1.69°, 4.56° → 4.13° → 2.54°
(``F_D90`` below 1: their diffuse darkens towards grazing incidence, as a coated base's
does); the cayman car paint 17.15° → 17.14° → 12.13° (every other start is some 27° off; from
the true normals the fit reaches 7.6°); GGX lobes over a Lambertian base (α 0.3, 0.1, 0.05)
0.89°, 0.55°, 0.43° (``F_D90 = 1`` kept) → 0.71°, 0.52°, 0.39°; matte 0.18° → 0.11°; the RGL
felt 5.68° → 6.49° → 6.39°, worse: a cloth's brightening at grazing incidence (with the
normals held at the truth its cost is least at ``F_D90 = 2``) is not what this shape captures,
and the normals lean to a darker one (least cost at 0). The grazing factor costs some 3 s and
ST14's start some 2 s of the 23 s of 96 images of 612 × 512
(``benchmarks/bench_photometric_stereo.py``).

References
----------
.. [1] T. Taniai, T. Maehara, "Neural inverse rendering for general reflectance photometric
   stereo", ICML 2018.
.. [2] D. B. Goldman, B. Curless, A. Hertzmann, S. M. Seitz, "Shape and spatially-varying BRDFs
   from photometric stereo", IEEE TPAMI 32(6), 2010.
.. [3] G. H. Golub, V. Pereyra, "The differentiation of pseudo-inverses and nonlinear least
   squares problems whose variables separate", SIAM J. Numer. Anal. 10(2), 1973.
.. [4] P. W. Holland, R. E. Welsch, "Robust regression using iteratively reweighted
   least-squares", Commun. Stat. Theory Methods 6(9), 1977.
.. [5] B. Walter, S. R. Marschner, H. Li, K. E. Torrance, "Microfacet models for refraction
   through rough surfaces", EGSR 2007 (GGX); E. Heitz, "Understanding the masking-shadowing
   function in microfacet-based BRDFs", JCGT 3(2), 2014 (Smith masking).
.. [6] C. L. Lawson, R. J. Hanson, *Solving Least Squares Problems*, Prentice-Hall 1974,
   ch. 23 (non-negative least squares).
.. [7] B. Burley, "Physically-based shading at Disney", SIGGRAPH 2012 course notes, §5.3
   (the diffuse model, fitted to the MERL measurements' grazing behaviour).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._checks import check_count
from brdfkit.brdf import GGXConductor
from brdfkit.brdf.principled import schlick_weight
from brdfkit.errors import ParameterError
from brdfkit.geometry import frame_from_normal
from brdfkit.vision.bivariate_stereo import bipolynomial, shared_bivariate
from brdfkit.vision.datasets import horizon_excess
from brdfkit.vision.normal_integration import least_squares_integration
from brdfkit.vision.photometric_stereo import (
    Callback,
    PhotometricStereoResult,
    _gray,
    _prepare,
    _result,
    _trim_weights,
    trimmed_least_squares,
)
from brdfkit.vision.svbrdf import SHADOW_BIASES

ROUGHNESS_GRID = tuple(float(a) for a in np.geomspace(0.02, 0.8, 17))
"""GGX roughnesses ``α`` the shared lobes are chosen from (sharp to broad, ratio 1.26)."""

GRAZING_GRID = tuple(float(f) for f in np.linspace(0.0, 3.0, 7))
"""Burley's grazing factors ``F_D90`` the shared diffuse term is chosen from (1: Lambertian;
Burley's own span 0.5 to 2.5)."""

SELECTION_ITERATIONS = 8
"""Normal-search iterations behind each candidate grazing factor (:func:`_searched_cost`)."""

SELECTION_PIXELS = 2000
"""Pixels (an even subsample of the mask) on which the shared roughnesses and the grazing
factor are chosen."""

CAUCHY_SCALE = 2.385
"""Cauchy's constant: 95 % efficiency on Gaussian residuals (in units of their sigma)."""

SHADOW_THRESHOLD = 0.05
"""Observations darker than this fraction of their pixel's 90th-percentile observation are
shadows (attached, or cast by what the integrated shape misses) and left out of the fit."""

DIFFERENCE_STEP = 1e-5
"""Forward-difference step of the normal's tangent coordinates (radians)."""

STEP_TOLERANCE = 1e-6
"""A pixel's normal search stops when its step is below this (radians per coordinate,
0.006°)."""

MAX_ROUNDS = 20
"""Largest ``rounds``."""

MAX_ITERATIONS = 200
"""Largest ``iterations`` (per round)."""

_VIEW = np.array([0.0, 0.0, 1.0])


def _local(
    normals: np.ndarray, lights: np.ndarray, visibility: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lights ``(P, N, 3)`` and the view ``(P, N, 3)`` in the frame of each of ``normals``
    ``(P, 3)``, and the Lambertian column ``V max(0, cos θ_i)`` ``(P, N)``."""
    s, t, n = frame_from_normal(normals)
    local_lights = np.stack([s @ lights.T, t @ lights.T, n @ lights.T], axis=-1)
    view = np.stack([s[:, 2], t[:, 2], n[:, 2]], axis=-1)[:, None, :]
    view = np.broadcast_to(view, local_lights.shape)
    return local_lights, view, np.clip(local_lights[..., 2], 0.0, None) * visibility


def _lobe_column(
    lobe: GGXConductor, local_lights: np.ndarray, view: np.ndarray, shading: np.ndarray
) -> np.ndarray:
    """The column ``V cos θ_i f(l, v)`` ``(P, N)`` of one lobe (module formula): the lobe's own
    ``eval`` compiled in float64 (:func:`brdfkit.compiled.compile`, the same code traced; a
    kernel per model structure, so every roughness shares it), some 20 times NumPy's speed."""
    from brdfkit.compiled import compile as compile_brdf

    value = compile_brdf(lobe, np.float64).eval(local_lights, view)[..., 0]
    return np.nan_to_num(value) * shading


def _diffuse_column(local_lights: np.ndarray, shading: np.ndarray, grazing: float) -> np.ndarray:
    """The diffuse column ``V cos θ_i (1 + (F_D90 - 1)(1 - cos θ_i)^5)`` ``(P, N)`` (module
    formula; ``grazing`` is ``F_D90``)."""
    return shading * (1 + (grazing - 1) * schlick_weight(local_lights[..., 2]))


def _design(
    normals: np.ndarray, lights: np.ndarray, lobes: tuple[GGXConductor, ...],
    visibility: np.ndarray, grazing: float,
) -> np.ndarray:  # fmt: skip
    """The rendering's columns ``(P, N, 1 + J)`` for ``normals`` ``(P, 3)``: the diffuse
    column of grazing factor ``grazing`` and ``V cos θ_i f_j(l, v)`` for each lobe (module
    formula), ``visibility`` ``(P, N)``."""
    local_lights, view, shading = _local(normals, lights, visibility)
    columns = [_diffuse_column(local_lights, shading, grazing)]
    columns += [_lobe_column(lobe, local_lights, view, shading) for lobe in lobes]
    return np.stack(columns, axis=-1)


def _applied(matrices: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Each pixel's matrix times its vector: ``(P, M, K)`` by ``(P, K)`` to ``(P, M)`` (a
    batched matrix product, several times ``einsum``'s speed on these shapes)."""
    return (matrices @ vectors[..., None])[..., 0]


def _transposed(matrices: np.ndarray) -> np.ndarray:
    """Each pixel's matrix transposed: ``(P, M, K)`` to ``(P, K, M)`` (a view)."""
    return np.swapaxes(matrices, 1, 2)


def _nonnegative_fit(
    design: np.ndarray, target: np.ndarray, weights: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-pixel weighted non-negative least squares ``min |sqrt(w)(I - A c)|², c >= 0``: the
    weights ``(P, K)``, the residuals ``I - A c`` ``(P, N)`` and the costs ``(P,)``.

    Active set (Lawson & Hanson 1974, ch. 23) on every pixel at once: solve on the free
    variables (a ``1e-9`` relative ridge), clamp each pixel's most negative free weight, or free
    its clamped weight of steepest descent, until none changes (at most ``3 K`` rounds).
    """
    size = design.shape[-1]
    weighted = design * weights[..., None]
    gram = _transposed(weighted) @ design
    rhs = _applied(_transposed(weighted), target)
    ridge = 1e-9 * (np.trace(gram, axis1=1, axis2=2) / size + 1e-300)
    identity = np.eye(size)
    free = np.ones(rhs.shape, dtype=bool)
    pixels = np.arange(len(rhs))
    for _ in range(3 * size):
        both = free[:, :, None] & free[:, None, :]
        system = np.where(both, gram, identity) + ridge[:, None, None] * identity
        c = np.linalg.solve(system, np.where(free, rhs, 0.0)[..., None])[..., 0]
        negative = free & (c < 0)
        gradient = rhs - _applied(gram, np.where(free, c, 0.0))
        descent = ~free & (gradient > 1e-12 * (np.abs(rhs).max(axis=1, keepdims=True) + 1e-300))
        clamp = negative.any(axis=1)
        release = ~clamp & descent.any(axis=1)
        if not (clamp.any() or release.any()):
            break
        worst = np.argmin(np.where(negative, c, np.inf), axis=1)
        free[pixels[clamp], worst[clamp]] = False
        best = np.argmax(np.where(descent, gradient, -np.inf), axis=1)
        free[pixels[release], best[release]] = True
    c = np.where(free, c, 0.0)
    residual = target - _applied(design, c)
    return c, residual, np.sum(weights * residual**2, axis=1)


def _moved(normals: np.ndarray, step: np.ndarray) -> np.ndarray:
    """``normalise(n + u t_1 + v t_2)`` for ``step = (u, v)`` ``(P, 2)`` or ``(2,)``, with
    ``(t_1, t_2)`` the tangents of :func:`~brdfkit.geometry.frame_from_normal` (a start
    without a normal, zero, moves into the frame's tangent plane, or stays zero)."""
    s, t, _ = frame_from_normal(normals)
    step = np.broadcast_to(step, (len(normals), 2))
    moved = normals + step[:, :1] * s + step[:, 1:] * t
    length = np.linalg.norm(moved, axis=1, keepdims=True)
    return moved / np.where(length > 0, length, 1.0)


class _Problem:
    """The data of one fit: gray observations ``(P, N)``, unit lights, the lobes, the diffuse
    term's grazing factor, the cast-shadow visibility ``(P, N)`` and the robust weights
    ``(P, N)``."""

    def __init__(self, target: np.ndarray, lights: np.ndarray) -> None:
        self.target, self.lights = target, lights
        self.lobes: tuple[GGXConductor, ...] = ()
        self.grazing = 1.0
        self.visibility = np.ones(target.shape)
        self.weights = np.ones(target.shape)

    def fit(self, normals: np.ndarray, pixels: np.ndarray) -> tuple[np.ndarray, ...]:
        """:func:`_nonnegative_fit` at ``normals`` of the pixels ``pixels``."""
        design = _design(normals, self.lights, self.lobes, self.visibility[pixels], self.grazing)
        return _nonnegative_fit(design, self.target[pixels], self.weights[pixels])

    def rendered(self, normals: np.ndarray, pixels: np.ndarray, c: np.ndarray) -> np.ndarray:
        """The rendering ``(P, N)`` of ``normals`` with weights ``c`` at ``pixels``."""
        design = _design(normals, self.lights, self.lobes, self.visibility[pixels], self.grazing)
        return _applied(design, c)


def _search(
    problem: _Problem, normals: np.ndarray, iterations: int, callback: Callable[[], None]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Levenberg–Marquardt on every pixel's normal (module docstring): the normals ``(P, 3)``,
    their weights ``(P, K)`` and residuals ``(P, N)``.

    The Jacobian of the rendering is taken by forward differences with the weights held
    (Kaufman's variable-projection approximation); a step (clipped to 0.2 per coordinate) is
    kept where the refitted cost falls, the damping then shrinks by 3 (grows by 4 otherwise,
    from 1e-3 within [1e-9, 1e9]); a pixel stops when a kept step is below
    :data:`STEP_TOLERANCE` or its damping reaches the maximum.
    """
    everything = np.arange(len(normals))
    normals = normals.copy()
    c, residual, cost = problem.fit(normals, everything)
    damping = np.full(len(normals), 1e-3)
    active = everything
    for _ in range(iterations):
        if len(active) == 0:
            break
        n_a, c_a, r_a = normals[active], c[active], residual[active]
        base = problem.target[active] - r_a
        jacobian = np.stack(
            [
                (problem.rendered(_moved(n_a, offset), active, c_a) - base) / DIFFERENCE_STEP
                for offset in np.eye(2) * DIFFERENCE_STEP
            ],
            axis=-1,
        )  # (P, N, 2)
        weighted = jacobian * problem.weights[active][..., None]
        jtj = _transposed(weighted) @ jacobian
        jtr = _applied(_transposed(weighted), r_a)
        diagonal = np.einsum("paa->pa", jtj) + 1e-12
        system = jtj + (damping[active][:, None] * diagonal)[..., None] * np.eye(2)
        step = np.clip(np.linalg.solve(system, jtr[..., None])[..., 0], -0.2, 0.2)
        candidate = _moved(n_a, step)
        c_new, r_new, cost_new = problem.fit(candidate, active)
        better = cost_new < cost[active]
        kept = active[better]
        normals[kept], c[kept], residual[kept], cost[kept] = (
            candidate[better], c_new[better], r_new[better], cost_new[better],
        )  # fmt: skip
        damping[active] = np.clip(np.where(better, damping[active] / 3, damping[active] * 4),
                                  1e-9, 1e9)  # fmt: skip
        converged = better & (np.abs(step).max(axis=1) < STEP_TOLERANCE)
        active = active[~converged & (damping[active] < 1e9)]
        callback()
    return normals, c, residual


def _subsample(count: int) -> np.ndarray:
    """At most :data:`SELECTION_PIXELS` evenly spread indices of ``count`` pixels."""
    return np.unique(np.linspace(0, count - 1, SELECTION_PIXELS).astype(np.intp))


def _select_lobes(
    problem: _Problem, normals: np.ndarray, grid: tuple[float, ...], count: int
) -> None:
    """Set the problem's shared lobes: greedy forward selection of ``count`` roughnesses from
    ``grid`` by the robust cost on :data:`SELECTION_PIXELS` pixels at ``normals`` (each lobe the
    one that lowers it most given those already chosen; one that lowers it by less than 0.1 % is
    not added), the first refined between its grid neighbours by halving the log-step twice."""
    pixels = _subsample(len(normals))
    local_lights, view, shading = _local(normals[pixels], problem.lights,
                                         problem.visibility[pixels])  # fmt: skip
    diffuse = _diffuse_column(local_lights, shading, problem.grazing)
    target, weights = problem.target[pixels], problem.weights[pixels]
    columns: dict[float, np.ndarray] = {}

    def cost(alphas: list[float]) -> float:
        for a in alphas:
            if a not in columns:
                columns[a] = _lobe_column(GGXConductor(alpha=a), local_lights, view, shading)
        design = np.stack([diffuse] + [columns[a] for a in alphas], axis=-1)
        return float(_nonnegative_fit(design, target, weights)[2].sum())

    chosen: list[float] = []
    current = cost([])
    for _ in range(count):
        scores = {a: cost([*chosen, a]) for a in grid if a not in chosen}
        best = min(scores, key=scores.get)
        if scores[best] > (1 - 1e-3) * current:
            break
        if not chosen:
            ratio = grid[1] / grid[0] if len(grid) > 1 else 1.0
            for _ in range(2):
                ratio = np.sqrt(ratio)
                for candidate in (best / ratio, best * ratio):
                    scores[candidate] = cost([candidate])
                best = min(scores, key=scores.get)
        chosen.append(best)
        current = scores[best]
    problem.lobes = tuple(GGXConductor(alpha=a) for a in chosen)


def _select_grazing(problem: _Problem, normals: np.ndarray, grid: tuple[float, ...]) -> None:
    """Set the problem's grazing factor: the one of ``grid`` of least :func:`_searched_cost`
    on :data:`SELECTION_PIXELS` pixels from ``normals``."""
    pixels = _subsample(len(normals))
    problem.grazing = min(grid, key=lambda f: _searched_cost(problem, normals, pixels, f))


def _searched_cost(
    problem: _Problem, normals: np.ndarray, pixels: np.ndarray, grazing: float
) -> float:
    """The robust cost at ``pixels`` with the grazing factor ``grazing`` once their normals
    have been searched again from ``normals`` (:data:`SELECTION_ITERATIONS` iterations): the
    normals lean to make up for a wrong diffuse shape, so the cost at fixed normals would keep
    the shape they were found with."""
    sub = _Problem(problem.target[pixels], problem.lights)
    sub.lobes, sub.grazing = problem.lobes, grazing
    sub.visibility, sub.weights = problem.visibility[pixels], problem.weights[pixels]
    _, _, residual = _search(sub, normals[pixels], SELECTION_ITERATIONS, lambda: None)
    return float(np.sum(sub.weights * residual**2))


def _cauchy_weights(residual: np.ndarray, known: np.ndarray) -> np.ndarray:
    """Cauchy IRLS weights ``1 / (1 + (r / (c σ))²)``, ``σ = 1.4826 median |r|`` over the
    observations the model lights (``known``), ``c`` :data:`CAUCHY_SCALE`."""
    sigma = 1.4826 * np.median(np.abs(residual[known])) if known.any() else 0.0
    scale = CAUCHY_SCALE * max(sigma, 1e-6 * np.abs(residual).max() + 1e-300)
    return 1.0 / (1.0 + (residual / scale) ** 2)


def _starts(
    images: ArrayLike, lights: np.ndarray, mask: np.ndarray, gray: np.ndarray
) -> list[np.ndarray]:
    """Candidate start normals ``(P, 3)`` of the mask's pixels: shared bivariate, trimmed least
    squares, ST14 (its elevation searched along the azimuth: no highlight pulls it sideways,
    and it is the start that reaches the cayman car paint), and the half vector of each
    pixel's brightest light (where a lobe peaks, ``n = h``; it rescues pixels whose highlight
    pulls the others off). ST14 refuses too few images for its trims (under 6 at its
    defaults; the other starts have checked the data already): then it is no candidate."""
    starts = [
        method(images, lights, mask).normals[mask]
        for method in (shared_bivariate, trimmed_least_squares)
    ]
    try:
        starts.append(bipolynomial(images, lights, mask).normals[mask])
    except ParameterError:
        pass
    half = lights[np.argmax(gray, axis=0)] + _VIEW
    return [*starts, half / np.linalg.norm(half, axis=1, keepdims=True)]


def _normal_map(normals: np.ndarray, mask: np.ndarray) -> np.ndarray:
    full = np.zeros((*mask.shape, 3))
    full[mask] = normals
    return full


def inverse_rendering(
    images: ArrayLike,
    light_directions: ArrayLike,
    mask: ArrayLike | None = None,
    *,
    lobes: int = 2,
    roughness_grid: tuple[float, ...] = ROUGHNESS_GRID,
    grazing_grid: tuple[float, ...] = GRAZING_GRID,
    rounds: int = 3,
    iterations: int = 8,
    cast_shadows: bool = True,
    shadow_bias: float | None = None,
    callback: Callback | None = None,
) -> PhotometricStereoResult:
    r"""Photometric stereo by inverse rendering with a microfacet dictionary (module docstring).

    Parameters
    ----------
    images, light_directions, mask : as :func:`~brdfkit.vision.photometric_stereo.least_squares`.
    lobes : the most shared GGX lobes (1 … 4).
    roughness_grid : the roughnesses they are chosen from, each in [1e-3, 1] (1 … 64 of them).
    grazing_grid : the grazing factors ``F_D90`` of the diffuse term it is chosen from after
        the first round, each in [0, 4] (1 … 64 of them); until then the one nearest 1
        (Lambert's law); ``(1.0,)`` keeps Lambert's law, a single value that factor throughout.
    rounds : alternations of cast shadows, robust weights and normal search (1 …
        :data:`MAX_ROUNDS`).
    iterations : normal-search iterations per round (1 … :data:`MAX_ITERATIONS`).
    cast_shadows : render the cast shadows of the current shape (else only attached ones).
    shadow_bias : height (pixels) an occluder of the integrated depth must rise above the ray
        (:func:`~brdfkit.vision.datasets.cast_shadows`), >= 0; by default the one of
        :data:`~brdfkit.vision.svbrdf.SHADOW_BIASES` (infinity: none) whose rendering of the
        start has the least cost.
    callback : ``callback(done, total)`` after each start and each search iteration.

    Returns
    -------
    PhotometricStereoResult
        Normals; albedo the diffuse weight ``ρ`` times the pixel's chromaticity.

    Raises
    ------
    brdfkit.errors.ParameterError
        Bad images, lights or mask (see :func:`~brdfkit.vision.photometric_stereo.least_squares`)
        or parameters outside the ranges above.
    brdfkit.errors.ResourceError
        Counts above their maxima, or data that would not fit in memory.

    References
    ----------
    T. Taniai, T. Maehara, ICML 2018 (inverse-rendering photometric stereo); D. B. Goldman et
    al., IEEE TPAMI 32(6), 2010 (shared basis BRDFs, per-pixel weights); B. Walter et al., EGSR
    2007 (GGX).

    Examples
    --------
    A glossy sphere (Lambertian plus a GGX lobe of roughness 0.1) under 96 DiLiGenT-like
    lights: least squares is biased by the highlights, inverse rendering is not:

    >>> import numpy as np
    >>> from brdfkit.brdf.spec import parse
    >>> from brdfkit.vision import datasets
    >>> from brdfkit.vision.metrics import angular_error
    >>> from brdfkit.vision.photometric_stereo import least_squares, sphere_normals
    >>> from brdfkit.vision.synthesis import render_brdf
    >>> normals, inside = sphere_normals((16, 16), centre=(7.5, 7.5), radius=7.0)
    >>> lights = datasets.diligent_like_lights()
    >>> glossy = parse("lambertian(albedo=0.5) + 0.3 * ggx(alpha=0.1)")
    >>> images = render_brdf(normals, inside, lights, glossy)
    >>> fitted = inverse_rendering(images, lights, inside, rounds=1)
    >>> error = angular_error(fitted.normals, normals, inside)["mean"]
    >>> baseline = angular_error(least_squares(images, lights, inside).normals, normals, inside)
    >>> bool(error < 0.5 < 5 < baseline["mean"])
    True
    """
    rounds = check_count("rounds", rounds, MAX_ROUNDS)
    iterations = check_count("iterations", iterations, MAX_ITERATIONS)
    lobes = check_count("lobes", lobes, 4)
    grid = tuple(float(a) for a in roughness_grid)
    if not 1 <= len(grid) <= 64 or not all(1e-3 <= a <= 1 for a in grid):
        raise ParameterError(f"roughness_grid must be 1 to 64 values in [0.001, 1]; got {grid}")
    grazing = tuple(float(f) for f in grazing_grid)
    if not 1 <= len(grazing) <= 64 or not all(0 <= f <= 4 for f in grazing):
        raise ParameterError(f"grazing_grid must be 1 to 64 values in [0, 4]; got {grazing}")
    if shadow_bias is not None and not shadow_bias >= 0:
        raise ParameterError(f"shadow_bias must be >= 0, got {shadow_bias}")
    observations, lights, mask = _prepare(images, light_directions, mask)
    report = callback if callback is not None else (lambda done, total: None)
    total, done = 2 + rounds * iterations, 0

    def advance() -> None:
        nonlocal done
        done += 1
        report(done, total)

    gray = _gray(observations)
    problem = _Problem(np.ascontiguousarray(gray.T), lights)
    problem.grazing = min(grazing, key=lambda f: abs(f - 1.0))
    dark = gray < SHADOW_THRESHOLD * np.percentile(gray, 90, axis=0)
    problem.weights = np.ascontiguousarray(~dark.T, dtype=np.float64)
    observed = problem.weights.copy()
    everything = np.arange(gray.shape[1])
    starts = _starts(images, lights, mask, gray)
    advance()
    _select_lobes(problem, starts[0], grid, lobes)
    if cast_shadows and shadow_bias is None:
        shadow_bias = _select_bias(problem, starts[0], mask)
    elif cast_shadows:
        problem.visibility = _cast(starts[0], mask, lights, (shadow_bias,))[0]
    costs = np.stack([problem.fit(start, everything)[2] for start in starts])
    normals = np.stack(starts)[np.argmin(costs, axis=0), everything]
    unlit = ~np.any(gray > 0, axis=0)  # any normal explains them: facing the camera, flat
    normals[unlit] = _VIEW
    advance()
    residual = problem.fit(normals, everything)[1]
    for round_ in range(rounds):
        if round_ > 0:
            if cast_shadows:
                problem.visibility = _cast(normals, mask, lights, (shadow_bias,))[0]
            residual = problem.fit(normals, everything)[1]
        if round_ > 0:  # the first round by least squares: a start's misfit is no outlier
            problem.weights = observed * _cauchy_weights(residual, observed > 0)
        if round_ == 1:  # the lobes again and the diffuse shape, from the first round's normals
            _select_lobes(problem, normals, grid, lobes)
            if len(grazing) > 1:
                _select_grazing(problem, normals, grazing)
        normals, c, residual = _search(problem, normals, iterations, advance)
    rho = np.maximum(c[:, :1], 1e-12)  # a pixel without a diffuse term keeps its normal
    rho[unlit] = 0.0  # no normal, as every method leaves a pixel no light reaches
    return _result((normals * rho).T, observations, mask, _trim_weights(gray, 0.25, 0.1))


def _cast(
    normals: np.ndarray, mask: np.ndarray, lights: np.ndarray, biases: tuple[float, ...]
) -> list[np.ndarray]:
    """Cast-shadow visibilities ``(P, N)`` (0/1) of the surface integrated from ``normals``, one
    per bias (:func:`~brdfkit.vision.svbrdf.shadow_visibility`; the depth integrated and its
    horizons marched once)."""
    height = -least_squares_integration(_normal_map(normals, mask), mask)
    excess = horizon_excess(np.where(mask, height, np.nan), lights).T
    return [(excess <= bias).astype(np.float64) for bias in biases]


def _select_bias(problem: _Problem, normals: np.ndarray, mask: np.ndarray) -> float:
    """The cast-shadow bias of :data:`~brdfkit.vision.svbrdf.SHADOW_BIASES` (infinity: no cast
    shadows) whose rendering has the least cost on :data:`SELECTION_PIXELS` pixels at
    ``normals``, as :func:`~brdfkit.vision.svbrdf.select_shadow_bias` chooses it; sets the
    problem's visibility to it."""
    pixels = _subsample(len(normals))
    costs, visibilities = [], _cast(normals, mask, problem.lights, SHADOW_BIASES)
    for visibility in visibilities:
        problem.visibility = visibility
        costs.append(problem.fit(normals[pixels], pixels)[2].sum())
    best = int(np.argmin(costs))
    problem.visibility = visibilities[best]
    return SHADOW_BIASES[best]


METHODS: dict[str, Callable[..., PhotometricStereoResult]] = {
    "inverse_rendering": inverse_rendering
}
"""The inverse-rendering method by name (a ``--method`` choice of ``brdfkit ps``)."""
