r"""Array code traced on scalar symbols: the array-API namespace of the compiled path.

The models compute through the array-API namespace of their inputs
(:func:`brdfkit._array.namespace`). :func:`trace` runs such a function once on
:class:`SymbolicArray` inputs on a batch of *one*, whose namespace is a
:class:`SymbolicNamespace`: an array is a NumPy *object* array of its per-lane scalars, each a
scalar symbol (:class:`~brdfkit.compiled.scalar_code.Sym`) or a constant, so a ``(1, 3)``
direction is three scalars. Slicing, stacking, broadcasting and reductions over the small
trailing axes resolve at trace time; every arithmetic operation writes one line of scalar code
through the :class:`~brdfkit.compiled.scalar_code.Emitter` (constants folded, common
subexpressions shared, selects resolved), which :mod:`brdfkit.compiled.codegen` makes the body
of a kernel's loop.

The namespace implements the subset of the array API standard the models use, with JAX's
rules for the values a trace cannot see: Python scalars take the dtype of the arrays they meet
("weak" types), and a float32 trace computes every float in float32 (as JAX does without
64-bit mode, which the compiled path's float32 kernels were first traced under). Anything that
needs a value the trace does not have (``if`` or ``bool()`` on a traced comparison, ``float()``,
``np.asarray``, an index computed from the data) raises :class:`TraceError`; a function the
namespace does not have raises ``ValueError`` naming it.

References
----------
.. [1] Python array API standard, https://data-apis.org/array-api/
.. [2] R. Frostig, M. J. Johnson, C. Leary, "Compiling machine learning programs via
       high-level tracing", SysML 2018 (tracing array code on abstract values; JAX's type
       promotion and weak types).

Examples
--------
>>> import numpy as np
>>> from brdfkit._array import namespace
>>> def half_z(w):
...     xp = namespace(w)
...     return xp.maximum(w[..., 2], 0.0) * 0.5
>>> em, (out,) = trace(half_z, np.float32, [(1, 3)])
>>> out.shape, out.dtype
((1,), dtype('float32'))
>>> em.lines[-1][1]
't0 * k1'
"""

from __future__ import annotations

import builtins
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from brdfkit._array import NUMPY_NAMESPACE
from brdfkit.compiled.scalar_code import (
    BINARY,
    UNARY,
    Emitter,
    Sym,
    binary_rule,
    constant_elements,
    convert,
    divide,
    elementwise,
    integer_power,
    reduce,
    select,
)

UNSUPPORTED = "use brdfkit.compiled.eval_chunked (NumPy) for this model"

NOT_CONCRETE = (
    "a traced array has no value while brdfkit.compiled traces a function: Python control "
    "flow on array values (if, bool(), float(), np.asarray) cannot be compiled; write it "
    "with where()"
)


class TraceError(TypeError):
    """A traced array used where its value is needed (:data:`NOT_CONCRETE`)."""


