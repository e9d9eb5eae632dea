"""Typed GLSL values over arrays: scalars and vectors as tuples of per-direction components.

A :class:`Value` is a GLSL type and its components: one for ``float``, ``int`` and ``bool``,
two to four for ``vec2``…``vec4``. A float component is an array of the evaluation's namespace
and dtype (0-d for a uniform quantity, the batch shape for a per-direction one), an ``int`` a
Python ``int`` (loop counters, literals) or an array, a ``bool`` a Python ``bool`` (a uniform
condition, so that only the branch taken runs) or a boolean array. Arithmetic follows the
OpenGL Shading Language 4.10, §5.9: component-wise, a scalar widened to a vector's size,
``int`` converted implicitly to ``float`` (§4.1.10), integer division truncating.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit._array import constant, is_abstract, namespace

__all__ = ["SIZES", "Arithmetic", "Value", "concrete"]

SIZES = {"bool": 1, "int": 1, "float": 1, "vec2": 2, "vec3": 3, "vec4": 4}
"""The number of components of each type."""


@dataclass(frozen=True, eq=False)
class Value:
    """A GLSL value: its ``type`` and its ``parts`` (one per component)."""

    type: str
    parts: tuple[Any, ...]

    @property
    def size(self) -> int:
        return len(self.parts)

    @property
    def is_vector(self) -> bool:
        return self.type.startswith("vec")


def vector_type(size: int) -> str:
    """``"float"`` for 1 component, else ``"vecN"``."""
    return "float" if size == 1 else f"vec{size}"


def concrete(condition: Any) -> Any:
    """A uniform condition as a Python ``bool`` (so that only the branch taken runs); a
    per-direction one (or one under a JAX trace) as it is."""
    if isinstance(condition, bool | np.bool_):
        return bool(condition)
    if getattr(condition, "ndim", None) == 0 and not is_abstract(condition):
        return bool(condition)
    return condition


class Arithmetic:
    """The operations on values in the namespace and dtype of ``like`` (an array)."""

    def __init__(self, like: Any, error: Callable[[int, str], Exception]) -> None:
        self.like = like
        self.xp = namespace(like)
        self.error = error

    # -- conversions ------------------------------------------------------------------------
    def number(self, value: float) -> Any:
        """A 0-d float array holding ``value``."""
        return constant(float(value), self.like)

    def floats(self, value: Value, line: int) -> tuple[Any, ...]:
        """The components of a numeric value as floats (``int`` converted, §4.1.10)."""
        if value.type == "bool":
            raise self.error(line, "a bool where a number is needed (write float(b))")
        if value.type != "int":
            return value.parts
        return tuple(self.number(p) if isinstance(p, int) else self.cast(p) for p in value.parts)

    def cast(self, part: Any) -> Any:
        return self.xp.astype(part, self.like.dtype)

    def convert(self, value: Value, type_: str, line: int, what: str) -> Value:
        """``value`` as ``type_`` where GLSL converts implicitly (``int`` to ``float``, an int
        vector nowhere else), else refused naming ``what``."""
        if value.type == type_:
            return value
        if type_ == "float" and value.type == "int":
            return Value("float", self.floats(value, line))
        raise self.error(line, f"{what} is {value.type}, expected {type_}")

    def widen(self, a: Value, b: Value, line: int, operator: str) -> tuple[tuple, tuple, int]:
        """The float components of ``a`` and ``b`` with a scalar repeated to the other's size."""
        pa, pb = self.floats(a, line), self.floats(b, line)
        if len(pa) != len(pb) and 1 not in (len(pa), len(pb)):
            raise self.error(line, f"'{operator}' between {a.type} and {b.type}")
        size = max(len(pa), len(pb))
        return pa * (size // len(pa)), pb * (size // len(pb)), size

    # -- operators --------------------------------------------------------------------------
    def arithmetic(self, operator: str, a: Value, b: Value, line: int) -> Value:
        """``a OP b`` for ``+ - * / %`` (§5.9)."""
        if a.type == "int" and b.type == "int":
            return Value("int", (self.integer(operator, a.parts[0], b.parts[0], line),))
        if operator == "%":
            raise self.error(line, f"'%' on {a.type} and {b.type} (use mod())")
        pa, pb, size = self.widen(a, b, line, operator)
        apply = _OPERATORS[operator]
        return Value(vector_type(size), tuple(apply(x, y) for x, y in zip(pa, pb, strict=True)))

    def integer(self, operator: str, a: Any, b: Any, line: int) -> Any:
        if isinstance(a, int) and isinstance(b, int):
            if operator in ("/", "%") and b == 0:
                raise self.error(line, "integer division by zero")
            if operator == "/":
                return abs(a) // abs(b) * (1 if (a < 0) == (b < 0) else -1)
            if operator == "%":
                return a - b * int(a / b)
            return _OPERATORS[operator](a, b)
        xp = self.xp
        if operator == "/":
            return xp.trunc(a / b)
        if operator == "%":
            return a - b * xp.trunc(a / b)
        return _OPERATORS[operator](a, b)

    def compare(self, operator: str, a: Value, b: Value, line: int) -> Value:
        """``<``, ``>``, ``<=``, ``>=`` on scalars, ``==`` and ``!=`` on any equal types."""
        if operator in ("==", "!="):
            if a.type == "bool" and b.type == "bool":
                pairs = list(zip(a.parts, b.parts, strict=True))
            else:
                if a.size != b.size:
                    raise self.error(line, f"'{operator}' between {a.type} and {b.type}")
                pairs = list(zip(*self.widen(a, b, line, operator)[:2], strict=True))
            equal = self.all_of([x == y for x, y in pairs])
            return Value("bool", (equal if operator == "==" else self.negate(equal),))
        if a.size != 1 or b.size != 1:
            raise self.error(line, f"'{operator}' between {a.type} and {b.type} (not scalars)")
        if a.type == "int" and b.type == "int":
            x, y = a.parts[0], b.parts[0]
        else:
            (x,), (y,), _ = self.widen(a, b, line, operator)
        return Value("bool", (concrete(_COMPARISONS[operator](x, y)),))

    def all_of(self, conditions: list[Any]) -> Any:
        result = concrete(conditions[0])
        for c in conditions[1:]:
            result = self.both(result, concrete(c))
        return result

    # -- masks ------------------------------------------------------------------------------
    def both(self, a: Any, b: Any) -> Any:
        """``a && b`` of Python bools or boolean arrays."""
        if isinstance(a, bool):
            return b if a else False
        if isinstance(b, bool):
            return a if b else False
        return self.xp.logical_and(a, b)

    def either(self, a: Any, b: Any) -> Any:
        """``a || b`` of Python bools or boolean arrays."""
        if isinstance(a, bool):
            return True if a else b
        if isinstance(b, bool):
            return True if b else a
        return self.xp.logical_or(a, b)

    def negate(self, a: Any) -> Any:
        return (not a) if isinstance(a, bool) else self.xp.logical_not(a)

    def differ(self, a: Any, b: Any) -> Any:
        """``a ^^ b``."""
        if isinstance(a, bool) and isinstance(b, bool):
            return a != b
        return self.xp.logical_xor(self.boolean(a), self.boolean(b))

    def boolean(self, part: Any) -> Any:
        return self.xp.asarray(part) if isinstance(part, bool) else part

    def select(self, condition: Any, a: Value, b: Value, line: int) -> Value:
        """``a`` where ``condition`` holds, else ``b`` (component-wise ``where``)."""
        if a.type != b.type:
            if {a.type, b.type} == {"int", "float"}:
                a = self.convert(a, "float", line, "a branch")
                b = self.convert(b, "float", line, "a branch")
            else:
                raise self.error(line, f"branches of types {a.type} and {b.type}")
        if isinstance(condition, bool):
            return a if condition else b
        parts = []
        for x, y in zip(a.parts, b.parts, strict=True):
            if isinstance(x, bool) or isinstance(y, bool):
                x, y = self.boolean(x), self.boolean(y)
            elif isinstance(x, int) or isinstance(y, int):
                x = self.number(x) if isinstance(x, int) else x
                y = self.number(y) if isinstance(y, int) else y
            parts.append(self.xp.where(condition, x, y))
        return Value(a.type, tuple(parts))


_OPERATORS: dict[str, Callable[[Any, Any], Any]] = {
    "+": lambda x, y: x + y,
    "-": lambda x, y: x - y,
    "*": lambda x, y: x * y,
    "/": lambda x, y: x / y,
}
_COMPARISONS: dict[str, Callable[[Any, Any], Any]] = {
    "<": lambda x, y: x < y,
    ">": lambda x, y: x > y,
    "<=": lambda x, y: x <= y,
    ">=": lambda x, y: x >= y,
}
