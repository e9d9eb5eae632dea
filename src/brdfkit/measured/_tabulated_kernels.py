r"""A tabulated (MERL-layout) BRDF's ``eval``, ``pdf`` and ``sample`` as numba kernels.

:func:`brdfkit.compiled.compile` traces array-API code; a table lookup (gathers at computed
indices) and a CDF search cannot be traced, so this module writes the
:class:`~brdfkit.measured.TabulatedBRDF`'s methods once for numba, with the calling
convention of the BRDF kernels the render's tile kernel calls
(:mod:`brdfkit.render.compiled_shading`): ``fn(parameters, *inputs, *outputs, n, *data)`` on
flat buffers of a block of pixels, the table's arrays trailing (``data``: the table is a
kernel *input*, never a compile-time constant, so one compilation serves every table of the
same rank, channel count and interpolation). :func:`table_kernels` gives them, with their
arguments, for a table or a constant multiple of one.

Each function restates, operation by operation and in the kernel's dtype, the NumPy code of
``measured/tabulated.py``, which stays the reference (``tests/measured/
test_tabulated_kernels.py`` holds them equal: float64 to rounding, float32 to float32
precision):

- ``eval`` (:func:`_table_cells`, :func:`_corner_cells`, :func:`_gathers`):
  :func:`brdfkit.geometry.to_half_diff` (the rotations by −φh and −θh written with
  :math:`\cos\varphi_h = h_x/\sin\theta_h`, :math:`\sin\theta_h = |h_{xy}|`,
  :math:`\cos\theta_h = h_z` instead of trigonometric calls: equal to rounding),
  :meth:`TabulatedBRDF._continuous_index` and :func:`brdfkit.measured.tabulated.lookup`
  (``"bin"``, ``"nearest"``, ``"linear"``: the 2^D corners in the same order), the
  renormalised measured weight and the upper-hemisphere mask;
- ``pdf`` and ``sample`` (:func:`_mixture_pdf`, :func:`_mixture_sample`): the one-sample
  mixture of the cosine hemisphere and the table's half-vector marginal
  (:class:`~brdfkit.measured.tabulated.HalfVectorSampling`, its
  :class:`~brdfkit.sampling.Distribution2D` searched in float64 for bisection's intervals),
  as :class:`~brdfkit.brdf.phong.MixtureSampled` combines them. The sampler is the NumPy
  path's, so it is unbiased for the same reason: the mixture density is positive wherever
  :math:`f\cos\theta_i` is (the cosine lobe keeps at least 10 %), and the weight is
  :math:`f\cos\theta_i/p` of the sampled direction.

The loops over a block are split so that LLVM vectorises the arithmetic (a loop holding a
gather runs scalar), with node and cell indices as int32 so that the vectorised loops keep
the float32 width; the table's rows are prefetched ahead of their gathers. A
:class:`~brdfkit.brdf.base.Scaled` table (constant k) multiplies ``eval`` and the weights by
k.

References
----------
.. [1] S. Rusinkiewicz, "A new change of variables for efficient BRDF representation",
       EGWR 1998.
.. [2] W. Matusik, H. Pfister, M. Brand, L. McMillan, "A data-driven reflectance model",
       SIGGRAPH 2003 (the MERL layout).
.. [3] E. Veach, *Robust Monte Carlo methods for light transport simulation*, PhD thesis,
       Stanford, 1997, §9.2.4 (one-sample mixtures).
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from brdfkit.brdf.base import BRDF, Scaled
from brdfkit.compiled import kernel_tools
from brdfkit.measured.tabulated import _NODE_TOLERANCE, TabulatedBRDF

_FUNCTIONS: dict[tuple[Any, ...], tuple[Callable[..., None], ...]] = {}


def _table_functions(
    dtype: type, rank: int, table_channels: int, channels: int, interpolation: str
) -> tuple[Callable[..., None], Callable[..., None], Callable[..., None]]:
    """``(sample, eval, pdf)`` numba functions, built once per set of arguments."""
    key = (dtype, rank, table_channels, channels, interpolation)
    if key not in _FUNCTIONS:
        _FUNCTIONS[key] = _new_table_functions(*key)
    return _FUNCTIONS[key]


PREFETCH_DISTANCE = 16
"""Pairs ahead whose table rows ``eval`` prefetches (:func:`_gathers`): far enough that a
table larger than the caches has its rows there when they are read, near enough that they
are not evicted again first."""


def _new_table_functions(
    dtype: type, rank: int, table_channels: int, channels: int, interpolation: str
) -> tuple[Callable[..., None], Callable[..., None], Callable[..., None]]:
    """The numba ``sample``, ``eval`` and ``pdf`` of a table of ``rank`` (3: isotropic, 4:
    anisotropic) with ``table_channels`` value channels, scaled to ``channels``, composed of
    the factories below (their helpers made afresh for each set: a numba function keeps the
    floating-point flags of its first caller)."""
    scalars = _scalars(dtype)
    cells = _table_cells(dtype, rank, interpolation, scalars)
    corners = _corner_cells(dtype, rank, table_channels, interpolation)
    evaluate = _gathers(dtype, rank, table_channels, channels, interpolation, cells, corners)
    pdf_fn = _mixture_pdf(dtype, rank, scalars)
    sample_fn = _mixture_sample(dtype, rank, channels, scalars, evaluate, pdf_fn)
    return sample_fn, _eval_kernel(evaluate), pdf_fn


class _Scalars(NamedTuple):
    """Branch-free scalar helpers of the table's kernels (:func:`_scalars`)."""

    clamp0: Callable[[Any], Any]
    unit: Callable[..., tuple[Any, Any, Any]]
    remainder: Callable[[Any, Any], Any]
    integer: Callable[[Any], Any]


