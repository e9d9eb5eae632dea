r"""The environment map's lookups as numba functions, for compiled shading kernels.

Each function restates, operation by operation and in the kernel's dtype, code of
:mod:`brdfkit.light.environment` (the readable reference; ``tests/light/
test_environment_kernels.py`` holds each pair equal on random inputs):

- :func:`unit` — :func:`brdfkit._array.normalize`, v / max(|v|, tiny);
- ``map_coordinates`` — ``EnvironmentMap._map_coordinates`` of a unit world direction:
  :math:`x = (\varphi \bmod 2\pi)/2\pi`, :math:`y = \theta/\pi` and :math:`\sin\theta`
  (instead of θ, for the pdf), branch-free;
- ``texel_cell`` and ``bilinear`` — ``_bilinear`` (``EnvironmentMap._lookup``): the four
  texels around :math:`(yH - \tfrac12, xW - \tfrac12)`, rows clamped, columns wrapping, and
  their bilinear weights;
- ``pdf_texel`` and ``solid_angle_pdf`` — ``EnvironmentMap.pdf``: the texel of
  :meth:`~brdfkit.sampling.Distribution2D.pdf` (none outside :math:`[0, 1)^2`) and
  :math:`p_\omega = p_{uv}/(2\pi^2 \sin\theta)`;
- ``sample_texels``, ``sample_point`` and ``sample_direction`` — ``EnvironmentMap.sample``:
  :meth:`~brdfkit.sampling.Distribution2D.sample`'s row of the marginal CDF and column of
  that row's conditional CDF (bisection's intervals, found by the guide tables of
  :func:`guides`), the point inside the texel, and its world direction
  :math:`R\,(\sin\theta\cos\varphi, \sin\theta\sin\varphi, \cos\theta)`.

The numba building blocks come from :mod:`brdfkit.compiled.kernel_tools`, handed in by the
caller (the compiled layer sits above this package): :func:`lookups` builds the functions once
per dtype. They round as written whoever calls them (no fast-math flags); the ones a
kernel's vectorised loop must see into (``bilinear``, ``sample_point``,
``sample_direction``) are inlined into it by numba, the rest by LLVM.

References
----------
.. [1] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 3rd ed., §13.6.7
       (piecewise-constant 2-D distributions), §14.2.4 (infinite area lights).
.. [2] H. C. Chen, Y. Asau, "On generating random variates from an empirical distribution",
       AIIE Transactions 6(2), 1974 (guide tables).
"""

from __future__ import annotations

import functools
import math
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit.sampling import Distribution2D

ROW_BUCKETS = 8
"""Guide-table buckets per row of a map's marginal CDF (:func:`guides`)."""
COLUMN_BUCKETS = 1
"""Guide-table buckets per column of each row's conditional CDF (:func:`guides`): past
(8, 1) more buckets shorten no scan enough to pay for their cache misses."""

_GUIDES: weakref.WeakKeyDictionary[Distribution2D, tuple[np.ndarray, np.ndarray]] = (
    weakref.WeakKeyDictionary()
)


@dataclass(frozen=True)
class MapLookups:
    """The numba functions of an environment map's lookups in one dtype (module docstring),
    and :meth:`tables`, the arrays a kernel passes them."""

    dtype: type
    tools: Any
    unit: Callable[..., Any]
    map_coordinates: Callable[..., Any]
    texel_cell: Callable[..., Any]
    bilinear: Callable[..., None]
    pdf_texel: Callable[..., Any]
    solid_angle_pdf: Callable[..., Any]
    sample_texels: Callable[..., None]
    sample_point: Callable[..., Any]
    sample_direction: Callable[..., Any]

    def tables(self, env: Any) -> tuple[Any, ...]:
        """``(image, rotation, scale, marginal, conditional, density, row_guide,
        col_guide)`` of the :class:`~brdfkit.light.EnvironmentMap` ``env`` for the kernels:
        its radiance and rotation in the dtype, and its light-sampling distribution's CDFs
        (float64), density and guide tables."""
        t = np.dtype(self.dtype)
        distribution = env._distribution
        return (
            np.ascontiguousarray(env.image, dtype=t),
            np.ascontiguousarray(env.rotation, dtype=t),
            t.type(env.scale),
            distribution._marginal,
            distribution._conditional,
            np.ascontiguousarray(distribution.density.ravel()),
            *guides(distribution, self.tools),
        )