class SymbolicArray:
    """An array of per-lane scalar symbols and constants (``elements``, an object array)
    of one ``dtype``; ``weak`` when it came from a Python scalar (it then takes the dtype of
    the arrays it meets)."""

    __array_ufunc__ = None  # NumPy defers its operators to ours
    abstract = True
    """Read by :func:`brdfkit._array.is_abstract`: value checks are skipped while tracing."""

    def __init__(
        self, space: SymbolicNamespace, elements: np.ndarray, dtype: Any, weak: bool = False
    ) -> None:
        self.space = space
        self.elements = elements
        self.dtype = np.dtype(dtype)
        self.weak = weak

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(self.elements.shape)

    @property
    def ndim(self) -> int:
        return self.elements.ndim

    @property
    def size(self) -> int:
        return int(self.elements.size)

    @property
    def device(self) -> str:
        return "cpu"

    def __array_namespace__(self, *, api_version: str | None = None) -> SymbolicNamespace:
        return self.space

    def to_device(self, device: Any, /, *, stream: Any = None) -> SymbolicArray:
        return self

    def __repr__(self) -> str:
        return f"SymbolicArray(shape={self.shape}, dtype={self.dtype})"

    def __len__(self) -> int:
        if self.ndim == 0:
            raise TypeError("len() of a 0-d array")
        return self.shape[0]

    def __iter__(self) -> Any:
        return (self[i] for i in range(len(self)))

    def concrete(self) -> np.ndarray:
        """The values, when every element is a constant.

        Raises
        ------
        TraceError
            When an element is a traced symbol.
        """
        if any(isinstance(e, Sym) for e in self.elements.flat):
            raise TraceError(NOT_CONCRETE)
        return np.array(self.elements.tolist(), dtype=self.dtype).reshape(self.shape)

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> np.ndarray:
        values = self.concrete()
        return values if dtype is None else values.astype(dtype)

    def __bool__(self) -> bool:
        return bool(self.concrete())

    def __float__(self) -> float:
        return float(self.concrete())

    def __int__(self) -> int:
        return int(self.concrete())

    def __index__(self) -> int:
        return int(self.concrete())

    def __getitem__(self, key: Any) -> SymbolicArray:
        return self.space.index(self, key)

    def __setitem__(self, key: Any, value: Any) -> None:
        raise TypeError("traced arrays are immutable (as JAX's); use where() or stack()")

    # arithmetic: the operand order is the primitive's (``2 * x`` is ``mul(2, x)``)
    def __add__(self, other: Any) -> SymbolicArray:
        return self.space.add(self, other)

    def __radd__(self, other: Any) -> SymbolicArray:
        return self.space.add(other, self)

    def __sub__(self, other: Any) -> SymbolicArray:
        return self.space.subtract(self, other)

    def __rsub__(self, other: Any) -> SymbolicArray:
        return self.space.subtract(other, self)

    def __mul__(self, other: Any) -> SymbolicArray:
        return self.space.multiply(self, other)

    def __rmul__(self, other: Any) -> SymbolicArray:
        return self.space.multiply(other, self)

    def __truediv__(self, other: Any) -> SymbolicArray:
        return self.space.divide(self, other)

    def __rtruediv__(self, other: Any) -> SymbolicArray:
        return self.space.divide(other, self)

    def __pow__(self, other: Any) -> SymbolicArray:
        return self.space.pow(self, other)

    def __rpow__(self, other: Any) -> SymbolicArray:
        return self.space.pow(other, self)

    def __neg__(self) -> SymbolicArray:
        return self.space.negative(self)

    def __pos__(self) -> SymbolicArray:
        return self

    def __abs__(self) -> SymbolicArray:
        return self.space.abs(self)

    def __invert__(self) -> SymbolicArray:
        return self.space.logical_not(self)

    def __and__(self, other: Any) -> SymbolicArray:
        return self.space.logical_and(self, other)

    def __rand__(self, other: Any) -> SymbolicArray:
        return self.space.logical_and(other, self)

    def __or__(self, other: Any) -> SymbolicArray:
        return self.space.logical_or(self, other)

    def __ror__(self, other: Any) -> SymbolicArray:
        return self.space.logical_or(other, self)

    def __xor__(self, other: Any) -> SymbolicArray:
        return self.space.logical_xor(self, other)

    def __rxor__(self, other: Any) -> SymbolicArray:
        return self.space.logical_xor(other, self)

    def __eq__(self, other: Any) -> SymbolicArray:  # type: ignore[override]
        return self.space.equal(self, other)

    def __ne__(self, other: Any) -> SymbolicArray:  # type: ignore[override]
        return self.space.not_equal(self, other)

    def __lt__(self, other: Any) -> SymbolicArray:
        return self.space.less(self, other)

    def __le__(self, other: Any) -> SymbolicArray:
        return self.space.less_equal(self, other)

    def __gt__(self, other: Any) -> SymbolicArray:
        return self.space.greater(self, other)

    def __ge__(self, other: Any) -> SymbolicArray:
        return self.space.greater_equal(self, other)

    __hash__ = None  # type: ignore[assignment]

    def __matmul__(self, other: Any) -> SymbolicArray:
        return self.space.matmul(self, other)

    def __mod__(self, other: Any) -> SymbolicArray:
        return self.space.remainder(self, other)

    def __floordiv__(self, other: Any) -> SymbolicArray:
        return self.space.floor_divide(self, other)


_FLOAT_UNARY = {
    "abs": "abs", "negative": "neg", "sign": "sign", "floor": "floor", "ceil": "ceil",
    "sqrt": "sqrt", "exp": "exp", "log": "log",
    "log1p": "log1p", "expm1": "expm1", "sin": "sin", "cos": "cos", "tan": "tan",
    "asin": "asin", "acos": "acos", "atan": "atan", "sinh": "sinh", "cosh": "cosh",
    "tanh": "tanh",
}  # fmt: skip
"""Array-API unary functions and the primitive (:data:`~brdfkit.compiled.scalar_code.UNARY`)
each one is; those that keep integers (abs, negative, sign) keep their dtype."""