def _scalars(dtype: type) -> _Scalars:
    """``clamp0`` (max(x, 0), NaN giving 0 as ``safe_sqrt``'s fmax), ``unit``
    (:func:`brdfkit._array.normalize`), ``remainder`` (``np.remainder(x, period)`` for x in
    [−period, period], angles from atan2) and ``integer`` (int64 of a float index, NaN
    reading index 0, by way of int32: AVX2 converts floats to int32 in vectors, to int64 only
    one by one); all branch-free, with their caller's flags."""
    jit = kernel_tools.jit()
    select = kernel_tools.select()
    zero, tiny = dtype(0), dtype(np.finfo(np.float32).tiny)

    @jit
    def clamp0(x: Any) -> Any:
        return select(x > zero, x, zero)

    @jit
    def unit(x: Any, y: Any, z: Any) -> tuple[Any, Any, Any]:
        length = np.sqrt(x * x + y * y + z * z)
        length = select(length > tiny, length, tiny)
        return x / length, y / length, z / length

    @jit
    def remainder(x: Any, period: Any) -> Any:
        wrapped = select(x < zero, x + period, x)
        return select(wrapped >= period, zero, wrapped)

    @jit
    def integer(x: Any) -> Any:
        return np.int64(np.int32(select(np.abs(x) < dtype(1e9), x, zero)))

    return _Scalars(clamp0, unit, remainder, integer)


