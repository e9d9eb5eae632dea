r"""Testing helpers for samplers, in the spirit of :mod:`numpy.testing`.

:func:`chi2_test` is Pearson's χ² goodness-of-fit test of a directional sampler against the density
it claims, as run by Mitsuba 3 and pbrt on every BSDF and warp: draw ``n`` samples, histogram them
over a (θ, φ) grid, integrate the claimed pdf over every cell to get the expected counts, pool the
cells whose expectation is too small, and compare. :func:`chi2_test_planar` does the same on a
rectangle of the plane (disks, triangles, 2D distributions). :func:`assert_chi2` and
:func:`assert_chi2_planar` raise an :class:`AssertionError` that shows where the histogram and the
density disagree.

Samplers may fail (a BRDF sampler that falls below the surface, say): ``sample_fn`` then returns
``(directions, valid)`` and the claimed pdf integrates to the expected fraction of valid samples,
:math:`\int p\,d\omega = P(\text{valid}) \le 1`. The invalid samples, and any sample outside the
histogram's domain, form one more category whose expected count is :math:`n(1 - \int p)`, so a
sampler that fails too often or too rarely is rejected too.

References
----------
.. [1] K. Pearson, "On the criterion that a given system of deviations from the probable ...",
       Philosophical Magazine 50(302), 1900.
.. [2] W. Jakob et al., Mitsuba 3, ``mitsuba/python/chi2.py`` (``ChiSquareTest``), 2022.
.. [3] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., ``pbrt-v4``
       ``src/pbrt/bsdfs_test.cpp`` (χ² tests of BSDF sampling), 2023.
.. [4] Z. Šidák, "Rectangular confidence regions for the means of multivariate normal
       distributions", JASA 62(318), 1967.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from brdfkit._array import check_param, to_numpy
from brdfkit.geometry import spherical_to_cartesian

__all__ = [
    "Chi2Result",
    "assert_chi2",
    "assert_chi2_planar",
    "brdf_sampler",
    "chi2_test",
    "chi2_test_planar",
]

_CHUNK = 1 << 20
"""Largest number of points handed to ``pdf_fn`` in one call."""

_UNIT_TOLERANCE = 1e-4
"""Largest |‖ω‖ − 1| accepted from a directional sampler (float32 samplers reach ~1e-7)."""

_EXCESS_TOLERANCE = 1e-3
"""How far above 1 the integral of a claimed pdf may lie (quadrature error) before rejection."""

_ZERO_PROBABILITY = 1e-12
"""Cell probabilities at or below this are zero (the rounding of sums of quadrature terms)."""

_MIN_DEPTH = 1
"""Levels every histogram cell is subdivided before quadrature may stop (its 4×4 sub-cells
against its 2×2 quarters at the earliest), so that a small feature of the pdf (the corner of a
spherical triangle) is seen by the nodes at all. (Level 2 would compare 8×8 with 4×4
sub-cells: four times the evaluations, for the same p-values to two digits on the atlas's
models.)"""

_EDGE_INSET = 1e-7
"""Relative distance of the outermost quadrature nodes from the edges of their rectangle."""


@dataclass(frozen=True, eq=False)
class Chi2Result:
    """The outcome of :func:`chi2_test` / :func:`chi2_test_planar`.

    Attributes
    ----------
    statistic : Pearson's :math:`\\chi^2 = \\sum (O - E)^2 / E` over the pooled categories.
    dof : degrees of freedom (categories − 1).
    p_value : probability of a statistic at least this large if the sampler follows the pdf.
    threshold : the significance level after the Šidák correction for ``test_count`` tests.
    passed : ``p_value >= threshold`` and no sanity check failed.
    observed, expected : (bins0, bins1) sample counts and integrated pdf × n per cell.
    edges : the cell edges along both parameter axes (see ``axes``).
    axes : names of the parameter axes (``("cos θ", "φ")``, ``("θ", "φ")`` or ``("x", "y")``).
    outside_observed : samples that were invalid or fell outside the histogram's domain.
    outside_expected : their expected number :math:`n(1 - \\int p)`, moved towards the observed
        number by at most ``3 · n · quadrature_error`` (the expected cell counts share the rest).
    pdf_integral : :math:`\\int p` over the domain, by adaptive Gauss–Lobatto quadrature.
    quadrature_error : estimated absolute error of ``pdf_integral`` (from cells that reached the
        subdivision limit, e.g. across a discontinuity of the pdf).
    n_samples : number of samples drawn.
    pooled_in, pooled_out : how many low-expectation categories were pooled into how many.
    messages : reasons for failure found by the sanity checks, and notes.
    """

    statistic: float
    dof: int
    p_value: float
    threshold: float
    passed: bool
    observed: np.ndarray
    expected: np.ndarray
    edges: tuple[np.ndarray, np.ndarray]
    axes: tuple[str, str]
    outside_observed: int
    outside_expected: float
    pdf_integral: float
    quadrature_error: float
    n_samples: int
    pooled_in: int
    pooled_out: int
    messages: tuple[str, ...] = field(default=())

    def residuals(self) -> np.ndarray:
        """Standardised residuals :math:`(O - E)/\\sqrt{E}` per cell (0 where E = 0)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (self.observed - self.expected) / np.sqrt(self.expected)
        return np.where(self.expected > 0, z, 0.0)

    def __str__(self) -> str:
        verdict = "passed" if self.passed else "FAILED"
        lines = [
            f"χ² test {verdict}: χ² = {self.statistic:.1f} with {self.dof} d.o.f., "
            f"p = {self.p_value:.3g} (threshold {self.threshold:.3g})",
            f"  {self.n_samples} samples; ∫pdf = {self.pdf_integral:.6f} "
            f"(± {self.quadrature_error:.1e}); invalid or outside the domain: "
            f"{self.outside_observed} observed, {self.outside_expected:.1f} expected",
        ]
        if self.pooled_in:
            lines.append(f"  pooled {self.pooled_in} low-expectation cells into {self.pooled_out}")
        lines += [f"  {m}" for m in self.messages]
        z = self.residuals()
        worst = np.argsort(-np.abs(z), axis=None)[:6]
        (edges0, edges1), (name0, name1) = self.edges, self.axes
        lines.append(f"  largest standardised residuals (O − E)/√E, cells in ({name0}, {name1}):")
        for flat in worst:
            i, j = np.unravel_index(flat, z.shape)
            lines.append(
                f"    [{edges0[i]:.3g}, {edges0[i + 1]:.3g}) × [{edges1[j]:.3g}, "
                f"{edges1[j + 1]:.3g}): O = {self.observed[i, j]:.0f}, "
                f"E = {self.expected[i, j]:.1f}, z = {z[i, j]:+.1f}"
            )
        lines.append(f"  residual map (rows: {name0}, columns: {name1}; clipped to ±9):")
        for row in np.clip(np.rint(z), -9, 9).astype(int):
            lines.append("    " + " ".join(f"{v:+d}" if v else " 0" for v in row))
        return "\n".join(lines)

    def assert_passed(self) -> None:
        """Raise :class:`AssertionError` with :meth:`__str__`'s summary unless the test passed."""
        if not self.passed:
            raise AssertionError(str(self))


