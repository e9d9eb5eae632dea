"""The kernels' output arrays, whose memory is used again once nothing refers to it.

A fresh large array costs the operating system's zeroing of every page on first touch, a
large part of a fast kernel's time on a big batch. Dr.Jit (Mitsuba 3) avoids it with a
caching allocator; :class:`OutputPool` is the same idea for the arrays the kernels return.
Each returned array is a view of a pooled buffer, so the buffer's reference count says
whether any array (or view, memoryview, tensor made from it) still uses it; only buffers
nothing else refers to are handed out again. At most :data:`POOL_BUFFERS` idle buffers and
:data:`POOL_BYTES` are kept (CPython only: elsewhere every call allocates).

References
----------
.. [1] W. Jakob, S. Speierer, N. Roussel, D. Vicini, "Dr.Jit: a just-in-time compiler for
       differentiable rendering", ACM TOG 41(4), 2022.
"""

from __future__ import annotations

import math
import sys
import threading

import numpy as np

ALIGNMENT = 64
"""Byte alignment of the pooled outputs: one cache line, so that each 512-bit store of the
kernels writes one line (a 16-byte-aligned array, malloc's, splits every store over two)."""
POOL_BUFFERS = 8
"""Most buffers the pool keeps."""
POOL_BYTES = 1 << 29
"""Largest memory the pool keeps (512 MiB: 10⁷ RGB float32 results take 120 MB)."""


class OutputPool:
    """Output arrays from reused buffers (module docstring); thread-safe."""

    def __init__(self) -> None:
        self._buffers: list[tuple[np.ndarray, int]] = []  # (buffer, first aligned byte)
        self._lock = threading.Lock()
        # The count of a buffer that only the list holds, read the way _references reads it
        # (what an interpreter counts for the argument itself differs between versions).
        self._idle = self._references([(np.empty(0, np.uint8), 0)], 0)

    @staticmethod
    def _references(buffers: list[tuple[np.ndarray, int]], k: int) -> int:
        return sys.getrefcount(buffers[k][0])

    def empty(self, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
        """An uninitialised C-contiguous array of ``shape`` and ``dtype``, aligned to
        :data:`ALIGNMENT` bytes: an idle buffer of its size if the pool holds one."""
        nbytes = math.prod(shape) * np.dtype(dtype).itemsize
        if not hasattr(sys, "getrefcount") or nbytes > POOL_BYTES:
            return np.empty(shape, dtype)
        with self._lock:
            for k in range(len(self._buffers)):
                if (
                    self._buffers[k][0].nbytes == nbytes + ALIGNMENT
                    and self._references(self._buffers, k) == self._idle
                ):
                    entry = self._buffers.pop(k)
                    self._buffers.append(entry)  # most recently used last
                    return _view(*entry, nbytes, shape, dtype)
            buffer = np.empty(nbytes + ALIGNMENT, np.uint8)
            # the aligned start, found once (reading an address through .ctypes is slow)
            self._buffers.append((buffer, -buffer.ctypes.data % ALIGNMENT))
            while (
                len(self._buffers) > POOL_BUFFERS
                or sum(b.nbytes for b, _ in self._buffers) > POOL_BYTES
            ):
                self._buffers.pop(0)  # dropped from the pool; freed when no array uses it
            return _view(*self._buffers[-1], nbytes, shape, dtype)


def _view(
    buffer: np.ndarray, start: int, nbytes: int, shape: tuple[int, ...], dtype: np.dtype
) -> np.ndarray:
    """``nbytes`` of ``buffer`` from byte ``start`` as an array of ``shape`` and ``dtype``: a
    view whose base is ``buffer`` itself, so the pool's reference count sees it."""
    return buffer[start : start + nbytes].view(dtype).reshape(shape)


OUTPUTS = OutputPool()
"""The pool of every kernel's outputs."""

__all__ = ["ALIGNMENT", "OUTPUTS", "POOL_BUFFERS", "POOL_BYTES", "OutputPool"]