_KEEPS_INTEGERS = {"abs", "negative", "sign"}

_BINARY_FUNCTIONS = {
    "add": "add", "subtract": "sub", "multiply": "mul", "maximum": "max", "minimum": "min",
    "atan2": "atan2", "equal": "eq", "not_equal": "ne",
    "less": "lt", "less_equal": "le", "greater": "gt", "greater_equal": "ge",
    "logical_and": "and", "logical_or": "or", "logical_xor": "xor",
}  # fmt: skip
"""Array-API binary functions and their primitives
(:data:`~brdfkit.compiled.scalar_code.BINARY`)."""

_COMPARISONS = {"eq", "ne", "lt", "le", "gt", "ge"}
_LOGICAL = {"and", "or", "xor"}
_FLOAT_ONLY = {"atan2"}

_SPECIAL = {"erf": "erf", "gammaln": "lgamma"}
"""Special functions (:func:`brdfkit._array.erf`, ``log_gamma``) by their :mod:`scipy.special`
names (which fold constants): ``math``'s in the kernel."""


class SymbolicNamespace:
    """The array-API namespace of one trace: its :class:`SymbolicArray` operations write
    scalar code through ``emitter``. ``dtype`` is the trace's float dtype: a float32 trace
    computes every float and integer in 32 bits (JAX's rule without 64-bit mode)."""

    bool = np.bool_
    int8, int16, int32, int64 = np.int8, np.int16, np.int32, np.int64
    uint8, uint16, uint32, uint64 = np.uint8, np.uint16, np.uint32, np.uint64
    float32, float64 = np.float32, np.float64
    e, pi, inf, nan, newaxis = math.e, math.pi, math.inf, math.nan, None

    __name__ = __name__  # a namespace's module name, which array_api_compat reads

    def __init__(self, emitter: Emitter, dtype: Any) -> None:
        self.emitter = emitter
        self.wide = np.dtype(dtype) == np.float64
        self.default_float = np.dtype(np.float64 if self.wide else np.float32)
        self.default_int = np.dtype(np.int64 if self.wide else np.int32)

    def __getattr__(self, name: str) -> Any:
        if not name.startswith("_") and hasattr(NUMPY_NAMESPACE, name):

            def unsupported(*args: Any, **kwargs: Any) -> Any:
                raise ValueError(f"the array function {name!r} is not supported by "
                                 f"brdfkit.compiled; {UNSUPPORTED}")  # fmt: skip

            return unsupported
        raise AttributeError(f"the traced array namespace has no {name!r}")

    # ---------------------------------------------------------------- dtypes
    def canonical(self, dtype: Any) -> np.dtype:
        """``dtype`` as the trace computes it (64-bit types in 32 bits in a float32 trace)."""
        dtype = np.dtype(dtype)
        if not self.wide and dtype.itemsize == 8 and dtype.kind in "iuf":
            return np.dtype(f"{dtype.kind}4")
        return dtype

    def _promote(self, values: Sequence[Any]) -> tuple[np.dtype, builtins.bool]:
        """The dtype of an operation on ``values`` and whether it is weak (JAX's rules:
        floats win over integers, Python scalars take the arrays' dtype)."""
        strong, weak_kinds = [], []
        for v in values:
            if isinstance(v, SymbolicArray):
                (weak_kinds.append(v.dtype.kind) if v.weak else strong.append(v.dtype))
            elif isinstance(v, np.ndarray | np.generic):
                strong.append(self.canonical(v.dtype))
            else:
                weak_kinds.append(np.asarray(v).dtype.kind)
        rank = {"b": 0, "u": 1, "i": 1, "f": 2, "c": 3}
        weak_rank = max((rank[k] for k in weak_kinds), default=0)
        if strong:
            floats = [d for d in strong if d.kind == "f"]
            dtype = np.result_type(*(floats or strong))
            if rank[dtype.kind] < weak_rank:
                dtype = self.default_float if weak_rank == 2 else self.default_int
            return self.canonical(dtype), False
        defaults = {0: np.dtype(np.bool_), 1: self.default_int, 2: self.default_float}
        return defaults[weak_rank], True

    def result_type(self, *arrays_and_dtypes: Any) -> np.dtype:
        values = [
            np.empty((), self.canonical(v)) if isinstance(v, type | np.dtype) else v
            for v in arrays_and_dtypes
        ]
        return self._promote(values)[0]

    def isdtype(self, dtype: Any, kind: Any) -> builtins.bool:
        return NUMPY_NAMESPACE.isdtype(np.dtype(dtype), kind)

    def finfo(self, dtype: Any) -> Any:
        arrays = SymbolicArray | np.ndarray | np.generic
        return np.finfo(self.canonical(dtype.dtype if isinstance(dtype, arrays) else dtype))

    # ---------------------------------------------------------------- arrays
    def _wrap(self, elements: np.ndarray, dtype: Any, weak: builtins.bool = False) -> SymbolicArray:
        return SymbolicArray(self, elements, dtype, weak)

    def lift(self, value: Any, dtype: Any) -> SymbolicArray:
        """``value`` (a traced array, NumPy array or Python scalar) as an array of ``dtype``."""
        dtype = np.dtype(dtype)
        if isinstance(value, SymbolicArray):
            if value.dtype == dtype:
                return value
            return self._wrap(convert(self.emitter, value.elements, dtype), dtype)
        if isinstance(value, list | tuple) and any(isinstance(v, SymbolicArray) for v in value):
            return self.stack([self.lift(v, dtype) for v in value])
        return self._wrap(constant_elements(np.asarray(value, dtype=dtype)), dtype)

    def symbols(self, shape: tuple[int, ...], dtype: Any, names: Sequence[str]) -> SymbolicArray:
        """An array of ``shape`` whose elements are the symbols ``names`` (in C order)."""
        elements = np.empty(shape, dtype=object)
        for k, name in enumerate(names):
            elements.flat[k] = Sym(name, np.dtype(dtype))
        return self._wrap(elements, dtype)

    def asarray(
        self, obj: Any, /, *, dtype: Any = None, device: Any = None, copy: Any = None
    ) -> SymbolicArray:
        if dtype is not None:
            return self.lift(obj, self.canonical(dtype))
        if isinstance(obj, SymbolicArray):
            return obj
        if isinstance(obj, list | tuple) and any(isinstance(v, SymbolicArray) for v in obj):
            return self.stack(list(obj))
        inferred, weak = self._promote([obj])
        if isinstance(obj, np.ndarray | np.generic):
            inferred = self.canonical(np.asarray(obj).dtype)
        array = self.lift(obj, inferred)
        array.weak = weak and not isinstance(obj, np.ndarray | np.generic | list | tuple)
        return array

    def astype(
        self, x: SymbolicArray, dtype: Any, /, *, copy: builtins.bool = True, device: Any = None
    ) -> SymbolicArray:
        return self.lift(x, self.canonical(dtype))

    def _filled(self, shape: Any, value: Any, dtype: Any) -> SymbolicArray:
        shape = (shape,) if isinstance(shape, int) else tuple(shape)
        dtype = self._promote([value])[0] if dtype is None else self.canonical(dtype)
        return self.lift(np.full(shape, value, dtype=dtype), dtype)

    def zeros(self, shape: Any, *, dtype: Any = None, device: Any = None) -> SymbolicArray:
        return self._filled(shape, 0.0, dtype or self.default_float)

    def ones(self, shape: Any, *, dtype: Any = None, device: Any = None) -> SymbolicArray:
        return self._filled(shape, 1.0, dtype or self.default_float)

    def full(
        self, shape: Any, fill_value: Any, *, dtype: Any = None, device: Any = None
    ) -> SymbolicArray:
        return self._filled(shape, fill_value, dtype)

    def zeros_like(
        self, x: SymbolicArray, /, *, dtype: Any = None, device: Any = None
    ) -> SymbolicArray:
        return self._filled(x.shape, 0, dtype or x.dtype)

    def ones_like(
        self, x: SymbolicArray, /, *, dtype: Any = None, device: Any = None
    ) -> SymbolicArray:
        return self._filled(x.shape, 1, dtype or x.dtype)

    def full_like(
        self, x: SymbolicArray, /, fill_value: Any, *, dtype: Any = None, device: Any = None
    ) -> SymbolicArray:
        return self._filled(x.shape, fill_value, dtype or x.dtype)

    # ---------------------------------------------------------------- elementwise
    def _unary(
        self, primitive: str, x: Any, keeps_integers: builtins.bool = False
    ) -> SymbolicArray:
        x = self.asarray(x)
        dtype = x.dtype if keeps_integers or x.dtype.kind == "f" else self.default_float
        x = self.lift(x, dtype)
        if primitive in ("sin", "cos") and dtype == np.float32:
            template = f"_{primitive}32({{0}})"
            fold = UNARY[primitive][0]
            out = elementwise(self.emitter, fold, template, [x.elements], dtype)
            return self._wrap(out, dtype, x.weak)
        out = elementwise(self.emitter, *UNARY[primitive], [x.elements], dtype)
        return self._wrap(out, dtype, x.weak)

    def _binary(self, primitive: str, x: Any, y: Any) -> SymbolicArray:
        dtype, weak = self._promote([x, y])
        if primitive in _LOGICAL:
            dtype = np.dtype(np.bool_)
        elif primitive in _FLOAT_ONLY and dtype.kind != "f":
            dtype = self.default_float
        a, b = self.lift(x, dtype), self.lift(y, dtype)
        out_dtype = np.dtype(np.bool_) if primitive in _COMPARISONS else dtype
        elements = [a.elements, b.elements]
        out = elementwise(self.emitter, *binary_rule(primitive, dtype), elements, out_dtype)
        return self._wrap(out, out_dtype, weak and primitive not in _COMPARISONS)

    def divide(self, x: Any, y: Any, /) -> SymbolicArray:
        dtype, weak = self._promote([x, y])
        if dtype.kind != "f":
            dtype = self.default_float
        a, b = self.lift(x, dtype), self.lift(y, dtype)
        return self._wrap(divide(self.emitter, a.elements, b.elements, dtype), dtype, weak)

    def pow(self, x: Any, y: Any, /) -> SymbolicArray:
        if type(y) is int and isinstance(x, SymbolicArray):
            out = integer_power(self.emitter, x.elements, y, x.dtype)
            return self._wrap(out, x.dtype, x.weak)
        return self._binary("pow", x, y)

    def square(self, x: Any, /) -> SymbolicArray:
        x = self.asarray(x)
        out = elementwise(self.emitter, *BINARY["mul"], [x.elements, x.elements], x.dtype)
        return self._wrap(out, x.dtype, x.weak)

    def where(self, condition: Any, x: Any, y: Any, /) -> SymbolicArray:
        dtype, weak = self._promote([x, y])
        condition = self.lift(self.asarray(condition), np.bool_)
        a, b = self.lift(x, dtype), self.lift(y, dtype)
        predicate, if_true, if_false = np.broadcast_arrays(
            condition.elements, a.elements, b.elements
        )
        out = np.empty(predicate.shape, dtype=object)
        for index in np.ndindex(out.shape):
            cases = [if_false[index], if_true[index]]
            out[index] = select(self.emitter, predicate[index], cases, dtype)
        return self._wrap(out, dtype, weak)

    def clip(self, x: Any, /, min: Any = None, max: Any = None) -> SymbolicArray:
        """JAX's ``clip``: ``min(max, max(min, x))``."""
        if min is not None:
            x = self._binary("max", min, x)
        if max is not None:
            x = self._binary("min", max, x)
        return x

    def isfinite(self, x: Any, /) -> SymbolicArray:
        x = self.asarray(x)
        out = elementwise(self.emitter, *UNARY["is_finite"], [x.elements], np.dtype(np.bool_))
        return self._wrap(out, np.bool_)

    def logical_not(self, x: Any, /) -> SymbolicArray:
        x = self.lift(self.asarray(x), np.bool_)
        out = elementwise(self.emitter, *UNARY["not"], [x.elements], x.dtype)
        return self._wrap(out, np.bool_)

    def trunc(self, x: Any, /) -> SymbolicArray:
        """JAX's ``trunc``: ``where(x < 0, ceil(x), floor(x))``."""
        return self.where(self.less(x, 0), self.ceil(x), self.floor(x))

    def erf(self, x: Any, /) -> SymbolicArray:
        return self._special("erf", x)

    def gammaln(self, x: Any, /) -> SymbolicArray:
        return self._special("gammaln", x)

    def _special(self, name: str, x: Any) -> SymbolicArray:
        from scipy import special  # only where a trace meets one (its import costs ~0.25 s)

        x = self.asarray(x)
        fold = getattr(special, name)
        out = elementwise(
            self.emitter, fold, f"math.{_SPECIAL[name]}({{0}})", [x.elements], x.dtype
        )
        return self._wrap(out, x.dtype, x.weak)

    def erfinv(self, x: Any, /) -> SymbolicArray:
        from scipy import special

        x = self.asarray(x)
        template = f"_erfinv{8 * x.dtype.itemsize}({{0}})"
        out = elementwise(self.emitter, special.erfinv, template, [x.elements], x.dtype)
        return self._wrap(out, x.dtype, x.weak)

    # ---------------------------------------------------------------- reductions
    def _reduction(
        self, op: str, x: Any, axis: Any, keepdims: builtins.bool, dtype: Any
    ) -> SymbolicArray:
        x = self.lift(self.asarray(x), dtype)
        axes = _axes(axis, x.ndim)
        out = reduce(self.emitter, x.elements, axes, op, dtype)
        if keepdims:
            out = np.expand_dims(out, axes)
        return self._wrap(out, dtype)

    def sum(
        self, x: Any, /, *, axis: Any = None, dtype: Any = None, keepdims: builtins.bool = False
    ) -> SymbolicArray:
        x = self.asarray(x)
        if dtype is None:
            dtype = self.default_int if x.dtype.kind == "b" else x.dtype
        return self._reduction("add", x, axis, keepdims, self.canonical(dtype))

    def max(self, x: Any, /, *, axis: Any = None, keepdims: builtins.bool = False) -> SymbolicArray:
        x = self.asarray(x)
        return self._reduction("max", x, axis, keepdims, x.dtype)

    def min(self, x: Any, /, *, axis: Any = None, keepdims: builtins.bool = False) -> SymbolicArray:
        x = self.asarray(x)
        return self._reduction("min", x, axis, keepdims, x.dtype)

    def all(self, x: Any, /, *, axis: Any = None, keepdims: builtins.bool = False) -> SymbolicArray:
        return self._reduction("and", self._truth(x), axis, keepdims, np.dtype(np.bool_))

    def any(self, x: Any, /, *, axis: Any = None, keepdims: builtins.bool = False) -> SymbolicArray:
        return self._reduction("or", self._truth(x), axis, keepdims, np.dtype(np.bool_))

    def _truth(self, x: Any) -> SymbolicArray:
        x = self.asarray(x)
        return x if x.dtype.kind == "b" else self.not_equal(x, 0)

    def mean(
        self, x: Any, /, *, axis: Any = None, keepdims: builtins.bool = False
    ) -> SymbolicArray:
        x = self.asarray(x)
        dtype = x.dtype if x.dtype.kind == "f" else self.default_float
        total = self.sum(x, axis=axis, dtype=dtype, keepdims=keepdims)
        count = math.prod(x.shape[a] for a in _axes(axis, x.ndim))
        return self.divide(total, self.asarray(count, dtype=dtype))

    # ---------------------------------------------------------------- shapes
    def reshape(self, x: SymbolicArray, /, shape: Any, *, copy: Any = None) -> SymbolicArray:
        return self._wrap(x.elements.reshape(shape), x.dtype, x.weak)

    def permute_dims(self, x: SymbolicArray, /, axes: Any) -> SymbolicArray:
        return self._wrap(np.transpose(x.elements, axes), x.dtype, x.weak)

    def broadcast_to(self, x: Any, /, shape: Any) -> SymbolicArray:
        x = self.asarray(x)
        return self._wrap(np.broadcast_to(x.elements, tuple(shape)), x.dtype, x.weak)

    def broadcast_arrays(self, *arrays: Any) -> list[SymbolicArray]:
        lifted = [self.asarray(a) for a in arrays]
        shape = np.broadcast_shapes(*(a.shape for a in lifted))
        return [self.broadcast_to(a, shape) for a in lifted]

    def broadcast_shapes(self, *shapes: tuple[int, ...]) -> tuple[int, ...]:
        return tuple(np.broadcast_shapes(*shapes))

    def stack(self, arrays: Sequence[Any], /, *, axis: int = 0) -> SymbolicArray:
        dtype, weak = self._promote(arrays)
        lifted = [self.lift(a, dtype).elements for a in arrays]
        return self._wrap(np.stack(np.broadcast_arrays(*lifted), axis=axis), dtype, weak)

    def concat(self, arrays: Sequence[Any], /, *, axis: int | None = 0) -> SymbolicArray:
        dtype, weak = self._promote(arrays)
        lifted = [self.lift(a, dtype).elements for a in arrays]
        if axis is None:
            lifted = [e.reshape(-1) for e in lifted]
        return self._wrap(np.concatenate(lifted, axis=axis or 0), dtype, weak)

    def index(self, x: SymbolicArray, key: Any) -> SymbolicArray:
        """``x[key]`` for indices known at trace time (integers, slices, ``None``, ``...``,
        constant index arrays).

        Raises
        ------
        ValueError
            For an index computed from traced values (a gather).
        """
        return self._wrap(x.elements[_static_key(key)], x.dtype, x.weak)

    def take(self, x: SymbolicArray, indices: Any, /, *, axis: int | None = None) -> SymbolicArray:
        indices = _static_key(indices)
        elements = x.elements.reshape(-1) if axis is None else x.elements
        return self._wrap(np.take(elements, indices, axis=axis or 0), x.dtype, x.weak)


