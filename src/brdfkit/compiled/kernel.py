r"""A compiled per-element kernel: one generated function, compiled once, run on all cores.

:func:`compile_function` turns an elementwise array-API function into a :class:`Kernel`:
the function's source is generated (:mod:`brdfkit.compiled.codegen`), compiled by numba with
the kernels' fast-math flags and vector width (:mod:`brdfkit.compiled.jit`), its loop
interleaved :data:`INTERLEAVE` times, and its machine code kept in this process and on disk
(:mod:`brdfkit.compiled.cache`) under a key of everything it depends on. A kernel call splits
the batch into blocks run on the kernels' threads (:func:`brdfkit.compiled.thread_pool.run_blocks`;
the kernels release the GIL) and returns arrays from the output pool
(:mod:`brdfkit.compiled.output_pool`).

References
----------
.. [1] S. K. Lam, A. Pitrou, S. Seibert, "Numba: a LLVM-based Python JIT compiler", LLVM-HPC
       2015.
"""

from __future__ import annotations

import builtins
import math
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from brdfkit.compiled import _numba
from brdfkit.compiled import cache as kernel_cache
from brdfkit.compiled.codegen import Generated, Port, by_component_source, generate
from brdfkit.compiled.jit import FASTMATH, compile_for, vector_bits
from brdfkit.compiled.output_pool import OUTPUTS
from brdfkit.compiled.scalar_functions import generated_code_functions
from brdfkit.compiled.thread_pool import run_blocks

INTERLEAVE = 2
"""Vector iterations that LLVM's loop vectoriser interleaves in each kernel's loop (its own
cost model picks 1 for these long bodies, whose registers it finds taken).

The body is one long chain of dependent operations per element (square roots and divisions
among them); two independent vectors in flight let the core overlap their latencies. The
main loop's values are bit for bit the same as without (each element gets the same
operations). LLVM then also vectorises the remainder of a batch (its last ``2 × lanes − 1``
elements at most; none for the render tile kernels' blocks of 256) at 4 lanes, down to 3
scalar elements, so those elements get the main loop's values where scalar and vector code
would round differently."""

RECORDS = "kernel"
"""The :mod:`brdfkit.compiled.cache` record kind of generated kernels' sources."""

_KERNELS: dict[str, Callable[..., None]] = {}
_KERNELS_LOCK = threading.Lock()


