"""Guide tables: sampling a piecewise-constant distribution by a short scan, not a bisection.

A CDF of ``count`` cells is searched for the interval k with ``cdf[k] <= u < cdf[k + 1]``.
:func:`guide_table` records, for equal buckets of [0, 1), the interval of each bucket's
left edge; :func:`guided_search`'s numba function starts there and scans a step or two
either way. The result is bisection's (:func:`brdfkit.sampling.Distribution2D`'s) for every
u, flat runs of the CDF (empty cells) included; only the number of steps depends on the
guide. The environment map's sampler and a tabulated BRDF's half-vector sampler search their
CDFs this way.

References
----------
.. [1] H. C. Chen, Y. Asau, "On generating random variates from an empirical distribution",
       AIIE Transactions 6(2), 1974 (the guide-table method).
.. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 3rd ed., §13.6.7.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from brdfkit.compiled.jit import compile_for, exact_jit


def guide_table(cdf: np.ndarray, count: int, buckets: int, rows: int = 1) -> np.ndarray:
    """The guide table of ``rows`` CDFs of ``count`` cells each (``cdf``: their ``count + 1``
    nodes per row, flat), for :func:`guided_search`: in row r, bucket m of ``buckets`` equal
    buckets of [0, 1) holds the interval k of u = m / buckets (``cdf[k] <= u < cdf[k + 1]``,
    clipped to [0, count)), at ``[r · buckets + m]``, ``(rows · buckets,)``: uint16 where
    ``count`` ≤ 2¹⁶ (half the memory of int32, fewer cache misses), else int32.

    Examples
    --------
    >>> import numpy as np
    >>> guide_table(np.array([0.0, 0.5, 0.5, 1.0]), count=3, buckets=4)
    array([0, 0, 2, 2], dtype=uint16)
    """
    nodes = np.ascontiguousarray(np.asarray(cdf, np.float64).reshape(rows, -1)[:, : count + 1])
    guide = np.empty((rows, buckets), np.uint16 if count <= 2**16 else np.int32)
    compile_for(_guide_rows(), nodes, guide)
    _guide_rows()(nodes, guide)
    return guide.ravel()


@functools.cache
def _guide_rows() -> Callable[..., None]:
    """The numba ``guide_rows(nodes, guide)`` of :func:`guide_table`: in each row of the
    nondecreasing ``nodes``, ``np.searchsorted(row, m / buckets, side="right") − 1`` clipped
    to [0, count) for every bucket m, by one walk along the row (the u's increase), its
    machine code kept on disk (:mod:`brdfkit.compiled.cache`)."""
    from brdfkit.compiled import cache

    @exact_jit()
    def guide_rows(nodes: np.ndarray, guide: np.ndarray) -> None:
        rows, buckets = guide.shape
        count = nodes.shape[1] - 1
        for r in range(rows):
            j = 0  # nodes of the row at or below u
            for m in range(buckets):
                u = np.float64(m) / np.float64(buckets)
                while j <= count and nodes[r, j] <= u:
                    j += 1
                guide[r, m] = min(max(j - 1, 0), count - 1)

    cache.enable(guide_rows, cache.key("hand-written", "guide-rows"))
    return guide_rows


@functools.cache
def guided_search() -> Callable[..., int]:
    """The numba ``guided_interval(cdf, base, guide, start, buckets, u, count)``: the
    interval of one float64 variate u ∈ [0, 1) in the row of ``count`` cells at
    ``cdf[base:]``, the k in ``[0, count)`` with ``cdf[base + k] <= u < cdf[base + k + 1]``
    (the last k with ``cdf[base + k] <= u``: bisection's, flat runs included), by a scan from
    the row's guide ``guide[start + ⌊u · buckets⌋]`` (:func:`guide_table`). The scan goes
    either way, so the result does not depend on the guide's values, only the number of
    steps does (rounding of u · buckets included)."""

    @exact_jit()
    def guided_interval(cdf: np.ndarray, base: int, guide: np.ndarray, start: int,
                        buckets: int, u: float, count: int) -> int:  # fmt: skip
        k = np.int64(guide[start + min(np.int64(u * buckets), buckets - 1)])
        while k > 0 and cdf[base + k] > u:
            k -= 1
        while k + 1 < count and cdf[base + k + 1] <= u:
            k += 1
        return k

    return guided_interval


__all__ = ["guide_table", "guided_search"]
