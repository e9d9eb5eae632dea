r"""A traced function written out as the Python source of a numba kernel.

:func:`generate` runs the function once on symbolic arrays (:mod:`brdfkit.compiled.symbolic`)
of a batch of *one* (``(1, w)`` per input of width ``w``; the models are written against the
array API, so they run on the tracer's namespace unchanged), whose operations write
straight-line scalar code (:mod:`brdfkit.compiled.scalar_code`), and checks that every output
follows the batch (a batch of two gives ``(2, ...)``). The result is the source of one
function

.. code-block:: python

    def kernel(prm, in0, in1, out0, n):
        _prefer_vector_width()
        p0 = prm[0]                    # the parameters, and what depends on them alone
        t3 = p0 * k1
        for i in range(n):             # the batch
            a0_0 = in0[i * 3 + 0]      # loads
            t7 = a0_0 * t3             # the live straight-line body
            out0[i * 3 + 0] = t7       # stores

over flat buffers holding ``max(w, 1)`` values per element (a line casts its value, e.g.
``np.float32(...)``, only where numba would type it otherwise), which numba compiles and LLVM
vectorises across the loop's iterations; :func:`by_component_source` rewrites it for arrays
laid out component by component. The parameters of a model are inputs, not constants, so
one source serves every parameter set of a model's structure.

References
----------
.. [1] R. Frostig, M. J. Johnson, C. Leary, "Compiling machine learning programs via
       high-level tracing", SysML 2018 (tracing array code into primitives).
.. [2] W. Jakob, S. Speierer, N. Roussel, D. Vicini, "Dr.Jit: a just-in-time compiler for
       differentiable rendering", ACM TOG 41(4), 2022 (the same trace-then-compile idea).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit.compiled.scalar_code import Emitter
from brdfkit.compiled.symbolic import UNSUPPORTED, SymbolicArray, trace

BATCH_ONLY = (
    "brdfkit.compiled compiles functions that are elementwise over the batch, with parameters "
    "that do not vary over it (a texture does): use brdfkit.compiled.eval_chunked for those"
)


@dataclass(frozen=True)
class Port:
    """One input or output of a kernel: per-element width (0 for a scalar) and dtype."""

    width: int
    dtype: np.dtype


@dataclass(frozen=True, eq=False)
class Generated:
    """A generated kernel: its ``source``, the ``constants`` it reads as globals, its input
    and output ports and the number of ``parameters`` it reads from ``prm``."""

    source: str
    constants: dict[str, np.generic]
    inputs: list[Port]
    outputs: list[Port]
    parameters: int

    def to_record(self) -> dict[str, Any]:
        """The kernel as JSON (constants as their exact bytes)."""
        return {
            "source": self.source,
            "constants": [[k, v.dtype.str, v.tobytes().hex()] for k, v in self.constants.items()],
            "ins": [[p.width, p.dtype.str] for p in self.inputs],
            "outs": [[p.width, p.dtype.str] for p in self.outputs],
            "parameters": self.parameters,
        }

    @classmethod
    def from_record(cls, record: dict[str, Any]) -> Generated:
        """:meth:`to_record`'s inverse.

        Raises
        ------
        KeyError, TypeError, ValueError
            For a record of another form.
        """
        constants = {
            name: np.frombuffer(bytes.fromhex(data), dtype=np.dtype(code))[0]
            for name, code, data in record["constants"]
        }
        ins = [Port(int(w), np.dtype(d)) for w, d in record["ins"]]
        outs = [Port(int(w), np.dtype(d)) for w, d in record["outs"]]
        return cls(str(record["source"]), constants, ins, outs, int(record["parameters"]))


def generate(
    fn: Callable[..., Any],
    widths: Sequence[int],
    dtype: np.dtype,
    parameter_shapes: Sequence[tuple[int, ...]],
) -> Generated:
    """The kernel of ``fn(*parameters, *inputs)``: parameters of ``parameter_shapes`` (read
    from ``prm``, flattened in order), inputs of ``widths``, all of ``dtype``.

    Raises
    ------
    ValueError
        When ``fn`` cannot be traced on a batch of one, an output does not follow the batch
        (a parameter varying over it), or ``fn`` uses an array function without a scalar
        form.
    """
    dtype = np.dtype(dtype)
    shapes = [tuple(s) for s in parameter_shapes]
    names = [[f"p{k}" for k in range(math.prod(s))] for s in shapes]
    offsets = np.cumsum([0] + [len(n) for n in names])
    names = [[f"p{offsets[j] + k}" for k in range(len(n))] for j, n in enumerate(names)]
    uniform_loads = [(name, f"prm[{k}]") for k, name in enumerate(itertools.chain(*names))]
    ins = [Port(w, dtype) for w in widths]
    loads = []
    for j, port in enumerate(ins):
        names.append([f"a{j}_{c}" for c in range(max(port.width, 1))])
        for c, name in enumerate(names[-1]):
            loads.append((name, f"in{j}[i * {port.width} + {c}]" if port.width else f"in{j}[i]"))
    em, results = _trace(fn, widths, dtype, shapes, names, [n for n, _ in uniform_loads])
    outs = [Port(r.shape[1] if r.ndim == 2 else 0, r.dtype) for r in results]
    elements = [r.elements for r in results]
    source = _source(em, uniform_loads, loads, elements, outs, len(ins))
    return Generated(source, em.constants, ins, outs, len(uniform_loads))


def _batched(widths: Sequence[int], batch: int) -> list[tuple[int, ...]]:
    return [(batch, w) if w else (batch,) for w in widths]


def _trace(
    fn: Callable[..., Any],
    widths: Sequence[int],
    dtype: np.dtype,
    parameter_shapes: list[tuple[int, ...]],
    names: list[list[str]],
    uniform: list[str],
) -> tuple[Emitter, list[SymbolicArray]]:
    """The trace of ``fn`` on a batch of one, its outputs checked to follow the batch (a
    batch of two gives ``(2, ...)``)."""
    try:
        em, results = trace(fn, dtype, parameter_shapes + _batched(widths, 1), names, uniform)
        wider = trace(fn, dtype, parameter_shapes + _batched(widths, 2))[1]
    except (ValueError, TypeError) as error:
        if UNSUPPORTED in str(error):
            raise
        raise ValueError(
            f"the function could not be traced on a batch of one ({error}); {BATCH_ONLY}"
        ) from error
    for k, (one, two) in enumerate(zip(results, wider, strict=True)):
        ok = one.ndim in (1, 2) and one.shape[0] == 1 and two.shape == (2, *one.shape[1:])
        if not ok:
            raise ValueError(
                f"output {k} of the traced function has shape {one.shape} for a batch of one "
                f"and does not follow the batch; {BATCH_ONLY}"
            )
    return em, results


def _source(
    em: Emitter,
    uniform_loads: list[tuple[str, str]],
    loads: list[tuple[str, str]],
    results: list[np.ndarray],
    outs: list[Port],
    n_inputs: int,
) -> str:
    """The kernel's Python source: the parameters and what depends on them alone, then the
    loop of loads, the live straight-line body and stores."""
    stores = []
    for j, (r, port) in enumerate(zip(results, outs, strict=True)):
        for c, value in enumerate(r.reshape(-1)):
            index = f"i * {port.width} + {c}" if port.width else "i"
            stores.append((f"out{j}[{index}]", em.ref(value)))
    live = {ref for _, ref in stores}
    body = []
    for target, code, uses in reversed(em.lines):
        if target in live:
            body.append((target, code))
            live.update(uses)
    body.reverse()
    params = ["prm"] + [f"in{j}" for j in range(n_inputs)] + [f"out{j}" for j in range(len(outs))]
    lines = [f"def kernel({', '.join(params)}, n):", "    _prefer_vector_width()"]
    lines += [f"    {name} = {code}" for name, code in uniform_loads if name in live]
    lines += [f"    {target} = {code}" for target, code in body if target in em.uniform]
    lines.append("    for i in range(n):")
    lines += [f"        {name} = {code}" for name, code in loads if name in live]
    lines += [f"        {target} = {code}" for target, code in body if target not in em.uniform]
    lines += [f"        {target} = {ref}" for target, ref in stores]
    return "\n".join(lines) + "\n"


def by_component_source(source: str, ins: list[Port], outs: list[Port]) -> str:
    """The kernel ``source`` of :func:`_source` for arrays laid out component by component:
    each component of a vector port is an array of its own (``in0[i * 3 + 1]`` becomes
    ``in0_1[i]``), so that LLVM loads and stores whole vectors of one component."""

    def names(kind: str, j: int, port: Port) -> list[str]:
        return [f"{kind}{j}_{c}" for c in range(port.width)] if port.width else [f"{kind}{j}"]

    params = ["prm"]
    params += [name for j, p in enumerate(ins) for name in names("in", j, p)]
    params += [name for j, p in enumerate(outs) for name in names("out", j, p)]
    body = source.split("\n", 1)[1]
    body = re.sub(r"\b(in|out)(\d+)\[i \* \d+ \+ (\d+)\]", r"\1\2_\3[i]", body)
    return f"def kernel({', '.join(params)}, n):\n{body}"


__all__ = ["BATCH_ONLY", "Generated", "Port", "by_component_source", "generate"]