class Kernel:
    """A compiled per-element function of arrays ``(n, width)`` (or ``(n,)``).

    Built by :func:`compile_function`; call it with arrays whose leading (batch) axes
    broadcast. Attributes: ``source`` (the generated Python), ``compile_seconds``,
    ``parameters`` (the values of the model parameters the kernel reads at each call; empty
    for a plain function, :meth:`bind` gives the same compiled code other values) and
    ``function``, the numba function itself, which other numba code may call as
    ``function(parameters, *inputs, *outputs, n)`` on flat buffers of ``n`` elements.
    """

    def __init__(
        self,
        function: Callable[..., None],
        source: str,
        ins: list[Port],
        outs: list[Port],
        parameters: np.ndarray | None = None,
        constants: dict[str, np.generic] | None = None,
    ) -> None:
        self.function = function
        self.source = source
        self.inputs = ins
        self.outputs = outs
        dtype = ins[0].dtype if ins else np.dtype(np.float64)
        self.parameters = np.zeros(0, dtype) if parameters is None else parameters
        self.compile_seconds = 0.0
        self._constants = {} if constants is None else constants
        self._by_component: list[Callable[..., None]] = []  # its code, once built; shared

    def bind(self, values: np.ndarray) -> Kernel:
        """This kernel's compiled code with parameter values ``values`` (flat, in order)."""
        values = np.ascontiguousarray(values, dtype=self.parameters.dtype).reshape(-1)
        if values.shape != self.parameters.shape:
            raise ValueError(
                f"values must hold {self.parameters.size} parameters; got {values.size}"
            )
        kernel = Kernel(
            self.function, self.source, self.inputs, self.outputs, values, self._constants
        )
        kernel._by_component = self._by_component
        return kernel

    def _component_code(self) -> Callable[..., None]:
        """The compiled code for arrays laid out component by component (see
        :func:`by_component_source`), built on the first such call."""
        if not self._by_component:
            source = by_component_source(self.source, self.inputs, self.outputs)
            self._by_component.append(numba_kernel(source, self._constants))
        return self._by_component[0]

    def _laid_out_by_component(
        self, arrays: list[np.ndarray], shape: tuple[int, ...], out: Sequence[np.ndarray] | None
    ) -> bool:
        """Whether every array of the call is laid out component by component: a vector
        port's ``(n, width)`` array Fortran-ordered (the transpose of a C-ordered
        ``(width, n)`` one, as ``np.asfortranarray`` gives), a scalar port's ``(n,)``
        contiguous, all of the port's dtype and the batch's shape (no broadcasting)."""
        if len(shape) != 1 or shape[0] < 2 or not any(p.width for p in self.inputs):
            return False
        ports = list(zip(arrays, self.inputs, strict=True))
        if out is not None:
            ports += list(zip(out, self.outputs, strict=True))
        for a, port in ports:
            full = (*shape, port.width) if port.width else shape
            layout = a.flags.f_contiguous if port.width else a.flags.c_contiguous
            if a.shape != full or a.dtype != port.dtype or not layout:
                return False
        return True

    def _call_by_component(
        self, arrays: list[np.ndarray], n: int, out: Sequence[np.ndarray] | None
    ) -> tuple[np.ndarray, ...]:
        """:meth:`__call__` on arrays laid out component by component; the results are too."""
        if out is None:
            # a (width, n) buffer's transpose (a scalar port's (n,) is its own)
            shapes = [(p.width, n) if p.width else (n,) for p in self.outputs]
            outs = [OUTPUTS.empty(s, p.dtype).T for s, p in zip(shapes, self.outputs, strict=True)]
        else:
            outs = list(out)
        ports = [*self.inputs, *self.outputs]
        columns = [
            _writable(a[:, c] if p.width else a)
            for a, p in zip([*arrays, *outs], ports, strict=True)
            for c in range(max(p.width, 1))
        ]
        run_blocks(self._component_code(), self.parameters, columns, [0] * len(columns), n)
        return tuple(outs)

    def __call__(
        self, *arrays: Any, out: Sequence[np.ndarray] | None = None
    ) -> tuple[np.ndarray, ...]:
        """Evaluate over the broadcast batch; returns one array per output.

        ``out`` (one C-contiguous array per output, of the result's shape and dtype) receives
        the results instead of new arrays: reusing it saves the allocation and, for large
        batches, the page faults of touching fresh memory.

        Arrays of one batch axis laid out component by component (``(n, 3)`` directions as
        ``np.asfortranarray`` has them: all x, then all y, then all z) are read in place by
        code built for that layout on the first such call, whose results (and ``out``, if
        given: laid out so too) are laid out the same way. The kernel then needs no
        shuffles to gather each component's lanes (faster; the same values bit for bit).
        """
        if len(arrays) != len(self.inputs):
            raise ValueError(f"arrays must be {len(self.inputs)} arrays; got {len(arrays)}")
        flat, batch = [], []
        for k, (a, port) in enumerate(zip(arrays, self.inputs, strict=True)):
            a = np.asarray(a)
            if port.width and (a.ndim == 0 or a.shape[-1] != port.width):
                raise ValueError(
                    f"argument {k} must have a last axis of length {port.width}; "
                    f"got shape {a.shape}"
                )
            batch.append(a.shape[:-1] if port.width else a.shape)
            flat.append(a)
        # one batch shape for all (the common case) needs no broadcasting: NumPy's
        # broadcast_shapes costs more than the rest of a call's Python together
        shape = batch[0] if batch.count(batch[0]) == len(batch) else np.broadcast_shapes(*batch)
        n = math.prod(shape)
        if self._laid_out_by_component(flat, shape, out):
            return self._call_by_component(flat, n, out)
        for k, (a, port) in enumerate(zip(flat, self.inputs, strict=True)):
            full = (*shape, port.width) if port.width else shape
            a = np.broadcast_to(a, full) if a.shape != full else a
            flat[k] = _writable(np.ascontiguousarray(a, dtype=port.dtype).reshape(-1))
        shapes = [(*shape, port.width) if port.width else shape for port in self.outputs]
        if out is None:
            outs = [OUTPUTS.empty(s, p.dtype) for s, p in zip(shapes, self.outputs, strict=True)]
        else:
            outs = list(out)
            for k, (o, s, p) in enumerate(zip(outs, shapes, self.outputs, strict=True)):
                if o.shape != s or o.dtype != p.dtype or not o.flags.c_contiguous:
                    raise ValueError(
                        f"out[{k}] must be a C-contiguous array of shape {s} and dtype "
                        f"{p.dtype}; got shape {o.shape}, dtype {o.dtype}"
                    )
        widths = [p.width for p in (*self.inputs, *self.outputs)]
        arrays_flat = [*flat, *(o.reshape(-1) for o in outs)]
        run_blocks(self.function, self.parameters, arrays_flat, widths, n)
        return tuple(outs)


def _writable(a: np.ndarray) -> np.ndarray:
    """``a``, or a copy where it is read-only (a broadcast view that is contiguous, a frozen
    array): numba compiles a kernel once per argument type, and a read-only array is
    another type, so one read-only input would compile the whole kernel a second time."""
    return a if a.flags.writeable else a.copy()


def compile_function(
    fn: Callable[..., Any], widths: Sequence[int], dtype: Any = np.float32
) -> Kernel:
    """Compile the elementwise array-API function ``fn`` to a parallel, vectorised kernel.

    ``fn`` takes arrays of shape ``(..., w)`` for each ``w`` in ``widths`` (``w = 0``: shape
    ``(...,)``) and returns an array or a tuple of arrays with the batch as leading axes. It is
    traced once on a batch of one, scalarised and compiled with numba
    (:mod:`brdfkit.compiled.codegen`); the kernel reproduces ``fn`` on any batch size.

    Raises
    ------
    ValueError
        When an output does not follow the batch (a parameter varying over the batch), or
        ``fn`` uses an array function the tracer does not know.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.compiled import compile_function
    >>> half_z = compile_function(lambda w: w[..., 2] * 0.5, (3,))
    >>> half_z(np.array([[0.0, 0.6, 0.8]], np.float32))[0]
    array([0.4], dtype=float32)
    """
    return compile_traced(fn, widths, dtype, ())