def guides(distribution: Distribution2D, tools: Any) -> tuple[np.ndarray, np.ndarray]:
    """The guide tables (``tools.guide_table``) of a :class:`~brdfkit.sampling.Distribution2D`:
    its marginal's (:data:`ROW_BUCKETS` per row) and its rows' conditionals'
    (:data:`COLUMN_BUCKETS` per column, row after row), built once per distribution (kept
    while it lives)."""
    if distribution not in _GUIDES:
        height, width = distribution.shape
        _GUIDES[distribution] = (
            tools.guide_table(distribution._marginal, height, ROW_BUCKETS * height),
            tools.guide_table(distribution._conditional, width, COLUMN_BUCKETS * width, height),
        )
    return _GUIDES[distribution]


@functools.cache
def lookups(dtype: type, tools: Any) -> MapLookups:
    """The map's numba lookups in ``dtype`` built from ``tools``
    (:mod:`brdfkit.compiled.kernel_tools`), once per dtype."""
    cell, bilinear = _texel_lookup(dtype, tools)
    pdf_texel, solid_angle_pdf = _map_pdf(dtype, tools)
    return MapLookups(
        dtype,
        tools,
        unit(dtype, tools),
        _map_coordinates(dtype, tools),
        cell,
        bilinear,
        pdf_texel,
        solid_angle_pdf,
        texel_sampler(tools),
        *_sample_geometry(dtype, tools),
    )


def unit(dtype: type, tools: Any) -> Callable[..., Any]:
    """:func:`brdfkit._array.normalize` of a vector ``(x, y, z)``: v / max(|v|, tiny)."""
    tiny = dtype(np.finfo(np.float32).tiny)

    @tools.exact_jit()
    def normalize(x: Any, y: Any, z: Any) -> tuple[Any, Any, Any]:
        length = max(np.sqrt(x * x + y * y + z * z), tiny)
        return x / length, y / length, z / length

    return normalize


def _map_coordinates(dtype: type, tools: Any) -> Callable[..., Any]:
    """``EnvironmentMap._map_coordinates``: ``map_coordinates(wx, wy, wz, r)`` of a unit world
    direction, ``r`` the map's rotation (row-major): x = (φ mod 2π)/2π, y = θ/π, and sin θ
    (the NumPy path's sin θ to rounding), branch-free."""
    select = tools.select()
    atan2, _, _ = tools.trigonometry(dtype)
    zero, pi, two_pi = dtype(0), dtype(math.pi), dtype(2 * math.pi)

    @tools.exact_jit()
    def map_coordinates(wx: Any, wy: Any, wz: Any, r: tuple) -> tuple[Any, Any, Any]:
        mx = wx * r[0] + wy * r[3] + wz * r[6]
        my = wx * r[1] + wy * r[4] + wz * r[7]
        mz = wx * r[2] + wy * r[5] + wz * r[8]
        sin_theta = np.sqrt(max(mx * mx + my * my, zero))
        theta = atan2(sin_theta, mz)
        phi = atan2(my, mx)
        phi = select(phi < zero, phi + two_pi, phi)  # np.remainder(φ, 2π) for φ ∈ (−π, π]
        return phi / two_pi, theta / pi, sin_theta

    return map_coordinates


def _texel_lookup(dtype: type, tools: Any) -> tuple[Callable[..., Any], Callable[..., None]]:
    """``_bilinear`` (``EnvironmentMap._lookup``) in two steps, so that a kernel can prefetch
    the texels between them: ``texel_cell(x, y, height, width, nc)``, the offsets in the flat
    image of the four texels at map coordinates (x, y) in [0, 1]² (rows r0, r1 clamped,
    columns c0, c1 wrapping: (r0, c0), (r0, c1), (r1, c0), (r1, c1)) and the weights (fr, fc)
    of r1 and c1, branch-free; and ``bilinear(texels, cells, weights, j, scale, out)``, the
    value at the cell ``cells[:, j]``, ``weights[:, j]`` into ``out[:, j]``."""
    select = tools.select()
    zero, one, half = dtype(0), dtype(1), dtype(0.5)

    @tools.exact_jit()
    def texel_cell(x: Any, y: Any, height: int, width: int, nc: int) -> tuple:
        row, col = y * dtype(height) - half, x * dtype(width) - half
        r0f, c0f = np.floor(row), np.floor(col)
        fr, fc = row - r0f, col - c0f
        # NaN (a degenerate direction) reads texel 0 instead of an undefined index
        r_index = np.int64(select(np.abs(r0f) < dtype(1e9), r0f, zero))
        c_index = np.int64(select(np.abs(c0f) < dtype(1e9), c0f, zero))
        r0 = min(max(r_index, 0), height - 1)
        r1 = min(max(r_index + 1, 0), height - 1)
        # c_index mod W without integer divisions: c_index is in [−1, W − 1] for x in [0, 1]
        c0 = select(c_index < 0, c_index + width, c_index)
        c0 = select(c0 >= width, c0 - width, c0)
        c1 = select(c0 + 1 < width, c0 + 1, np.int64(0))
        top, bottom = r0 * width, r1 * width
        return (top + c0) * nc, (top + c1) * nc, (bottom + c0) * nc, (bottom + c1) * nc, fr, fc

    @tools.inline_jit()
    def bilinear(texels: np.ndarray, cells: np.ndarray, weights: np.ndarray, j: int,
                 scale: Any, out: np.ndarray) -> None:  # fmt: skip
        i00, i01 = np.uint64(cells[0, j]), np.uint64(cells[1, j])  # unsigned: no
        i10, i11 = np.uint64(cells[2, j]), np.uint64(cells[3, j])  # wrap-around per read
        fr, fc = weights[0, j], weights[1, j]
        for c in range(out.shape[0]):
            k = np.uint64(c)
            top = texels[i00 + k] * (one - fc) + texels[i01 + k] * fc
            bottom = texels[i10 + k] * (one - fc) + texels[i11 + k] * fc
            out[c, j] = (top * (one - fr) + bottom * fr) * scale

    return texel_cell, bilinear


