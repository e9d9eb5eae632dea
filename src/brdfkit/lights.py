"""Light sources: directional, point, Lambertian area lights, uniform sky, environment maps.

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

import copy
import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import (
    Array,
    asarray,
    check_vectors,
    clamp,
    constant,
    cross,
    dot,
    namespace,
    norm,
    normalize,
    safe_div,
    safe_sqrt,
    to_numpy,
)
from brdfkit.brdf.base import Domain, channel_count, check_number, param
from brdfkit.errors import ParameterError, SpecError
from brdfkit.geometry import (
    cartesian_to_spherical,
    frame_from_normal,
    spherical_to_cartesian,
    to_world,
)
from brdfkit.sampling import (
    square_to_uniform_cone,
    square_to_uniform_cone_pdf,
    square_to_uniform_disk_concentric,
    square_to_uniform_hemisphere,
    square_to_uniform_hemisphere_pdf,
)

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
    r²/(A cos θ_l)."""

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
    emitting ``radiance`` towards ``edge_u × edge_v``; sampled uniformly by area."""

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


# --------------------------------------------------------------------------- environment maps


def _sampling_weights(image: np.ndarray, compensate: bool = False) -> np.ndarray:
    """Texel weights (H, W) of an environment map's light sampling: luminance·sin θ.

    A bilinear lookup inside a pixel mixes its 3×3 neighbourhood, so the neighbourhood's
    maximum is sampled (L/pdf stays bounded next to a bright sun), plus a floor of 10⁻³ of
    its mean so that every direction the lookup can light has a positive density. With
    ``compensate`` the map's sin θ-weighted mean luminance is subtracted first, clipped at
    zero (:attr:`EnvironmentMap.compensated`).
    """
    from scipy.ndimage import maximum_filter

    from brdfkit.io import REC709_WEIGHTS

    height = image.shape[0]
    sin_theta = np.sin((np.arange(height) + 0.5) * math.pi / height)[:, None]
    if image.shape[2] == 3:
        lum = image @ np.array(REC709_WEIGHTS)
    else:
        lum = image.mean(axis=2)
    peak = maximum_filter(lum, size=3, mode=("nearest", "wrap"))
    floor = 1e-3 * max(peak.mean(), 1e-12)
    if compensate:
        mean = float(np.sum(lum * sin_theta) / (np.sum(sin_theta) * lum.shape[1]))
        peak = np.maximum(peak - mean, 0.0)
    return (peak + floor) * sin_theta


@dataclass(frozen=True, eq=False)
class EnvironmentMap(Light):
    r"""Distant radiance from an equirectangular (lat-long) image, bilinearly interpolated.

    The map follows :func:`brdfkit.sh.latlong_directions`: row 0 at +z (θ = 0), column 0 starting
    at φ = 0 (+x) with φ growing towards +y. ``rotation`` (a 3×3 matrix) takes map directions to
    world directions. Importance sampling draws pixels from a piecewise-constant distribution
    proportional to luminance·sin θ (the 3×3 maximum, since the bilinear lookup mixes
    neighbours, plus a small floor so that every direction the bilinear
    lookup can light has a positive density), with solid-angle pdf
    :math:`p_\omega = p_{uv} / (2\pi^2 \sin\theta)`.

    Parameters
    ----------
    image : (H, W, C) non-negative radiance (W·m⁻²·sr⁻¹).
    scale : multiplies the radiance.
    rotation : (3, 3) rotation matrix map → world (default identity).

    References
    ----------
    .. [1] P. Debevec, "Rendering synthetic objects into real scenes", SIGGRAPH 1998.
    .. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 3rd ed., §14.2.4.
    """

    image: Any = None
    scale: float = 1.0
    rotation: Any = None

    def __post_init__(self) -> None:
        img = to_numpy(check_number("image", self.image)) if self.image is not None else None
        if img is None or img.ndim != 3 or img.shape[0] < 2 or img.shape[1] < 2:
            shape = None if img is None else img.shape
            raise ParameterError(
                f"image must be an (H, W, C) lat-long array with H, W >= 2; got {shape}"
            )
        if not np.all(np.isfinite(img)) or np.any(img < 0):
            raise ParameterError("image must hold finite, non-negative radiance values")
        STRENGTH.check("scale", self.scale)
        rot = np.eye(3) if self.rotation is None else check_number("rotation", self.rotation)
        rot = np.asarray(to_numpy(rot), dtype=float)
        finite = rot.shape == (3, 3) and np.all(np.isfinite(rot))
        if not finite or not np.allclose(rot @ rot.T, np.eye(3), atol=1e-6):
            raise ParameterError(f"rotation must be a 3×3 rotation matrix; got {rot!r}")
        object.__setattr__(self, "image", np.ascontiguousarray(img, dtype=np.float32))
        object.__setattr__(self, "rotation", rot)
        object.__setattr__(self, "channels", img.shape[2])

    @functools.cached_property
    def _distribution(self):
        """The light-sampling distribution of :meth:`sample` and :meth:`pdf`
        (:func:`_sampling_weights`), made when first needed: a map only looked up (the atlas's
        quadrature spheres, whose Monte Carlo renders sample :attr:`compensated`) never
        pays for it."""
        from brdfkit.sampling import Distribution2D

        return Distribution2D(_sampling_weights(self.image))

    @functools.cached_property
    def compensated(self) -> EnvironmentMap:
        r"""The same map with the light-sampling distribution MIS should combine with BRDF
        sampling: proportional to :math:`\max(L - \bar L, 0)\sin\theta` plus the floor,
        with :math:`\bar L` the map's mean luminance over the sphere.

        Multiple importance sampling with BRDF sampling covers the directions where the map is
        near its mean well already; taking the mean out of the light's density spends its
        samples on what is brighter (Karlík et al.'s MIS compensation), and the floor keeps the
        density positive wherever the map lights, so either strategy alone stays unbiased. Same
        radiance, rotation and scale; only :meth:`sample` and :meth:`pdf` differ.

        References
        ----------
        .. [1] O. Karlík, M. Šik, P. Vévoda, T. Skřivan, J. Křivánek, "MIS compensation:
           optimizing sampling techniques in multiple importance sampling", *ACM Trans.
           Graph.* 38(6), 2019.
        """
        from brdfkit.sampling import Distribution2D

        view = copy.copy(self)
        weights = _sampling_weights(self.image, compensate=True)
        object.__setattr__(view, "_distribution", Distribution2D(weights))
        view.__dict__["compensated"] = view
        return view

    @classmethod
    def from_file(
        cls, path: str | Path, scale: float = 1.0, rotation: Any = None
    ) -> EnvironmentMap:
        """Read a lat-long ``.hdr``/``.exr`` (or LDR, decoded to linear) environment map."""
        from brdfkit.io import read_image

        image = read_image(path)
        if Path(path).suffix.lower() not in (".hdr", ".exr", ".pfm"):
            from brdfkit.io import srgb_decode

            image = srgb_decode(image)
        return cls(image[..., :3], scale=scale, rotation=rotation)

    @classmethod
    def from_mirror_ball(
        cls, photo: Any, height: int = 256, width: int = 512, scale: float = 1.0
    ) -> EnvironmentMap:
        """Convert a photograph of a mirror ball (cropped to the ball) to a lat-long map.

        Orthographic view along the camera's −z; the camera frame (x right, y up, z towards the
        camera) maps to the world frame as world = (z_cam, x_cam, y_cam): world +z is the
        photo's up and world +x points towards the camera. For a world direction d the ball
        normal reflecting the view direction v = +x into d is n = (d + v)/|d + v|, seen at
        photo coordinates (x, y) = (n·x_cam, n·y_cam). Directions right behind the ball
        (d ≈ −v) are not seen and come out poorly sampled.
        """
        from brdfkit.sh import latlong_directions

        photo = to_numpy(photo).astype(np.float32)
        if photo.ndim != 3 or photo.shape[0] < 2:
            raise ParameterError(f"photo must be an (H, W, C) image of the ball; got {photo.shape}")
        d = latlong_directions(height, width)
        v = np.array([1.0, 0.0, 0.0])
        n = d + v
        n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
        x_cam, y_cam = n[..., 1], n[..., 2]
        ph, pw = photo.shape[:2]
        col = (x_cam + 1) / 2 * pw - 0.5
        row = (1 - y_cam) / 2 * ph - 0.5
        image = _bilinear_np(photo, row, col)
        return cls(image, scale=scale)

    def _map_coordinates(self, wi: Array) -> tuple[Array, Array, Array]:
        """Unit world ``wi`` as map coordinates: x = φ/2π ∈ [0, 1), y = θ/π, and θ."""
        xp = namespace(wi)
        wi_map = xp.matmul(wi, asarray(self.rotation, xp, like=wi))
        theta, phi = cartesian_to_spherical(wi_map)
        x = xp.remainder(phi, constant(2 * math.pi, phi)) / (2 * math.pi)
        return x, theta / math.pi, theta

    def _lookup(self, wi: Array) -> Array:
        xp = namespace(wi)
        x, y, _ = self._map_coordinates(wi)
        height, width = self.image.shape[:2]
        image = asarray(self.image, xp, like=wi)
        value = _bilinear(image, y * height - 0.5, x * width - 0.5)
        return value * self.scale

    def incident_radiance(self, points: Array, wi: Array) -> Array:
        xp = namespace(points, wi)
        value = self._lookup(normalize(wi))
        return xp.broadcast_to(value, (*_batch(points, wi), value.shape[-1]))

    def sample(self, points: Array, u: Array) -> LightSample:
        xp = namespace(points, u)
        uv, pdf_uv = self._distribution.sample(asarray(u[..., :2], xp, like=points))
        theta, phi = uv[..., 1] * math.pi, uv[..., 0] * (2 * math.pi)
        wi_map = spherical_to_cartesian(theta, phi)
        wi = xp.matmul(wi_map, xp.permute_dims(asarray(self.rotation, xp, like=points), (1, 0)))
        pdf = _solid_angle_pdf(pdf_uv, theta)
        value = safe_div(self._lookup(wi), pdf[..., None])
        batch = _batch(points, wi)
        inf = xp.full(batch, math.inf, dtype=points.dtype)
        return LightSample(
            xp.broadcast_to(wi, (*batch, 3)),
            xp.broadcast_to(value, (*batch, value.shape[-1])),
            xp.broadcast_to(pdf, batch),
            inf,
            False,
        )

    def pdf(self, points: Array, wi: Array) -> Array:
        xp = namespace(points, wi)
        x, y, theta = self._map_coordinates(normalize(wi))
        pdf_uv = self._distribution.pdf(xp.stack([x, y], axis=-1))
        pdf = _solid_angle_pdf(pdf_uv, theta)
        return xp.broadcast_to(pdf, _batch(points, wi))

    def irradiance(self, normals: Array) -> Array:
        r"""Irradiance :math:`E(n) = \int L(\omega) \max(n\cdot\omega, 0)\,d\omega` on a
        surface with unit world normal ``normals`` ``(..., 3)``; ``(..., C)``.

        A Lambertian surface of albedo ρ under the map reflects exactly :math:`\rho E(n)/\pi`
        towards every viewer above it, with no Monte Carlo. E is read from
        :meth:`irradiance_table` (built once per map) by bilinear interpolation.
        """
        xp = namespace(normals)
        x, y, _ = self._map_coordinates(normalize(normals))
        table = asarray(self.irradiance_table, xp, like=normals)
        rows, cols = table.shape[:2]
        return _bilinear(table, y * (rows - 1), x * cols) * self.scale

    @functools.cached_property
    def irradiance_table(self) -> np.ndarray:
        r"""E at map-frame normals on a lat-long node grid, ``(97, 192, C)`` float32.

        Row ``i`` holds θ = πi/96 (both poles included), column ``j`` φ = 2πj/192. Each
        value is a normalised quadrature over the map's pixels grouped into 48×96 cells:

        .. math:: E(n) = \pi\,\frac{\sum_c \max(n\cdot M_c, 0)}{\sum_c \max(n\cdot A_c, 0)},
           \quad M_c = \sum_{p\in c} L_p \,\Delta\Omega_p\, \omega_p,
           \quad A_c = \sum_{p\in c} \Delta\Omega_p\, \omega_p,

        with :math:`\Delta\Omega_p = \tfrac{2\pi}{W}(\cos\theta_p^- - \cos\theta_p^+)` the
        exact solid angle of pixel p and :math:`\omega_p` its centre. Because
        :math:`n\cdot\omega` is linear in ω, the cell moments M_c are exact for every cell
        wholly above or below n's horizon; only cells that straddle it (where the cosine is
        below the cell's size, π/48) err, by at most their radiance × solid angle × π/96.
        The denominator is the same quadrature of L = 1 (exactly π in the limit): it removes
        the quadrature's own error, so a constant map gives E = πL to rounding (white-out).
        The grid's bilinear interpolation errs by at most ~h|∇E|/4 (h = π/96) at the kink
        that a point-like source puts at its terminator, and by O(h²) elsewhere.

        References
        ----------
        .. [1] R. Ramamoorthi, P. Hanrahan, "An efficient representation for irradiance
               environment maps", SIGGRAPH 2001 (the irradiance map; here by direct
               summation instead of spherical harmonics, which ring at a sun).
        """
        moments, areas = _cell_moments(self.image, IRRADIANCE_CELLS)
        rows, cols = IRRADIANCE_GRID
        t, p = np.meshgrid(
            np.linspace(0.0, math.pi, rows), np.arange(cols) * (2 * math.pi / cols), indexing="ij"
        )
        normals = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)
        normals = normals.reshape(-1, 3).astype(np.float32)
        channels = moments.shape[0]
        table = np.empty((normals.shape[0], channels))
        for start in range(0, normals.shape[0], 512):  # ~20 MB of temporaries per block
            n = normals[start : start + 512]
            area = _clamped_sum(n, areas)
            for ch in range(channels):
                table[start : start + 512, ch] = math.pi * _clamped_sum(n, moments[ch]) / area
        return table.reshape(rows, cols, channels).astype(np.float32)


IRRADIANCE_CELLS = (48, 96)
"""Cells (rows, columns) the map's pixels are grouped into for :meth:`EnvironmentMap.irradiance`."""