def _table_cells(dtype: type, rank: int, interpolation: str, s: _Scalars) -> Callable[..., None]:
    r"""``cells(wi, wo, n, sizes, upper, low, high, weight)``: per pair, whether both
    directions are above the surface, :func:`brdfkit.geometry.to_half_diff` and
    :meth:`TabulatedBRDF._continuous_index`, then ``lookup``'s nodes per axis: the lower and
    upper node (or the one node of "bin" and "nearest" in ``low``) and the upper node's
    weight, at ``[axis · n + j]`` (axis-major, int32: the loop over the pairs reads and
    writes them contiguously, and LLVM vectorises it at the float32 width).

    The rotations of ``to_half_diff`` by −φh about z and −θh about y take the cosines and
    sines of the angles from h itself, :math:`\cos\varphi_h = h_x/\sin\theta_h`,
    :math:`\sin\theta_h = |h_{xy}|`, :math:`\cos\theta_h = h_z` (φh = 0 where
    sin θh = 0), instead of trigonometric calls: equal to rounding."""
    jit = kernel_tools.jit()
    select = kernel_tools.select()
    prefer_vector_width = kernel_tools.vector_width_hint()
    atan2, _, _ = kernel_tools.trigonometry(dtype)
    clamp0, unit, remainder, integer = s
    zero, one = dtype(0), dtype(1)
    pi, half_pi, two_pi = dtype(math.pi), dtype(math.pi / 2), dtype(2 * math.pi)
    nudge = dtype(_NODE_TOLERANCE)
    isotropic, linear, bin_mode = rank == 3, interpolation == "linear", interpolation == "bin"

    @jit
    def wrap(index: Any, size: Any, periodic: bool) -> Any:
        """``lookup``'s wrap: np.remainder on periodic axes (index ∈ [−size, 2 size)), else
        clip."""
        if periodic:
            index = select(index < 0, index + size, index)
            return select(index >= size, index - size, index)
        index = select(index > 0, index, 0)
        return select(index < size - 1, index, size - 1)

    @jit
    def axis(u: Any, size: Any, periodic: bool, a: int, j: int, n: int, low: np.ndarray,
             high: np.ndarray, weight: np.ndarray) -> None:  # fmt: skip
        at = a * n + j
        if linear:
            floor = np.floor(u)
            i = integer(floor)
            low[at], high[at] = wrap(i, size, periodic), wrap(i + 1, size, periodic)
            weight[at] = u - floor
        else:
            rounded = np.floor(u + nudge) if bin_mode else np.rint(u)
            low[at] = wrap(integer(rounded), size, periodic)

    @kernel_tools.vector_jit()
    def cells(wi: np.ndarray, wo: np.ndarray, n: int, sizes: np.ndarray, upper: np.ndarray,
              low: np.ndarray, high: np.ndarray, weight: np.ndarray) -> None:  # fmt: skip
        n0, n_last = sizes[0], sizes[rank - 1]
        n_td, n_ph = sizes[rank - 2], sizes[1]
        prefer_vector_width()
        for j in range(n):
            i0, i1, i2 = wi[3 * j], wi[3 * j + 1], wi[3 * j + 2]
            o0, o1, o2 = wo[3 * j], wo[3 * j + 1], wo[3 * j + 2]
            upper[j] = (i2 > zero) & (o2 > zero)
            wx, wy, wz = unit(i0, i1, i2)
            vx, vy, vz = unit(o0, o1, o2)
            hx, hy, hz = unit(wx + vx, wy + vy, wz + vz)
            sin_h = np.sqrt(clamp0(hx * hx + hy * hy))
            theta_h = atan2(sin_h, hz)
            has_phi = sin_h != zero
            safe = select(has_phi, sin_h, one)
            cp, sp = select(has_phi, hx / safe, one), select(has_phi, hy / safe, zero)
            x1, y1 = cp * wx + sp * wy, cp * wy - sp * wx
            dx, dy, dz = hz * x1 - sin_h * wz, y1, sin_h * x1 + hz * wz
            theta_d = atan2(np.sqrt(clamp0(dx * dx + dy * dy)), dz)
            phi_d = atan2(dy, dx)
            u_th = np.sqrt(clamp0(theta_h) / half_pi) * dtype(n0)
            u_td = clamp0(theta_d) / half_pi * dtype(n_td)
            u_pd = remainder(phi_d, pi) / pi * dtype(n_last)
            axis(u_th, n0, False, 0, j, n, low, high, weight)
            if not isotropic:
                u_ph = remainder(atan2(hy, hx), two_pi) / two_pi * dtype(n_ph)
                axis(u_ph, n_ph, True, 1, j, n, low, high, weight)
            axis(u_td, n_td, False, rank - 2, j, n, low, high, weight)
            axis(u_pd, n_last, True, rank - 1, j, n, low, high, weight)

    return cells


def _corner_cells(
    dtype: type, rank: int, table_channels: int, interpolation: str
) -> Callable[..., None]:
    """``corner_cells(low, high, weight, sizes, n, flat, corner_weight)``: ``lookup``'s 2^D
    corners per pair, in its order: their rows of the flattened table and their multilinear
    weights (one corner of weight 1 for "bin" and "nearest"), at ``[corner · n + j]``
    (corner-major: a vectorised loop over the pairs per corner). No fast-math flags: the
    weights' products in ``lookup``'s order."""
    prefer_vector_width = kernel_tools.vector_width_hint()
    one = dtype(1)
    linear = interpolation == "linear"
    corners = 2**rank if linear else 1
    width = table_channels + 1

    @kernel_tools.exact_jit()
    def corner_cells(low: np.ndarray, high: np.ndarray, weight: np.ndarray, sizes: np.ndarray,
                     n: int, flat: np.ndarray, corner_weight: np.ndarray) -> None:  # fmt: skip
        for corner in range(corners):
            prefer_vector_width()
            for j in range(n):
                index, w = np.int64(0), one
                for a in range(rank):
                    upper_node = linear and ((corner >> (rank - 1 - a)) & 1) == 1
                    at = a * n + j
                    index = index * sizes[a] + (high[at] if upper_node else low[at])
                    if linear:
                        w = w * (weight[at] if upper_node else one - weight[at])
                flat[corner * n + j] = index * width
                corner_weight[corner * n + j] = w

    return corner_cells