def _map_pdf(dtype: type, tools: Any) -> tuple[Callable[..., Any], Callable[..., Any]]:
    """``EnvironmentMap.pdf`` in two steps: ``pdf_texel(x, y, height, width)``, the flat
    index of :meth:`~brdfkit.sampling.Distribution2D.pdf`'s texel at map coordinates (x, y)
    (−1 outside [0, 1)², where the pdf is 0), and ``solid_angle_pdf(p_uv, sin_theta)``,
    ``_solid_angle_pdf``'s safe_div(p_uv, 2π² max(sin θ, 0)); both branch-free."""
    select = tools.select()
    zero, one, two_pi_sq = dtype(0), dtype(1), dtype(2 * math.pi**2)

    @tools.exact_jit()
    def pdf_texel(x: Any, y: Any, height: int, width: int) -> Any:
        inside = (x >= zero) & (x < one) & (y >= zero) & (y < one)
        col = min(max(np.floor(np.float64(x) * width), 0.0), width - 1.0)
        row = min(max(np.floor(np.float64(y) * height), 0.0), height - 1.0)
        index = np.int64(select(inside, row, 0.0)) * width + np.int64(select(inside, col, 0.0))
        return select(inside, index, np.int64(-1))

    @tools.exact_jit()
    def solid_angle_pdf(pdf_uv: Any, sin_theta: Any) -> Any:
        denominator = two_pi_sq * max(sin_theta, zero)
        ok = denominator != zero
        return select(ok, pdf_uv / select(ok, denominator, one), zero)

    return pdf_texel, solid_angle_pdf


def texel_sampler(tools: Any) -> Callable[..., None]:
    """:meth:`~brdfkit.sampling.Distribution2D.sample`'s texels: the numba
    ``sample_texels(a, b, marginal, conditional, row_guide, col_guide, height, width, nb,
    rows, cols, base)`` for ``nb`` float64 variates ``a`` (column) and ``b`` (row) already
    clamped below 1: the marginal's row, then the row's column (``base``: the row's offset in
    ``conditional``), each the interval of ``sampling._find_interval``'s bisection, found by
    the guide-table search (``tools.guided_search``, :func:`guides`). Loops split so that the
    guide reads of the block's samples overlap, and each column search's CDF nodes are
    prefetched before the scans."""
    guided_interval = tools.guided_search()
    prefetch = tools.prefetch()

    @tools.cached_jit("environment-texel-search")
    def sample_texels(a: np.ndarray, b: np.ndarray, marginal: np.ndarray,
                      conditional: np.ndarray, row_guide: np.ndarray, col_guide: np.ndarray,
                      height: int, width: int, nb: int, rows: np.ndarray, cols: np.ndarray,
                      base: np.ndarray) -> None:  # fmt: skip
        row_buckets, col_buckets = row_guide.shape[0], col_guide.shape[0] // height
        first = np.int64(0)  # not a literal 0: both searches compile to one function
        for j in range(nb):
            row = guided_interval(marginal, first, row_guide, first, row_buckets, b[j], height)
            rows[j], base[j] = row, row * (width + 1)
        for j in range(nb):
            start = rows[j] * col_buckets
            cols[j] = col_guide[start + min(np.int64(a[j] * col_buckets), col_buckets - 1)]
            prefetch(conditional, base[j] + cols[j])
        for j in range(nb):
            cols[j] = guided_interval(conditional, base[j], col_guide, rows[j] * col_buckets,
                                      col_buckets, a[j], width)  # fmt: skip

    return sample_texels


