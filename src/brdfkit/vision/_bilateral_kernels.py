"""Compiled conjugate gradients of :mod:`brdfkit.vision.bilateral_integration`.

Each iteration of the bilateral integration solves a weighted graph Laplacian ``L z = b``
(one unknown per mask pixel, five entries per row) to a loose relative tolerance, started from
the previous depth. SciPy's ``cg`` spends more time in its Python loop than in arithmetic at
this size (50k unknowns, thousands of iterations per integration); here the whole solve is one
compiled loop, each step three passes over the vectors. The matrix is stored by pixel, not as
CSR: a pixel's row neighbours are the next and previous unknowns, so only its column
neighbours are looked up. The kernel is compiled on first use and cached on disk
(``cache=True``).

References
----------
.. [1] M. R. Hestenes, E. Stiefel, "Methods of conjugate gradients for solving linear systems",
   J. Res. Nat. Bur. Standards 49(6), 409-436, 1952.
.. [2] Y. Saad, "Iterative methods for sparse linear systems", 2nd ed., SIAM 2003, Alg. 9.1.
"""

from __future__ import annotations

import numpy as np

from brdfkit.errors import require_extra

numba = require_extra("numba")

_FASTMATH = {"reassoc", "contract", "nsz", "arcp"}
"""Floating-point licences: reorder sums (vectorised reductions), fuse multiply-adds; no
assumption that values are finite."""

_jit = numba.njit(cache=True, nogil=True, error_model="numpy", fastmath=_FASTMATH)


@_jit
def _apply(degree, c_right, c_left, c_up, c_down, up, down, x, out):  # pragma: no cover
    """``out = L x`` for the five-point graph Laplacian: pixel ``i``'s neighbours are
    ``i ± 1`` in its row (weight 0 where absent) and ``up[i]``, ``down[i]``; returns ``x.Lx``."""
    n = len(x)
    dot = 0.0
    for i in range(n):
        s = degree[i] * x[i] - c_up[i] * x[up[i]] - c_down[i] * x[down[i]]
        if i + 1 < n:
            s -= c_right[i] * x[i + 1]
        if i > 0:
            s -= c_left[i] * x[i - 1]
        out[i] = s
        dot += x[i] * s
    return dot


@_jit
def stencil_cg(
    degree, c_right, c_left, c_up, c_down, up, down, rhs, x, rtol, max_iterations
):  # pragma: no cover
    """Jacobi-preconditioned conjugate gradients on the five-point Laplacian of
    :func:`_apply`, in place on ``x`` (the start); stops when ``|r| <= rtol |rhs|``. Returns
    the iterations.

    Saad's Algorithm 9.1 with ``M = diag(L)`` (the diagonal kept at least 1e-5, as the
    authors' code does): three passes per iteration (the product with its dot ``p.Lp``; the
    updates of ``x``, ``r`` and the preconditioned residual with their dots; the new
    direction)."""
    n = len(rhs)
    r = np.empty(n)
    z = np.empty(n)
    p = np.empty(n)
    lp = np.empty(n)
    inverse_diagonal = np.empty(n)
    _apply(degree, c_right, c_left, c_up, c_down, up, down, x, lp)
    rhs_norm2 = 0.0
    rz = 0.0
    for i in range(n):
        inverse_diagonal[i] = 1.0 / max(degree[i], 1e-5)
        r[i] = rhs[i] - lp[i]
        z[i] = inverse_diagonal[i] * r[i]
        p[i] = z[i]
        rz += r[i] * z[i]
        rhs_norm2 += rhs[i] * rhs[i]
    limit = rtol * rtol * rhs_norm2
    for iteration in range(max_iterations):
        p_lp = _apply(degree, c_right, c_left, c_up, c_down, up, down, p, lp)
        if p_lp <= 0.0:
            return iteration
        alpha = rz / p_lp
        rr = 0.0
        rz_next = 0.0
        for i in range(n):
            x[i] += alpha * p[i]
            r[i] -= alpha * lp[i]
            z[i] = inverse_diagonal[i] * r[i]
            rr += r[i] * r[i]
            rz_next += r[i] * z[i]
        if rr <= limit:
            return iteration + 1
        beta = rz_next / rz
        rz = rz_next
        for i in range(n):
            p[i] = z[i] + beta * p[i]
    return max_iterations