def _gathers(
    dtype: type,
    rank: int,
    table_channels: int,
    channels: int,
    interpolation: str,
    cells: Callable[..., None],
    corner_cells: Callable[..., None],
) -> Callable[..., None]:
    """``evaluate(wi, wo, n, table, sizes, k, out)``: ``k · TabulatedBRDF.eval`` of n pairs
    into ``out`` (n × channels): the cells, the corners, then the gathers from the table, the
    renormalised measured weight and the upper-hemisphere mask. Each pair's rows are
    prefetched :data:`PREFETCH_DISTANCE` pairs ahead: a table larger than the caches (a
    90 × 90 × 180 RGB table with its measured flag is 23 MB in float32) makes a pair's reads
    a few cache misses, and the loop body is too long for the core to run far enough ahead
    on its own."""
    prefetch = kernel_tools.prefetch()
    zero, covered_min = dtype(0), dtype(1e-12)
    corners = 2**rank if interpolation == "linear" else 1
    cstep = 1 if table_channels > 1 else 0
    width = table_channels + 1

    @kernel_tools.jit()
    def evaluate(wi: np.ndarray, wo: np.ndarray, n: int, table: np.ndarray,
                 sizes: np.ndarray, k: np.ndarray, out: np.ndarray) -> None:  # fmt: skip
        upper = np.empty(n, np.bool_)
        low = np.empty(n * rank, np.int32)
        high = np.empty(n * rank, np.int32)
        weight = np.empty(n * rank, dtype)
        flat = np.empty(n * corners, np.int64)
        corner_weight = np.empty(n * corners, dtype)
        cells(wi, wo, n, sizes, upper, low, high, weight)
        corner_cells(low, high, weight, sizes, n, flat, corner_weight)
        values = table.reshape(-1)
        for j in range(min(n, PREFETCH_DISTANCE)):
            for corner in range(corners):
                prefetch(values, flat[corner * n + j])
        found = np.empty(width, dtype)
        for j in range(n):
            ahead = j + PREFETCH_DISTANCE
            if ahead < n:
                for corner in range(corners):
                    prefetch(values, flat[corner * n + ahead])
            if width == 4:  # RGB and the measured flag: four sums in registers
                f0, f1, f2, f3 = zero, zero, zero, zero
                for corner in range(corners):  # lookup(): the 2^D corners in its order
                    # unsigned: no negative-index wrap-around per read
                    at, w = np.uint64(flat[corner * n + j]), corner_weight[corner * n + j]
                    f0 += w * values[at]
                    f1 += w * values[at + np.uint64(1)]
                    f2 += w * values[at + np.uint64(2)]
                    f3 += w * values[at + np.uint64(3)]
                found[0], found[1], found[2], found[3] = f0, f1, f2, f3
            else:
                for c in range(width):
                    found[c] = zero
                for corner in range(corners):
                    at, w = np.uint64(flat[corner * n + j]), corner_weight[corner * n + j]
                    for c in range(width):
                        found[c] += w * values[at + np.uint64(c)]
            measured = found[table_channels]
            for c in range(channels):
                v = found[c * cstep] / measured if measured > covered_min else zero
                out[j * channels + c] = k[c] * v if upper[j] else zero

    return evaluate


def _eval_kernel(evaluate: Callable[..., None]) -> Callable[..., None]:
    """``evaluate`` with the calling convention of the BRDF kernels (module docstring)."""

    @kernel_tools.jit()
    def eval_fn(params: np.ndarray, wi: np.ndarray, wo: np.ndarray, out: np.ndarray, n: int,
                table: np.ndarray,
                sizes: np.ndarray, k: np.ndarray, share: Any, density: np.ndarray,
                marginal: np.ndarray, conditional: np.ndarray, one_minus_cos: np.ndarray,
                n_theta: int, n_phi: int, guide: np.ndarray) -> None:  # fmt: skip
        evaluate(wi, wo, n, table, sizes, k, out)

    return eval_fn


