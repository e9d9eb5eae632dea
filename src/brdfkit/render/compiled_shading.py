r"""Compiled shading under an environment map: the driver of the tile kernel.

:class:`EnvironmentShader` computes what :func:`brdfkit.render.reflected_radiance` computes
with ``method`` ``"auto"`` or ``"mis"``, at compiled speed: the exact parts as the NumPy path
has them (Lambertian lobes as :math:`\rho E(n)/\pi`, :func:`~brdfkit.render.split_diffuse`; a
smooth plastic's mirror as :math:`sF(\theta_o)L(\omega_r)`,
:func:`~brdfkit.render.split_mirror`; the control variate :math:`k\,E(n)` of the rest,
:func:`~brdfkit.render.diffuse_floor`, k from the compiled ``eval``), and the MIS estimate of
the rest by the numba tile kernel (``render/_reflection_kernels.py``), whose BRDF kernels
:func:`brdfkit.compiled.compile` builds from the model's own code, or
:func:`brdfkit.measured.table_kernels` for a tabulated BRDF. Its tasks (sets of pixels) run
on the kernels' threads (:func:`brdfkit.compiled.kernel_tools.run_tasks`; the kernel releases
the GIL). With a visibility factor (shadow rays against a mesh, ``method="mis"``) a
recording tile kernel writes each sample's terms and directions, the rays are cast in
batches between chunks of samples, and the visible terms are averaged
(:meth:`EnvironmentShader.shade`).

The uniforms are those of the NumPy path (the same generator calls in the same order: per
pixel and strategy its own nested-scrambled, digitally shifted Sobol' sequence,
:func:`brdfkit.sampling.scrambled_sobol`, or i.i.d. uniforms), so with ``dtype=float64`` the
image equals :func:`~brdfkit.render.shade`'s to rounding, and with float32 to float32
precision away from the rare samples whose texel flips. :func:`compiled_shader` decides
where the compiled path applies; :func:`kernels_built` whether it costs no compilation,
:func:`pending_kernels` what a render would build first and :func:`build_kernels` builds it
(timed, for :func:`build_estimate`: the command line announces a build in one line), the tile
kernel compiled by a worker process on another core meanwhile
(:mod:`brdfkit.compiled.worker`).

A new map's set-up runs on both cores: its sampling tables (the pixels' digest, the weights,
the CDFs and their guide tables) are built on a helper thread from the shader's construction
on, while the caller traces its G-buffer, and :func:`~brdfkit.render.shade` prepares each
next tile (frames, the floor k, k·E(n)) on that thread while the kernel shades the tile
before; the work and its results are the same as on one thread.

References
----------
.. [1] E. Veach, L. Guibas, "Optimally combining sampling techniques for Monte Carlo
       rendering", SIGGRAPH 1995.
.. [2] S. K. Lam, A. Pitrou, S. Seibert, "Numba: a LLVM-based Python JIT compiler", 2015.
"""

from __future__ import annotations

import contextlib
import math
import sys
import threading
import time
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit import compiled, sampling
from brdfkit.brdf.base import BRDF
from brdfkit.brdf.one_sided import one_sided_view
from brdfkit.compiled import cache as kernel_cache
from brdfkit.compiled import kernel_tools
from brdfkit.compiled import worker as compiled_worker
from brdfkit.compiled.thread_pool import BLOCK as BLOCK_EVALUATIONS
from brdfkit.light.base import Light
from brdfkit.light.environment import EnvironmentMap, compiled_lookups
from brdfkit.params import check_choice
from brdfkit.render._reflection_kernels import (
    BLOCK,
    brdf_functions,
    build_tile_helpers,
    step_functions,
    steps_built,
    tile_kernel,
    tile_kernel_built,
)
from brdfkit.render.reflection_equation import (
    FLOOR_DIRECTIONS,
    Estimate,
    Visibility,
    _floor_directions,
    _mirror_envmap,
    _Uniforms,
    diffuse_envmap_radiance,
    local_frames,
    split_diffuse,
    split_mirror,
    uniform_seeds,
)

HEURISTICS = ("power", "balance")
METHODS = ("auto", "mis")


_METHODS = (("sample", 3), ("eval", 0), ("pdf", 0))
"""The BRDF kernels the tile kernel calls: method and width of its uniforms."""

_BRDF_KERNELS: weakref.WeakKeyDictionary[
    BRDF, dict[np.dtype, tuple[compiled.CompiledBRDF, tuple[Any, ...]]]
] = weakref.WeakKeyDictionary()


