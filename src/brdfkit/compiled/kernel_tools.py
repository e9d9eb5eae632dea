"""What a hand-written numba kernel needs, in one place.

Most compiled code is generated from the models' own code (:func:`brdfkit.compiled.compile`).
What tracing cannot express (table lookups, searches in a CDF, a tile's sampling loop) is
written for numba by hand, beside the code it mirrors (``measured/_tabulated_kernels.py``,
``render/_reflection_kernels.py``, ``light/_environment_kernels.py``, the vision kernels).
Those modules build their functions from this toolkit only:

- decorators: :func:`exact_jit` (rounds as written), :func:`vector_jit` (the
  :data:`FASTMATH` flags of vectorised loops), :func:`jit` (a helper with its caller's
  flags), :func:`inline_jit` (a step inlined into its caller), :func:`step_jit` (a step
  called through its address), :func:`without_runtime`
  (options for code that passes arrays on without reference counting), :func:`cached_jit`
  (:func:`exact_jit` with its machine code kept on disk);
- intrinsics: :func:`select` (a branch-free choice), :func:`prefetch` (a cache hint),
  :func:`vector_width_hint` (:func:`vector_bits` wide vectors for one function),
  :func:`empty` and :func:`flat` (``np.empty`` and ``reshape(-1)`` lowered in place: their
  cached machine code loads without numba's array module);
- functions as arguments: :func:`first_class_function` (a compiled function as a value of
  type :func:`function_type`: a kernel taking it is compiled once per signature, not per
  function), with :func:`array_type`, :func:`scalar_type` and :func:`type_of` for a kernel's
  signature;
- scalar functions: :func:`trigonometry` (``atan2``, ``sin``, ``cos`` in a dtype);
- CDF searches: :func:`guide_table` and :func:`guided_search`;
- threads: :func:`threads` and :func:`run_tasks`.

A layer below :mod:`brdfkit.compiled` (the environment map's kernels in :mod:`brdfkit.light`)
is handed this module by its caller rather than importing it.

Examples
--------
>>> import numpy as np
>>> from brdfkit.compiled import kernel_tools
>>> select = kernel_tools.select()
>>> @kernel_tools.exact_jit()
... def clamp0(x):
...     return select(x > 0.0, x, 0.0)
>>> float(clamp0(-2.5)), float(clamp0(1.5))
(0.0, 1.5)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from brdfkit.compiled.guide_tables import guide_table, guided_search
from brdfkit.compiled.jit import (
    FASTMATH,
    array_type,
    empty,
    exact_jit,
    first_class_function,
    flat,
    function_type,
    inline_jit,
    jit,
    prefetch,
    scalar_type,
    select,
    step_jit,
    type_of,
    vector_bits,
    vector_jit,
    vector_width_hint,
    without_runtime,
)
from brdfkit.compiled.scalar_functions import trigonometry
from brdfkit.compiled.thread_pool import run_tasks, threads


def cached_jit(name: str) -> Callable[[Any], Any]:
    """:func:`exact_jit` for a hand-written kernel called on its own (not inlined into a
    generated one), its machine code kept in :mod:`brdfkit.compiled.cache` under ``name``
    (the cache's folder already names the version of brdfkit's code): a new process loads
    it instead of compiling it again."""
    from brdfkit.compiled import cache

    def decorate(function: Callable[..., Any]) -> Any:
        dispatcher = exact_jit()(function)
        cache.enable(dispatcher, cache.key("hand-written", name))
        return dispatcher

    return decorate


__all__ = [
    "FASTMATH",
    "array_type",
    "cached_jit",
    "empty",
    "exact_jit",
    "first_class_function",
    "flat",
    "function_type",
    "guide_table",
    "guided_search",
    "inline_jit",
    "jit",
    "prefetch",
    "run_tasks",
    "scalar_type",
    "select",
    "step_jit",
    "threads",
    "trigonometry",
    "type_of",
    "vector_bits",
    "vector_jit",
    "vector_width_hint",
    "without_runtime",
]