def _mixture_pdf(dtype: type, rank: int, s: _Scalars) -> Callable[..., None]:
    r"""The mixture's pdf ``pdf_fn`` (the BRDF kernels' calling convention):
    ``MixtureSampled.pdf``, :math:`(1 - s)\cos\theta_i/\pi + s\,p_h(h)/(4\,\omega_o
    \cdot h)`, with ``HalfVectorSampling.pdf``'s half-vector density read at h's cell of
    its density table. Three loops: the half vectors' cells (vectorised), the density reads
    (a gather keeps LLVM from vectorising a loop), the mixture (vectorised)."""
    jit = kernel_tools.jit()
    select = kernel_tools.select()
    prefer_vector_width = kernel_tools.vector_width_hint()
    atan2, _, _ = kernel_tools.trigonometry(dtype)
    _, unit, remainder, integer = s
    zero, one, four = dtype(0), dtype(1), dtype(4)
    pi, half_pi, two_pi = dtype(math.pi), dtype(math.pi / 2), dtype(2 * math.pi)
    isotropic = rank == 3

    @jit
    def half_vector_cell(i0: Any, i1: Any, i2: Any, o0: Any, o1: Any, o2: Any, n_theta: int,
                         n_phi: int) -> tuple[Any, Any, Any]:  # fmt: skip
        """h of the pair, its cell of ``HalfVectorSampling.density`` (flattened), wo·h and
        h_z."""
        hx, hy, hz = unit(i0 + o0, i1 + o1, i2 + o2)
        wo_dot_h = o0 * hx + o1 * hy + o2 * hz
        theta = atan2(np.sqrt(hx * hx + hy * hy), hz)
        row = min(max(np.floor(np.sqrt(theta / half_pi) * dtype(n_theta)), zero),
                  dtype(n_theta - 1))  # fmt: skip
        index = integer(row) * n_phi
        if not isotropic:
            phi = remainder(atan2(hy, hx), two_pi)
            col = min(max(np.floor(phi / two_pi * dtype(n_phi)), zero), dtype(n_phi - 1))
            index += integer(col)
        return index, wo_dot_h, hz

    @jit
    def mixture_pdf(i2: Any, o2: Any, share: Any, density_h: Any, wo_dot_h: Any,
                    hz: Any) -> Any:  # fmt: skip
        p_h = select(hz > zero, density_h, zero)
        term = select(wo_dot_h > zero, p_h / (four * select(wo_dot_h > zero, wo_dot_h, one)),
                      zero)  # fmt: skip
        total = (one - share) * (max(i2, zero) / pi)
        total = select(share > zero, total + share * term, total)
        return select((i2 > zero) & (o2 > zero), total, zero)

    @kernel_tools.vector_jit()
    def pdf_fn(params: np.ndarray, wi: np.ndarray, wo: np.ndarray, out: np.ndarray, n: int,
               table: np.ndarray,
               sizes: np.ndarray, k: np.ndarray, share: Any, density: np.ndarray,
               marginal: np.ndarray, conditional: np.ndarray, one_minus_cos: np.ndarray,
               n_theta: int, n_phi: int, guide: np.ndarray) -> None:  # fmt: skip
        index, wo_dot_h, hz = np.empty(n, np.int32), np.empty(n, dtype), np.empty(n, dtype)
        prefer_vector_width()
        for j in range(n):
            index[j], wo_dot_h[j], hz[j] = half_vector_cell(
                wi[3 * j], wi[3 * j + 1], wi[3 * j + 2], wo[3 * j], wo[3 * j + 1],
                wo[3 * j + 2], n_theta, n_phi,
            )  # fmt: skip
        for j in range(n):
            out[j] = density[index[j]]
        for j in range(n):
            out[j] = mixture_pdf(wi[3 * j + 2], wo[3 * j + 2], share, out[j], wo_dot_h[j],
                                 hz[j])  # fmt: skip

    return pdf_fn