def _compiled(model: BRDF, dtype: np.dtype) -> tuple[compiled.CompiledBRDF, tuple[Any, ...]]:
    """``model`` compiled (:func:`brdfkit.compiled.compile`) and the numba functions of its
    ``sample`` (3 uniforms), ``eval`` and ``pdf`` kernels, kept per model object. The
    functions are those of the model's structure (they read the parameter values,
    ``compiled.parameters``, at each call), so a model that differs in values only reuses
    them and the tile kernel built on them."""
    per_dtype = _BRDF_KERNELS.setdefault(model, {})
    if dtype not in per_dtype:
        compiled_model = compiled.compile(model, dtype)
        per_dtype[dtype] = (
            compiled_model,
            tuple(compiled_model.kernel(method, width).function for method, width in _METHODS),
        )
    return per_dtype[dtype]


def shading_parts(brdf: BRDF, method: str) -> tuple[Any, BRDF | None, BRDF | None, bool]:
    """How :class:`EnvironmentShader` shades ``brdf`` with ``method``: ``(rho, mirror, rest,
    control)``, the albedo of its Lambertian lobes (exact, ρE(n)/π;
    :func:`~brdfkit.render.split_diffuse`), a smooth plastic's mirror (exact;
    :func:`~brdfkit.render.split_mirror`), the rest that the kernel samples (one-sided, as on
    the NumPy path) and whether the control variate k·E(n) of ``method="auto"``
    (:func:`~brdfkit.render.diffuse_floor`) applies to it. With ``"mis"`` all is sampled."""
    if method != "auto":
        return None, None, one_sided_view(brdf), False
    rho, rest = split_diffuse(brdf)
    mirror, rest = split_mirror(rest)
    if rest is not None:  # transmitting lobes sampled one-sided
        rest = one_sided_view(rest)
    control = rest is not None and (mirror is not None or not rest.has_delta)
    return rho, mirror, rest, control


def uses_irradiance(brdf: BRDF, method: str = "auto") -> bool:
    """Whether shading ``brdf`` under a map reads the map's irradiance table
    (:attr:`~brdfkit.light.EnvironmentMap.irradiance_table`: Lambertian lobes or the control
    variate, :func:`shading_parts`)."""
    rho, _, _, control = shading_parts(brdf, method)
    return rho is not None or control


@dataclass(frozen=True, eq=False)
class Prepared:
    """Queries made ready by :meth:`EnvironmentShader.prepare`: their batch shape, the exact
    part of their value ``batch + (C,)``, and for the kernel the indices of the pixels it
    shades, the flat ``wo`` ``(n, 3)`` and frames ``(n, 3, 3)`` in its dtype and the control
    variate's k ``(n, C)``; for shadow rays the points ``batch + (3,)``."""

    batch: tuple[int, ...]
    value: np.ndarray
    pixels: np.ndarray | None = None
    wo: np.ndarray | None = None
    frame: np.ndarray | None = None
    control: np.ndarray | None = None
    point: np.ndarray | None = None


