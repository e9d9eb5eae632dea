r"""Straight-line scalar code: the operations of a traced kernel, one line each.

:mod:`brdfkit.compiled.symbolic` traces a model's array code on NumPy *object* arrays whose
elements are scalar symbols (:class:`Sym`) or constants: every array of the trace is its
handful of per-lane scalars (``(1, 3)`` → 3 scalars), so slicing, concatenation,
broadcasting and reductions over the small trailing axes resolve at trace time. The
functions here turn the remaining operations into code: :func:`elementwise` applies a
primitive lane by lane, and the :class:`Emitter` writes one line of scalar code per
operation. It folds constants, shares common subexpressions, and marks what depends on the
model's parameters alone (computed once per call, before the kernel's loop). A ``where``
becomes a branch-free select (:func:`select`), and the inner guard of the models' double
``where`` (:func:`brdfkit._array.safe_div`) is resolved (:func:`_given`), so that a guarded
division compiles to one select.

Primitives map to NumPy expressions that numba compiles (``sqrt``, division, ``min``/``max``
and selects vectorise), to the intrinsics of :mod:`brdfkit.compiled._numba` (``_select``,
``_max``, boolean operators, ``_rsqrt32``) and to :mod:`brdfkit.compiled.scalar_functions`
(float32 ``_sin32``/``_cos32``, ``_erfinv32``/``_erfinv64``); ``erf`` and ``lgamma`` are
``math``'s.

References
----------
.. [1] R. Frostig, M. J. Johnson, C. Leary, "Compiling machine learning programs via
       high-level tracing", SysML 2018 (tracing array code into primitives).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Sym:
    """A per-lane scalar in the generated code: a variable ``name`` of NumPy ``dtype``."""

    name: str
    dtype: np.dtype


# Elementwise primitives: (NumPy function used to fold constants, code template).
UNARY: dict[str, tuple[Callable[..., Any], str]] = {
    "neg": (np.negative, "-{0}"),
    "abs": (np.abs, "np.abs({0})"),
    "sign": (np.sign, "np.sign({0})"),
    "floor": (np.floor, "np.floor({0})"),
    "ceil": (np.ceil, "np.ceil({0})"),
    "sqrt": (np.sqrt, "np.sqrt({0})"),
    "cbrt": (np.cbrt, "np.cbrt({0})"),
    "exp": (np.exp, "np.exp({0})"),
    "exp2": (np.exp2, "np.exp2({0})"),
    "log": (np.log, "np.log({0})"),
    "log1p": (np.log1p, "np.log1p({0})"),
    "expm1": (np.expm1, "np.expm1({0})"),
    "sin": (np.sin, "np.sin({0})"),
    "cos": (np.cos, "np.cos({0})"),
    "tan": (np.tan, "np.tan({0})"),
    "asin": (np.arcsin, "np.arcsin({0})"),
    "acos": (np.arccos, "np.arccos({0})"),
    "atan": (np.arctan, "np.arctan({0})"),
    "sinh": (np.sinh, "np.sinh({0})"),
    "cosh": (np.cosh, "np.cosh({0})"),
    "tanh": (np.tanh, "np.tanh({0})"),
    "is_finite": (np.isfinite, "np.isfinite({0})"),
    "not": (np.logical_not, "_not({0})"),
}
BINARY: dict[str, tuple[Callable[..., Any], str]] = {
    "add": (np.add, "{0} + {1}"),
    "sub": (np.subtract, "{0} - {1}"),
    "mul": (np.multiply, "{0} * {1}"),
    "div": (np.divide, "{0} / {1}"),
    "pow": (np.power, "{0} ** {1}"),
    "max": (np.maximum, "np.maximum({0}, {1})"),
    "min": (np.minimum, "np.minimum({0}, {1})"),
    "atan2": (np.arctan2, "np.arctan2({0}, {1})"),
    "nextafter": (np.nextafter, "np.nextafter({0}, {1})"),
    "eq": (np.equal, "{0} == {1}"),
    "ne": (np.not_equal, "{0} != {1}"),
    "lt": (np.less, "{0} < {1}"),
    "le": (np.less_equal, "{0} <= {1}"),
    "gt": (np.greater, "{0} > {1}"),
    "ge": (np.greater_equal, "{0} >= {1}"),
    "and": (np.logical_and, "_and({0}, {1})"),
    "or": (np.logical_or, "_or({0}, {1})"),
    "xor": (np.logical_xor, "_xor({0}, {1})"),
}
_FLOATBINARY = {"max": "_max({0}, {1})", "min": "_min({0}, {1})"}
"""Templates of the float ``max``/``min``: LLVM's ``maximum``/``minimum``, NaN-propagating as
``np.maximum``/``np.minimum`` (and JAX's), one vector instruction and a NaN fix-up. numba's
own ``np.maximum`` of scalars is a compare-and-select chain that LLVM lowers, under the
kernels' fast-math flags, to integer compares and mask logic."""


class Emitter:
    """Builds straight-line scalar code: constant folding, common-subexpression sharing."""

    def __init__(self) -> None:
        self.lines: list[tuple[str, str, tuple[str, ...]]] = []  # (target, expression, uses)
        self.constants: dict[str, np.generic] = {}
        self._const_names: dict[tuple[str, bytes], str] = {}
        self._memo: dict[tuple[str, tuple[str, ...]], Sym] = {}
        self.definitions: dict[str, tuple[str, tuple[Any, ...]]] = {}  # name: (template, args)
        self.uniform: set[str] = set()  # symbols of the parameters alone: computed once per call

    def ref(self, x: Any) -> str:
        """The code name of a symbol or constant (constants become typed module globals)."""
        if isinstance(x, Sym):
            return x.name
        value = np.asarray(x)[()]
        key = (value.dtype.str, value.tobytes())
        if key not in self._const_names:
            name = f"k{len(self._const_names)}"
            self._const_names[key] = name
            self.constants[name] = value
        return self._const_names[key]

    def emit(self, template: str, args: Sequence[Any], dtype: np.dtype) -> Sym:
        """A new symbol ``template.format(*args)`` cast to ``dtype`` (shared if seen before)."""
        refs = tuple(self.ref(a) for a in args)
        key = (template + "|" + dtype.str, refs)
        if key not in self._memo:
            name = f"t{len(self.lines)}"
            code = template.format(*refs)
            if not _typed_as(template, args, dtype):
                code = f"bool({code})" if dtype == np.bool_ else f"{_cast_name(dtype)}({code})"
            self.lines.append((name, code, refs))
            self._memo[key] = Sym(name, dtype)
            self.definitions[name] = (template, tuple(args))
            if all(not isinstance(a, Sym) or a.name in self.uniform for a in args):
                self.uniform.add(name)
        return self._memo[key]


def _cast_name(dtype: np.dtype) -> str:
    return f"np.{np.dtype(dtype).name}"


_SAME_TYPE = frozenset(
    {"{0} + {1}", "{0} - {1}", "{0} * {1}", "{0} / {1}", "-{0}", "np.sqrt({0})", "_rsqrt32({0})"}
    | set(_FLOATBINARY.values())
)
"""Templates that numba types as their operands' float type when all operands have it."""
_COMPARISONS = frozenset(BINARY[op][1] for op in ("eq", "ne", "lt", "le", "gt", "ge"))
_LOGICAL = frozenset({"_and({0}, {1})", "_or({0}, {1})", "_xor({0}, {1})", "_not({0})"})


def _dtype_of(x: Any) -> np.dtype:
    """The type numba gives ``x`` in the generated code (constants are typed globals)."""
    return x.dtype if isinstance(x, Sym) else np.asarray(x).dtype


def _typed_as(template: str, args: Sequence[Any], dtype: np.dtype) -> bool:
    """Whether numba types ``template`` of ``args`` as ``dtype`` already, so that the cast to
    it would compile to nothing: float arithmetic, square roots and ``_max``/``_min`` of
    operands of that type, a select between two of them, comparisons of operands of one
    type and logic of booleans. The line is then written without it (numba types and lowers
    each cast call: a third of a model kernel's build; the machine code is the same)."""
    types = [_dtype_of(a) for a in args]
    if dtype == np.bool_:
        if template in _COMPARISONS:
            return types[0] == types[1]
        return template in _LOGICAL and all(t == np.bool_ for t in types)
    if dtype.kind != "f":
        return False
    if template == _SELECT:
        return types[0] == np.bool_ and types[1] == types[2] == dtype
    return template in _SAME_TYPE and all(t == dtype for t in types)


def _is_const(x: Any) -> bool:
    return not isinstance(x, Sym)


def elementwise(
    em: Emitter, fold: Callable[..., Any], template: str, args: list[np.ndarray], dtype: np.dtype
) -> np.ndarray:
    """Apply a primitive lane-wise to broadcast object arrays, folding all-constant elements."""
    args = np.broadcast_arrays(*args)
    out = np.empty(args[0].shape, dtype=object)
    for index in np.ndindex(out.shape):
        values = [a[index] for a in args]
        if all(_is_const(v) for v in values):
            with np.errstate(all="ignore"):
                out[index] = np.asarray(fold(*values)).astype(dtype)[()]
        else:
            out[index] = em.emit(template, values, dtype)
    return out


_SELECT = "_select({0}, {2}, {1})"
"""Template of a select: its arguments are ``[predicate, case if false, case if true]``."""


def select(em: Emitter, predicate: Any, cases: list[Any], dtype: np.dtype) -> Any:
    """``cases[predicate]`` for a boolean predicate (JAX's ``select_n``); each case as
    :func:`_given` the predicate's value that picks it."""
    if _is_const(predicate):
        return cases[int(bool(predicate))]
    if not isinstance(cases[0], Sym) and not isinstance(cases[1], Sym):
        if np.asarray(cases[0]).tobytes() == np.asarray(cases[1]).tobytes():
            return cases[0]
    cases = [_given(em, case, predicate, bool(k)) for k, case in enumerate(cases)]
    return em.emit(_SELECT, [predicate, *cases], dtype)


def _given(em: Emitter, x: Any, predicate: Sym, value: bool) -> Any:
    """``x`` in the lanes where ``predicate`` is ``value``, with the selects on ``predicate``
    that are ``x`` or its operands resolved to their case there.

    The same values in those lanes, which are the only ones a select on ``predicate`` keeps of
    ``x`` (the kernels' operations are pure and do not trap). It undoes the inner guard of the
    models' double ``where`` (:func:`brdfkit._array.safe_div`, ``safe_sqrt``: a guarded
    operand for the gradient, then the guarded result): ``where(b != 0, a / where(b != 0, b,
    1), 0)`` compiles as ``where(b != 0, a / b, 0)``, one select instead of two.
    """

    def resolved(a: Any) -> Any:
        template, args = em.definitions.get(a.name, ("", ())) if isinstance(a, Sym) else ("", ())
        if template == _SELECT and args[0].name == predicate.name:
            return args[1 + value]
        return a

    case = resolved(x)
    if case is not x:
        return case
    if not isinstance(x, Sym) or x.name not in em.definitions:
        return x
    template, args = em.definitions[x.name]
    operands = [resolved(a) for a in args]
    if all(a is b for a, b in zip(operands, args, strict=True)):
        return x
    return em.emit(template, operands, x.dtype)


def binary_rule(op: str, dtype: np.dtype) -> tuple[Callable[..., Any], str]:
    """The constant fold and code template of the binary primitive ``op`` on ``dtype``."""
    fold, template = BINARY[op]
    if op in _FLOATBINARY and np.dtype(dtype).kind == "f":
        template = _FLOATBINARY[op]
    return fold, template


def reduce(em: Emitter, x: np.ndarray, axes: tuple[int, ...], op: str, dtype: Any) -> np.ndarray:
    fold, template = binary_rule(op, dtype)
    keep = [a for a in range(x.ndim) if a not in axes]
    moved = np.transpose(x, keep + list(axes))
    flat = moved.reshape(*moved.shape[: len(keep)], -1)
    out = np.empty(flat.shape[:-1], dtype=object)
    for index in np.ndindex(out.shape):
        items = list(flat[index])
        total = items[0]
        for item in items[1:]:
            pair = [np.array(total, dtype=object), np.array(item, dtype=object)]
            total = elementwise(em, fold, template, pair, dtype)[()]
        out[index] = total
    return out


def constant_elements(value: Any) -> np.ndarray:
    """``value`` (a NumPy array) as an object array of its NumPy scalars."""
    arr = np.asarray(value)
    out = np.empty(arr.shape, dtype=object)
    for index in np.ndindex(arr.shape):
        out[index] = arr[index]
    return out


def convert(em: Emitter, x: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """The elements ``x`` converted to ``dtype`` (constants folded)."""
    return elementwise(em, lambda v: v, "{0}", [x], dtype)


def divide(em: Emitter, x: np.ndarray, y: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """``x / y``; by a divisor computed once per call (of the parameters alone), as ``x``
    times its reciprocal. A constant divisor becomes that under LLVM's reciprocal fast-math
    flag already, in every copy of the loop alike; a per-call one would too, but LLVM may
    then do it in the vectorised loop and not in its scalar remainder, and a pixel's value
    would depend on its place in the batch."""
    x, y = np.broadcast_arrays(x, y)
    out = np.empty(x.shape, dtype=object)
    fold, template = BINARY["div"]
    one = np.ones((), dtype=dtype)
    for index in np.ndindex(out.shape):
        a, b = x[index], y[index]
        per_call = isinstance(b, Sym) and b.name in em.uniform
        floored = None if per_call else _floored_square(em, b)
        if per_call and not (_is_const(a) or a.name in em.uniform):
            reciprocal = em.emit(template, [one, b], dtype)
            out[index] = em.emit(BINARY["mul"][1], [a, reciprocal], dtype)
        elif floored is not None:
            reciprocal = em.emit("_rsqrt32({0})", [floored], dtype)
            mul = BINARY["mul"]
            out[index] = elementwise(em, *mul, [np.array(a), np.array(reciprocal)], dtype)[()]
        else:
            out[index] = elementwise(em, fold, template, [np.array(a), np.array(b)], dtype)[()]
    return out


def _floored_square(em: Emitter, b: Any) -> Sym | None:
    """``m`` where the float32 divisor ``b`` is ``sqrt(m)`` with ``m = max(z, c)`` for a
    constant ``c`` at least float32's smallest normal number (as :func:`brdfkit._array.normalize`
    has it), else ``None``.

    A division by such a root becomes a multiplication by ``_rsqrt32(m)``, which LLVM computes
    as a reciprocal-square-root estimate and one Newton step (``rsqrt14`` on AVX-512: what
    Mitsuba 3 does for its normalisations) instead of a square root and a division; ``m`` is
    positive and normal, so the estimate's exceptional cases (0, subnormals) never arise.
    Within 2 ulp of the exact quotient; the last bit may depend on the width of the vector
    code that computes an element (main loop or remainder). float64 keeps the exact root."""
    if not isinstance(b, Sym) or b.dtype != np.float32:
        return None
    template, args = em.definitions.get(b.name, ("", ()))
    if template != UNARY["sqrt"][1] or not isinstance(args[0], Sym):
        return None
    template, args = em.definitions.get(args[0].name, ("", ()))
    if template != _FLOATBINARY["max"]:
        return None
    floors = [float(v) for v in args if _is_const(v)]
    if len(floors) != 1 or not np.finfo(np.float32).tiny <= floors[0] < np.inf:
        return None
    return em.emit(_FLOATBINARY["max"], list(args), np.dtype(np.float32))


def integer_power(em: Emitter, x: np.ndarray, y: int, dtype: np.dtype) -> np.ndarray:
    """``x**y`` for an integer ``y`` by repeated squaring (as XLA does)."""
    mul = BINARY["mul"]
    result = None
    base = x
    for bit in bin(abs(y))[:1:-1]:
        if bit == "1":
            result = base if result is None else elementwise(em, *mul, [result, base], dtype)
        base = elementwise(em, *mul, [base, base], dtype)
    if result is None:
        result = constant_elements(np.ones(x.shape, dtype=dtype))
    if y < 0:
        one = constant_elements(np.ones((), dtype=dtype))
        result = elementwise(em, *BINARY["div"], [one, result], dtype)
    return result


__all__ = [
    "BINARY",
    "UNARY",
    "Emitter",
    "Sym",
    "binary_rule",
    "constant_elements",
    "convert",
    "divide",
    "elementwise",
    "integer_power",
    "reduce",
    "select",
]