def _mixture_sample(
    dtype: type,
    rank: int,
    channels: int,
    s: _Scalars,
    evaluate: Callable[..., None],
    pdf_fn: Callable[..., None],
) -> Callable[..., None]:
    r"""The mixture's sampler ``sample_fn`` (the BRDF kernels' calling convention):
    ``MixtureSampled.sample`` with ``mixture_choices`` on the first two uniforms, the cosine
    lobe or ``HalfVectorSampling.sample``'s half vector (:func:`_half_vector_sampling`)
    reflected, then the mixture's pdf and the weight :math:`f\cos\theta_i/p`. The
    half-vector lobe runs in several loops: the gathers of the cells' CDF nodes and edges in
    their own (scalar) loops, the arithmetic between and after them vectorised."""
    select = kernel_tools.select()
    prefer_vector_width = kernel_tools.vector_width_hint()
    guided_interval = kernel_tools.guided_search()
    find_intervals, cell_point, half_vector = _half_vector_sampling(dtype, s)
    cosine_sample = _cosine_sampling(dtype)
    integer = s.integer
    zero, one, two = dtype(0), dtype(1), dtype(2)
    below_one_64 = 1 - np.finfo(np.float64).eps / 2
    stretch_max = dtype(1.0 - 1e-7)
    isotropic = rank == 3

    @kernel_tools.jit()
    def sample_fn(params: np.ndarray, wo: np.ndarray, u: np.ndarray, wi: np.ndarray,
                  weight: np.ndarray,
                  pdf: np.ndarray, delta: np.ndarray, n: int, table: np.ndarray,
                  sizes: np.ndarray, k: np.ndarray, share: Any, density: np.ndarray,
                  marginal: np.ndarray, conditional: np.ndarray, one_minus_cos: np.ndarray,
                  n_theta: int, n_phi: int, guide: np.ndarray) -> None:  # fmt: skip
        cosine_share = one - share
        span = select(cosine_share > zero, cosine_share, one)
        half_span = select(share > zero, share, one)
        half = np.empty(n, np.bool_)
        a, b = np.empty(n, np.float64), np.empty(n, np.float64)
        rows, cols, base = np.empty(n, np.int64), np.empty(n, np.int64), np.empty(n, np.int64)
        m0, m1 = np.empty(n, np.float64), np.empty(n, np.float64)
        c0, c1 = np.empty(n, np.float64), np.empty(n, np.float64)
        x, scaled, cell = np.empty(n, dtype), np.empty(n, dtype), np.empty(n, dtype)
        lo, hi = np.empty(n, dtype), np.empty(n, dtype)
        prefer_vector_width()
        for j in range(n):  # the cosine lobe where chosen, the half vector's variates
            u0, u1 = u[3 * j], u[3 * j + 1]
            half[j] = (share != zero) & (u0 >= cosine_share)
            cx, cy, cz = cosine_sample(min(max(u0 / span, zero), stretch_max), u1)
            wi[3 * j], wi[3 * j + 1], wi[3 * j + 2] = cx, cy, cz
            stretched = min(max((u0 - cosine_share) / half_span, zero), stretch_max)
            a[j] = min(np.float64(stretched), below_one_64)
            b[j] = min(np.float64(u1), below_one_64)
            base[j] = 0
            delta[j] = False
        for j in range(n):  # the θh marginal's rows, from the guide table
            rows[j] = guided_interval(marginal, 0, guide, 0, guide.shape[0], b[j], n_theta)
            base[j] = rows[j] * (n_phi + 1)
        if isotropic:  # one column per row: find_intervals would find column 0
            for j in range(n):
                cols[j] = 0
        else:
            find_intervals(conditional, base, a, n_phi, n, cols)
        for j in range(n):  # the found cells' CDF nodes
            m0[j], m1[j] = marginal[rows[j]], marginal[rows[j] + 1]
            at = base[j] + cols[j]
            c0[j], c1[j] = conditional[at], conditional[at + 1]
        prefer_vector_width()
        for j in range(n):
            x[j], scaled[j], cell[j] = cell_point(a[j], b[j], rows[j], cols[j], m0[j], m1[j],
                                                  c0[j], c1[j], n_theta, n_phi)  # fmt: skip
        for j in range(n):  # the θh cells' edges
            i = integer(cell[j])
            lo[j], hi[j] = one_minus_cos[i], one_minus_cos[i + 1]
        prefer_vector_width()
        for j in range(n):  # the half-vector lobe's directions where chosen
            o0, o1, o2 = wo[3 * j], wo[3 * j + 1], wo[3 * j + 2]
            hx, hy, hz = half_vector(x[j], scaled[j], cell[j], lo[j], hi[j])
            d = two * (o0 * hx + o1 * hy + o2 * hz)
            pick = half[j]
            wi[3 * j] = select(pick, d * hx - o0, wi[3 * j])
            wi[3 * j + 1] = select(pick, d * hy - o1, wi[3 * j + 1])
            wi[3 * j + 2] = select(pick, d * hz - o2, wi[3 * j + 2])
        pdf_fn(params, wi, wo, pdf, n, table, sizes, k, share, density, marginal, conditional,
               one_minus_cos, n_theta, n_phi, guide)  # fmt: skip
        evaluate(wi, wo, n, table, sizes, k, weight)
        for j in range(n):
            p = pdf[j]
            ratio = wi[3 * j + 2] / select(p > zero, p, one)
            for c in range(channels):
                weight[j * channels + c] = select(p > zero, weight[j * channels + c] * ratio, zero)

    return sample_fn


