r"""Shading under one environment map as one compiled kernel per tile.

:func:`brdfkit.render.reflected_radiance` estimates, per pixel, with MIS of BRDF sampling
and environment-map sampling,

.. math:: L_o \approx \frac1N \sum_{k=1}^N \Bigl[
          w_b(\omega_k)\,\frac{f\,L\cos\theta}{p_b}(\omega_k)
          + w_l(\omega'_k)\,\frac{f\,L\cos\theta}{p_l}(\omega'_k)\Bigr],
   \qquad w_b = \frac{p_b^\beta}{p_b^\beta + p_l^\beta},\;
          w_l = \frac{p_l^\beta}{p_b^\beta + p_l^\beta},

(Veach's power heuristic β = 2, or the balance heuristic β = 1) on NumPy arrays of
pixels × samples. Profiled, about 40 % of its time is the BRDF and 40 % the map: the bilinear
lookup, the binary searches in its CDFs and the direction ↔ map-coordinate conversions. Those
cannot be traced by :mod:`brdfkit.compiled` (indexing, searches), so this module writes
them once as small numba functions and calls, from one ``numba.njit(nogil=True)`` loop per block of
pixels, the BRDF kernels that :func:`brdfkit.compiled.compile` builds from the model's own code:

- per sample k, the BRDF's ``sample`` kernel over the block's pixels (vectorised across them);
- per pixel, the map's radiance and pdf at the BRDF's direction, a map sample (the marginal
  CDF over rows, then the row's conditional CDF over columns: the intervals of
  :class:`~brdfkit.sampling.Distribution2D`'s bisection, found from guide tables built once
  per map, :func:`map_guides`), its radiance
  and the solid-angle pdf
  :math:`p_\omega = p_{uv}/(2\pi^2\sin\theta)`;
- the BRDF's ``eval`` and ``pdf`` kernels at the map's directions above the surface
  (compacted: below it the term is 0), then the MIS sum.

Nothing of size pixels × samples is stored: the scratch memory is a few buffers per block.
The uniforms are those of the NumPy path (the same generator calls in the same order: per
pixel and strategy its own nested-scrambled, digitally shifted Sobol' sequence,
:func:`brdfkit.sampling.scrambled_sobol`, whose hash the kernel evaluates from the same code,
or i.i.d. uniforms), so with ``dtype=float64`` the image equals :func:`~brdfkit.render.shade`'s to
rounding, and with float32 to float32 precision away from the rare samples whose texel flips.
Lambertian lobes are taken out as :math:`\rho E(n)/\pi` as in ``method="auto"``
(:func:`~brdfkit.render.split_diffuse`), a smooth plastic's mirror as
:math:`sF(\theta_o)L(\omega_r)` (:func:`~brdfkit.render.split_mirror`), and so is the
control variate :math:`k\,E(n)` of the rest (:func:`~brdfkit.render.diffuse_floor`: k
from the compiled ``eval``, the kernel samples f − k). Blocks run on
:func:`brdfkit.compiled.kernel_tools.threads`
threads (the kernel releases the GIL).

References
----------
.. [1] E. Veach, L. Guibas, "Optimally combining sampling techniques for Monte Carlo
       rendering", SIGGRAPH 1995.
.. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 3rd ed., §13.6.7
       (piecewise-constant 2-D distributions), §14.2.4 (infinite area lights).
.. [3] S. K. Lam, A. Pitrou, S. Seibert, "Numba: a LLVM-based Python JIT compiler", 2015.
"""

from __future__ import annotations

import functools
import math
import types
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
from brdfkit.light.base import Light
from brdfkit.light.environment import EnvironmentMap
from brdfkit.measured import table_kernels
from brdfkit.params import check_choice
from brdfkit.render.reflection_equation import (
    FLOOR_DIRECTIONS,
    Estimate,
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
BLOCK = 256
"""Pixels per call of the BRDF kernels inside the tile kernel (their vectorised batch)."""


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
            tuple(
                compiled_model.kernel(method, width).function
                for method, width in (("sample", 3), ("eval", 0), ("pdf", 0))
            ),
        )
    return per_dtype[dtype]


_TILE_KERNELS: dict[tuple[Any, ...], Any] = {}


def _tile_kernel(
    sample_fn: Callable[..., None],
    eval_fn: Callable[..., None],
    pdf_fn: Callable[..., None],
    dtype: type,
    brdf_channels: int,
    map_channels: int,
) -> Callable[..., None]:
    """:func:`_new_tile_kernel`, built once per set of arguments, its machine code kept on
    disk (:mod:`brdfkit.compiled.cache`) where the BRDF's kernels are."""
    key = (sample_fn, eval_fn, pdf_fn, dtype, brdf_channels, map_channels)
    if key not in _TILE_KERNELS:
        kernel = _new_tile_kernel(*key)
        disk_key = _tile_disk_key(*key)
        if disk_key is not None:
            kernel_cache.enable(kernel, disk_key)
        _TILE_KERNELS[key] = kernel
    return _TILE_KERNELS[key]


