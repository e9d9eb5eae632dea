"""Rendering what a surface looks like: shapes, cameras, direct lighting by the reflection equation.

A render is two steps. A *G-buffer* holds, per pixel, the surface point, normal, tangent, the
direction towards the viewer and a coverage mask; it comes from a shape seen by a camera
(:class:`Sphere`, :class:`Plane`, :class:`Cylinder` with :class:`Camera`) or straight from a
normal map and mask (photometric-stereo data, SVBRDF textures). Then :func:`shade` evaluates the
reflection equation (:func:`brdfkit.integrate.reflected_radiance`) at every covered pixel, in
tiles of rows so that memory stays bounded, with per-pixel BRDF parameters sliced per tile.
Direct lighting only: no shadows from other geometry and no interreflection.

World frame: +z is up (the environment maps' pole). The default camera looks horizontally along
−x from +x with the image's right along +y and up along +z (the camera frame of
:meth:`brdfkit.lights.EnvironmentMap.from_mirror_ball`).

References
----------
.. [1] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., ch. 5–6.
.. [2] CMU 16-385 Lecture 14: "evaluating the reflectance equation renders images".
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from brdfkit._array import to_numpy
from brdfkit.brdf.base import BRDF, Scaled, Sum
from brdfkit.integrate import FLOOR_DIRECTIONS, Estimate, reflected_radiance
from brdfkit.lights import Light
from brdfkit.sampling import query_seeds

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
        """A camera at ``position`` looking at ``target`` with ``up`` towards the image's top."""
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
    small = np.linalg.norm(t, axis=-1) < 1e-9
    t[small] = np.cross([1.0, 0.0, 0.0], normals[small]) if np.any(small) else t[small]
    return t / np.maximum(np.linalg.norm(t, axis=-1, keepdims=True), 1e-12)


