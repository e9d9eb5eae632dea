"""Scenes seen through a G-buffer: cameras, shapes (sphere, plane, cylinder) and normal maps.

A *G-buffer* holds, per pixel, the surface point, normal, tangent, the direction towards the
viewer and a coverage mask; it comes from a shape seen by a camera (:class:`Sphere`,
:class:`Plane`, :class:`Cylinder` with :class:`Camera`) or straight from a normal map and mask
(photometric-stereo data, SVBRDF textures).

World frame: +z is up (the environment maps' pole). The default camera looks horizontally along
−x from +x with the image's right along +y and up along +z (the camera frame of
:meth:`brdfkit.light.EnvironmentMap.from_mirror_ball`).

References
----------
.. [1] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., ch. 5–6.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from brdfkit._array import dot, holds_normal, norm, to_numpy

FRONT = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
"""Camera-to-world rotation of the default view: columns are the camera's x, y, z in the world."""


@dataclass(frozen=True, eq=False)
class GBuffer:
    """Per-pixel geometry, each ``(H, W, 3)`` world vectors (``mask`` is ``(H, W)`` bool)."""

    points: np.ndarray
    normals: np.ndarray
    tangents: np.ndarray
    wo: np.ndarray
    mask: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return self.mask.shape


# --------------------------------------------------------------------------- cameras
@dataclass(frozen=True, eq=False)
class Camera:
    """An orthographic or perspective pinhole camera.

    Orthographic: the image plane spans ``extent`` world units across its larger side, rays are
    parallel along the camera's −z. Perspective: ``fov`` (radians) across the larger side.
    ``rotation`` is camera-to-world (columns: the camera's x, y, z axes in the world);
    ``position`` its centre.
    """

    kind: Literal["orthographic", "perspective"] = "orthographic"
    position: Any = (10.0, 0.0, 0.0)
    rotation: Any = dataclasses.field(default_factory=lambda: FRONT.copy())
    extent: float = 2.0
    fov: float = math.radians(30)

    def __post_init__(self) -> None:
        if self.kind not in ("orthographic", "perspective"):
            raise ValueError(f"kind must be 'orthographic' or 'perspective'; got {self.kind!r}")
        if self.extent <= 0:
            raise ValueError(f"extent must be > 0; got {self.extent}")
        if not 0 < self.fov < math.pi:
            raise ValueError(f"fov must be in (0, π) radians; got {self.fov}")

    @classmethod
    def look_at(
        cls, position: Any, target: Any = (0, 0, 0), up: Any = (0, 0, 1), **kwargs: Any
    ) -> Camera:
        """A camera at ``position`` looking at ``target`` with ``up`` towards the image's top.

        Examples
        --------
        Looking down from above, with +y to the image's top: the camera's axes are the world's:

        >>> camera = Camera.look_at((0.0, 0.0, 5.0), up=(0.0, 1.0, 0.0))
        >>> camera.rotation.tolist()
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        """
        position, target, up = (np.asarray(v, dtype=float) for v in (position, target, up))
        z = position - target
        if np.linalg.norm(z) == 0:
            raise ValueError("position and target must differ")
        z /= np.linalg.norm(z)
        x = np.cross(up, z)
        if np.linalg.norm(x) < 1e-9:
            raise ValueError(f"up must not be parallel to the viewing direction; got {up}")
        x /= np.linalg.norm(x)
        return cls(position=position, rotation=np.stack([x, np.cross(z, x), z], axis=1), **kwargs)

    def rays(
        self, height: int, width: int, rows: slice | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Ray origins and unit directions through pixel centres, each ``(H, W, 3)`` (or
        only the image's ``rows``)."""
        if height < 1 or width < 1:
            raise ValueError(f"resolution must be positive; got {height}×{width}")
        scale = 1.0 / max(height, width)
        xs = ((np.arange(width) + 0.5) * 2 - width) * scale
        ys = (height - (np.arange(height)[rows or slice(None)] + 0.5) * 2) * scale
        x, y = np.meshgrid(xs, ys)
        rot = np.asarray(self.rotation, dtype=float)
        pos = np.asarray(self.position, dtype=float)
        if self.kind == "orthographic":
            half = self.extent / 2
            local = np.stack([x * half, y * half, np.zeros_like(x)], axis=-1)
            origins = pos + local @ rot.T
            directions = np.broadcast_to(-rot[:, 2], origins.shape).copy()
        else:
            tan_half = math.tan(self.fov / 2)
            local = np.stack([x * tan_half, y * tan_half, -np.ones_like(x)], axis=-1)
            directions = local @ rot.T
            directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
            origins = np.broadcast_to(pos, directions.shape).copy()
        return origins, directions


# --------------------------------------------------------------------------- shapes
def _tangent_from(normals: np.ndarray, axis: np.ndarray) -> np.ndarray:
    t = np.cross(axis, normals)
    small = norm(t) < 1e-9
    t[small] = np.cross([1.0, 0.0, 0.0], normals[small]) if np.any(small) else t[small]
    return t / np.maximum(norm(t, keepdims=True), 1e-12)


@dataclass(frozen=True, eq=False)
class Sphere:
    """A sphere of ``radius`` at ``center``; tangents follow the lines of latitude (about +z)."""

    center: Any = (0.0, 0.0, 0.0)
    radius: float = 1.0

    def intersect(self, origins: np.ndarray, directions: np.ndarray):
        c = np.asarray(self.center, dtype=float)
        oc = origins - c
        b = dot(oc, directions)
        disc = b * b - (dot(oc, oc) - self.radius**2)
        hit = disc >= 0
        t = -b - np.sqrt(np.where(hit, disc, 0))
        hit &= t > 0
        points = origins + t[..., None] * directions
        normals = (points - c) / self.radius
        return hit, points, normals, _tangent_from(normals, np.array([0.0, 0.0, 1.0]))


@dataclass(frozen=True, eq=False)
class Plane:
    """An infinite plane through ``point`` with ``normal``; tangent along ``tangent``."""

    point: Any = (0.0, 0.0, 0.0)
    normal: Any = (1.0, 0.0, 0.0)
    tangent: Any = (0.0, 1.0, 0.0)

    def intersect(self, origins: np.ndarray, directions: np.ndarray):
        n = np.asarray(self.normal, dtype=float)
        n = n / np.linalg.norm(n)
        denom = directions @ n
        t = np.where(
            np.abs(denom) > 1e-12,
            ((np.asarray(self.point) - origins) @ n) / np.where(denom == 0, 1, denom),
            -1,
        )
        hit = t > 0
        points = origins + t[..., None] * directions
        normals = np.broadcast_to(n, points.shape).copy()
        tangent = np.asarray(self.tangent, dtype=float)
        tangent = tangent - (tangent @ n) * n
        return (
            hit,
            points,
            normals,
            np.broadcast_to(tangent / np.linalg.norm(tangent), points.shape).copy(),
        )


@dataclass(frozen=True, eq=False)
class Cylinder:
    """A cylinder of ``radius`` around the z axis through ``center``, of height ``height``."""

    center: Any = (0.0, 0.0, 0.0)
    radius: float = 0.7
    height: float = 1.8

    def intersect(self, origins: np.ndarray, directions: np.ndarray):
        o = origins - np.asarray(self.center, dtype=float)
        a = directions[..., 0] ** 2 + directions[..., 1] ** 2
        b = o[..., 0] * directions[..., 0] + o[..., 1] * directions[..., 1]
        c = o[..., 0] ** 2 + o[..., 1] ** 2 - self.radius**2
        disc = b * b - a * c
        hit = (disc >= 0) & (a > 1e-12)
        t = (-b - np.sqrt(np.where(hit, disc, 0))) / np.where(a > 1e-12, a, 1)
        z = o[..., 2] + t * directions[..., 2]
        hit &= (t > 0) & (np.abs(z) <= self.height / 2)
        points = origins + t[..., None] * directions
        normals = np.concatenate(
            [o[..., :2] + t[..., None] * directions[..., :2], np.zeros_like(z)[..., None]], axis=-1
        )
        normals /= np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-12)
        return hit, points, normals, _tangent_from(normals, np.array([0.0, 0.0, 1.0]))


def gbuffer(
    shape: Sphere | Plane | Cylinder,
    camera: Camera | None = None,
    resolution: int | tuple[int, int] = 256,
    rows: slice | None = None,
) -> GBuffer:
    """Trace one ray per pixel of ``camera`` (default: orthographic front view) to ``shape``
    (or only the image's ``rows``, a G-buffer of those rows).

    Examples
    --------
    >>> g = gbuffer(Sphere(), resolution=4)
    >>> g.shape, g.mask.astype(int).tolist()
    ((4, 4), [[0, 1, 1, 0], [1, 1, 1, 1], [1, 1, 1, 1], [0, 1, 1, 0]])
    >>> g.normals[1, 1].round(4).tolist(), g.wo[1, 1].tolist()  # the viewer is along +x
    ([0.9354, -0.25, 0.25], [1.0, 0.0, 0.0])
    """
    height, width = (resolution, resolution) if isinstance(resolution, int) else resolution
    camera = camera or Camera()
    origins, directions = camera.rays(height, width, rows)
    hit, points, normals, tangents = shape.intersect(origins, directions)
    # Pixels that miss get a harmless camera-facing frame: they are never shown.
    facing = -directions
    normals = np.where(hit[..., None], normals, facing)
    tangents = np.where(hit[..., None], tangents, facing)
    missed = ~hit  # their tangents made for them alone
    tangents[missed] = _tangent_from(facing[missed], np.array([0.0, 0.0, 1.0]))
    points = np.where(hit[..., None], points, 0.0)
    return GBuffer(points, normals, tangents, facing, hit)


def normal_map_gbuffer(
    normals: Any, mask: Any | None = None, view: Any = (0.0, 0.0, 1.0)
) -> GBuffer:
    """A G-buffer from a normal map ``(H, W, 3)`` (camera frame) and an optional mask.

    The view is orthographic along ``view`` (default +z, towards the camera), the frame in which
    photometric-stereo normals and light directions are given.

    Examples
    --------
    >>> import numpy as np
    >>> normals = np.zeros((2, 3, 3))
    >>> normals[0] = (0.0, 0.0, 2.0)  # the bottom row is empty (zero normals)
    >>> g = normal_map_gbuffer(normals)
    >>> g.mask.tolist(), g.normals[0, 0].tolist()
    ([[True, True, True], [False, False, False]], [0.0, 0.0, 1.0])
    """
    n = np.asarray(to_numpy(normals), dtype=float)
    if n.ndim != 3 or n.shape[2] != 3:
        raise ValueError(f"normals must have shape (H, W, 3); got {n.shape}")
    length = np.linalg.norm(n, axis=-1)
    m = holds_normal(n) if mask is None else np.asarray(to_numpy(mask)).astype(bool)
    if m.shape != n.shape[:2]:
        raise ValueError(f"mask must have shape {n.shape[:2]}; got {m.shape}")
    n = np.where(m[..., None], n / np.maximum(length, 1e-12)[..., None], [0.0, 0.0, 1.0])
    wo = np.broadcast_to(np.asarray(view, dtype=float) / np.linalg.norm(view), n.shape).copy()
    points = np.zeros_like(n)
    return GBuffer(points, n, _tangent_from(n, np.array([0.0, 1.0, 0.0])), wo, m)


def interior_mask(resolution: int, margin: float = 0.03) -> np.ndarray:
    """Pixels whose centre lies inside the orthographic unit sphere by ``margin`` (radii).

    Examples
    --------
    >>> interior_mask(4).astype(int).tolist()
    [[0, 1, 1, 0], [1, 1, 1, 1], [1, 1, 1, 1], [0, 1, 1, 0]]
    """
    c = ((np.arange(resolution) + 0.5) * 2 - resolution) / resolution
    x, y = np.meshgrid(c, c)
    return x * x + y * y < (1 - margin) ** 2


__all__ = [
    "FRONT",
    "Camera",
    "Cylinder",
    "GBuffer",
    "Plane",
    "Sphere",
    "gbuffer",
    "interior_mask",
    "normal_map_gbuffer",
]