def _tile_disk_key(
    sample_fn: Callable[..., None],
    eval_fn: Callable[..., None],
    pdf_fn: Callable[..., None],
    dtype: type,
    brdf_channels: int,
    map_channels: int,
) -> str | None:
    """The disk-cache key of a tile kernel: its BRDF kernels' keys (their machine code is
    inlined into it) and its options, or ``None`` where one of them has none."""
    keys = [kernel_cache.key_of(fn) for fn in (sample_fn, eval_fn, pdf_fn)]
    if None in keys:
        return None
    return kernel_cache.key("tile", *keys, np.dtype(dtype).str, brdf_channels, map_channels, BLOCK)


ROW_BUCKETS = 8
"""Guide-table buckets per row of a map's marginal CDF (:func:`map_guides`)."""
COLUMN_BUCKETS = 1
"""Guide-table buckets per column of each row's conditional CDF (:func:`map_guides`).
Measured (``benchmarks/bench_env_sampling.py``, royal_esplanade_1k, one thread, loaded
machine), ns per sample for (row, column) buckets: (4, 1) 62, (8, 1) 56, (16, 1) 61,
(4, 2) 66, (8, 2) 62, (16, 2) 55: within the noise past (8, 1), the smallest tables."""

_GUIDES: weakref.WeakKeyDictionary[sampling.Distribution2D, tuple[np.ndarray, np.ndarray]] = (
    weakref.WeakKeyDictionary()
)


def map_guides(distribution: sampling.Distribution2D) -> tuple[np.ndarray, np.ndarray]:
    """The guide tables (:func:`brdfkit.compiled.kernel_tools.guide_table`) of a map's
    :class:`~brdfkit.sampling.Distribution2D`: its marginal's (:data:`ROW_BUCKETS` per row)
    and its rows' conditionals' (:data:`COLUMN_BUCKETS` per column, row after row), built
    once per distribution (kept while it lives: one per map) for :func:`map_sampler`."""
    if distribution not in _GUIDES:
        height, width = distribution.shape
        _GUIDES[distribution] = (
            kernel_tools.guide_table(distribution._marginal, height, ROW_BUCKETS * height),
            kernel_tools.guide_table(
                distribution._conditional, width, COLUMN_BUCKETS * width, height
            ),
        )
    return _GUIDES[distribution]


@functools.cache
def map_sampler() -> Callable[..., None]:
    """The numba ``map_samples(a, b, marginal, conditional, row_guide, col_guide, height,
    width, nb, rows, cols, base)``: ``Distribution2D.sample``'s texels for ``nb`` float64
    variates ``a`` (column) and ``b`` (row) already clamped below 1, the marginal's row, then
    the row's column (``base``: the row's offset in ``conditional``), each by the guide-table
    search (:func:`brdfkit.compiled.kernel_tools.guided_search`, :func:`map_guides`): the rows
    and columns of ``sampling._find_interval``'s bisection, in a scan of a step or two instead
    of its ~10 + ~11 steps (1k map). Loops split so that the guide reads of the block's
    samples overlap, and each column search's CDF nodes are prefetched before the scans."""
    jit = kernel_tools.jit()
    guided_interval = kernel_tools.guided_search()
    prefetch = kernel_tools.prefetch()

    @jit
    def map_samples(a: np.ndarray, b: np.ndarray, marginal: np.ndarray,
                    conditional: np.ndarray, row_guide: np.ndarray, col_guide: np.ndarray,
                    height: int, width: int, nb: int, rows: np.ndarray, cols: np.ndarray,
                    base: np.ndarray) -> None:  # fmt: skip
        row_buckets, col_buckets = row_guide.shape[0], col_guide.shape[0] // height
        for j in range(nb):
            row = guided_interval(marginal, 0, row_guide, 0, row_buckets, b[j], height)
            rows[j], base[j] = row, row * (width + 1)
        for j in range(nb):
            start = rows[j] * col_buckets
            cols[j] = col_guide[start + min(np.int64(a[j] * col_buckets), col_buckets - 1)]
            prefetch(conditional, base[j] + cols[j])
        for j in range(nb):
            cols[j] = guided_interval(conditional, base[j], col_guide, rows[j] * col_buckets,
                                      col_buckets, a[j], width)  # fmt: skip

    return map_samples


