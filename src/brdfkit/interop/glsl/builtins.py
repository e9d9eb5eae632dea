"""The GLSL built-in functions of the subset, over :class:`~brdfkit.interop.glsl.values.Value`.

Each is the definition of the OpenGL Shading Language 4.10, §8 (angle and trigonometry §8.1,
exponential §8.2, common §8.3, geometric §8.5), computed component-wise in the array namespace
of the evaluation. Where GLSL leaves a result undefined (``pow`` of a negative base, ``acos``
outside [-1, 1], ``normalize`` of a zero vector) the array library's result stands: NaN or ∞,
except ``pow`` of a negative base with a whole exponent, which is finite (GPUs give NaN).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from brdfkit.interop.glsl.values import SIZES, Arithmetic, Value, vector_type

__all__ = ["BUILTINS", "CONSTRUCTORS", "call_builtin", "construct"]

Builtin = Callable[[Arithmetic, list[Value], int], Value]

CONSTRUCTORS = ("float", "int", "bool", "vec2", "vec3", "vec4")
"""The type names that construct a value (§5.4)."""


def _componentwise(function: Callable[..., Any]) -> Builtin:
    """A built-in applying ``function(xp, *components)`` component by component, a scalar
    argument repeated to the vectors' size (``max(v, 0.0)``, ``mix(a, b, t)``)."""

    def builtin(ar: Arithmetic, args: list[Value], line: int) -> Value:
        parts = [ar.floats(a, line) for a in args]
        size = max(len(p) for p in parts)
        if any(len(p) not in (1, size) for p in parts):
            shown = ", ".join(a.type for a in args)
            raise ar.error(line, f"arguments of mismatched sizes ({shown})")
        columns = [p * (size // len(p)) for p in parts]
        out = tuple(function(ar.xp, *c) for c in zip(*columns, strict=True))
        return Value(vector_type(size), out)

    return builtin


def _dot(ar: Arithmetic, a: Value, b: Value, line: int) -> Any:
    pa, pb = ar.floats(a, line), ar.floats(b, line)
    if len(pa) != len(pb):
        raise ar.error(line, f"dot of {a.type} and {b.type}")
    total = pa[0] * pb[0]
    for x, y in zip(pa[1:], pb[1:], strict=True):
        total = total + x * y
    return total


def _geometric(name: str) -> Builtin:
    def builtin(ar: Arithmetic, args: list[Value], line: int) -> Value:
        xp = ar.xp
        if name == "dot":
            return Value("float", (_dot(ar, args[0], args[1], line),))
        if name == "length":
            return Value("float", (xp.sqrt(_dot(ar, args[0], args[0], line)),))
        if name == "distance":
            d = ar.arithmetic("-", args[0], args[1], line)
            return Value("float", (xp.sqrt(_dot(ar, d, d, line)),))
        if name == "normalize":
            inverse = 1 / xp.sqrt(_dot(ar, args[0], args[0], line))
            return Value(args[0].type, tuple(p * inverse for p in ar.floats(args[0], line)))
        if name == "cross":
            if args[0].type != "vec3" or args[1].type != "vec3":
                raise ar.error(line, f"cross of {args[0].type} and {args[1].type}")
            (ax, ay, az), (bx, by, bz) = args[0].parts, args[1].parts
            return Value("vec3", (ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx))
        if name == "reflect":  # I - 2 dot(N, I) N
            i, n = args
            twice = Value("float", (2 * _dot(ar, n, i, line),))
            return ar.arithmetic("-", i, ar.arithmetic("*", twice, n, line), line)
        if name == "faceforward":  # N if dot(Nref, I) < 0 else -N
            n, i, nref = args
            flip = Value("float", (-1.0 * ar.number(1),))
            front = _dot(ar, nref, i, line) < 0
            return ar.select(front, n, ar.arithmetic("*", flip, n, line), line)
        return _refract(ar, args, line)

    return builtin


def _refract(ar: Arithmetic, args: list[Value], line: int) -> Value:
    """refract(I, N, eta) of §8.5: 0 on total internal reflection."""
    i, n, eta = args
    e = ar.floats(eta, line)[0]
    cosine = _dot(ar, n, i, line)
    k = 1 - e * e * (1 - cosine * cosine)
    scale = e * cosine + ar.xp.sqrt(ar.xp.maximum(k, ar.number(0)))
    parts = tuple(
        e * x - scale * y for x, y in zip(ar.floats(i, line), ar.floats(n, line), strict=True)
    )
    zero = Value(i.type, tuple(p * 0 for p in parts))
    return ar.select(k < 0, zero, Value(i.type, parts), line)


def _atan(ar: Arithmetic, args: list[Value], line: int) -> Value:
    if len(args) == 2:
        return _componentwise(lambda xp, y, x: xp.atan2(y, x))(ar, args, line)
    return _componentwise(lambda xp, x: xp.atan(x))(ar, args, line)


def _smoothstep(xp: Any, edge0: Any, edge1: Any, x: Any) -> Any:
    t = xp.clip((x - edge0) / (edge1 - edge0), 0.0, 1.0)
    return t * t * (3 - 2 * t)


_ONE_ARGUMENT: dict[str, Callable[..., Any]] = {
    "radians": lambda xp, x: x * (3.141592653589793 / 180),
    "degrees": lambda xp, x: x * (180 / 3.141592653589793),
    "sin": lambda xp, x: xp.sin(x),
    "cos": lambda xp, x: xp.cos(x),
    "tan": lambda xp, x: xp.tan(x),
    "asin": lambda xp, x: xp.asin(x),
    "acos": lambda xp, x: xp.acos(x),
    "sinh": lambda xp, x: xp.sinh(x),
    "cosh": lambda xp, x: xp.cosh(x),
    "tanh": lambda xp, x: xp.tanh(x),
    "exp": lambda xp, x: xp.exp(x),
    "log": lambda xp, x: xp.log(x),
    "exp2": lambda xp, x: xp.pow(2 + 0 * x, x),
    "log2": lambda xp, x: xp.log2(x),
    "sqrt": lambda xp, x: xp.sqrt(x),
    "inversesqrt": lambda xp, x: 1 / xp.sqrt(x),
    "abs": lambda xp, x: xp.abs(x),
    "sign": lambda xp, x: xp.sign(x),
    "floor": lambda xp, x: xp.floor(x),
    "ceil": lambda xp, x: xp.ceil(x),
    "trunc": lambda xp, x: xp.trunc(x),
    "round": lambda xp, x: xp.round(x),
    "fract": lambda xp, x: x - xp.floor(x),
}
_MORE_ARGUMENTS: dict[str, tuple[int, Callable[..., Any]]] = {
    "pow": (2, lambda xp, x, y: xp.pow(x, y)),
    "mod": (2, lambda xp, x, y: x - y * xp.floor(x / y)),
    "min": (2, lambda xp, x, y: xp.minimum(x, y)),
    "max": (2, lambda xp, x, y: xp.maximum(x, y)),
    "step": (2, lambda xp, edge, x: xp.where(x < edge, 0 * x, 0 * x + 1)),
    "clamp": (3, lambda xp, x, lo, hi: xp.minimum(xp.maximum(x, lo), hi)),
    "mix": (3, lambda xp, x, y, a: x * (1 - a) + y * a),
    "smoothstep": (3, _smoothstep),
}
_GEOMETRIC_ARITY = {
    "dot": 2,
    "length": 1,
    "distance": 2,
    "normalize": 1,
    "cross": 2,
    "reflect": 2,
    "faceforward": 3,
    "refract": 3,
}

BUILTINS: dict[str, tuple[tuple[int, ...], Builtin]] = {
    **{name: ((1,), _componentwise(f)) for name, f in _ONE_ARGUMENT.items()},
    **{name: ((n,), _componentwise(f)) for name, (n, f) in _MORE_ARGUMENTS.items()},
    **{name: ((n,), _geometric(name)) for name, n in _GEOMETRIC_ARITY.items()},
    "atan": ((1, 2), _atan),
}
"""Each built-in by name: the argument counts it takes and the function."""


def call_builtin(ar: Arithmetic, name: str, args: list[Value], line: int) -> Value:
    """The built-in ``name`` applied to ``args``."""
    counts, function = BUILTINS[name]
    if len(args) not in counts:
        expected = " or ".join(map(str, counts))
        raise ar.error(line, f"built-in '{name}' takes {expected} arguments, got {len(args)}")
    return function(ar, args, line)


def construct(ar: Arithmetic, type_: str, args: list[Value], line: int) -> Value:
    """``type_(args…)`` (§5.4.1): a conversion of a scalar, a scalar repeated to a vector, or
    the components of the arguments in order (a longer vector truncated)."""
    if not args:
        raise ar.error(line, f"constructor {type_}() without arguments")
    size = SIZES[type_]
    if size == 1:
        return Value(type_, (_scalar(ar, type_, args[0], line),))
    components = [[_scalar(ar, "float", Value(a.type, (p,)), line) for p in a.parts] for a in args]
    parts = [p for c in components for p in c]
    if len(args) == 1 and len(parts) == 1:
        parts = parts * size
    if len(parts) < size or len(parts) - len(components[-1]) >= size:
        raise ar.error(line, f"constructor {type_} given {len(parts)} components")
    return Value(type_, tuple(parts[:size]))


def _scalar(ar: Arithmetic, type_: str, value: Value, line: int) -> Any:
    """The first component of ``value`` converted to the scalar ``type_``."""
    part = value.parts[0]
    if type_ == "bool":
        if value.type == "bool":
            return part
        return part != 0 if isinstance(part, int) else ar.boolean(part != 0)
    if value.type == "bool":
        if isinstance(part, bool):
            return int(part) if type_ == "int" else ar.number(float(part))
        one = ar.number(1)
        return ar.xp.where(part, one, 0 * one)
    if type_ == "int":
        return part if isinstance(part, int) else ar.xp.trunc(part)
    return ar.floats(Value(value.type, (part,)), line)[0]
