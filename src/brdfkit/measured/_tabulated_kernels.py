r"""Tabulated (MERL-layout) BRDFs on the compiled shading path.

:mod:`brdfkit.compiled` traces array-API code; a table lookup (gathers at computed indices)
and a CDF search cannot be traced, so this module writes the
:class:`~brdfkit.measured.TabulatedBRDF`'s ``eval``, ``pdf`` and ``sample`` once as numba
functions with the calling convention of the kernels :mod:`brdfkit.render._reflection_kernels`'s
tile kernel calls (flat buffers of a block of pixels, then the table's arrays as trailing
arguments: the table is a kernel *input*, never a compile-time constant, so one compilation
serves every table of the same rank, channel count and interpolation).

Each function re-expresses, operation by operation and in the kernel's dtype, the NumPy code
that stays the reference (tests hold them equal: float64 to rounding, float32 to float32
precision):

- ``eval``: :func:`brdfkit.geometry.to_half_diff` (the two rotations by −φh and −θh written
  with :math:`\cos\varphi_h = h_x/\sin\theta_h`, :math:`\sin\theta_h = |h_{xy}|`,
  :math:`\cos\theta_h = h_z` instead of trigonometric calls: equal to rounding),
  :meth:`TabulatedBRDF._continuous_index` and :func:`brdfkit.measured.tabulated.lookup`
  (``"bin"``, ``"nearest"``, ``"linear"``: the 2^D corners in the same order), the renormalised
  measured weight and the upper-hemisphere mask;
- ``pdf`` and ``sample``: the one-sample mixture of the cosine hemisphere and the table's
  half-vector marginal (:class:`~brdfkit.measured.tabulated.HalfVectorSampling`, its
  :class:`~brdfkit.sampling.Distribution2D` searched in float64 by the same bisection), as
  :class:`~brdfkit.brdf.phong.MixtureSampled` combines them. The sampler is the NumPy path's,
  so it is unbiased for the same reason: the mixture density is positive wherever
  :math:`f\cos\theta_i` is (the cosine lobe keeps at least 10 %), and the weight is
  :math:`f\cos\theta_i/p` of the sampled direction.

A :class:`~brdfkit.brdf.base.Scaled` table (constant k) multiplies ``eval`` and the weights by k.

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
from typing import Any

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
"""Pairs ahead whose table rows :func:`_new_table_functions`' ``eval`` prefetches. Measured
on the 90 × 90 × 180 RGB benchmark table, random pairs in blocks of 256 (the render's), CPU
per pair on a loaded 2-core machine: 110 ns without, 61 / 47 / 40 / 37.5 / 40.5 ns at 4 / 8 /
16 / 32 / 64 pairs ahead."""


def _new_table_functions(
    dtype: type, rank: int, table_channels: int, channels: int, interpolation: str
) -> tuple[Callable[..., None], Callable[..., None], Callable[..., None]]:
    """The numba ``sample``, ``eval`` and ``pdf`` of a table of ``rank`` (3: isotropic, 4:
    anisotropic) with ``table_channels`` value channels, scaled to ``channels``.

    ``eval`` runs in three loops over the batch: the half/difference angles and the cells'
    indices and weights branch-free (LLVM vectorises it; float32 with the branch-free
    trigonometry of :func:`~brdfkit.compiled.kernel_tools.trigonometry`), the corners' table
    rows and
    weights, then the gathers from the table, each pair's rows prefetched :data:`PREFETCH_DISTANCE`
    pairs ahead. The vectorised loops write their node and cell indices as int32 (an axis's
    or the θh marginal's cells: small): with int64 outputs LLVM held them to 4 float32 lanes
    (the width of 4 int64 in AVX2), with int32 to 8 (measured, one core, blocks of 256:
    eval 65 → 56, pdf 15 → 12, sample 144 → 115 ns per pair, values bit-equal).
    A 90 × 90 × 180 RGB table (its value channels and the measured flag: 23 MB in float32)
    does not stay in the caches of a render, so its 2^D corners are cache misses; with the
    prefetches they overlap (measured: 10⁶ random pairs, 0.11 → 0.06 s).
    """
    jit = kernel_tools.jit()  # helpers: their caller's flags
    # the vectorised loops: the fast-math flags and vector width of the traced kernels
    vector_jit = kernel_tools.vector_jit()
    # no fast-math flags: lookup's corner weights, products in its order
    corner_jit = kernel_tools.exact_jit()
    prefer_vector_width = kernel_tools.vector_width_hint()
    prefetch = kernel_tools.prefetch()
    select = kernel_tools.select()
    T = dtype
    atan2, sin, cos = kernel_tools.trigonometry(T)
    guided_interval = kernel_tools.guided_search()
    zero, one, two, four = T(0), T(1), T(2), T(4)
    pi, half_pi, two_pi = T(math.pi), T(math.pi / 2), T(2 * math.pi)
    quarter_pi = T(math.pi / 4)
    tiny = T(np.finfo(np.float32).tiny)
    covered_min = T(1e-12)
    nudge = T(_NODE_TOLERANCE)
    below_one_64 = 1 - np.finfo(np.float64).eps / 2
    below_one = T(1 - np.finfo(T).eps / 2)
    stretch_max = T(1.0 - 1e-7)
    corners = 2**rank if interpolation == "linear" else 1
    isotropic = rank == 3
    cstep = 1 if table_channels > 1 else 0
    linear = interpolation == "linear"
    bin_mode = interpolation == "bin"
    width = table_channels + 1

    @jit
    def clamp0(x: Any) -> Any:
        """max(x, 0), branch-free (NaN gives 0, as ``safe_sqrt``'s fmax)."""
        return select(x > zero, x, zero)

    @jit
    def unit(x: Any, y: Any, z: Any) -> tuple[Any, Any, Any]:
        """:func:`brdfkit._array.normalize`."""
        length = np.sqrt(x * x + y * y + z * z)
        length = select(length > tiny, length, tiny)
        return x / length, y / length, z / length

    @jit
    def remainder(x: Any, period: Any) -> Any:
        """np.remainder(x, period) for x ∈ [−period, period] (angles from atan2)."""
        wrapped = select(x < zero, x + period, x)
        return select(wrapped >= period, zero, wrapped)

    @jit
    def integer(x: Any) -> Any:
        """int64 of a float index (NaN, from degenerate input, reads index 0), by way of
        int32: AVX2 converts floats to int32 in vectors, to int64 only one by one."""
        return np.int64(np.int32(select(np.abs(x) < T(1e9), x, zero)))

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
        """One axis of ``lookup``: its lower and upper node (or the one node of "bin" and
        "nearest" in ``low``) and the upper node's weight, at ``[a · n + j]`` (axis-major:
        the loops over the pairs read and write them contiguously, so LLVM vectorises them)."""
        at = a * n + j
        if linear:
            floor = np.floor(u)
            i = integer(floor)
            low[at], high[at] = wrap(i, size, periodic), wrap(i + 1, size, periodic)
            weight[at] = u - floor
        else:
            rounded = np.floor(u + nudge) if bin_mode else np.rint(u)
            low[at] = wrap(integer(rounded), size, periodic)

    @vector_jit
    def cells(wi: np.ndarray, wo: np.ndarray, n: int, sizes: np.ndarray, upper: np.ndarray,
              low: np.ndarray, high: np.ndarray, weight: np.ndarray) -> None:  # fmt: skip
        """``to_half_diff`` and ``_continuous_index`` per pair, then :func:`axis`."""
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
            # to_half_diff's rotations by −φh about z and −θh about y, with the cosines and
            # sines of the angles from h itself (φh = atan2(hy, hx) = 0 when sin θh = 0)
            has_phi = sin_h != zero
            safe = select(has_phi, sin_h, one)
            cp, sp = select(has_phi, hx / safe, one), select(has_phi, hy / safe, zero)
            x1, y1 = cp * wx + sp * wy, cp * wy - sp * wx
            dx, dy, dz = hz * x1 - sin_h * wz, y1, sin_h * x1 + hz * wz
            theta_d = atan2(np.sqrt(clamp0(dx * dx + dy * dy)), dz)
            phi_d = atan2(dy, dx)
            u_th = np.sqrt(clamp0(theta_h) / half_pi) * T(n0)
            u_td = clamp0(theta_d) / half_pi * T(n_td)
            u_pd = remainder(phi_d, pi) / pi * T(n_last)
            axis(u_th, n0, False, 0, j, n, low, high, weight)
            if not isotropic:
                u_ph = remainder(atan2(hy, hx), two_pi) / two_pi * T(n_ph)
                axis(u_ph, n_ph, True, 1, j, n, low, high, weight)
            axis(u_td, n_td, False, rank - 2, j, n, low, high, weight)
            axis(u_pd, n_last, True, rank - 1, j, n, low, high, weight)

    @corner_jit
    def corner_cells(low: np.ndarray, high: np.ndarray, weight: np.ndarray, sizes: np.ndarray,
                     n: int, flat: np.ndarray, corner_weight: np.ndarray) -> None:  # fmt: skip
        """``lookup``'s corners per pair, in its order: their rows of the flattened table
        and their multilinear weights (one corner of weight 1 for "bin" and "nearest"), at
        ``[corner · n + j]`` (corner-major: a vectorised loop over the pairs per corner)."""
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

    @jit
    def evaluate(wi: np.ndarray, wo: np.ndarray, n: int, table: np.ndarray,
                 sizes: np.ndarray, k: np.ndarray, out: np.ndarray) -> None:  # fmt: skip
        """``k · TabulatedBRDF.eval`` of n pairs into ``out`` (n × channels): the cells,
        then the gathers, each pair's rows prefetched :data:`PREFETCH_DISTANCE` pairs ahead
        (a pair's reads are a few cache misses in a table larger than the cache; the loop
        body is too long for the core to run far enough ahead on its own)."""
        upper = np.empty(n, np.bool_)
        low = np.empty(n * rank, np.int32)
        high = np.empty(n * rank, np.int32)
        weight = np.empty(n * rank, T)
        flat = np.empty(n * corners, np.int64)
        corner_weight = np.empty(n * corners, T)
        cells(wi, wo, n, sizes, upper, low, high, weight)
        corner_cells(low, high, weight, sizes, n, flat, corner_weight)
        values = table.reshape(-1)
        for j in range(min(n, PREFETCH_DISTANCE)):
            for corner in range(corners):
                prefetch(values, flat[corner * n + j])
        found = np.empty(width, T)
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

    @jit
    def half_vector_cell(i0: Any, i1: Any, i2: Any, o0: Any, o1: Any, o2: Any, n_theta: int,
                         n_phi: int) -> tuple[Any, Any, Any]:  # fmt: skip
        """h of the pair, its cell of ``HalfVectorSampling.density`` (flattened), wo·h and
        h_z."""
        hx, hy, hz = unit(i0 + o0, i1 + o1, i2 + o2)
        wo_dot_h = o0 * hx + o1 * hy + o2 * hz
        theta = atan2(np.sqrt(hx * hx + hy * hy), hz)
        row = min(max(np.floor(np.sqrt(theta / half_pi) * T(n_theta)), zero), T(n_theta - 1))
        index = integer(row) * n_phi
        if not isotropic:
            phi = remainder(atan2(hy, hx), two_pi)
            col = min(max(np.floor(phi / two_pi * T(n_phi)), zero), T(n_phi - 1))
            index += integer(col)
        return index, wo_dot_h, hz

    @jit
    def mixture_pdf(i2: Any, o2: Any, share: Any, density_h: Any, wo_dot_h: Any,
                    hz: Any) -> Any:  # fmt: skip
        """``MixtureSampled.pdf``: (1 − s) cos θi/π + s p_h(h)/(4 wo·h), the half-vector
        density ``HalfVectorSampling.pdf`` (``reflected_pdf``) read at h's cell."""
        p_h = select(hz > zero, density_h, zero)
        term = select(wo_dot_h > zero, p_h / (four * select(wo_dot_h > zero, wo_dot_h, one)),
                      zero)  # fmt: skip
        total = (one - share) * (max(i2, zero) / pi)
        total = select(share > zero, total + share * term, total)
        return select((i2 > zero) & (o2 > zero), total, zero)

    @vector_jit
    def find_intervals(cdf: np.ndarray, base: np.ndarray, u: np.ndarray, count: int, n: int,
                       out: np.ndarray) -> None:  # fmt: skip
        """``sampling._find_interval`` for n variates in lock step (the same bisection
        steps, each over all of them: a vectorisable inner loop); into ``out``."""
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
        """``HalfVectorSampling.sample``'s first part for float64 uniforms (u0: φh, u1: θh,
        clamped below 1) in the row and column the CDF searches found (m0, m1 and c0, c1: its
        CDF nodes): the point's x (φh / 2π), y · N_θh and θh cell."""
        x = T((col + (u0 - c0) / (c1 - c0)) / n_phi)
        x = select(x < below_one, x, below_one)
        y = T((row + (u1 - m0) / (m1 - m0)) / n_theta)
        y = select(y < below_one, y, below_one)
        scaled = y * T(n_theta)
        cell = np.floor(scaled)
        return x, scaled, select(cell < T(n_theta - 1), clamp0(cell), T(n_theta - 1))

    @jit
    def half_vector(x: Any, scaled: Any, cell: Any, lo: Any, hi: Any) -> tuple[Any, Any, Any]:
        """``HalfVectorSampling.sample``'s half vector at the point of :func:`cell_point`,
        lo and hi the 1 − cos θ of its θh cell's edges."""
        omc = lo + (scaled - cell) * (hi - lo)
        sin_theta = np.sqrt(clamp0(omc * (two - omc)))
        phi = x * two_pi
        return sin_theta * cos(phi), sin_theta * sin(phi), one - omc

    @jit
    def cosine_sample(a: Any, b: Any) -> tuple[Any, Any, Any]:
        """``square_to_cosine_hemisphere``: the concentric disk lifted (Malley)."""
        p, q = two * a - one, two * b - one
        flip = np.abs(p) < np.abs(q)
        r, other = select(flip, q, p), select(flip, p, q)
        phi = quarter_pi * select(r != zero, other / select(r != zero, r, one), zero)
        phi = select(flip, half_pi - phi, phi)
        x, y = r * cos(phi), r * sin(phi)
        return x, y, np.sqrt(max(one - (x * x + y * y), zero))

    @jit
    def eval_fn(params: np.ndarray, wi: np.ndarray, wo: np.ndarray, out: np.ndarray, n: int,
                table: np.ndarray,
                sizes: np.ndarray, k: np.ndarray, share: Any, density: np.ndarray,
                marginal: np.ndarray, conditional: np.ndarray, one_minus_cos: np.ndarray,
                n_theta: int, n_phi: int, guide: np.ndarray) -> None:  # fmt: skip
        evaluate(wi, wo, n, table, sizes, k, out)

    @vector_jit
    def pdf_fn(params: np.ndarray, wi: np.ndarray, wo: np.ndarray, out: np.ndarray, n: int,
               table: np.ndarray,
               sizes: np.ndarray, k: np.ndarray, share: Any, density: np.ndarray,
               marginal: np.ndarray, conditional: np.ndarray, one_minus_cos: np.ndarray,
               n_theta: int, n_phi: int, guide: np.ndarray) -> None:  # fmt: skip
        """The mixture's pdf in three loops: the half vectors' cells (vectorised), the
        density reads (a gather keeps LLVM from vectorising a loop), the mixture
        (vectorised)."""
        index, wo_dot_h, hz = np.empty(n, np.int32), np.empty(n, T), np.empty(n, T)
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

    @jit
    def sample_fn(params: np.ndarray, wo: np.ndarray, u: np.ndarray, wi: np.ndarray,
                  weight: np.ndarray,
                  pdf: np.ndarray, delta: np.ndarray, n: int, table: np.ndarray,
                  sizes: np.ndarray, k: np.ndarray, share: Any, density: np.ndarray,
                  marginal: np.ndarray, conditional: np.ndarray, one_minus_cos: np.ndarray,
                  n_theta: int, n_phi: int, guide: np.ndarray) -> None:  # fmt: skip
        """``MixtureSampled.sample`` (mixture_choices on the first two uniforms). The
        half-vector lobe in four loops: the gathers of the cells' CDF nodes and edges in
        their own (scalar) loops, the arithmetic between and after them vectorised (one loop
        with the gathers ran scalar: ~40 of a sample's ~145 ns per pair)."""
        cosine_share = one - share
        span = select(cosine_share > zero, cosine_share, one)
        half_span = select(share > zero, share, one)
        half = np.empty(n, np.bool_)
        a, b = np.empty(n, np.float64), np.empty(n, np.float64)
        rows, cols, base = np.empty(n, np.int64), np.empty(n, np.int64), np.empty(n, np.int64)
        m0, m1 = np.empty(n, np.float64), np.empty(n, np.float64)
        c0, c1 = np.empty(n, np.float64), np.empty(n, np.float64)
        x, scaled, cell = np.empty(n, T), np.empty(n, T), np.empty(n, T)
        lo, hi = np.empty(n, T), np.empty(n, T)
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

    return sample_fn, eval_fn, pdf_fn


GUIDE_BUCKETS = 4
"""Buckets of :func:`~brdfkit.compiled.kernel_tools.guide_table` per cell of the θh marginal:
from the guide a sample's row search is a scan of a step or two instead of a bisection."""


EVAL_CHUNK = 4096
"""Pairs per call (and per task of the threads) of the ``eval`` kernel in
:meth:`TableKernels.eval` (elementwise: the values do not depend on it). One call over a
whole image's control-variate pairs (~10⁶) streams its per-pair scratch arrays through
memory; measured ~2× slower."""


class TableKernels:
    """A (scaled) table's numba ``sample``/``eval``/``pdf`` and their array arguments.

    ``functions`` follow :mod:`brdfkit.render._reflection_kernels`'s calling convention with
    ``data`` appended; :meth:`eval` evaluates broadcast direction arrays (the control variate's
    floor).
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

        # on the kernels' threads (the kernel releases the GIL): the control variate's floor of a
        # 256² render is ~8×10⁵ pairs, ~40 ms on one core
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