def _half_vector_sampling(
    dtype: type, s: _Scalars
) -> tuple[Callable[..., None], Callable[..., Any], Callable[..., Any]]:
    """``HalfVectorSampling.sample`` in three parts: ``find_intervals(cdf, base, u, count,
    n, out)``, ``sampling._find_interval`` for n variates in lock step (the same bisection
    steps, each over all of them: a vectorisable inner loop); ``cell_point(u0, u1, row, col,
    m0, m1, c0, c1, n_theta, n_phi)``, the point in the found row and column for float64
    uniforms (u0: φh, u1: θh, clamped below 1; m0, m1 and c0, c1 their CDF nodes): its x
    (φh / 2π), y · N_θh and θh cell; and ``half_vector(x, scaled, cell, lo, hi)``, the half
    vector at that point, lo and hi the 1 − cos θ of its θh cell's edges."""
    jit = kernel_tools.jit()
    select = kernel_tools.select()
    prefer_vector_width = kernel_tools.vector_width_hint()
    _, sin, cos = kernel_tools.trigonometry(dtype)
    clamp0 = s.clamp0
    one, two, two_pi = dtype(1), dtype(2), dtype(2 * math.pi)
    below_one = dtype(1 - np.finfo(dtype).eps / 2)

    @kernel_tools.vector_jit()
    def find_intervals(cdf: np.ndarray, base: np.ndarray, u: np.ndarray, count: int, n: int,
                       out: np.ndarray) -> None:  # fmt: skip
        hi = np.empty(n, np.int64)
        for j in range(n):
            out[j], hi[j] = 0, count
        for _ in range(max(1, math.ceil(math.log2(count))) + 1):
            prefer_vector_width()
            for j in range(n):
                mid = (out[j] + hi[j]) >> 1
                right = cdf[base[j] + mid] <= u[j]
                out[j], hi[j] = select(right, mid, out[j]), select(right, hi[j], mid)

    @jit
    def cell_point(u0: float, u1: float, row: int, col: int, m0: float, m1: float, c0: float,
                   c1: float, n_theta: int, n_phi: int) -> tuple[Any, Any, Any]:  # fmt: skip
        x = dtype((col + (u0 - c0) / (c1 - c0)) / n_phi)
        x = select(x < below_one, x, below_one)
        y = dtype((row + (u1 - m0) / (m1 - m0)) / n_theta)
        y = select(y < below_one, y, below_one)
        scaled = y * dtype(n_theta)
        cell = np.floor(scaled)
        return x, scaled, select(cell < dtype(n_theta - 1), clamp0(cell), dtype(n_theta - 1))

    @jit
    def half_vector(x: Any, scaled: Any, cell: Any, lo: Any, hi: Any) -> tuple[Any, Any, Any]:
        omc = lo + (scaled - cell) * (hi - lo)
        sin_theta = np.sqrt(clamp0(omc * (two - omc)))
        phi = x * two_pi
        return sin_theta * cos(phi), sin_theta * sin(phi), one - omc

    return find_intervals, cell_point, half_vector


def _cosine_sampling(dtype: type) -> Callable[..., Any]:
    """``cosine_sample(a, b)``: ``square_to_cosine_hemisphere``, the concentric disk (Shirley
    and Chiu) lifted to the hemisphere (Malley), branch-free."""
    select = kernel_tools.select()
    _, sin, cos = kernel_tools.trigonometry(dtype)
    zero, one, two = dtype(0), dtype(1), dtype(2)
    quarter_pi, half_pi = dtype(math.pi / 4), dtype(math.pi / 2)

    @kernel_tools.jit()
    def cosine_sample(a: Any, b: Any) -> tuple[Any, Any, Any]:
        p, q = two * a - one, two * b - one
        flip = np.abs(p) < np.abs(q)
        r, other = select(flip, q, p), select(flip, p, q)
        phi = quarter_pi * select(r != zero, other / select(r != zero, r, one), zero)
        phi = select(flip, half_pi - phi, phi)
        x, y = r * cos(phi), r * sin(phi)
        return x, y, np.sqrt(max(one - (x * x + y * y), zero))

    return cosine_sample


GUIDE_BUCKETS = 4
"""Buckets of :func:`~brdfkit.compiled.kernel_tools.guide_table` per cell of the θh marginal:
from the guide a sample's row search is a scan of a step or two instead of a bisection."""


EVAL_CHUNK = 4096
"""Pairs per call (and per task of the threads) of the ``eval`` kernel in
:meth:`TableKernels.eval` (elementwise: the values do not depend on it), so that its
per-pair scratch arrays stay in cache."""


