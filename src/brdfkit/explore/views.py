"""What each view of the explorer shows, computed from the BRDF's own ``eval`` and the renderer.

Every view is linked to one incident direction ``wi`` = (θi, φi) in the local frame (z the
normal). The lit sphere is :func:`brdfkit.render.shade` of a unit sphere under a
:class:`~brdfkit.light.DirectionalLight` whose world direction is ``wi`` carried by
:data:`LOCAL_TO_WORLD`: the frame at the sphere's centre pixel, whose normal faces the default
camera, so that the sphere's centre sees the BRDF at exactly (θi, φi) with ``wo`` = the normal.

The lit object is a mesh (:mod:`brdfkit.render.bundled_meshes` or a file) under the environment
map in Mitsuba 3's frame, with shadows (:func:`brdfkit.render.mesh.render_mesh`'s G-buffer and
visibility), refined in progressive passes (:func:`lit_passes`), seen by an orbiting camera
(:func:`orbit_camera`: azimuth and elevation about the object's centre, +y up).

References
----------
.. [1] S. Rusinkiewicz, "A new change of variables for efficient BRDF representation", EGWR 1998
       (the θh, θd, φd coordinates).
.. [2] B. Burley, "Physically-based shading at Disney", SIGGRAPH 2012 course notes (BRDF
       Explorer's views: θh/θd/θv curves, the θh×θd slice, the lit sphere).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from brdfkit import compiled
from brdfkit._array import to_numpy
from brdfkit.brdf.base import BRDF
from brdfkit.geometry import from_half_diff, spherical_to_cartesian
from brdfkit.light.analytic import DirectionalLight
from brdfkit.light.environment import EnvironmentMap
from brdfkit.measured import table_kernels
from brdfkit.render.mesh import MeshGBuffer, MeshScene
from brdfkit.render.mitsuba_frame import look_at_camera, mitsuba_oriented
from brdfkit.render.passes import Pass, progressive
from brdfkit.render.reflection_equation import (
    delta_radiance,
    diffuse_envmap_radiance,
    local_frames,
    split_diffuse,
)
from brdfkit.render.scene import Camera, GBuffer, Sphere, gbuffer

LOCAL_TO_WORLD = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
"""Columns: the local x, y, z axes in the world of :mod:`brdfkit.render` (local z, the normal at
the sphere's centre, is +x towards the default camera; local x is the image's right, +y)."""

CURVE_SAMPLES = 181
"""Points on each curve (θv over [−90°, 90°] in 1° steps; θh and θd over [0°, 90°])."""

SLICE_RESOLUTION = 90
"""Cells per side of the θh × θd slice (1° each)."""

LOBE_GRID = (24, 48)
"""(θo, φo) nodes of the 3D lobe mesh."""

ENV_MAX_SAMPLES = 1024
"""Samples per pixel at which the environment-lit sphere stops refining."""

ALBEDO_ANGLES = 16
ALBEDO_SAMPLES = 1024

LIT_RESOLUTION = 128
"""Pixels per side of the lit-object image."""

LIT_MAX_SAMPLES = 64
"""Samples per pixel at which the lit object stops refining."""

LIT_FOV = 40.0
"""The orbiting camera's horizontal field of view, degrees."""

ELEVATION_RANGE = (-30.0, 89.0)
"""The orbiting camera's elevation above the horizontal plane, degrees (at 90 the look-at's up
would be parallel to the view)."""

DEFAULT_MESH = "bundled:shaderball"
"""The mesh the lit-object view opens with."""

PREVIEW_MIN = 64
"""The least resolution of a preview's sphere (:attr:`ViewState.sphere_resolution`)."""


