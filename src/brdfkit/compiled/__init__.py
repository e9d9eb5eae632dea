"""The compiled back end: every model's own array-API code traced, compiled and cached.

:func:`compile` turns a model into a :class:`CompiledBRDF` whose ``eval``, ``pdf`` and
``sample`` run as numba kernels generated from the model's code (no second copy of any
formula); :mod:`~brdfkit.compiled.cache` keeps built kernels on disk;
:mod:`~brdfkit.compiled.structure` splits a model into its structure and parameter values, so
that one kernel serves every parameter set.
"""

from brdfkit.compiled.kernels import (
    CompiledBRDF,
    Kernel,
    compile,
    compile_function,
    eval_chunked,
)

__all__ = [
    "CompiledBRDF",
    "Kernel",
    "compile",
    "compile_function",
    "eval_chunked",
]
