r"""Tabulated BRDFs on a regular grid of Rusinkiewicz half/difference angles.

A measured BRDF is a table. Following Rusinkiewicz (1998) and Matusik et al. (2003) the grid is
laid in the half/difference angles :math:`(\theta_h, \varphi_h, \theta_d, \varphi_d)`
(:func:`brdfkit.geometry.to_half_diff`): isotropic tables drop :math:`\varphi_h` (3-D, shape
``(N_θh, N_θd, N_φd, C)``), anisotropic ones keep it (4-D, shape ``(N_θh, N_φh, N_θd, N_φd, C)``).
Node coordinates (the MERL convention, so a MERL file is simply a 90 × 90 × 180 table):

.. math::

    \theta_{h,i} = \tfrac{\pi}{2}\,(i/N_{\theta h})^2,\quad
    \theta_{d,j} = \tfrac{\pi}{2}\,j/N_{\theta d},\quad
    \varphi_{d,k} = \pi\,k/N_{\varphi d},\quad
    \varphi_{h,l} = 2\pi\,l/N_{\varphi h}

— the square-root warp of θh puts resolution at the specular peak. By reciprocity
:math:`f(\theta_h,\varphi_h,\theta_d,\varphi_d) = f(\theta_h,\varphi_h,\theta_d,\varphi_d+\pi)`, so
φd is folded into :math:`[0, \pi)` and is periodic there; φh is periodic on :math:`[0, 2\pi)`.

Negative table entries mean "not measured" (the MERL convention); they evaluate to 0 and are left
out of fits. Lookup is vectorised (gathers from the flattened table, a Python loop only over the
2^D corners of a cell) and written against the array API so that it runs on NumPy and torch
(``scipy.interpolate.RegularGridInterpolator`` would be NumPy-only).

Measured data have no analytic importance sampler. :class:`CosineSampled` samples the
cosine-weighted hemisphere (exact for the diffuse part, unbiased but noisy for sharp
highlights); a table adds half-vector sampling from its own θh (and φh) marginal
(:class:`HalfVectorSampling`) in a one-sample mixture with the cosine hemisphere, in the
spirit of the data-driven samplers of Lawrence et al. [4]_ with a far simpler, ``wo``-independent
factor. The albedo is the base class's Monte Carlo estimate.

References
----------
.. [1] S. Rusinkiewicz, "A new change of variables for efficient BRDF representation",
       EGWR 1998.
.. [2] W. Matusik, H. Pfister, M. Brand, L. McMillan, "A data-driven reflectance model",
       ACM TOG 22(3) (SIGGRAPH), 2003; ``BRDFRead.cpp`` of the MERL BRDF database.
.. [3] CIE 015:2018, *Colorimetry*, 4th ed. (the 1931 standard observer);
       IEC 61966-2-1 (sRGB).
.. [4] J. Lawrence, S. Rusinkiewicz, R. Ramamoorthi, "Efficient BRDF importance sampling using
       a factored representation", ACM TOG 23(3) (SIGGRAPH), 2004.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, asarray, namespace, safe_sqrt, to_numpy
from brdfkit.brdf.base import BRDF, Sample, result_shape, upper_hemisphere
from brdfkit.brdf.phong import (
    Component,
    MixtureSampled,
    cosine_component,
    reflect_about,
    reflected_pdf,
)
from brdfkit.data import colorimetry
from brdfkit.errors import ParameterError
from brdfkit.geometry import from_half_diff, to_half_diff
from brdfkit.sampling import (
    Distribution2D,
    square_to_cosine_hemisphere,
    square_to_cosine_hemisphere_pdf,
)

INTERPOLATIONS = ("bin", "nearest", "linear")
"""Lookup modes of :class:`TabulatedBRDF`: the cell's first node (MERL's ``BRDFRead.cpp``),
the closest node, or multilinear interpolation between the nodes."""


_NODE_TOLERANCE = 1e-6
"""Continuous indices this close below a node count as the node ("bin" lookup): the angles of
a node recomputed from its directions carry round-off (up to ~1e-11 of a bin in θh, and a φd a
rounding below 0 folds to the end of the previous period)."""


# --------------------------------------------------------------------------- colour
@functools.cache
def _spectrum_to_rgb(wavelengths: tuple[float, ...]) -> np.ndarray:
    basis = colorimetry.align_to_observer(np.asarray(wavelengths), np.eye(len(wavelengths)))
    xyz = colorimetry.tristimulus(basis, colorimetry.d65())
    return xyz @ colorimetry.XYZ_TO_LINEAR_SRGB.T


OBSERVER_RANGE = colorimetry.OBSERVER_RANGE
"""The wavelengths (nm) the CIE 1931 2° observer tabulates."""

MIN_OBSERVED_WAVELENGTHS = 6
"""Fewest wavelengths a spectrum needs inside :data:`OBSERVER_RANGE`: evenly spaced spectra are
interpolated by Sprague (1880), which needs six samples."""


def wavelengths_problem(wavelengths: Any) -> str:
    """Why ``wavelengths`` (nm) cannot be converted to sRGB, or ``""`` when they can.

    They must be finite whole nanometres, strictly increasing, within [300, 900], with at least
    :data:`MIN_OBSERVED_WAVELENGTHS` inside :data:`OBSERVER_RANGE`: a spectrum is aligned to
    the observer's 1 nm grid (:func:`brdfkit.data.colorimetry.align_to_observer`), which needs
    whole nanometres and enough samples on it. Readers use this to raise their own error
    naming the file.

    Parameters
    ----------
    wavelengths : array_like
        The wavelengths in nm (flattened).

    Returns
    -------
    str
        The reason, in words, or ``""``.
    """
    wl = np.asarray(wavelengths, dtype=np.float64).ravel()
    if not np.all(np.isfinite(wl)) or np.any(wl != np.round(wl)):
        return f"wavelengths must be finite whole nanometres; got {wl}"
    if wl.size == 0 or not np.all(np.diff(wl) > 0) or wl[0] < 300 or wl[-1] > 900:
        return f"wavelengths must be increasing values in nm within [300, 900]; got {wl}"
    lo, hi = OBSERVER_RANGE
    observed = np.count_nonzero((wl >= lo) & (wl <= hi))
    if observed < MIN_OBSERVED_WAVELENGTHS:
        return (
            f"wavelengths must include at least {MIN_OBSERVED_WAVELENGTHS} within the CIE "
            f"observer's [{lo:g}, {hi:g}] nm; got {observed} of {wl}"
        )
    return ""


def spectrum_to_rgb_matrix(wavelengths: Any) -> np.ndarray:
    r"""The ``(n, 3)`` matrix M taking spectral reflectances at ``wavelengths`` (nm) to linear sRGB.

    :math:`\mathrm{RGB} = S\,M` with
    :math:`XYZ = \sum_\lambda S(\lambda)\,E(\lambda)\,\bar{\mathbf x}(\lambda)\,\Delta\lambda
    \,/\sum_\lambda E(\lambda)\,\bar y(\lambda)\,\Delta\lambda` under illuminant D65 (the sRGB
    white) with the CIE 1931 2° observer, then the sRGB XYZ→RGB matrix; a constant spectrum 1
    maps to RGB ≈ (1, 1, 1). The integration is colour-science's ``msds_to_XYZ`` "Integration"
    (the spectra interpolated onto the observer's 1 nm grid: Sprague for even spacing, else a
    cubic spline, the ends held), restated in :mod:`brdfkit.data.colorimetry` with its tables
    shipped (the tests hold it equal to colour-science's to ~1e-12) rather than imported:
    colour-science is a 94 MiB install for a few tables and a sum.

    Raises
    ------
    ParameterError
        When the wavelengths are unusable (:func:`wavelengths_problem` says why).

    References
    ----------
    .. [1] CIE 015:2018, *Colorimetry*; IEC 61966-2-1:1999 (sRGB).
    .. [2] colour-science, ``colour.msds_to_XYZ``.

    Examples
    --------
    >>> import numpy as np
    >>> wavelengths = np.arange(400.0, 701.0, 10.0)
    >>> (np.ones(31) @ spectrum_to_rgb_matrix(wavelengths)).round(2).tolist()  # white stays white
    [1.0, 1.0, 1.0]
    """
    wl = np.asarray(wavelengths, dtype=np.float64).ravel()
    problem = wavelengths_problem(wl)
    if problem:
        raise ParameterError(problem)
    return _spectrum_to_rgb(tuple(float(x) for x in wl))


# --------------------------------------------------------------------------- sampling
class CosineSampled(BRDF):
    """Cosine-weighted hemisphere sampling for measured BRDFs (no analytic sampler exists).

    ``pdf = cos θi / π``; ``weight = f·cos θi / pdf = π f``. Unbiased for any BRDF; its variance
    grows with the sharpness of the highlight.

    References
    ----------
    .. [1] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., §A.5.3.
    """

    reciprocal: ClassVar[bool] = False  # measured data: reciprocal only as far as measured
    energy_conserving: ClassVar[bool] = False  # measured, not claimed

    def pdf(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        p = square_to_cosine_hemisphere_pdf(wi)
        return xp.where(wo[..., 2] > 0, p, xp.zeros_like(p))

    def sample(self, wo: Array, u: Array) -> Sample:
        xp = namespace(wo, u)
        wi = square_to_cosine_hemisphere(asarray(u, xp, like=wo)[..., :2])
        pdf = self.pdf(wi, wo)
        ok = pdf > 0
        weight = self.eval(wi, wo) * math.pi
        weight = xp.where(ok[..., None], weight, xp.zeros_like(weight))
        return Sample(wi, weight, pdf, xp.zeros_like(pdf, dtype=xp.bool))


MAX_HALF_VECTOR_PROBABILITY = 0.9
"""Largest share of samples a table gives its half-vector lobe: the cosine hemisphere keeps at
least 10 %, which bounds the weight of any direction the θh marginal misjudges (a highlight
that moves with θd, a diffuse floor) by 10 × π f."""


def _theta_h_edges(count: int) -> np.ndarray:
    r"""The θh of a table's ``count`` θh nodes and the end of their axis, ``(count + 1,)``: node
    i at :math:`(i/N)^2\,\pi/2` (MERL's square-root warp, dense near the highlight), then π/2."""
    return (np.arange(count + 1) / count) ** 2 * (math.pi / 2)


def white_sky_weights(table: TabulatedBRDF) -> np.ndarray:
    r"""Per node, the weight :math:`w` of its cell in the white-sky albedo
    :math:`\rho_{hh} = \frac1\pi\iint f\cos\theta_i\cos\theta_o\,d\omega_i\,d\omega_o
    \approx \sum f\,w`.

    Each node stands for the cell from it to the next node along every axis. Its weight is
    :math:`\cos\theta_i\cos\theta_o/\pi` at the cell's middle (0 below the horizon), with
    :math:`\cos\theta_i\cos\theta_o = (\cos\theta_h\cos\theta_d)^2 -
    (\sin\theta_h\sin\theta_d\cos\varphi_d)^2`, times the cell's exact measure under
    :math:`d\omega_i\,d\omega_o = 4\cos\theta_d\,d\omega_h\,d\omega_d` [1]_: the solid angle of
    its θh cell (its share of it in φh) times :math:`\int 4\cos\theta_d\,d\omega_d` over its θd
    and φd cells, doubled as φd is folded by π. A constant table c sums to πc to quadrature
    accuracy.

    Returns
    -------
    An array broadcastable to the grid: ``(N_θh, N_θd, N_φd)`` (3-D) or ``(N_θh, 1, N_θd, N_φd)``.

    References
    ----------
    .. [1] S. Rusinkiewicz, EGWR 1998 (the Jacobian of the half/difference change of variables).
    """
    n = table.shape
    theta_h = _theta_h_edges(n[0])
    theta_d = np.arange(n[-2] + 1) / n[-2] * (math.pi / 2)
    phi_d = (np.arange(n[-1]) + 0.5) / n[-1] * math.pi
    n_phi_h = 1 if table.isotropic else n[1]
    half = (2 * math.pi / n_phi_h) * np.diff(1 - np.cos(theta_h))  # ∫ dω_h over the θh cell
    diff = 2 * np.diff(np.sin(theta_d) ** 2) * (2 * math.pi / n[-1])  # ∫ 4 cos θd dω_d, twice
    middle = [(edges[:-1] + edges[1:]) / 2 for edges in (theta_h, theta_d)]
    th, td, pd = np.meshgrid(*middle, phi_d, indexing="ij")
    a = np.cos(th) * np.cos(td)
    b = np.sin(th) * np.sin(td) * np.cos(pd)
    cosines = np.clip(a - b, 0, None) * np.clip(a + b, 0, None)
    weight = cosines * half[:, None, None] * diff[None, :, None] / math.pi
    return weight if table.isotropic else weight[:, None]


class HalfVectorSampling:
    r"""Half vectors drawn from a tabulated BRDF's own θh (and φh) marginal.

    Cell i of the half-vector hemisphere spans θh from node i to node i + 1 of the table's
    square-root-warped axis (:math:`\theta_{h,N} = \pi/2`), and for a 4-D table cell l spans φh
    from node l to l + 1. The cell's value :math:`m_{il}` is the table's mean over it, over θd,
    φd and the channels (the mean of the cell's nodes for ``"linear"`` and ``"nearest"`` lookup,
    its first node for ``"bin"``; unmeasured nodes count 0). A cell is chosen with probability
    :math:`\propto m_{il}\,\Omega_{il}`, :math:`\Omega_{il} = 2\pi(\cos\theta_i -
    \cos\theta_{i+1})/N_{\varphi h}` its solid angle (:class:`~brdfkit.sampling.Distribution2D`),
    then :math:`\cos\theta_h` and :math:`\varphi_h` uniformly inside it, so the solid-angle
    density is constant per cell:

    .. math::

        p(\mathbf h) = m_{il} \Big/ \sum_{jk} m_{jk}\,\Omega_{jk}.

    Reflecting ``wo`` about h gives :math:`p(\omega_i) = p(\mathbf h)/(4\,\omega_o\cdot\mathbf h)`.

    :attr:`probability` is the lobe's share in the mixture with the cosine hemisphere: the
    share of the table's white-sky albedo
    :math:`\rho_{hh} = \frac1\pi\iint f\cos\theta_i\cos\theta_o\,d\omega_i\,d\omega_o` that lies
    above its diffuse floor d, :math:`\frac1\pi\iint \max(f - d, 0)\cos\theta_i\cos\theta_o\,
    d\omega_i\,d\omega_o / \rho_{hh}`, with d the median of the measured values under the same
    measure (the value half of all cosine-weighted direction pairs lie below) and f the channel
    mean, summed over the nodes (:func:`white_sky_weights`), at most
    :data:`MAX_HALF_VECTOR_PROBABILITY`. For a one-sample mixture whose lobes match the parts of
    the integrand, the variance is least with each lobe chosen in proportion to its part's
    integral; a table without energy above its floor (a Lambertian table) gets 0 and is sampled
    exactly by the cosine hemisphere.

    Parameters
    ----------
    table : the tabulated BRDF.

    Attributes
    ----------
    probability : the mixture weight of half-vector sampling.
    density : (N_θh, N_φh) :math:`p(\mathbf h)` per cell in sr⁻¹ (N_φh = 1 for a 3-D table).

    References
    ----------
    .. [1] J. Lawrence, S. Rusinkiewicz, R. Ramamoorthi, "Efficient BRDF importance sampling
           using a factored representation", ACM TOG 23(3) (SIGGRAPH), 2004.
    .. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., §A.4.2
           (piecewise-constant distributions) and §9.6.2 (the 1/(4 ωo·h) Jacobian), 2023.
    """

    def __init__(self, table: TabulatedBRDF) -> None:
        shape, channels = table.shape, table.channels
        n_theta = shape[0]
        n_phi = 1 if table.isotropic else shape[1]
        nodes = table._table[:, :-1].reshape(*shape, channels)
        node_values = nodes.reshape(n_theta, n_phi, -1).mean(axis=-1)
        if table.interpolation == "bin":
            cells = node_values
        else:  # the mean of a cell's corners (clamped past the last θh node, periodic in φh)
            cells = (node_values + np.concatenate([node_values[1:], node_values[-1:]])) / 2
            if n_phi > 1:
                cells = (cells + np.roll(cells, -1, axis=1)) / 2
        theta = _theta_h_edges(n_theta)
        # 1 − cos θ = 2 sin²(θ/2) keeps the narrow cells near θh = 0 resolved.
        self._one_minus_cos = 2 * np.sin(theta / 2) ** 2
        solid_angle = (2 * math.pi / n_phi) * np.diff(self._one_minus_cos)[:, None]
        energy = float(np.sum(cells * solid_angle))
        self.density: np.ndarray = cells / energy if energy > 0 else np.zeros_like(cells)
        self._distribution = Distribution2D(cells * solid_angle) if energy > 0 else None
        measured = (table._table[:, -1] > 0).reshape(shape)
        value = table._table[:, :-1].mean(axis=-1).reshape(shape)[measured]
        weight = np.broadcast_to(white_sky_weights(table), shape)[measured]
        share = 0.0
        if value.size:
            order = np.argsort(value)
            cumulative = np.cumsum(weight[order])
            floor = value[order][np.searchsorted(cumulative, cumulative[-1] / 2)]
            total = float(np.sum(value * weight))
            above = float(np.sum(np.maximum(value - floor, 0) * weight))
            share = above / total if above > 0 else 0.0
        self.probability: float = min(share, MAX_HALF_VECTOR_PROBABILITY)

    def sample(self, u: Array) -> Array:
        """Half vectors ``(..., 3)`` from uniforms ``u`` of shape ``(..., 2)``."""
        if self._distribution is None:
            raise ValueError("the table is zero everywhere: it has no half-vector distribution")
        xp = namespace(u)
        points, _ = self._distribution.sample(u)
        n_theta = self.density.shape[0]
        scaled = points[..., 1] * n_theta
        row = xp.clip(xp.floor(scaled), 0, n_theta - 1)
        edges = asarray(self._one_minus_cos, xp, like=points, dtype=points.dtype)
        index = xp.reshape(xp.astype(row, xp.int64), (-1,))
        lo = xp.reshape(xp.take(edges, index), row.shape)
        hi = xp.reshape(xp.take(edges, index + 1), row.shape)
        one_minus_cos = lo + (scaled - row) * (hi - lo)
        sin_theta = safe_sqrt(one_minus_cos * (2 - one_minus_cos))
        phi = points[..., 0] * (2 * math.pi)
        return xp.stack(
            [sin_theta * xp.cos(phi), sin_theta * xp.sin(phi), 1 - one_minus_cos], axis=-1
        )

    def pdf(self, h: Array) -> Array:
        r"""Solid-angle density :math:`p(\mathbf h)` of :meth:`sample`, ``(...,)``; 0 if h.z ≤ 0."""
        xp = namespace(h)
        n_theta, n_phi = self.density.shape
        theta = xp.atan2(xp.sqrt(h[..., 0] ** 2 + h[..., 1] ** 2), h[..., 2])
        row = xp.clip(xp.floor(xp.sqrt(theta / (math.pi / 2)) * n_theta), 0, n_theta - 1)
        index = xp.astype(row, xp.int64) * n_phi
        if n_phi > 1:
            phi = xp.remainder(xp.atan2(h[..., 1], h[..., 0]), 2 * math.pi)
            col = xp.clip(xp.floor(phi / (2 * math.pi) * n_phi), 0, n_phi - 1)
            index = index + xp.astype(col, xp.int64)
        density = asarray(self.density.ravel(), xp, like=h, dtype=h.dtype)
        value = xp.reshape(xp.take(density, xp.reshape(index, (-1,))), index.shape)
        return xp.where(h[..., 2] > 0, value, xp.zeros_like(value))


# --------------------------------------------------------------------------- samples
@dataclass(frozen=True, eq=False)
class MeasuredSamples:
    """Scattered BRDF measurements: directions and values.

    Attributes
    ----------
    wi : (N, 3) unit directions towards the light.
    wo : (N, 3) unit directions towards the viewer.
    values : (N, C) BRDF values f_r (sr⁻¹); negative entries mean "not measured".
    spectral : (N, n) spectral values behind ``values`` (``None`` if not spectral).
    wavelengths : (n,) wavelengths of ``spectral`` in nm (``None`` if not spectral).
    name : a label (usually the file name).

    Examples
    --------
    >>> import numpy as np
    >>> up, down = [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]
    >>> samples = MeasuredSamples(np.array([up, up, up]), np.array([up, down, up]), [0.3, 0.3, -1])
    >>> samples.values.shape, samples.valid.tolist()  # below the surface, "not measured"
    ((3, 1), [True, False, False])
    """

    wi: np.ndarray
    wo: np.ndarray
    values: np.ndarray
    spectral: np.ndarray | None = None
    wavelengths: np.ndarray | None = None
    name: str = ""

    def __post_init__(self) -> None:
        for attr in ("wi", "wo"):
            v = np.asarray(getattr(self, attr), dtype=np.float64)
            if v.ndim != 2 or v.shape[1] != 3:
                raise ValueError(f"{attr} must have shape (N, 3); got {v.shape}")
            object.__setattr__(self, attr, v)
        values = np.asarray(self.values, dtype=np.float64)
        if values.ndim == 1:
            values = values[:, None]
        if values.ndim != 2 or values.shape[0] != self.wi.shape[0] != self.wo.shape[0]:
            raise ValueError(
                f"values must have shape (N, C) with N = {self.wi.shape[0]} (the directions); "
                f"got {values.shape}"
            )
        object.__setattr__(self, "values", values)

    @property
    def valid(self) -> np.ndarray:
        """(N,) bool: measured (non-negative, finite, both directions above the surface)."""
        return (
            np.all(np.isfinite(self.values) & (self.values >= 0), axis=-1)
            & (self.wi[:, 2] > 0)
            & (self.wo[:, 2] > 0)
        )


# --------------------------------------------------------------------------- the table
MIN_SAMPLES = 4
"""Fewest valid measurements :meth:`TabulatedBRDF.from_samples` resamples (a tetrahedron)."""


@dataclass(frozen=True, eq=False)
class TabulatedBRDF(MixtureSampled):
    r"""A BRDF tabulated on a regular half/difference grid (see the module docstring).

    ``eval`` returns the looked-up entry ``v`` times a per-channel scale ``s`` (MERL stores
    values scaled by 1500, 1500/1.15, 1500/1.66), zero below the surface. Unmeasured (negative)
    nodes are left out: interpolation weights are renormalised over the measured nodes of the
    cell, and a point whose nodes are all unmeasured evaluates to 0. Lookup
    (``interpolation``): ``"bin"`` — the first node of the cell holding the point (floor of the
    continuous index; exactly MERL's ``BRDFRead.cpp``), ``"nearest"`` — the closest node,
    ``"linear"`` — multilinear between the 2^D nodes around it (clamped at the θ ends, wrapped
    on the periodic φ axes).

    Reciprocal by construction (φd is folded by π); isotropic when 3-D. Sampled by a one-sample
    mixture of the cosine hemisphere and the table's half-vector marginal
    (:class:`HalfVectorSampling`, built on first use and kept); ``pdf`` is the mixture density.

    Parameters
    ----------
    values : ``(N_θh, N_θd, N_φd, C)`` or ``(N_θh, N_φh, N_θd, N_φd, C)`` raw table (kept as
        given, so writers reproduce files bit for bit).
    scale : per-channel factor ``(C,)`` or scalar applied on lookup.
    interpolation : ``"bin"``, ``"nearest"`` or ``"linear"``.
    samples : the scattered measurements the table was built from, if any (fits use them).
    name : a label.

    Attributes
    ----------
    clamped : int
        How many stored values are negative ("not measured": MERL's −1 marker, or a node below
        the horizon), and so never reach ``eval`` as a value (a point whose nodes are all
        unmeasured evaluates to 0); 0 when none. ``values`` keeps them as stored.

    References
    ----------
    .. [1] S. Rusinkiewicz, EGWR 1998. .. [2] W. Matusik et al., SIGGRAPH 2003.

    Examples
    --------
    A table of a model, looked up between its nodes, is close to the model:

    >>> import numpy as np
    >>> from brdfkit.brdf import parse
    >>> model = parse("ggx(alpha=0.3)")
    >>> table = TabulatedBRDF.from_brdf(model, (32, 32, 32))
    >>> table.shape, table.channels, table.isotropic
    ((32, 32, 32), 1, True)
    >>> wi, wo = np.array([0.0, 0.6, 0.8]), np.array([0.0, -0.6, 0.8])  # a mirror pair
    >>> float(model.eval(wi, wo)[0].round(3)), float(table.eval(wi, wo)[0].round(3))
    (1.348, 1.349)
    """

    values: Any = None
    scale: Any = 1.0
    interpolation: str = "linear"
    samples: MeasuredSamples | None = None
    name: str = ""
    clamped: int = field(init=False, default=0)
    _table: np.ndarray = field(init=False, repr=False)
    _half_vector: HalfVectorSampling | None = field(init=False, repr=False, default=None)

    reciprocal: ClassVar[bool] = True
    energy_conserving: ClassVar[bool] = False  # measured, not claimed

    def __post_init__(self) -> None:
        values = np.asarray(self.values)
        if values.ndim not in (4, 5) or min(values.shape) < 1:
            raise ValueError(
                "values must have shape (N_theta_h, N_theta_d, N_phi_d, C) or "
                f"(N_theta_h, N_phi_h, N_theta_d, N_phi_d, C); got {values.shape}"
            )
        if not np.issubdtype(values.dtype, np.floating):
            raise ValueError(f"values must be floating point; got dtype {values.dtype}")
        channels = values.shape[-1]
        scale = np.asarray(self.scale, dtype=np.float64)
        if scale.ndim > 1 or scale.size not in (1, channels) or np.any(~np.isfinite(scale)):
            raise ValueError(
                f"scale must be a finite scalar or have {channels} entries; got {self.scale!r}"
            )
        if self.interpolation not in INTERPOLATIONS:
            raise ValueError(
                f"interpolation must be one of {INTERPOLATIONS}; got {self.interpolation!r}"
            )
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "channels", channels)
        object.__setattr__(self, "clamped", int(np.count_nonzero(values < 0)))
        # One extra column flags measured nodes: lookup interpolates it with the values and
        # divides, so unmeasured nodes drop out of the interpolation.
        measured = np.all(np.nan_to_num(values, nan=-1.0) >= 0, axis=-1, keepdims=True)
        table = np.concatenate([np.where(measured, values * scale, 0.0), measured], axis=-1)
        # C order: np.take copies a non-contiguous table (a MERL file's is transposed) whole
        # on every call
        object.__setattr__(self, "_table", np.ascontiguousarray(table.reshape(-1, channels + 1)))

    @property
    def isotropic(self) -> bool:  # type: ignore[override]
        return self.values.ndim == 4

    @property
    def shape(self) -> tuple[int, ...]:
        """The grid resolution (without the channel axis)."""
        return tuple(self.values.shape[:-1])

    def scaled_values(self) -> np.ndarray:
        """The table in BRDF units (sr⁻¹): ``values · scale``, negatives ("not measured") kept."""
        return self.values * np.asarray(self.scale, dtype=np.float64)

    def to_spec(self) -> str:
        raise ValueError(
            f"a tabulated BRDF ({self.name or 'unnamed'}) has no spec string; it is data"
        )

    def __repr__(self) -> str:
        return f"TabulatedBRDF(name={self.name!r}, shape={self.shape}, channels={self.channels})"

    # -- grid geometry ----------------------------------------------------------------------
    def _axes(self) -> list[tuple[int, bool]]:
        """(size, periodic) per grid axis, in table order."""
        n = self.shape
        if self.isotropic:
            return [(n[0], False), (n[1], False), (n[2], True)]
        return [(n[0], False), (n[1], True), (n[2], False), (n[3], True)]

    def _continuous_index(
        self, theta_h: Array, phi_h: Array, theta_d: Array, phi_d: Array
    ) -> list[Array]:
        xp = namespace(theta_h)
        n = self.shape
        half_pi = math.pi / 2
        u_theta_h = xp.sqrt(xp.clip(theta_h, 0.0, None) / half_pi) * n[0]
        u_theta_d = xp.clip(theta_d, 0.0, None) / half_pi * n[-2]
        u_phi_d = xp.remainder(phi_d, math.pi) / math.pi * n[-1]
        if self.isotropic:
            return [u_theta_h, u_theta_d, u_phi_d]
        u_phi_h = xp.remainder(phi_h, 2 * math.pi) / (2 * math.pi) * n[1]
        return [u_theta_h, u_phi_h, u_theta_d, u_phi_d]

    def node_angles(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Half/difference angles ``(θh, φh, θd, φd)`` of every node, each of the grid's shape.

        For an isotropic table φh = 0.
        """
        th, ph, td, pd = (np.array(a) for a in np.broadcast_arrays(*self.node_axes()))
        return th, ph, td, pd

    def node_axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The angles of :meth:`node_angles` as an open grid: each array has the grid's number
        of axes, of length 1 but along its own (φh of an isotropic table: a single 0), and
        they broadcast to the grid (functions of the angles computed on the axes, not on
        every node)."""
        n = self.shape
        theta_h = _theta_h_edges(n[0])[:-1]
        theta_d = np.arange(n[-2]) / n[-2] * (math.pi / 2)
        phi_d = np.arange(n[-1]) / n[-1] * math.pi
        if self.isotropic:
            th, td, pd = np.ix_(theta_h, theta_d, phi_d)
            return th, np.zeros((1, 1, 1)), td, pd
        phi_h = np.arange(n[1]) / n[1] * (2 * math.pi)
        th, ph, td, pd = np.ix_(theta_h, phi_h, theta_d, phi_d)
        return th, ph, td, pd

    def node_directions(self) -> tuple[np.ndarray, np.ndarray]:
        """``(wi, wo)`` of every node, each of shape ``grid + (3,)``."""
        return from_half_diff(*self.node_angles())

    # -- the protocol -----------------------------------------------------------------------
    @property
    def half_vector_sampling(self) -> HalfVectorSampling:
        """The table's half-vector sampler (built on first use, then kept)."""
        if self._half_vector is None:
            object.__setattr__(self, "_half_vector", HalfVectorSampling(self))
        return self._half_vector

    def components(self, wo: Array) -> list[Component]:
        xp = namespace(wo)
        half = self.half_vector_sampling
        share = xp.full_like(wo[..., 2], half.probability)
        if half.probability == 0:
            return [cosine_component(1 - share)]
        return [
            cosine_component(1 - share),
            (
                share,
                lambda wi: reflected_pdf(wi, wo, half.pdf),
                lambda u: reflect_about(wo, half.sample(u)),
            ),
        ]

    def eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        wi = asarray(wi, xp)
        wo = asarray(wo, xp, like=wi)
        batch = result_shape(wi, wo)
        wi_b = xp.reshape(xp.broadcast_to(wi, (*batch, 3)), (-1, 3))
        wo_b = xp.reshape(xp.broadcast_to(wo, (*batch, 3)), (-1, 3))
        coords = self._continuous_index(*to_half_diff(wi_b, wo_b))
        table = asarray(self._table, xp, like=wi, dtype=wi.dtype)
        found = lookup(table, coords, self._axes(), self.interpolation)
        weight = found[:, -1:]
        covered = weight > 1e-12
        value = found[:, :-1] / xp.where(covered, weight, xp.ones_like(weight))
        value = xp.where(covered, value, xp.zeros_like(value))
        value = xp.reshape(value, (*batch, self.channels))
        return xp.where(upper_hemisphere(wi, wo), value, xp.zeros_like(value))

    # -- construction -----------------------------------------------------------------------
    @classmethod
    def from_brdf(
        cls,
        brdf: BRDF,
        shape: tuple[int, ...] = (90, 90, 180),
        *,
        channels: int | None = None,
        interpolation: str = "linear",
        name: str = "",
    ) -> TabulatedBRDF:
        """Tabulate ``brdf`` at the grid nodes of ``shape`` (3-D isotropic or 4-D anisotropic).

        Nodes with either direction at or below the horizon are stored as −1 ("not measured").
        ``channels`` broadcasts a grey model to C channels (default: the model's own).

        Examples
        --------
        >>> import numpy as np
        >>> from brdfkit.brdf import Lambertian
        >>> table = TabulatedBRDF.from_brdf(Lambertian(rho=0.5), (8, 8, 16), channels=3)
        >>> table.shape, table.channels, table.clamped > 0  # some nodes lie below the horizon
        ((8, 8, 16), 3, True)
        >>> (table.eval(np.array([0.6, 0.0, 0.8]), np.array([0.0, 0.6, 0.8])) * np.pi).tolist()
        [0.5, 0.5, 0.5]
        """
        shape = tuple(int(s) for s in shape)
        if len(shape) not in (3, 4) or min(shape) < 1:
            raise ValueError(
                "shape must be (N_theta_h, N_theta_d, N_phi_d) or "
                f"(N_theta_h, N_phi_h, N_theta_d, N_phi_d) with positive sizes; got {shape}"
            )
        c = brdf.channels if channels is None else int(channels)
        if brdf.channels not in (1, c):
            raise ValueError(f"channels must be 1 or {brdf.channels} for {brdf!r}; got {c}")
        grid = cls(np.zeros((*shape, 1)), name=name)
        wi, wo = grid.node_directions()
        f = np.broadcast_to(to_numpy(brdf.eval(wi, wo)), (*shape, c)).astype(np.float64)
        above = (wi[..., 2] > 0) & (wo[..., 2] > 0)
        values = np.where(above[..., None], f, -1.0)
        return cls(values, interpolation=interpolation, name=name or repr(brdf))

    @classmethod
    def from_samples(
        cls,
        samples: MeasuredSamples,
        shape: tuple[int, ...] = (32, 32, 32),
        *,
        method: str = "linear",
        interpolation: str = "linear",
    ) -> TabulatedBRDF:
        r"""Resample scattered measurements onto an isotropic 3-D grid.

        The samples are placed at their grid coordinates (continuous node indices divided by the
        axis sizes, so every axis spans [0, 1]); copies shifted by ±1 along the periodic φd axis
        make the interpolant wrap. ``method="linear"`` is scipy's Delaunay-based
        ``LinearNDInterpolator`` with nodes outside the samples' convex hull filled from the
        nearest sample (``NearestNDInterpolator``); ``method="nearest"`` uses the nearest sample
        everywhere (also under ``"linear"`` when the samples span no volume, as when they all lie
        in one plane of the grid). Nodes below the horizon are −1 ("not measured").

        Raises
        ------
        ValueError
            For a bad ``shape`` or ``method``, or fewer than :data:`MIN_SAMPLES` valid samples.

        References
        ----------
        .. [1] C. B. Barber, D. P. Dobkin, H. Huhdanpaa, "The Quickhull algorithm for convex
               hulls", ACM TOMS 22(4), 1996 (scipy.spatial.Delaunay).

        Examples
        --------
        >>> import numpy as np
        >>> from brdfkit.brdf import Lambertian
        >>> from brdfkit.sampling import hemisphere_pairs
        >>> wi, wo = hemisphere_pairs(300)
        >>> samples = MeasuredSamples(wi, wo, Lambertian(rho=0.5).eval(wi, wo), name="white")
        >>> table = TabulatedBRDF.from_samples(samples, (8, 8, 8), method="nearest")
        >>> table.name, table.samples is samples
        ('white', True)
        >>> (table.eval(np.array([0.6, 0.0, 0.8]), np.array([0.0, 0.6, 0.8])) * np.pi).tolist()
        [0.5]
        """
        from scipy.interpolate import LinearNDInterpolator, NearestNDInterpolator
        from scipy.spatial import QhullError

        shape = tuple(int(s) for s in shape)
        if len(shape) != 3 or min(shape) < 2:
            raise ValueError(
                f"shape must be (N_theta_h, N_theta_d, N_phi_d), each >= 2; got {shape}"
            )
        if method not in ("linear", "nearest"):
            raise ValueError(f"method must be 'linear' or 'nearest'; got {method!r}")
        valid = samples.valid
        if np.count_nonzero(valid) < MIN_SAMPLES:
            raise ValueError(
                f"samples {samples.name!r} hold {np.count_nonzero(valid)} valid measurements; "
                f"at least {MIN_SAMPLES} are needed"
            )
        grid = cls(np.zeros((*shape, 1)))
        sizes = np.asarray(shape, dtype=np.float64)
        points = (
            np.stack(
                grid._continuous_index(*to_half_diff(samples.wi[valid], samples.wo[valid])), axis=-1
            )
            / sizes
        )
        values = samples.values[valid]
        points = np.concatenate([points + np.array([0.0, 0.0, shift]) for shift in (-1, 0, 1)])
        values = np.concatenate([values] * 3)
        th, _, td, pd = grid.node_angles()
        nodes = np.stack(grid._continuous_index(th, th * 0, td, pd), axis=-1) / sizes
        nearest = NearestNDInterpolator(points, values)(nodes)
        table = nearest
        if method == "linear":
            try:
                linear = LinearNDInterpolator(points, values)(nodes)
            except QhullError:  # the samples span no volume: no node lies inside their hull
                linear = nearest
            table = np.where(np.isnan(linear), nearest, linear)
        wi, wo = grid.node_directions()
        above = (wi[..., 2] > 0) & (wo[..., 2] > 0)
        table = np.where(above[..., None], np.maximum(table, 0.0), -1.0)
        return cls(table, interpolation=interpolation, samples=samples, name=samples.name)


# --------------------------------------------------------------------------- lookup
def lookup(
    table: Array, coords: list[Array], axes: list[tuple[int, bool]], interpolation: str
) -> Array:
    r"""Look up a flattened regular table at continuous node indices.

    ``table`` has shape ``(prod(sizes), C)`` (C-order over the axes); ``coords[k]`` holds the
    continuous index along axis k (node i at ``i``) for each of M points, shape ``(M,)``.
    Multilinear interpolation is
    :math:`\sum_{c\in\{0,1\}^D}\prod_k w_k^{c_k}\,T[i + c]` with
    :math:`w_k^1 = u_k - \lfloor u_k\rfloor`, :math:`w_k^0 = 1 - w_k^1`; indices past the ends
    are clamped, or wrapped on periodic axes. Returns ``(M, C)``.

    References
    ----------
    .. [1] W. H. Press et al., *Numerical Recipes*, 3rd ed., §3.6 (interpolation in a grid).

    Examples
    --------
    A two-node axis, looked up a quarter and three quarters of the way:

    >>> import numpy as np
    >>> table, axes = np.array([[0.0], [10.0]]), [(2, False)]
    >>> lookup(table, [np.array([0.25, 0.75])], axes, "linear").tolist()
    [[2.5], [7.5]]
    >>> lookup(table, [np.array([0.25, 0.75])], axes, "nearest").tolist()
    [[0.0], [10.0]]
    """
    xp = namespace(table, *coords)
    strides = np.cumprod([1] + [size for size, _ in axes[:0:-1]])[::-1]

    def wrap(index: Array, size: int, periodic: bool) -> Array:
        return xp.remainder(index, size) if periodic else xp.clip(index, 0, size - 1)

    if interpolation in ("bin", "nearest"):
        flat = None
        for u, (size, periodic), stride in zip(coords, axes, strides, strict=True):
            # "bin": nodes themselves must land in their own cell despite round-off in the
            # angles (θh = (i/N)² π/2 gives u = i(1 ± ε)), hence the nudge.
            rounded = xp.floor(u + _NODE_TOLERANCE) if interpolation == "bin" else xp.round(u)
            index = wrap(xp.astype(rounded, xp.int64), size, periodic) * int(stride)
            flat = index if flat is None else flat + index
        return xp.take(table, flat, axis=0)
    lower, upper, weights = [], [], []
    for u, (size, periodic) in zip(coords, axes, strict=True):
        floor = xp.floor(u)
        i0 = xp.astype(floor, xp.int64)
        lower.append(wrap(i0, size, periodic))
        upper.append(wrap(i0 + 1, size, periodic))
        weights.append(xp.astype(u - floor, table.dtype))
    total = None
    for corner in range(2 ** len(axes)):
        flat, weight = None, None
        for k, stride in enumerate(strides):
            bit = (corner >> (len(axes) - 1 - k)) & 1
            index = (upper[k] if bit else lower[k]) * int(stride)
            w = weights[k] if bit else 1 - weights[k]
            flat = index if flat is None else flat + index
            weight = w if weight is None else weight * w
        term = weight[:, None] * xp.take(table, flat, axis=0)
        total = term if total is None else total + term
    return total


__all__ = [
    "INTERPOLATIONS",
    "MAX_HALF_VECTOR_PROBABILITY",
    "MIN_OBSERVED_WAVELENGTHS",
    "MIN_SAMPLES",
    "OBSERVER_RANGE",
    "CosineSampled",
    "HalfVectorSampling",
    "MeasuredSamples",
    "TabulatedBRDF",
    "lookup",
    "spectrum_to_rgb_matrix",
    "wavelengths_problem",
    "white_sky_weights",
]
