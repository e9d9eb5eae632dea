"""Compiled per-pixel kernels of the iterative photometric-stereo methods.

NumPy runs one operation at a time over all the pixels: at DiLiGenT size (40k pixels, 96
lights) every intermediate of an iteration is a 30 MB ``(N, P)`` array (or a 250 MB
``(P, N, K)`` design) written to memory and read back, and one core works. The solvers here do
the same arithmetic pixel by pixel, each pixel's rows in cache, with the pixels split over the
cores (``numba.prange``). Each kernel mirrors the NumPy code it replaced, step by step; results
agree to rounding (the tests compare them with the NumPy formulations).

Kernels are compiled on first use and cached on disk (``cache=True``).

References
----------
.. [1] S. K. Lam, A. Pitrou, S. Seibert, "Numba: a LLVM-based Python JIT compiler", LLVM-HPC
   2015.
"""

from __future__ import annotations

import numpy as np

from brdfkit.errors import require_extra

numba = require_extra("numba")

_FASTMATH = {"reassoc", "contract", "nsz", "arcp"}
"""Floating-point licences: reorder sums (vectorised reductions), fuse multiply-adds; no
assumption that values are finite."""

_jit = numba.njit(cache=True, nogil=True, error_model="numpy", fastmath=_FASTMATH)
_pjit = numba.njit(cache=True, nogil=True, error_model="numpy", fastmath=_FASTMATH, parallel=True)

_BLOCKS = 16
"""Contiguous pixel blocks the robust-PCA kernel splits its sums over (the parallel tasks; a
fixed count, so the rounding of the sum does not depend on the number of threads)."""

_CHUNK = 256
"""Pixels a parallel task of the consensus kernels takes (its scratch arrays made once)."""

# ----------------------------------------------------------------------------------------------
# Sparse regression (ADMM, Ikehata et al. 2012)


@_pjit
def admm_chunk(gray, error, dual, pinv, lights, betas, b_out, gap2_out):  # pragma: no cover
    """``len(betas)`` ADMM iterations of :func:`~brdfkit.vision.photometric_stereo.
    sparse_regression` on every pixel, in place on ``error`` and ``dual`` ``(P, N)``.

    Per pixel and iteration ``j`` (penalty ``beta = betas[j]``): ``b = L^+ (I - e + y/beta)``,
    ``r = I - L b``, ``e = shrink(r + y/beta, 1/beta)``, ``y += beta (r - e)``; writes ``b``
    to ``b_out[j]`` ``(3, P)`` and ``|r - e|^2`` to ``gap2_out[j]`` ``(P,)``.
    """
    n_pixels, n_lights = gray.shape
    for p in numba.prange(n_pixels):
        g, e, y = gray[p], error[p], dual[p]
        for j in range(len(betas)):
            beta = betas[j]
            inverse = 1.0 / beta
            b0 = 0.0
            b1 = 0.0
            b2 = 0.0
            for k in range(n_lights):
                v = g[k] - e[k] + y[k] * inverse
                b0 += pinv[0, k] * v
                b1 += pinv[1, k] * v
                b2 += pinv[2, k] * v
            gap2 = 0.0
            for k in range(n_lights):
                r = g[k] - (lights[k, 0] * b0 + lights[k, 1] * b1 + lights[k, 2] * b2)
                x = r + y[k] * inverse
                shrunk = min(max(x, -inverse), inverse)
                e[k] = x - shrunk  # sign(x) max(|x| - 1/beta, 0)
                gap = r - e[k]
                y[k] += beta * gap
                gap2 += gap * gap
            b_out[j, 0, p] = b0
            b_out[j, 1, p] = b1
            b_out[j, 2, p] = b2
            gap2_out[j, p] = gap2


# ----------------------------------------------------------------------------------------------
# Tangent frames (the consensus rings here, and vision._bivariate_kernels)


@_jit
def _tangents(nx, ny, nz):  # pragma: no cover
    """:func:`~brdfkit.vision.bivariate_stereo._tangent_frame` for one normal."""
    if abs(nz) < 0.9:
        hx, hy, hz = 0.0, 0.0, 1.0
    else:
        hx, hy, hz = 1.0, 0.0, 0.0
    ax, ay, az = ny * hz - nz * hy, nz * hx - nx * hz, nx * hy - ny * hx
    length = np.sqrt(ax * ax + ay * ay + az * az)
    ax, ay, az = ax / length, ay / length, az / length
    return ax, ay, az, ny * az - nz * ay, nz * ax - nx * az, nx * ay - ny * ax


# ----------------------------------------------------------------------------------------------
# Consensus (Higo et al. 2010)


