r"""The model spec language: BRDFs written as short strings, parsed safely.

A spec is a Python-like expression over registered model names::

    ggx(alpha=0.2, material='Au')
    lambertian(albedo=[0.8, 0.4, 0.2]) + blinn_phong(n=80, ks=0.04)
    0.5 * lambertian
    lambertian + cook_torrance          # bare names use the defaults
    0.7 * (lambertian + 0.5 * ggx(alpha=0.1))

Grammar (everything else is rejected)::

    spec   := term | spec "+" spec | factor "*" spec | spec "*" factor | "(" spec ")"
    term   := NAME | NAME "(" [NAME "=" value {"," NAME "=" value}] ")"
    factor := number | "[" number {"," number} "]" | factor "*" factor
    value  := number | string | True | False | None | "[" number {"," number} "]"
    number := ["-"] (int | float)

Parameter names are the model's dataclass fields, or the aliases in its ``spec_aliases``
(``lambertian(albedo=0.8)`` sets the field ``rho``).

``+`` builds :class:`~brdfkit.brdf.base.Sum`, ``*`` builds :class:`~brdfkit.brdf.base.Scaled`:
a chain ``a + b + c`` is one sum of three lobes, and a product ``0.5 * model * [1, 0.5, 0.5]``
one scaled model whose factor is the product of the numbers (and lists, per channel). Integers
are read as floats (one too large for a float is infinite, and rejected as a value).
The string is read with :func:`ast.parse` and only the node types above are interpreted — it is
never passed to :func:`eval`, so a spec cannot run code. :meth:`BRDF.to_spec` writes specs that
this parser reads back.

A spec holds at most :data:`~brdfkit.params.MAX_SPEC_LENGTH` characters and a sum or product at most
:data:`MAX_CHAIN` operands (read without recursion, and refused whatever the interpreter's
recursion limit, which IPython, for one, raises); Python's parser refuses expressions nested
more than about 200 parentheses deep, and so does :func:`parse`.

Errors: a spec outside the grammar (a syntax error, an unknown model or parameter, a construct
not listed above, too long or too deeply nested) raises :class:`~brdfkit.errors.SpecError`; a
value that the model rejects raises :class:`~brdfkit.errors.ParameterError`, prefixed with the
model's name (``"ggx: alpha must be in [0.0001, 10.0]; got 1e+308"``). Both are ``ValueError``.

References
----------
.. [1] Python language reference, "The ast module", https://docs.python.org/3/library/ast.html
.. [2] W. Jakob et al., Mitsuba 3 plugin dictionaries (the idea of naming a scattering model
       and its parameters as data), https://mitsuba.readthedocs.io
"""

from __future__ import annotations

import ast
import dataclasses
import difflib
import functools
import math
import threading
from typing import Any

import numpy as np

from brdfkit.brdf.base import BRDF, MODELS, Scaled, Sum
from brdfkit.errors import ParameterError, SpecError
from brdfkit.params import MAX_SPEC_LENGTH

Value = float | str | bool | None | list[float]
"""A parameter value a spec may hold."""


MAX_CHAIN = 2000
"""The most operands one sum or product of a spec may chain (``a + b + …``)."""

_QUOTED = 80  # characters of a spec quoted in an error message


_PARSING = threading.Lock()
"""One :func:`ast.parse` at a time: CPython 3.11's is not thread-safe (two threads parsing at
once can raise ``SystemError: AST constructor recursion depth mismatch``), and the explorer's
workers parse specs side by side."""