def _sample_geometry(dtype: type, tools: Any) -> tuple[Callable[..., Any], Callable[..., Any]]:
    """``EnvironmentMap.sample`` after the texel search: ``sample_point(a, b, row, col, m0,
    m1, c0, c1, height, width)``, :meth:`~brdfkit.sampling.Distribution2D.sample`'s point
    (x, y) in the texel (float64 variates a, b, the texel's CDF nodes m0, m1 of its row and
    c0, c1 of its column), rounded to the dtype and kept below 1; and
    ``sample_direction(x, y, r)``, the world direction of map coordinates (x, y) (θ = πy,
    φ = 2πx, rotated by ``r``, row-major) and sin θ."""
    _, sin, cos = tools.trigonometry(dtype)
    pi, two_pi = dtype(math.pi), dtype(2 * math.pi)
    below_one = dtype(1 - np.finfo(dtype).eps / 2)

    @tools.inline_jit()
    def sample_point(a: float, b: float, row: int, col: int, m0: float, m1: float, c0: float,
                     c1: float, height: int, width: int) -> tuple[Any, Any]:  # fmt: skip
        x = min(dtype((col + (a - c0) / (c1 - c0)) / width), below_one)
        y = min(dtype((row + (b - m0) / (m1 - m0)) / height), below_one)
        return x, y

    @tools.inline_jit()
    def sample_direction(x: Any, y: Any, r: tuple) -> tuple[Any, Any, Any, Any]:
        theta, phi = y * pi, x * two_pi
        sin_theta = sin(theta)
        mx, my, mz = sin_theta * cos(phi), sin_theta * sin(phi), cos(theta)
        lx = mx * r[0] + my * r[1] + mz * r[2]
        ly = mx * r[3] + my * r[4] + mz * r[5]
        lz = mx * r[6] + my * r[7] + mz * r[8]
        return lx, ly, lz, sin_theta

    return sample_point, sample_direction


@functools.cache
def cell_moments(tools: Any) -> Callable[..., None]:
    r"""``environment._cell_moments`` (the irradiance table's cell moments) as the numba
    ``moments(image, row_factors, col_factors, row_cell, col_cell, out)``: one pass over the
    pixels of ``image`` ``(H, W, C)``, each adding :math:`\Delta\Omega_p\omega_p` = (row
    factor 0 · column factors 0 and 1, row factor 1) to :math:`A_c` and :math:`L_p` times it
    to :math:`M_c` of its cell ``(row_cell[h], col_cell[w])`` in ``out`` ``(rows, cols, 1 +
    C, 3)`` (zeros on entry), in float64. Its machine code is kept on disk."""

    @tools.cached_jit("environment-cell-moments")
    def moments(image: np.ndarray, row_factors: np.ndarray, col_factors: np.ndarray,
                row_cell: np.ndarray, col_cell: np.ndarray, out: np.ndarray) -> None:  # fmt: skip
        height, width, channels = image.shape
        for h in range(height):
            r, sin_part, z = row_cell[h], row_factors[0, h], row_factors[1, h]
            for w in range(width):
                cell = out[r, col_cell[w]]
                x, y = sin_part * col_factors[0, w], sin_part * col_factors[1, w]
                cell[0, 0] += x
                cell[0, 1] += y
                cell[0, 2] += z
                for c in range(channels):
                    value = np.float64(image[h, w, c])
                    cell[1 + c, 0] += value * x
                    cell[1 + c, 1] += value * y
                    cell[1 + c, 2] += value * z

    return moments