def _new_tile_kernel(
    sample_fn: Callable[..., None],
    eval_fn: Callable[..., None],
    pdf_fn: Callable[..., None],
    dtype: type,
    brdf_channels: int,
    map_channels: int,
) -> Callable[..., None]:
    """The numba kernel shading a set of pixels, for one BRDF's compiled kernels and dtype.

    Every step mirrors the NumPy code it replaces, operation by operation and in its dtype
    (``T``); the map's CDF searches run in float64 as :class:`~brdfkit.sampling.Distribution2D`
    does. One shortcut: a map sample's radiance is read at its map coordinates, where the
    NumPy path turns them into a direction and back (the same texel weights to rounding). Per
    block of :data:`BLOCK` pixels and per sample, loops are split so that the unpredictable
    table reads (the CDF searches, :func:`map_sampler`, then texel fetches) overlap: measured
    1.1–1.4× over one loop doing each pixel's work in turn (2k × 1k and 64 × 32 maps).
    As soon as a direction's map coordinates are known, its two texel rows and its pdf
    texel are prefetched, so that the reads of the last loops hit the cache (gold scene, 16
    spp, one thread on a loaded machine: ~370 → ~260 ns CPU per pixel-sample, together with
    the float32 trigonometry of :func:`~brdfkit.compiled.kernel_tools.trigonometry` and the
    Sobol' variates computed a block at a time). LLVM vectorises a loop only if it holds no
    gather and no prefetch, so the arithmetic (frames, map coordinates, the map samples'
    directions, the bilinear cells, MIS weights and the running mean) runs in loops of its
    own over arrays along the block, between short scalar loops of reads (gold, 16 spp, two
    threads: 0.094 → 0.062 s per 256² image).
    """
    jit = kernel_tools.jit()
    T = dtype
    pi, two_pi, two_pi_sq = T(math.pi), T(2 * math.pi), T(2 * math.pi**2)
    zero, one, half = T(0), T(1), T(0.5)
    tiny = T(np.finfo(np.float32).tiny)
    below_one_64 = 1 - np.finfo(np.float64).eps / 2
    below_one = T(1 - np.finfo(T).eps / 2)
    channels = max(brdf_channels, map_channels)
    cb_step = 1 if brdf_channels > 1 else 0
    cl_step = 1 if map_channels > 1 else 0
    select = kernel_tools.select()
    atan2, sin, cos = kernel_tools.trigonometry(T)
    prefetch = kernel_tools.prefetch()
    map_samples = map_sampler()

    @jit
    def unit(x: Any, y: Any, z: Any) -> tuple[Any, Any, Any]:
        """:func:`brdfkit._array.normalize`: v / max(|v|, tiny)."""
        length = max(np.sqrt(x * x + y * y + z * z), tiny)
        return x / length, y / length, z / length

    @jit
    def map_coordinates(wx: Any, wy: Any, wz: Any, r: tuple) -> tuple[Any, Any, Any]:
        """``EnvironmentMap._map_coordinates`` of a unit direction: x = (φ mod 2π)/2π,
        y = θ/π, and sin θ (the NumPy path's sin θ to rounding), branch-free; ``r`` the
        map's rotation, row-major."""
        mx = wx * r[0] + wy * r[3] + wz * r[6]
        my = wx * r[1] + wy * r[4] + wz * r[7]
        mz = wx * r[2] + wy * r[5] + wz * r[8]
        sin_theta = np.sqrt(max(mx * mx + my * my, zero))
        theta = atan2(sin_theta, mz)
        phi = atan2(my, mx)
        phi = select(phi < zero, phi + two_pi, phi)  # np.remainder(φ, 2π) for φ ∈ (−π, π]
        return phi / two_pi, theta / pi, sin_theta

    @jit
    def texel_cell(x: Any, y: Any, height: int, width: int, nc: int) -> tuple:
        """``EnvironmentMap._lookup``'s bilinear cell at map coordinates (x, y) in [0, 1]²,
        branch-free: the offsets in the flat image of its texels (rows r0, r1 clamped, columns
        c0, c1 wrapping: (r0, c0), (r0, c1), (r1, c0), (r1, c1)), then the weights (fr, fc)
        of r1 and c1."""
        row, col = y * T(height) - half, x * T(width) - half
        r0f, c0f = np.floor(row), np.floor(col)
        fr, fc = row - r0f, col - c0f
        # NaN (a degenerate direction) reads texel 0 instead of an undefined index
        r_index = np.int64(select(np.abs(r0f) < T(1e9), r0f, zero))
        c_index = np.int64(select(np.abs(c0f) < T(1e9), c0f, zero))
        r0 = min(max(r_index, 0), height - 1)
        r1 = min(max(r_index + 1, 0), height - 1)
        # c_index mod W without integer divisions: c_index is in [−1, W − 1] for x in [0, 1]
        c0 = select(c_index < 0, c_index + width, c_index)
        c0 = select(c0 >= width, c0 - width, c0)
        c1 = select(c0 + 1 < width, c0 + 1, np.int64(0))
        top, bottom = r0 * width, r1 * width
        return (top + c0) * nc, (top + c1) * nc, (bottom + c0) * nc, (bottom + c1) * nc, fr, fc

    @jit
    def bilinear(texels: np.ndarray, cells: np.ndarray, weights: np.ndarray, j: int,
                 scale: Any, out: np.ndarray) -> None:  # fmt: skip
        """``EnvironmentMap._lookup``: the bilinear value at the cell ``cells[:, j]``,
        ``weights[:, j]`` of :func:`texel_cell` (``texels``: the flat image), into
        ``out[:, j]``."""
        i00, i01 = np.uint64(cells[0, j]), np.uint64(cells[1, j])  # unsigned: no
        i10, i11 = np.uint64(cells[2, j]), np.uint64(cells[3, j])  # wrap-around per read
        fr, fc = weights[0, j], weights[1, j]
        for c in range(out.shape[0]):
            k = np.uint64(c)
            top = texels[i00 + k] * (one - fc) + texels[i01 + k] * fc
            bottom = texels[i10 + k] * (one - fc) + texels[i11 + k] * fc
            out[c, j] = (top * (one - fr) + bottom * fr) * scale

    @jit
    def pdf_texel(x: Any, y: Any, height: int, width: int) -> Any:
        """``EnvironmentMap.pdf``'s texel at map coordinates (x, y): its flat index, −1
        outside [0, 1)² (where the pdf is 0), branch-free."""
        inside = (x >= zero) & (x < one) & (y >= zero) & (y < one)
        col = min(max(np.floor(np.float64(x) * width), 0.0), width - 1.0)
        row = min(max(np.floor(np.float64(y) * height), 0.0), height - 1.0)
        index = np.int64(select(inside, row, 0.0)) * width + np.int64(select(inside, col, 0.0))
        return select(inside, index, np.int64(-1))

    @jit
    def solid_angle_pdf(pdf_uv: Any, sin_theta: Any) -> Any:
        """``lights._solid_angle_pdf``: safe_div(p_uv, 2π² max(sin θ, 0)), branch-free."""
        denominator = two_pi_sq * max(sin_theta, zero)
        ok = denominator != zero
        return select(ok, pdf_uv / select(ok, denominator, one), zero)

    reverse_bits, laine_karras = jit(sampling.reverse_bits), jit(sampling.laine_karras)
    key_hash = jit(
        types.FunctionType(
            sampling.key_hash.__code__, {**vars(sampling), "_mix64": jit(sampling._mix64)}
        )
    )
    key_slot = jit(sampling.key_slot)
    unit_interval = 2.0**-sampling.SOBOL_BITS

    @jit
    def block_keys(seeds: np.ndarray, stream: int, pixels: np.ndarray, start: int, nb: int,
                   out: np.ndarray) -> None:  # fmt: skip
        """The block's pixels' scramble keys of ``stream`` (``sampling.scramble_keys`` of
        their seeds) as ``out`` ``(2, d, nb)`` uint64: contiguous along the block for
        :func:`block_variates`."""
        d = out.shape[1]
        for j in range(nb):
            seed = np.uint64(seeds[pixels[start + j]])
            for i in range(2):
                for k in range(d):
                    out[i, k, j] = key_hash(seed, key_slot(stream, i * d + k))

    @jit
    def block_variates(digits: np.ndarray, keys: np.ndarray, s: int, nb: int,
                       out: np.ndarray) -> None:  # fmt: skip
        """:func:`variate` of sample s of the block's pixels, all d dimensions, into ``out``
        ``(d, nb)``: one straight-line integer loop per dimension over the block (LLVM
        vectorises it; a variate at a time ran scalar, ~30 ns each)."""
        for k in range(digits.shape[1]):
            d = np.uint64(digits[s, k])
            for j in range(nb):
                x = reverse_bits(laine_karras(d, keys[0, k, j])) ^ keys[1, k, j]
                out[k, j] = np.float64(np.int64(x)) * unit_interval  # x < 2^32: exact

    @jit
    def weight(p: Any, q: Any, power: bool) -> Any:
        """safe_div(p^β, p^β + q^β)."""
        if power:
            p, q = p * p, q * q
        total = p + q
        return select(total != zero, p / select(total != zero, total, one), zero)

    @jit
    def shade(
        params: np.ndarray,
        pixels: np.ndarray,
        wo: np.ndarray,
        frame: np.ndarray,
        points_b: np.ndarray,
        digits_b: np.ndarray,
        points_l: np.ndarray,
        digits_l: np.ndarray,
        seeds: np.ndarray,
        image: np.ndarray,
        rot: np.ndarray,
        scale: Any,
        marginal: np.ndarray,
        conditional: np.ndarray,
        density: np.ndarray,
        row_guide: np.ndarray,
        col_guide: np.ndarray,
        power: bool,
        control: np.ndarray,
        mean: np.ndarray,
        m2: np.ndarray,
        data: tuple,
    ) -> None:
        height, width = image.shape[0], image.shape[1]
        samples = max(points_b.shape[1], digits_b.shape[0])
        wo_buf = np.empty(BLOCK * 3, T)
        u_buf = np.empty(BLOCK * 3, T)
        wi_buf = np.empty(BLOCK * 3, T)
        wt_buf = np.empty(BLOCK * brdf_channels, T)
        pdf_buf = np.empty(BLOCK, T)
        delta_buf = np.empty(BLOCK, np.bool_)
        wil_buf = np.empty(BLOCK * 3, T)
        f_buf = np.empty(BLOCK * brdf_channels, T)
        pbl_buf = np.empty(BLOCK, T)
        above = np.empty(BLOCK, np.int64)  # the map's samples above the surface, compacted:
        wic_buf = np.empty(BLOCK * 3, T)  # their directions, the viewer's,
        woc_buf = np.empty(BLOCK * 3, T)
        fc_buf = np.empty(BLOCK * brdf_channels, T)  # f and p_b there
        pbc_buf = np.empty(BLOCK, T)
        # the block's frames, frames[3 i + k, j] = frame[pixels[start + j], i, k]: contiguous
        # along the block, so that the loops over it vectorise
        frames = np.empty((9, BLOCK), T)
        sin_b = np.empty(BLOCK, T)  # sin θ of the BRDF's samples in the map's frame
        m0_l, m1_l = np.empty(BLOCK, np.float64), np.empty(BLOCK, np.float64)  # their CDF
        c0_l, c1_l = np.empty(BLOCK, np.float64), np.empty(BLOCK, np.float64)  # nodes, pdf
        pdf_uv = np.empty(BLOCK, T)
        r = (rot[0, 0], rot[0, 1], rot[0, 2], rot[1, 0], rot[1, 1], rot[1, 2], rot[2, 0],
             rot[2, 1], rot[2, 2])  # fmt: skip
        pdf_l = np.empty(BLOCK, T)
        cos_l = np.empty(BLOCK, T)
        controls = np.empty((brdf_channels, BLOCK), T)  # the block's control variates k
        radiance_b = np.empty((map_channels, BLOCK), T)  # the map at the BRDF's samples,
        radiance_l = np.empty((map_channels, BLOCK), T)  # at its own,
        p_texel = np.empty(BLOCK, T)  # and its pdf's texel at the BRDF's
        # the bilinear cells (texel_cell) of the BRDF's and the map's samples, the pdf's texel
        # (pdf_texel) at the BRDF's
        cells_b, cells_l = np.empty((4, BLOCK), np.int64), np.empty((4, BLOCK), np.int64)
        weights_b, weights_l = np.empty((2, BLOCK), T), np.empty((2, BLOCK), T)
        density_b = np.empty(BLOCK, np.int64)
        texels = image.reshape(-1)
        nc = image.shape[2]
        mean_b = np.empty((channels, BLOCK), np.float64)  # the block's running mean and
        m2_b = np.empty((channels, BLOCK), np.float64)  # sum of squared deviations
        a_buf = np.empty(BLOCK, np.float64)
        b_buf = np.empty(BLOCK, np.float64)
        rows = np.empty(BLOCK, np.int64)
        cols = np.empty(BLOCK, np.int64)
        base = np.empty(BLOCK, np.int64)
        sobol = digits_b.shape[0] > 0
        keys_bb = np.empty((2, 3, BLOCK), np.uint64)
        keys_lb = np.empty((2, 2, BLOCK), np.uint64)
        u_b = np.empty((3, BLOCK), np.float64)
        u_l = np.empty((2, BLOCK), np.float64)
        for start in range(0, pixels.shape[0], BLOCK):
            nb = min(BLOCK, pixels.shape[0] - start)
            if sobol:
                block_keys(seeds, 0, pixels, start, nb, keys_bb)
                block_keys(seeds, 1, pixels, start, nb, keys_lb)
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
            for s in range(samples):
                inverse_count = 1.0 / (s + 1)
                if sobol:
                    block_variates(digits_b, keys_bb, s, nb, u_b)
                    block_variates(digits_l, keys_lb, s, nb, u_l)
                else:
                    for j in range(nb):
                        p = pixels[start + j]
                        for k in range(3):
                            u_b[k, j] = points_b[p, s, k]
                        for k in range(2):
                            u_l[k, j] = points_l[p, s, k]
                # BRDF sampling, vectorised over the block
                for j in range(nb):
                    for k in range(3):
                        u_buf[j * 3 + k] = T(u_b[k, j])
                sample_fn(params, wo_buf, u_buf, wi_buf, wt_buf, pdf_buf, delta_buf, nb, *data)
                # Directions, map coordinates and the map's CDF searches first, texel reads
                # after: short loops whose independent cache misses overlap. The arithmetic
                # runs in loops of its own, which LLVM vectorises (a loop with a gather or a
                # prefetch in it runs scalar).
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
                    a, b = T(u_l[0, j]), T(u_l[1, j])
                    a_buf[j] = min(np.float64(a), below_one_64)
                    b_buf[j] = min(np.float64(b), below_one_64)
                for j in range(nb):  # the lookup's two texel rows, the pdf's texel
                    prefetch(texels, cells_b[0, j])
                    prefetch(texels, cells_b[2, j])
                    prefetch(density, max(density_b[j], 0))
                map_samples(
                    a_buf, b_buf, marginal, conditional, row_guide, col_guide, height, width,
                    nb, rows, cols, base,
                )  # fmt: skip
                for j in range(nb):  # the found cells' CDF nodes and pdf
                    row, col, at = rows[j], cols[j], base[j] + cols[j]
                    m0_l[j], m1_l[j] = marginal[row], marginal[row + 1]
                    c0_l[j], c1_l[j] = conditional[at], conditional[at + 1]
                    pdf_uv[j] = T(density[row * width + col])
                for j in range(nb):
                    row, col, a, b = rows[j], cols[j], a_buf[j], b_buf[j]
                    c0, c1, m0, m1 = c0_l[j], c1_l[j], m0_l[j], m1_l[j]
                    x = min(T((col + (a - c0) / (c1 - c0)) / width), below_one)
                    y = min(T((row + (b - m0) / (m1 - m0)) / height), below_one)
                    i00, i01, i10, i11, fr, fc = texel_cell(x, y, height, width, nc)
                    cells_l[0, j], cells_l[1, j], cells_l[2, j], cells_l[3, j] = i00, i01, i10, i11
                    weights_l[0, j], weights_l[1, j] = fr, fc
                    theta, phi = y * pi, x * two_pi
                    sin_theta = sin(theta)
                    pdf_l[j] = solid_angle_pdf(pdf_uv[j], sin_theta)
                    mx, my, mz = sin_theta * cos(phi), sin_theta * sin(phi), cos(theta)
                    lx = mx * r[0] + my * r[1] + mz * r[2]
                    ly = mx * r[3] + my * r[4] + mz * r[5]
                    lz = mx * r[6] + my * r[7] + mz * r[8]
                    for k in range(3):
                        wil_buf[j * 3 + k] = (
                            lx * frames[3 * k, j] + ly * frames[3 * k + 1, j]
                            + lz * frames[3 * k + 2, j]
                        )  # fmt: skip
                    cos_l[j] = max(wil_buf[j * 3 + 2], zero)
                for j in range(nb):
                    prefetch(texels, cells_l[0, j])
                    prefetch(texels, cells_l[2, j])
                # the BRDF at the map's directions above the surface only (about half of
                # them): below it f = 0 and p_b = 0 and the term, times cos θ = 0, is 0
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
                # the texel reads (and the map's pdf at the BRDF's samples), then the MIS
                # arithmetic in a loop LLVM vectorises
                for j in range(nb):
                    bilinear(texels, cells_b, weights_b, j, scale, radiance_b)
                    p_texel[j] = T(density[max(density_b[j], 0)])
                    # the map's sample: its radiance at the sampled coordinates (the NumPy
                    # path converts them to a direction and back, equal to rounding)
                    bilinear(texels, cells_l, weights_l, j, scale, radiance_l)
                for j in range(nb):
                    pb, pl = pdf_buf[j], pdf_l[j]
                    # EnvironmentMap.pdf at the BRDF's sample
                    p_light = select(density_b[j] >= 0, solid_angle_pdf(p_texel[j], sin_b[j]),
                                     zero)  # fmt: skip
                    w_b = select(delta_buf[j], one, weight(pb, p_light, power))
                    w_l = weight(pl, pbl_buf[j], power)
                    upper = wi_buf[j * 3 + 2] > zero
                    cos_over_p = select(pb != zero, wi_buf[j * 3 + 2] / select(pb != zero, pb, one),
                                        zero)  # fmt: skip
                    for c in range(channels):
                        k_c = controls[c * cb_step, j]
                        k = k_c * cos_over_p  # (f − k)·cos/p
                        term = (wt_buf[j * brdf_channels + c * cb_step] - k) * radiance_b[
                            c * cl_step, j
                        ]  # fmt: skip
                        term_b = select(upper, term * w_b, zero * w_b)
                        radiance = radiance_l[c * cl_step, j]
                        value = select(pl != zero, radiance / select(pl != zero, pl, one), zero)
                        c_l = (f_buf[j * brdf_channels + c * cb_step] - k_c) * value
                        x64 = np.float64(term_b + c_l * cos_l[j] * w_l)
                        previous = mean_b[c, j]
                        current = previous + (x64 - previous) * inverse_count
                        mean_b[c, j] = current
                        m2_b[c, j] += (x64 - previous) * (x64 - current)
            for j in range(nb):
                for c in range(channels):
                    mean[start + j, c] = mean_b[c, j]
                    m2[start + j, c] = m2_b[c, j]

    return shade