class TableKernels:
    """A (scaled) table's numba ``sample``/``eval``/``pdf`` and their array arguments.

    ``functions`` (``sample``, ``eval``, ``pdf``) follow the BRDF kernels' calling convention
    (module docstring) with ``data`` appended; ``parameters`` is their leading argument (a
    table has none); :meth:`eval` evaluates broadcast direction arrays (the control
    variate's floor) on the kernels' threads.
    """

    def __init__(self, table: TabulatedBRDF, k: np.ndarray, channels: int, dtype: Any) -> None:
        t = np.dtype(dtype)
        half = table.half_vector_sampling
        distribution = half._distribution
        n_theta, n_phi = half.density.shape
        if distribution is None:  # no half-vector lobe (share 0): CDFs of the right sizes
            marginal = np.linspace(0.0, 1.0, n_theta + 1)
            conditional = np.tile(np.linspace(0.0, 1.0, n_phi + 1), n_theta)
        else:
            marginal, conditional = distribution._marginal, distribution._conditional
        self.channels = channels
        self.data = (
            np.ascontiguousarray(table._table, dtype=t),
            np.asarray(table.shape, np.int64),
            np.ascontiguousarray(np.broadcast_to(k, (channels,)), dtype=t),
            t.type(half.probability),
            np.ascontiguousarray(half.density.ravel(), dtype=t),
            np.ascontiguousarray(marginal, dtype=np.float64),
            np.ascontiguousarray(conditional, dtype=np.float64),
            np.ascontiguousarray(half._one_minus_cos, dtype=t),
            int(n_theta),
            int(n_phi),
            kernel_tools.guide_table(marginal, int(n_theta), GUIDE_BUCKETS * int(n_theta)),
        )
        self.dtype = t
        self.parameters = np.zeros(0, t)  # the kernels' leading argument; a table has none
        self.functions = _table_functions(
            t.type, len(table.shape), table.channels, channels, table.interpolation
        )

    def eval(self, wi: Any, wo: Any) -> np.ndarray:
        """f(wi, wo) of broadcast ``(..., 3)`` arrays, ``(..., C)`` in the kernel's dtype."""
        wi, wo = np.broadcast_arrays(np.asarray(wi, self.dtype), np.asarray(wo, self.dtype))
        batch = wi.shape[:-1]
        n = math.prod(batch)
        out = np.empty(n * self.channels, self.dtype)
        wi_flat, wo_flat = (v.reshape(-1).copy() for v in (wi, wo))
        c = self.channels

        def run(lo: int) -> None:  # chunks: the kernel's scratch stays in cache
            hi = min(lo + EVAL_CHUNK, n)
            self.functions[1](
                self.parameters, wi_flat[3 * lo : 3 * hi], wo_flat[3 * lo : 3 * hi],
                out[c * lo : c * hi], hi - lo, *self.data,
            )  # fmt: skip

        # on the kernels' threads (the kernel releases the GIL)
        kernel_tools.run_tasks(run, range(0, n, EVAL_CHUNK), kernel_tools.threads())
        return out.reshape(*batch, self.channels)

    def built(self) -> bool:
        """Whether the numba functions are compiled for this dtype."""
        return all(f.signatures for f in self.functions)


_KERNELS: weakref.WeakKeyDictionary[BRDF, dict[np.dtype, TableKernels]] = (
    weakref.WeakKeyDictionary()
)


def _unscaled(model: BRDF) -> tuple[TabulatedBRDF, np.ndarray] | None:
    """``(table, k)`` for a table or a product of constant scales and a table, else None."""
    k: np.ndarray = np.ones(1)
    while isinstance(model, Scaled):
        factor = np.asarray(model.k, np.float64)
        if factor.ndim > 1:
            return None
        k = k * factor.reshape(-1)
        model = model.inner
    return (model, k) if isinstance(model, TabulatedBRDF) else None


def table_kernels(model: BRDF, dtype: Any) -> TableKernels | None:
    """The kernels of a :class:`~brdfkit.measured.TabulatedBRDF` (or a constant
    :class:`~brdfkit.brdf.base.Scaled` one), kept per model object; ``None`` for other
    models. Raises ``ImportError`` without numba."""
    found = _unscaled(model)
    if found is None:
        return None
    dtype = np.dtype(dtype)
    per_dtype = _KERNELS.setdefault(model, {})
    if dtype not in per_dtype:
        table, k = found
        per_dtype[dtype] = TableKernels(table, k, model.channels, dtype)
    return per_dtype[dtype]


__all__ = ["TableKernels", "table_kernels"]