def parse(spec: str) -> BRDF:
    """The BRDF that the spec string ``spec`` describes.

    Parameters
    ----------
    spec : an expression such as ``"lambertian(albedo=[0.8, 0.4, 0.2]) + ggx(alpha=0.2)"``
        (see the module docstring for the grammar), at most :data:`MAX_SPEC_LENGTH` characters.

    Returns
    -------
    BRDF
        A registered model, a :class:`~brdfkit.brdf.base.Sum` (``a + b``) or a
        :class:`~brdfkit.brdf.base.Scaled` (``k * a``).

    Raises
    ------
    brdfkit.errors.SpecError
        On a spec that is no string or too long, a syntax error (quoting the spec), an unknown
        model (listing the known ones), an unknown parameter (naming the model and listing its
        parameters), a construct outside the grammar, or nesting too deep.
    brdfkit.errors.ParameterError
        On a parameter value that the model rejects (prefixed with the model's name), or a
        factor of ``k * model`` outside its domain.

    References
    ----------
    .. [1] Python language reference, "The ast module".
    """
    if not isinstance(spec, str):
        raise SpecError(f"spec must be a string; got {type(spec).__name__} {_quote(spec)}")
    if len(spec) > MAX_SPEC_LENGTH:
        raise SpecError(
            f"spec {_quote(spec)} holds {len(spec)} characters; at most {MAX_SPEC_LENGTH}"
        )
    text = spec.strip()
    try:
        with _PARSING:
            tree = ast.parse(text, mode="eval")
    except SyntaxError as error:
        raise SpecError(
            f"spec {_quote(spec)} is not a valid model expression: {error.msg}"
        ) from None
    except (RecursionError, MemoryError):
        raise SpecError(f"spec {_quote(spec)} is nested or chained too deeply") from None
    except ValueError as error:  # a character no source text may hold (a lone surrogate)
        raise SpecError(f"spec {_quote(spec)} is not a valid model expression: {error}") from None
    try:
        result = _node(tree.body, text)
    except RecursionError:
        raise SpecError(f"spec {_quote(spec)} is nested too deeply") from None
    if not isinstance(result, BRDF):
        raise SpecError(
            f"spec {_quote(spec)} is a value ({_quote(result)}), not a model expression"
        )
    return result


def _quote(value: Any) -> str:
    """``repr(value)``, shortened to about :data:`_QUOTED` characters."""
    text = repr(value)
    return text if len(text) <= _QUOTED else f"{text[: _QUOTED - 5]}…{text[-4:]}"


def _chain(node: ast.expr, op: type[ast.operator]) -> list[ast.expr]:
    """The operands of nested ``op`` nodes (``a + b + c`` → ``[a, b, c]``), left to right,
    collected without recursion (a long chain is a deep tree)."""
    operands, stack = [], [node]
    while stack:
        item = stack.pop()
        if isinstance(item, ast.BinOp) and isinstance(item.op, op):
            stack += [item.right, item.left]
        else:
            operands.append(item)
        if len(operands) > MAX_CHAIN:
            raise SpecError(f"a sum or product is chained too deeply: at most {MAX_CHAIN} operands")
    return operands


def _node(node: ast.expr, text: str) -> BRDF | Value:
    """Interpret one expression node: a model (BRDF) or a literal value."""
    if isinstance(node, ast.Name):
        return _model(node.id, [], text, node)
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name):
            raise _unsupported(node.func, text, "a model name before '('")
        return _model(node.func.id, node.keywords, text, node, positional=len(node.args))
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
        return _sum(_chain(node, ast.Add), text)
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
        return _product(node, _chain(node, ast.Mult), text)
    return _literal(node, text)


def _sum(operands: list[ast.expr], text: str) -> Sum:
    """The sum of the models ``operands`` (sums among them add their lobes)."""
    lobes: list[BRDF] = []
    for operand in operands:
        term = _node(operand, text)
        if not isinstance(term, BRDF):
            raise _unsupported(operand, text, "'+' between two models")
        lobes += term.lobes if isinstance(term, Sum) else [term]
    return Sum(tuple(lobes))


def _product(node: ast.expr, operands: list[ast.expr], text: str) -> BRDF | Value:
    """A product of numbers and lists with at most one model: the scaled model, or the
    product of the factors."""
    values = [_node(operand, text) for operand in operands]
    models = [value for value in values if isinstance(value, BRDF)]
    if len(models) > 1:
        raise _unsupported(node, text, "'*' between a number (or list) and a model")
    factors = [
        _factor(value, operand, text)
        for value, operand in zip(values, operands, strict=True)
        if not isinstance(value, BRDF)
    ]
    try:
        with np.errstate(over="ignore", under="ignore", invalid="ignore"):
            k = functools.reduce(np.multiply, [np.asarray(f, dtype=np.float64) for f in factors])
    except ValueError:  # lists of different lengths
        lengths = sorted({len(f) for f in factors if isinstance(f, list)})
        raise SpecError(
            f"spec {_quote(text)}: the lists multiplied in {_segment(node, text)} must have one "
            f"length (one factor per channel); got lengths {lengths}"
        ) from None
    return Scaled(k.tolist(), models[0]) if models else k.tolist()


