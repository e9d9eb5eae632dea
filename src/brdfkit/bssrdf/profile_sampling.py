r"""Importance sampling of a radial profile, and of exit points by axis projection (pbrt-v3).

A BSSRDF's spatial term needs points :math:`x_i` on the surface near :math:`x_o` with density
close to :math:`R_d(\lVert x_i - x_o\rVert)`. pbrt-v3 samples a radius r with density
:math:`\propto 2\pi r R_d(r)` and an angle φ, places a probe segment perpendicular to a chosen
projection axis at :math:`x_o + r(\cos\varphi\,v_x + \sin\varphi\,v_y)`, of half-length
:math:`\sqrt{r_{max}^2 - r^2}` along :math:`v_z`, and takes its intersections with the
surface. The axis is the normal with probability ½ and either tangent with ¼ (a curved
surface may be seen edge-on from the normal). The area density of a found point combines the
three projections:

.. math::
    p(x_i) = \sum_{a \in \{s, t, n\}} P_a\,\frac{p_r(r_a)}{2\pi r_a}\,\lvert n_i\cdot v_a\rvert,
    \qquad r_a = \text{the distance of } x_i - x_o \text{ from the axis } v_a,

divided by the number of intersections when one is picked from several. :math:`r_{max}`
is the radius inside which 99.9 % of the profile's power lies (the rest is not sampled, as in
pbrt-v3).

The radius is drawn from the profile tabulated on a grid: piecewise-constant density in each
interval, the interval chosen by :class:`brdfkit.sampling.Distribution2D` (one row), so
:meth:`RadialSampler.pdf` is exactly the density :meth:`RadialSampler.sample` draws from.

References
----------
.. [1] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 3rd ed., §15.4
       (``SeparableBSSRDF::Sample_Sp``, ``Pdf_Sp``), 2016.
.. [2] A. King, C. Kulla, A. Conty, M. Fajardo, "BSSRDF importance sampling", SIGGRAPH Talks
       2013.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from brdfkit._checks import as_float_array
from brdfkit.sampling import Distribution2D

AXIS_PROBABILITIES = np.array([0.25, 0.25, 0.5])
"""Probabilities of projecting along the tangent s, the tangent t and the normal n."""

COVERED = 0.999
"""The fraction of a profile's power inside :math:`r_{max}`."""


@dataclass(frozen=True)
class Probe:
    """Probe segments in the local frame (s, t, n) of :math:`x_o`: each starts at ``origin``
    (relative to :math:`x_o`) and runs ``length`` along the unit ``axis``; ``radius`` is the
    sampled distance from the axis through :math:`x_o` (``length`` is 0 beyond
    :math:`r_{max}`)."""

    origin: np.ndarray
    axis: np.ndarray
    length: np.ndarray
    radius: np.ndarray


@dataclass(frozen=True, eq=False)
class RadialSampler:
    r"""Sampling of radii with density :math:`\propto` ``density`` (tabulated at ``radii``,
    increasing from 0; :math:`2\pi r R_d(r)` for a profile), piecewise constant between
    nodes: interval j has the mass of the trapezoid rule there.

    Examples
    --------
    An exponential density: its median is ln 2:

    >>> r = np.linspace(0.0, 30.0, 3001)
    >>> sampler = RadialSampler(r, np.exp(-r))
    >>> round(float(sampler.quantile(0.5)), 3)
    0.693
    >>> float(sampler.pdf(sampler.sample(np.array([[0.3, 0.5]])))[0]) > 0
    True
    """

    radii: np.ndarray
    density: np.ndarray

    @cached_property
    def _masses(self) -> np.ndarray:
        r, f = np.asarray(self.radii, float), np.asarray(self.density, float)
        return 0.5 * (f[1:] + f[:-1]) * np.diff(r)

    @cached_property
    def _distribution(self) -> Distribution2D:
        return Distribution2D(self._masses[None, :])

    def sample(self, u: Any) -> np.ndarray:
        """Radii for uniforms ``u`` ``(..., 2)`` (the second is unused, kept for
        :class:`~brdfkit.sampling.Distribution2D`)."""
        points, _ = self._distribution.sample(as_float_array("u", u))
        x = points[..., 0] * self._masses.size
        j = np.minimum(x.astype(np.int64), self._masses.size - 1)
        r = np.asarray(self.radii, float)
        return r[j] + (x - j) * (r[j + 1] - r[j])

    def pdf(self, radius: Any) -> np.ndarray:
        """The density (per unit radius) :meth:`sample` draws ``radius`` with."""
        radius = as_float_array("radius", radius)
        r = np.asarray(self.radii, float)
        j = np.clip(np.searchsorted(r, radius, side="right") - 1, 0, self._masses.size - 1)
        inside = (radius >= r[0]) & (radius < r[-1])
        density = self._masses[j] / self._masses.sum() / (r[j + 1] - r[j])
        return np.where(inside, density, 0.0)

    def quantile(self, q: float) -> float:
        """The radius below which the fraction ``q`` of the mass lies."""
        cdf = np.concatenate([[0.0], np.cumsum(self._masses)]) / self._masses.sum()
        return float(np.interp(q, cdf, np.asarray(self.radii, float)))

    def sample_probe(self, u: Any) -> Probe:
        """Probe segments (module docstring) for uniforms ``u`` ``(..., 3)``: the axis from
        ``u[..., 0]``, the radius from ``u[..., 1]``, the angle from ``u[..., 2]``."""
        u = as_float_array("u", u)
        axis = np.searchsorted(np.cumsum(AXIS_PROBABILITIES), u[..., 0], side="right")
        axis = np.minimum(axis, 2)
        radius = self.sample(np.stack([u[..., 1], np.full_like(u[..., 1], 0.5)], -1))
        phi = 2 * np.pi * u[..., 2]
        r_max = self.quantile(COVERED)
        half = np.sqrt(np.maximum(r_max * r_max - radius * radius, 0.0))
        eye = np.eye(3)
        v_z = eye[axis]
        v_x, v_y = eye[(axis + 1) % 3], eye[(axis + 2) % 3]
        offset = radius[..., None] * (np.cos(phi)[..., None] * v_x + np.sin(phi)[..., None] * v_y)
        return Probe(offset - half[..., None] * v_z, v_z, 2 * half, radius)

    def probe_pdf(self, offset: Any, normal: Any) -> np.ndarray:
        """The area density of finding the surface point at ``offset`` from :math:`x_o`
        (local frame), where the surface has unit ``normal`` (module docstring's sum over
        the three projections)."""
        offset, normal = as_float_array("offset", offset), as_float_array("normal", normal)
        total = np.zeros(offset.shape[:-1])
        for a in range(3):
            others = np.delete(offset, a, axis=-1)
            r = np.sqrt(np.sum(others * others, axis=-1))
            area = np.divide(self.pdf(r), 2 * np.pi * r, out=np.zeros_like(r), where=r > 0)
            total = total + AXIS_PROBABILITIES[a] * area * np.abs(normal[..., a])
        return total


__all__ = ["AXIS_PROBABILITIES", "COVERED", "Probe", "RadialSampler"]
