"""Shading a G-buffer by the reflection equation: :func:`shade` and :func:`render_sphere`.

:func:`shade` evaluates the reflection equation
(:func:`brdfkit.render.reflection_equation.reflected_radiance`) at every covered pixel, in tiles
of rows so that memory stays bounded, with per-pixel BRDF parameters sliced per tile. Under an
environment map it takes the compiled path (:mod:`brdfkit.render.compiled_shading`) wherever
that applies, whatever the size of the work. Direct lighting only: no interreflection,
and shadows only through a visibility factor (meshes, :mod:`brdfkit.render.mesh`).

References
----------
.. [1] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., ch. 13.
.. [2] CMU 16-385 Lecture 14: "evaluating the reflectance equation renders images".
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from brdfkit._array import to_numpy
from brdfkit.brdf.base import BRDF, Scaled, Sum
from brdfkit.light.base import Light
from brdfkit.render.reflection_equation import (
    FLOOR_DIRECTIONS,
    Estimate,
    Visibility,
    reflected_radiance,
)
from brdfkit.render.scene import Camera, GBuffer, Sphere, gbuffer
from brdfkit.sampling import query_seeds


# --------------------------------------------------------------------------- shading
def slice_brdf(brdf: BRDF, image_shape: tuple[int, int], rows: slice) -> BRDF:
    """``brdf`` with each per-pixel parameter (leading axes ``image_shape``) cut to ``rows``.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> texture = Lambertian(rho=np.full((8, 8, 1), 0.5))
    >>> slice_brdf(texture, (8, 8), slice(2, 4)).rho.shape
    (2, 8, 1)
    """
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
    compiled: bool | str = True,
    visibility: Callable[[slice], Visibility] | None = None,
) -> np.ndarray:
    """Linear radiance image ``(H, W, C)`` of the G-buffer under ``lights``.

    Pixels are shaded in tiles of rows holding at most ``max_evaluations`` BRDF evaluations
    (pixels × samples, and the control variate's
    :data:`~brdfkit.render.reflection_equation.FLOOR_DIRECTIONS`),
    which bounds memory (about 400 bytes per evaluation on the NumPy path, 200 MB per tile;
    the compiled path keeps a few buffers per block). By default each pixel has its own
    scrambled Sobol' sequence, keyed by its index in the image, so the tiles do not change
    the image (``sequence``, see :func:`~brdfkit.render.reflected_radiance`); with
    ``method="auto"`` Lambertian lobes under an environment map come noise-free from the
    map's irradiance (:func:`~brdfkit.render.split_diffuse`) and only the other lobes are
    sampled.
    ``progress(done, total)`` is called after each tile.

    ``compiled`` chooses the compiled path: each tile shaded by the numba kernel of
    :class:`brdfkit.render.compiled_shading.EnvironmentShader` where it applies (one
    :class:`~brdfkit.light.EnvironmentMap` plus any delta lights, ``method`` ``"auto"`` or
    ``"mis"``, a BRDF :mod:`brdfkit.compiled` compiles: see
    :func:`~brdfkit.render.compiled_shading.compiled_shader`), NumPy elsewhere. ``True``
    (default): float32 kernels wherever they apply, built on first use once per model
    structure and kept on disk (:mod:`brdfkit.compiled.cache`) for every later process;
    ``"float64"``: float64 kernels (the image then equals the NumPy one to rounding);
    ``False``: the NumPy reference. Same tiles, seeds and
    uniforms on both paths (float32 kernels: equal to float32 precision).

    ``visibility(rows)`` gives the visibility factor of the image's ``rows`` (shadow rays:
    :meth:`brdfkit.render.mesh.MeshScene.visibility`), which
    :func:`~brdfkit.render.reflected_radiance` applies to every light and BRDF sample, and
    the compiled path between its kernels' samples.

    Examples
    --------
    A plane facing the camera, lit head-on with irradiance π, reflects ρ everywhere:

    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> from brdfkit.light import DirectionalLight
    >>> from brdfkit.render import Plane, gbuffer
    >>> g = gbuffer(Plane(), resolution=(2, 3))
    >>> image = shade(g, Lambertian(rho=0.5), DirectionalLight((1.0, 0.0, 0.0), irradiance=np.pi))
    >>> image.shape, image.round(12).ravel().tolist()
    ((2, 3, 1), [0.5, 0.5, 0.5, 0.5, 0.5, 0.5])
    """
    return _shade(
        g, brdf, lights, method=method, samples=samples, seed=seed, sequence=sequence,
        max_evaluations=max_evaluations, background=background, progress=progress,
        compiled=compiled, stderr=False, visibility=visibility,
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
    first_row: int = 0,
    first_sample: int = 0,
    cache: dict[Any, Any] | None = None,
    visibility: Callable[[slice], Visibility] | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`shade`'s image and its per-pixel standard error (0 outside the mask; ``None``
    unless ``stderr``).

    The G-buffer is the image's rows from ``first_row`` on (:func:`render_sphere`'s bands).
    With ``sequence="sobol"`` each pixel's seed is a hash of ``seed`` and its index in the
    image (:func:`~brdfkit.sampling.query_seeds`), whatever the tiles, and its samples are
    points ``first_sample`` … of its sequence; with ``"random"`` a tile's seed is ``seed``
    plus its first row in the image. ``cache`` (a dict kept across calls on the same
    G-buffer, BRDF and lights: :func:`progressive`'s passes) keeps the compiled plan and each
    tile's sample-independent work
    (:meth:`~brdfkit.render.compiled_shading.EnvironmentShader.prepare`,
    the delta lights)."""
    want_stderr = stderr
    height, width = g.shape
    light_list = [lights] if isinstance(lights, Light) else list(lights)
    channels = max([brdf.channels] + [lt.channels for lt in light_list])
    image = np.full((height, width, channels), background, dtype=np.float64)
    stderr = np.zeros((height, width, channels)) if want_stderr else None
    plan = _cached_plan(cache, brdf, light_list, method, compiled, visibility is not None)
    rows_per_tile = _rows_per_tile(samples, method, width, max_evaluations)
    if plan is not None and sequence == "sobol":
        # the kernel's memory does not grow with the samples, nor do a pixel's samples
        # depend on the tiles: the same tiles whatever the samples (cache keys of passes)
        rows_per_tile = _rows_per_tile(COMPILED_TILE_SAMPLES, method, width, max_evaluations)
    tiles = [
        slice(r0, min(r0 + rows_per_tile, height))
        for r0 in range(0, height, rows_per_tile)
        if np.any(g.mask[r0 : r0 + rows_per_tile])
    ]

    def tile_key(rows: slice) -> tuple[Any, ...]:
        return ("tile", compiled, first_row + rows.start, first_row + rows.stop)

    def prepare_tile(rows: slice, seen: Visibility | None) -> tuple[Any, Any]:
        """The tile's sample-independent work (:meth:`EnvironmentShader.prepare
        <brdfkit.render.compiled_shading.EnvironmentShader.prepare>`, the delta lights),
        kept in ``cache``."""
        shader, others = plan
        key = tile_key(rows)
        if cache is not None and key in cache:
            return cache[key]
        prepared = shader.prepare(
            g.wo[rows], g.normals[rows], g.points[rows], g.tangents[rows], mask=g.mask[rows]
        )
        exact = None
        if others:  # delta lights: exact, no samples
            exact = reflected_radiance(
                slice_brdf(brdf, (height, width), rows), others, g.wo[rows],
                normal=g.normals[rows], point=g.points[rows], tangent=g.tangents[rows],
                visibility=seen,
            ).value  # fmt: skip
        if cache is not None:
            cache[key] = prepared, exact
        return prepared, exact

    ahead: dict[int, Any] = {}  # the next tile's prepare, on the helper thread
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
            seen = None if visibility is None else visibility(rows)
            if plan is not None:
                shader = plan[0]
                if r0 in ahead:
                    prepared, exact = ahead.pop(r0).result()
                else:
                    prepared, exact = prepare_tile(rows, seen)
                following = next((t for t in tiles if t.start > r0), None)
                new = following is not None and (cache is None or tile_key(following) not in cache)
                if new and visibility is None:
                    ahead[following.start] = _prepare_ahead(prepare_tile, following)
                estimate = shader.shade(
                    prepared,
                    samples=samples,
                    seed=tile_seed,
                    sequence=sequence,
                    first_sample=first_sample,
                    visibility=seen,
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
                    visibility=seen,
                )
            value = to_numpy(estimate.value)
            image[rows] = np.where(m[..., None], value, background)
            if stderr is not None:
                stderr[rows] = np.where(m[..., None], to_numpy(estimate.stderr), 0.0)
        if progress is not None:
            progress(rows.stop, height)
    return image, stderr