def _literal(node: ast.expr, text: str) -> Value:
    """A parameter value: a number (with signs), string, bool, None or a list of numbers."""
    sign, inner = 1.0, node
    while isinstance(inner, ast.UnaryOp) and isinstance(inner.op, ast.USub | ast.UAdd):
        sign = -sign if isinstance(inner.op, ast.USub) else sign
        inner = inner.operand
    if inner is not node:
        value = _number(inner)
        if value is None:
            raise _unsupported(node, text, "a sign before a number")
        return sign * value
    if isinstance(node, ast.Constant) and (
        node.value is None or isinstance(node.value, str | bool)
    ):
        return node.value
    if _number(node) is not None:
        return _number(node)
    if isinstance(node, ast.List | ast.Tuple):
        items = [_literal(item, text) for item in node.elts]
        if not items or any(isinstance(x, bool) or not isinstance(x, float) for x in items):
            raise _unsupported(node, text, "a non-empty list of numbers")
        return items
    raise _unsupported(node, text, "a model, a number, a string or a list of numbers")


def _number(node: ast.expr) -> float | None:
    """The number a constant node holds, as a float (±inf beyond the floats), or ``None``."""
    if not isinstance(node, ast.Constant) or isinstance(node.value, bool):
        return None
    if isinstance(node.value, float):
        return node.value
    if isinstance(node.value, int):
        try:
            return float(node.value)
        except OverflowError:
            return math.inf
    return None


def _factor(value: BRDF | Value, node: ast.expr, text: str) -> float | list[float]:
    """A scale factor: a number or a list of numbers (one per channel)."""
    if isinstance(value, bool) or not isinstance(value, float | list):
        raise _unsupported(node, text, "'*' between a number (or list) and a model")
    return value


def _model(
    name: str, keywords: list[ast.keyword], text: str, node: ast.expr, positional: int = 0
) -> BRDF:
    """Instantiate the registered model ``name`` with the keyword arguments of the call."""
    if name not in MODELS:
        close = difflib.get_close_matches(name, MODELS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        known = ", ".join(sorted(MODELS))
        raise SpecError(
            f"unknown model {_quote(name)} in spec {_quote(text)}{hint}; known models: {known}"
        )
    cls = MODELS[name]
    fields = [f.name for f in dataclasses.fields(cls) if f.init]  # type: ignore[arg-type]
    if positional:
        raise SpecError(
            f"model {name!r} in spec {_quote(text)} takes parameters by name "
            f"({', '.join(fields)}); got {positional} positional argument(s)"
        )
    kwargs: dict[str, Any] = {}
    for keyword in keywords:
        if keyword.arg is None:
            raise _unsupported(node, text, "parameters given as name=value")
        field = cls.spec_aliases.get(keyword.arg, keyword.arg)
        if field not in fields:
            aliases = {v: k for k, v in cls.spec_aliases.items()}
            listed = ", ".join(f"{f} (or {aliases[f]})" if f in aliases else f for f in fields)
            raise SpecError(
                f"model {name!r} has no parameter {_quote(keyword.arg)} (in spec "
                f"{_quote(text)}); its parameters are: {listed or '(none)'}"
            )
        if field in kwargs:
            raise SpecError(
                f"parameter {field!r} of model {name!r} is given twice in spec {_quote(text)}"
            )
        kwargs[field] = _literal(keyword.value, text)
    try:
        return cls(**kwargs)
    except ParameterError as error:
        raise ParameterError(f"{name}: {error}") from error


def _segment(node: ast.AST, text: str) -> str:
    """The source text of ``node``, quoted and shortened."""
    return _quote(ast.get_source_segment(text, node) or type(node).__name__)


def _unsupported(node: ast.AST, text: str, expected: str) -> SpecError:
    """The error for a construct outside the spec grammar, quoting the offending text."""
    return SpecError(
        f"spec {_quote(text)}: {_segment(node, text)} is not allowed here; expected {expected}"
    )


__all__ = ["MAX_CHAIN", "parse"]
