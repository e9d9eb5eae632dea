r"""The reflection equation under an environment map as one numba kernel per set of pixels.

The kernel restates :func:`brdfkit.render.reflected_radiance`'s MIS estimate (the readable
reference, ``render/reflection_equation.py``; :mod:`brdfkit.render.compiled_shading` drives
the kernel and its tests hold the two equal): per pixel, with BRDF sampling (density
:math:`p_b`) and environment-map sampling (:math:`p_l`),

.. math:: L_o \approx \frac1N \sum_{k=1}^N \Bigl[
          w_b(\omega_k)\,\frac{(f - k)\,L\cos\theta}{p_b}(\omega_k)
          + w_l(\omega'_k)\,\frac{(f - k)\,L\cos\theta}{p_l}(\omega'_k)\Bigr],
   \qquad w_b = \frac{p_b^\beta}{p_b^\beta + p_l^\beta},\;
          w_l = \frac{p_l^\beta}{p_b^\beta + p_l^\beta},

Veach's power heuristic (β = 2) or the balance heuristic (β = 1), with the control variate
:math:`k\,E(n)` taken out exactly by the driver (:func:`~brdfkit.render.diffuse_floor`; k = 0
without it). Per block of :data:`BLOCK` pixels and per sample, the kernel's steps are small
numba functions, each mirroring the NumPy code it replaces in the kernel's dtype:

- :func:`_block_loader`: the block's viewing directions, frames and control variates;
- :func:`_variate_steps` and :func:`_draw`: the uniforms of both strategies, each pixel's own
  nested-scrambled, digitally shifted Sobol' sequence (:func:`brdfkit.sampling.scrambled_sobol`:
  the scramble keys hashed from the same code) or i.i.d. points;
- :func:`_brdf_sampling`: the BRDF's ``sample`` kernel over the block (vectorised across it);
- :func:`_map_at_brdf_samples`: the map's coordinates, bilinear cell and pdf texel at those
  directions (``light/_environment_kernels.py``);
- :func:`_map_sampling`: a map sample per pixel (the guide-table texel search, the point in
  the texel and its direction, its pdf :math:`p_\omega = p_{uv}/(2\pi^2\sin\theta)`);
- :func:`_brdf_at_map_samples`: the BRDF's ``eval`` and ``pdf`` kernels at the map's samples
  above the surface only (below it the term is 0);
- :func:`_radiance_reads`: the map's bilinear radiance at both sets of directions;
- :func:`_accumulation`: the MIS weights, the control variate's terms (:func:`_mis_terms`)
  and the running mean and sum of squared deviations (Welford).

With shadows (meshes) the last step is :func:`_recording` instead: the kernel writes each
sample's two MIS terms and the world directions of its two samples, and its driver
(:meth:`brdfkit.render.compiled_shading.EnvironmentShader.shade` with ``visibility``) casts
their shadow rays through Embree in one batch, which numba cannot call, and weighs the terms
by the visibility factor :math:`V \in \{0, 1\}` before their mean: the estimate of
:math:`\int V\,(f - k)\,L\cos\theta\,d\omega` of the NumPy path.

The BRDF's kernels are those :func:`brdfkit.compiled.compile` builds from the model's own code
or a tabulated BRDF's (:func:`brdfkit.measured.table_kernels`), called through the same
convention: ``fn(parameters, *inputs, *outputs, n, *data)``, once per block (vectorised over
it). They are arguments of the tile kernel (first-class functions, called through their
addresses: :func:`brdf_functions`), so the tile kernel, most of a first build, is the same for
every BRDF: compiled once per machine, and compiled ahead of its first call
(:func:`tile_signature`, :func:`build_tile_kernel`) by a worker process while the process
that needs it builds the BRDF's kernels (:func:`brdfkit.render.compiled_shading.build_kernels`).
Loops are split so that the
unpredictable table reads (CDF searches, texel fetches) of a block overlap and the arithmetic
runs in loops LLVM vectorises (a loop holding a gather or a prefetch runs scalar); a
direction's texels are prefetched as soon as its map coordinates are known. Nothing of size
pixels × samples is stored.

References
----------
.. [1] E. Veach, L. Guibas, "Optimally combining sampling techniques for Monte Carlo
       rendering", SIGGRAPH 1995.
.. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 3rd ed., §13.6.7
       (piecewise-constant 2-D distributions), §14.2.4 (infinite area lights).
.. [3] B. P. Welford, "Note on a method for calculating corrected sums of squares and
       products", Technometrics 4(3), 1962.
"""

from __future__ import annotations

import functools
import types
from collections.abc import Callable
from typing import Any

import numpy as np

from brdfkit import sampling
from brdfkit.compiled import cache as kernel_cache
from brdfkit.compiled import kernel_tools
from brdfkit.light.environment import compiled_lookups, compiled_texel_search

BLOCK = 256
"""Pixels per call of the BRDF kernels inside the tile kernel (their vectorised batch)."""

_TILE_KERNELS: dict[tuple[Any, ...], Any] = {}