@functools.cache
def clamped_sums(tools: Any) -> Callable[..., None]:
    r"""``environment._clamped_sums`` (the irradiance table's sums over cells) as the numba
    ``sums(prefix, components, turns, theta, phi, inner, outer, first, last, out)``: for the
    node rows ``first`` … ``last − 1`` of ``theta`` × ``phi`` (``phi`` increasing),
    :math:`\sum_c \max(n\cdot v_c, 0)` of each of the cells' ``K`` vectors into ``out``
    ``(nodes, K)`` (zeros on entry). Per cell row r, the cells of the arc :math:`|\varphi_c -
    \varphi_n| <` ``inner[r, i]`` (wholly above the horizon) are summed from the prefix sums
    ``prefix[r]`` ``(3 cols + 1, 3K)`` of three turns of the row's vectors, and the cells
    between it and the arc of ``outer[r, i]`` are clamped one by one, read from
    ``components`` ``(rows, cols, 3, K)`` (each cell's x, y and z of its K vectors side by
    side: one read per cell for all K sums);
    ``turns``: three turns of the cell columns' azimuths. The arcs' ends are
    ``_arc_indices``' searches, found by walking ``turns`` along the increasing φ of a
    node row instead of bisecting for each node. float64 throughout (the NumPy code clamps
    in float32). Its machine code is kept on disk (``tools.cached_jit``)."""
    margin, pi = 1e-9, math.pi

    @tools.inline_jit()
    def arc(turns: np.ndarray, at: tuple, phi: float, width: float,
            cols: int) -> tuple[int, int, tuple]:  # fmt: skip
        """``_arc_indices``' [lo, hi) of one node and the walks' new places ``at`` (lo, hi,
        centre): each ``np.searchsorted(turns, value, side)`` walked on from its place for
        the node before, φ increasing."""
        lo, hi, centre = at
        if width >= pi:
            return cols, 2 * cols, at
        if width < 0:
            while centre < turns.shape[0] and turns[centre] < phi:
                centre += 1
            return centre, centre, (lo, hi, centre)
        value = phi - width - margin
        while lo < turns.shape[0] and turns[lo] < value:
            lo += 1
        value = phi + width + margin
        while hi < turns.shape[0] and turns[hi] <= value:
            hi += 1
        return lo, min(hi, lo + cols), (lo, hi, centre)

    @tools.inline_jit()
    def clamp_cells(components: np.ndarray, start: int, stop: int, nx: float, ny: float,
                    nz: float, out: np.ndarray, node: int) -> None:  # fmt: skip
        """Σ max(n·v_c, 0) over the cells ``start`` … ``stop − 1`` (wrapping) into ``out[node]``
        for each of the K vectors, cell after cell (each vector's sum gets the same additions
        in the same order as one vector at a time; a cell's components are read once)."""
        cols, _, k = components.shape
        total = out[node]
        for c in range(start, stop):
            cell = c
            while cell >= cols:
                cell -= cols
            v = components[cell]
            for q in range(k):
                dot = v[0, q] * nx + v[1, q] * ny + v[2, q] * nz
                total[q] += max(dot, 0.0)

    @tools.cached_jit("environment-clamped-sums")
    def sums(prefix: np.ndarray, components: np.ndarray, turns: np.ndarray, theta: np.ndarray,
             phi: np.ndarray, inner: np.ndarray, outer: np.ndarray, first: int, last: int,
             out: np.ndarray) -> None:  # fmt: skip
        rows, cols, _, k = components.shape
        k3 = 3 * k
        count = phi.shape[0]
        normals = np.empty((count, 3))
        above = np.empty((count, k3))
        for i in range(first, last):
            for j in range(count):
                normals[j, 0] = np.sin(theta[i]) * np.cos(phi[j])
                normals[j, 1] = np.sin(theta[i]) * np.sin(phi[j])
                normals[j, 2] = np.cos(theta[i])
            above[:] = 0.0
            for r in range(rows):
                row_prefix, row_components = prefix[r], components[r]
                at_in, at_out = (0, 0, 0), (0, 0, 0)
                for j in range(count):
                    nx, ny, nz = normals[j, 0], normals[j, 1], normals[j, 2]
                    lo_in, hi_in, at_in = arc(turns, at_in, phi[j], inner[r, i], cols)
                    lo_out, hi_out, at_out = arc(turns, at_out, phi[j], outer[r, i], cols)
                    if hi_out - lo_out >= cols:
                        lo_out, hi_out = lo_in, lo_in + cols
                    for q in range(k3):
                        above[j, q] += row_prefix[hi_in, q] - row_prefix[lo_in, q]
                    # the cells in between: [lo_out, lo_in) and [hi_in, hi_out)
                    node = i * count + j
                    clamp_cells(row_components, lo_out, lo_in, nx, ny, nz, out, node)
                    clamp_cells(row_components, hi_in, hi_out, nx, ny, nz, out, node)
            for j in range(count):
                for q in range(0, k3, 3):
                    dot = above[j, q] * normals[j, 0] + above[j, q + 1] * normals[j, 1]
                    out[i * count + j, q // 3] += dot + above[j, q + 2] * normals[j, 2]

    return sums


__all__ = [
    "COLUMN_BUCKETS",
    "ROW_BUCKETS",
    "MapLookups",
    "cell_moments",
    "clamped_sums",
    "guides",
    "lookups",
    "unit",
]
