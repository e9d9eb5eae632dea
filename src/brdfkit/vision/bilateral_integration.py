r"""Bilateral normal integration: depth from a normal map, keeping its discontinuities.

Least squares (:func:`brdfkit.vision.normal_integration.least_squares_integration`) asks every
pair of neighbouring pixels to agree with the normals, so a depth step (one part of an object in
front of another) is smeared over the pixels around it. Bilateral normal integration (Cao et al.
2022) writes one equation per pixel for each of its four one-sided differences and weights the
two sides of an axis against each other: where the surface is smooth both sides agree (weights
½, least squares); at a step only the side that does not cross it is kept.

Frame as :mod:`brdfkit.vision` (normals ``n``: x right, y up, z towards the camera); the
unknown ``z`` is the depth (orthographic, pixel units) or its logarithm (perspective). With
``n_u = n_x`` (right), ``n_v = n_y`` (up) and ``n_d = -n_z`` (into the scene), a pixel's
forward and backward differences along the columns (rows go the same way, upwards) satisfy

.. math:: \tilde n_u\,(z_{u+1} - z_u) = -n_u, \qquad \tilde n_u\,(z_u - z_{u-1}) = -n_u,

with :math:`\tilde n = n_d` (orthographic) or, with intrinsics ``K`` and
:math:`(\bar u, \bar v) = (u - c_x, c_y - v)`, :math:`\tilde n_u = \bar v n_v + \bar u n_u +
f_x n_d` and :math:`\tilde n_v = \bar v n_v + \bar u n_u + f_y n_d` (the equations multiplied by
the ray's normal component, so that grazing pixels weigh little). The energy

.. math:: E(z) = \sum_p w_p^u (\partial_u^+ z - b)^2 + (1 - w_p^u)(\partial_u^- z - b)^2
          + (\text{same along } v), \qquad
          w_p^u = \sigma_k\big((\partial_u^- z)^2 - (\partial_u^+ z)^2\big),

with :math:`\sigma_k(x) = 1 / (1 + e^{-k x})`, is minimised by iteratively reweighted least
squares: weights fixed, ``z`` solves a weighted graph Laplacian (every pair of neighbours one
edge, its two equations summed); ``z`` fixed, the weights are updated; until the energy changes
by less than ``tolerance`` (relative). ``k`` sets how readily a step is kept (0: least squares).
Each linear solve is Jacobi-preconditioned conjugate gradients to a relative residual of
``solver_tolerance`` started from the previous depth, as in the authors' implementation: its
inexact steps are part of the method: solving every step exactly lands in other, worse local
minima on the DiLiGenT objects (mean absolute depth error 0.50 mm rather than 0.33 on bear,
0.10 rather than 0.074 on cat), and so does solving the last weighted system exactly.

A depth prior ``d_0`` (e.g. from a depth sensor) adds :math:`\lambda \sum_{p \in M} (z_p -
z_{0,p})^2` over the pixels ``M`` where it is known (``z_0`` its log in perspective), after
moving ``z`` onto the prior's mean, with :math:`\lambda = \beta \operatorname{median}(\tilde
n^2)`: each known depth weighs ``β`` times a typical equation, in perspective (where
:math:`\tilde n` is about the focal length in pixels) as in orthographic projection. The
iterations solve for ``z`` less the prior's mean, so that the solver's relative tolerance
applies to the shape rather than to the mean (log-)depth.

A continuity prior decides what the normals leave open. Scaling part of a surface about the
camera centre (orthographic: moving it along the axis) leaves its normals unchanged, so where
the weights part two regions, or join them only weakly across an occluding contour, their
relative depth is not in the data. With ``continuity`` :math:`\gamma > 0` the energy gains

.. math:: \mu \sum_p (z_p - z^{LS}_p)^2, \qquad
          \mu = \gamma\, \frac{\pi^2}{N}\, \operatorname{median}(\tilde n^2),

with :math:`z^{LS}` the masked least-squares surface (the smoothest one the normals allow:
it integrates across every edge) and ``N`` the mask's pixels: :math:`\pi^2 / N` times a
typical equation weight is about the stiffness of the softest shape of a least-squares mask
of ``N`` pixels (a tilt across it, the Laplacian's smallest non-zero eigenvalue), so with
:math:`\gamma = 0.01` every shape the equations hold moves by about 1 % or less towards
:math:`z^{LS}`, while a mode the weights leave loose (a relative scale across a contour)
follows it. The iterations then start from :math:`z^{LS}`.

Piece scales set those loose modes and nothing else. After the authors' iterations, each edge
couples its pixels by :math:`c_e = w\,\tilde n_p^2 + (1 - w')\,\tilde n_q^2` (its weight in
the last Laplacian); the edges with :math:`c_e < \gamma_p \operatorname{median}(c)` at an
occluding contour (one of their pixels' normals nearly perpendicular to its viewing ray ``r``,
:math:`|n \cdot r| <` :data:`CONTOUR_FACING`, where a depth step can hide) are cut, and each
connected piece :math:`P` of what remains gets the one constant the normals leave
free in it (perspective: a scale; orthographic: an offset),

.. math:: z_p \leftarrow z_p + \frac{1}{|P|} \sum_{q \in P} (z^{LS}_q - z_q),
          \qquad p \in P,

so that its mean (log-)depth is least squares' there. Inside a piece the result is the
authors' up to that constant; where the weights part nothing (one piece) it is theirs.
A weak edge between two pixels that face the camera is a crease, not a step: the authors'
depth holds across it (on DiLiGenT harvest, cut at creases too at 2 %, least squares misplaced
a quarter of the statue: 4.7 mm mean error rather than 1.8).
A piece is a part of the surface: it holds an interior pixel, one whose four edges are all
kept. What the cut parts without one (a silhouette pixel, whose grazing normal makes
:math:`\tilde n_p` small, or a sliver one or two pixels wide along an occluding contour) joins
as a whole, layer by layer from the pieces outwards, the piece it is most strongly coupled to
across a cut, and keeps the authors' depth relative to it. Least squares' depth for it is
no better: it carries a neighbour's slope onto it or smears the contour's step over it
(rendered in DiLiGenT's camera, a sphere of its ball's size: mean absolute depth error
0.0160 mm with its silhouette pixels taken as pieces, the authors' 0.0133; three overlapping
spheres: 0.0023 mm worse than theirs with slivers of 4 to 13 pixels taken as pieces, the same
without).
With :math:`\gamma_p = 1\,\%` (the continuity prior's fraction) an edge that holds its
pixels together by under 1 % of a typical edge does not hold their relative depth. With a depth
prior, a piece holding a known depth keeps the constant the prior gave it, and the others take
least squares' moved onto the prior (:math:`z^{LS}` plus the mean of :math:`z_0 - z^{LS}` over
the known pixels).

References
----------
.. [1] X. Cao, H. Santo, B. Shi, F. Okura, Y. Matsushita, "Bilateral normal integration",
   ECCV 2022, 552-567. Reference code: github.com/xucao-42/bilateral_normal_integration.
.. [2] Y. Quéau, J.-D. Durou, J.-F. Aujol, "Normal integration: a survey", J. Math. Imaging
   Vis. 60, 576-593, 2018.
.. [3] A. N. Tikhonov, V. Y. Arsenin, "Solutions of ill-posed problems", Winston, 1977 (a
   weak quadratic prior fixing the directions the data leave free).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._checks import as_float_array, check_count, check_memory
from brdfkit.errors import ParameterError
from brdfkit.vision.normal_integration import check_camera, check_normals

MAX_ITERATIONS = 10_000
"""Largest ``max_iterations`` accepted (reweighting iterations)."""

BYTES_PER_PIXEL = 400
"""Peak memory per mask pixel (edges, equations, weights, solver vectors), estimated."""

CG_MAX_ITERATIONS = 5000
"""Most conjugate-gradient steps of one linear solve (the authors' ``cg_max_iter``)."""

PIECES = 0.01
"""The piece cut ``γ_p`` of ``brdfkit integrate``'s default: an edge coupling its two pixels by
less than 1 % of the median edge does not hold their relative depth (see the module
docstring)."""

CONTOUR_FACING = 0.2
"""An edge is cut only at an occluding contour: where one of its two pixels' normals is within
about 12° of perpendicular to its viewing ray, ``|n·r| < 0.2`` (see the module docstring)."""

PRIOR_WEIGHT = 0.01
"""The depth prior's default ``β``: each known depth weighs 1 % of a typical equation, between
following the noise of a dense prior (10 %) and letting a sparse one go (0.1 %)."""

CONTINUITY = 0.01
"""The continuity prior's ``γ`` that ``brdfkit integrate``'s default uses: 1 % of the stiffness
of a mask's softest least-squares shape (see the module docstring)."""


@dataclass(frozen=True)
class BilateralIntegration:
    """The result of :func:`bilateral_integration`.

    Attributes
    ----------
    depth : (H, W) depth along the optical axis away from the camera, NaN outside the mask.
    horizontal_weights, vertical_weights : (H, W) weight of each pixel's forward difference
        (towards the right / upwards), NaN outside the mask: ½ on a smooth surface, near 0 or
        1 beside a discontinuity.
    energies : the energy after each iteration.
    solver_steps : conjugate-gradient steps in all.
    """

    depth: np.ndarray
    horizontal_weights: np.ndarray
    vertical_weights: np.ndarray
    energies: tuple[float, ...]
    solver_steps: int

    @property
    def iterations(self) -> int:
        """Reweighting iterations run."""
        return len(self.energies)


@dataclass(frozen=True)
class _Edges:
    """The neighbour pairs of a mask, each oriented forwards (``p`` to its right or upper
    neighbour ``q``), horizontal ones first; ``index`` numbers the mask pixels."""

    index: np.ndarray
    p: np.ndarray
    q: np.ndarray
    horizontal: int

    @classmethod
    def of(cls, mask: np.ndarray) -> _Edges:
        index = np.full(mask.shape, -1, dtype=np.int64)
        index[mask] = np.arange(int(mask.sum()))
        right = mask[:, :-1] & mask[:, 1:]
        up = mask[1:, :] & mask[:-1, :]  # the pixel below and the one above it
        p = np.concatenate([index[:, :-1][right], index[1:, :][up]])
        q = np.concatenate([index[:, 1:][right], index[:-1, :][up]])
        return cls(index, p, q, int(right.sum()))


class _Laplacian:
    """``L = D^T diag(c) D`` for the edges' difference operator ``D`` (``z_q - z_p``), stored by
    pixel: its diagonal (the degree) and the weights of the edges to its four neighbours, the
    row neighbours being the next and previous pixel (the mask is numbered row by row).
    :meth:`update` writes new edge weights ``c`` in place."""

    def __init__(self, edges: _Edges, n: int) -> None:
        h = edges.horizontal
        self.up = np.arange(n, dtype=np.int32)  # itself where there is no neighbour (weight 0)
        self.up[edges.p[h:]] = edges.q[h:]
        self.down = np.arange(n, dtype=np.int32)
        self.down[edges.q[h:]] = edges.p[h:]
        self.weights = np.zeros((4, n))  # right, left, up, down
        self.degree = np.zeros(n)
        self._edges, self._n = edges, n

    def update(self, c: np.ndarray) -> None:
        e, h = self._edges, self._edges.horizontal
        self.weights[0, e.p[:h]] = c[:h]
        self.weights[1, e.q[:h]] = c[:h]
        self.weights[2, e.p[h:]] = c[h:]
        self.weights[3, e.q[h:]] = c[h:]
        self.degree = np.bincount(e.p, c, self._n) + np.bincount(e.q, c, self._n)


def _coefficients(
    normals: np.ndarray, mask: np.ndarray, camera: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per mask pixel: ``(ñ_u, ñ_v, b_u, b_v)``, the equations ``ñ (z_next - z) = b``."""
    n_u, n_v, n_d = normals[mask, 0], normals[mask, 1], -normals[mask, 2]
    if camera is None:
        return n_d, n_d, -n_u, -n_v
    rows, columns = np.nonzero(mask)
    tangential = (camera[1, 2] - rows) * n_v + (columns - camera[0, 2]) * n_u
    return tangential + camera[0, 0] * n_d, tangential + camera[1, 1] * n_d, -n_u, -n_v


def _facing(normals: np.ndarray, mask: np.ndarray, camera: np.ndarray | None) -> np.ndarray:
    """Per mask pixel, ``|n·r|``: the cosine between its normal and its viewing ray ``r``
    (orthographic ``(0, 0, -1)``; perspective ``(ū / f_x, v̄ / f_y, -1)`` normalised)."""
    n = normals[mask]
    if camera is None:
        return np.abs(n[:, 2])
    rows, columns = np.nonzero(mask)
    ray = np.stack(
        [(columns - camera[0, 2]) / camera[0, 0], (camera[1, 2] - rows) / camera[1, 1],
         -np.ones(len(rows))],
        axis=1,
    )  # fmt: skip
    return np.abs(np.sum(n * ray, axis=1)) / np.linalg.norm(ray, axis=1)


def _sigmoid(x: np.ndarray, k: float) -> np.ndarray:
    import scipy.special

    return scipy.special.expit(k * x)


def _moved_onto_prior(z: np.ndarray, z_prior: np.ndarray, known: np.ndarray) -> np.ndarray:
    """``z`` plus the constant that gives it the prior's mean over the ``known`` pixels."""
    return z + np.mean(z_prior[known] - z[known])


def _least_squares_reference(
    normals: np.ndarray,
    mask: np.ndarray,
    camera: np.ndarray | None,
    z_prior: np.ndarray | None,
    known: np.ndarray | None,
) -> np.ndarray:
    """``z`` of the masked least-squares surface on the mask pixels, moved onto the prior if
    there is one: what the continuity prior pulls towards and the pieces' constants come from."""
    from brdfkit.vision.normal_integration import least_squares_integration

    depth = least_squares_integration(normals, mask, camera)[mask]
    reference = depth if camera is None else np.log(depth)
    return reference if z_prior is None else _moved_onto_prior(reference, z_prior, known)


def _check_prior(
    depth_prior: ArrayLike | None, mask: np.ndarray, camera: np.ndarray | None
) -> np.ndarray | None:
    """``z`` of the prior on the mask pixels (NaN where unknown), or None."""
    if depth_prior is None:
        return None
    prior = as_float_array("depth_prior", depth_prior, finite=False)
    if prior.shape != mask.shape:
        raise ParameterError(f"depth_prior must have shape {mask.shape}, got {prior.shape}")
    values = prior[mask]
    known = np.isfinite(values)
    if not known.any():
        raise ParameterError("depth_prior has no finite value inside the mask")
    if camera is not None:
        if np.any(values[known] <= 0):
            raise ParameterError("depth_prior must be positive (perspective depth)")
        values = np.where(known, np.log(np.where(known, values, 1.0)), np.nan)
    return values


class _Problem:
    """The equations of one normal map and the state of the reweighting."""

    def __init__(self, normals: np.ndarray, mask: np.ndarray, camera: np.ndarray | None) -> None:
        self.edges = _Edges.of(mask)
        self.n = int(mask.sum())
        a_u, a_v, b_u, b_v = _coefficients(normals, mask, camera)
        h, e = self.edges.horizontal, self.edges
        self.a = (a_u, a_v)
        self.b = (b_u, b_v)
        # Per edge: the coefficient and target of p's forward and q's backward equation.
        self.a_forward = np.concatenate([a_u[e.p[:h]], a_v[e.p[h:]]])
        self.a_backward = np.concatenate([a_u[e.q[:h]], a_v[e.q[h:]]])
        self.b_forward = np.concatenate([b_u[e.p[:h]], b_v[e.p[h:]]])
        self.b_backward = np.concatenate([b_u[e.q[:h]], b_v[e.q[h:]]])
        self.laplacian = _Laplacian(self.edges, self.n)
        self.facing = _facing(normals, mask, camera)
        self.typical = float(np.median(np.concatenate(self.a) ** 2))  # median weight ñ²

    def differences(self, z: np.ndarray) -> tuple[np.ndarray, ...]:
        """Each pixel's forward and backward scaled differences ``ñ ∂^± z`` along u and v
        (0 where the neighbour is outside the mask)."""
        e, h = self.edges, self.edges.horizontal
        delta = z[e.q] - z[e.p]
        out = [np.zeros(self.n) for _ in range(4)]  # u+, u-, v+, v-
        for axis, edges in ((0, slice(None, h)), (1, slice(h, None))):
            out[2 * axis][e.p[edges]] = self.a[axis][e.p[edges]] * delta[edges]
            out[2 * axis + 1][e.q[edges]] = self.a[axis][e.q[edges]] * delta[edges]
        return tuple(out)

    def reweight(self, z: np.ndarray, k: float) -> tuple[np.ndarray, np.ndarray, float]:
        """The forward weights along u and v for depth ``z``, and the energy with them."""
        u_plus, u_minus, v_plus, v_minus = self.differences(z)
        w_u = _sigmoid(u_minus**2 - u_plus**2, k)
        w_v = _sigmoid(v_minus**2 - v_plus**2, k)
        (b_u, b_v) = self.b
        energy = np.sum(
            w_u * (u_plus - b_u) ** 2
            + (1 - w_u) * (u_minus - b_u) ** 2
            + w_v * (v_plus - b_v) ** 2
            + (1 - w_v) * (v_minus - b_v) ** 2
        )
        return w_u, w_v, float(energy)

    def edge_weights(self, w_u: np.ndarray, w_v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per edge, the weight of p's forward and of q's backward equation."""
        e, h = self.edges, self.edges.horizontal
        w_forward = np.concatenate([w_u[e.p[:h]], w_v[e.p[h:]]])
        w_backward = 1 - np.concatenate([w_u[e.q[:h]], w_v[e.q[h:]]])
        return w_forward, w_backward

    def coupling(self, w_u: np.ndarray, w_v: np.ndarray) -> np.ndarray:
        """Per edge, its weight ``c`` in the Laplacian: its two equations' weighted squares."""
        w_forward, w_backward = self.edge_weights(w_u, w_v)
        return w_forward * self.a_forward**2 + w_backward * self.a_backward**2

    def normal_equations(self, w_u: np.ndarray, w_v: np.ndarray) -> np.ndarray:
        """Write ``L`` for the weights into :attr:`laplacian`; return the right side."""
        e = self.edges
        w_forward, w_backward = self.edge_weights(w_u, w_v)
        t = w_forward * self.a_forward * self.b_forward
        t += w_backward * self.a_backward * self.b_backward
        self.laplacian.update(self.coupling(w_u, w_v))
        return np.bincount(e.q, t, self.n) - np.bincount(e.p, t, self.n)


def _pieces(problem: _Problem, coupling: np.ndarray, cut: float) -> np.ndarray:
    """Piece label of each pixel. The connected parts of the graph of the edges whose coupling
    is at least ``cut`` times the median, or which join two pixels facing the camera
    (:data:`CONTOUR_FACING`), are pieces where they hold an interior pixel (all four of its
    edges kept); each other part (a lone pixel, a sliver) joins, layer by layer from the
    pieces outwards, the piece of the neighbour it is most strongly coupled to across a cut."""
    import scipy.sparse
    from scipy.sparse.csgraph import connected_components

    e, n = problem.edges, problem.n
    facing = np.minimum(problem.facing[e.p], problem.facing[e.q]) >= CONTOUR_FACING
    kept = (coupling >= cut * np.median(coupling)) | facing
    graph = scipy.sparse.coo_matrix(
        (np.ones(int(kept.sum())), (e.p[kept], e.q[kept])), shape=(n, n)
    )
    count, part = connected_components(graph, directed=False)
    interior = np.bincount(e.p[kept], minlength=n) + np.bincount(e.q[kept], minlength=n) == 4
    placed = np.bincount(part, interior, minlength=count) > 0
    piece = np.arange(count)
    p, q, c = e.p[~kept], e.q[~kept], coupling[~kept]  # the cuts, from either side
    joining, joined, strength = part[np.r_[p, q]], part[np.r_[q, p]], np.r_[c, c]
    while True:
        waiting = ~placed[joining]
        joining, joined, strength = joining[waiting], joined[waiting], strength[waiting]
        reaching = placed[joined]
        if not reaching.any():
            return np.unique(piece[part], return_inverse=True)[1]
        a, b = joining[reaching], joined[reaching]
        order = np.lexsort((strength[reaching], a))  # by part, then coupling
        strongest = order[np.r_[a[order][1:] != a[order][:-1], True]]
        piece[a[strongest]] = piece[b[strongest]]
        placed[a[strongest]] = True


def _scaled_pieces(
    problem: _Problem,
    z: np.ndarray,
    weights: tuple[np.ndarray, np.ndarray],
    cut: float,
    reference: Callable[[], np.ndarray],
    fixed: np.ndarray | None = None,
) -> np.ndarray:
    """``z`` with each piece's free constant moved so that its mean is the ``reference()``'s
    there, but for the pieces holding a ``fixed`` pixel (:func:`_pieces`). Without ``fixed``
    pixels and with one piece per part of the mask, ``z`` (each part's constant is its own)."""
    piece = _pieces(problem, problem.coupling(*weights), cut)
    if fixed is None and piece.max() + 1 == _mask_parts(problem.edges.index >= 0):
        return z
    target = reference()
    shift = np.bincount(piece, target - z) / np.bincount(piece)
    if fixed is not None:
        shift[np.unique(piece[fixed])] = 0.0
    return z + shift[piece]


def _mask_parts(mask: np.ndarray) -> int:
    """How many 4-connected parts ``mask`` has."""
    import scipy.ndimage

    return int(scipy.ndimage.label(mask)[1])


def _solve(
    laplacian: _Laplacian,
    rhs: np.ndarray,
    z: np.ndarray,
    rtol: float,
    prior: np.ndarray,
) -> int:
    """Conjugate gradients on ``(L + diag(prior)) z = rhs`` in place on ``z``; returns the
    steps."""
    from brdfkit.vision._bilateral_kernels import stencil_cg

    degree = laplacian.degree + prior
    right, left, up, down = laplacian.weights
    return int(
        stencil_cg(
            degree, right, left, up, down, laplacian.up, laplacian.down, rhs, z, rtol,
            CG_MAX_ITERATIONS,
        )
    )  # fmt: skip


def _normalised(z: np.ndarray, mask: np.ndarray, perspective: bool) -> np.ndarray:
    """Depth with each connected part's free constant fixed as least squares does: nearest
    pixel at 0 (orthographic) or geometric mean 1 (perspective)."""
    import scipy.ndimage

    labels, count = scipy.ndimage.label(mask)
    part = labels[mask] - 1
    if perspective:
        return np.exp(z - (np.bincount(part, z, count) / np.bincount(part, minlength=count))[part])
    nearest = np.full(count, np.inf)
    np.minimum.at(nearest, part, z)
    return z - nearest[part]


def _on_mask(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    out = np.full(mask.shape, np.nan)
    out[mask] = values
    return out


def bilateral_integration(
    normals: ArrayLike,
    mask: ArrayLike | None = None,
    camera: ArrayLike | None = None,
    *,
    k: float = 2.0,
    depth_prior: ArrayLike | None = None,
    prior_weight: float = PRIOR_WEIGHT,
    continuity: float = 0.0,
    pieces: float = 0.0,
    tolerance: float = 1e-4,
    max_iterations: int = 100,
    solver_tolerance: float = 1e-3,
    callback: Callable[[int, int], None] | None = None,
) -> BilateralIntegration:
    """Depth from normals, discontinuities kept (bilateral normal integration, Cao et al. 2022).

    Minimises the bilateral energy of the module docstring by iteratively reweighted least
    squares from ``z = 0`` and weights ½, each linear system solved by Jacobi-preconditioned
    conjugate gradients warm-started from the previous depth.

    Parameters
    ----------
    normals : (H, W, 3) unit normals (x right, y up, z towards the camera).
    mask : (H, W) bool, the pixels to integrate; all when omitted.
    camera : (3, 3) intrinsics ``K`` (perspective); orthographic when omitted.
    k : sharpness of the sigmoid weights, >= 0 (0: least squares; the authors' default 2).
    depth_prior : (H, W) depth known in places (NaN elsewhere): perspective, in the units
        wanted for the result; orthographic, in pixels (the normals' slopes are per pixel).
        Without it depth is known up to a constant (orthographic) or a scale.
    prior_weight : ``β`` > 0, the weight of each known depth as a fraction of the median
        equation weight (module docstring); :data:`PRIOR_WEIGHT` by default.
    continuity : ``γ`` >= 0, the continuity prior's strength as a fraction of the stiffness of
        the mask's softest least-squares shape (module docstring); 0, the authors' method,
        leaves loose modes where the iterations from a fronto-parallel plane put them;
        :data:`CONTINUITY` (1 %) is ``brdfkit integrate``'s ``bilateral_continuity``.
    pieces : ``γ_p`` >= 0; when > 0, after the iterations (the authors' method unchanged) the
        edges whose coupling is below ``γ_p`` times the median coupling are cut and each
        connected piece's free constant is set from the least-squares surface (pixels of no
        part with an interior pixel join a neighbour's piece; module docstring), but for the
        pieces where ``depth_prior`` knows a depth; :data:`PIECES`
        (1 %) is ``brdfkit integrate``'s default. Not with ``continuity``.
    tolerance : stop when the energy changes by less than this fraction.
    max_iterations : most reweighting iterations.
    solver_tolerance : relative residual at which each linear solve stops.
    callback : called as ``callback(iteration, max_iterations)`` after each iteration.

    Returns
    -------
    BilateralIntegration
        ``depth`` away from the camera, NaN outside the mask: without a prior, in pixel units
        with each connected part's nearest pixel at 0 (orthographic), or with a geometric mean
        of 1 per part (perspective); with one, in the prior's units.

    Raises
    ------
    brdfkit.errors.ParameterError
        Normals not (H, W, 3) or not finite in the mask, a mask of another shape or empty, a
        camera that is not a (3, 3) matrix with positive focal lengths, a prior of another
        shape, empty or not positive (perspective), or an option out of its range.
    brdfkit.errors.ResourceError
        More mask pixels than the memory available holds.

    Notes
    -----
    Claims, tested: a depth step is kept where least squares smears it (orthographic and
    perspective); a plane is recovered (exactly orthographic, to the finite differences' error
    in perspective); a prior sets the offset and units, and in perspective a sparse one sets
    the relative scale of parts the normals leave free; on DiLiGenT cow the mean absolute depth
    error is the authors' (0.058 mm). On the seven DiLiGenT objects, from the normals their code
    reads (not renormalised: a change of 1e-4 in length, carried by the inexact solves, moves
    it by up to 1e-3 mm), it is theirs to 1e-9 mm, three times as fast (``benchmarks/``).

    Limit: scaling part of a surface about the camera centre leaves its normals unchanged, so
    the relative scale (orthographic: offset) of parts joined only across occluding contours is
    not in the data; the weak coupling the weights leave across the contour sets it. On DiLiGenT
    goblet, whose stem and foot meet the cup only behind its lower rim, each part's shape is
    within 0.3 mm, but the rim's own slope carried across the contour gives a 3.5 mm step where
    the true one is 25 mm: the foot comes out 1.7 % too near (tested), 9 mm mean error. With
    ``continuity=CONTINUITY`` the least-squares surface decides it: 1.0 % too near, 5.5 mm
    (tested; the shapes still within 0.35 mm, and on the step below the halves move by under
    5 % of the way to least squares' bent shape, tested). On the seven DiLiGenT objects the
    mean error falls from 1.74 to 1.26 mm, but bear (0.33 to 0.42 mm) and harvest (1.84 to
    1.87 mm) get worse. A ``depth_prior`` is the way to know it.

    With ``pieces=PIECES``: inside each piece the result differs from the authors' by one
    constant, and each piece's mean depth is least squares' (tested where a grazing edge parts a
    plane from the surface in front of it); where nothing, or only silhouette pixels and
    slivers, are cut off it is theirs to rounding (tested on the step below, a sphere in
    perspective, a strip two pixels wide); on DiLiGenT goblet the foot is 0.9 % too near
    rather than 1.7 % (tested); on the seven DiLiGenT objects the mean error is 1.19 mm
    against the authors' 1.74 (``benchmarks/``). At 0.5 % the weights do not part goblet's foot
    from its cup; from 1 % to 3 % the seven objects' mean error is 1.19 to 1.15 mm, harvest the
    authors' (tested at 2 %: only occluding contours are cut, not its creases); at 5 % bear is
    cut at a contour that least squares misplaces (0.50 mm rather than 0.33). A weak edge
    between two surfaces that both face the camera (a box's top over the floor seen from
    above, its side hidden) is not cut either: there the result is the authors'.

    References
    ----------
    X. Cao, H. Santo, B. Shi, F. Okura, Y. Matsushita, "Bilateral normal integration",
    ECCV 2022.

    Examples
    --------
    A flat left half; the right half a plane whose depth grows by 2 pixels per row, so that the
    step between them varies along the border (no smooth surface has these normals). Each half
    keeps its own shape; least squares bends both:

    >>> import numpy as np
    >>> from brdfkit.vision.normal_integration import least_squares_integration
    >>> normals = np.zeros((8, 8, 3))
    >>> normals[..., 2] = 1.0
    >>> normals[:, 4:] = np.array([0.0, -2.0, 1.0]) / np.sqrt(5.0)
    >>> depth = bilateral_integration(normals).depth
    >>> np.diff(depth[:, 6]).round(1).tolist(), float(np.ptp(depth[:, 1]).round(1))
    ([2.0, 2.0, 1.9, 1.9, 1.9, 2.0, 2.0], 0.1)
    >>> depth = least_squares_integration(normals)
    >>> np.diff(depth[:, 6]).round(1).tolist(), float(np.ptp(depth[:, 1]).round(1))
    ([1.8, 1.6, 1.5, 1.4, 1.5, 1.6, 1.8], 3.0)

    Piece scales change only what the weights part; these halves stay joined where their step
    vanishes, so nothing is cut and the result is the authors':

    >>> authors = bilateral_integration(normals).depth
    >>> pieced = bilateral_integration(normals, pieces=PIECES).depth
    >>> float(np.abs(pieced - authors).max()) < 1e-12
    True

    The continuity prior leaves shapes that the normals hold where they were:

    >>> depth = bilateral_integration(normals, continuity=CONTINUITY).depth
    >>> np.diff(depth[:, 6]).round(1).tolist(), float(np.ptp(depth[:, 1]).round(1))
    ([2.0, 2.0, 1.9, 1.9, 1.9, 2.0, 2.0], 0.1)
    """
    normals, mask = check_normals(normals, mask)
    if camera is not None:
        camera = check_camera(camera)
    if not (np.isfinite(k) and k >= 0):
        raise ParameterError(f"k must be a finite number >= 0, got {k}")
    for name, value in (("tolerance", tolerance), ("solver_tolerance", solver_tolerance)):
        if not (np.isfinite(value) and 0 < value < 1):
            raise ParameterError(f"{name} must be in (0, 1), got {value}")
    if not (np.isfinite(prior_weight) and prior_weight > 0):
        raise ParameterError(f"prior_weight must be a finite number > 0, got {prior_weight}")
    if not (np.isfinite(continuity) and continuity >= 0):
        raise ParameterError(f"continuity must be a finite number >= 0, got {continuity}")
    if not (np.isfinite(pieces) and 0 <= pieces < 1):
        raise ParameterError(f"pieces must be in [0, 1), got {pieces}")
    if pieces > 0 and continuity > 0:
        raise ParameterError("pieces sets the scales that continuity would set: give one of them")
    check_count("max_iterations", max_iterations, MAX_ITERATIONS)
    z_prior = _check_prior(depth_prior, mask, camera)
    offset, known = 0.0, None
    if z_prior is not None:  # solved about the prior's mean, so that CG's tolerance is the shape's
        known = np.isfinite(z_prior)
        offset = float(np.mean(z_prior[known]))
        z_prior = z_prior - offset
    pixels = int(mask.sum())
    check_memory(f"bilateral integration of {pixels} pixels", BYTES_PER_PIXEL * pixels)
    problem = _Problem(normals, mask, camera)
    z = np.zeros(problem.n)
    if continuity > 0:  # μ = γ π² / N median(ñ²) (module docstring)
        reference = _least_squares_reference(normals, mask, camera, z_prior, known)
        mu = continuity * np.pi**2 / problem.n * problem.typical
        z = reference.copy()
    w_u = w_v = np.full(problem.n, 0.5)
    energy = float(np.sum(problem.b[0] ** 2 + problem.b[1] ** 2))  # weights ½ at z = 0
    energies: list[float] = []
    steps = 0
    for iteration in range(max_iterations):
        rhs = problem.normal_equations(w_u, w_v)
        prior = np.zeros(problem.n)
        if z_prior is not None:
            lam = prior_weight * problem.typical
            z = _moved_onto_prior(z, z_prior, known)
            rhs = rhs + lam * np.where(known, z_prior, 0.0)
            prior += lam * known
        if continuity > 0:
            rhs = rhs + mu * reference
            prior += mu
        steps += _solve(problem.laplacian, rhs, z, solver_tolerance, prior)
        previous, (w_u, w_v, energy) = energy, problem.reweight(z, k)
        energies.append(energy)
        if callback is not None:
            callback(iteration + 1, max_iterations)
        if abs(energy - previous) < tolerance * previous:
            break
    if pieces > 0:
        reference = partial(_least_squares_reference, normals, mask, camera, z_prior, known)
        z = _scaled_pieces(problem, z, (w_u, w_v), pieces, reference, known)
    if z_prior is not None:
        depth = np.exp(z + offset) if camera is not None else z + offset
    else:
        depth = _normalised(z, mask, camera is not None)
    return BilateralIntegration(
        _on_mask(depth, mask), _on_mask(w_u, mask), _on_mask(w_v, mask), tuple(energies), steps
    )
