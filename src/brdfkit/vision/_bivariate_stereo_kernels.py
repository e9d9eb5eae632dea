"""Compiled per-pixel kernels of :mod:`brdfkit.vision.bivariate_stereo` (ST14, IA14, AZ08).

Variable projection: for a candidate normal, a pixel's reflectance weights are the
(non-negative) least-squares fit of its lit observations to a ``K``-function basis, and the
normal is found by Levenberg–Marquardt on the remaining residual. Each kernel does for one
pixel what the NumPy formulation did for all at once (the tests keep that formulation as the
reference), with the pixels split over the cores (the fits and the normal search in threads
of their own, :func:`_over_threads`; the lighter passes in ``numba.prange`` loops); per pixel:

- only the observations of non-zero weight are visited (a shadowed or trimmed one adds nothing
  to the fit and its residual is 0);
- the bi-polynomial Gram is accumulated an observation at a time as full rows (SIMD over the
  basis; each entry summed in the observations' order, as before, so that its ill-conditioned
  Grams round as they did); the ramps' (IA14) from sums by ramp index (:func:`_ramps_system`,
  ``O(M + K^2)``); the table's (AZ08) 2 × 2 in the pass that evaluates the table;
- the non-negative fit starts its active set from the pixel's previous fit (the optimum of a
  strictly convex quadratic is unique, so only the number of rounds changes);
- the start selection (:func:`best_start`) keeps the winner's residual for the search, and
  it and the search keep the weights of their normals (AZ08's next table needs no refit);
- a rejected Levenberg–Marquardt step keeps ``J^T J`` and ``J^T r`` for the next try (the
  normal did not move), and a pixel stops when its step is below a tolerance;
- the per-pixel work (a block's pixels, the fits, the Jacobian products, the solvers) is
  compiled without numba's runtime: the arrays it passes on per pixel and
  call are not reference-counted (atomic increments and decrements, on counts that the threads
  share, were a quarter of the time); the parallel kernels allocate each block's work arrays
  and hand the block to it;
- the ramps' screening bound (:func:`_ramps_bound`) solves by Cholesky and takes the cost from
  the solution (no pivoting, no residual pass), the two solves of the Jacobian products share
  one elimination (:func:`_solve_free_sides`), the ramp indices are counted without branches;
- the table's rows (AZ08) are computed for a pixel's observations at once with fdlibm's
  ``acos`` (:func:`_table_rows`, vectorised), instead of a libm call per observation;
- the ranks, shadow weights and transposed intensities of the start come from one parallel
  pass (:func:`order_statistics`).

All but the table's rows give the numbers they replace bit for bit (the fdlibm ``acos`` differs
from libm's in the last bit for about a third of the arguments: the AZ08 normals of the
DiLiGenT-size benchmark by ~1e-13). Kernels are compiled on first use and cached on disk
(``cache=True``).

References
----------
.. [1] G. H. Golub, V. Pereyra, "The differentiation of pseudo-inverses and nonlinear least
   squares problems whose variables separate", SIAM J. Numer. Anal. 10(2), 1973 (variable
   projection).
.. [2] C. L. Lawson, R. J. Hanson, "Solving Least Squares Problems", Prentice-Hall 1974,
   ch. 23 (the active-set non-negative least squares).
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from brdfkit.compiled.kernel_tools import without_runtime
from brdfkit.errors import require_extra
from brdfkit.vision._photometric_stereo_kernels import _FASTMATH, _tangents

numba = require_extra("numba")

_jit = numba.njit(cache=True, nogil=True, error_model="numpy", fastmath=_FASTMATH)
_inline = numba.njit(
    cache=True, nogil=True, error_model="numpy", fastmath=_FASTMATH, inline="always"
)
_pjit = numba.njit(cache=True, nogil=True, error_model="numpy", fastmath=_FASTMATH, parallel=True)
_hot = numba.njit(
    cache=True, nogil=True, error_model="numpy", fastmath=_FASTMATH, **without_runtime()
)
_strict = numba.njit(
    cache=True, nogil=True, error_model="numpy", fastmath=False, **without_runtime()
)
"""Without floating-point licences (named: a callee inherits its caller's otherwise)."""
_exact_pjit = numba.njit(cache=True, nogil=True, error_model="numpy", fastmath=False, parallel=True)
"""Without floating-point licences: :func:`order_statistics` rounds as NumPy does (no fused
multiply-add in the percentile's interpolation)."""

BIPOLYNOMIAL, RAMPS, TABLE = 0, 1, 2
"""Basis kinds (see :class:`brdfkit.vision.bivariate_stereo.Basis`)."""

BLOCK = 32
"""Pixels per parallel task (they share one set of work arrays)."""

SCREEN_STRIDE = 3
"""The subset of kept observations of :func:`_lower_bound`: every ``SCREEN_STRIDE``-th."""

SCREEN_MARGIN = 1e-7
"""The margin of :func:`best_start`'s screening, relative to the pixel's ``sum w I^2``: above
the fits' relative ridge of 1e-9 (the bounds hold for the ridge-free costs) and small against
any cost the methods reach (noise at 1e-3 of the signal makes a cost of ~1e-6 of it)."""


TASKS_PER_THREAD = 2
"""Tasks of :func:`_over_threads` per thread: blocks of pixels interleaved, so that a region of
costly pixels (highlights, pixels still searching) is shared out, taken as threads finish. At
DiLiGenT size 8 made each call 5 % slower than numba's parallel loops (a task's hand-over and
dispatch, 130 calls in ST14's search), 1 and 2 as fast."""


def _over_threads(kernel: Callable[..., None], n_pixels: int, *arguments: object) -> None:
    """``kernel(task, tasks, *arguments)`` for every task, on ``numba.get_num_threads()``
    threads: each task takes every ``tasks``-th block of :data:`BLOCK` pixels.

    The per-pixel kernels run in Python threads rather than in numba's parallel loops: they
    release the GIL (``nogil``) and compile as plain functions, where the parallel loops made
    a first run of ``brdfkit ps`` (every 4th pixel) compile for 41 s rather than 30 (at the
    same speed once compiled).
    """
    blocks = -(-n_pixels // BLOCK)
    threads = max(1, min(numba.get_num_threads(), blocks))
    tasks = min(blocks, threads * TASKS_PER_THREAD)
    if threads == 1:
        for task in range(tasks):
            kernel(task, tasks, *arguments)
        return
    futures = [_pool(threads).submit(kernel, task, tasks, *arguments) for task in range(tasks)]
    try:
        for future in futures:
            future.result()
    except BaseException:  # an interrupt: the tasks not started are not run
        for future in futures:
            future.cancel()
        raise


def _pool(threads: int) -> ThreadPoolExecutor:
    """A pool of ``threads`` worker threads, kept for the process (its threads wait idle); a
    forked child, which has none of its parent's threads, makes its own."""
    return _process_pool(threads, os.getpid())


@functools.cache
def _process_pool(threads: int, process: int) -> ThreadPoolExecutor:
    return ThreadPoolExecutor(max_workers=threads, thread_name_prefix="brdfkit-pixels")


@_jit
def table_columns(cos_d, n_d):  # pragma: no cover
    """Per light, the lower ``θ_d`` node ``j`` ``(N,)`` of the table and the fraction ``f_w``
    ``(N,)`` above it (``θ_d`` uniform on [0, π/2] over ``n_d`` nodes)."""
    n_lights = len(cos_d)
    column = np.empty(n_lights, np.int64)
    fraction = np.empty(n_lights)
    for n in range(n_lights):
        w = np.arccos(min(max(cos_d[n], 0.0), 1.0)) / (np.pi / 2) * (n_d - 1)
        column[n] = min(int(np.floor(w)), n_d - 2)
        fraction[n] = w - column[n]
    return column, fraction


@_inline
def _root(w):  # pragma: no cover
    """``sqrt(w)``, without the square root for the usual 0/1 weights (the same value)."""
    return w if w == 1.0 or w == 0.0 else np.sqrt(w)


_ACOS_P = (
    1.66666666666666657415e-01, -3.25565818622400915405e-01, 2.01212532134862925881e-01,
    -4.00555345006794114027e-02, 7.91534994289814532176e-04, 3.47933107596021167570e-05,
)  # fmt: skip
_ACOS_Q = (
    -2.40339491173441421878e00, 2.02094576023350569471e00, -6.88283971605453293030e-01,
    7.70381505559019352791e-02,
)  # fmt: skip
_PI_2_HI, _PI_2_LO = 1.57079632679489655800e00, 6.12323399573676603587e-17


@_strict
def _table_rows(cosines, m, n_h, bins, fractions):  # pragma: no cover
    """The table's row of ``cosines[:m]`` (``cos θ_h``): the lower ``θ_h`` node ``i`` into
    ``bins[:m, 0]`` and the fraction ``f_u`` above it (``sqrt(θ_h)`` uniform on ``n_h`` nodes)
    and ``sqrt(θ_h / (π/2))`` into ``fractions[:m]``, vectorised: ``θ_h`` by fdlibm's ``acos``
    (``e_acos.c``: a rational approximation of ``asin``, within 1 ulp, as libm's; its two
    ranges computed both and selected, and compiled without floating-point licences, which
    would undo its compensated sums) instead of an opaque libm call per observation.

    Its ``θ_h`` and libm's differ in the last bit for about a third of the arguments; the
    normals of the shared table (AZ08) by ~1e-13 (the DiLiGenT-size benchmark)."""
    p0, p1, p2, p3, p4, p5 = _ACOS_P
    q1, q2, q3, q4 = _ACOS_Q
    for j in range(m):
        x = min(max(cosines[j], 0.0), 1.0)
        small = x < 0.5
        z = x * x if small else (1.0 - x) * 0.5
        p = z * (p0 + z * (p1 + z * (p2 + z * (p3 + z * (p4 + z * p5)))))
        q = 1.0 + z * (q1 + z * (q2 + z * (q3 + z * q4)))
        r = p / q
        s = np.sqrt(z)
        t = s * 134217729.0  # Veltkamp's split: high, the upper 26 bits of s (its square exact)
        high = t - (t - s)
        c = (z - high * high) / (s + high)
        theta = _PI_2_HI - (x - (_PI_2_LO - x * r)) if small else 2.0 * (high + (r * s + c))
        if x >= 1.0:
            theta = 0.0
        root = np.sqrt(theta / (np.pi / 2))
        u = root * (n_h - 1)
        i = min(int(np.floor(u)), n_h - 2)
        bins[j, 0] = i
        fractions[j, 0] = u - i
        fractions[j, 1] = root


@_inline
def _table_value(fa, i, fu, c, fw, n_d):  # pragma: no cover
    """The bilinear table ``fa`` (``n_d`` columns) at row ``i + fu``, column ``c + fw``."""
    return (
        fa[i * n_d + c] * ((1 - fu) * (1 - fw))
        + fa[(i + 1) * n_d + c] * (fu * (1 - fw))
        + fa[i * n_d + c + 1] * ((1 - fu) * fw)
        + fa[(i + 1) * n_d + c + 1] * (fu * fw)
    )


@_inline
def _design(ints, nx, ny, nz, kept, m, lights, half, cos_d, design):  # pragma: no cover
    """The bi-polynomial basis values, cosine factor included, of the observations ``kept[:m]``
    into ``design[:m]`` ``(M, K)`` (the other bases: :func:`_ramps_system`,
    :func:`_table_system`)."""
    for j in range(m):
        n = kept[j]
        cos_i = nx * lights[n, 0] + ny * lights[n, 1] + nz * lights[n, 2]
        cos_h = nx * half[n, 0] + ny * half[n, 1] + nz * half[n, 2]
        shading = max(cos_i, 0.0)
        ch = max(cos_h, 0.0)
        power_h = 1.0
        k = 0
        for _a in range(ints[0] + 1):
            power_d = 1.0
            for _b in range(ints[1] + 1):
                design[j, k] = shading * power_h * power_d
                power_d *= cos_d[n]
                k += 1
            power_h *= ch


@_hot
def _table_system(
    nx, ny, nz, kept, g_kept, w_kept, m, lights, half, column, fraction, ints, fa, design, gram,
    rhs, bins, fractions,
):  # pragma: no cover  # fmt: skip
    """The design ``max(0, n·l) (1, T(θ_h, θ_d))`` of the shared table (``T`` bilinear on the
    ``ints = (n_h, n_d)`` nodes ``fa``) into ``design[:m]`` ``(M, 2)``, and its weighted Gram and
    right-hand side summed in the same pass (each entry as the general loop of :func:`_fit`
    sums it). Each observation's :func:`_table_rows` goes to ``bins[:m, 0]`` and ``fractions[:m]``
    ``(f_u, sqrt(θ_h / (π/2)))``, for :func:`_products` (no second ``arccos``)."""
    n_h, n_d = ints[0], ints[1]
    cosines = design[:, 1]  # cos θ_h, overwritten below
    for j in range(m):
        n = kept[j]
        cosines[j] = nx * half[n, 0] + ny * half[n, 1] + nz * half[n, 2]
    _table_rows(cosines, m, n_h, bins, fractions)
    g00 = g01 = g11 = r0 = r1 = 0.0
    for j in range(m):
        n = kept[j]
        cos_i = nx * lights[n, 0] + ny * lights[n, 1] + nz * lights[n, 2]
        shading = max(cos_i, 0.0)
        i, fu = bins[j, 0], fractions[j, 0]
        d0, d1 = shading, shading * _table_value(fa, i, fu, column[n], fraction[n], n_d)
        design[j, 0], design[j, 1] = d0, d1
        w0, w1 = w_kept[j] * d0, w_kept[j] * d1
        r0 += w0 * g_kept[j]
        r1 += w1 * g_kept[j]
        g00 += w0 * d0
        g01 += w0 * d1
        g11 += w1 * d1
    gram[0, 0], gram[0, 1], gram[1, 1] = g00, g01, g11
    rhs[0], rhs[1] = r0, r1


@_hot
def _solve_free(gram, rhs, free, work, work_b, coef):  # pragma: no cover
    """``coef`` = the solution of ``gram x = rhs`` on the ``free`` unknowns, 0 on the others
    (:func:`_solve_free_sides` of one right-hand side)."""
    _solve_free_sides(gram, rhs[None, :], free, work, work_b[None, :], coef[None, :])


@_hot
def _solve_free_sides(gram, rhs, free, work, work_b, coef):  # pragma: no cover
    """The solutions of ``gram x = rhs[s]`` on the ``free`` unknowns, 0 on the others, for
    each right-hand side ``rhs[s]`` (``(S, K)``) into ``coef[s]``: one Gaussian elimination with
    partial pivoting (LAPACK's ``gesv``) of the free block for all sides (``work_b``
    ``(S, K)``); a zero pivot leaves that unknown 0. Each side takes the same operations in the
    same order as alone, so the same numbers."""
    sides, k = rhs.shape
    f = 0
    for i in range(k):
        if free[i]:
            g = 0
            for j in range(k):
                if free[j]:
                    work[f, g] = gram[i, j]
                    g += 1
            for side in range(sides):
                work_b[side, f] = rhs[side, i]
            f += 1
    for c in range(f):
        pivot = c
        for r in range(c + 1, f):
            if abs(work[r, c]) > abs(work[pivot, c]):
                pivot = r
        if pivot != c:  # (the columns before c are no longer read)
            for q in range(c, f):
                work[c, q], work[pivot, q] = work[pivot, q], work[c, q]
            for side in range(sides):
                work_b[side, c], work_b[side, pivot] = work_b[side, pivot], work_b[side, c]
        if work[c, c] == 0.0:
            continue
        for r in range(c + 1, f):
            factor = work[r, c] / work[c, c]
            if factor != 0.0:
                for q in range(c + 1, f):  # (column c below the pivot is no longer read)
                    work[r, q] -= factor * work[c, q]
                for side in range(sides):
                    work_b[side, r] -= factor * work_b[side, c]
    for side in range(sides):
        for c in range(f - 1, -1, -1):
            total = work_b[side, c]
            for q in range(c + 1, f):
                total -= work[c, q] * work_b[side, q]
            work_b[side, c] = total / work[c, c] if work[c, c] != 0.0 else 0.0
        f = 0
        for i in range(k):
            if free[i]:
                coef[side, i] = work_b[side, f]
                f += 1
            else:
                coef[side, i] = 0.0


@_hot
def _weights(gram, rhs, nonnegative, warm, coef, work, work_b, free):  # pragma: no cover
    """One pixel's ``argmin_c c^T G c / 2 - r^T c`` (``c >= 0`` if ``nonnegative``) into
    ``coef``, with a relative ridge of ``1e-9`` on ``G``. Non-negative: active-set rounds from
    the free set ``free`` (in and out; all free unless ``warm``): solve on the free variables,
    then clamp the most negative, or free the clamped one of steepest descent, until none
    changes (at most ``2 K`` rounds)."""
    k = len(rhs)
    trace = 0.0
    for i in range(k):
        trace += gram[i, i]
    ridge = 1e-9 * trace / k + 1e-300
    for i in range(k):
        gram[i, i] += ridge
    if not nonnegative:
        free[:] = True
        _solve_free(gram, rhs, free, work, work_b, coef)
        return
    if not warm:
        free[:] = True
    scale = 0.0
    for i in range(k):
        scale = max(scale, abs(rhs[i]))
    threshold = -1e-12 * scale
    for _ in range(2 * k):
        _solve_free(gram, rhs, free, work, work_b, coef)
        worst, worst_value = -1, np.inf
        steepest, steepest_value = -1, np.inf
        for i in range(k):
            if free[i] and coef[i] < 0 and coef[i] < worst_value:
                worst, worst_value = i, coef[i]
            if not free[i]:
                gradient = -rhs[i]
                for j in range(k):
                    gradient += gram[i, j] * max(coef[j], 0.0)
                if gradient < threshold and gradient < steepest_value:
                    steepest, steepest_value = i, gradient
        if worst >= 0:
            free[worst] = False
        elif steepest >= 0:
            free[steepest] = True
        else:
            break
    for i in range(k):
        coef[i] = max(coef[i], 0.0)


@_inline
def _scratch(n_lights, k):  # pragma: no cover
    """Work arrays of :func:`_fit`: design ``(N, K)``, Gram, right-hand side, solver rows, and
    those of :func:`_ramps_system`: each observation's two ramp indices and fractions (the
    table's row and fractions: :func:`_table_system`), the sums by index pair
    ``(4, K/2 + 1, K/2 + 1)`` and by index ``(6, K/2 + 1)``, the weights' prefix sums
    ``(K + 2,)``."""
    bins = k // 2 + 1
    return (
        np.empty((n_lights, k)), np.empty((k, k)), np.empty(k), np.empty((k, k)), np.empty(k),
        np.empty((n_lights, 2), np.int64), np.empty((n_lights, 2)), np.empty((4, bins, bins)),
        np.empty((6, bins)), np.empty(k + 2),
    )  # fmt: skip


@_inline
def _ramp(x, knots):  # pragma: no cover
    """The ramps ``clip((x - t_k) / (t_{k+1} - t_k), 0, 1)`` of increasing ``knots`` at ``x``
    as ``(q, f)``: 1 below index ``q``, ``f`` at ``q``, 0 above (``q`` = the number of ramps
    when all are 1)."""
    steps = len(knots) - 1
    q = 0
    for a in range(steps):  # the ramps whose ratio is >= 1 (clipped to 1): a prefix, the knots
        q += x >= knots[a + 1]  # increasing; counted without branches
    if q == steps:
        return q, 1.0
    return q, min(max((x - knots[q]) / (knots[q + 1] - knots[q]), 0.0), 1.0)


@_hot
def _ramps_system(
    nx, ny, nz, kept, g_kept, w_kept, m, lights, half, fa, fb, gram, rhs, bins, fractions,
    pairs, singles,
):  # pragma: no cover  # fmt: skip
    """The weighted Gram and right-hand side of the ramps basis from each observation's
    :func:`_ramp` indices: a row is ``(1, …, 1, f, 0, …, 0)`` in each lobe, so
    ``G_ab = sum_j w_j D_ja D_jb`` is a sum of the weights (and fractions) over the
    observations whose indices lie above ``a`` and ``b`` — sums by index, then suffix sums:
    ``O(M + K^2)`` instead of ``O(M K^2)``. The indices and fractions go to ``bins``,
    ``fractions`` ``(M, 2)`` (for the residual's model)."""
    steps = len(fa) - 1
    pairs[:, :, :] = 0.0  # [0] w, [1] w f_d, [2] w f_s, [3] w f_d f_s by (q_d, q_s)
    singles[:, :] = 0.0  # [0] w f_d^2, [1] w I, [2] w I f_d by q_d; [3-5] the same by q_s
    for j in range(m):
        n = kept[j]
        cos_i = nx * lights[n, 0] + ny * lights[n, 1] + nz * lights[n, 2]
        cos_h = nx * half[n, 0] + ny * half[n, 1] + nz * half[n, 2]
        qd, fd = _ramp(cos_i, fa)
        if cos_i > 0:
            qs, fs = _ramp(cos_h, fb)
        else:
            qs, fs = 0, 0.0  # the specular lobe's row is 0 behind the surface
        bins[j, 0], bins[j, 1], fractions[j, 0], fractions[j, 1] = qd, qs, fd, fs
        w, wi = w_kept[j], w_kept[j] * g_kept[j]
        pairs[0, qd, qs] += w
        pairs[1, qd, qs] += w * fd
        pairs[2, qd, qs] += w * fs
        pairs[3, qd, qs] += w * fd * fs
        singles[0, qd] += w * fd * fd
        singles[1, qd] += wi
        singles[2, qd] += wi * fd
        singles[3, qs] += w * fs * fs
        singles[4, qs] += wi
        singles[5, qs] += wi * fs
    # suffix sums: pairs[0] over both indices, pairs[1] over q_s, pairs[2] over q_d, and the
    # right-hand side's singles[1], singles[4]
    for x in range(steps, -1, -1):
        for y in range(steps, -1, -1):
            if y < steps:
                pairs[0, x, y] += pairs[0, x, y + 1]
                pairs[1, x, y] += pairs[1, x, y + 1]
            if x < steps:
                pairs[2, x, y] += pairs[2, x + 1, y]
        if x < steps:
            singles[1, x] += singles[1, x + 1]
            singles[4, x] += singles[4, x + 1]
    for x in range(steps - 1, -1, -1):
        for y in range(steps + 1):
            pairs[0, x, y] += pairs[0, x + 1, y]
    # D_ja D_jb (a <= b, one lobe): 1 where q > b; at q == b, f (a < b) or f^2 (a == b)
    for a in range(steps):
        rhs[a] = singles[1, a + 1] + singles[2, a]
        rhs[steps + a] = singles[4, a + 1] + singles[5, a]
        for b in range(a, steps):
            gram[a, b] = pairs[0, b + 1, 0] + (pairs[1, b, 0] if a < b else singles[0, b])
            gram[steps + a, steps + b] = pairs[0, 0, b + 1] + (
                pairs[2, 0, b] if a < b else singles[3, b]
            )
        # across the lobes: (1 if q_d > a, f_d if q_d == a) (1 if q_s > b, f_s if q_s == b)
        for b in range(steps):
            gram[a, steps + b] = (
                pairs[0, a + 1, b + 1] + pairs[1, a, b + 1] + pairs[2, a + 1, b] + pairs[3, a, b]
            )


@_hot
def _kept(w, g, kept, g_kept, w_kept):  # pragma: no cover
    """The observations of non-zero weight: indices into ``kept``, their intensities and
    weights; returns their number."""
    m = 0
    for n in range(len(w)):
        if w[n] != 0.0:
            kept[m] = n
            g_kept[m] = g[n]
            w_kept[m] = w[n]
            m += 1
    return m


@_hot
def _fit(
    nx, ny, nz, kept, g_kept, w_kept, m, lights, half, cos_d, column, fraction, kind, ints, fa,
    fb, warm, nonnegative, residual, coef, free, scratch,
):  # pragma: no cover  # fmt: skip
    """Residual ``sqrt(w) (I - D c)`` ``(N,)`` (0 where ``w = 0``) of the best weights ``c``
    ``(K,)`` for the normal ``(nx, ny, nz)``, given the pixel's kept observations; returns the
    cost ``|residual|^2``."""
    design, gram, rhs, work, work_b, bins, fractions, pairs, singles, prefix = scratch
    k = len(coef)
    if kind == RAMPS:
        _ramps_system(
            nx, ny, nz, kept, g_kept, w_kept, m, lights, half, fa, fb, gram, rhs, bins,
            fractions, pairs, singles,
        )  # fmt: skip
    elif kind == TABLE:
        _table_system(
            nx, ny, nz, kept, g_kept, w_kept, m, lights, half, column, fraction, ints, fa, design,
            gram, rhs, bins, fractions,
        )  # fmt: skip
    else:
        _design(ints, nx, ny, nz, kept, m, lights, half, cos_d, design)
        gram[:, :] = 0.0
        rhs[:] = 0.0
        for j in range(m):
            row = design[j]
            for a in range(k):
                wa = w_kept[j] * row[a]
                if wa == 0.0:  # adds nothing
                    continue
                rhs[a] += wa * g_kept[j]
                for b in range(k):  # the full row (vectorised); the lower half is replaced below
                    gram[a, b] += wa * row[b]
    for a in range(k):
        for b in range(a):
            gram[a, b] = gram[b, a]
    _weights(gram, rhs, nonnegative, warm, coef, work, work_b, free)
    if kind == RAMPS:  # each lobe's prefix sums [0, c_0, c_0 + c_1, ...]
        steps = k // 2
        for lobe in range(2):
            total = 0.0
            prefix[lobe * (steps + 1)] = 0.0
            for a in range(steps):
                total += coef[lobe * steps + a]
                prefix[lobe * (steps + 1) + a + 1] = total
    residual[:] = 0.0
    cost = 0.0
    for j in range(m):
        if kind == RAMPS:  # sum_a D_ja c_a from the prefix sums (written here: a call per
            # observation costs more than the sum)
            steps = k // 2
            qd, qs = bins[j, 0], bins[j, 1]
            model = prefix[qd] + prefix[steps + 1 + qs]
            if qd < steps:
                model += fractions[j, 0] * coef[qd]
            if qs < steps:
                model += fractions[j, 1] * coef[steps + qs]
        else:
            model = 0.0
            for a in range(k):
                model += design[j, a] * coef[a]
        value = _root(w_kept[j]) * (g_kept[j] - model)
        residual[kept[j]] = value
        cost += value * value
    return cost


@_inline
def _products_scratch(n_lights, k):  # pragma: no cover
    """Work arrays of :func:`_products`: per kept observation the model's change ``dD c``
    ``(2, N)`` in the two tangent directions; per direction the weights' right-hand side and
    change ``(2, K)``, the rows ``dD_j`` ``(2, K)``, the change's prefix sums ``(2, K + 2)``,
    sums by ramp index ``(2, 4, K/2 + 1)`` and the solver's right-hand sides ``(2, K)``."""
    return (
        np.empty((2, n_lights)), np.empty((2, k)), np.empty((2, k)), np.empty((2, k)),
        np.empty((2, k + 2)), np.empty((2, 4, k // 2 + 1)), np.empty((2, k)),
    )  # fmt: skip


@_hot
def _products(
    nx, ny, nz, t, kept, w_kept, m, lights, half, cos_d, column, fraction, kind, ints, fa, fb,
    residual, coef, free, scratch, work_products,
):  # pragma: no cover  # fmt: skip
    """``J^T J`` and ``J^T r`` ``(j00, j01, j11, g0, g1)`` of the residual ``r = sqrt(w) (I - D c)``
    that :func:`_fit` just left for the normal ``(nx, ny, nz)`` (its system in ``scratch``), in
    the tangent coordinates of ``n(u, v) = normalise(n + u t_1 + v t_2)`` (``t`` from
    :func:`_tangents`).

    The exact variable-projection Jacobian [1]_ with the fit's active set held: with
    ``G = D_F^T W D_F + ρ I`` on the free weights ``F`` (``ρ`` the ridge of :func:`_weights`),
    ``G dc = dD^T W (I - D c) - D^T W dD c - dρ c`` and ``dr = -sqrt(w) (dD c + D dc)``, where
    ``dD`` is the derivative of the design along ``t_1`` or ``t_2`` (``d cos θ_i = t·l``,
    ``d cos θ_h = t·h``; ``cos θ_d`` does not depend on the normal). Each design is piecewise
    smooth in the cosines (ramps, bilinear table, ``max(0, ·)``); at a kink the derivative is
    that of the piece the observation is in.
    """
    design, gram, _, work, _, bins, fractions, _, _, _ = scratch
    change, source, delta, rows, prefix, sums, pair = work_products
    k = len(coef)
    steps = k // 2
    source[:, :] = 0.0
    trace_0 = trace_1 = 0.0  # d tr(G) / 2 (the ridge follows the trace)
    for j in range(m):  # dD c and dD^T sqrt(w) r
        n = kept[j]
        tl0 = t[0] * lights[n, 0] + t[1] * lights[n, 1] + t[2] * lights[n, 2]
        tl1 = t[3] * lights[n, 0] + t[4] * lights[n, 1] + t[5] * lights[n, 2]
        th0 = t[0] * half[n, 0] + t[1] * half[n, 1] + t[2] * half[n, 2]
        th1 = t[3] * half[n, 0] + t[4] * half[n, 1] + t[5] * half[n, 2]
        cos_i = nx * lights[n, 0] + ny * lights[n, 1] + nz * lights[n, 2]
        cos_h = nx * half[n, 0] + ny * half[n, 1] + nz * half[n, 2]
        weighted = _root(w_kept[j]) * residual[n]
        if kind == RAMPS:  # one fraction per lobe moves, at slope 1 / (knot spacing)
            qd, qs = bins[j, 0], bins[j, 1]
            slope_d = 1.0 / (fa[qd + 1] - fa[qd]) if qd < steps and cos_i >= fa[qd] else 0.0
            slope_s = 0.0
            if cos_i > 0 and qs < steps and cos_h >= fb[qs]:
                slope_s = 1.0 / (fb[qs + 1] - fb[qs])
            for c in range(2):
                dd = slope_d * (tl0 if c == 0 else tl1)
                ds = slope_s * (th0 if c == 0 else th1)
                value = trace = 0.0
                if qd < steps:
                    value += coef[qd] * dd
                    source[c, qd] += dd * weighted
                    trace += fractions[j, 0] * dd
                if qs < steps:
                    value += coef[steps + qs] * ds
                    source[c, steps + qs] += ds * weighted
                    trace += fractions[j, 1] * ds
                change[c, j] = value
                if c == 0:
                    trace_0 += w_kept[j] * trace
                else:
                    trace_1 += w_kept[j] * trace
            continue
        if kind == TABLE:
            if cos_i > 0:
                n_h, n_d = ints[0], ints[1]
                i, fu, root = bins[j, 0], fractions[j, 0], fractions[j, 1]  # the fit's
                col, fw = column[n], fraction[n]
                value = _table_value(fa, i, fu, col, fw, n_d)
                slope = 0.0  # d T / d cos θ_h (0 where the cosine is clipped)
                if 0.0 < cos_h < 1.0:
                    du = -(n_h - 1) / (np.pi * root * np.sqrt(1.0 - cos_h * cos_h))
                    slope = du * (
                        (1 - fw) * (fa[(i + 1) * n_d + col] - fa[i * n_d + col])
                        + fw * (fa[(i + 1) * n_d + col + 1] - fa[i * n_d + col + 1])
                    )
                rows[0, 0], rows[1, 0] = tl0, tl1
                rows[0, 1] = tl0 * value + cos_i * slope * th0
                rows[1, 1] = tl1 * value + cos_i * slope * th1
            else:
                rows[:, :] = 0.0
        else:  # the bi-polynomial s ch^a cd^b, s = max(cos θ_i, 0), ch = max(cos θ_h, 0)
            shading, ch = max(cos_i, 0.0), max(cos_h, 0.0)
            gate_i = 1.0 if cos_i > 0 else 0.0
            gate_h = 1.0 if cos_h > 0 else 0.0
            power_h, slope_h = 1.0, 0.0  # ch^a, a ch^(a - 1)
            q = 0
            for a in range(ints[0] + 1):
                power_d = 1.0
                for _b in range(ints[1] + 1):
                    base, base_h = power_h * power_d, shading * gate_h * slope_h * power_d
                    rows[0, q] = gate_i * tl0 * base + base_h * th0
                    rows[1, q] = gate_i * tl1 * base + base_h * th1
                    power_d *= cos_d[n]
                    q += 1
                slope_h = (a + 1) * power_h
                power_h *= ch
        for c in range(2):
            value = trace = 0.0
            for a in range(k):
                value += rows[c, a] * coef[a]
                source[c, a] += rows[c, a] * weighted
                trace += rows[c, a] * design[j, a]
            change[c, j] = value
            if c == 0:
                trace_0 += w_kept[j] * trace
            else:
                trace_1 += w_kept[j] * trace
    # minus D^T W dD c
    if kind == RAMPS:  # by ramp index, then suffix sums (as _ramps_system's right-hand side)
        sums[:, :, :] = 0.0
        for j in range(m):
            qd, qs = bins[j, 0], bins[j, 1]
            for c in range(2):
                y = w_kept[j] * change[c, j]
                sums[c, 0, qd] += y
                sums[c, 1, qd] += y * fractions[j, 0]
                sums[c, 2, qs] += y
                sums[c, 3, qs] += y * fractions[j, 1]
        for c in range(2):
            tail_d = tail_s = 0.0
            for a in range(steps - 1, -1, -1):
                tail_d += sums[c, 0, a + 1]
                tail_s += sums[c, 2, a + 1]
                source[c, a] -= tail_d + sums[c, 1, a]
                source[c, steps + a] -= tail_s + sums[c, 3, a]
    else:
        for j in range(m):
            for c in range(2):
                y = w_kept[j] * change[c, j]
                for a in range(k):
                    source[c, a] -= design[j, a] * y
    for c in range(2):
        ridge = 2e-9 * (trace_0 if c == 0 else trace_1) / k  # d of _weights' ridge: minus dρ c
        for a in range(k):
            source[c, a] -= ridge * coef[a]
    _solve_free_sides(gram, source, free, work, pair, delta)
    for c in range(2):
        if kind == RAMPS:
            for lobe in range(2):
                total = 0.0
                prefix[c, lobe * (steps + 1)] = 0.0
                for a in range(steps):
                    total += delta[c, lobe * steps + a]
                    prefix[c, lobe * (steps + 1) + a + 1] = total
    j00 = j01 = j11 = g0 = g1 = 0.0
    for j in range(m):  # dr = -sqrt(w) (dD c + D dc)
        r = residual[kept[j]]
        root = _root(w_kept[j])
        d0 = d1 = 0.0
        for c in range(2):
            if kind == RAMPS:
                qd, qs = bins[j, 0], bins[j, 1]
                value = prefix[c, qd] + prefix[c, steps + 1 + qs]
                if qd < steps:
                    value += fractions[j, 0] * delta[c, qd]
                if qs < steps:
                    value += fractions[j, 1] * delta[c, steps + qs]
            else:
                value = 0.0
                for a in range(k):
                    value += design[j, a] * delta[c, a]
            if c == 0:
                d0 = -root * (change[0, j] + value)
            else:
                d1 = -root * (change[1, j] + value)
        j00 += d0 * d0
        j01 += d0 * d1
        j11 += d1 * d1
        g0 += d0 * r
        g1 += d1 * r
    return j00, j01, j11, g0, g1


def fit_pixels(
    normals, gray, weights, lights, half, cos_d, column, fraction, kind, ints, fa, fb,
    warm, nonnegative, residual, coef, free, products=None,
):  # fmt: skip
    """:func:`_fit` on every pixel (normals ``(P, 3)``, intensities and weights ``(P, N)``):
    residuals ``(P, N)`` and weights ``(P, K)`` into the output arrays, the active sets
    ``(P, K)`` updated in place (the start of the next fit); returns the costs ``(P,)``.
    ``products`` ``(P, 6)``, if given and not empty, receives each fit's ``J^T J`` and
    ``J^T r`` as :func:`lm_step` keeps them (its first iteration then needs no refit)."""
    cost = np.empty(len(gray))
    _over_threads(
        _fit_tasks, len(gray), normals, gray, weights, lights, half, cos_d, column, fraction,
        kind, ints, fa, fb, warm, nonnegative, residual, coef, free, products, cost,
    )  # fmt: skip
    return cost


@_jit
def _fit_tasks(
    task, tasks, normals, gray, weights, lights, half, cos_d, column, fraction, kind, ints, fa,
    fb, warm, nonnegative, residual, coef, free, products, cost,
):  # pragma: no cover  # fmt: skip
    """:func:`fit_pixels` on the blocks ``task``, ``task + tasks``, … (:func:`_over_threads`)."""
    n_pixels, n_lights = gray.shape
    k = coef.shape[1]
    for block in range(task, (n_pixels + BLOCK - 1) // BLOCK, tasks):
        _fit_block(
            block * BLOCK, min((block + 1) * BLOCK, n_pixels), normals, gray, weights, lights,
            half, cos_d, column, fraction, kind, ints, fa, fb, warm, nonnegative, residual, coef,
            free, products, cost, np.empty(n_lights, np.int64), np.empty(n_lights),
            np.empty(n_lights), _scratch(n_lights, k), _products_scratch(n_lights, k),
        )  # fmt: skip


@_hot
def _fit_block(
    lo, hi, normals, gray, weights, lights, half, cos_d, column, fraction, kind, ints, fa, fb,
    warm, nonnegative, residual, coef, free, products, cost, kept, g_kept, w_kept, scratch,
    work_products,
):  # pragma: no cover  # fmt: skip
    """:func:`fit_pixels` on the pixels ``lo … hi - 1`` with the block's work arrays (without
    numba's runtime, as :func:`_best_start_block`)."""
    for p in range(lo, hi):
        m = _kept(weights[p], gray[p], kept, g_kept, w_kept)
        nx, ny, nz = normals[p, 0], normals[p, 1], normals[p, 2]
        cost[p] = _fit(
            nx, ny, nz, kept, g_kept, w_kept, m, lights, half, cos_d, column, fraction, kind,
            ints, fa, fb, warm, nonnegative, residual[p], coef[p], free[p], scratch,
        )  # fmt: skip
        if products is not None and len(products):
            _store_products(
                products, p, nx, ny, nz, kept, w_kept, m, lights, half, cos_d, column,
                fraction, kind, ints, fa, fb, residual[p], coef[p], free[p], scratch,
                work_products,
            )  # fmt: skip


@_hot
def _store_products(
    products, p, nx, ny, nz, kept, w_kept, m, lights, half, cos_d, column, fraction, kind, ints,
    fa, fb, residual, coef, free, scratch, work_products,
):  # pragma: no cover  # fmt: skip
    """:func:`_products` of the fit in ``scratch`` (of the normal ``(nx, ny, nz)``) into
    ``products[p]`` ``(6,)``, flagged as held (as :func:`lm_step` keeps them)."""
    j00, j01, j11, g0, g1 = _products(
        nx, ny, nz, _tangents(nx, ny, nz), kept, w_kept, m, lights, half, cos_d, column, fraction,
        kind, ints, fa, fb, residual, coef, free, scratch, work_products,
    )  # fmt: skip
    products[p, 0], products[p, 1], products[p, 2] = j00, j01, j11
    products[p, 3], products[p, 4], products[p, 5] = g0, g1, 1.0


@_hot
def _lower_bound(
    tx, ty, tz, kept, g_kept, w_kept, m, sub_kept, sub_g, sub_w, m_sub, lights, half, cos_d,
    column, fraction, kind, ints, fa, fb, nonnegative, shifted, coef, all_free, scratch,
):  # pragma: no cover  # fmt: skip
    """A lower bound on :func:`_fit`'s cost at ``(tx, ty, tz)`` (up to its ridge), cheaper than
    the fit: the fit to the subset ``sub_*[:m_sub]`` of the kept observations (the minimum of a
    part of the cost's terms), for the non-negative ramps without the constraint (the minimum
    over a superset of the weights: one solve instead of the active-set rounds). ``shifted``,
    ``coef`` and ``all_free`` are overwritten (the ramps' bound: :func:`_ramps_bound`, which
    leaves them alone)."""
    if kind == RAMPS:
        return _ramps_bound(
            tx, ty, tz, sub_kept, sub_g, sub_w, m_sub, lights, half, fa, fb, scratch
        )
    return _fit(
        tx, ty, tz, sub_kept, sub_g, sub_w, m_sub, lights, half, cos_d, column, fraction, kind,
        ints, fa, fb, False, nonnegative and kind != RAMPS, shifted, coef, all_free, scratch,
    )  # fmt: skip


@_hot
def _ramps_bound(tx, ty, tz, kept, g_kept, w_kept, m, lights, half, fa, fb, scratch):
    """The ramps' :func:`_lower_bound`: the cost ``|sqrt(w) (I - D c)|^2`` of the unconstrained
    least-squares weights ``c`` (with :func:`_weights`' ridge ``ρ``) of the observations given,
    ``sum w I^2 - |y|^2 - ρ |c|^2`` from the Cholesky factor ``L`` of ``G + ρ I`` (``L y = b``,
    ``L^T c = y``; ``b^T c = |y|^2``, ``c^T G c = b^T c - ρ |c|^2``): no pivoting, half the
    elimination's operations, and no residual pass. It equals :func:`_fit`'s unconstrained cost
    up to rounding, which the screening's margin covers (relative 1e-7 against 1e-16). A
    non-positive pivot (rounding; ``G + ρ I`` is positive definite) gives the bound 0."""
    _, gram, rhs, work, work_b, bins, fractions, pairs, singles, _ = scratch
    _ramps_system(
        tx, ty, tz, kept, g_kept, w_kept, m, lights, half, fa, fb, gram, rhs, bins, fractions,
        pairs, singles,
    )  # fmt: skip
    k = len(rhs)
    trace = 0.0
    for i in range(k):
        trace += gram[i, i]
    ridge = 1e-9 * trace / k + 1e-300
    for j in range(k):  # L (lower) into work, from the upper triangle of the Gram
        total = gram[j, j] + ridge
        for q in range(j):
            total -= work[j, q] * work[j, q]
        if not total > 0.0:
            return 0.0
        pivot = np.sqrt(total)
        work[j, j] = pivot
        for i in range(j + 1, k):
            total = gram[j, i]
            for q in range(j):
                total -= work[i, q] * work[j, q]
            work[i, j] = total / pivot
    fitted = 0.0
    for i in range(k):  # L y = b
        total = rhs[i]
        for q in range(i):
            total -= work[i, q] * work_b[q]
        work_b[i] = total / work[i, i]
        fitted += work_b[i] * work_b[i]
    penalty = 0.0
    for i in range(k - 1, -1, -1):  # L^T c = y, in place
        total = work_b[i]
        for q in range(i + 1, k):
            total -= work[q, i] * work_b[q]
        work_b[i] = total / work[i, i]
        penalty += work_b[i] * work_b[i]
    signal = 0.0
    for j in range(m):
        signal += w_kept[j] * g_kept[j] * g_kept[j]
    return signal - fitted - ridge * penalty


@_hot
def _try_start(
    tx, ty, tz, first, screen, kept, g_kept, w_kept, m, sub_kept, sub_g, sub_w, m_sub, margin,
    lights, half, cos_d, column, fraction, kind, ints, fa, fb, warm, nonnegative, shifted, coef,
    free, all_free, scratch, p, normals, residual, cost, coefficients,
):  # pragma: no cover  # fmt: skip
    """:func:`best_start`'s candidate ``(tx, ty, tz)`` for pixel ``p``: fitted, and kept (normal,
    residual, cost, weights) if ``first`` or of less cost than the pixel's best so far; returns
    whether it was (its fit is then in ``scratch``). With ``screen``, it is fitted only if its
    :func:`_lower_bound` is below that cost plus ``margin`` (it cannot win otherwise)."""
    if screen and not first:
        bound = _lower_bound(
            tx, ty, tz, kept, g_kept, w_kept, m, sub_kept, sub_g, sub_w, m_sub, lights, half,
            cos_d, column, fraction, kind, ints, fa, fb, nonnegative, shifted, coef, all_free,
            scratch,
        )  # fmt: skip
        if bound >= cost[p] + margin:
            return False
    trial = _fit(
        tx, ty, tz, kept, g_kept, w_kept, m, lights, half, cos_d, column, fraction, kind, ints,
        fa, fb, warm, nonnegative, shifted, coef, free, scratch,
    )  # fmt: skip
    if first or trial < cost[p]:
        normals[p, 0], normals[p, 1], normals[p, 2] = tx, ty, tz
        for n in range(len(shifted)):  # (loops: a slice copy would need numba's runtime)
            residual[p, n] = shifted[n]
        cost[p] = trial
        for a in range(len(coef)):
            coefficients[p, a] = coef[a]
        return True
    return False


def best_start(
    starts, ring, gray, weights, lights, half, cos_d, column, fraction, kind, ints, fa, fb,
    warm, nonnegative, normals, residual, cost, free, coefficients, screen=True, products=None,
):  # fmt: skip
    """:func:`~brdfkit.vision.bivariate_stereo._best_start` per pixel: the candidate of least cost
    among ``starts`` ``(S, P, 3)`` (the first of equal costs), then among it and the 6 normals
    ``ring`` radians around it, into ``normals`` ``(P, 3)``, with its residual ``(P, N)``, cost
    ``(P,)`` and weights ``coefficients`` ``(P, K)`` (the start of the normal search: no
    refit); ``free`` as :func:`fit_pixels`.

    With ``screen`` (the default), a ring normal is fitted only where its :func:`_lower_bound`
    (on every :data:`SCREEN_STRIDE`-th kept observation) is below the best cost so far plus
    :data:`SCREEN_MARGIN` times the pixel's ``sum w I^2``, so that it could win: the ring's
    normals, 12° off, rarely do (~1.5 % of the pixels of the DiLiGenT-size benchmark), and
    their bounds mostly exceed the best cost many times over. The margin covers the fits'
    ridge (the bounds hold for the ridge-free costs). The same candidates win as without
    screening (every pixel of that benchmark, for the three bases).

    ``products`` ``(P, 6)``, if given, receives the winner's ``J^T J`` and ``J^T r`` as
    :func:`lm_step` keeps them (from the winner's fit, kept aside: the search's first iteration
    needs no refit), and ``free`` the winner's active set.
    """
    _over_threads(
        _best_start_tasks, starts.shape[1], starts, np.cos(ring), np.sin(ring), gray, weights,
        lights, half, cos_d, column, fraction, kind, ints, fa, fb, warm, nonnegative, normals,
        residual, cost, free, coefficients, screen, products,
    )  # fmt: skip


@_jit
def _best_start_tasks(
    task, tasks, starts, cos_ring, sin_ring, gray, weights, lights, half, cos_d, column,
    fraction, kind, ints, fa, fb, warm, nonnegative, normals, residual, cost, free,
    coefficients, screen, products,
):  # pragma: no cover  # fmt: skip
    """:func:`best_start` on the blocks ``task``, ``task + tasks``, … (:func:`_over_threads`)."""
    n_pixels, n_lights = starts.shape[1], gray.shape[1]
    k = free.shape[1]
    for block in range(task, (n_pixels + BLOCK - 1) // BLOCK, tasks):
        _best_start_block(
            block * BLOCK, min((block + 1) * BLOCK, n_pixels), starts, cos_ring, sin_ring, gray,
            weights, lights, half, cos_d, column, fraction, kind, ints, fa, fb, warm,
            nonnegative, normals, residual, cost, free, coefficients, screen, products,
            np.empty(n_lights, np.int64), np.empty(n_lights), np.empty(n_lights),
            np.empty(n_lights, np.int64), np.empty(n_lights), np.empty(n_lights),
            np.empty(n_lights), np.empty(k), np.ones(k, dtype=np.bool_),
            _scratch(n_lights, k), _scratch(n_lights, k), np.ones(k, dtype=np.bool_),
            _products_scratch(n_lights, k),
        )  # fmt: skip


@_hot
def _best_start_block(
    lo, hi, starts, cos_ring, sin_ring, gray, weights, lights, half, cos_d, column, fraction,
    kind, ints, fa, fb, warm, nonnegative, normals, residual, cost, free, coefficients, screen,
    products, kept, g_kept, w_kept, sub_kept, sub_g, sub_w, shifted, coef, all_free, scratch,
    best, best_free, work_products,
):  # pragma: no cover  # fmt: skip
    """:func:`best_start` on the pixels ``lo … hi - 1`` with the block's work arrays (the
    winner's fit ``best``, a fit ``scratch``): compiled without numba's runtime, so that no
    array passed on per pixel and call is reference-counted (atomic operations on counts the
    threads share, a quarter of the time before)."""
    n_starts = starts.shape[0]
    k = len(coef)
    for p in range(lo, hi):
        m = _kept(weights[p], gray[p], kept, g_kept, w_kept)
        m_sub = 0
        signal = 0.0
        for j in range(m):
            signal += w_kept[j] * g_kept[j] * g_kept[j]
            if j % SCREEN_STRIDE == 0:
                sub_kept[m_sub], sub_g[m_sub], sub_w[m_sub] = kept[j], g_kept[j], w_kept[j]
                m_sub += 1
        before = (
            kept, g_kept, w_kept, m, sub_kept, sub_g, sub_w, m_sub, SCREEN_MARGIN * signal,
            lights, half, cos_d, column, fraction, kind, ints, fa, fb, warm, nonnegative,
            shifted, coef, free[p], all_free,
        )  # fmt: skip
        after = (p, normals, residual, cost, coefficients)
        for s in range(n_starts):
            if _try_start(
                starts[s, p, 0], starts[s, p, 1], starts[s, p, 2], s == 0, False, *before,
                scratch, *after,
            ):  # fmt: skip
                scratch, best = best, scratch  # keep the winner's fit aside
                for a in range(k):
                    best_free[a] = free[p, a]
        nx, ny, nz = normals[p, 0], normals[p, 1], normals[p, 2]  # the ring around it
        t = _tangents(nx, ny, nz)
        for s in range(6):
            ca, sa = np.cos(s * np.pi / 3), np.sin(s * np.pi / 3)
            if _try_start(
                nx * cos_ring + sin_ring * (ca * t[0] + sa * t[3]),
                ny * cos_ring + sin_ring * (ca * t[1] + sa * t[4]),
                nz * cos_ring + sin_ring * (ca * t[2] + sa * t[5]),
                False, screen, *before, scratch, *after,
            ):  # fmt: skip
                scratch, best = best, scratch
                for a in range(k):
                    best_free[a] = free[p, a]
        if products is not None:
            for a in range(k):
                free[p, a] = best_free[a]
            _store_products(
                products, p, normals[p, 0], normals[p, 1], normals[p, 2], kept, w_kept, m,
                lights, half, cos_d, column, fraction, kind, ints, fa, fb, residual[p],
                coefficients[p], free[p], best, work_products,
            )  # fmt: skip


def lm_step(
    normals, damping, residual, cost, active, free, gray, weights, lights, half, cos_d, column,
    fraction, kind, ints, fa, fb, warm, nonnegative, tolerance, products=None, coefficients=None,
):  # fmt: skip
    """One Levenberg–Marquardt iteration of :func:`~brdfkit.vision.bivariate_stereo._refine_normals`
    on every ``active`` pixel, in place on ``normals`` ``(P, 3)``, ``damping`` ``(P,)``,
    ``residual`` ``(P, N)``, ``cost`` ``(P,)``, ``active`` ``(P,)``, the active sets ``free``
    ``(P, K)`` and, if given, the reflectance weights ``coefficients`` ``(P, K)`` of the
    normals.

    ``n(u, v) = normalise(n + u t_1 + v t_2)``; the Jacobian analytic (:func:`_products`); the
    step ``-(J^T J + λ tr(J^T J)/2 I)^{-1} J^T r`` clipped to 0.2 per coordinate is kept if the
    cost falls (``λ`` / 3, else ``λ`` × 4, within [1e-7, 1e7]). A pixel whose step is below
    ``tolerance`` (both coordinates) stops: it is made inactive without trying the step.

    ``products`` ``(P, 6)``, if given (zeros at the start), keeps each pixel's ``J^T J``,
    ``J^T r`` of its current normal and whether they hold: they are computed from the fit that
    accepted the normal (and kept through rejected steps), so that no iteration refits the
    current normal (the same numbers as the refit).
    """
    _over_threads(
        _lm_tasks, len(gray), normals, damping, residual, cost, active, free, gray, weights,
        lights, half, cos_d, column, fraction, kind, ints, fa, fb, warm, nonnegative, tolerance,
        products, coefficients,
    )  # fmt: skip


@_jit
def _lm_tasks(
    task, tasks, normals, damping, residual, cost, active, free, gray, weights, lights, half,
    cos_d, column, fraction, kind, ints, fa, fb, warm, nonnegative, tolerance, products,
    coefficients,
):  # pragma: no cover  # fmt: skip
    """:func:`lm_step` on the blocks ``task``, ``task + tasks``, … (:func:`_over_threads`)."""
    n_pixels, n_lights = gray.shape
    k = free.shape[1]
    for block in range(task, (n_pixels + BLOCK - 1) // BLOCK, tasks):
        _lm_block(
            block * BLOCK, min((block + 1) * BLOCK, n_pixels), normals, damping, residual, cost,
            active, free, gray, weights, lights, half, cos_d, column, fraction, kind, ints, fa,
            fb, warm, nonnegative, tolerance, products, coefficients,
            np.empty(n_lights, np.int64), np.empty(n_lights), np.empty(n_lights),
            np.empty(n_lights), np.empty(k), _scratch(n_lights, k),
            _products_scratch(n_lights, k),
        )  # fmt: skip


@_hot
def _lm_block(
    lo, hi, normals, damping, residual, cost, active, free, gray, weights, lights, half, cos_d,
    column, fraction, kind, ints, fa, fb, warm, nonnegative, tolerance, products, coefficients,
    kept, g_kept, w_kept, shifted, coef, scratch, work_products,
):  # pragma: no cover  # fmt: skip
    """:func:`lm_step` on the pixels ``lo … hi - 1`` with the block's work arrays (without
    numba's runtime, as :func:`_best_start_block`)."""
    for p in range(lo, hi):
        if not active[p]:
            continue
        r = residual[p]
        m = _kept(weights[p], gray[p], kept, g_kept, w_kept)
        nx, ny, nz = normals[p, 0], normals[p, 1], normals[p, 2]
        t = _tangents(nx, ny, nz)
        if products is not None and products[p, 5] != 0.0:  # held since the normal's fit
            j00, j01, j11 = products[p, 0], products[p, 1], products[p, 2]
            g0, g1 = products[p, 3], products[p, 4]
        else:  # refit the normal for its system
            _fit(
                nx, ny, nz, kept, g_kept, w_kept, m, lights, half, cos_d, column, fraction,
                kind, ints, fa, fb, warm, nonnegative, shifted, coef, free[p], scratch,
            )  # fmt: skip
            j00, j01, j11, g0, g1 = _products(
                nx, ny, nz, t, kept, w_kept, m, lights, half, cos_d, column, fraction, kind,
                ints, fa, fb, shifted, coef, free[p], scratch, work_products,
            )  # fmt: skip
            if products is not None:
                products[p, 0], products[p, 1], products[p, 2] = j00, j01, j11
                products[p, 3], products[p, 4], products[p, 5] = g0, g1, 1.0
        shift = damping[p] * ((j00 + j11) / 2 + 1e-300)
        a00, a11 = j00 + shift, j11 + shift
        determinant = a00 * a11 - j01 * j01
        if determinant != 0.0:
            s0 = -(a11 * g0 - j01 * g1) / determinant
            s1 = -(a00 * g1 - j01 * g0) / determinant
        else:
            s0 = s1 = 0.0
        if abs(s0) < tolerance and abs(s1) < tolerance:
            active[p] = False
            continue
        s0, s1 = min(max(s0, -0.2), 0.2), min(max(s1, -0.2), 0.2)  # at most ~11° per iteration
        tx = nx + s0 * t[0] + s1 * t[3]
        ty = ny + s0 * t[1] + s1 * t[4]
        tz = nz + s0 * t[2] + s1 * t[5]
        length = np.sqrt(tx * tx + ty * ty + tz * tz)
        tx, ty, tz = tx / length, ty / length, tz / length
        trial_cost = _fit(
            tx, ty, tz, kept, g_kept, w_kept, m, lights, half, cos_d, column, fraction, kind,
            ints, fa, fb, warm, nonnegative, shifted, coef, free[p], scratch,
        )  # fmt: skip
        if trial_cost < cost[p]:
            normals[p, 0], normals[p, 1], normals[p, 2] = tx, ty, tz
            for n in range(len(shifted)):  # (loops: slice copies need numba's runtime)
                r[n] = shifted[n]
            cost[p] = trial_cost
            if coefficients is not None:
                for a in range(len(coef)):
                    coefficients[p, a] = coef[a]
            damping[p] = min(max(damping[p] / 3, 1e-7), 1e7)
            if products is not None:  # the new normal's, from the fit just done
                _store_products(
                    products, p, tx, ty, tz, kept, w_kept, m, lights, half, cos_d, column,
                    fraction, kind, ints, fa, fb, shifted, coef, free[p], scratch,
                    work_products,
                )  # fmt: skip
        else:
            damping[p] = min(max(damping[p] * 4, 1e-7), 1e7)


@_hot
def _table_sums(
    normals, gray, weights, lights, half, column, fraction, n_h, n_d, coefficients, bands, rhs,
    corner, weight, used, cosines, bins, fractions,
):  # pragma: no cover  # fmt: skip
    """:func:`table_normal_equations` of the pixels given, added to ``bands`` and ``rhs``
    (work arrays: ``corner``, ``weight`` ``(4,)``; per observation ``used``, ``cosines``
    ``(N,)``, ``bins``, ``fractions`` ``(N, 2)``, for :func:`_table_rows`)."""
    for p in range(len(normals)):
        nx, ny, nz = normals[p, 0], normals[p, 1], normals[p, 2]
        rho_d, rho_s = coefficients[p, 0], coefficients[p, 1]
        m = 0
        for n in range(gray.shape[1]):  # the observations that add to the sums
            if weights[p, n] == 0.0:
                continue
            shading = max(nx * lights[n, 0] + ny * lights[n, 1] + nz * lights[n, 2], 0.0)
            if shading * rho_s == 0.0:
                continue
            used[m] = n
            cosines[m] = nx * half[n, 0] + ny * half[n, 1] + nz * half[n, 2]
            m += 1
        _table_rows(cosines, m, n_h, bins, fractions)
        for j in range(m):
            n = used[j]
            w = weights[p, n]
            shading = max(nx * lights[n, 0] + ny * lights[n, 1] + nz * lights[n, 2], 0.0)
            scale = shading * rho_s  # d model / d T
            target = gray[p, n] - shading * rho_d
            i, fu = bins[j, 0], fractions[j, 0]
            c, fw = column[n], fraction[n]
            weight[0], weight[1] = (1 - fu) * (1 - fw), fu * (1 - fw)
            weight[2], weight[3] = (1 - fu) * fw, fu * fw
            for a in range(4):  # corner a is node (i + a % 2, c + a // 2)
                corner[a] = (i + a % 2) * n_d + c + a // 2
            for a in range(4):
                wa = w * scale * weight[a]
                rhs[corner[a]] += wa * target
                for b in range(4):
                    di, dj = b % 2 - a % 2, b // 2 - a // 2
                    bands[corner[a], 1 + di, 1 + dj] += wa * scale * weight[b]


@_pjit
def table_normal_equations(
    normals, gray, weights, lights, half, column, fraction, n_h, n_d, coefficients, n_chunks
):  # pragma: no cover
    """The least-squares system of the shared table ``T`` given the normals and the per-pixel
    ``(ρ_d, ρ_s)`` ``coefficients`` ``(P, 2)``: ``I_k ≈ max(0, n·l_k) (ρ_d + ρ_s T(θ_h, θ_d))``
    with ``T`` bilinear on ``n_h × n_d`` nodes (flat index ``i n_d + j``).

    Returns the normal matrix as bands ``(n_chunks, n_h n_d, 3, 3)`` (entry ``[., q, 1 + di,
    1 + dj]`` couples node ``q`` with node ``q + di n_d + dj``) and the right-hand side
    ``(n_chunks, n_h n_d)``, summed over ``n_chunks`` parts of the pixels (in parallel; the
    caller adds the parts).
    """
    size = n_h * n_d
    n_pixels, n_lights = gray.shape
    bands = np.zeros((n_chunks, size, 3, 3))
    rhs = np.zeros((n_chunks, size))
    for chunk in numba.prange(n_chunks):
        lo, hi = chunk * n_pixels // n_chunks, (chunk + 1) * n_pixels // n_chunks
        _table_sums(
            normals[lo:hi], gray[lo:hi], weights[lo:hi], lights, half, column, fraction, n_h,
            n_d, coefficients[lo:hi], bands[chunk], rhs[chunk], np.empty(4, np.int64),
            np.empty(4), np.empty(n_lights, np.int64), np.empty(n_lights),
            np.empty((n_lights, 2), np.int64), np.empty((n_lights, 2)),
        )  # fmt: skip
    return bands, rhs


@_pjit
def trimmed_starts(gray, ranks, lights, windows, starts):  # pragma: no cover
    """The trimmed least-squares start normals of :func:`~brdfkit.vision.bivariate_stereo._start`
    into ``starts`` ``(S, P, 3)``: per pixel and window ``windows[s] = (lo, hi)``, the unit ``b`` of
    ``(sum_n l_n l_n^T + 1e-12 I) b = sum_n I_n l_n`` over the observations of rank (``ranks``
    ``(P, N)``) in ``[lo, hi)`` (``gray`` ``(N, P)``; :func:`_solve_free`, as
    :func:`~brdfkit.vision.photometric_stereo._weighted_least_squares` solves it), or the view
    ``(0, 0, 1)`` where ``b = 0``."""
    n_lights, n_pixels = gray.shape
    for p in numba.prange(n_pixels):
        gram, rhs = np.empty((3, 3)), np.empty(3)
        work, work_b, b = np.empty((3, 3)), np.empty(3), np.empty(3)
        free = np.ones(3, dtype=np.bool_)
        for s in range(len(windows)):
            lo, hi = windows[s, 0], windows[s, 1]
            gram[:, :] = 0.0
            rhs[:] = 0.0
            for n in range(n_lights):
                if lo <= ranks[p, n] < hi:
                    for a in range(3):
                        rhs[a] += gray[n, p] * lights[n, a]
                        for c in range(3):
                            gram[a, c] += lights[n, a] * lights[n, c]
            for a in range(3):
                gram[a, a] += 1e-12
            _solve_free(gram, rhs, free, work, work_b, b)
            length = np.sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2])
            if length > 0:
                starts[s, p, 0], starts[s, p, 1], starts[s, p, 2] = (
                    b[0] / length,
                    b[1] / length,
                    b[2] / length,
                )
            else:
                starts[s, p, 0], starts[s, p, 1], starts[s, p, 2] = 0.0, 0.0, 1.0


@_pjit
def diffuse_albedo(
    normals, gray, weights, lights, ranks, n_dark, n_bright, use
):  # pragma: no cover
    """``ρ_d`` ``(P,)`` of :func:`~brdfkit.vision.bivariate_stereo._finish`: per pixel, the
    Lambertian fit ``sum u I cos θ_i / sum u cos^2 θ_i`` over the observations ``u`` ``(P, N)``
    (into ``use``) that are lit (``weights`` ``(P, N)``, ``cos θ_i > 0.1``) and of rank (``ranks``
    ``(P, N)``) in ``[n_dark, N - n_bright)``, or over all the lit ones if none is; ``gray``
    ``(N, P)``."""
    n_lights, n_pixels = gray.shape
    rho = np.empty(n_pixels)
    for p in numba.prange(n_pixels):
        nx, ny, nz = normals[p, 0], normals[p, 1], normals[p, 2]
        count = numerator = denominator = lit_numerator = lit_denominator = 0.0
        for n in range(n_lights):
            c = max(nx * lights[n, 0] + ny * lights[n, 1] + nz * lights[n, 2], 0.0)
            lit = weights[p, n] if c > 0.1 else 0.0
            trim = lit if n_dark <= ranks[p, n] < n_lights - n_bright else 0.0
            use[p, n] = trim
            count += trim
            numerator += trim * c * gray[n, p]
            denominator += trim * (c * c)
            lit_numerator += lit * c * gray[n, p]
            lit_denominator += lit * (c * c)
        if count == 0.0:  # no trimmed observation: all the lit ones
            numerator, denominator = lit_numerator, lit_denominator
            for n in range(n_lights):
                c = max(nx * lights[n, 0] + ny * lights[n, 1] + nz * lights[n, 2], 0.0)
                use[p, n] = weights[p, n] if c > 0.1 else 0.0
        rho[p] = numerator / max(denominator, 1e-300)
    return rho


@_exact_pjit
def order_statistics(
    gray, threshold, previous, gamma, ranks, lit, tied, by_pixel
):  # pragma: no cover
    """Per pixel of ``gray`` ``(N, P)`` (pixels over the cores): the rank of each observation
    ``(P, N)`` into ``ranks``, counted (the number of smaller observations:
    :func:`numpy.argsort`'s order where no two observations are equal), whether two are equal
    ``(P,)`` into ``tied`` (there the caller takes NumPy's order, which its sort algorithm
    decides), the shadow weights ``(P, N)`` into ``lit`` (1 where the observation is above
    ``threshold`` times the pixel's :func:`numpy.percentile`, linear, interpolated as NumPy does
    between the sorted observations ``previous`` and ``previous + 1`` at ``gamma``, else 0), and
    ``gray`` transposed ``(P, N)`` into ``by_pixel`` (the layout of the per-pixel kernels)."""
    n_lights, n_pixels = gray.shape
    following = min(previous + 1, n_lights - 1)
    for block in numba.prange((n_pixels + BLOCK - 1) // BLOCK):
        lo, hi = block * BLOCK, min((block + 1) * BLOCK, n_pixels)
        values = np.empty((BLOCK, n_lights))
        for n in range(n_lights):  # the block's rows, read along gray's contiguous axis
            for p in range(lo, hi):
                values[p - lo, n] = gray[n, p]
        for p in range(lo, hi):
            row = values[p - lo]
            for n in range(n_lights):
                by_pixel[p, n] = row[n]
            a = b = 0.0
            equal = 0
            for n in range(n_lights):
                x = row[n]
                below = same = 0
                for q in range(n_lights):  # compares over the row (vectorised)
                    below += row[q] < x
                    same += row[q] == x
                ranks[p, n] = below
                equal += same
                if below <= previous < below + same:  # the sorted row's entry [previous]
                    a = x
                if below <= following < below + same:
                    b = x
            tied[p] = equal > n_lights
            difference = b - a
            if gamma >= 0.5:  # numpy's _lerp
                reference = b - difference * (1 - gamma)
            else:
                reference = a + difference * gamma
            level = threshold * reference
            for n in range(n_lights):
                lit[p, n] = 1.0 if row[n] > level else 0.0
