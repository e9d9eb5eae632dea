"""A model's own NumPy ``eval`` over a huge batch, chunk by chunk, into one output array.

:func:`eval_chunked` is the path for what the compiled kernels do not take (a texture, a
model the tracer cannot compile): the model's own code on fixed-size chunks, optionally on
threads (NumPy releases the GIL inside its loops), so that temporaries stay in cache and the
extra memory is bounded by the chunk, never by the batch. The values are those of one big
call.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from brdfkit._array import to_numpy
from brdfkit.brdf.base import BRDF

DEFAULT_CHUNK = 1 << 16
"""Batch elements per chunk of :func:`eval_chunked` (a few MB of float32 temporaries).

Chosen by sweeping 2k–128k on ``benchmarks/bench_brdf.py``'s GGX conductor: with two worker
threads 64k is fastest, because every NumPy operation hands the GIL back and forth between
the threads and short operations make that hand-off dominate; one thread is within a few
per cent of its best there."""


def directions(name: str, v: Any) -> np.ndarray:
    """``v`` as a NumPy array of directions ``(..., 3)``.

    Raises
    ------
    ValueError
        When its last axis is not of length 3 (naming the argument ``name``).
    """
    v = np.asarray(to_numpy(v))
    if v.ndim == 0 or v.shape[-1] != 3:
        raise ValueError(f"{name} must have a last axis of length 3 (x, y, z); got shape {v.shape}")
    return v


def eval_chunked(
    model: BRDF,
    wi: Any,
    wo: Any,
    *,
    chunk: int = DEFAULT_CHUNK,
    workers: int = 1,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """``model.eval(wi, wo)`` on NumPy in chunks of ``chunk`` pairs, into one output array.

    The model's own code runs on each chunk, so values are identical to one big call; the
    dtype of the inputs is kept (float32 stays float32). The temporaries of a chunk (a few
    dozen arrays of ``chunk × C`` values) stay in cache and bound the extra memory, whatever
    the batch size; ``out`` (shape ``batch + (C,)``) avoids even the output allocation.
    ``workers > 1`` evaluates chunks on that many threads (NumPy releases the GIL in its
    loops, not between them, so threads gain less than their number; see
    :data:`DEFAULT_CHUNK`).
    Each chunk's directions are handed to the model as a copy laid out component by
    component: the same values, in the layout NumPy reads fastest.

    Raises
    ------
    ValueError
        For a bad ``chunk``/``workers``, directions without a last axis of 3, or an ``out`` of
        the wrong shape or dtype.
    """
    if chunk < 1:
        raise ValueError(f"chunk must be >= 1; got {chunk}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1; got {workers}")
    wi, wo = directions("wi", wi), directions("wo", wo)
    dtype = np.result_type(wi.dtype, wo.dtype)
    if not np.issubdtype(dtype, np.floating):
        dtype = np.dtype(np.float64)
    batch = np.broadcast_shapes(wi.shape[:-1], wo.shape[:-1])
    wi, wo = _flat_view(wi, batch), _flat_view(wo, batch)
    shape = (*batch, model.channels)
    if out is None:
        out = np.empty(shape, dtype=dtype)
    elif out.shape != shape or out.dtype != dtype or not out.flags.c_contiguous:
        raise ValueError(
            f"out must be a C-contiguous array of shape {shape} and dtype {dtype}; "
            f"got shape {out.shape}, dtype {out.dtype}"
        )
    flat = out.reshape(-1, model.channels)

    def run(start: int) -> None:
        stop = start + chunk
        a, b = _components_first(wi[start:stop]), _components_first(wo[start:stop])
        _store(flat[start:stop], np.asarray(model.eval(a, b)))

    starts = range(0, flat.shape[0], chunk)
    if workers == 1:
        for start in starts:
            run(start)
    else:
        pool = ThreadPoolExecutor(workers)
        try:
            list(pool.map(run, starts))
        finally:  # on an error or an interrupt, the chunks not started are dropped
            pool.shutdown(wait=True, cancel_futures=True)
    return out


def _components_first(v: np.ndarray) -> np.ndarray:
    """``(n, 3)`` directions with the same values laid out component by component (a view of
    a ``(3, n)`` array), so that every ``w[..., k]`` a model reads is contiguous: NumPy reads
    a component strided through ``(x, y, z)`` rows several times slower. The layout carries
    through the model's arithmetic."""
    soa = np.empty((v.shape[1], v.shape[0]), v.dtype)
    for k in range(v.shape[1]):
        soa[k] = v[:, k]
    return soa.T


def _store(target: np.ndarray, value: np.ndarray) -> None:
    """``target[...] = value`` for ``(n, C)`` arrays; a channel-major ``value`` (a model's
    per-channel terms are computed channels first) is copied one channel at a time, since
    NumPy's own copy steps through it C values per row, several times slower."""
    if value.shape == target.shape and value.ndim == 2 and value.strides[0] < value.strides[1]:
        for c in range(value.shape[1]):
            target[:, c] = value[:, c]
    else:
        target[...] = value


def _flat_view(v: np.ndarray, batch: tuple[int, ...]) -> np.ndarray:
    """``v`` broadcast to ``batch + (3,)`` as ``(n, 3)``: a view where strides allow (a full
    array, or one direction repeated), else a copy."""
    full = np.broadcast_to(v, (*batch, 3))
    try:
        return np.reshape(full, (-1, 3), copy=False)
    except ValueError:
        return full.reshape(-1, 3)


__all__ = ["DEFAULT_CHUNK", "directions", "eval_chunked"]