def _static_key(key: Any) -> Any:
    """An index with its traced parts (constant ones) as NumPy values."""
    if isinstance(key, tuple):
        return tuple(_static_key(k) for k in key)
    if isinstance(key, SymbolicArray):
        try:
            return key.concrete()
        except TraceError:
            raise ValueError(
                f"indexing by traced values (a gather) is not supported by brdfkit.compiled; "
                f"{UNSUPPORTED}"
            ) from None
    return key


def _axes(axis: Any, ndim: int) -> tuple[int, ...]:
    if axis is None:
        return tuple(range(ndim))
    axes = (axis,) if isinstance(axis, int) else tuple(axis)
    return tuple(sorted(a % ndim for a in axes))


def _add_functions() -> None:
    """The namespace's elementwise functions, from the tables above."""
    for name, primitive in _FLOAT_UNARY.items():

        def unary(
            self: SymbolicNamespace, x: Any, /, _p: str = primitive, name_: str = name
        ) -> SymbolicArray:
            return self._unary(_p, x, keeps_integers=name_ in _KEEPS_INTEGERS)

        unary.__name__ = name
        setattr(SymbolicNamespace, name, unary)
    for name, primitive in _BINARY_FUNCTIONS.items():

        def binary(
            self: SymbolicNamespace, x: Any, y: Any, /, _p: str = primitive
        ) -> SymbolicArray:
            return self._binary(_p, x, y)

        binary.__name__ = name
        setattr(SymbolicNamespace, name, binary)