def tile_kernel(
    dtype: type,
    brdf_channels: int,
    map_channels: int,
    record: bool = False,
    load: bool = False,
) -> Callable[..., None]:
    """The kernel shading a set of pixels in ``dtype`` for any BRDF of ``brdf_channels``
    channels, built once per set of arguments, its machine code kept on disk
    (:mod:`brdfkit.compiled.cache`). With ``load`` (a caller about to shade with a BRDF
    without data arrays: a compiled model) its machine code for those calls
    (:func:`tile_signature`) is loaded now where the disk holds it, so that the first call
    runs it at once (a call numba has to type first loads every installed package's numba
    extensions beforehand, and the threads of the first tasks would wait for the load).

    It is called as ``kernel(parameters, pixels, wo, frame, points_b, digits_b, points_l,
    digits_l, seeds, image, rotation, scale, marginal, conditional, density, row_guide,
    col_guide, power, control, mean, m2, data, sample_fn, eval_fn, pdf_fn, block_keys,
    scrambled, locate, read)``, the BRDF's kernels and four block-level steps passed as
    first-class functions (:func:`brdf_functions`, :func:`step_functions`; compiled on their
    own and called through their addresses, so the tile kernel is the same for every BRDF and
    compiled once per machine, and compiled in another process while this one builds those),
    and writes each pixel's mean and sum of squared
    deviations of the MIS terms into ``mean`` and ``m2`` ``(n, C)``. The ``record`` kernel
    (shadows) writes instead each sample's two MIS terms into ``mean`` ``(n, N, 2, C)`` and
    the world directions of its two samples into ``m2`` ``(n, N, 2, 3)``, both in ``dtype``
    (:func:`_recording`): their visibility is the driver's."""
    key = (np.dtype(dtype).type, brdf_channels, map_channels, record)
    if key not in _TILE_KERNELS:
        kernel = _new_tile_kernel(*key)
        kernel_cache.enable(kernel, _tile_disk_key(*key))
        _TILE_KERNELS[key] = kernel
    kernel = _TILE_KERNELS[key]
    if load and not kernel.signatures and kernel_cache.has(_tile_disk_key(*key)):
        kernel.compile(tile_signature(*key))
    return kernel


def brdf_functions(
    functions: tuple[Callable[..., None], ...], dtype: type, brdf_channels: int, data: tuple
) -> tuple[Any, Any, Any]:
    """The BRDF's numba kernels ``functions`` (sample, eval, pdf: ``fn(parameters, *inputs,
    *outputs, n, *data)`` on flat buffers) compiled (or loaded) for the tile kernel's
    buffers in ``dtype`` and the arrays ``data``, as the first-class functions
    :func:`tile_kernel` takes."""
    return tuple(
        kernel_tools.first_class_function(fn, types)
        for fn, types in zip(functions, _brdf_argument_types(dtype, data), strict=True)
    )


def _brdf_argument_types(dtype: type, data: tuple) -> tuple[tuple[Any, ...], ...]:
    """The numba argument types of the BRDF's sample, eval and pdf kernels as the tile kernel
    calls them: ``(parameters, wo, u, wi, weight, pdf, delta, n, *data)``, ``(parameters, wi,
    wo, f, n, *data)`` and ``(parameters, wi, wo, pdf, n, *data)``, flat buffers of
    ``dtype`` (``delta`` boolean)."""
    flat = kernel_tools.array_type(dtype, 1)
    n = kernel_tools.scalar_type(np.int64)
    rest = (n, *(kernel_tools.type_of(a) for a in data))
    sample = (flat, flat, flat, flat, flat, flat, kernel_tools.array_type(np.bool_, 1), *rest)
    return sample, (flat, flat, flat, flat, *rest), (flat, flat, flat, flat, *rest)


def tile_signature(
    dtype: type, brdf_channels: int, map_channels: int, record: bool = False
) -> tuple[Any, ...]:
    """The numba argument types of :func:`tile_kernel` as
    :class:`~brdfkit.render.compiled_shading.EnvironmentShader` calls it for a BRDF without
    data arrays (a compiled model) and the map's tables
    (:func:`brdfkit.light.environment.compiled_lookups`): compiling these ahead of the
    first call (:func:`build_tile_kernel`, in another process) compiles what that call
    runs."""
    array, scalar = kernel_tools.array_type, kernel_tools.scalar_type
    t, f64, u32 = np.dtype(dtype), np.float64, np.uint32
    outputs = (array(t, 4), array(t, 4)) if record else (array(f64, 2), array(f64, 2))
    brdf = _brdf_argument_types(t.type, ())
    functions = tuple(map(kernel_tools.function_type, (*brdf, *_step_types(t.type))))
    return (
        array(t, 1), array(np.int64, 1), array(t, 2), array(t, 3),  # parameters … frame
        array(f64, 3), array(u32, 2), array(f64, 3), array(u32, 2), array(np.uint64, 1),
        array(t, 3), array(t, 2), scalar(t),  # image, rotation, scale
        array(f64, 1), array(f64, 1), array(f64, 1), array(np.uint16, 1), array(np.uint16, 1),
        scalar(np.bool_), array(t, 2), *outputs, kernel_tools.type_of(()), *functions,
    )  # fmt: skip


def build_tile_kernel(dtype: str, brdf_channels: int, map_channels: int, record: bool) -> None:
    """Compile :func:`tile_kernel` for :func:`tile_signature` into the disk cache (or find it
    there): what a worker process runs while the process that asked for it builds the
    BRDF's kernels."""
    tile_kernel(np.dtype(dtype).type, brdf_channels, map_channels, record).compile(
        tile_signature(np.dtype(dtype).type, brdf_channels, map_channels, record)
    )


def build_tile_helpers(dtype: type) -> None:
    """Compile (or load) into the disk cache the largest helpers of the tile kernel in
    ``dtype`` that a worker compiling it (:func:`build_tile_kernel`) would otherwise compile
    itself: the map's texel search (``sample_texels``) and, in float32, the sine and cosine
    of the map's sampled directions (together about a sixth of the worker's compile). The
    process that starts the worker compiles them first, in the seconds the worker takes to
    reach them; the worker then loads them (or, where it gets there first, compiles them as
    before)."""
    array, n = kernel_tools.array_type, kernel_tools.scalar_type(np.int64)
    f64, i64, guide = array(np.float64, 1), array(np.int64, 1), array(np.uint16, 1)
    search = compiled_texel_search(kernel_tools)
    search.compile((f64, f64, f64, f64, guide, guide, n, n, n, i64, i64, i64))
    _, sin, cos = kernel_tools.trigonometry(dtype)
    for function in (sin, cos):
        if kernel_cache.key_of(function) is not None:  # kept on disk: float32's
            function.compile((kernel_tools.scalar_type(dtype),))