@numba.njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def consensus_best(lit, ranks, products, tables, totals):  # pragma: no cover
    """The global search of :func:`~brdfkit.vision.consensus._global_search` for a block of
    pixels: the index ``(B,)`` of each pixel's lowest-cost candidate.

    ``lit`` and ``ranks`` ``(B, N)`` (``lit`` 0 or 1); ``products`` ``(B, M)`` the sums
    ``sum_k lit_k ranks_k R_ck`` (``R`` the candidates' cosine ranks, a matrix product done by
    the caller); ``tables`` ``(3, N, M)`` the transposes of ``R``, ``R^2`` and the candidates'
    front indicator, ``totals`` ``(3, M)`` their sums over all lights. The other sums over the
    lit lights are added here from whichever list is shorter, the lit or the unlit lights
    (totals minus the unlit ones): all are sums of integers, exact in any order, and the cost
    is evaluated with NumPy's operations in NumPy's order (no fast-math), so the choice is the
    one of the NumPy formulation.
    """
    n_pixels, n_lights = lit.shape
    n_candidates = products.shape[1]
    best = np.empty(n_pixels, np.int64)
    for chunk in numba.prange((n_pixels + _CHUNK - 1) // _CHUNK):
        sums = np.empty((3, n_candidates))
        cost = np.empty(n_candidates)
        chosen = np.empty(n_lights, np.int64)
        for p in range(chunk * _CHUNK, min((chunk + 1) * _CHUNK, n_pixels)):
            w, r = lit[p], ranks[p]
            n_lit = 0
            s_w = s_i = s_ii = 0.0
            for k in range(n_lights):
                s_w += w[k]
                s_i += w[k] * r[k]
                s_ii += w[k] * r[k] * r[k]
                n_lit += w[k] != 0.0
            complement = n_lights - n_lit < n_lit
            n_chosen = 0
            for k in range(n_lights):
                if (w[k] != 0.0) != complement:
                    chosen[n_chosen] = k
                    n_chosen += 1
            sums[:, :] = 0.0
            for t in range(3):
                row = sums[t]
                for a in range(n_chosen):
                    column = tables[t, chosen[a]]
                    for c in range(n_candidates):
                        row[c] += column[c]
                if complement:
                    for c in range(n_candidates):
                        row[c] = totals[t, c] - row[c]
            count = max(s_w, 1.0)
            mean_i = s_i / count
            var_i = s_ii / count - mean_i * mean_i
            for c in range(n_candidates):
                mean_c = sums[0, c] / count
                var_c = sums[1, c] / count - mean_c * mean_c
                covariance = products[p, c] / count - mean_i * mean_c
                rho = covariance / np.sqrt(max(var_i * var_c, 1e-300))
                disagree = (s_w + totals[2, c] - 2 * sums[2, c]) / n_lights
                cost[c] = (1 - rho) / 2 + disagree
            index = 0
            for c in range(1, n_candidates):
                if cost[c] < cost[index]:
                    index = c
            best[p] = index
    return best


@_jit
def _lit_moments(ranks, lit):  # pragma: no cover
    """Count (at least 1), mean and variance of one pixel's lit observations' ranks."""
    count = s_i = s_ii = 0.0
    for k in range(len(ranks)):
        count += lit[k]
        s_i += lit[k] * ranks[k]
        s_ii += lit[k] * ranks[k] * ranks[k]
    count = max(count, 1.0)
    mean_i = s_i / count
    return count, mean_i, s_ii / count - mean_i * mean_i


@_jit
def _consensus_cost(
    nx, ny, nz, ranks, lit, moments, lights, order, cosines, ordered
):  # pragma: no cover
    """The consensus cost (:mod:`brdfkit.vision.consensus`) of one pixel's normal; ``moments`` are
    :func:`_lit_moments` of the pixel, ``order`` holds a permutation of the lights (any: it is
    insertion-sorted by ``(n·l_k, k)`` in place, which is fast from a nearby normal's order),
    ``cosines`` and ``ordered`` are scratch ``(N,)``."""
    n_lights = len(ranks)
    for k in range(n_lights):
        cosines[k] = nx * lights[k, 0] + ny * lights[k, 1] + nz * lights[k, 2]
    for i in range(n_lights):
        ordered[i] = cosines[order[i]]
    for i in range(1, n_lights):  # the sort moves the values along, compared in place
        key, value = order[i], ordered[i]
        j = i - 1
        while j >= 0 and (ordered[j] > value or (ordered[j] == value and order[j] > key)):
            order[j + 1], ordered[j + 1] = order[j], ordered[j]
            j -= 1
        order[j + 1], ordered[j + 1] = key, value
    s_c = s_cc = s_ic = disagree = 0.0
    for position in range(n_lights):
        k = order[position]
        rank_c = float(position)
        w = lit[k]
        s_c += w * rank_c
        s_cc += w * rank_c * rank_c
        s_ic += w * ranks[k] * rank_c
        disagree += abs(w - (1.0 if ordered[position] > 0 else 0.0))
    count, mean_i, var_i = moments
    mean_c = s_c / count
    variance = var_i * (s_cc / count - mean_c * mean_c)
    rho = (s_ic / count - mean_i * mean_c) / np.sqrt(max(variance, 1e-300))
    return (1 - rho) / 2 + disagree / n_lights


@_pjit
def consensus_rings(normals, cost, order, ranks, lit, lights, radii, start):  # pragma: no cover
    """The hill climbing of :func:`~brdfkit.vision.consensus.consensus` on every pixel, in place
    on ``normals`` ``(P, 3)`` and their costs ``cost`` ``(P,)``: for each radius, 6 trial
    normals around the current one, each kept if its cost is lower. With ``start`` the costs
    of the given normals are computed first (with no ``radii``: the costs alone). ``order``
    ``(P, N)`` is each pixel's last sort of the lights (any permutation is valid)."""
    n_pixels, n_lights = ranks.shape
    for chunk in numba.prange((n_pixels + _CHUNK - 1) // _CHUNK):
        cosines, ordered = np.empty(n_lights), np.empty(n_lights)
        for p in range(chunk * _CHUNK, min((chunk + 1) * _CHUNK, n_pixels)):
            nx, ny, nz = normals[p, 0], normals[p, 1], normals[p, 2]
            moments = _lit_moments(ranks[p], lit[p])
            if start:
                cost[p] = _consensus_cost(
                    nx, ny, nz, ranks[p], lit[p], moments, lights, order[p], cosines, ordered
                )
            best = cost[p]
            for radius in radii:
                t = _tangents(nx, ny, nz)
                cr, sr = np.cos(radius), np.sin(radius)
                for step in range(6):
                    azimuth = step * np.pi / 3
                    ca, sa = np.cos(azimuth), np.sin(azimuth)
                    tx = nx * cr + sr * (ca * t[0] + sa * t[3])
                    ty = ny * cr + sr * (ca * t[1] + sa * t[4])
                    tz = nz * cr + sr * (ca * t[2] + sa * t[5])
                    trial = _consensus_cost(
                        tx, ty, tz, ranks[p], lit[p], moments, lights, order[p], cosines, ordered
                    )
                    if trial < best:
                        nx, ny, nz, best = tx, ty, tz, trial
            normals[p, 0], normals[p, 1], normals[p, 2], cost[p] = nx, ny, nz, best


# ----------------------------------------------------------------------------------------------
# Robust PCA (inexact ALM, Wu et al. 2010)


@_pjit
def rpca_step(
    data, sparse, dual, observed, left, right, mu, mu_next, lam, z, matrix_next
):  # pragma: no cover
    """The updates of one :func:`~brdfkit.vision.photometric_stereo.robust_pca` iteration
    after its singular-value shrinkage, per pixel (rows of the ``(P, N)`` arrays), in place on
    ``sparse`` and ``dual``; returns ``|D - A - E|^2`` summed over the pixels.

    The shrinkage's input is ``M = D - E + Y / mu`` (recomputed here, not stored), and
    ``A = M right left^T`` (the shrinkage ``V f V^T`` of the Gram's kept eigenvectors), with
    ``z = M right`` written to ``z`` ``(P, k)``; ``E = shrink(D - A + Y/mu, lam/mu)`` where
    observed, ``D - A + Y/mu`` elsewhere; ``Y += mu (D - A - E)``; ``matrix_next = D - E +
    Y / mu_next``, the next shrinkage's input. The pixels' sums are added in :data:`_BLOCKS`
    contiguous blocks (the same rounding on any number of threads).
    """
    n_pixels, n_lights = data.shape
    rank = left.shape[1]
    gap2 = np.zeros(_BLOCKS)
    tau = lam / mu
    for block in numba.prange(_BLOCKS):
        total = 0.0
        for p in range(block * n_pixels // _BLOCKS, (block + 1) * n_pixels // _BLOCKS):
            d, e, y, zp, row = data[p], sparse[p], dual[p], z[p], matrix_next[p]
            zp[:] = 0.0
            for k in range(n_lights):
                m = d[k] - e[k] + y[k] / mu
                for j in range(rank):
                    zp[j] += right[k, j] * m
            for k in range(n_lights):
                low = 0.0
                for j in range(rank):
                    low += left[k, j] * zp[j]
                target = d[k] - low + y[k] / mu
                if observed[p, k]:
                    e[k] = target - min(max(target, -tau), tau)
                else:
                    e[k] = target
                gap = d[k] - low - e[k]
                y[k] += mu * gap
                total += gap * gap
                row[k] = d[k] - e[k] + y[k] / mu_next
        gap2[block] = total
    return gap2.sum()