@dataclass(frozen=True)
class ViewState:
    """The shared settings of all views (angles in degrees, as the sliders show them).

    Examples
    --------
    >>> ViewState(theta_i=45.0).wi().round(4).tolist()
    [0.7071, 0.0, 0.7071]
    """

    theta_i: float = 45.0
    phi_i: float = 0.0
    theta_h: float = 20.0
    theta_d: float = 30.0
    phi_d: float = 90.0
    resolution: int = 256
    irradiance: float = math.pi
    envmap: bool = False
    lit: bool = False
    mesh: str = DEFAULT_MESH
    azimuth: float = 30.0
    elevation: float = 25.0
    preview: bool = False

    @property
    def sphere_resolution(self) -> int:
        """Pixels per side of the lit sphere: :attr:`resolution`, or half of it (at least
        :data:`PREVIEW_MIN`) for a ``preview``, the state of a slider being dragged (the page
        asks for the full image once it rests).

        Examples
        --------
        >>> ViewState(resolution=256, preview=True).sphere_resolution
        128
        """
        return max(self.resolution // 2, PREVIEW_MIN) if self.preview else self.resolution

    def wi(self) -> np.ndarray:
        """The incident direction (local), ``(3,)``."""
        return spherical_to_cartesian(np.radians(self.theta_i), np.radians(self.phi_i))

    def light(self) -> DirectionalLight:
        """The sphere's light: from :meth:`wi` in the world, delivering :attr:`irradiance`."""
        return DirectionalLight(direction=LOCAL_TO_WORLD @ self.wi(), irradiance=self.irradiance)


@lru_cache(maxsize=4)
def sphere_gbuffer(resolution: int) -> GBuffer:
    """The unit sphere's G-buffer in the default camera (cached: only the light moves)."""
    return gbuffer(Sphere(), None, resolution)


@dataclass(frozen=True, eq=False)
class Disk:
    """The sphere's visible pixels, flattened, with what :func:`~brdfkit.render.shade` derives
    from their G-buffer before it evaluates a light
    (:func:`brdfkit.render.reflection_equation.local_frames`): the
    points, the local frames (normal, tangent) and ``wo`` in them, each ``(N, 3)``."""

    mask: np.ndarray
    point: np.ndarray
    frame: tuple[np.ndarray, np.ndarray, np.ndarray]
    wo_local: np.ndarray


@lru_cache(maxsize=4)
def sphere_disk(resolution: int) -> Disk:
    """The :class:`Disk` of :func:`sphere_gbuffer` (cached: only the light moves)."""
    g = sphere_gbuffer(resolution)
    m = g.mask
    _, point, frame, wo_local, _ = local_frames(g.wo[m], g.normals[m], g.points[m], g.tangents[m])
    return Disk(m, point, frame, wo_local)


def sphere(brdf: BRDF, state: ViewState) -> np.ndarray:
    """Linear radiance ``(R, R, C)`` of the lit sphere, ``render_sphere(brdf, state.light(),
    state.sphere_resolution)``: :func:`sphere_values` on the visible pixels, 0 on the
    background.

    Examples
    --------
    A Lambertian sphere lit from the viewer with irradiance π: ρ cos θ at most:

    >>> from brdfkit.brdf import parse
    >>> image = sphere(parse("lambertian(rho=0.5)"), ViewState(theta_i=0.0, resolution=8))
    >>> image.shape, float(image.max().round(4))
    ((8, 8, 1), 0.4921)
    """
    mask = sphere_disk(state.sphere_resolution).mask
    value = sphere_values(brdf, state)
    image = np.zeros((*mask.shape, value.shape[-1]))
    image[mask] = value
    return image


def sphere_values(brdf: BRDF, state: ViewState) -> np.ndarray:
    """Linear radiance ``(N, C)`` of the lit sphere's N visible pixels, in the row order of
    ``sphere_disk(state.sphere_resolution).mask``: the delta-light term of the reflection
    equation (:func:`brdfkit.render.reflected_radiance`) that :func:`~brdfkit.render.shade`
    evaluates, in one batch, from geometry computed once per resolution, with f from
    :func:`fast_eval` (the compiled float64 kernel once it is built: equal to NumPy's to
    rounding, a few times faster on every core).

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> state = ViewState(theta_i=0.0, resolution=8)
    >>> values = sphere_values(parse("lambertian(rho=0.5)"), state)
    >>> values.shape == (int(sphere_disk(8).mask.sum()), 1)
    True
    """
    disk = sphere_disk(state.sphere_resolution)
    model = fast_eval(brdf)
    return to_numpy(delta_radiance(model, state.light(), disk.point, disk.frame, disk.wo_local))


def fast_eval(brdf: BRDF) -> Any:
    """An object whose ``eval(wi, wo)`` equals ``brdf.eval`` in float64: the compiled kernel
    (:func:`brdfkit.compiled.compile`, or :func:`brdfkit.measured.table_kernels` for a
    table) where it is built in this process for ``brdf``'s structure (a model that differs
    in parameter values only shares it, so a parameter's slider stays on it), else ``brdf``
    itself (NumPy). It builds nothing: :func:`build_fast_eval` does.

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> build_fast_eval(parse("lambertian(rho=0.5)"))
    >>> other = parse("lambertian(rho=0.7)")  # the same structure: the same kernel
    >>> fast = fast_eval(other)
    >>> d = np.array([0.0, 0.6, 0.8])
    >>> fast is other, bool(np.allclose(fast.eval(d, d), other.eval(d, d), rtol=1e-15))
    (False, True)
    """
    try:
        table = table_kernels(brdf, np.float64)
        if table is not None:
            return table if any(table.functions is f for f in _TABLE_EVALS_BUILT) else brdf
        model = compiled.compile(brdf, np.float64)
    except (ImportError, ValueError):  # no numba; a model the kernels do not take
        return brdf
    return model if model.built("eval") else brdf


_TABLE_EVALS_BUILT: list[tuple[Any, ...]] = []
"""The numba functions of the tables whose ``eval`` :func:`build_fast_eval` built (shared by
every table of one layout)."""


def build_fast_eval(brdf: BRDF) -> None:
    """Build (or load from the disk cache) the kernel :func:`fast_eval` uses for ``brdf``;
    nothing where there is none (no numba, a model the kernels do not take)."""
    direction = np.array([[0.0, 0.0, 1.0]])
    try:
        table = table_kernels(brdf, np.float64)
        (table or compiled.compile(brdf, np.float64)).eval(direction, direction)
    except (ImportError, ValueError):
        return
    if table is not None and not any(table.functions is f for f in _TABLE_EVALS_BUILT):
        _TABLE_EVALS_BUILT.append(table.functions)


HORIZON = 1e-6
"""Directions with cos θ at most this are drawn as 0 (at the horizon f·cos θ has a finite limit
but f itself may overflow)."""


def environment_passes(
    brdf: BRDF,
    envmap: EnvironmentMap,
    resolution: int,
    cancel: threading.Event | None = None,
    max_samples: int = ENV_MAX_SAMPLES,
    between_tiles: Callable[[], None] | None = None,
) -> Iterator[Pass]:
    """The sphere under ``envmap`` refined progressively (:func:`brdfkit.render.progressive`:
    2, 4, …, 64, 96, 128, 192, … samples per pixel in two Sobol' replicates), stopping when
    ``cancel`` is set; ``between_tiles()`` after each tile (:func:`tile_progress`)."""
    return progressive(
        sphere_gbuffer(resolution),
        brdf,
        envmap,
        max_samples=max_samples,
        cancel=cancel,
        max_evaluations=PROGRESSIVE_TILE_EVALUATIONS,
        progress=tile_progress(between_tiles),
    )


PROGRESSIVE_TILE_EVALUATIONS = 1 << 17
"""BRDF evaluations per tile of the progressive views' passes (a quarter of
:func:`~brdfkit.render.shade`'s default): tiles of a few ms, after each of which a pass can
wait for the directional-light views (``between_tiles``). The pixels' samples do not depend
on the tiles (Sobol' sequences seeded per pixel): the images equal those of the default
tiles to float32 rounding (the compiled kernels' per-tile sums)."""


LIT_TILE_EVALUATIONS = PROGRESSIVE_TILE_EVALUATIONS // 4
"""BRDF evaluations per tile of the lit object's passes: each evaluation also casts two
shadow rays, about three times the work of an evaluation without them, so its tiles take
a little less time than the environment-lit sphere's."""


def tile_progress(between_tiles: Callable[[], None] | None) -> Callable[[int, int], None] | None:
    """:func:`~brdfkit.render.progressive`'s ``progress`` that calls ``between_tiles()``."""
    if between_tiles is None:
        return None
    return lambda done, total: between_tiles()


def diffuse_term(brdf: BRDF, envmap: EnvironmentMap, resolution: int) -> np.ndarray | None:
    """The exact part of the environment-lit sphere that needs no samples: ρ E(n)/π of the
    BRDF's Lambertian lobes (:func:`brdfkit.render.split_diffuse`, the term
    :func:`brdfkit.render.progressive`'s estimator adds to every pass), ``(R, R, C)``;
    ``None`` for a BRDF without a Lambertian lobe. The page shows it before the first pass."""
    rho, _ = split_diffuse(brdf)
    if rho is None or np.ndim(rho) > 1:
        return None
    disk = sphere_disk(resolution)
    value = to_numpy(diffuse_envmap_radiance(rho, envmap, disk.frame, disk.wo_local))
    image = np.zeros((*disk.mask.shape, value.shape[-1]))
    image[disk.mask] = value
    return image


def relative_noise(p: Pass, mask: np.ndarray) -> float:
    r"""The image's Monte Carlo noise relative to its mean value over the sphere: the RMS over
    the sphere of ``p.error`` divided by the mean. With :func:`~brdfkit.render.progressive`'s
    default Sobol' replicates the squared ``error`` is an unbiased estimate of each pixel's
    variance, so the square of this is an unbiased estimate of the relative mean squared
    error, from the first pass on. Without replicates, the RMS of ``p.stderr`` (conservative
    with Sobol' points)."""
    mean = float(np.mean(p.image[mask]))
    if mean <= 0:
        return 0.0
    error = p.stderr if p.error is None else p.error
    return float(np.sqrt(np.mean(error[mask] ** 2)) / mean)


def orbit_camera(
    bounds: np.ndarray, azimuth: float, elevation: float, resolution: int = LIT_RESOLUTION
) -> Camera:
    """A :data:`LIT_FOV` camera in Mitsuba's frame looking at the centre of ``bounds``
    (``(2, 3)``: least and greatest corner) from ``azimuth`` degrees about +y (0: from +z) and
    ``elevation`` degrees above the horizontal, far enough that the box's bounding sphere fits
    the view.

    Examples
    --------
    >>> box = np.array([[-1.0, 0.0, -1.0], [1.0, 2.0, 1.0]])
    >>> camera = orbit_camera(box, azimuth=0.0, elevation=0.0)
    >>> camera.position.round(3).tolist(), camera.rotation[:, 2].round(3).tolist()
    ([0.0, 1.0, 5.064], [0.0, 0.0, 1.0])
    """
    low, high = np.asarray(bounds, dtype=float)
    centre, radius = (low + high) / 2, max(float(np.linalg.norm(high - low)) / 2, 1e-6)
    distance = radius / math.sin(math.radians(LIT_FOV) / 2)
    a, e = math.radians(azimuth), math.radians(elevation)
    offset = np.array([math.cos(e) * math.sin(a), math.sin(e), math.cos(e) * math.cos(a)])
    return look_at_camera(
        centre + distance * offset, centre, (0, 1, 0), fov=LIT_FOV, size=(resolution, resolution)
    )


@lru_cache(maxsize=8)
def lit_gbuffer(
    scene: MeshScene,
    bounds: tuple[float, ...],
    azimuth: float,
    elevation: float,
    resolution: int = LIT_RESOLUTION,
) -> MeshGBuffer:
    """The G-buffer of ``scene`` seen by :func:`orbit_camera` (``bounds``: the box's six
    numbers, least corner first), cached: the BRDFs change more often than the camera."""
    camera = orbit_camera(np.reshape(bounds, (2, 3)), azimuth, elevation, resolution)
    return scene.gbuffer(camera, resolution)


def lit_passes(
    brdf: BRDF,
    scene: MeshScene,
    g: MeshGBuffer,
    envmap: EnvironmentMap,
    cancel: threading.Event | None = None,
    max_samples: int = LIT_MAX_SAMPLES,
    between_tiles: Callable[[], None] | None = None,
) -> Iterator[Pass]:
    """The lit object: ``scene``'s G-buffer ``g`` under ``envmap`` (turned into Mitsuba's
    frame, :func:`~brdfkit.render.mitsuba_frame.mitsuba_oriented`) with shadows
    (:meth:`~brdfkit.render.mesh.MeshScene.visibility`), refined progressively
    (:func:`brdfkit.render.progressive`, default seed and Sobol' replicates: the same passes as
    that call with the same tiles in any process; other tiles round the float32 sums otherwise),
    stopping when ``cancel`` is set; ``between_tiles()`` after each tile (:func:`tile_progress`)
    and before each round of its shadow rays (:meth:`~brdfkit.render.mesh.MeshScene.unoccluded`),
    so that a tile under way yields the cores within a millisecond or two.

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> from brdfkit.render.bundled_meshes import load_mesh, object_bounds
    >>> scene = load_mesh("bundled:knot")
    >>> g = lit_gbuffer(scene, tuple(object_bounds("knot").ravel()), 30.0, 25.0, 16)
    >>> white = EnvironmentMap(np.ones((8, 16, 1)))
    >>> first = next(lit_passes(parse("lambertian(rho=0.5)"), scene, g, white))
    >>> first.samples, first.image.shape, bool(0 < first.image[g.mask].mean() <= 0.5)
    (2, (16, 16, 1), True)
    """
    light = mitsuba_oriented(envmap)
    visibility = scene.visibility(g, before_batch=between_tiles)
    return progressive(
        g,
        brdf,
        light,
        max_samples=max_samples,
        cancel=cancel,
        visibility=visibility,
        max_evaluations=LIT_TILE_EVALUATIONS,
        progress=tile_progress(between_tiles),
    )


def _eval(brdf: BRDF, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """f as float64 ``(..., C)``; 0 where a direction lies at or below the :data:`HORIZON`."""
    wi, wo = np.broadcast_arrays(wi, wo)
    f = np.asarray(brdf.eval(np.ascontiguousarray(wi), np.ascontiguousarray(wo)), np.float64)
    below = (wi[..., 2] <= HORIZON) | (wo[..., 2] <= HORIZON)
    return np.where(below[..., None], 0.0, np.nan_to_num(f, nan=0.0, posinf=0.0))


def incidence_plane(state: ViewState) -> tuple[np.ndarray, np.ndarray]:
    """``(theta_v, wo)``: signed view angles over [−90°, 90°] in the plane of incidence and their
    directions; θv = +θi is the mirror direction."""
    theta_v = np.radians(np.linspace(-90.0, 90.0, CURVE_SAMPLES))
    phi = math.radians(state.phi_i) + math.pi  # the mirror side is opposite the light
    wo = np.stack(
        [np.sin(theta_v) * math.cos(phi), np.sin(theta_v) * math.sin(phi), np.cos(theta_v)], -1
    )
    return theta_v, wo


def theta_v_curve(brdf: BRDF, state: ViewState) -> tuple[np.ndarray, np.ndarray]:
    """f(wi, wo(θv)) in the plane of incidence (the polar plot and the θv curve): ``(θv, f)``."""
    theta_v, wo = incidence_plane(state)
    return theta_v, _eval(brdf, state.wi(), wo)


def theta_h_curve(brdf: BRDF, state: ViewState) -> tuple[np.ndarray, np.ndarray]:
    """f over θh ∈ [0°, 90°] at the state's θd and φd (φh = 0)."""
    theta_h = np.radians(np.linspace(0.0, 90.0, CURVE_SAMPLES))
    wi, wo = from_half_diff(
        theta_h,
        0 * theta_h,
        np.full_like(theta_h, math.radians(state.theta_d)),
        np.full_like(theta_h, math.radians(state.phi_d)),
    )
    return theta_h, _eval(brdf, wi, wo)


def theta_d_curve(brdf: BRDF, state: ViewState) -> tuple[np.ndarray, np.ndarray]:
    """f over θd ∈ [0°, 90°] at the state's θh and φd (φh = 0)."""
    theta_d = np.radians(np.linspace(0.0, 90.0, CURVE_SAMPLES))
    wi, wo = from_half_diff(
        np.full_like(theta_d, math.radians(state.theta_h)),
        0 * theta_d,
        theta_d,
        np.full_like(theta_d, math.radians(state.phi_d)),
    )
    return theta_d, _eval(brdf, wi, wo)


def half_diff_slice(brdf: BRDF, state: ViewState) -> np.ndarray:
    """f on the θh × θd grid at the state's φd, ``(θd, θh, C)`` with cell centres 0.5°, 1.5°, …"""
    centres = (np.arange(SLICE_RESOLUTION) + 0.5) * (math.pi / 2 / SLICE_RESOLUTION)
    th, td = np.meshgrid(centres, centres)
    wi, wo = from_half_diff(th, 0 * th, td, np.full_like(th, math.radians(state.phi_d)))
    return _eval(brdf, wi, wo)


def lobe(brdf: BRDF, state: ViewState) -> np.ndarray:
    """f(wi, wo) on the :data:`LOBE_GRID` of (θo, φo) nodes (θo from 0° to 90°, φo over a full
    turn with the seam repeated), ``(T, P, C)``; the front end draws r = f (or f·cos θo)."""
    theta = np.radians(np.linspace(0.0, 90.0, LOBE_GRID[0]))
    phi = np.radians(np.linspace(0.0, 360.0, LOBE_GRID[1]))
    t, p = np.meshgrid(theta, phi, indexing="ij")
    wo = spherical_to_cartesian(t, p)
    wo[..., 2] = np.maximum(wo[..., 2], 2 * HORIZON)  # the horizon row, just above it
    return _eval(brdf, state.wi(), wo)


def albedo(brdf: BRDF) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Directional albedo ρ(θo) at :data:`ALBEDO_ANGLES` angles in [0°, 89°] with its Monte Carlo
    standard error (:meth:`BRDF.albedo_estimate`, :data:`ALBEDO_SAMPLES` samples): ``(θ, ρ, σ)``."""
    theta = np.radians(np.linspace(0.0, 89.0, ALBEDO_ANGLES))
    wo = spherical_to_cartesian(theta, np.zeros_like(theta))
    mean, stderr = brdf.albedo_estimate(wo, samples=ALBEDO_SAMPLES)
    return theta, np.asarray(mean, np.float64), np.asarray(stderr, np.float64)


__all__ = [
    "ALBEDO_ANGLES",
    "ALBEDO_SAMPLES",
    "CURVE_SAMPLES",
    "DEFAULT_MESH",
    "ELEVATION_RANGE",
    "ENV_MAX_SAMPLES",
    "HORIZON",
    "LIT_FOV",
    "LIT_MAX_SAMPLES",
    "LIT_RESOLUTION",
    "LOBE_GRID",
    "LOCAL_TO_WORLD",
    "PREVIEW_MIN",
    "PROGRESSIVE_TILE_EVALUATIONS",
    "SLICE_RESOLUTION",
    "Disk",
    "ViewState",
    "albedo",
    "build_fast_eval",
    "diffuse_term",
    "environment_passes",
    "fast_eval",
    "half_diff_slice",
    "incidence_plane",
    "lit_gbuffer",
    "lit_passes",
    "lobe",
    "orbit_camera",
    "relative_noise",
    "sphere",
    "sphere_disk",
    "sphere_gbuffer",
    "sphere_values",
    "theta_d_curve",
    "theta_h_curve",
    "theta_v_curve",
    "tile_progress",
]