IRRADIANCE_GRID = (97, 192)
"""Node grid (rows with both poles, columns) of :meth:`EnvironmentMap.irradiance_table`."""


def _cell_moments(image: np.ndarray, cells: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    r"""Per cell of a lat-long ``image``, :math:`M_c = \sum_p L_p\Delta\Omega_p\omega_p` as
    ``(C, 3, cells)`` and :math:`A_c = \sum_p \Delta\Omega_p\omega_p` as ``(3, cells)``
    float32; pixel (r, c) goes to cell ``(r·rows // H, c·cols // W)``."""
    height, width, channels = image.shape
    edges = np.arange(height + 1) * (math.pi / height)
    solid_angle = (2 * math.pi / width) * (np.cos(edges[:-1]) - np.cos(edges[1:]))
    theta = (np.arange(height) + 0.5) * (math.pi / height)
    phi = (np.arange(width) + 0.5) * (2 * math.pi / width)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    omega = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])
    weighted = (omega * solid_angle[:, None]).reshape(3, -1)  # (3, H·W)
    rows, cols = cells
    cell = (np.arange(height) * rows // height)[:, None] * cols + np.arange(width) * cols // width
    cell, count = cell.ravel(), rows * cols

    def per_cell(values: np.ndarray) -> np.ndarray:
        return np.stack([np.bincount(cell, values * w, count) for w in weighted])

    radiance = image.reshape(-1, channels).astype(np.float64)
    moments = np.stack([per_cell(radiance[:, ch]) for ch in range(channels)])
    return moments.astype(np.float32), per_cell(np.ones(height * width)).astype(np.float32)


def _clamped_sum(normals: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Σ_c max(n·v_c, 0) for each of ``normals`` ``(N, 3)`` over ``vectors`` ``(3, cells)``."""
    dots = normals @ vectors
    return np.maximum(dots, 0.0, out=dots).sum(axis=1, dtype=np.float64)


def _solid_angle_pdf(pdf_uv: Array, theta: Array) -> Array:
    """p_ω = p_uv / (2π² sin θ) of a lat-long map; 0 at the poles (sin θ ≤ 0 after rounding)."""
    return safe_div(pdf_uv, 2 * math.pi**2 * clamp(namespace(theta).sin(theta), 0.0))


def _bilinear(image: Array, row: Array, col: Array) -> Array:
    """Bilinear lookup of an (H, W, C) lat-long image at fractional pixel coordinates.

    Columns wrap around (φ is periodic); rows clamp at the poles.
    """
    xp = namespace(image, row)
    height, width, channels = image.shape
    r0f, c0f = xp.floor(row), xp.floor(col)
    fr, fc = (row - r0f)[..., None], (col - c0f)[..., None]
    r_index = xp.astype(r0f, xp.int64)
    r0 = xp.clip(r_index, 0, height - 1)
    r1 = xp.clip(r_index + 1, 0, height - 1)
    c0 = xp.remainder(xp.astype(c0f, xp.int64), width)
    c1 = xp.remainder(c0 + 1, width)
    flat = xp.reshape(image, (height * width, channels))
    shape = (*row.shape, channels)

    def at(r: Array, c: Array) -> Array:
        return xp.reshape(xp.take(flat, xp.reshape(r * width + c, (-1,)), axis=0), shape)

    top = at(r0, c0) * (1 - fc) + at(r0, c1) * fc
    bottom = at(r1, c0) * (1 - fc) + at(r1, c1) * fc
    return top * (1 - fr) + bottom * fr


def _bilinear_np(image: np.ndarray, row: np.ndarray, col: np.ndarray) -> np.ndarray:
    """Bilinear lookup clamped at every border (for photographs, which do not wrap)."""
    from scipy.ndimage import map_coordinates

    return np.stack(
        [
            map_coordinates(image[..., c], [row, col], order=1, mode="nearest")
            for c in range(image.shape[2])
        ],
        axis=-1,
    )


# --------------------------------------------------------------------------- light specs
LIGHT_SPECS = {
    "directional": "directional:X,Y,Z[:E]  (direction towards the light, irradiance E)",
    "point": "point:X,Y,Z[:I]  (position, intensity I)",
    "sky": "sky[:L]  (uniform radiance L over the upper hemisphere)",
    "envmap": "envmap:PATH[:SCALE]  (lat-long .hdr/.exr; 'envmap' alone: the bundled map)",
    "sunsky": "sunsky:X,Y,Z[:T]  (Hosek–Wilkie sky and sun towards X,Y,Z, turbidity T)",
}


def parse_light(spec: str) -> Light:
    """A light from a short text spec, e.g. ``"directional:1,0.5,0.7:3"`` or ``"envmap:sky.hdr"``.

    The forms are :data:`LIGHT_SPECS`; numbers are read with :class:`float`, and a spec holds at
    most :data:`~brdfkit.brdf._spec.MAX_SPEC_LENGTH` characters. An environment map's file is
    read by :func:`brdfkit.io.read_image`, whose errors pass through.

    Raises
    ------
    brdfkit.errors.SpecError
        For a spec outside these forms (an unknown kind, a missing or malformed number), naming
        the spec and listing the known forms.
    brdfkit.errors.ParameterError
        For a value outside its domain (a zero or non-finite direction, a negative or infinite
        strength), naming it.
    """
    from brdfkit.brdf._spec import MAX_SPEC_LENGTH

    if not isinstance(spec, str):
        raise SpecError(f"light spec must be a string; got {type(spec).__name__} {spec!r:.80}")
    if len(spec) > MAX_SPEC_LENGTH:
        raise SpecError(f"light spec holds {len(spec)} characters; at most {MAX_SPEC_LENGTH}")
    kind, _, rest = spec.strip().partition(":")
    if kind in ("directional", "point"):
        vector, _, value = rest.partition(":")
        numbers = _floats(spec, vector, 3), _float(spec, value or "1")
        if kind == "directional":
            return DirectionalLight(*numbers)
        return PointLight(*numbers)
    if kind == "sky":
        return UniformSky(_float(spec, rest or "1"))
    if kind == "envmap":
        path, scale = rest, 1.0
        head, sep, tail = rest.rpartition(":")
        if sep and _is_float(tail):
            path, scale = head, float(tail)
        STRENGTH.check("scale", scale)  # before the file is read
        if not path:
            from brdfkit.data import default_envmap_path

            path = str(default_envmap_path())
        return EnvironmentMap.from_file(path, scale=scale)
    if kind == "sunsky":
        from brdfkit.sunsky import SunSky

        vector, _, value = rest.partition(":")
        return SunSky(_floats(spec, vector, 3), turbidity=_float(spec, value or "3"))
    raise SpecError(f"light spec {spec!r:.80} has an unknown kind {kind!r:.40}. {_known()}")


def _known() -> str:
    return f"Known forms: {'; '.join(LIGHT_SPECS.values())}"


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _float(spec: str, text: str) -> float:
    """``text`` as a float, or a :class:`~brdfkit.errors.SpecError` quoting ``spec``."""
    if not _is_float(text):
        raise SpecError(
            f"light spec {spec!r:.80} is invalid: {text!r:.40} is no number. {_known()}"
        )
    return float(text)


def _floats(spec: str, text: str, count: int) -> tuple[float, ...]:
    """``count`` comma-separated floats, or a :class:`~brdfkit.errors.SpecError`."""
    parts = text.split(",")
    if len(parts) != count:
        raise SpecError(
            f"light spec {spec!r:.80} is invalid: expected {count} comma-separated numbers, got "
            f"{text!r:.40}. {_known()}"
        )
    return tuple(_float(spec, part) for part in parts)


__all__ = [
    "LIGHT_SPECS",
    "DirectionalLight",
    "DiskLight",
    "EnvironmentMap",
    "Light",
    "LightSample",
    "PointLight",
    "RectangleLight",
    "SphereLight",
    "UniformSky",
    "parse_light",
]