@dataclass(frozen=True, eq=False)
class Sphere:
    """A sphere of ``radius`` at ``center``; tangents follow the lines of latitude (about +z)."""

    center: Any = (0.0, 0.0, 0.0)
    radius: float = 1.0

    def intersect(self, origins: np.ndarray, directions: np.ndarray):
        c = np.asarray(self.center, dtype=float)
        oc = origins - c
        b = np.sum(oc * directions, axis=-1)
        disc = b * b - (np.sum(oc * oc, axis=-1) - self.radius**2)
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
    (or only the image's ``rows``, a G-buffer of those rows)."""
    height, width = (resolution, resolution) if isinstance(resolution, int) else resolution
    camera = camera or Camera()
    origins, directions = camera.rays(height, width, rows)
    hit, points, normals, tangents = shape.intersect(origins, directions)
    # Pixels that miss get a harmless camera-facing frame: they are never shown.
    facing = -directions
    normals = np.where(hit[..., None], normals, facing)
    tangents = np.where(hit[..., None], tangents, _tangent_from(facing, np.array([0.0, 0.0, 1.0])))
    points = np.where(hit[..., None], points, 0.0)
    return GBuffer(points, normals, tangents, facing, hit)


def normal_map_gbuffer(
    normals: Any, mask: Any | None = None, view: Any = (0.0, 0.0, 1.0)
) -> GBuffer:
    """A G-buffer from a normal map ``(H, W, 3)`` (camera frame) and an optional mask.

    The view is orthographic along ``view`` (default +z, towards the camera), the frame in which
    photometric-stereo normals and light directions are given.
    """
    n = np.asarray(to_numpy(normals), dtype=float)
    if n.ndim != 3 or n.shape[2] != 3:
        raise ValueError(f"normals must have shape (H, W, 3); got {n.shape}")
    length = np.linalg.norm(n, axis=-1)
    m = length > 0.5 if mask is None else np.asarray(to_numpy(mask)).astype(bool)
    if m.shape != n.shape[:2]:
        raise ValueError(f"mask must have shape {n.shape[:2]}; got {m.shape}")
    n = np.where(m[..., None], n / np.maximum(length, 1e-12)[..., None], [0.0, 0.0, 1.0])
    wo = np.broadcast_to(np.asarray(view, dtype=float) / np.linalg.norm(view), n.shape).copy()
    points = np.zeros_like(n)
    return GBuffer(points, n, _tangent_from(n, np.array([0.0, 1.0, 0.0])), wo, m)


# --------------------------------------------------------------------------- shading
def slice_brdf(brdf: BRDF, image_shape: tuple[int, int], rows: slice) -> BRDF:
    """``brdf`` with each per-pixel parameter (leading axes ``image_shape``) cut to ``rows``."""
    if isinstance(brdf, Sum):
        return Sum(tuple(slice_brdf(lobe, image_shape, rows) for lobe in brdf.lobes))
    if isinstance(brdf, Scaled):
        return Scaled(
            _slice_value(brdf.k, image_shape, rows), slice_brdf(brdf.inner, image_shape, rows)
        )
    changes = {}
    for field in dataclasses.fields(brdf):
        value = getattr(brdf, field.name)
        sliced = _slice_value(value, image_shape, rows)
        if sliced is not value:
            changes[field.name] = sliced
    return dataclasses.replace(brdf, **changes) if changes else brdf


def _slice_value(value: Any, image_shape: tuple[int, int], rows: slice) -> Any:
    shape = getattr(value, "shape", None)
    if shape is not None and len(shape) >= 3 and tuple(shape[:2]) == tuple(image_shape):
        return value[rows]
    return value


def shade(
    g: GBuffer,
    brdf: BRDF,
    lights: Light | Sequence[Light],
    *,
    method: str = "auto",
    samples: int = 64,
    seed: int = 0,
    sequence: str = "sobol",
    max_evaluations: int = 500_000,
    background: float = 0.0,
    progress: Callable[[int, int], None] | None = None,
    compiled: bool | str = "auto",
) -> np.ndarray:
    """Linear radiance image ``(H, W, C)`` of the G-buffer under ``lights``.

    Pixels are shaded in tiles of rows holding at most ``max_evaluations`` BRDF evaluations
    (pixels × samples, and the control variate's :data:`~brdfkit.integrate.FLOOR_DIRECTIONS`),
    which bounds memory (measured ~400 B per evaluation on the NumPy path: ~200 MB per tile;
    the compiled path keeps a few buffers per block). By default each pixel has its own
    scrambled Sobol' sequence, keyed by its index in the image, so the tiles do not change
    the image (``sequence``, see :func:`~brdfkit.integrate.reflected_radiance`); with
    ``method="auto"`` Lambertian lobes under an environment map come noise-free from the
    map's irradiance (:func:`~brdfkit.integrate.split_diffuse`) and only the other lobes are
    sampled.
    ``progress(done, total)`` is called after each tile.

    ``compiled`` chooses the compiled path: each tile shaded by the numba kernel of
    :class:`brdfkit.render_kernel.EnvironmentShader` where it applies (one
    :class:`~brdfkit.lights.EnvironmentMap` plus any delta lights, ``method`` ``"auto"`` or
    ``"mis"``, a BRDF :mod:`brdfkit.accel` compiles: see
    :func:`~brdfkit.render_kernel.compiled_shader`), NumPy elsewhere. ``"auto"`` (default):
    float32 kernels when this model's are built already or the render has at least
    :data:`~brdfkit.render_kernel.AUTO_COMPILE_WORK` pixel-samples (building them costs
    seconds); ``True``: float32 kernels wherever they apply; ``"float64"``: float64 kernels
    (the image then equals the NumPy one to rounding); ``False``: NumPy. Same tiles, seeds and
    uniforms on both paths (float32 kernels: equal to float32 precision).
    """
    return _shade(
        g, brdf, lights, method=method, samples=samples, seed=seed, sequence=sequence,
        max_evaluations=max_evaluations, background=background, progress=progress,
        compiled=compiled, stderr=False,
    )[0]  # fmt: skip


def _shade(
    g: GBuffer,
    brdf: BRDF,
    lights: Light | Sequence[Light],
    *,
    method: str,
    samples: int,
    seed: int,
    sequence: str,
    max_evaluations: int,
    background: float,
    progress: Callable[[int, int], None] | None,
    compiled: bool | str,
    stderr: bool = True,
    work: int | None = None,
    first_row: int = 0,
    first_sample: int = 0,
    cache: dict[Any, Any] | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`shade`'s image and its per-pixel standard error (0 outside the mask; ``None``
    unless ``stderr``); ``work`` (pixel-samples) decides ``compiled="auto"`` when given.

    The G-buffer is the image's rows from ``first_row`` on (:func:`render_sphere`'s bands).
    With ``sequence="sobol"`` each pixel's seed is a hash of ``seed`` and its index in the
    image (:func:`~brdfkit.sampling.query_seeds`), whatever the tiles, and its samples are
    points ``first_sample`` … of its sequence; with ``"random"`` a tile's seed is ``seed``
    plus its first row in the image. ``cache`` (a dict kept across calls on the same
    G-buffer, BRDF and lights: :func:`progressive`'s passes) keeps the compiled plan and each
    tile's sample-independent work (:meth:`~brdfkit.render_kernel.EnvironmentShader.prepare`,
    the delta lights)."""
    want_stderr = stderr
    height, width = g.shape
    light_list = [lights] if isinstance(lights, Light) else list(lights)
    channels = max([brdf.channels] + [lt.channels for lt in light_list])
    image = np.full((height, width, channels), background, dtype=np.float64)
    stderr = np.zeros((height, width, channels)) if want_stderr else None
    if work is None:
        work = np.count_nonzero(g.mask) * samples
    if cache is not None and ("plan", compiled) in cache:
        plan = cache["plan", compiled]
    else:
        plan = _compiled_plan(brdf, light_list, method, compiled, work)
        if cache is not None:
            cache["plan", compiled] = plan
    rows_per_tile = _rows_per_tile(samples, method, width, max_evaluations)
    if plan is not None and sequence == "sobol":
        # the kernel's memory does not grow with the samples, nor do a pixel's samples
        # depend on the tiles: the same tiles whatever the samples (cache keys of passes)
        rows_per_tile = _rows_per_tile(COMPILED_TILE_SAMPLES, method, width, max_evaluations)
    for r0 in range(0, height, rows_per_tile):
        rows = slice(r0, min(r0 + rows_per_tile, height))
        m = g.mask[rows]
        if np.any(m):
            if sequence == "sobol":
                first = (first_row + rows.start) * width
                count = (rows.stop - rows.start) * width
                tile_seed: Any = query_seeds(seed, count, first).reshape(-1, width)
            else:
                tile_seed = seed + first_row + r0
            if plan is not None:
                shader, others = plan
                key = ("tile", compiled, first_row + rows.start, first_row + rows.stop)
                if cache is not None and key in cache:
                    prepared, exact = cache[key]
                else:
                    prepared = shader.prepare(
                        g.wo[rows], g.normals[rows], g.points[rows], g.tangents[rows], mask=m
                    )
                    exact = None
                    if others:  # delta lights: exact, no samples
                        exact = reflected_radiance(
                            slice_brdf(brdf, (height, width), rows), others, g.wo[rows],
                            normal=g.normals[rows], point=g.points[rows],
                            tangent=g.tangents[rows],
                        ).value  # fmt: skip
                    if cache is not None:
                        cache[key] = prepared, exact
                estimate = shader.shade(
                    prepared,
                    samples=samples,
                    seed=tile_seed,
                    sequence=sequence,
                    first_sample=first_sample,
                )
                if exact is not None:
                    estimate = Estimate(estimate.value + to_numpy(exact), estimate.stderr)
            else:
                estimate = reflected_radiance(
                    slice_brdf(brdf, (height, width), rows),
                    light_list,
                    g.wo[rows],
                    normal=g.normals[rows],
                    point=g.points[rows],
                    tangent=g.tangents[rows],
                    method=method,
                    samples=samples,
                    seed=tile_seed,
                    sequence=sequence,
                    first_sample=first_sample,
                )
            value = to_numpy(estimate.value)
            image[rows] = np.where(m[..., None], value, background)
            if stderr is not None:
                stderr[rows] = np.where(m[..., None], to_numpy(estimate.stderr), 0.0)
        if progress is not None:
            progress(rows.stop, height)
    return image, stderr


def _rows_per_tile(samples: int, method: str, width: int, max_evaluations: int) -> int:
    """Rows of a tile of at most ``max_evaluations`` BRDF evaluations (at least one row)."""
    per_pixel = max(samples, 1) * (2 if method in ("auto", "mis") else 1)
    if method == "auto":
        per_pixel += FLOOR_DIRECTIONS
    return max(1, max_evaluations // (per_pixel * width))


COMPILED_TILE_SAMPLES = 16
"""Samples per pixel that size the compiled path's tiles with Sobol' sequences (its memory
does not grow with the samples): tiles of a few tens of ms at most, so that a cancel or a
progress report comes soon."""

COMPILED = (True, False, "auto", "float64")
"""Values of :func:`shade`'s ``compiled``."""


