r"""The compiled back end: every model's own array-API code traced, compiled and cached.

Rendering, albedo tables and fitting evaluate a BRDF hundreds of millions of times. Array code
on NumPy runs one operation at a time over the whole batch: every intermediate is a full-size
array written to and read back from memory, and only one core works. :func:`compile` turns the
*same* model code into compiled per-element kernels instead, with no second copy of any
formula:

1. **Trace** (:mod:`~brdfkit.compiled.codegen`). The model method (``eval``, ``pdf``,
   ``sample``) is run once on symbolic arrays (:mod:`~brdfkit.compiled.symbolic`) of a batch
   of *one* direction pair (the models are written against the array API, so they run on the
   tracer's namespace unchanged). Its numeric parameters enter the trace as inputs: the
   model is rebuilt on abstract values of their shapes (:mod:`~brdfkit.compiled.structure`),
   so the kernel depends on the model's structure alone.
2. **Scalarise** (:mod:`~brdfkit.compiled.scalar_code`). Each array of the trace is its
   per-lane scalar symbols: small trailing axes resolve at compile time, constants fold, common
   subexpressions are shared, and what remains is straight-line, branch-free scalar code.
3. **Compile** (:mod:`~brdfkit.compiled.kernel`). That code is the body of a numba loop over
   the batch, which LLVM vectorises across elements with two vectors in flight; blocks of the
   batch run on a thread pool (:mod:`~brdfkit.compiled.thread_pool`). Kernels are kept per
   model structure and dtype in the process and on disk (:mod:`~brdfkit.compiled.cache`): a
   new parameter set costs neither tracing nor compiling.

A method qualifies when it is elementwise over the batch (every protocol method is) and its
parameters do not vary over the batch; a texture is rejected with a ``ValueError``:
:func:`eval_chunked` (:mod:`~brdfkit.compiled.chunked`) evaluates it with NumPy in bounded
memory. ``sqrt``, division, ``min``/``max`` and selects vectorise; so do ``sin`` and ``cos``
in float32 kernels (:mod:`~brdfkit.compiled.scalar_functions`); other transcendentals are
scalar libm calls.

What tracing cannot express (table lookups, CDF searches, a tile's sampling loop) is written
for numba by hand beside the code it mirrors, from :mod:`~brdfkit.compiled.kernel_tools`.
Every use of numba's internals (and of the LLVM binding under it) is in one module,
``compiled/_numba.py``.

References
----------
.. [1] R. Frostig, M. J. Johnson, C. Leary, "Compiling machine learning programs via
       high-level tracing", SysML 2018 (tracing array code into primitives).
.. [2] S. K. Lam, A. Pitrou, S. Seibert, "Numba: a LLVM-based Python JIT compiler", LLVM-HPC
       2015.
.. [3] W. Jakob, S. Speierer, N. Roussel, D. Vicini, "Dr.Jit: a just-in-time compiler for
       differentiable rendering", ACM TOG 41(4), 2022 (the same trace-then-compile idea).
"""

from brdfkit.compiled.chunked import DEFAULT_CHUNK, eval_chunked
from brdfkit.compiled.compiled_brdf import CompiledBRDF, compile
from brdfkit.compiled.kernel import Kernel, compile_function
from brdfkit.compiled.thread_pool import threads

__all__ = [
    "DEFAULT_CHUNK",
    "CompiledBRDF",
    "Kernel",
    "compile",
    "compile_function",
    "eval_chunked",
    "threads",
]