@dataclass(frozen=True, eq=False)
class Prepared:
    """Queries made ready by :meth:`EnvironmentShader.prepare`: their batch shape, the exact
    part of their value ``batch + (C,)``, and for the kernel the indices of the pixels it
    shades, the flat ``wo`` ``(n, 3)`` and frames ``(n, 3, 3)`` in its dtype and the control
    variate's k ``(n, C)``."""

    batch: tuple[int, ...]
    value: np.ndarray
    pixels: np.ndarray | None = None
    wo: np.ndarray | None = None
    frame: np.ndarray | None = None
    control: np.ndarray | None = None


class EnvironmentShader:
    r"""A compiled MIS shader for one BRDF under one :class:`~brdfkit.light.EnvironmentMap`.

    Calling it equals :func:`brdfkit.render.reflected_radiance` with ``method`` ``"auto"``
    or ``"mis"`` and ``heuristic`` ``"power"`` or ``"balance"``, same uniforms (module
    docstring), at compiled speed. The BRDF's non-Lambertian part must be compilable by
    :func:`brdfkit.compiled.compile` (its parameters may not vary per pixel; the albedo of its
    Lambertian lobes, ``method="auto"``, neither) or be a tabulated BRDF, alone or scaled by
    a constant (:mod:`brdfkit.measured._tabulated_kernels`, the table an input of the kernel).

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
        self.rho, self.rest = split_diffuse(brdf) if method == "auto" else (None, brdf)
        # a smooth plastic's mirror exactly, its base sampled (integrate.split_mirror)
        self.mirror, self.rest = split_mirror(self.rest) if method == "auto" else (None, self.rest)
        if self.rest is not None:  # transmitting lobes sampled one-sided, as on the NumPy path
            self.rest = one_sided_view(self.rest)
        if self.rho is not None and np.ndim(self.rho) > 1:
            raise ValueError("a per-pixel Lambertian albedo is not supported by the compiled path")
        self.channels = max(brdf.channels, self.env.channels)
        self._kernel: Callable[..., None] | None = None
        # the control variate k(wo)·E(n) of method="auto" (integrate.diffuse_floor)
        self.control = (
            method == "auto"
            and self.rest is not None
            and (self.mirror is not None or not self.rest.has_delta)
        )
        # the BRDF's kernels' trailing arguments (a table's arrays, render_table_kernel)
        self._data: tuple[Any, ...] = ()
        if self.rest is not None:
            table = table_kernels(self.rest, self.dtype)
            if table is not None:
                self._rest, functions, self._data = table, table.functions, table.data
            else:
                self._rest, functions = _compiled(self.rest, self.dtype)
            self._kernel = _tile_kernel(
                *functions,
                self.dtype.type,
                self.rest.channels,
                self.env.channels,
            )
        env, t = self.env, self.dtype
        distribution = env.compensated._distribution  # as integrate's MIS
        self._tables = (
            np.ascontiguousarray(env.image, dtype=t),
            np.ascontiguousarray(env.rotation, dtype=t),
            t.type(env.scale),
            distribution._marginal,
            distribution._conditional,
            np.ascontiguousarray(distribution.density.ravel()),
            *map_guides(distribution),
        )

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
        control = np.zeros((n, self.rest.channels), self.dtype)
        if self.control:
            control[keep] = self._floor(wo_local.reshape(n, 3)[keep])
            k = control.reshape(*batch, self.rest.channels).astype(np.float64)
            value = value + diffuse_envmap_radiance(k * math.pi, self.env, frame, wo_local)
        t = self.dtype
        wo_flat = np.ascontiguousarray(wo_local.reshape(n, 3), dtype=t)
        frame_flat = np.ascontiguousarray(
            np.stack([np.broadcast_to(v, (*batch, 3)).reshape(n, 3) for v in frame], axis=1),
            dtype=t,
        )
        return Prepared(batch, value, np.flatnonzero(keep), wo_flat, frame_flat, control)

    def shade(
        self,
        prepared: Prepared,
        *,
        samples: int = 256,
        seed: Any = 0,
        sequence: str = "random",
        first_sample: int = 0,
    ) -> Estimate:
        """:meth:`__call__` on queries made ready by :meth:`prepare`."""
        if samples < 1:
            raise ValueError(f"samples must be >= 1; got {samples}")
        if sequence not in ("random", "sobol"):
            raise ValueError(f"sequence must be 'random' or 'sobol'; got {sequence!r}")
        batch, value = prepared.batch, prepared.value
        stderr2 = np.zeros((*batch, self.channels))
        if self._kernel is not None:
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
        ``eval``, ``(n, C)``."""
        directions = _floor_directions(FLOOR_DIRECTIONS).astype(self.dtype)
        f = self._rest.eval(directions, wo_local[:, None, :].astype(self.dtype))
        median = np.partition(f, FLOOR_DIRECTIONS // 2, axis=-2)[:, FLOOR_DIRECTIONS // 2]
        return np.maximum(median, 0)

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
                found_m2[lo:hi], self._data,
            )  # fmt: skip

        kernel_tools.run_tasks(run, range(len(bounds) - 1), kernel_tools.threads())
        mean[pixels], m2[pixels] = found_mean, found_m2
        shape = (*batch, self.channels)
        return mean.reshape(shape), m2.reshape(shape)