def _compiled_plan(
    brdf: BRDF, lights: list[Light], method: str, compiled: bool | str, work: int
) -> tuple[Any, list[Light]] | None:
    """The compiled shader and the delta lights left to NumPy, or ``None`` for the NumPy path."""
    if not any(compiled is c or (isinstance(compiled, str) and compiled == c) for c in COMPILED):
        raise ValueError(
            f"compiled must be one of True, False, 'auto', 'float64'; got {compiled!r}"
        )
    if compiled is False:
        return None
    from brdfkit.render_kernel import AUTO_COMPILE_WORK, compiled_shader

    dtype = np.float64 if compiled == "float64" else np.float32
    build = compiled != "auto" or work >= AUTO_COMPILE_WORK
    return compiled_shader(brdf, lights, method=method, dtype=dtype, build=build)


def render_sphere(
    brdf: BRDF,
    lights: Light | Sequence[Light],
    resolution: int = 256,
    camera: Camera | None = None,
    **kwargs: Any,
) -> np.ndarray:
    """A unit sphere seen by ``camera`` (default orthographic front view), shaded by ``brdf``.

    The G-buffer is traced band by band of :data:`BAND_PIXELS` pixels and each band shaded
    in turn (the same tiles and seeds as :func:`shade` on the whole G-buffer, so the same
    image), so that memory holds the image and one band, not a whole-image G-buffer. An
    image of one band keeps its sample-independent work for the next call on the same
    inputs (:func:`_recent_work`): rendering it again, with other seeds or samples, skips it.
    """
    height, width = (resolution, resolution) if isinstance(resolution, int) else resolution
    options = {**_SHADE_KEYWORDS, **kwargs}
    rows_per_tile = _rows_per_tile(
        options["samples"], options["method"], width, options["max_evaluations"]
    )
    band = rows_per_tile * max(1, BAND_PIXELS // (rows_per_tile * width))
    if band >= height:
        g, cache = _recent_work(brdf, lights, camera, (height, width), options)
        return _shade(g, brdf, lights, **options, stderr=False, cache=cache)[0]
    progress, seed = options.pop("progress"), options.pop("seed")
    # the compiled path's choice made once, for the whole image's work
    work = int(math.pi / 4 * height * width) * options["samples"]
    image = None
    for r0 in range(0, height, band):
        rows = slice(r0, min(r0 + band, height))
        g = gbuffer(Sphere(), camera, (height, width), rows)
        part = _shade(
            g, brdf, lights, **options, seed=seed, progress=None, stderr=False, work=work,
            first_row=r0,
        )[0]  # fmt: skip
        if image is None:
            image = np.empty((height, width, part.shape[-1]))
        image[rows] = part
        if progress is not None:
            progress(rows.stop, height)
    return image


BAND_PIXELS = 1 << 18
"""Pixels per band of :func:`render_sphere` (a 512² image in one band: ~60 MB of G-buffer)."""


_RECENT: dict[str, tuple[tuple[Any, ...], tuple[Any, ...], GBuffer, dict[Any, Any]]] = {}
"""The most recent :func:`_recent_work` entry (one: a 512² image's holds ~100 MB)."""


def _recent_work(
    brdf: BRDF,
    lights: Light | Sequence[Light],
    camera: Camera | None,
    shape: tuple[int, int],
    options: dict[str, Any],
) -> tuple[GBuffer, dict[Any, Any]]:
    """The unit sphere's G-buffer and :func:`_shade`'s ``cache`` of its sample-independent
    work (each tile's :meth:`~brdfkit.render_kernel.EnvironmentShader.prepare` and delta
    lights), kept for the most recent inputs: the same model, light and camera objects
    (immutable, held by the entry so that their ids stay theirs), shape, ``method`` and
    tiling options. Per call the compiled plan is decided afresh (kernels may have been
    built since); the tiles' entries carry the plan's dtype (``compiled``) in their keys.
    The per-render set-up it saves (G-buffer, frames, the control variate's floor, the
    irradiance) was measured at ~45 ms of a 256² render's 140 ms (gold, 16 spp)."""
    light_list = (lights,) if isinstance(lights, Light) else tuple(lights)
    key = (
        id(brdf), tuple(map(id, light_list)), id(camera), shape, options["method"],
        options["sequence"], options["max_evaluations"],
    )  # fmt: skip
    entry = _RECENT.get("sphere")
    if entry is None or entry[0] != key:
        entry = (key, (brdf, light_list, camera), gbuffer(Sphere(), camera, shape), {})
        _RECENT["sphere"] = entry
    cache = entry[3]
    cache.pop(("plan", options["compiled"]), None)
    return entry[2], cache


# --------------------------------------------------------------------------- progressive
@dataclass(frozen=True, eq=False)
class Pass:
    """One refinement of :func:`progressive`: the running mean ``image`` ``(H, W, C)``, its
    per-pixel standard error ``stderr`` (same shape: from the samples' spread, conservative
    with Sobol' points), the total samples per pixel so far, the seconds elapsed since
    rendering began and, with Sobol' replicates, ``error`` (same shape): half the difference
    of the two replicates, whose square estimates each pixel's variance without bias."""

    image: np.ndarray
    stderr: np.ndarray
    samples: int
    seconds: float
    error: np.ndarray | None = None


class _Cancelled(Exception):
    """Raised between tiles when :func:`progressive`'s ``cancel`` is set."""


def progressive(
    g: GBuffer,
    brdf: BRDF,
    lights: Light | Sequence[Light],
    *,
    max_samples: int = 1024,
    first_samples: int = 1,
    seed: int = 0,
    cancel: threading.Event | None = None,
    **shade_kwargs: Any,
) -> Iterator[Pass]:
    r"""Render the G-buffer in passes of doubling sample counts, yielding the running mean.

    The first pass shades ``first_samples`` samples per pixel (an image in a fraction of a
    full render's time); each later pass shades as many samples as all passes before it, so
    the total doubles until ``max_samples`` (with Sobol' replicates, from
    :data:`HALF_STEPS_FROM` samples of each on, half as many: totals 64, 96, 128, 192, …,
    a finer choice of when to stop). Each pass is :func:`shade` work
    (``shade_kwargs``: ``method``, ``sequence``, ``compiled``, …). With ``compiled="auto"``
    (default) the compiled kernels are built on a background thread while the first passes
    run on NumPy, and used from the next pass once they are ready. Setting ``cancel`` stops
    rendering between tiles: the pass under way is dropped and the iterator ends.

    With ``sequence="sobol"`` (default) a pixel's samples are two independent replicates,
    each one scrambled Sobol' sequence per pixel that every pass continues
    (``first_sample``: after N samples of each, the next N), so that after each pass each
    replicate holds a whole scrambled net, not a union of independently scrambled pieces
    (measured on a gold sphere: 1.26–1.41× lower RMS error at 16–128 spp). The first pass
    has ``first_samples`` samples in all (half from each; at least one each), and
    ``max_samples`` counts both. :attr:`Pass.error` is :math:`|\bar x_A - \bar x_B|/2`:
    its square is an unbiased estimate of the image's variance
    :math:`\operatorname{Var}((\bar x_A + \bar x_B)/2)` per pixel (noisy per pixel, exact
    on average: Owen's independent replicates of randomized quasi-Monte Carlo). With
    ``"random"`` passes are independent draws. Either way all samples are pooled by the
    exact mean and sum of squared deviations (Chan et al.), and ``stderr`` is
    :math:`\sqrt{M_2}/N` over all N samples (0 after a single sample: no estimate yet; a
    conservative over-estimate with Sobol' points).

    References
    ----------
    .. [1] T. F. Chan, G. H. Golub, R. J. LeVeque, "Updating formulae and a pairwise
           algorithm for computing sample variances", COMPSTAT 1982.
    .. [2] A. B. Owen, *Monte Carlo theory, methods and examples*, 2013, §17.2 (independent
           replicates of randomized quasi-Monte Carlo estimate its variance).
    """
    if first_samples < 1:
        raise ValueError(f"first_samples must be >= 1; got {first_samples}")
    if max_samples < first_samples:
        raise ValueError(
            f"max_samples must be >= first_samples ({first_samples}); got {max_samples}"
        )
    unknown = set(shade_kwargs) - _SHADE_OPTIONS
    if unknown:
        raise TypeError(f"progressive() got unexpected keyword arguments {sorted(unknown)}")
    user_progress = shade_kwargs.pop("progress", None)

    def between_tiles(done: int, total: int) -> None:
        if cancel is not None and cancel.is_set():
            raise _Cancelled
        if user_progress is not None:
            user_progress(done, total)

    kwargs = {**_SHADE_DEFAULTS, **shade_kwargs}
    builder = _background_build(brdf, lights, kwargs) if kwargs["compiled"] == "auto" else None

    cache: dict[Any, Any] = {}  # the plan and each tile's sample-independent work

    def shade_pass(samples: int, pass_seed: int, first_sample: int) -> tuple[Any, Any]:
        nonlocal builder
        if builder is not None and not builder.is_alive():
            # the kernels are ready (or do not apply: NumPy from now on)
            kwargs["compiled"], builder = builder.built, None  # type: ignore[attr-defined]
        return _shade(
            g, brdf, lights, **kwargs, samples=samples, seed=pass_seed,
            progress=between_tiles, first_sample=first_sample, cache=cache,
        )  # fmt: skip

    start = time.perf_counter()
    passes = _replicate_passes if kwargs["sequence"] == "sobol" else _pooled_passes
    try:
        for image, stderr, count, error in passes(
            shade_pass, seed, first_samples, max_samples, cancel
        ):
            yield Pass(image, stderr, count, time.perf_counter() - start, error)
    except _Cancelled:
        return


def _pool(
    pooled: tuple[np.ndarray, np.ndarray, int] | None, value: np.ndarray, stderr: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray, int]:
    """(mean, M2, count) of the samples pooled so far and the ``n`` of a new shade (its mean
    and standard error), by Chan et al.'s update."""
    pass_m2 = stderr * stderr * (n * n)
    if pooled is None:
        return value, pass_m2, n
    mean, m2, count = pooled
    delta = value - mean
    total = count + n
    return mean + delta * (n / total), m2 + pass_m2 + delta * delta * (count * n / total), total


def _pooled_passes(
    shade_pass: Callable[..., tuple[Any, Any]],
    seed: int,
    first_samples: int,
    max_samples: int,
    cancel: threading.Event | None,
) -> Iterator[tuple[np.ndarray, np.ndarray, int, None]]:
    """:func:`progressive`'s passes of independent draws, pooled (``sequence="random"``)."""
    pooled, count, index = None, 0, 0
    while count < max_samples:
        if cancel is not None and cancel.is_set():
            return
        n = min(first_samples if count == 0 else count, max_samples - count)
        value, stderr = shade_pass(n, seed if index == 0 else _pass_seed(seed, index), 0)
        pooled = _pool(pooled, value, stderr, n)
        mean, m2, count = pooled
        index += 1
        yield mean.copy(), np.sqrt(m2) / count, count, None


HALF_STEPS_FROM = 32
"""Samples of each Sobol' replicate from which :func:`progressive`'s passes grow by half
(totals 64, 96, 128, 192, 256, …: each pass still an aligned block of the sequences)."""


def _replicate_passes(
    shade_pass: Callable[..., tuple[Any, Any]],
    seed: int,
    first_samples: int,
    max_samples: int,
    cancel: threading.Event | None,
) -> Iterator[tuple[np.ndarray, np.ndarray, int, np.ndarray]]:
    """:func:`progressive`'s passes continuing two independent replicates' sequences."""
    seeds = (seed, _pass_seed(seed, 1))
    means: list[Any] = [None, None]  # each replicate's mean
    pooled = None  # both replicates' samples, pooled
    count = 0  # samples of each replicate so far
    while 2 * count < max_samples:
        if cancel is not None and cancel.is_set():
            return
        if count == 0:
            n = max(1, first_samples // 2)
        elif count < HALF_STEPS_FROM:
            n = count
        else:  # half the largest power of two in count: an aligned block of the sequence
            n = 1 << (count.bit_length() - 2)
        n = min(n, -(-(max_samples - 2 * count) // 2))
        for r, replicate_seed in enumerate(seeds):
            value, stderr = shade_pass(n, replicate_seed, count)
            previous = means[r]
            means[r] = (
                value if previous is None else previous + (value - previous) * (n / (count + n))
            )
            pooled = _pool(pooled, value, stderr, n)
        count += n
        a, b = means
        yield (a + b) / 2, np.sqrt(pooled[1]) / (2 * count), 2 * count, np.abs(a - b) / 2


def _background_build(
    brdf: BRDF, lights: Light | Sequence[Light], kwargs: dict[str, Any]
) -> threading.Thread | None:
    """A thread building the compiled shader while the first passes run on NumPy, or ``None``
    where it is built already (``kwargs["compiled"]`` then becomes ``True``)."""
    from brdfkit.render_kernel import compiled_shader

    light_list = [lights] if isinstance(lights, Light) else list(lights)
    method = kwargs["method"]
    if compiled_shader(brdf, light_list, method=method, build=False) is not None:
        kwargs["compiled"] = True
        return None

    def build() -> None:
        plan = compiled_shader(brdf, light_list, method=method)
        if plan is not None:
            plan[0].build()
            thread.built = True  # type: ignore[attr-defined]

    thread = threading.Thread(target=build, name="brdfkit-compile", daemon=True)
    thread.built = False  # type: ignore[attr-defined]
    thread.start()
    return thread


def progressive_sphere(
    brdf: BRDF,
    lights: Light | Sequence[Light],
    resolution: int = 256,
    camera: Camera | None = None,
    **kwargs: Any,
) -> Iterator[Pass]:
    """:func:`progressive` on a unit sphere seen by ``camera`` (as :func:`render_sphere`)."""
    return progressive(gbuffer(Sphere(), camera, resolution), brdf, lights, **kwargs)


def _pass_seed(seed: int, index: int) -> int:
    """An independent seed per pass (tiles add their first row to it)."""
    return int(np.random.SeedSequence([seed, index]).generate_state(1, np.uint64)[0] >> 2)


_SHADE_KEYWORDS: dict[str, Any] = {
    name: parameter.default
    for name, parameter in inspect.signature(shade).parameters.items()
    if parameter.kind is inspect.Parameter.KEYWORD_ONLY
}
_SHADE_DEFAULTS = {
    name: value
    for name, value in _SHADE_KEYWORDS.items()
    if name not in ("samples", "seed", "progress")
}
_SHADE_OPTIONS = set(_SHADE_DEFAULTS) | {"progress"}


__all__ = [
    "FRONT",
    "Camera",
    "Cylinder",
    "GBuffer",
    "Pass",
    "Plane",
    "Sphere",
    "gbuffer",
    "normal_map_gbuffer",
    "progressive",
    "progressive_sphere",
    "render_sphere",
    "shade",
    "slice_brdf",
]