def _prepare_ahead(prepare_tile: Callable[[slice, None], Any], rows: slice) -> Any:
    """The future of ``prepare_tile(rows, None)`` on the compiled shader's helper thread: the
    next tile's per-pixel set-up (frames, the control variate's floor, the irradiance) runs
    on the second core while this tile's kernel runs, instead of after it on one core."""
    from brdfkit.render.compiled_shading import _in_background

    return _in_background(lambda: prepare_tile(rows, None))


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


COMPILED = (True, False, "float64")
"""Values of :func:`shade`'s ``compiled``."""


def _cached_plan(
    cache: dict[Any, Any] | None,
    brdf: BRDF,
    lights: list[Light],
    method: str,
    compiled: bool | str,
    shadows: bool,
) -> tuple[Any, list[Light]] | None:
    """:func:`_compiled_plan` for :func:`_shade`, kept in its ``cache`` (if any); with
    ``shadows`` every lobe is sampled by MIS, as :func:`reflected_radiance` does."""
    if cache is not None and ("plan", compiled) in cache:
        return cache["plan", compiled]
    shadowed = shadows and method == "auto"
    plan = _compiled_plan(brdf, lights, "mis" if shadowed else method, compiled, shadows)
    if cache is not None:
        cache["plan", compiled] = plan
    return plan