_CHUNK = 512
"""Pixels per task of the thread pool, at most (a few ms of work at 16 spp)."""


def _task_bounds(count: int, workers: int) -> list[int]:
    """Bounds of the thread pool's tasks over ``count`` pixels: at most :data:`_CHUNK` each,
    their number a multiple of ``workers`` and their sizes equal to within a pixel, so that
    the workers finish a tile together (with tasks of :data:`_CHUNK` and a short last one,
    one thread waited on the other for part of a task per tile)."""
    tasks = -(-max(count, 1) // _CHUNK)
    tasks = -(-tasks // workers) * workers
    return [count * i // tasks for i in range(tasks + 1)]


def _uniforms(
    seed: Any, sequence: str, batch: tuple[int, ...], samples: int, first_sample: int
) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray], np.ndarray]:
    """The NumPy path's uniforms (``integrate._Uniforms``, the same generator calls and keys)
    of the BRDF's (3-D, stream 0) and the map's (2-D, stream 1) samples, without their
    pixels × samples array for Sobol: per strategy ``(points, digits)``, then the pixels'
    seeds. For ``"random"`` the i.i.d. ``points`` ``(n, N, d)`` (digits and seeds empty), for
    ``"sobol"`` the sequence's bit-reversed digits ``(N, d)`` and the pixels' 64-bit seeds
    ``(n,)`` (:func:`~brdfkit.render.reflection_equation.uniform_seeds`), from which the kernel
    hashes the scramble keys of each stream (``sampling.scramble_keys``; in NumPy a tile's keys took
    ~0.6 ms, with the kernel's threads waiting)."""
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
"""Pixel-samples from which ``compiled="auto"`` builds a model's kernels: building them (JAX
trace and numba compile of ``sample``/``eval``/``pdf`` and of the tile kernel) takes 5–10 s
per model structure on a 2-core machine, about what the NumPy path takes for this many MIS
pixel-samples of a GGX conductor (~1.7 µs each). Below it, the NumPy path unless the kernels
are built already — for any model of the same structure (:func:`kernels_built`): once one
parameter set is built, every other set of that structure shades compiled at no build cost."""


def compiled_shader(
    brdf: BRDF,
    lights: Sequence[Light],
    *,
    method: str,
    dtype: Any = np.float32,
    build: bool = True,
) -> tuple[EnvironmentShader, list[Light]] | None:
    """The compiled shader for ``brdf`` under ``lights`` and the lights it leaves to the NumPy
    path, or ``None`` where the compiled path does not apply.

    It applies to exactly one :class:`~brdfkit.light.EnvironmentMap` plus any delta lights
    (directional, point: evaluated exactly, no samples, by the NumPy path), ``method``
    ``"auto"`` or ``"mis"``, a BRDF whose non-Lambertian part :func:`brdfkit.compiled.compile`
    compiles (no per-pixel parameters), with numba and JAX installed, or whose non-Lambertian
    part is a (constant-scaled) tabulated BRDF (:mod:`brdfkit.measured._tabulated_kernels`, numba).
    With ``build=False`` it is returned only when it costs no compilation: the model's
    kernels are built already, or the BRDF is Lambertian (no Monte Carlo).
    """
    maps = [lt for lt in lights if isinstance(lt, EnvironmentMap)]
    others = [lt for lt in lights if not isinstance(lt, EnvironmentMap)]
    if method not in METHODS or len(maps) != 1 or not all(lt.delta for lt in others):
        return None
    dtype = np.dtype(dtype)
    try:  # without numba, a table's kernels_built raises ImportError as the shader does
        if not build:
            _, rest = split_diffuse(brdf) if method == "auto" else (None, brdf)
            _, rest = split_mirror(rest) if method == "auto" else (None, rest)
            view = None if rest is None else one_sided_view(rest)
            if view is not None and not kernels_built(view, dtype, maps[0].channels):
                return None
        return EnvironmentShader(brdf, maps[0], method=method, dtype=dtype), others
    except (ValueError, ImportError):
        return None


def kernels_built(model: BRDF, dtype: Any = np.float32, map_channels: int | None = None) -> bool:
    """Whether compiled shading kernels for this model exist in this process (for its
    structure: any model that differs from it in parameter values only, or for the object)
    or in the disk cache (:mod:`brdfkit.compiled.cache`: loading them compiles nothing), for a
    map of ``map_channels`` channels (``None``: 1 or 3)."""
    dtype = np.dtype(dtype)
    table = table_kernels(model, dtype)
    entry = _BRDF_KERNELS.get(model, {}).get(dtype)
    if table is not None:
        kernels = table.functions
    elif entry is not None:
        kernels = entry[1]
    else:
        compiled_model = compiled.compile(model, dtype)
        methods = (("sample", 3), ("eval", 0), ("pdf", 0))
        if not all(compiled_model.cached(method, width) for method, width in methods):
            return False
        # built, or their source and machine code on disk: making them now costs a load
        kernels = tuple(compiled_model.kernel(method, width).function for method, width in methods)
    tiles = [t for key, t in _TILE_KERNELS.items() if key[:4] == (*kernels, dtype.type)]
    if any(t.signatures for t in tiles):
        return True
    for channels in (map_channels,) if map_channels is not None else (1, 3):
        disk_key = _tile_disk_key(*kernels, dtype.type, model.channels, channels)
        if disk_key is not None and kernel_cache.has(disk_key):
            return True
    return False


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
    "HEURISTICS",
    "METHODS",
    "EnvironmentShader",
    "compiled_shader",
    "kernels_built",
    "reflected_radiance",
]