def tile_kernel_built(
    dtype: type, brdf_channels: int, map_channels: int | None, record: bool = False
) -> bool:
    """Whether a tile kernel (the ``record`` one: :func:`tile_kernel`) is compiled in this
    process, or its machine code is on disk, for a map of ``map_channels`` channels
    (``None``: 1 or 3); the steps it calls are :func:`steps_built`'s."""
    for channels in (map_channels,) if map_channels is not None else (1, 3):
        tile = _TILE_KERNELS.get((np.dtype(dtype).type, brdf_channels, channels, record))
        if tile is not None and tile.signatures:
            return True
        if kernel_cache.has(_tile_disk_key(dtype, brdf_channels, channels, record)):
            return True
    return False


def _tile_disk_key(dtype: type, brdf_channels: int, map_channels: int, record: bool) -> str:
    """The disk-cache key of a tile kernel: its options (the BRDF's kernels are arguments)."""
    options = (np.dtype(dtype).str, brdf_channels, map_channels, BLOCK)
    return kernel_cache.key("tile", *options, *(("record",) if record else ()))


def _new_tile_kernel(
    dtype: type, brdf_channels: int, map_channels: int, record: bool
) -> Callable[..., None]:
    """The tile kernel (module docstring) composed of its steps, in dtype ``dtype`` (the map's
    CDF searches in float64, as :class:`~brdfkit.sampling.Distribution2D`); with ``record``
    the recording kernel (:func:`tile_kernel`)."""
    env = compiled_lookups(dtype, kernel_tools)
    return _tile_loop(
        dtype,
        brdf_channels,
        map_channels,
        _block_loader(brdf_channels, max(brdf_channels, map_channels)),
        _draw(),
        _brdf_sampling(dtype),
        _map_sampling(env, dtype),
        _brdf_at_map_samples(dtype, brdf_channels),
        (_recording if record else _accumulation)(env, dtype, brdf_channels, map_channels),
    )


