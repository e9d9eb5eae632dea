"""Analytic light sources: directional and point lights, sphere, disk and rectangle area
lights, and a uniform sky.

Delta lights (directional, point) are sampled with probability one; area lights are Lambertian
emitters sampled by solid angle (spheres by their cone of directions, disks and rectangles by
area, converted to solid angle). Occlusion by other geometry is not modelled.

References
----------
.. [1] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., ch. 12.
.. [2] J. Arvo, "Stratified sampling of spherical triangles", SIGGRAPH 1995.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import (
    Array,
    asarray,
    clamp,
    cross,
    dot,
    namespace,
    norm,
    normalize,
    safe_div,
    safe_sqrt,
)
from brdfkit.errors import ParameterError
from brdfkit.geometry import (
    frame_from_normal,
    to_world,
)
from brdfkit.light.base import LENGTH, STRENGTH, Light, LightSample, _batch, _point, _unit, _vector
from brdfkit.params import channel_count, param
from brdfkit.sampling import (
    square_to_uniform_cone,
    square_to_uniform_cone_pdf,
    square_to_uniform_disk_concentric,
    square_to_uniform_hemisphere,
    square_to_uniform_hemisphere_pdf,
)


# --------------------------------------------------------------------------- delta lights
class _DeltaLight(Light):
    """A light reached from one direction only: no radiance or density in any given ``wi``."""

    delta: ClassVar[bool] = True

    def incident_radiance(self, points: Array, wi: Array) -> Array:
        xp = namespace(points, wi)
        return xp.zeros((*_batch(points, wi), self.channels), dtype=wi.dtype)

    def pdf(self, points: Array, wi: Array) -> Array:
        xp = namespace(wi)
        return xp.zeros(wi.shape[:-1], dtype=wi.dtype)


@dataclass(frozen=True, eq=False)
class DirectionalLight(_DeltaLight):
    """A distant light from ``direction`` delivering irradiance ``irradiance`` (W·m⁻²) on a
    surface facing it: E(n) = E·max(0, n·l).

    References
    ----------
    .. [1] CMU 16-385 Lecture 14, "directional light"; PBRT 4th ed. §12.4.

    Examples
    --------
    The direction is normalised; every receiving point gets the same direction and irradiance:

    >>> import numpy as np
    >>> light = DirectionalLight(direction=(0.0, 0.0, 2.0), irradiance=3.0)
    >>> light.direction.tolist(), light.delta
    ([0.0, 0.0, 1.0], True)
    >>> sample = light.sample(np.zeros((2, 3)))
    >>> sample.wi.tolist(), sample.value.tolist()
    ([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]], [[3.0], [3.0]])
    """

    direction: Any = (0.0, 0.0, 1.0)
    irradiance: Any = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "direction", _unit("direction", self.direction))
        STRENGTH.check("irradiance", self.irradiance)
        object.__setattr__(self, "channels", channel_count(self.irradiance, names=("irradiance",)))

    def sample(self, points: Array, u: Array | None = None) -> LightSample:
        xp = namespace(points)
        batch = tuple(points.shape[:-1])
        wi = xp.broadcast_to(_vector("direction", self.direction, points), (*batch, 3))
        e = param(self.irradiance, points)
        value = xp.broadcast_to(e, (*batch, e.shape[-1]))
        ones = xp.ones(batch, dtype=points.dtype)
        return LightSample(wi, value, ones, ones * math.inf, True)


@dataclass(frozen=True, eq=False)
class PointLight(_DeltaLight):
    """An isotropic point light of intensity ``intensity`` (W·sr⁻¹) at ``position``.

    The irradiance at distance r on a surface facing it is E⊥ = I/r² (inverse-square law).

    Examples
    --------
    >>> import numpy as np
    >>> light = PointLight(position=(0.0, 0.0, 2.0), intensity=100.0)
    >>> sample = light.sample(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    >>> sample.value.tolist(), sample.distance.tolist()
    ([[25.0], [100.0]], [2.0, 1.0])
    """

    position: Any = (0.0, 0.0, 1.0)
    intensity: Any = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _point("position", self.position))
        STRENGTH.check("intensity", self.intensity)
        object.__setattr__(self, "channels", channel_count(self.intensity, names=("intensity",)))

    def sample(self, points: Array, u: Array | None = None) -> LightSample:
        xp = namespace(points)
        to_light = _vector("position", self.position, points) - points
        r2 = dot(to_light, to_light)
        if not bool(xp.all(r2 > 0)):
            raise ValueError("points must not coincide with the point light's position")
        value = param(self.intensity, points) / r2[..., None]
        ones = xp.ones(r2.shape, dtype=points.dtype)
        return LightSample(normalize(to_light), value, ones, xp.sqrt(r2), True)


def _uniform_where(radiance: Any, hit: Array, points: Array, wi: Array) -> Array:
    """The constant ``radiance`` where ``hit``, else 0, shaped ``batch + (C,)``."""
    xp = namespace(points, wi)
    value = param(radiance, wi)
    shape = (*_batch(points, wi), value.shape[-1])
    return xp.where(hit[..., None], xp.broadcast_to(value, shape), xp.zeros(shape, dtype=wi.dtype))


# --------------------------------------------------------------------------- area lights
def _check_radiance(obj: Any) -> None:
    STRENGTH.check("radiance", obj.radiance)
    object.__setattr__(obj, "channels", channel_count(obj.radiance, names=("radiance",)))


@dataclass(frozen=True, eq=False)
class SphereLight(Light):
    """A Lambertian sphere of ``radius`` at ``center`` emitting uniform radiance ``radiance``.

    Sampled uniformly in the cone of directions it subtends (solid-angle sampling, pdf
    1/(2π(1 − cos α)) with sin α = R/d); a point facing it receives E = πL sin²α.

    Examples
    --------
    Seen from twice its radius the sphere fills a cone of half-angle 30°; a sample's value
    L/pdf is L times that cone's solid angle:

    >>> import numpy as np
    >>> light = SphereLight(center=(0.0, 0.0, 2.0), radius=1.0, radiance=1.0)
    >>> sample = light.sample(np.zeros(3), np.array([0.3, 0.7]))
    >>> float(sample.value[0].round(4)), float(sample.pdf.round(4))
    (0.8418, 1.1879)
    >>> light.incident_radiance(np.zeros(3), np.array([0.0, 1.0, 0.0])).tolist()  # misses it
    [0.0]
    """

    center: Any = (0.0, 0.0, 2.0)
    radius: float = 0.5
    radiance: Any = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _point("center", self.center))
        LENGTH.check("radius", self.radius)
        _check_radiance(self)

    def _cone(self, points: Array) -> tuple[Array, Array, Array]:
        xp = namespace(points)
        to_center = _vector("center", self.center, points) - points
        d = norm(to_center)
        if not bool(xp.all(d > self.radius)):
            raise ValueError("points must lie outside the sphere light")
        cos_alpha = safe_sqrt(1 - (self.radius / d) ** 2)
        return to_center / d[..., None], cos_alpha, d

    def sample(self, points: Array, u: Array) -> LightSample:
        axis, cos_alpha, d = self._cone(points)
        local = square_to_uniform_cone(u[..., :2], cos_alpha)
        wi = to_world(local, frame_from_normal(axis))
        pdf = square_to_uniform_cone_pdf(local, cos_alpha)
        value = param(self.radiance, points) / pdf[..., None]
        # distance to the first intersection along wi
        b = dot(wi, axis) * d
        dist = b - safe_sqrt(b * b - d * d + self.radius**2)
        return LightSample(wi, value, pdf, dist, False)

    def _hits(self, points: Array, wi: Array) -> tuple[Array, Array, Array]:
        axis, cos_alpha, _ = self._cone(points)
        return dot(normalize(wi), axis) >= cos_alpha, cos_alpha, axis

    def incident_radiance(self, points: Array, wi: Array) -> Array:
        return _uniform_where(self.radiance, self._hits(points, wi)[0], points, wi)

    def pdf(self, points: Array, wi: Array) -> Array:
        xp = namespace(points, wi)
        hit, cos_alpha, _ = self._hits(points, wi)
        density = 1 / (2 * math.pi * (1 - cos_alpha))
        return xp.where(hit, density, xp.zeros_like(density))


@dataclass(frozen=True, eq=False)
class _PlanarLight(Light):
    """Shared code of one-sided planar Lambertian emitters sampled by area."""

    def _area(self) -> float:
        raise NotImplementedError

    def _sample_area(self, u: Array) -> Array:
        raise NotImplementedError

    def _inside(self, q: Array) -> Array:
        raise NotImplementedError

    def _plane(self, like: Array) -> tuple[Array, Array]:
        raise NotImplementedError

    def sample(self, points: Array, u: Array) -> LightSample:
        xp = namespace(points, u)
        _, n = self._plane(points)
        q = self._sample_area(asarray(u[..., :2], xp, like=points))
        to_light = q - points
        dist2 = dot(to_light, to_light)
        dist = xp.sqrt(dist2)
        wi = to_light / dist[..., None]
        cos_light = clamp(-dot(wi, n), 0.0)  # emits towards +normal
        pdf = safe_div(dist2, cos_light * self._area())
        value = safe_div(param(self.radiance, points), pdf[..., None])
        return LightSample(wi, value, pdf, dist, False)

    def _intersect(self, points: Array, wi: Array) -> tuple[Array, Array, Array]:
        xp = namespace(points, wi)
        origin, n = self._plane(points)
        wi = normalize(wi)
        cos_light = -dot(wi, n)
        safe = xp.where(cos_light > 0, cos_light, xp.ones_like(cos_light))
        t = dot(points - origin, n) / safe
        q = points + t[..., None] * wi
        hit = (cos_light > 0) & (t > 0) & self._inside(q)
        return hit, t, safe

    def incident_radiance(self, points: Array, wi: Array) -> Array:
        return _uniform_where(self.radiance, self._intersect(points, wi)[0], points, wi)

    def pdf(self, points: Array, wi: Array) -> Array:
        xp = namespace(points, wi)
        hit, t, cos_light = self._intersect(points, wi)
        density = t * t / (cos_light * self._area())
        return xp.where(hit, density, xp.zeros_like(density))


@dataclass(frozen=True, eq=False)
class DiskLight(_PlanarLight):
    """A one-sided Lambertian disk of ``radius`` at ``center`` emitting ``radiance`` towards
    ``normal``; sampled uniformly by area (concentric map), pdf converted to solid angle
    r²/(A cos θ_l).

    Examples
    --------
    The default disk (radius 1/2) hangs 2 above the origin, facing down: straight up, the pdf
    is r²/(A cos θ_l) = 4/(π/4) = 16/π:

    >>> import numpy as np
    >>> light = DiskLight()
    >>> up = np.array([0.0, 0.0, 1.0])
    >>> light.incident_radiance(np.zeros(3), up).tolist()
    [1.0]
    >>> float((light.pdf(np.zeros(3), up) * np.pi).round(12))
    16.0
    """

    center: Any = (0.0, 0.0, 2.0)
    normal: Any = (0.0, 0.0, -1.0)
    radius: float = 0.5
    radiance: Any = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _point("center", self.center))
        object.__setattr__(self, "normal", _unit("normal", self.normal))
        LENGTH.check("radius", self.radius)
        _check_radiance(self)

    def _area(self) -> float:
        return math.pi * self.radius**2

    def _plane(self, like: Array) -> tuple[Array, Array]:
        return _vector("center", self.center, like), _vector("normal", self.normal, like)

    def _sample_area(self, u: Array) -> Array:
        xp = namespace(u)
        disk = square_to_uniform_disk_concentric(u) * self.radius
        local = xp.concat([disk, xp.zeros_like(disk[..., :1])], axis=-1)
        center, n = self._plane(u)
        return center + to_world(local, frame_from_normal(n))

    def _inside(self, q: Array) -> Array:
        center, _ = self._plane(q)
        return dot(q - center, q - center) <= self.radius**2


@dataclass(frozen=True, eq=False)
class RectangleLight(_PlanarLight):
    """A one-sided Lambertian parallelogram ``corner + s·edge_u + t·edge_v`` (s, t ∈ [0, 1])
    emitting ``radiance`` towards ``edge_u × edge_v``; sampled uniformly by area.

    Examples
    --------
    The default unit square hangs 2 above the origin, facing down:

    >>> import numpy as np
    >>> light = RectangleLight(radiance=(1.0, 0.5, 0.25))
    >>> up = np.array([0.0, 0.0, 1.0])
    >>> light.channels, light.incident_radiance(np.zeros(3), up).tolist()
    (3, [1.0, 0.5, 0.25])
    >>> float(light.pdf(np.zeros(3), up))  # r²/(A cos θ_l)
    4.0
    """

    corner: Any = (-0.5, -0.5, 2.0)
    edge_u: Any = (0.0, 1.0, 0.0)
    edge_v: Any = (1.0, 0.0, 0.0)
    radiance: Any = 1.0

    def __post_init__(self) -> None:
        for name in ("corner", "edge_u", "edge_v"):
            object.__setattr__(self, name, _point(name, getattr(self, name)))
        if not np.linalg.norm(np.cross(self.edge_u, self.edge_v)) > 0:
            raise ParameterError(
                "edge_u and edge_v must span a parallelogram; got parallel or vanishing edges"
            )
        _check_radiance(self)

    def _area(self) -> float:
        return float(np.linalg.norm(np.cross(self.edge_u, self.edge_v)))

    def _plane(self, like: Array) -> tuple[Array, Array]:
        n = np.cross(self.edge_u, self.edge_v)
        return _vector("corner", self.corner, like), _vector("normal", n / np.linalg.norm(n), like)

    def _sample_area(self, u: Array) -> Array:
        corner = _vector("corner", self.corner, u)
        return (
            corner
            + u[..., 0:1] * _vector("edge_u", self.edge_u, u)
            + u[..., 1:2] * _vector("edge_v", self.edge_v, u)
        )

    def _inside(self, q: Array) -> Array:
        corner, n = self._plane(q)
        eu, ev = _vector("edge_u", self.edge_u, q), _vector("edge_v", self.edge_v, q)
        # Solve q - corner = s·eu + t·ev through the dual basis of the parallelogram.
        d = q - corner
        area_n = dot(cross(eu, ev), n)
        s = dot(cross(d, ev), n) / area_n
        t = dot(cross(eu, d), n) / area_n
        return (s >= 0) & (s <= 1) & (t >= 0) & (t <= 1)


# --------------------------------------------------------------------------- distant lights
@dataclass(frozen=True, eq=False)
class UniformSky(Light):
    """Constant radiance ``radiance`` from every direction of the upper hemisphere (world +z).

    A Lambertian surface of albedo ρ facing up under it has radiance ρL ("white-out").
    Sampled uniformly over the upper hemisphere.

    Examples
    --------
    >>> import numpy as np
    >>> sky = UniformSky(radiance=2.0)
    >>> up_and_down = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    >>> sky.incident_radiance(np.zeros(3), up_and_down).tolist()
    [[2.0], [0.0]]
    >>> sample = sky.sample(np.zeros(3), np.array([0.2, 0.9]))
    >>> float((sample.value[0] / (2 * np.pi)).round(12))  # L/pdf = L·2π
    2.0
    """

    radiance: Any = 1.0

    def __post_init__(self) -> None:
        _check_radiance(self)

    def sample(self, points: Array, u: Array) -> LightSample:
        xp = namespace(points, u)
        wi = square_to_uniform_hemisphere(asarray(u[..., :2], xp, like=points))
        pdf = square_to_uniform_hemisphere_pdf(wi)
        value = param(self.radiance, points) / pdf[..., None]
        batch = _batch(points, wi)
        return LightSample(
            xp.broadcast_to(wi, (*batch, 3)),
            xp.broadcast_to(value, (*batch, value.shape[-1])),
            xp.broadcast_to(pdf, batch),
            xp.full(batch, math.inf, dtype=points.dtype),
            False,
        )

    def incident_radiance(self, points: Array, wi: Array) -> Array:
        return _uniform_where(self.radiance, wi[..., 2] > 0, points, wi)

    def pdf(self, points: Array, wi: Array) -> Array:
        xp = namespace(points, wi)
        p = square_to_uniform_hemisphere_pdf(wi)
        return xp.broadcast_to(p, _batch(points, wi))


__all__ = [
    "DirectionalLight",
    "DiskLight",
    "PointLight",
    "RectangleLight",
    "SphereLight",
    "UniformSky",
]
