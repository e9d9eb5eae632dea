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

Parameter names are the model's dataclass fields, or the aliases in its ``spec_aliases``
(``lambertian(albedo=0.8)`` sets the field ``rho``).
    number := ["-"] (int | float)

``+`` builds :class:`~brdfkit.brdf.base.Sum`, ``*`` builds :class:`~brdfkit.brdf.base.Scaled`.
The string is read with :func:`ast.parse` and only the node types above are interpreted — it is
never passed to :func:`eval`, so a spec cannot run code. :meth:`BRDF.to_spec` writes specs that
this parser reads back.

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
from typing import Any

import numpy as np

from brdfkit.brdf.base import BRDF, MODELS, Scaled

Value = float | int | str | bool | None | list[float]
"""A parameter value a spec may hold."""


def parse(spec: str) -> BRDF:
    """The BRDF that the spec string ``spec`` describes.

    Parameters
    ----------
    spec : an expression such as ``"lambertian(albedo=[0.8, 0.4, 0.2]) + ggx(alpha=0.2)"``
        (see the module docstring for the grammar).

    Returns
    -------
    BRDF
        A registered model, a :class:`~brdfkit.brdf.base.Sum` (``a + b``) or a
        :class:`~brdfkit.brdf.base.Scaled` (``k * a``).

    Raises
    ------
    ValueError
        On a syntax error (quoting the spec), an unknown model (listing the known ones), an
        unknown parameter (naming the model and listing its parameters), a construct outside
        the grammar, or a parameter value that the model rejects.

    References
    ----------
    .. [1] Python language reference, "The ast module".
    """
    if not isinstance(spec, str):
        raise ValueError(f"spec must be a string; got {type(spec).__name__} {spec!r}")
    import brdfkit.brdf  # noqa: F401  (registers every model)

    try:
        tree = ast.parse(spec.strip(), mode="eval")
    except SyntaxError as error:
        raise ValueError(f"spec {spec!r} is not a valid model expression: {error.msg}") from None
    result = _node(tree.body, spec)
    if not isinstance(result, BRDF):
        raise ValueError(f"spec {spec!r} is a value ({result!r}), not a model expression")
    return result


def _node(node: ast.expr, spec: str) -> BRDF | Value:
    """Interpret one expression node: a model (BRDF) or a literal value."""
    if isinstance(node, ast.Name):
        return _model(node.id, [], spec, node)
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name):
            raise _unsupported(node.func, spec, "a model name before '('")
        return _model(node.func.id, node.keywords, spec, node, positional=len(node.args))
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
        left, right = _node(node.left, spec), _node(node.right, spec)
        if not (isinstance(left, BRDF) and isinstance(right, BRDF)):
            raise _unsupported(node, spec, "'+' between two models")
        return left + right
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
        left, right = _node(node.left, spec), _node(node.right, spec)
        if isinstance(left, BRDF) and isinstance(right, BRDF):
            raise _unsupported(node, spec, "'*' between a number (or list) and a model")
        if isinstance(left, BRDF):
            return Scaled(_factor(right, node, spec), left)
        if isinstance(right, BRDF):
            return Scaled(_factor(left, node, spec), right)
        return np.multiply(_factor(left, node, spec), _factor(right, node, spec)).tolist()
    return _literal(node, spec)


def _literal(node: ast.expr, spec: str) -> Value:
    """A parameter value: a number (with optional minus), string, bool, None or number list."""
    if isinstance(node, ast.Constant) and (
        node.value is None or isinstance(node.value, str | bool | int | float)
    ):
        return node.value
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
        inner = _literal(node.operand, spec)
        if isinstance(inner, bool) or not isinstance(inner, int | float):
            raise _unsupported(node, spec, "a sign before a number")
        return -inner if isinstance(node.op, ast.USub) else inner
    if isinstance(node, ast.List | ast.Tuple):
        items = [_literal(item, spec) for item in node.elts]
        if not items or any(isinstance(x, bool) or not isinstance(x, int | float) for x in items):
            raise _unsupported(node, spec, "a non-empty list of numbers")
        return items
    raise _unsupported(node, spec, "a model, a number, a string or a list of numbers")


def _factor(value: BRDF | Value, node: ast.expr, spec: str) -> float | list[float]:
    """A scale factor: a number or a list of numbers (one per channel)."""
    if isinstance(value, bool) or not isinstance(value, int | float | list):
        raise _unsupported(node, spec, "'*' between a number (or list) and a model")
    return value


def _model(
    name: str, keywords: list[ast.keyword], spec: str, node: ast.expr, positional: int = 0
) -> BRDF:
    """Instantiate the registered model ``name`` with the keyword arguments of the call."""
    if name not in MODELS:
        close = difflib.get_close_matches(name, MODELS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        known = ", ".join(sorted(MODELS))
        raise ValueError(f"unknown model {name!r} in spec {spec!r}{hint}; known models: {known}")
    cls = MODELS[name]
    fields = [f.name for f in dataclasses.fields(cls) if f.init]  # type: ignore[arg-type]
    if positional:
        raise ValueError(
            f"model {name!r} in spec {spec!r} takes parameters by name ({', '.join(fields)}); "
            f"got {positional} positional argument(s)"
        )
    kwargs: dict[str, Any] = {}
    for keyword in keywords:
        if keyword.arg is None:
            raise _unsupported(node, spec, "parameters given as name=value")
        field = cls.spec_aliases.get(keyword.arg, keyword.arg)
        if field not in fields:
            aliases = {v: k for k, v in cls.spec_aliases.items()}
            listed = ", ".join(f"{f} (or {aliases[f]})" if f in aliases else f for f in fields)
            raise ValueError(
                f"model {name!r} has no parameter {keyword.arg!r} (in spec {spec!r}); "
                f"its parameters are: {listed or '(none)'}"
            )
        if field in kwargs:
            raise ValueError(
                f"parameter {field!r} of model {name!r} is given twice in spec {spec!r}"
            )
        kwargs[field] = _literal(keyword.value, spec)
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name}: {error}") from error


def _unsupported(node: ast.AST, spec: str, expected: str) -> ValueError:
    """The error for a construct outside the spec grammar, quoting the offending text."""
    text = ast.get_source_segment(spec.strip(), node) or type(node).__name__
    return ValueError(f"spec {spec!r}: {text!r} is not allowed here; expected {expected}")


__all__ = ["parse"]