class EnvironmentShader:
    r"""A compiled MIS shader for one BRDF under one :class:`~brdfkit.light.EnvironmentMap`.

    Calling it equals :func:`brdfkit.render.reflected_radiance` with ``method`` ``"auto"``
    or ``"mis"`` and ``heuristic`` ``"power"`` or ``"balance"``, same uniforms (module
    docstring), at compiled speed. The BRDF's non-Lambertian part must be compilable by
    :func:`brdfkit.compiled.compile` (its parameters may not vary per pixel; the albedo of its
    Lambertian lobes, ``method="auto"``, neither) or be a tabulated BRDF, alone or scaled by
    a constant (:func:`brdfkit.measured.table_kernels`, the table an input of the kernel).

    Parameters
    ----------
    brdf : the surface's reflectance.
    light : the environment map (or a sequence holding only it).
    method : ``"auto"`` (Lambertian lobes as ρE(n)/π, the rest by MIS of f − k with the
        control variate k·E(n), :func:`~brdfkit.render.diffuse_floor`) or ``"mis"``.
    heuristic : ``"power"`` (β = 2) or ``"balance"`` (β = 1).
    dtype : float32 (fastest) or float64 (the NumPy path's precision) for the arithmetic.

    Raises
    ------
    ValueError
        For another light, method or heuristic, a per-pixel parameter, or a BRDF that
        :mod:`brdfkit.compiled` cannot compile.
    """

    def __init__(
        self,
        brdf: BRDF,
        light: Light | Sequence[Light],
        *,
        method: str = "auto",
        heuristic: str = "power",
        dtype: Any = np.float32,
    ) -> None:
        lights = [light] if isinstance(light, Light) else list(light)
        if len(lights) != 1 or not isinstance(lights[0], EnvironmentMap):
            raise ValueError(f"light must be one EnvironmentMap; got {light!r}")
        check_choice("method", method, METHODS)
        check_choice("heuristic", heuristic, HEURISTICS)
        self.env: EnvironmentMap = lights[0]
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.float32, np.float64):
            raise ValueError(f"dtype must be float32 or float64; got {self.dtype}")
        self.heuristic = heuristic
        self.rho, self.mirror, self.rest, self.control = shading_parts(brdf, method)
        if self.rho is not None and np.ndim(self.rho) > 1:
            raise ValueError("a per-pixel Lambertian albedo is not supported by the compiled path")
        self.channels = max(brdf.channels, self.env.channels)
        self._kernel: Callable[..., None] | None = None
        self._recorder: Callable[..., None] | None = None  # with shadows, built when asked
        self._floor_block: np.ndarray | None = None  # the floor's directions, made when asked
        # the BRDF's kernels' trailing arguments (a table's arrays: brdfkit.measured)
        self._data: tuple[Any, ...] = ()
        if self.rest is not None:
            table = _table_kernels(self.rest, self.dtype)
            if table is not None:
                self._rest, functions, self._data = table, table.functions, table.data
            else:
                self._rest, functions = _compiled(self.rest, self.dtype)
            self._kernel = tile_kernel(
                self.dtype.type, self.rest.channels, self.env.channels, load=not self._data
            )
            self._functions = (
                *brdf_functions(functions, self.dtype.type, self.rest.channels, self._data),
                *step_functions(self.dtype.type),
            )
        # the map's arrays for the kernel, its sampling as the NumPy path's MIS, built on a
        # helper thread while the caller traces its G-buffer and prepares its first tile;
        # first the irradiance table's cells, which that tile's floor needs sooner
        lookups = compiled_lookups(self.dtype, kernel_tools)
        env, irradiance = self.env, self.rho is not None or self.control

        def build_tables() -> tuple[Any, ...]:
            if irradiance:
                env.prepare_irradiance()
            return lookups.tables(env.compensated)

        self._map_tables = _in_background(build_tables)

    @property
    def _tables(self) -> tuple[Any, ...]:
        """The map's arrays for the kernel (:meth:`MapLookups.tables
        <brdfkit.light._environment_kernels.MapLookups.tables>`), waited for."""
        return self._map_tables.result()

    def __call__(
        self,
        wo: Any,
        normal: Any | None = None,
        point: Any | None = None,
        tangent: Any | None = None,
        *,
        samples: int = 256,
        seed: Any = 0,
        sequence: str = "random",
        first_sample: int = 0,
        mask: np.ndarray | None = None,
    ) -> Estimate:
        """Reflected radiance towards ``wo`` (arguments as
        :func:`~brdfkit.render.reflected_radiance`, ``first_sample`` included); ``mask``
        (the batch's shape) skips the Monte Carlo of pixels it marks False (their value is
        then the exact parts alone: Lambertian lobes, a plastic's mirror) without changing
        the others (beyond their last bit: a pixel's place in a vectorised block of the BRDF
        kernels can change its rounding).
        Returns float64 ``value`` and ``stderr``. The same as :meth:`shade` of
        :meth:`prepare`."""
        prepared = self.prepare(wo, normal, point, tangent, mask=mask)
        return self.shade(
            prepared, samples=samples, seed=seed, sequence=sequence, first_sample=first_sample
        )

    def prepare(
        self,
        wo: Any,
        normal: Any | None = None,
        point: Any | None = None,
        tangent: Any | None = None,
        *,
        mask: np.ndarray | None = None,
    ) -> Prepared:
        """What does not depend on the samples, for any number of :meth:`shade` calls on
        these queries (progressive passes): the local frames, and the exact terms (the
        Lambertian lobes' ρE(n)/π and the control variate's k·E(n))."""
        _, point, frame, wo_local, batch = local_frames(np.asarray(wo), normal, point, tangent)
        value = np.zeros((*batch, self.channels))
        if self.rho is not None:
            value = value + diffuse_envmap_radiance(self.rho, self.env, frame, wo_local)
        if self.mirror is not None:
            value = value + _mirror_envmap(self.mirror, self.env, point, frame, wo_local)
        if self._kernel is None:
            return Prepared(batch, value)
        n = math.prod(batch)
        keep = np.ones(n, bool) if mask is None else np.asarray(mask, bool).reshape(n)
        # the frames (n, 3, 3): tangent, bitangent, normal of each query
        frames = np.stack([np.broadcast_to(v, (*batch, 3)).reshape(n, 3) for v in frame], axis=1)
        control = np.zeros((n, self.rest.channels), self.dtype)
        if self.control:  # k·E(n) of the pixels shaded (the others' k is 0)
            kept_wo = wo_local.reshape(n, 3)[keep]
            control[keep] = k = self._floor(kept_wo)
            kept_frames = frames[keep]  # one gather of the three vectors
            floor = diffuse_envmap_radiance(
                k.astype(np.float64) * math.pi,
                self.env,
                (kept_frames[:, 0], kept_frames[:, 1], kept_frames[:, 2]),
                kept_wo,
            )
            value = np.ascontiguousarray(value)  # (*batch, channels): flat, a view of it
            value.reshape(n, self.channels)[keep] += floor
        t = self.dtype
        wo_flat = np.ascontiguousarray(wo_local.reshape(n, 3), dtype=t)
        frame_flat = frames.astype(t, copy=False)  # frames is this call's own
        return Prepared(batch, value, np.flatnonzero(keep), wo_flat, frame_flat, control, point)

    def shade(
        self,
        prepared: Prepared,
        *,
        samples: int = 256,
        seed: Any = 0,
        sequence: str = "random",
        first_sample: int = 0,
        visibility: Visibility | None = None,
    ) -> Estimate:
        """:meth:`__call__` on queries made ready by :meth:`prepare`; with ``visibility``
        (:func:`~brdfkit.render.reflected_radiance`'s, ``method="mis"`` only) each sample's
        terms carry the visibility factor (:meth:`_shadowed_monte_carlo`)."""
        if samples < 1:
            raise ValueError(f"samples must be >= 1; got {samples}")
        if sequence not in ("random", "sobol"):
            raise ValueError(f"sequence must be 'random' or 'sobol'; got {sequence!r}")
        batch, value = prepared.batch, prepared.value
        stderr2 = np.zeros((*batch, self.channels))
        exact = self.rho is not None or self.mirror is not None or self.control
        if visibility is not None and exact:
            raise ValueError("visibility needs method='mis' (the exact parts assume no shadows)")
        if self._kernel is not None and visibility is not None:
            mean, m2 = self._shadowed_monte_carlo(
                prepared, samples, seed, sequence, first_sample, visibility
            )
            value = value + mean
            stderr2 = m2 / samples / samples
        elif self._kernel is not None:
            mean, m2 = self._monte_carlo(prepared, samples, seed, sequence, first_sample)
            value = value + mean
            stderr2 = m2 / samples / samples
        return Estimate(value, np.sqrt(stderr2))

    def build(self) -> EnvironmentShader:
        """Compile the kernels now (numba compiles on first call) with a one-pixel call."""
        self(np.array([[0.0, 0.0, 1.0]]), samples=1)
        return self

    def _floor(self, wo_local: np.ndarray) -> np.ndarray:
        """:func:`~brdfkit.render.diffuse_floor` of the sampled part by its compiled
        ``eval``, ``(n, C)``, on the calling thread: in batches of at most
        :data:`~brdfkit.compiled.thread_pool.BLOCK` evaluations, which the kernel runs where
        it is called, so that the next tile's preparation (:func:`~brdfkit.render.shade`'s
        helper thread) never waits for the kernels' threads, busy with the tile before."""
        step = max(1, BLOCK_EVALUATIONS // FLOOR_DIRECTIONS)
        if self._floor_block is None:  # the directions, laid out as the kernel reads them
            directions = _floor_directions(FLOOR_DIRECTIONS).astype(self.dtype)
            self._floor_block = np.tile(directions, (step, 1, 1))
        wo = wo_local.astype(self.dtype)
        floor = np.empty((wo.shape[0], self.rest.channels), self.dtype)
        for lo in range(0, wo.shape[0], step):
            batch = wo[lo : lo + step]
            # each wo once per direction, laid out as the directions: the kernel's call
            # would copy a broadcast view so, element by element (several times slower)
            repeated = np.repeat(batch, FLOOR_DIRECTIONS, axis=0)
            f = self._rest.eval(
                self._floor_block[: batch.shape[0]], repeated.reshape(-1, FLOOR_DIRECTIONS, 3)
            )
            f.partition(FLOOR_DIRECTIONS // 2, axis=-2)  # in place: f is this call's own
            np.maximum(f[:, FLOOR_DIRECTIONS // 2], 0, out=floor[lo : lo + step])
        return floor

    def _monte_carlo(
        self, prepared: Prepared, samples: int, seed: Any, sequence: str, first_sample: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per-pixel mean and Σ(x − mean)² of the MIS terms, ``batch + (C,)`` each."""
        batch, pixels = prepared.batch, prepared.pixels
        wo_flat, frame_flat, control = prepared.wo, prepared.frame, prepared.control
        brdf_uniforms, map_uniforms, seeds = _uniforms(seed, sequence, batch, samples, first_sample)
        n = math.prod(batch)
        mean = np.zeros((n, self.channels))
        m2 = np.zeros((n, self.channels))
        found_mean = np.empty((pixels.size, self.channels))
        found_m2 = np.empty((pixels.size, self.channels))
        kernel = self._kernel
        power = self.heuristic == "power"

        bounds = _task_bounds(pixels.size, kernel_tools.threads())

        def run(task: int) -> None:
            lo, hi = bounds[task], bounds[task + 1]
            kernel(
                self._rest.parameters, pixels[lo:hi], wo_flat, frame_flat, *brdf_uniforms,
                *map_uniforms, seeds, *self._tables, power, control, found_mean[lo:hi],
                found_m2[lo:hi], self._data, *self._functions,
            )  # fmt: skip

        kernel_tools.run_tasks(run, range(len(bounds) - 1), kernel_tools.threads())
        mean[pixels], m2[pixels] = found_mean, found_m2
        shape = (*batch, self.channels)
        return mean.reshape(shape), m2.reshape(shape)

    def _shadowed_monte_carlo(
        self,
        prepared: Prepared,
        samples: int,
        seed: Any,
        sequence: str,
        first_sample: int,
        visibility: Visibility,
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`_monte_carlo` with the visibility factor, per chunk of
        :data:`SHADOW_SAMPLES` samples: the recording tile kernel writes each sample's two MIS
        terms and the world directions of its two samples (:meth:`_record`), ``visibility``
        answers their shadow rays in one batch (a term of 0 asks none, as on the NumPy
        path), and each pixel's visible terms fold into its mean and sum of squared
        deviations (Chan et al.'s update across chunks)."""
        batch, pixels, channels = prepared.batch, prepared.pixels, self.channels
        brdf_uniforms, map_uniforms, seeds = _uniforms(seed, sequence, batch, samples, first_sample)
        n = math.prod(batch)
        mean, m2 = np.zeros((pixels.size, channels)), np.zeros((pixels.size, channels))
        points = np.asarray(prepared.point)[..., None, None, :]
        for first in range(0, samples, SHADOW_SAMPLES):
            count = min(SHADOW_SAMPLES, samples - first)
            chunk = [_sample_chunk(u, first, count) for u in (*brdf_uniforms, *map_uniforms)]
            terms, directions = self._record(prepared, chunk, seeds)
            wi, distance = np.zeros((n, count, 2, 3), self.dtype), np.zeros((n, count, 2))
            wi[pixels] = directions
            distance[pixels] = np.where(np.any(terms != 0, axis=-1), np.inf, 0.0)
            seen = visibility(
                points, wi.reshape(*batch, count, 2, 3), distance.reshape(*batch, count, 2)
            )
            seen = np.asarray(seen).reshape(n, count, 2)[pixels]
            x = terms[..., 0, :] * seen[..., 0, None] + terms[..., 1, :] * seen[..., 1, None]
            x = x.astype(np.float64)  # (pixels, count, C)
            chunk_mean = np.mean(x, axis=1)
            chunk_m2 = np.sum(np.square(x - chunk_mean[:, None, :]), axis=1)
            delta, total = chunk_mean - mean, first + count
            mean += delta * (count / total)
            m2 += chunk_m2 + delta * delta * (first * count / total)
        full_mean, full_m2 = np.zeros((n, channels)), np.zeros((n, channels))
        full_mean[pixels], full_m2[pixels] = mean, m2
        shape = (*batch, channels)
        return full_mean.reshape(shape), full_m2.reshape(shape)

    def _record(
        self, prepared: Prepared, chunk: list[np.ndarray], seeds: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The recording tile kernel (:func:`~brdfkit.render._reflection_kernels.tile_kernel`
        with ``record``, built when first asked) on the prepared pixels and one chunk of
        their uniforms, on the kernels' threads: each sample's two MIS terms ``(pixels,
        samples, 2, C)`` and the world directions of its two samples ``(pixels, samples, 2,
        3)``, in the kernels' dtype."""
        if self._recorder is None:
            self._recorder = tile_kernel(
                self.dtype.type, self.rest.channels, self.env.channels, record=True
            )
        pixels, count = prepared.pixels, max(chunk[0].shape[1], chunk[1].shape[0])
        terms = np.empty((pixels.size, count, 2, self.channels), self.dtype)
        directions = np.empty((pixels.size, count, 2, 3), self.dtype)
        bounds = _task_bounds(pixels.size, kernel_tools.threads())

        def run(task: int) -> None:
            lo, hi = bounds[task], bounds[task + 1]
            self._recorder(
                self._rest.parameters, pixels[lo:hi], prepared.wo, prepared.frame, *chunk,
                seeds, *self._tables, self.heuristic == "power", prepared.control,
                terms[lo:hi], directions[lo:hi], self._data, *self._functions,
            )  # fmt: skip

        kernel_tools.run_tasks(run, range(len(bounds) - 1), kernel_tools.threads())
        return terms, directions


_HELPER: list[Any] = []
"""The one helper thread (an executor) that builds maps' tables for new shaders."""
_HELPER_LOCK = threading.Lock()


def _in_background(function: Callable[[], Any]) -> Any:
    """The future of ``function()`` on the helper thread: a map's sampling tables are
    NumPy and numba work that mostly runs without the GIL, so they are built on the second
    core while this thread traces the G-buffer and prepares the first tile (per-pixel work
    that needs no table). An error is raised where the result is asked for."""
    from concurrent.futures import ThreadPoolExecutor

    with _HELPER_LOCK:
        if not _HELPER:
            _HELPER.append(ThreadPoolExecutor(1, thread_name_prefix="brdfkit-map-tables"))
    return _HELPER[0].submit(function)


SHADOW_SAMPLES = 16
"""Samples per chunk of :meth:`EnvironmentShader._shadowed_monte_carlo` (its per-sample
records and shadow rays: 2 × 16 per pixel)."""


def _sample_chunk(uniforms: np.ndarray, first: int, count: int) -> np.ndarray:
    """Samples ``first`` … ``first + count`` of one of :func:`_uniforms`' arrays: the i.i.d.
    points' (pixels, samples, d) or the Sobol' digits' (samples, d) (empty arrays as they
    are)."""
    if uniforms.ndim == 3 and uniforms.shape[1] > 0:
        return np.ascontiguousarray(uniforms[:, first : first + count])
    if uniforms.ndim == 2 and uniforms.shape[0] > 0:
        return np.ascontiguousarray(uniforms[first : first + count])
    return uniforms


_CHUNK = 512
"""Pixels per task of the thread pool, at most."""


def _task_bounds(count: int, workers: int) -> list[int]:
    """Bounds of the thread pool's tasks over ``count`` pixels: at most :data:`_CHUNK` each,
    their number a multiple of ``workers`` and their sizes equal to within a pixel, so that
    the workers finish a tile together (with tasks of :data:`_CHUNK` and a short last one,
    one thread would wait on the other for part of a task per tile)."""
    tasks = -(-max(count, 1) // _CHUNK)
    tasks = -(-tasks // workers) * workers
    return [count * i // tasks for i in range(tasks + 1)]


def _uniforms(
    seed: Any, sequence: str, batch: tuple[int, ...], samples: int, first_sample: int
) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray], np.ndarray]:
    """The NumPy path's uniforms (``reflection_equation._Uniforms``: the same generator calls)
    of the BRDF's (3-D, stream 0) and the map's (2-D, stream 1) samples, without their
    pixels × samples array for Sobol: per strategy ``(points, digits)``, then the pixels'
    seeds. For ``"random"`` the i.i.d. ``points`` ``(n, N, d)`` (digits and seeds empty), for
    ``"sobol"`` the sequence's bit-reversed digits ``(N, d)`` and the pixels' 64-bit seeds
    ``(n,)`` (:func:`~brdfkit.render.reflection_equation.uniform_seeds`), from which the kernel
    hashes the scramble keys of each stream itself (``sampling.scramble_keys``), on its
    threads."""
    n = math.prod(batch)
    uniforms = _Uniforms(seed, sequence, first_sample)
    result = []
    for dim in (3, 2):
        if sequence == "random":
            points = uniforms.draw(batch, samples, dim).reshape(n, samples, dim)
            digits = np.empty((0, dim), np.uint32)
        else:
            points = np.empty((0, 0, dim))
            integers = sampling.sobol_integers(first_sample, samples, dim)
            digits = np.ascontiguousarray(sampling.reverse_bits(integers))
        result.append((points, digits))
    if sequence == "random":
        seeds = np.empty(0, np.uint64)
    else:
        seeds = np.ascontiguousarray(uniform_seeds(seed, batch).reshape(n), dtype=np.uint64)
    return result[0], result[1], seeds


AUTO_COMPILE_WORK = 4_000_000
"""Pixel-samples of MIS shading of a GGX conductor that the NumPy path takes about as long for
as building that model's kernels takes (a symbolic trace and numba compiles of
``sample``/``eval``/``pdf`` and the tile kernel, seconds once per model structure and
machine). :func:`~brdfkit.render.shade` builds them whatever the work; a caller rendering
many models once each, small (the atlas), may weigh their build against it."""

BUILD_SECONDS = 10.0
"""Estimated seconds to build a model's shading kernels where this machine has not built any
yet (then :func:`build_kernels`' record of the last build is the estimate)."""


def compiled_shader(
    brdf: BRDF,
    lights: Sequence[Light],
    *,
    method: str,
    dtype: Any = np.float32,
    build: bool = True,
    shadows: bool = False,
) -> tuple[EnvironmentShader, list[Light]] | None:
    """The compiled shader for ``brdf`` under ``lights`` and the lights it leaves to the NumPy
    path, or ``None`` where the compiled path does not apply.

    It applies to exactly one :class:`~brdfkit.light.EnvironmentMap` plus any delta lights
    (directional, point: evaluated exactly, no samples, by the NumPy path), ``method``
    ``"auto"`` or ``"mis"``, a BRDF whose non-Lambertian part :func:`brdfkit.compiled.compile`
    compiles (no per-pixel parameters), with numba installed, or whose non-Lambertian
    part is a (constant-scaled) tabulated BRDF (:func:`brdfkit.measured.table_kernels`).
    With ``build=False`` it is returned only when it costs no compilation: the model's
    kernels are built already (with ``shadows``, the recording tile kernel), or the BRDF is
    Lambertian (no Monte Carlo).
    """
    maps = [lt for lt in lights if isinstance(lt, EnvironmentMap)]
    others = [lt for lt in lights if not isinstance(lt, EnvironmentMap)]
    if method not in METHODS or len(maps) != 1 or not all(lt.delta for lt in others):
        return None
    dtype = np.dtype(dtype)
    try:  # without numba, a table's kernels_built raises ImportError as the shader does
        if not build:
            view = shading_parts(brdf, method)[2]
            if view is not None and not kernels_built(view, dtype, maps[0].channels, shadows):
                return None
        return EnvironmentShader(brdf, maps[0], method=method, dtype=dtype), others
    except (ValueError, ImportError):
        return None


def kernels_built(
    model: BRDF, dtype: Any = np.float32, map_channels: int | None = None, shadows: bool = False
) -> bool:
    """Whether compiled shading kernels for this model exist in this process (for its
    structure: any model that differs from it in parameter values only, or for the object)
    or in the disk cache (:mod:`brdfkit.compiled.cache`: loading them compiles nothing), for a
    map of ``map_channels`` channels (``None``: 1 or 3); with ``shadows`` the recording tile
    kernel of the shadowed path. The tile kernel is looked for first: where it is missing
    (a first build) the answer needs no trace of the model, and :func:`build_kernels` starts
    its worker sooner."""
    dtype = np.dtype(dtype)
    return (
        tile_kernel_built(dtype.type, model.channels, map_channels, shadows)
        and steps_built(dtype.type)
        and _brdf_kernels_built(model, dtype)
    )


def _brdf_kernels_built(model: BRDF, dtype: np.dtype) -> bool:
    """Whether the BRDF kernels the tile kernel calls for ``model`` exist in this process (a
    table's, :func:`brdfkit.measured.table_kernels`) or are built or on disk (a compiled
    model's source and machine code: making them costs a load)."""
    table = _table_kernels(model, dtype)
    if table is not None:
        return table.built()
    if dtype in _BRDF_KERNELS.get(model, {}):
        return True
    compiled_model = compiled.compile(model, dtype)
    return all(compiled_model.cached(method, width) for method, width in _METHODS)


def pending_kernels(
    brdf: BRDF, lights: Sequence[Light], *, method: str = "auto", dtype: Any = np.float32
) -> BRDF | None:
    """The part of ``brdf`` whose shading kernels :func:`~brdfkit.render.shade` would build
    before its first tile (not built in this process, nor on disk), or ``None`` where the
    compiled path costs no build or does not apply (:func:`compiled_shader`)."""
    maps = [lt for lt in lights if isinstance(lt, EnvironmentMap)]
    others = [lt for lt in lights if not isinstance(lt, EnvironmentMap)]
    if method not in METHODS or len(maps) != 1 or not all(lt.delta for lt in others):
        return None
    if compiled_shader(brdf, lights, method=method, dtype=dtype, build=False) is not None:
        return None
    return shading_parts(brdf, method)[2]


def build_estimate() -> float:
    """Seconds that building a model's shading kernels is expected to take on this machine:
    the last build :func:`build_kernels` recorded, else :data:`BUILD_SECONDS`."""
    record = kernel_cache.load_record(_TIMINGS, _BUILD_KEY)
    seconds = None if record is None else record.get("seconds")
    return float(seconds) if isinstance(seconds, float) and seconds > 0 else BUILD_SECONDS


def build_kernels(
    brdf: BRDF, lights: Sequence[Light], *, method: str = "auto", dtype: Any = np.float32
) -> float:
    """Build (or load) the compiled shader's kernels for ``brdf`` under ``lights`` now
    (:meth:`EnvironmentShader.build`), record the seconds taken for :func:`build_estimate`
    and return them (0 where the compiled path does not apply).

    Where the tile kernel is neither built nor on disk, a worker process compiles it into the
    disk cache (:func:`_tile_worker`) while this one builds the helpers the worker will load
    (:func:`~brdfkit.render._reflection_kernels.build_tile_helpers`), the BRDF's kernels,
    the tile kernel's steps and the map's tables; this process then loads it (or, where the worker
    failed, compiles it itself). The worker is ended when this returns or raises."""
    start = time.perf_counter()
    with _tile_worker(brdf, lights, method, np.dtype(dtype)) as worker:
        if worker is not None:
            build_tile_helpers(np.dtype(dtype).type)
        plan = compiled_shader(brdf, lights, method=method, dtype=dtype)
        if plan is None:
            return 0.0
        shader = plan[0]
        prepared = shader.prepare(np.array([[0.0, 0.0, 1.0]]))  # the floor's, the map's kernels
        if worker is not None:
            worker.wait()  # the tile kernel's machine code on disk (else compiled here)
        shader.shade(prepared, samples=1)
    seconds = time.perf_counter() - start
    kernel_cache.store_record(_TIMINGS, _BUILD_KEY, {"seconds": seconds})
    return seconds


def _tile_worker(
    brdf: BRDF, lights: Sequence[Light], method: str, dtype: np.dtype
) -> contextlib.AbstractContextManager[Any]:
    """A worker process compiling the tile kernel that shading ``brdf`` under ``lights`` calls
    into the disk cache (:func:`brdfkit.compiled.worker.start`), while this process builds
    the BRDF's kernels and the map's tables; a context giving ``None`` where that kernel is
    built or on disk already, the cache is off, or the BRDF is a table's (its kernels take
    arrays: the tile kernel is compiled here)."""
    maps = [lt for lt in lights if isinstance(lt, EnvironmentMap)]
    rest = shading_parts(brdf, method)[2] if method in METHODS else None
    if len(maps) != 1 or rest is None or _is_table(rest, dtype):
        return contextlib.nullcontext()
    options = (dtype.type, rest.channels, maps[0].channels, False)
    if tile_kernel_built(*options):
        return contextlib.nullcontext()
    worker = compiled_worker.start(
        "brdfkit.render._reflection_kernels",
        "build_tile_kernel",
        dtype.name,
        *options[1:],
        absent=_NOT_FOR_KERNELS,
    )
    return contextlib.nullcontext() if worker is None else worker


_NOT_FOR_KERNELS = ("scipy",)
"""Packages the tile kernel's worker goes without: numba imports SciPy's BLAS at its first
compile only to learn whether ``np.dot`` and the like can be compiled (about a fifth of a
second of the worker's start, before its compile), which the tile kernel never calls."""


def _is_table(model: BRDF, dtype: np.dtype) -> bool:
    """Whether ``model`` is shaded by a table's kernels (:func:`brdfkit.measured.table_kernels`;
    ``False`` without numba, where nothing is compiled)."""
    try:
        return _table_kernels(model, dtype) is not None
    except ImportError:
        return False


def _table_kernels(model: BRDF, dtype: np.dtype) -> Any:
    """:func:`brdfkit.measured.table_kernels` of ``model``, without importing
    :mod:`brdfkit.measured` (~6 ms of a render's start-up) where it is not imported yet: no
    tabulated BRDF can exist then."""
    if "brdfkit.measured.tabulated" not in sys.modules:
        return None
    from brdfkit.measured import table_kernels

    return table_kernels(model, dtype)


_TIMINGS = "timings"
_BUILD_KEY = kernel_cache.key("shading kernels build")


def reflected_radiance(
    brdf: BRDF,
    light: Light | Sequence[Light],
    wo: Any,
    normal: Any | None = None,
    point: Any | None = None,
    tangent: Any | None = None,
    *,
    method: str = "auto",
    samples: int = 256,
    heuristic: str = "power",
    seed: Any = 0,
    sequence: str = "random",
    first_sample: int = 0,
    dtype: Any = np.float32,
) -> Estimate:
    """:func:`brdfkit.render.reflected_radiance` under one environment map, compiled (see
    :class:`EnvironmentShader`, which builds the kernel once for many calls)."""
    shader = EnvironmentShader(brdf, light, method=method, heuristic=heuristic, dtype=dtype)
    return shader(
        wo, normal, point, tangent, samples=samples, seed=seed, sequence=sequence,
        first_sample=first_sample,
    )  # fmt: skip


__all__ = [
    "AUTO_COMPILE_WORK",
    "BLOCK",
    "BUILD_SECONDS",
    "HEURISTICS",
    "METHODS",
    "SHADOW_SAMPLES",
    "EnvironmentShader",
    "Prepared",
    "build_estimate",
    "build_kernels",
    "compiled_shader",
    "kernels_built",
    "pending_kernels",
    "reflected_radiance",
    "shading_parts",
    "uses_irradiance",
]