def _block_loader(brdf_channels: int, channels: int) -> Callable[..., None]:
    """``load_block(pixels, start, nb, wo, frame, control, wo_buf, frames, controls, mean_b,
    m2_b)``: the block's viewing directions, its frames ``frames[3 i + k, j] = frame[pixel
    j, i, k]`` and control variates ``controls[c, j]`` (contiguous along the block, so that
    the loops over it vectorise), and its running means and sums set to 0."""

    @kernel_tools.inline_jit()
    def load_block(pixels: np.ndarray, start: int, nb: int, wo: np.ndarray, frame: np.ndarray,
                   control: np.ndarray, wo_buf: np.ndarray, frames: np.ndarray,
                   controls: np.ndarray, mean_b: np.ndarray, m2_b: np.ndarray) -> None:  # fmt: skip
        for j in range(nb):
            p = pixels[start + j]
            for k in range(3):
                wo_buf[j * 3 + k] = wo[p, k]
            for i in range(9):
                frames[i, j] = frame[p, i // 3, i % 3]
            for c in range(brdf_channels):
                controls[c, j] = control[p, c]
            for c in range(channels):
                mean_b[c, j] = 0.0
                m2_b[c, j] = 0.0

    return load_block


@functools.cache
def _variate_steps() -> tuple[Callable[..., None], Callable[..., None]]:
    """``(block_keys, scrambled)``: ``block_keys(seeds, stream, pixels, start, nb, out)``, the
    block's pixels' scramble keys of ``stream`` (``sampling.scramble_keys`` of their seeds:
    ``key_hash`` of ``key_slot``, the same code jitted) as ``out`` ``(2, d, nb)``; and
    ``scrambled(digits, keys, s, nb, out)``, sample ``s`` of each dimension's Sobol' digits
    Laine–Karras scrambled by the pixels' keys, bit-reversed and shifted
    (``sampling.scrambled_sobol``; one integer loop per dimension over the block, which LLVM
    vectorises), as ``out`` ``(d, nb)``. Block-level steps: first-class functions of the
    tile kernel (:func:`step_functions`)."""
    jit = kernel_tools.jit()
    reverse_bits, laine_karras = jit(sampling.reverse_bits), jit(sampling.laine_karras)
    key_hash = jit(
        types.FunctionType(
            sampling.key_hash.__code__, {**vars(sampling), "_mix64": jit(sampling._mix64)}
        )
    )
    key_slot = jit(sampling.key_slot)
    unit_interval = 2.0**-sampling.SOBOL_BITS

    @kernel_tools.step_jit()
    def block_keys(seeds: np.ndarray, stream: int, pixels: np.ndarray, start: int, nb: int,
                   out: np.ndarray) -> None:  # fmt: skip
        d = out.shape[1]
        for j in range(nb):
            seed = np.uint64(seeds[pixels[start + j]])
            for i in range(2):
                for k in range(d):
                    out[i, k, j] = key_hash(seed, key_slot(stream, i * d + k))

    @kernel_tools.step_jit()
    def scrambled(digits: np.ndarray, keys: np.ndarray, s: int, nb: int,
                  out: np.ndarray) -> None:  # fmt: skip
        for k in range(digits.shape[1]):
            d = np.uint64(digits[s, k])
            for j in range(nb):
                x = reverse_bits(laine_karras(d, keys[0, k, j])) ^ keys[1, k, j]
                out[k, j] = np.float64(np.int64(x)) * unit_interval  # x < 2^32: exact

    return block_keys, scrambled


_STEPS: dict[type, tuple[Callable[..., None], ...]] = {}


def step_functions(dtype: type) -> tuple[Any, ...]:
    """The tile kernel's block-level steps compiled on their own (their machine code on
    disk) as the first-class functions :func:`tile_kernel` takes last: the Sobol' variates'
    ``block_keys`` and ``scrambled`` (:func:`_variate_steps`), the map at the BRDF's
    samples, ``locate`` (:func:`_map_at_brdf_samples`), and the texel reads, ``read``
    (:func:`_radiance_reads`). The process that builds the BRDF's kernels builds these too,
    while a worker compiles the rest of the tile kernel (:func:`build_tile_kernel`), so that
    the two processes take about equal shares of a first build. Each is called once per
    block and sample at most; called through their addresses, ``locate`` and ``read`` make
    the kernel about 2 % slower (the map's sampling, the other step of their size, made it
    10–15 % slower and stays in the tile kernel)."""
    dtype = np.dtype(dtype).type
    if dtype not in _STEPS:
        env = compiled_lookups(dtype, kernel_tools)
        steps = (*_variate_steps(), _map_at_brdf_samples(env), _radiance_reads(env, dtype))
        for name, step in zip(_STEP_NAMES, steps, strict=True):
            if not step.signatures:  # not yet compiled in this process: from disk
                kernel_cache.enable(step, _step_key(name, dtype))
        _STEPS[dtype] = steps
    return tuple(
        kernel_tools.first_class_function(step, arguments)
        for step, arguments in zip(_STEPS[dtype], _step_types(dtype), strict=True)
    )


_STEP_NAMES = ("block keys", "scrambled digits", "map lookup", "radiance reads")


def _step_key(name: str, dtype: type) -> str:
    """The disk-cache key of the step ``name`` of :func:`step_functions`."""
    return kernel_cache.key("tile step", name, np.dtype(dtype).str)


def _step_types(dtype: type) -> tuple[tuple[Any, ...], ...]:
    """The numba argument types of :func:`step_functions`' steps in ``dtype`` as the tile
    kernel calls them."""
    array, n = kernel_tools.array_type, kernel_tools.scalar_type(np.int64)
    t, t2 = array(dtype, 1), array(dtype, 2)
    i1, i2, f1 = array(np.int64, 1), array(np.int64, 2), array(np.float64, 1)
    keys = array(np.uint64, 3)
    block_keys = (array(np.uint64, 1), n, i1, n, n, keys)
    scrambled = (array(np.uint32, 2), keys, n, n, array(np.float64, 2))
    locate = (n, t, t2, t, f1, t2, n, n, n, t, i2, t2, i1)
    read = (n, t, f1, kernel_tools.scalar_type(dtype), i2, t2, i1, i2, t2, t2, t2, t)
    return block_keys, scrambled, locate, read


def steps_built(dtype: type) -> bool:
    """Whether :func:`step_functions`' steps are compiled in this process or on disk."""
    steps = _STEPS.get(np.dtype(dtype).type)
    if steps is not None and all(step.signatures for step in steps):
        return True
    return all(kernel_cache.has(_step_key(name, dtype)) for name in _STEP_NAMES)


def _draw() -> Callable[..., None]:
    """``draw(s, start, nb, pixels, sequences, keys, scrambled, u_b, u_l)``: sample ``s`` of
    the BRDF's (3-D) and the map's (2-D) uniforms of the block, ``(d, nb)`` each: the
    pixels' scrambled Sobol' points (``scrambled``, :func:`_variate_steps`) or the i.i.d.
    ``points`` of the NumPy path."""

    @kernel_tools.inline_jit()
    def draw(s: int, start: int, nb: int, pixels: np.ndarray, sequences: tuple, keys: tuple,
             scrambled: Any, u_b: np.ndarray, u_l: np.ndarray) -> None:  # fmt: skip
        points_b, digits_b, points_l, digits_l = sequences
        if digits_b.shape[0] > 0:
            scrambled(digits_b, keys[0], s, nb, u_b)
            scrambled(digits_l, keys[1], s, nb, u_l)
            return
        for j in range(nb):
            p = pixels[start + j]
            for k in range(3):
                u_b[k, j] = points_b[p, s, k]
            for k in range(2):
                u_l[k, j] = points_l[p, s, k]

    return draw


def _brdf_sampling(dtype: type) -> Callable[..., None]:
    """``sample_brdf(params, data, sample_fn, nb, u_b, wo_buf, u_buf, brdf)``: the BRDF's
    ``sample`` kernel on the block's uniforms (rounded to the dtype), into ``brdf = (wi,
    weight, pdf, delta)``."""

    @kernel_tools.inline_jit()
    def sample_brdf(params: np.ndarray, data: tuple, sample_fn: Any, nb: int, u_b: np.ndarray,
                    wo_buf: np.ndarray, u_buf: np.ndarray, brdf: tuple) -> None:  # fmt: skip
        wi_buf, wt_buf, pdf_buf, delta_buf = brdf
        for j in range(nb):
            for k in range(3):
                u_buf[j * 3 + k] = dtype(u_b[k, j])
        sample_fn(params, wo_buf, u_buf, wi_buf, wt_buf, pdf_buf, delta_buf, nb, *data)

    return sample_brdf


def _map_at_brdf_samples(env: Any) -> Callable[..., None]:
    """``locate(nb, wi_buf, frames, texels, density, rot, height, width, nc, sin_b, cells_b,
    weights_b, density_b)``: the BRDF's sampled directions in the world (the block's frames),
    unit, then their map coordinates' sin θ, bilinear cells (``env.texel_cell``) and pdf
    texels (``env.pdf_texel``); then the texels' rows and the pdf's texel prefetched.
    ``texels`` the flat image, ``rot`` the map's rotation. A block-level step
    (:func:`step_functions`)."""
    prefetch = kernel_tools.prefetch()
    unit, map_coordinates = env.unit, env.map_coordinates
    texel_cell, pdf_texel = env.texel_cell, env.pdf_texel

    @kernel_tools.step_jit()
    def locate(nb: int, wi_buf: np.ndarray, frames: np.ndarray, texels: np.ndarray,
               density: np.ndarray, rot: np.ndarray, height: int, width: int, nc: int,
               sin_b: np.ndarray, cells_b: np.ndarray, weights_b: np.ndarray,
               density_b: np.ndarray) -> None:  # fmt: skip
        r = (rot[0, 0], rot[0, 1], rot[0, 2], rot[1, 0], rot[1, 1], rot[1, 2], rot[2, 0],
             rot[2, 1], rot[2, 2])  # fmt: skip
        for j in range(nb):
            v0, v1, v2 = wi_buf[j * 3], wi_buf[j * 3 + 1], wi_buf[j * 3 + 2]
            wx = v0 * frames[0, j] + v1 * frames[3, j] + v2 * frames[6, j]
            wy = v0 * frames[1, j] + v1 * frames[4, j] + v2 * frames[7, j]
            wz = v0 * frames[2, j] + v1 * frames[5, j] + v2 * frames[8, j]
            ux, uy, uz = unit(wx, wy, wz)
            x, y, sin_b[j] = map_coordinates(ux, uy, uz, r)
            i00, i01, i10, i11, fr, fc = texel_cell(x, y, height, width, nc)
            cells_b[0, j], cells_b[1, j], cells_b[2, j], cells_b[3, j] = i00, i01, i10, i11
            weights_b[0, j], weights_b[1, j] = fr, fc
            density_b[j] = pdf_texel(x, y, height, width)
        for j in range(nb):  # the lookup's two texel rows, the pdf's texel
            prefetch(texels, cells_b[0, j])
            prefetch(texels, cells_b[2, j])
            prefetch(density, max(density_b[j], 0))

    return locate


def _map_sampling(env: Any, dtype: type) -> Callable[..., None]:
    """``sample_map(nb, u_l, view, cdfs, frames, scratch, cells_l, weights_l, pdf_l, wil_buf,
    cos_l)``: ``EnvironmentMap.sample`` per pixel: the texel search (``env.sample_texels``
    on the float64 uniforms, clamped below 1 as ``Distribution2D.sample`` does), the texels'
    CDF nodes and density (gathers in a loop of their own), then the point in the texel
    (``env.sample_point``), its bilinear cell, solid-angle pdf and direction in the pixel's
    frame with cos θ; finally the texels' rows prefetched. ``cdfs = (marginal, conditional,
    row_guide, col_guide)``; ``scratch`` the float64 uniforms, texels and CDF nodes."""
    prefetch = kernel_tools.prefetch()
    sample_texels, sample_point = env.sample_texels, env.sample_point
    sample_direction, texel_cell = env.sample_direction, env.texel_cell
    solid_angle_pdf = env.solid_angle_pdf
    zero = dtype(0)
    below_one_64 = 1 - np.finfo(np.float64).eps / 2

    @kernel_tools.inline_jit()
    def sample_map(nb: int, u_l: np.ndarray, view: tuple, cdfs: tuple, frames: np.ndarray,
                   scratch: tuple, cells_l: np.ndarray, weights_l: np.ndarray,
                   pdf_l: np.ndarray, wil_buf: np.ndarray, cos_l: np.ndarray) -> None:  # fmt: skip
        texels, density, r, height, width, nc = view
        marginal, conditional, row_guide, col_guide = cdfs
        a_buf, b_buf, rows, cols, base, m0_l, m1_l, c0_l, c1_l, pdf_uv = scratch
        for j in range(nb):
            a, b = dtype(u_l[0, j]), dtype(u_l[1, j])
            a_buf[j] = min(np.float64(a), below_one_64)
            b_buf[j] = min(np.float64(b), below_one_64)
        sample_texels(a_buf, b_buf, marginal, conditional, row_guide, col_guide, height, width,
                      nb, rows, cols, base)  # fmt: skip
        for j in range(nb):  # the found cells' CDF nodes and pdf
            row, col, at = rows[j], cols[j], base[j] + cols[j]
            m0_l[j], m1_l[j] = marginal[row], marginal[row + 1]
            c0_l[j], c1_l[j] = conditional[at], conditional[at + 1]
            pdf_uv[j] = dtype(density[row * width + col])
        for j in range(nb):
            x, y = sample_point(a_buf[j], b_buf[j], rows[j], cols[j], m0_l[j], m1_l[j], c0_l[j],
                                c1_l[j], height, width)  # fmt: skip
            i00, i01, i10, i11, fr, fc = texel_cell(x, y, height, width, nc)
            cells_l[0, j], cells_l[1, j], cells_l[2, j], cells_l[3, j] = i00, i01, i10, i11
            weights_l[0, j], weights_l[1, j] = fr, fc
            lx, ly, lz, sin_theta = sample_direction(x, y, r)
            pdf_l[j] = solid_angle_pdf(pdf_uv[j], sin_theta)
            for k in range(3):
                wil_buf[j * 3 + k] = (
                    lx * frames[3 * k, j] + ly * frames[3 * k + 1, j] + lz * frames[3 * k + 2, j]
                )
            cos_l[j] = max(wil_buf[j * 3 + 2], zero)
        for j in range(nb):
            prefetch(texels, cells_l[0, j])
            prefetch(texels, cells_l[2, j])

    return sample_map


def _brdf_at_map_samples(dtype: type, brdf_channels: int) -> Callable[..., None]:
    """``evaluate(params, data, eval_fn, pdf_fn, nb, cos_l, wil_buf, wo_buf, compact, f_buf,
    pbl_buf)``: the BRDF's ``eval`` and ``pdf`` kernels at the map's samples above the
    surface, compacted
    into ``compact = (above, wi, wo, f, pdf)`` (about half of them: below it f = 0 and
    p_b = 0, and the term, times cos θ = 0, is 0), then spread back to ``f_buf`` and
    ``pbl_buf`` with zeros elsewhere."""
    zero = dtype(0)

    @kernel_tools.inline_jit()
    def evaluate(params: np.ndarray, data: tuple, eval_fn: Any, pdf_fn: Any, nb: int,
                 cos_l: np.ndarray, wil_buf: np.ndarray, wo_buf: np.ndarray, compact: tuple,
                 f_buf: np.ndarray, pbl_buf: np.ndarray) -> None:  # fmt: skip
        above, wic_buf, woc_buf, fc_buf, pbc_buf = compact
        live = 0
        for j in range(nb):
            if cos_l[j] > zero:
                above[live] = j
                for k in range(3):
                    wic_buf[live * 3 + k] = wil_buf[j * 3 + k]
                    woc_buf[live * 3 + k] = wo_buf[j * 3 + k]
                live += 1
        eval_fn(params, wic_buf, woc_buf, fc_buf, live, *data)
        pdf_fn(params, wic_buf, woc_buf, pbc_buf, live, *data)
        for j in range(nb):
            pbl_buf[j] = zero
            for c in range(brdf_channels):
                f_buf[j * brdf_channels + c] = zero
        for i in range(live):
            j = above[i]
            pbl_buf[j] = pbc_buf[i]
            for c in range(brdf_channels):
                f_buf[j * brdf_channels + c] = fc_buf[i * brdf_channels + c]

    return evaluate


def _radiance_reads(env: Any, dtype: type) -> Callable[..., None]:
    """``read(nb, texels, density, scale, cells_b, weights_b, density_b, cells_l, weights_l,
    radiance_b, radiance_l, p_texel)``: the texel reads: the map's bilinear radiance at the
    BRDF's samples (at their directions' coordinates) and at its own (at the sampled
    coordinates: the NumPy path converts them to a direction and back, equal to rounding),
    and the map's pdf texel at the BRDF's samples. ``texels`` the flat image. A block-level
    step (:func:`step_functions`)."""
    bilinear = env.bilinear

    @kernel_tools.step_jit()
    def read(nb: int, texels: np.ndarray, density: np.ndarray, scale: Any, cells_b: np.ndarray,
             weights_b: np.ndarray, density_b: np.ndarray, cells_l: np.ndarray,
             weights_l: np.ndarray, radiance_b: np.ndarray, radiance_l: np.ndarray,
             p_texel: np.ndarray) -> None:  # fmt: skip
        for j in range(nb):
            bilinear(texels, cells_b, weights_b, j, scale, radiance_b)
            p_texel[j] = dtype(density[max(density_b[j], 0)])
            bilinear(texels, cells_l, weights_l, j, scale, radiance_l)

    return read


def _mis_terms(env: Any, dtype: type, brdf_channels: int, map_channels: int) -> tuple:
    r"""``(pixel_weights, channel_terms)``: ``pixel_weights(j, power, brdf, light,
    brdf_at_light)`` the MIS weights of pixel ``j``'s two samples and the BRDF sample's
    :math:`\cos\theta/p_b`; ``channel_terms(j, c, weights, brdf, light, brdf_at_light,
    controls, radiance_b, radiance_l)`` one sample's two MIS terms of pixel ``j`` and channel
    ``c`` (module docstring), the BRDF
    sample's :math:`w_b (f - k) L\cos\theta / p_b` and the map sample's
    :math:`w_l (f - k) L\cos\theta / p_l`, in the kernel's dtype:

    - the weights :math:`w_b` (1 for a delta sample) and :math:`w_l` of the power or balance
      heuristic, ``safe_div(p^β, p^β + q^β)``, with :math:`p_l` at the BRDF's sample from its
      pdf texel (0 outside the map);
    - the control variate: :math:`(f - k)\cos\theta/p_b = w - k\cos\theta/p_b` of the
      BRDF's sample (its weight :math:`w`), :math:`(f - k)` at the map's.

    ``brdf = (wi, weight, pdf, delta)`` of the BRDF's samples, ``light = (pdf_l, cos_l,
    density_b, p_texel, sin_b)``, ``brdf_at_light = (f_buf, pbl_buf)``."""
    select = kernel_tools.select()
    solid_angle_pdf = env.solid_angle_pdf
    zero, one = dtype(0), dtype(1)
    cb_step = 1 if brdf_channels > 1 else 0
    cl_step = 1 if map_channels > 1 else 0

    @kernel_tools.jit()
    def weight(p: Any, q: Any, power: bool) -> Any:
        """safe_div(p^β, p^β + q^β)."""
        if power:
            p, q = p * p, q * q
        total = p + q
        return select(total != zero, p / select(total != zero, total, one), zero)

    @kernel_tools.inline_jit()
    def pixel_weights(j: int, power: bool, brdf: tuple, light: tuple,
                      brdf_at_light: tuple) -> tuple:  # fmt: skip
        wi_buf, _, pdf_buf, delta_buf = brdf
        pdf_l, _, density_b, p_texel, sin_b = light
        pb, pl = pdf_buf[j], pdf_l[j]
        # EnvironmentMap.pdf at the BRDF's sample
        p_light = select(density_b[j] >= 0, solid_angle_pdf(p_texel[j], sin_b[j]), zero)
        w_b = select(delta_buf[j], one, weight(pb, p_light, power))
        w_l = weight(pl, brdf_at_light[1][j], power)
        upper = wi_buf[j * 3 + 2] > zero
        cos_over_p = select(pb != zero, wi_buf[j * 3 + 2] / select(pb != zero, pb, one), zero)
        return w_b, w_l, upper, cos_over_p

    @kernel_tools.inline_jit()
    def channel_terms(j: int, c: int, weights: tuple, brdf: tuple, light: tuple,
                      brdf_at_light: tuple, controls: np.ndarray, radiance_b: np.ndarray,
                      radiance_l: np.ndarray) -> tuple:  # fmt: skip
        w_b, w_l, upper, cos_over_p = weights
        wt_buf, pl, cos_l, f_buf = brdf[1], light[0][j], light[1], brdf_at_light[0]
        k_c = controls[c * cb_step, j]
        k = k_c * cos_over_p  # (f − k)·cos/p
        term = (wt_buf[j * brdf_channels + c * cb_step] - k) * radiance_b[c * cl_step, j]
        term_b = select(upper, term * w_b, zero * w_b)
        radiance = radiance_l[c * cl_step, j]
        value = select(pl != zero, radiance / select(pl != zero, pl, one), zero)
        c_l = (f_buf[j * brdf_channels + c * cb_step] - k_c) * value
        return term_b, c_l * cos_l[j] * w_l

    return pixel_weights, channel_terms


def _accumulation(env: Any, dtype: type, brdf_channels: int, map_channels: int) -> tuple:
    r"""``(accumulate, flush)``: ``accumulate(nb, s, start, power, brdf, light,
    brdf_at_light, controls, radiance_b, radiance_l, frames, wil_buf, mean_b, m2_b, mean,
    m2)`` folds sample ``s``'s MIS estimate per pixel and channel (the sum of
    :func:`_mis_terms`) into the block's running mean and sum of squared deviations
    (Welford, in float64); ``flush(start, nb, mean_b, m2_b, mean, m2)`` writes the block's
    into the outputs. The loop is straight-line, so LLVM vectorises it."""
    pixel_weights, channel_terms = _mis_terms(env, dtype, brdf_channels, map_channels)
    channels = max(brdf_channels, map_channels)

    @kernel_tools.inline_jit()
    def running_mean(mean_b: np.ndarray, m2_b: np.ndarray, c: int, j: int, x: float,
                     inverse_count: float) -> None:  # fmt: skip
        previous = mean_b[c, j]
        current = previous + (x - previous) * inverse_count
        mean_b[c, j] = current
        m2_b[c, j] += (x - previous) * (x - current)

    @kernel_tools.inline_jit()
    def accumulate(nb: int, s: int, start: int, power: bool, brdf: tuple, light: tuple,
                   brdf_at_light: tuple, controls: np.ndarray, radiance_b: np.ndarray,
                   radiance_l: np.ndarray, frames: np.ndarray, wil_buf: np.ndarray,
                   mean_b: np.ndarray, m2_b: np.ndarray, mean: np.ndarray,
                   m2: np.ndarray) -> None:  # fmt: skip
        inverse_count = 1.0 / (s + 1)
        for j in range(nb):
            weights = pixel_weights(j, power, brdf, light, brdf_at_light)
            for c in range(channels):
                term_b, term_l = channel_terms(j, c, weights, brdf, light, brdf_at_light,
                                               controls, radiance_b, radiance_l)  # fmt: skip
                running_mean(mean_b, m2_b, c, j, np.float64(term_b + term_l), inverse_count)

    @kernel_tools.inline_jit()
    def flush(start: int, nb: int, mean_b: np.ndarray, m2_b: np.ndarray, mean: np.ndarray,
              m2: np.ndarray) -> None:  # fmt: skip
        for j in range(nb):
            for c in range(channels):
                mean[start + j, c] = mean_b[c, j]
                m2[start + j, c] = m2_b[c, j]

    return accumulate, flush


def _recording(env: Any, dtype: type, brdf_channels: int, map_channels: int) -> tuple:
    r"""``(record, flush)`` of the recording kernel (shadows: :func:`tile_kernel` with
    ``record``): ``record(...)`` (:func:`_accumulation`'s arguments) writes sample ``s``'s two
    MIS terms per pixel and channel (:func:`_mis_terms`) into ``terms[pixel, s, strategy, c]``
    and the world directions of both samples (the local ones turned by the pixel's frame, as
    the NumPy path's ``to_world``) into ``directions[pixel, s, strategy]``, for the shadow
    rays that the driver casts in between; ``flush`` does nothing."""
    pixel_weights, channel_terms = _mis_terms(env, dtype, brdf_channels, map_channels)
    channels = max(brdf_channels, map_channels)

    @kernel_tools.inline_jit()
    def record(nb: int, s: int, start: int, power: bool, brdf: tuple, light: tuple,
               brdf_at_light: tuple, controls: np.ndarray, radiance_b: np.ndarray,
               radiance_l: np.ndarray, frames: np.ndarray, wil_buf: np.ndarray,
               mean_b: np.ndarray, m2_b: np.ndarray, terms_out: np.ndarray,
               directions: np.ndarray) -> None:  # fmt: skip
        wi_buf = brdf[0]
        for j in range(nb):
            p = start + j
            weights = pixel_weights(j, power, brdf, light, brdf_at_light)
            for c in range(channels):
                term_b, term_l = channel_terms(j, c, weights, brdf, light, brdf_at_light,
                                               controls, radiance_b, radiance_l)  # fmt: skip
                terms_out[p, s, 0, c] = term_b
                terms_out[p, s, 1, c] = term_l
            for i in range(3):
                directions[p, s, 0, i] = (
                    wi_buf[j * 3] * frames[i, j] + wi_buf[j * 3 + 1] * frames[3 + i, j]
                    + wi_buf[j * 3 + 2] * frames[6 + i, j]
                )  # fmt: skip
                directions[p, s, 1, i] = (
                    wil_buf[j * 3] * frames[i, j] + wil_buf[j * 3 + 1] * frames[3 + i, j]
                    + wil_buf[j * 3 + 2] * frames[6 + i, j]
                )  # fmt: skip

    @kernel_tools.inline_jit()
    def flush(start: int, nb: int, mean_b: np.ndarray, m2_b: np.ndarray, terms_out: np.ndarray,
              directions: np.ndarray) -> None:  # fmt: skip
        return

    return record, flush


def _tile_loop(
    dtype: type,
    brdf_channels: int,
    map_channels: int,
    load_block: Callable[..., None],
    draw: Callable[..., None],
    sample_brdf: Callable[..., None],
    sample_map: Callable[..., None],
    evaluate: Callable[..., None],
    finish: tuple[Callable[..., None], Callable[..., None]],
) -> Callable[..., None]:
    """The tile kernel: its scratch buffers (a few per block, along the block), then per
    block of :data:`BLOCK` pixels and per sample the steps in turn, and each pixel's mean and
    sum of squared deviations."""
    accumulate, flush = finish
    T, B, CB = dtype, BLOCK, BLOCK * brdf_channels
    channels = max(brdf_channels, map_channels)
    f64, i64 = np.float64, np.int64
    empty, flat = kernel_tools.empty(), kernel_tools.flat()

    @kernel_tools.jit()
    def shade(params: np.ndarray, pixels: np.ndarray, wo: np.ndarray, frame: np.ndarray,
              points_b: np.ndarray, digits_b: np.ndarray, points_l: np.ndarray,
              digits_l: np.ndarray, seeds: np.ndarray, image: np.ndarray, rot: np.ndarray,
              scale: Any, marginal: np.ndarray, conditional: np.ndarray, density: np.ndarray,
              row_guide: np.ndarray, col_guide: np.ndarray, power: bool, control: np.ndarray,
              mean: np.ndarray, m2: np.ndarray, data: tuple, sample_fn: Any, eval_fn: Any,
              pdf_fn: Any, block_keys: Any, scrambled: Any, locate: Any,
              read: Any) -> None:  # fmt: skip
        r = (rot[0, 0], rot[0, 1], rot[0, 2], rot[1, 0], rot[1, 1], rot[1, 2], rot[2, 0],
             rot[2, 1], rot[2, 2])  # fmt: skip
        texels, (height, width, nc) = flat(image), image.shape
        view = (texels, density, r, height, width, nc)
        cdfs = (marginal, conditional, row_guide, col_guide)
        sequences = (points_b, digits_b, points_l, digits_l)
        samples = max(points_b.shape[1], digits_b.shape[0])
        # the block's viewing directions, frames, control variates and uniforms
        wo_buf, frames = empty(B * 3, T), empty((9, B), T)
        controls = empty((brdf_channels, B), T)
        keys = (empty((2, 3, B), np.uint64), empty((2, 2, B), np.uint64))
        u_b, u_l, u_buf = empty((3, B), f64), empty((2, B), f64), empty(B * 3, T)
        # the BRDF's samples (wi, weight, pdf, delta), and the map there: sin θ, cells, pdf
        brdf = (empty(B * 3, T), empty(CB, T), empty(B, T), empty(B, np.bool_))
        sin_b, density_b = empty(B, T), empty(B, i64)
        cells_b, weights_b = empty((4, B), i64), empty((2, B), T)
        # the map's samples: variates, texels, CDF nodes, density; cells, pdf, direction
        searched = (empty(B, f64), empty(B, f64), empty(B, i64), empty(B, i64),
                    empty(B, i64))  # fmt: skip
        nodes = (empty(B, f64), empty(B, f64), empty(B, f64), empty(B, f64))
        scratch = (*searched, *nodes, empty(B, T))
        cells_l, weights_l = empty((4, B), i64), empty((2, B), T)
        pdf_l, wil_buf, cos_l = empty(B, T), empty(B * 3, T), empty(B, T)
        # the BRDF at the map's samples above the surface, compacted, then spread out
        compact = (empty(B, i64), empty(B * 3, T), empty(B * 3, T), empty(CB, T),
                   empty(B, T))  # fmt: skip
        f_buf, pbl_buf = empty(CB, T), empty(B, T)
        # the radiance at both, the map's pdf texel at the BRDF's; the running statistics
        radiance_b, radiance_l = empty((map_channels, B), T), empty((map_channels, B), T)
        p_texel = empty(B, T)
        mean_b, m2_b = empty((channels, B), f64), empty((channels, B), f64)
        light = (pdf_l, cos_l, density_b, p_texel, sin_b)
        for start in range(0, pixels.shape[0], B):
            nb = min(B, pixels.shape[0] - start)
            if digits_b.shape[0] > 0:
                for stream in range(2):  # a variable: one compile, not one per literal
                    block_keys(seeds, stream, pixels, start, nb, keys[stream])
            load_block(pixels, start, nb, wo, frame, control, wo_buf, frames, controls, mean_b,
                       m2_b)  # fmt: skip
            for s in range(samples):
                draw(s, start, nb, pixels, sequences, keys, scrambled, u_b, u_l)
                sample_brdf(params, data, sample_fn, nb, u_b, wo_buf, u_buf, brdf)
                locate(nb, brdf[0], frames, texels, density, rot, height, width, nc, sin_b,
                       cells_b, weights_b, density_b)  # fmt: skip
                sample_map(nb, u_l, view, cdfs, frames, scratch, cells_l, weights_l, pdf_l,
                           wil_buf, cos_l)  # fmt: skip
                evaluate(params, data, eval_fn, pdf_fn, nb, cos_l, wil_buf, wo_buf, compact, f_buf,
                         pbl_buf)  # fmt: skip
                read(nb, texels, density, scale, cells_b, weights_b, density_b, cells_l,
                     weights_l, radiance_b, radiance_l, p_texel)  # fmt: skip
                accumulate(nb, s, start, power, brdf, light, (f_buf, pbl_buf), controls,
                           radiance_b, radiance_l, frames, wil_buf, mean_b, m2_b, mean,
                           m2)  # fmt: skip
            flush(start, nb, mean_b, m2_b, mean, m2)

    return shade