def compile_traced(
    fn: Callable[..., Any],
    widths: Sequence[int],
    dtype: Any,
    parameter_shapes: Sequence[tuple[int, ...]],
    record: str | None = None,
) -> Kernel:
    """:func:`compile_function` of ``fn(*parameters, *inputs)``, whose leading arguments are
    parameters of the given shapes (not batched): the kernel reads their values, flattened in
    order, from its parameter array at each call (:meth:`Kernel.bind`), and computes what
    depends on them alone once per call, before its loop. With ``record`` (a key naming
    everything ``fn``'s trace depends on), the generated source is kept on disk
    (:mod:`brdfkit.compiled.cache`) and a later process skips the trace."""
    dtype = np.dtype(dtype)
    if dtype not in (np.float32, np.float64):
        raise ValueError(f"dtype must be float32 or float64; got {dtype}")
    stored = None if record is None else kernel_cache.load_record(RECORDS, record)
    if stored is not None:
        try:
            generated = Generated.from_record(stored)
        except (KeyError, TypeError, ValueError):  # a record of another form: trace again
            generated = None
        if generated is not None:
            return _warm(generated, dtype)
    generated = generate(fn, widths, dtype, parameter_shapes)
    if record is not None:
        kernel_cache.store_record(RECORDS, record, generated.to_record())
    return _warm(generated, dtype)


def _warm(generated: Generated, dtype: np.dtype) -> Kernel:
    """The kernel of ``generated``, compiled now (numba compiles on first call) rather than
    in the user's timing, or loaded from the disk cache: for the flat buffers its calls pass
    (:func:`~brdfkit.compiled.jit.compile_for`), then called once on one element."""
    start = time.perf_counter()
    function = numba_kernel(generated.source, generated.constants)
    kernel = Kernel(
        function,
        generated.source,
        generated.inputs,
        generated.outputs,
        np.zeros(generated.parameters, dtype),
        generated.constants,
    )
    ports = [*generated.inputs, *generated.outputs]
    compile_for(function, kernel.parameters, *(np.zeros(1, p.dtype) for p in ports), 1)
    kernel(*[np.zeros((1, p.width) if p.width else (1,), p.dtype) for p in generated.inputs])
    kernel.compile_seconds = time.perf_counter() - start
    return kernel


def machine_code_cached(record: dict[str, Any]) -> bool:
    """Whether the kernel that a :meth:`Generated.to_record` record describes has machine
    code on disk (loading it compiles nothing); ``False`` for a record of another form."""
    try:
        generated = Generated.from_record(record)
    except (KeyError, TypeError, ValueError):
        return False
    return kernel_cache.has(_disk_key(generated.source, generated.constants))


def _kernel_key(source: str, constants: dict[str, np.generic]) -> str:
    """What a generated kernel's machine code depends on: source, constants, vector width."""
    return f"{vector_bits()}|{source}" + repr(
        sorted((k, v.dtype.str, v.tobytes()) for k, v in constants.items())
    )


def _disk_key(source: str, constants: dict[str, np.generic]) -> str:
    """The :mod:`brdfkit.compiled.cache` key of a generated kernel's machine code."""
    return kernel_cache.key("kernel", _kernel_key(source, constants))


def numba_kernel(source: str, constants: dict[str, np.generic]) -> Callable[..., None]:
    """The numba function of a generated kernel ``source`` reading ``constants`` as globals:
    compiled with the :data:`~brdfkit.compiled.jit.FASTMATH` flags, :data:`INTERLEAVE` and
    the disk cache, or fetched from this process's kernels."""
    numba = _numba.numba_module()

    bits = vector_bits()
    key = _kernel_key(source, constants)
    with _KERNELS_LOCK:
        if key in _KERNELS:
            return _KERNELS[key]
        namespace: dict[str, Any] = {
            "__name__": __name__,  # the module numba's cache re-imports for the globals
            "np": np,
            "math": math,
            **_numba.intrinsics(),
            "_prefer_vector_width": _numba.vector_width_hint(bits),
            **constants,
            **generated_code_functions(source),
        }
        exec(builtins.compile(source, "<brdfkit.compiled kernel>", "exec"), namespace)
        function = numba.njit(fastmath=set(FASTMATH), error_model="numpy", nogil=True)(
            namespace["kernel"]
        )
        _numba.compile_interleaved(function, INTERLEAVE)
        kernel_cache.enable(function, _disk_key(source, constants))  # machine code on disk
        _KERNELS[key] = function
        return function


__all__ = [
    "INTERLEAVE",
    "RECORDS",
    "Kernel",
    "compile_function",
    "compile_traced",
    "machine_code_cached",
    "numba_kernel",
]