def _compiled_plan(
    brdf: BRDF, lights: list[Light], method: str, compiled: bool | str, shadows: bool = False
) -> tuple[Any, list[Light]] | None:
    """The compiled shader and the delta lights left to NumPy, or ``None`` for the NumPy path
    (``shadows``: for a render with a visibility factor)."""
    if not any(compiled is c or (isinstance(compiled, str) and compiled == c) for c in COMPILED):
        raise ValueError(f"compiled must be one of True, False, 'float64'; got {compiled!r}")
    if compiled is False:
        return None
    from brdfkit.render.compiled_shading import compiled_shader

    dtype = np.float64 if compiled == "float64" else np.float32
    return compiled_shader(brdf, lights, method=method, dtype=dtype, shadows=shadows)


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

    Examples
    --------
    A Lambertian sphere lit from the camera (+x) with irradiance π has radiance ρ cos θ,
    brightest in the middle; the corners miss the sphere:

    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> from brdfkit.light import DirectionalLight
    >>> front = DirectionalLight((1.0, 0.0, 0.0), irradiance=np.pi)
    >>> image = render_sphere(Lambertian(rho=0.5), front, resolution=8)
    >>> image.shape, float(image[0, 0, 0])
    ((8, 8, 1), 0.0)
    >>> float(image[3, 3, 0].round(4)), float(image.max().round(4))  # 0.5 · cos θ
    (0.4921, 0.4921)
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
    image = None
    for r0 in range(0, height, band):
        rows = slice(r0, min(r0 + band, height))
        g = gbuffer(Sphere(), camera, (height, width), rows)
        part = _shade(
            g, brdf, lights, **options, seed=seed, progress=None, stderr=False, first_row=r0,
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
    work (each tile's :meth:`~brdfkit.render.compiled_shading.EnvironmentShader.prepare` and
    delta lights), kept for the most recent inputs: the same model, light and camera objects
    (immutable, held by the entry so that their ids stay theirs), shape, ``method`` and
    tiling options. The plan and the tiles' entries carry the plan's dtype (``compiled``) in
    their keys. The per-render set-up it saves: the G-buffer, the compiled shader, the
    frames, the control variate's floor and the irradiance."""
    light_list = (lights,) if isinstance(lights, Light) else tuple(lights)
    key = (
        id(brdf), tuple(map(id, light_list)), id(camera), shape, options["method"],
        options["sequence"], options["max_evaluations"],
    )  # fmt: skip
    entry = _RECENT.get("sphere")
    if entry is None or entry[0] != key:
        # the plan first: a new map's tables are built on a helper thread meanwhile
        # (compiled_shading.EnvironmentShader), while this one traces the G-buffer
        cache: dict[Any, Any] = {}
        _cached_plan(cache, brdf, list(light_list), options["method"], options["compiled"], False)
        entry = (key, (brdf, light_list, camera), gbuffer(Sphere(), camera, shape), cache)
        _RECENT["sphere"] = entry
    return entry[2], entry[3]


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
    "render_sphere",
    "shade",
    "slice_brdf",
]