_add_functions()


def trace(
    fn: Callable[..., Any],
    dtype: Any,
    shapes: Sequence[tuple[int, ...]],
    names: Sequence[Sequence[str]] | None = None,
    uniform: Sequence[str] = (),
) -> tuple[Emitter, list[SymbolicArray]]:
    """Run ``fn`` once on symbolic arrays of ``shapes`` and ``dtype`` (the trace's float
    dtype, :class:`SymbolicNamespace`), their symbols named ``names`` (by default
    ``x{argument}_{element}``, in C order), those in ``uniform`` the same for the whole batch
    (parameters); returns the emitter holding the scalar code and ``fn``'s outputs (one array
    or a tuple of them) as a list.

    Raises
    ------
    TraceError
        When ``fn`` needs a traced value (Python control flow on array values).
    ValueError
        When ``fn`` uses an array function or an index the trace does not support.
    """
    em = Emitter()
    em.uniform.update(uniform)
    space = SymbolicNamespace(em, dtype)
    if names is None:
        names = [[f"x{j}_{c}" for c in range(math.prod(s))] for j, s in enumerate(shapes)]
    args = [space.symbols(tuple(shape), dtype, n) for shape, n in zip(shapes, names, strict=True)]
    out = fn(*args)
    outs = list(out) if isinstance(out, tuple | list) else [out]
    return em, [space.asarray(o) for o in outs]


__all__ = [
    "NOT_CONCRETE",
    "UNSUPPORTED",
    "SymbolicArray",
    "SymbolicNamespace",
    "TraceError",
    "trace",
]
