"""The kernels' threads: one pool per process, tasks taken from a queue by every worker.

The compiled kernels release the GIL (``nogil``), so Python threads run them truly in
parallel. :func:`run_tasks` hands out work items from a queue to the calling thread and the
threads of one pool kept for the process (starting threads per call costs milliseconds), so a
core slowed by other work takes fewer items; :func:`run_blocks` splits a kernel's batch into
such items.
"""

from __future__ import annotations

import os
import queue
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

BLOCK = 1 << 15
"""Fewest elements per block of work :func:`run_blocks` hands to a thread."""
BLOCKS_PER_THREAD = 8
"""Blocks per worker thread of a large batch in :func:`run_blocks`: enough that a core slowed
by other work takes fewer of them, few enough that the per-block hand-off (a pool round trip
and a numba dispatch that both need the GIL, tens of µs) stays small."""

_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()


def threads() -> int:
    """Worker threads of the kernels: the cores this process may use (``BRDFKIT_THREADS``
    overrides)."""
    override = os.environ.get("BRDFKIT_THREADS")
    return len(os.sched_getaffinity(0)) if override is None else int(override)


def run_tasks(task: Callable[[int], None], items: Sequence[int], workers: int) -> None:
    """``task(item)`` for every item, taken from a queue by the calling thread and
    ``workers - 1`` threads of the process's pool. ``task`` must not call this function
    itself (a pool thread would wait on the pool)."""
    global _POOL
    if workers <= 1 or len(items) <= 1:
        for item in items:
            task(item)
        return
    with _POOL_LOCK:
        if _POOL is None or _POOL._max_workers < workers - 1:
            _POOL = ThreadPoolExecutor(workers - 1, thread_name_prefix="brdfkit-kernels")
        pool = _POOL
    pending: queue.SimpleQueue[int] = queue.SimpleQueue()
    for item in items:
        pending.put(item)

    def work() -> None:
        while True:
            try:
                item = pending.get_nowait()
            except queue.Empty:
                return
            task(item)

    helpers = [pool.submit(work) for _ in range(min(workers, len(items)) - 1)]
    try:
        work()  # the calling thread takes tasks too
        for helper in helpers:
            helper.result()
    except BaseException:  # an error or an interrupt: the helpers take no further item
        _drain(pending)
        raise


def _drain(pending: queue.SimpleQueue[int]) -> None:
    """Empty ``pending``, so that each thread stops after the item in its hands."""
    while True:
        try:
            pending.get_nowait()
        except queue.Empty:
            return


def run_blocks(
    function: Callable[..., None],
    parameters: np.ndarray,
    arrays: list[np.ndarray],
    widths: list[int],
    n: int,
) -> None:
    """Run ``function(parameters, *arrays, n)`` over ``n`` elements in blocks on
    :func:`run_tasks`' threads.

    ``arrays`` are flat, holding ``max(width, 1)`` values per element. A batch of at most
    :data:`BLOCK` elements runs on the calling thread; a larger one in
    :data:`BLOCKS_PER_THREAD` blocks per thread (at least :data:`BLOCK` elements each), each
    block given views of its slice of every array and its own ``n``. The kernels' loops run
    over ``range(n)`` from 0: numba's ``prange`` and a loop over ``range(start, stop)`` both
    keep LLVM's loop vectoriser off these kernels (it cannot prove the indices non-negative).
    """
    workers = 1 if n <= BLOCK else threads()
    if workers == 1:
        if n:
            function(parameters, *arrays, n)
        return
    size = max(BLOCK, -(-n // (workers * BLOCKS_PER_THREAD)))
    steps = [(a, max(w, 1)) for a, w in zip(arrays, widths, strict=True)]

    def block(lo: int) -> None:
        hi = min(lo + size, n)
        function(parameters, *[a[lo * w : hi * w] for a, w in steps], hi - lo)

    run_tasks(block, range(0, n, size), workers)


__all__ = ["BLOCK", "BLOCKS_PER_THREAD", "run_blocks", "run_tasks", "threads"]
