"""numba's decorators and LLVM intrinsics as brdfkit's kernels use them.

Three decorators: :func:`exact_jit` (no floating-point licences: argument reductions, Newton
steps and table lookups round as written), :func:`vector_jit` (the :data:`FASTMATH` licences
of the vectorised loops) and :func:`jit` (a helper compiled with the licences of the function
that calls it); all release the GIL and follow NumPy's error model (a division by zero gives
inf or NaN, never an exception). The intrinsics (:func:`select`,
:func:`prefetch`, :func:`vector_width_hint`) are single LLVM instructions or attributes that
keep a loop branch-free and vectorised (:mod:`brdfkit.compiled._numba` builds them). A kernel
may take compiled functions as arguments (:func:`first_class_function`, of the type
:func:`function_type`) and so be compiled once for all functions of one signature; its
signature, given ahead of its first call, is made of :func:`array_type`, :func:`scalar_type`
and :func:`type_of`; :func:`compile_for` compiles (or loads) a function for the types of
given arguments. numba is imported on first use.

References
----------
.. [1] S. K. Lam, A. Pitrou, S. Seibert, "Numba: a LLVM-based Python JIT compiler", LLVM-HPC
       2015.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

from brdfkit.compiled import _numba

FASTMATH = frozenset({"contract", "arcp", "nsz", "reassoc"})
"""LLVM fast-math flags of the vectorised kernels: fused multiply-add, reciprocal
multiplication, no signed zeros and reassociation (the same float32 error against float64 as
without them). No NaN/infinity assumptions: the models' ``where`` guards rely on both."""


def jit() -> Callable[[Any], Any]:
    """numba's decorator for helpers of a kernel: no GIL, NumPy's error model, and the
    floating-point flags of the function calling it (numba's flags inheritance: a helper of
    a :func:`vector_jit` loop is compiled with its fast-math flags, of an :func:`exact_jit`
    one without, and inlined there)."""
    numba = _numba.numba_module()

    return numba.njit(nogil=True, error_model="numpy")


def inline_jit() -> Callable[[Any], Any]:
    """numba's decorator for a step of a kernel: :func:`jit`'s options, and the function's
    code inlined into its caller's by numba (``inline="always"``), so that the step's loops
    are optimised where the caller's arrays are known not to overlap (a loop over arrays
    that might overlap needs run-time checks, which can keep LLVM from vectorising it)."""
    numba = _numba.numba_module()

    return numba.njit(nogil=True, error_model="numpy", inline="always")


def step_jit() -> Callable[[Any], Any]:
    """numba's decorator for a step of a kernel compiled on its own and called through its
    address (:func:`first_class_function`, once per block of pixels): :func:`jit`'s options
    without numba's runtime (:func:`without_runtime`), so that a call passes its arrays on
    without updating their reference counts. The step may not allocate."""
    numba = _numba.numba_module()
    return numba.njit(nogil=True, error_model="numpy", **without_runtime())


def exact_jit() -> Callable[[Any], Any]:
    """numba's decorator for functions that must round as written wherever they are called
    from: no fast-math flags (reassociation would undo argument reductions and Newton
    steps), NumPy's error model, no GIL."""
    numba = _numba.numba_module()

    return numba.njit(fastmath=False, error_model="numpy", nogil=True)


def vector_jit() -> Callable[[Any], Any]:
    """numba's decorator for loops LLVM should vectorise: the :data:`FASTMATH` flags, NumPy's
    error model, no GIL. A function so compiled calls ``prefer_vector_width()``
    (:func:`vector_width_hint`) to have its loops use :func:`vector_bits` wide vectors."""
    numba = _numba.numba_module()

    return numba.njit(nogil=True, error_model="numpy", fastmath=set(FASTMATH))


def vector_bits() -> int:
    """The SIMD width the kernels ask LLVM's vectoriser for, in bits (``BRDFKIT_VECTOR_BITS``
    overrides; default 512).

    LLVM tunes recent Intel CPUs to prefer 256-bit vectors even where AVX-512 is there (the
    512-bit units once lowered the clock of a whole core). The kernels are throughput-bound on
    division and square roots, which 512-bit vectors do at more lanes per cycle. Where
    AVX-512 is absent the hint has no effect (the widest legal vectors are used), so 512 is
    safe everywhere; set 256 on a CPU whose clock drops under AVX-512.
    """
    bits = os.environ.get("BRDFKIT_VECTOR_BITS", "512")
    if bits not in ("128", "256", "512"):
        raise ValueError(f"BRDFKIT_VECTOR_BITS must be 128, 256 or 512; got {bits!r}")
    return int(bits)


