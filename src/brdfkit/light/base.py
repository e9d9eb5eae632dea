"""The light protocol: what every light source answers, and the domains of light parameters.

Every light answers three questions about a receiving point ``x`` (world coordinates, shape
``(..., 3)``):

- :meth:`Light.sample` — pick a direction ``wi`` towards the light from uniforms ``u``; returns a
  :class:`LightSample` whose ``value`` is what multiplies ``f·cos θi`` in a Monte Carlo estimate:
  L_i/pdf for extended lights, and for delta lights the irradiance E⊥ on a surface facing the
  light (directional: E; point: I/r², the inverse-square law).
- :meth:`Light.incident_radiance` — the incident radiance L_i(x, wi) (zero for delta lights).
- :meth:`Light.pdf` — the solid-angle density with which :meth:`Light.sample` picks ``wi``.

Radiometric units: radiance W·m⁻²·sr⁻¹, irradiance W·m⁻², intensity W·sr⁻¹ (DESIGN.md §1).
Occlusion by other geometry is not modelled (direct lighting of convex shapes).

References
----------
.. [1] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., ch. 12.
.. [2] P. Debevec, "Rendering synthetic objects into real scenes", SIGGRAPH 1998.
.. [3] J. Arvo, "Stratified sampling of spherical triangles", SIGGRAPH 1995.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import (
    Array,
    asarray,
    check_vectors,
    to_numpy,
)
from brdfkit.errors import ParameterError
from brdfkit.params import Domain, check_number

STRENGTH = Domain(0.0, 1e12, hint="a radiometric strength")
"""Radiance, irradiance, intensity and an environment map's scale: [0, 10¹²] (the sun's
radiance is about 2·10⁷ W·m⁻²·sr⁻¹)."""


COORDINATE = Domain(-1e12, 1e12, hint="metres")
"""Each coordinate of a light's position, centre, corner or edge: [−10¹², 10¹²] m."""


DIRECTION = Domain(-math.inf, math.inf, hint="a direction: any length but 0")
"""Each coordinate of a light's direction or normal: any finite number (normalised)."""


LENGTH = Domain(0.0, 1e12, lo_open=True, hint="metres")
"""A light's radius: (0, 10¹²] m."""


@dataclass(frozen=True, eq=False)
class LightSample:
    """A direction towards a light and its Monte Carlo value.

    Attributes
    ----------
    wi : (..., 3) unit direction from the receiving point towards the light (world frame).
    value : (..., C) L_i(wi)/pdf for extended lights; E⊥ (irradiance facing the light) for
        delta lights. Zero where the sample missed the light.
    pdf : (...,) solid-angle density (1 for delta lights, whose density is a Dirac).
    distance : (...,) distance to the sampled point on the light (inf for distant lights).
    delta : whether the light is a delta light (directional or point).
    """

    wi: Array
    value: Array
    pdf: Array
    distance: Array
    delta: bool


class Light:
    """Base class of light sources (see the module docstring for the protocol)."""

    delta: ClassVar[bool] = False
    channels: int = 1

    def sample(self, points: Array, u: Array) -> LightSample:
        """Sample a direction towards the light from each point."""
        raise NotImplementedError

    def incident_radiance(self, points: Array, wi: Array) -> Array:
        """Incident radiance at ``points`` from directions ``wi``, ``(..., C)``."""
        raise NotImplementedError

    def pdf(self, points: Array, wi: Array) -> Array:
        """Solid-angle density of :meth:`sample` choosing ``wi`` at ``points``, ``(...,)``."""
        raise NotImplementedError


def _batch(*arrays: Array) -> tuple[int, ...]:
    return tuple(np.broadcast_shapes(*(tuple(a.shape[:-1]) for a in arrays)))


def _vector(name: str, value: Any, like: Array) -> Array:
    return asarray(check_vectors(name, asarray(value)), like=like)


def _point(name: str, value: Any, domain: Domain = COORDINATE) -> np.ndarray:
    """A validated float64 3-vector parameter, each coordinate in ``domain``."""
    v = np.asarray(to_numpy(check_number(name, value)), dtype=np.float64)
    if v.shape != (3,):
        raise ParameterError(
            f"{name} must have a last axis of length 3 (x, y, z); got shape {v.shape}"
        )
    return domain.check(name, v)


def _unit(name: str, value: Any) -> np.ndarray:
    """A validated non-zero 3-vector parameter, normalised (without overflow or underflow)."""
    v = _point(name, value, DIRECTION)
    largest = np.max(np.abs(v))
    if largest == 0:
        raise ParameterError(f"{name} must be a non-zero vector; got (0, 0, 0)")
    v = v / largest
    return v / np.linalg.norm(v)


__all__ = [
    "Light",
    "LightSample",
]