@dataclass(frozen=True)
class _Domain:
    """A rectangle of parameters, its map to sample space and back, and the map's Jacobian."""

    edges: tuple[np.ndarray, np.ndarray]
    axes: tuple[str, str]
    forward: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]  # params → (points, |J|)
    backward: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, list[str]]]  # → (params, in)


def _spherical_domain(
    theta_bins: int, phi_bins: int, sphere: bool, binning: Literal["cos", "theta"]
) -> _Domain:
    """(1 − cos θ, φ) (equal-area rows) or (θ, φ) cells over the sphere or upper hemisphere."""
    if binning == "cos":
        t_max, axes = (2.0 if sphere else 1.0), ("1 − cos θ", "φ")
    elif binning == "theta":
        t_max, axes = (math.pi if sphere else math.pi / 2), ("θ", "φ")
    else:
        raise ValueError(f"binning must be 'cos' or 'theta'; got {binning!r}")
    edges = (np.linspace(0.0, t_max, theta_bins + 1), np.linspace(0.0, 2 * math.pi, phi_bins + 1))

    def forward(params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t, phi = params[:, 0], params[:, 1]
        theta = np.arccos(np.clip(1 - t, -1, 1)) if binning == "cos" else t
        jacobian = np.ones_like(t) if binning == "cos" else np.sin(t)
        return spherical_to_cartesian(theta, phi), jacobian

    def backward(dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
        notes = []
        if dirs.ndim != 2 or dirs.shape[1] != 3:
            raise ValueError(
                f"sample_fn must return directions with a last axis of length 3; got shape "
                f"{dirs.shape}"
            )
        length = np.linalg.norm(dirs, axis=1)
        off = np.abs(length - 1) > _UNIT_TOLERANCE
        if np.any(off):
            notes.append(
                f"{np.count_nonzero(off)} valid samples are not unit vectors "
                f"(e.g. ‖ω‖ = {length[off][0]:.6g})"
            )
        z = np.clip(dirs[:, 2], -1, 1)
        t = 1 - z if binning == "cos" else np.arccos(z)
        phi = np.arctan2(dirs[:, 1], dirs[:, 0])
        phi = np.where(phi < 0, phi + 2 * math.pi, phi)
        return np.stack([t, phi], axis=1), t <= t_max, notes

    return _Domain(edges, axes, forward, backward)


def _planar_domain(
    bounds: tuple[tuple[float, float], tuple[float, float]], bins: tuple[int, int]
) -> _Domain:
    """Cells of the rectangle ``bounds`` = ((x0, x1), (y0, y1)) of the plane."""
    (x0, x1), (y0, y1) = bounds
    if not (x1 > x0 and y1 > y0):
        raise ValueError(f"bounds must be ((x0, x1), (y0, y1)) with x1 > x0, y1 > y0; got {bounds}")
    edges = (np.linspace(x0, x1, bins[0] + 1), np.linspace(y0, y1, bins[1] + 1))

    def forward(params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return params, np.ones(len(params))

    def backward(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
        if points.ndim != 2 or points.shape[1] != 2:
            raise ValueError(
                f"sample_fn must return points with a last axis of length 2; got shape "
                f"{points.shape}"
            )
        inside = (
            (points[:, 0] >= x0)
            & (points[:, 0] <= x1)
            & (points[:, 1] >= y0)
            & (points[:, 1] <= y1)
        )
        return points, inside, []

    return _Domain(edges, ("x", "y"), forward, backward)


def _gauss_lobatto(order: int) -> tuple[np.ndarray, np.ndarray]:
    r"""Nodes and weights of the ``order``-point Gauss–Lobatto rule on [0, 1] (exact for
    polynomials of degree 2·order − 3): the end points and the roots of :math:`P'_{n-1}`, with
    weights :math:`2 / (n(n-1) P_{n-1}(x)^2)` on [−1, 1].

    References
    ----------
    .. [1] M. Abramowitz and I. A. Stegun, *Handbook of Mathematical Functions*, eq. 25.4.32.
    """
    if isinstance(order, bool) or not isinstance(order, int | np.integer) or order < 3:
        raise ValueError(f"order must be an integer ≥ 3; got {order!r}")
    legendre = np.polynomial.legendre.Legendre.basis(order - 1)
    nodes = np.concatenate([[-1.0], np.sort(legendre.deriv().roots().real), [1.0]])
    weights = 2 / (order * (order - 1) * legendre(nodes) ** 2)
    return (nodes + 1) / 2, weights / 2


def _integrate_cells(
    density: Callable[[np.ndarray], np.ndarray],
    lo: np.ndarray,
    hi: np.ndarray,
    *,
    rule: tuple[np.ndarray, np.ndarray],
    tol: float,
    min_depth: int,
    max_depth: int,
) -> tuple[np.ndarray, float]:
    r"""Integrals of ``density`` over the rectangles ``[lo, hi]`` (shape (K, 2)), adaptively.

    Each rectangle is integrated with the tensor product of the 1D ``rule`` (nodes and weights on
    [0, 1], Gauss–Lobatto from :func:`_gauss_lobatto`) and again as the sum over its four
    quarters; it is accepted when the two agree to
    ``tol · max(area share, |integral|)`` and it is at least ``min_depth`` levels deep; otherwise
    its quarters are refined in turn, up to ``max_depth`` levels (vectorised: one ``density`` call
    per level and chunk). Lobatto nodes reach the rectangle's edges, so a discontinuity of the
    integrand cannot hide between the outermost nodes of both rules (as it can with Gauss–Legendre
    nodes); they are pulled inside by a relative ``1e-7`` so that a discontinuity lying exactly on
    an edge (the horizon of a hemisphere) is not evaluated on both sides.

    Returns
    -------
    integrals : (K,).
    error : the summed disagreement of the rectangles still unresolved at ``max_depth``.
    """
    nodes, weights = rule
    nodes = _EDGE_INSET + (1 - 2 * _EDGE_INSET) * nodes
    grid = np.stack(np.meshgrid(nodes, nodes, indexing="ij"), axis=-1).reshape(-1, 2)
    grid_weights = np.outer(weights, weights).ravel()

    def integrate(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        size = hi - lo
        points = (lo[:, None, :] + size[:, None, :] * grid[None]).reshape(-1, 2)
        values = np.concatenate(
            [density(points[k : k + _CHUNK]) for k in range(0, len(points), _CHUNK)]
        )
        return values.reshape(len(lo), -1) @ grid_weights * np.prod(size, axis=1)

    total_area = float(np.sum(np.prod(hi - lo, axis=1)))
    integrals = np.zeros(len(lo))
    owner = np.arange(len(lo))
    coarse = integrate(lo, hi)
    error = 0.0
    for depth in range(max_depth):
        mid = (lo + hi) / 2
        quarters_lo = np.stack(
            [lo, np.stack([mid[:, 0], lo[:, 1]], 1), np.stack([lo[:, 0], mid[:, 1]], 1), mid]
        )
        quarters_hi = np.stack(
            [mid, np.stack([hi[:, 0], mid[:, 1]], 1), np.stack([mid[:, 0], hi[:, 1]], 1), hi]
        )
        parts = integrate(quarters_lo.reshape(-1, 2), quarters_hi.reshape(-1, 2)).reshape(4, -1)
        fine = parts.sum(axis=0)
        difference = np.abs(fine - coarse)
        share = np.prod(hi - lo, axis=1) / total_area
        converged = difference <= tol * np.maximum(share, np.abs(fine))
        done = converged & (depth >= min_depth)
        if depth == max_depth - 1:
            error = float(np.sum(difference[~converged]))
            done[:] = True
        np.add.at(integrals, owner[done], fine[done])
        refine = ~done
        if not np.any(refine):
            break
        owner = np.tile(owner[refine], 4)
        lo = quarters_lo[:, refine].reshape(-1, 2)
        hi = quarters_hi[:, refine].reshape(-1, 2)
        coarse = parts[:, refine].ravel()
    return integrals, error


def _pearson(
    observed: np.ndarray, expected: np.ndarray, min_expected: float
) -> tuple[float, int, int, int]:
    """Pearson's statistic after pooling, in increasing order of expectation, the categories whose
    expected count is below ``min_expected`` into groups of at least ``min_expected`` (a left-over
    group joins the next-smallest category). Returns (χ², categories, pooled_in, pooled_out)."""
    order = np.argsort(expected, kind="stable")
    observed, expected = observed[order], expected[order]
    small = int(np.searchsorted(expected, min_expected))
    groups_o, groups_e = [], []
    pooled_o = pooled_e = 0.0
    for o, e in zip(observed[:small], expected[:small], strict=True):
        pooled_o, pooled_e = pooled_o + o, pooled_e + e
        if pooled_e >= min_expected:
            groups_o.append(pooled_o)
            groups_e.append(pooled_e)
            pooled_o = pooled_e = 0.0
    pooled_out = len(groups_e)
    rest_o, rest_e = list(observed[small:]), list(expected[small:])
    if pooled_e > 0:
        if groups_e:
            groups_o[-1] += pooled_o
            groups_e[-1] += pooled_e
        elif rest_e:
            rest_o[0] += pooled_o
            rest_e[0] += pooled_e
        else:
            groups_o, groups_e, pooled_out = [pooled_o], [pooled_e], 1
    o = np.array(groups_o + rest_o, dtype=np.float64)
    e = np.array(groups_e + rest_e, dtype=np.float64)
    statistic = float(np.sum((o - e) ** 2 / e)) if len(e) else 0.0
    return statistic, len(e), small, pooled_out


def _run(
    domain: _Domain,
    sample_fn: Callable[[Any], Any],
    pdf_fn: Callable[[Any], Any],
    *,
    n_samples: int,
    sample_dim: int,
    significance: float,
    test_count: int,
    min_expected: float,
    seed: int,
    convert: Callable[[np.ndarray], Any] | None,
    order: int,
    max_depth: int,
) -> Chi2Result:
    """The test itself, on any :class:`_Domain`."""
    from scipy import stats

    if n_samples < 1:
        raise ValueError(f"n_samples must be a positive integer; got {n_samples}")
    check_param("significance", significance, 0.0, 1.0, lo_open=True, hi_open=True)
    if test_count < 1:
        raise ValueError(f"test_count must be a positive integer; got {test_count}")
    if sample_dim < 1:
        raise ValueError(f"sample_dim must be a positive integer; got {sample_dim}")
    if max_depth < 1:
        raise ValueError(f"max_depth must be a positive integer; got {max_depth}")
    rule = _gauss_lobatto(order)
    to_backend = convert if convert is not None else (lambda a: a)
    messages: list[str] = []

    # Histogram of the samples.
    u = np.random.default_rng(seed).random((n_samples, sample_dim))
    out = sample_fn(to_backend(u))
    if isinstance(out, tuple | list):
        points, valid = to_numpy(out[0]), to_numpy(out[1]) != 0
    else:
        points, valid = to_numpy(out), np.ones((), dtype=bool)
    points = np.asarray(points, dtype=np.float64).reshape(n_samples, -1)
    valid = np.broadcast_to(valid, np.shape(points)[:1]) if valid.ndim == 0 else valid.ravel()
    finite = np.all(np.isfinite(points), axis=1)
    if np.any(valid & ~finite):
        messages.append(f"{np.count_nonzero(valid & ~finite)} valid samples are not finite")
    # Invalid samples may hold anything (zeros, say): only the valid ones are mapped and checked.
    params, inside, notes = domain.backward(points[valid & finite])
    messages += notes
    params = params[inside]
    edges0, edges1 = domain.edges
    shape = (len(edges0) - 1, len(edges1) - 1)
    i = np.clip(np.searchsorted(edges0, params[:, 0], side="right") - 1, 0, shape[0] - 1)
    j = np.clip(np.searchsorted(edges1, params[:, 1], side="right") - 1, 0, shape[1] - 1)
    observed = np.bincount(i * shape[1] + j, minlength=shape[0] * shape[1]).reshape(shape)
    outside_observed = n_samples - len(params)

    # Expected counts: the pdf integrated over every cell.
    bad_pdf: list[float] = []

    def density(p: np.ndarray) -> np.ndarray:
        points, jacobian = domain.forward(p)
        values = np.asarray(to_numpy(pdf_fn(to_backend(points))), dtype=np.float64)
        values = np.broadcast_to(values, points.shape[:1]).ravel()
        if not np.all(np.isfinite(values) & (values >= 0)):
            bad_pdf.append(float(values[~(np.isfinite(values) & (values >= 0))][0]))
            values = np.where(np.isfinite(values) & (values >= 0), values, 0.0)
        return values * jacobian

    lo0, lo1 = np.meshgrid(edges0[:-1], edges1[:-1], indexing="ij")
    hi0, hi1 = np.meshgrid(edges0[1:], edges1[1:], indexing="ij")
    probabilities, quadrature_error = _integrate_cells(
        density,
        np.stack([lo0.ravel(), lo1.ravel()], axis=1),
        np.stack([hi0.ravel(), hi1.ravel()], axis=1),
        rule=rule,
        tol=0.01 / math.sqrt(n_samples),
        min_depth=_MIN_DEPTH,
        max_depth=max_depth,
    )
    if bad_pdf:
        messages.append(f"pdf_fn returned negative or non-finite values (e.g. {bad_pdf[0]:g})")
    pdf_integral = float(probabilities.sum())
    if pdf_integral > 1 + _EXCESS_TOLERANCE:
        messages.append(f"the pdf integrates to {pdf_integral:.6f} > 1 over the domain")
    # ∫p is known to ± the quadrature error only (a discontinuous pdf leaves ~1e-4): within three
    # times that band, the expected fraction of invalid/outside samples is the one closest to the
    # observed fraction, and the cells share the rest. Smooth pdfs have no band: no freedom.
    allowance = 3 * quadrature_error
    missing = outside_observed / n_samples
    missing = min(max(missing, 1 - pdf_integral - allowance), 1 - pdf_integral + allowance)
    missing = min(max(missing, 0.0), 1.0)
    cells_total = min(max(1 - missing, pdf_integral - allowance), pdf_integral + allowance)
    scale = cells_total / pdf_integral if pdf_integral > 0 else 1.0
    expected = n_samples * scale * probabilities.reshape(shape)
    outside_expected = n_samples * missing

    all_observed = np.append(observed.ravel(), outside_observed).astype(np.float64)
    all_expected = np.append(expected.ravel(), outside_expected)
    # Expectations at the level of the rounding of ∫p (1e-16 · n) count as zero.
    zero = all_expected <= _ZERO_PROBABILITY * n_samples
    impossible = zero & (all_observed > 0)
    if np.any(impossible):
        where = "outside the domain or invalid" if impossible[-1] else "in cells of zero density"
        messages.append(
            f"{int(all_observed[impossible].sum())} samples fell where the pdf is 0 ({where})"
        )
    keep = ~zero
    statistic, categories, pooled_in, pooled_out = _pearson(
        all_observed[keep], all_expected[keep], min_expected
    )
    dof = categories - 1
    if dof < 1:
        messages.append("too few categories with a positive expectation (d.o.f. < 1)")
    p_value = float(stats.chi2.sf(statistic, dof)) if dof >= 1 else math.nan
    threshold = 1 - (1 - significance) ** (1 / test_count)
    passed = not messages and math.isfinite(p_value) and p_value >= threshold
    return Chi2Result(
        statistic=statistic,
        dof=dof,
        p_value=p_value,
        threshold=threshold,
        passed=passed,
        observed=observed,
        expected=expected,
        edges=domain.edges,
        axes=domain.axes,
        outside_observed=outside_observed,
        outside_expected=outside_expected,
        pdf_integral=pdf_integral,
        quadrature_error=quadrature_error,
        n_samples=n_samples,
        pooled_in=pooled_in,
        pooled_out=pooled_out,
        messages=tuple(messages),
    )


def chi2_test(
    sample_fn: Callable[[Any], Any],
    pdf_fn: Callable[[Any], Any],
    *,
    sphere: bool = True,
    theta_bins: int = 10,
    phi_bins: int = 20,
    binning: Literal["cos", "theta"] = "cos",
    n_samples: int = 1_000_000,
    sample_dim: int = 2,
    significance: float = 0.01,
    test_count: int = 1,
    min_expected: float = 5.0,
    seed: int = 0,
    convert: Callable[[np.ndarray], Any] | None = None,
    order: int = 5,
    max_depth: int = 10,
) -> Chi2Result:
    r"""Pearson's χ² test that the directions of ``sample_fn`` follow the solid-angle ``pdf_fn``.

    ``n_samples`` i.i.d. variates ``u`` (shape ``(n, sample_dim)``, uniform in [0, 1)) go through
    ``sample_fn``; the resulting unit directions are histogrammed on ``theta_bins × phi_bins``
    cells, equal-area rows in :math:`1 - \cos\theta` (``binning="cos"``, as Mitsuba) or rows
    uniform in θ (``binning="theta"``, finer near the pole for peaked lobes), covering the sphere
    or, with ``sphere=False``, the upper hemisphere only. The expected count of a cell is
    :math:`n \int_{cell} p(\omega)\,d\omega`, the integral computed by adaptive tensor
    Gauss–Lobatto quadrature in the cell's parameters (with the Jacobian
    :math:`d\omega = d(1-\cos\theta)\,d\phi = \sin\theta\,d\theta\,d\phi`), refined until its error
    is about 1 % of the sampling noise :math:`\sqrt{n}`. Invalid samples and samples outside the
    domain form one more category with expectation :math:`n(1 - \int p)` (to within the
    quadrature's error). Categories expected
    fewer than ``min_expected`` times are pooled; :math:`\chi^2 = \sum (O - E)^2/E` is compared with
    the χ² distribution (``scipy.stats.chi2``) and the sampler passes when the p-value is at least
    the Šidák-corrected level :math:`1 - (1 - \alpha)^{1/m}` for ``m = test_count`` tests.

    The test also fails, whatever the p-value, when valid samples are not finite or not unit
    vectors, when samples fall where the pdf is 0, or when the pdf is negative, non-finite or
    integrates to more than 1.

    Parameters
    ----------
    sample_fn : ``u -> directions`` of shape ``(n, 3)``, or ``u -> (directions, valid)`` with
        ``valid`` (n,) booleans (nonzero = valid). Condition on ``wo`` by closure, e.g. for a
        BRDF: ``def sample_fn(u): s = brdf.sample(wo, u); return s.wi, s.pdf > 0``.
    pdf_fn : ``directions (m, 3) -> (m,)`` solid-angle density claimed for the valid samples.
    sphere : histogram the whole sphere (default) or only z ≥ 0.
    theta_bins, phi_bins : histogram resolution.
    binning : ``"cos"`` (equal-area rows) or ``"theta"`` (rows uniform in θ).
    n_samples : number of samples.
    sample_dim : number of uniforms per sample (2, or 3 for samplers that choose a lobe).
    significance : level α of the test (probability of rejecting a correct sampler).
    test_count : number of tests run together, for the Šidák correction.
    min_expected : pooling threshold on expected counts (5 is the textbook rule).
    seed : seed of the NumPy generator of ``u``.
    convert : applied to the NumPy float64 ``u`` and query directions before they are passed on,
        e.g. ``lambda a: torch.tensor(a, dtype=torch.float32)``; results are read back with
        ``to_numpy``.
    order : Gauss–Lobatto points per axis and sub-cell (≥ 3).
    max_depth : levels of adaptive subdivision at most.

    Returns
    -------
    Chi2Result

    References
    ----------
    .. [1] W. Jakob et al., Mitsuba 3, ``mitsuba/python/chi2.py``, 2022.
    .. [2] K. Pearson, Philosophical Magazine 50(302), 1900.
    .. [3] Z. Šidák, JASA 62(318), 1967.

    Examples
    --------
    The cosine-weighted warp follows its own density, not the uniform one:

    >>> from brdfkit.sampling import (
    ...     square_to_cosine_hemisphere,
    ...     square_to_cosine_hemisphere_pdf,
    ...     square_to_uniform_hemisphere_pdf,
    ... )
    >>> small = dict(sphere=False, theta_bins=5, phi_bins=10, n_samples=20_000)
    >>> result = chi2_test(square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf, **small)
    >>> result.passed, result.dof, round(result.pdf_integral, 6)
    (True, 49, 1.0)
    >>> chi2_test(square_to_cosine_hemisphere, square_to_uniform_hemisphere_pdf, **small).passed
    False
    """
    _check_bins("theta_bins", theta_bins)
    _check_bins("phi_bins", phi_bins)
    return _run(
        _spherical_domain(theta_bins, phi_bins, sphere, binning),
        sample_fn,
        pdf_fn,
        n_samples=n_samples,
        sample_dim=sample_dim,
        significance=significance,
        test_count=test_count,
        min_expected=min_expected,
        seed=seed,
        convert=convert,
        order=order,
        max_depth=max_depth,
    )


def chi2_test_planar(
    sample_fn: Callable[[Any], Any],
    pdf_fn: Callable[[Any], Any],
    *,
    bounds: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 1.0), (0.0, 1.0)),
    bins: tuple[int, int] = (20, 20),
    n_samples: int = 1_000_000,
    sample_dim: int = 2,
    significance: float = 0.01,
    test_count: int = 1,
    min_expected: float = 5.0,
    seed: int = 0,
    convert: Callable[[np.ndarray], Any] | None = None,
    order: int = 5,
    max_depth: int = 10,
) -> Chi2Result:
    r"""Pearson's χ² test that the 2D points of ``sample_fn`` follow the area density ``pdf_fn``.

    As :func:`chi2_test`, on the rectangle ``bounds = ((x0, x1), (y0, y1))`` cut into
    ``bins = (x_bins, y_bins)`` cells (``observed[i, j]`` is x-cell ``i``, y-cell ``j``):
    ``sample_fn`` returns points ``(n, 2)`` (or ``(points, valid)``) and ``pdf_fn`` maps ``(m, 2)``
    points to their density per unit area.

    References
    ----------
    .. [1] W. Jakob et al., Mitsuba 3, ``mitsuba/python/chi2.py`` (``PlanarDomain``), 2022.

    Examples
    --------
    The concentric disk warp on the square around the disk (the pdf's edge, the rim, cuts
    through cells, so their quadrature stops at a shallower ``max_depth`` here):

    >>> from brdfkit.sampling import (
    ...     square_to_uniform_disk_concentric,
    ...     square_to_uniform_disk_concentric_pdf,
    ... )
    >>> result = chi2_test_planar(
    ...     square_to_uniform_disk_concentric,
    ...     square_to_uniform_disk_concentric_pdf,
    ...     bounds=((-1.0, 1.0), (-1.0, 1.0)),
    ...     bins=(8, 8),
    ...     n_samples=20_000,
    ...     max_depth=6,
    ... )
    >>> result.passed, result.axes
    (True, ('x', 'y'))
    """
    _check_bins("bins[0]", bins[0])
    _check_bins("bins[1]", bins[1])
    return _run(
        _planar_domain(bounds, bins),
        sample_fn,
        pdf_fn,
        n_samples=n_samples,
        sample_dim=sample_dim,
        significance=significance,
        test_count=test_count,
        min_expected=min_expected,
        seed=seed,
        convert=convert,
        order=order,
        max_depth=max_depth,
    )


def _check_bins(name: str, value: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise ValueError(f"{name} must be a positive integer; got {value!r}")


def brdf_sampler(
    brdf: Any, wo: Any, record: list | None = None
) -> tuple[Callable[[Any], tuple[Any, Any]], Callable[[Any], Any]]:
    """The ``(sample_fn, pdf_fn)`` pair that :func:`chi2_test` takes for a BRDF's sampler at one
    view direction ``wo`` (shape ``(3,)``).

    ``sample_fn(u)`` draws ``brdf.sample(wo, u)`` for uniforms ``u`` of shape ``(n, d)`` and
    returns ``(wi, valid)``, valid where the sample has pdf > 0 and is not from a delta lobe;
    each :class:`~brdfkit.brdf.base.Sample` is appended to ``record`` when one is given.
    ``pdf_fn(wi)`` is ``brdf.pdf(wi, wo)``.

    References
    ----------
    .. [1] W. Jakob et al., Mitsuba 3, ``mitsuba/python/chi2.py`` (``BSDFAdapter``), 2022.

    Examples
    --------
    GGX's visible-normal sampler, seen from 37° (three uniforms per sample):

    >>> import numpy as np
    >>> from brdfkit.brdf import parse
    >>> sample_fn, pdf_fn = brdf_sampler(parse("ggx(alpha=0.3)"), np.array([0.6, 0.0, 0.8]))
    >>> small = dict(sphere=False, theta_bins=5, phi_bins=10, n_samples=20_000)
    >>> chi2_test(sample_fn, pdf_fn, sample_dim=3, **small).passed
    True
    """

    def sample_fn(u: Any) -> tuple[Any, Any]:
        s = brdf.sample(np.broadcast_to(wo, (*u.shape[:-1], 3)), u)
        if record is not None:
            record.append(s)
        return s.wi, (s.pdf > 0) & ~s.delta

    def pdf_fn(wi: Any) -> Any:
        return brdf.pdf(wi, np.broadcast_to(wo, wi.shape))

    return sample_fn, pdf_fn


def assert_chi2(
    sample_fn: Callable[[Any], Any], pdf_fn: Callable[[Any], Any], **options: Any
) -> Chi2Result:
    """Run :func:`chi2_test` (same keyword ``options``) and raise :class:`AssertionError` with the
    histogram summary (:meth:`Chi2Result.__str__`) if the sampler is rejected.

    References
    ----------
    .. [1] W. Jakob et al., Mitsuba 3, ``mitsuba/python/chi2.py``, 2022.

    Examples
    --------
    >>> from brdfkit.sampling import square_to_cosine_hemisphere, square_to_uniform_hemisphere_pdf
    >>> small = dict(sphere=False, theta_bins=5, phi_bins=10, n_samples=20_000)
    >>> assert_chi2(  # doctest: +ELLIPSIS
    ...     square_to_cosine_hemisphere, square_to_uniform_hemisphere_pdf, **small
    ... )
    Traceback (most recent call last):
    ...
    AssertionError: χ² test FAILED: χ² = ... with ... d.o.f., p = 0 (threshold 0.01)
    ...
    """
    result = chi2_test(sample_fn, pdf_fn, **options)
    result.assert_passed()
    return result


def assert_chi2_planar(
    sample_fn: Callable[[Any], Any], pdf_fn: Callable[[Any], Any], **options: Any
) -> Chi2Result:
    """Run :func:`chi2_test_planar` (same keyword ``options``) and raise :class:`AssertionError`
    with the histogram summary if the sampler is rejected.

    References
    ----------
    .. [1] W. Jakob et al., Mitsuba 3, ``mitsuba/python/chi2.py``, 2022.
    """
    result = chi2_test_planar(sample_fn, pdf_fn, **options)
    result.assert_passed()
    return result