def vector_width_hint() -> Any:
    """The numba intrinsic ``prefer_vector_width()``: a call marks the calling function's
    loops for :func:`vector_bits` wide vectors (``"prefer-vector-width"``), for that function
    alone."""
    return _numba.vector_width_hint(vector_bits())


def select() -> Callable[[Any, Any, Any], Any]:
    """The numba intrinsic ``select(condition, a, b)``: ``a`` where ``condition`` else ``b``,
    one LLVM ``select`` (both operands computed, no branch), for ``a`` and ``b`` of one type.
    Python's conditional expression compiles to a branch, which keeps LLVM from vectorising
    the loop around it."""
    return _numba.intrinsics()["_select"]


def empty() -> Callable[[Any, Any], Any]:
    """The numba intrinsic ``empty(shape, dtype)``: ``np.empty(shape, dtype)`` (an integer or
    a tuple of integers, a NumPy scalar type) lowered into the calling function, so that its
    machine code, loaded from the disk cache, needs no module of numba's array functions
    imported (:func:`brdfkit.compiled._numba.array_intrinsics`)."""
    return _numba.array_intrinsics()["empty"]


def flat() -> Callable[[Any], Any]:
    """The numba intrinsic ``flat(array)``: ``array.reshape(-1)`` of a C-contiguous array (a
    view), lowered into the calling function as :func:`empty` is."""
    return _numba.array_intrinsics()["flat"]


def prefetch() -> Callable[[Any, int], None]:
    """The numba intrinsic ``prefetch(array, i)``: LLVM's ``llvm.prefetch`` of element ``i``
    of a C-contiguous ``array`` (read, keep in all cache levels); a hint, no effect on values.
    Issued some iterations ahead of a gather, it overlaps the cache misses of a table larger
    than the caches."""
    return _numba.prefetch()


def without_runtime() -> dict[str, Any]:
    """``numba.njit`` options that compile a function without numba's reference-counting
    runtime: arrays passed on are not reference-counted (atomic updates of counts that
    threads share). The function may then neither allocate nor return an array."""
    return _numba.no_runtime_options()


def array_type(dtype: Any, ndim: int) -> Any:
    """numba's type of a writable, C-contiguous NumPy array of ``dtype`` and ``ndim`` axes
    (what ``numba.typeof`` gives such an array)."""
    numba = _numba.numba_module()
    import numpy as np

    return numba.types.Array(numba.from_dtype(np.dtype(dtype)), ndim, "C")


def scalar_type(dtype: Any) -> Any:
    """numba's type of a NumPy scalar of ``dtype`` (``bool``: Python's and NumPy's booleans)."""
    numba = _numba.numba_module()
    import numpy as np

    return numba.from_dtype(np.dtype(dtype))


def type_of(value: Any) -> Any:
    """numba's type of ``value`` as a kernel's argument (``numba.typeof``)."""
    numba = _numba.numba_module()

    return numba.typeof(value)


def compile_for(dispatcher: Any, *arguments: Any) -> None:
    """Compile the numba function ``dispatcher`` for the types of ``arguments`` now, or load
    its machine code (from this process or the disk cache), so that calling it with them
    runs that code at once.

    What numba's own first call of a function does, less one step: before looking at the
    arguments, that call loads every installed package's numba extensions (it reads the
    entry points of every installed distribution: 15–35 ms of a process's start-up), which
    machine code loaded from the disk does not need, and which compiling code does itself.
    """
    dispatcher.compile(tuple(type_of(a) for a in arguments))


def function_type(argument_types: tuple[Any, ...]) -> Any:
    """numba's type of a compiled function of ``argument_types`` returning nothing, as an
    argument of a kernel (:func:`first_class_function`)."""
    return _numba.function_type(argument_types)


def first_class_function(dispatcher: Any, argument_types: tuple[Any, ...]) -> Any:
    """The numba function ``dispatcher`` compiled (or loaded) for ``argument_types``, as a
    value a kernel takes as an argument of type :func:`function_type` and calls through its
    address: the kernel is then compiled once for every function of that type, and a
    function's code is compiled on its own, not again inside each kernel calling it."""
    return _numba.first_class(dispatcher, argument_types)


__all__ = [
    "FASTMATH",
    "array_type",
    "compile_for",
    "empty",
    "exact_jit",
    "first_class_function",
    "flat",
    "function_type",
    "inline_jit",
    "jit",
    "prefetch",
    "scalar_type",
    "select",
    "step_jit",
    "type_of",
    "vector_bits",
    "vector_jit",
    "vector_width_hint",
    "without_runtime",
]
